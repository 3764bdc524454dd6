// ---- window_stats.wgsl (CPU side and twin: window_stats.rs) ----
// Once per window, the telemetry of the fluid: per workgroup the kinetic energy
// Σ ½ m |u|², the largest |u|² and the largest density error |ρ/(ε ρ0) − 1| of its fluid
// particles (ε the grains' porosity, Robinson eq. 15's intrinsic density; 1 without
// grains), reduced in workgroup memory by a fixed halving tree, so the same particles
// in the same order give the same bits. One vec4 per workgroup; the CPU adds the
// workgroups' energies in f64.
// Needs: prelude, SPH constants, StepParams, porosity (porosity.rs).

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// (Σ ½ m |u|², max |u|², max |ρ/(ε ρ0) − 1|, 0) per workgroup.
@group(3) @binding(5) var<storage, read_write> partials: array<vec4<f32>>;

var<workgroup> sums: array<vec4<f32>, WORKGROUP_SIZE>;

// Barriers need uniform control flow: no thread returns early.
@compute @workgroup_size(WORKGROUP_SIZE)
fn window_stats(@builtin(workgroup_id) wid: vec3<u32>,
                @builtin(local_invocation_index) lid: u32,
                @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    var s = vec4<f32>(0.0);
    if i < params.n_total && is_fluid(id[i]) {
        let u = vel[i].xyz;
        let u2 = dot(u, u);
        // |ρ − ε ρ0| / (ε ρ0): the difference first (exact in f32 near ε ρ0), so a division
        // rounded to 2.5 ulp (NVIDIA; Vulkan allows it) costs 2.5 ulp of the error, not of 1.
        let rho_e = RHO0 * porosity(i);
        s = vec4<f32>(0.5 * pos[i].w * u2, u2, abs(rho[i] - rho_e) / rho_e, 0.0);
    }
    sums[lid] = s;
    workgroupBarrier();
    for (var stride = WORKGROUP_SIZE / 2u; stride > 0u; stride = stride / 2u) {
        if lid < stride {
            let a = sums[lid];
            let b = sums[lid + stride];
            sums[lid] = vec4<f32>(a.x + b.x, max(a.y, b.y), max(a.z, b.z), 0.0);
        }
        workgroupBarrier();
    }
    if lid == 0u {
        partials[wid.x + wid.y * nwg.x] = sums[0];
    }
}
