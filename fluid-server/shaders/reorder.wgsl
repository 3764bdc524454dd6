// Counting sort, part 4: permutes the registered per-particle buffers, several a pass.
//   gather:    reorder_out[k n + j] = in_k[src_of[j]]   (coalesced writes, cached reads)
// for each member k of the pass; then neighbour_grid.rs copies slice k back over
// buffer k with copy_buffer_to_buffer, so the caller's buffer (and every bind group
// holding it) sees sorted data.
//
// Composed (neighbour_grid.rs, `gather_pass`) after the prelude, `alias Elem =
// vec4<u32>;` or `alias Elem = u32;` (16- or 4-byte elements, moved as raw bits so NaN
// payloads survive) with the members' bindings `reorder_in0`, `reorder_in1`, … at
// 2, 3, …, and grid_common.wgsl (group 1: grid params only); followed by
// `gather_members(j, s)`, one line per member.

@group(0) @binding(0) var<storage, read> reorder_src_of: array<u32>;
@group(0) @binding(1) var<storage, read_write> reorder_out: array<Elem>;

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
    gather_members(j, reorder_src_of[j]);
}
