// ---- blowup_check.wgsl (CPU side: blowup_check.rs) ----
// Once per window: find the smallest id of a fluid particle whose position, velocity or
// density is not finite, whose density left [ρ0 (1 − BLOWUP_DENSITY_DEVIATION),
// ρ0 (1 + BLOWUP_DENSITY_DEVIATION)], whose speed exceeds c_s or, with variable h, whose
// smoothing length (Robinson eq. 19) exceeds MAX_H, the largest the grid was built for;
// then copy that particle's values out. Atomics are fine here: this is not a pair loop and it runs
// once per window.
// Needs: prelude, SPH constants, StepParams, kernel; BLOWUP_DENSITY_DEVIATION
// (blowup_check.rs), porosity (porosity.rs).

// ---- kernels ----
@group(0) @binding(0) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rho: array<f32>;
@group(0) @binding(3) var<storage, read> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
// [0] smallest bad id (0xffffffff: none); [1], [2] the gradient pass's counts, [3], [4]
// the body counts (body_non_penetration.wgsl, particle_shifting_surface.wgsl).
@group(3) @binding(1) var<storage, read_write> status: array<atomic<u32>, 5>;
// The bad particle: (pos, ρ), (vel, p), (mass, 0, 0, 0).
@group(3) @binding(2) var<storage, read_write> bad_values: array<vec4<f32>, 3>;

const NONE: u32 = 0xffffffffu;
const EXPONENT_MASK: u32 = 0x7f800000u;

// Infinite or NaN, by the bits (comparisons with NaN may be folded away).
fn not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & EXPONENT_MASK) == EXPONENT_MASK;
}

fn bad(i: u32) -> bool {
    let p = pos[i].xyz;
    let u = vel[i].xyz;
    let r = rho[i];
    if not_finite(p.x) || not_finite(p.y) || not_finite(p.z) || not_finite(u.x) || not_finite(u.y)
        || not_finite(u.z) || not_finite(r) {
        return true;
    }
    // Among grains ρ is superficial: the intrinsic density is ρ/ε (Robinson eq. 15).
    if VARIABLE_H && variable_h_of(pos[i].w, r) > MAX_H {
        return true;
    }
    return abs(r / (RHO0 * porosity(i)) - 1.0) > BLOWUP_DENSITY_DEVIATION || dot(u, u) > SOUND_SPEED * SOUND_SPEED;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn find_bad(@builtin(workgroup_id) wid: vec3<u32>,
            @builtin(local_invocation_index) lid: u32,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    if bad(i) {
        atomicMin(&status[0], id[i]);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn capture_bad(@builtin(workgroup_id) wid: vec3<u32>,
               @builtin(local_invocation_index) lid: u32,
               @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || id[i] != atomicLoad(&status[0]) {
        return;
    }
    bad_values[0] = vec4<f32>(pos[i].xyz, rho[i]);
    bad_values[1] = vec4<f32>(vel[i].xyz, press[i]);
    bad_values[2] = vec4<f32>(pos[i].w, 0.0, 0.0, 0.0);
}
