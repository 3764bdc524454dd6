// ---- body_load_reduce.wgsl (CPU twin: body_load_reduce.rs) ----
// One workgroup per body: its markers are the contiguous range load_ranges[g] =
// (first marker, count, body index, _). Each thread sums a strided slice, then the
// workgroup sums the WORKGROUP_SIZE partial sums with a tree reduction (log2 levels,
// no serial accumulation over the whole range). The Kahan compensation of each marker
// is folded in first.
// Needs: prelude, StepParams.

// ---- kernels ----
@group(2) @binding(3) var<storage, read> marker_load: array<vec4<f32>>;
@group(2) @binding(4) var<storage, read> marker_load_c: array<vec4<f32>>;
@group(2) @binding(5) var<storage, read> load_ranges: array<vec4<u32>>;
// Two vec4 per body range: force, moment.
@group(2) @binding(6) var<storage, read_write> body_loads: array<vec4<f32>>;

var<workgroup> partial_force: array<vec3<f32>, WORKGROUP_SIZE>;
var<workgroup> partial_moment: array<vec3<f32>, WORKGROUP_SIZE>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn reduce_body_loads(@builtin(workgroup_id) wid: vec3<u32>,
                     @builtin(local_invocation_index) lid: u32,
                     @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = linear_workgroup(wid, nwg);
    // g is uniform over the workgroup: returning here keeps the barriers uniform.
    if g >= params.n_load_bodies {
        return;
    }
    let range = load_ranges[g];
    var f = vec3<f32>(0.0);
    var m = vec3<f32>(0.0);
    for (var k = lid; k < range.y; k += WORKGROUP_SIZE) {
        let slot = 2u * (range.x + k);
        f += marker_load[slot].xyz - marker_load_c[slot].xyz;
        m += marker_load[slot + 1u].xyz - marker_load_c[slot + 1u].xyz;
    }
    partial_force[lid] = f;
    partial_moment[lid] = m;
    for (var s = WORKGROUP_SIZE / 2u; s > 0u; s = s / 2u) {
        workgroupBarrier();
        if lid < s {
            partial_force[lid] += partial_force[lid + s];
            partial_moment[lid] += partial_moment[lid + s];
        }
    }
    workgroupBarrier();
    if lid == 0u {
        body_loads[2u * g] = vec4<f32>(partial_force[0], 0.0);
        body_loads[2u * g + 1u] = vec4<f32>(partial_moment[0], 0.0);
    }
}
