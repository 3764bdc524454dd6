// ---- neighbour_count.wgsl (CPU side: neighbour_count.rs) ----
// Neighbours inside the support radius of each fluid particle (self excluded); 0 for
// other particles. Diagnostics only (BENCHMARKS.md quotes pair throughput with it).
// Needs: prelude, SPH constants, StepParams, grid_common.

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(3) @binding(3) var<storage, read_write> counts: array<u32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn neighbour_count(@builtin(workgroup_id) wid: vec3<u32>,
                   @builtin(local_invocation_index) lid: u32,
                   @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total {
        return;
    }
    if !is_fluid(id[i]) {
        counts[i] = 0u;
        return;
    }
    let p_i = pos[i].xyz;
    let c_i = cell_coord(p_i);
    var n = 0u;
    for (var dz = -GRID_REACH; dz <= GRID_REACH; dz++) {
        for (var dy = -GRID_REACH; dy <= GRID_REACH; dy++) {
            let rs = row_ranges(c_i, dy, dz);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                let r_ij = pair_vec(p_i, pos[j].xyz);
                if dot(r_ij, r_ij) < SUPPORT_RADIUS2 && j != i {
                    n += 1u;
                }
            }
        }
    }
    counts[i] = n;
}
