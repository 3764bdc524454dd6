// Counting sort, part 4: permutes one registered per-particle buffer.
//   gather:    scratch[j] = buffer[src_of[j]]   (coalesced writes, cached reads)
// then neighbour_grid.rs copies the scratch back with copy_buffer_to_buffer, so the
// caller's buffer (and every bind group holding it) sees sorted data.
//
// Composed after the prelude, `alias Elem = vec4<u32>;` or `alias Elem = u32;`
// (16- or 4-byte elements, moved as raw bits so NaN payloads survive) and
// grid_common.wgsl (group 1: grid params only).

@group(0) @binding(0) var<storage, read> reorder_src_of: array<u32>;
@group(0) @binding(1) var<storage, read> reorder_in: array<Elem>;
@group(0) @binding(2) var<storage, read_write> reorder_out: array<Elem>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn gather(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let j = linear_id(wid, lid, nwg);
    if j >= grid.n_particles {
        return;
    }
    reorder_out[j] = reorder_in[reorder_src_of[j]];
}
