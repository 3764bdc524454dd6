// ---- particle_shifting.wgsl: Joubert eqs. (17)–(19) (CPU twin: particle_shifting.rs) ----
// After `correct` (eq. 23 has moved the particles), once per step:
//   δr_i = β ‖u‖max Δt s_i                         (eq. 17; s_i from the gradient pass)
//   δu_i = ⟨∇u⟩ᶜ_i · δr_i,  δp_i = ⟨∇p⟩ᶜ_i · δr_i   (eq. 18)
//   δρ_i = (ρ0/ρ_i)^(γ−1) δp_i / c_s²              (eq. 19), then p_i from the EOS;
//   among unresolved grains ρ_i is the intrinsic density ρ/ε (the EOS's, Robinson eq. 15).
// Fluid particles only. Needs: prelude, SPH constants, StepParams, the gradient layout
// (GradientFields::layout_wgsl: shifting reads ∇u, ∇p and s), tait_eos (library),
// `porosity(i)` (porosity.rs: 1 without grains),
// `limit_shift(p_i, δr)`: δr itself without bodies (PLAIN_SHIFT_WGSL in
// particle_shifting.rs), the surface rule of particle_shifting_surface.wgsl with them.

// ---- kernels ----
@group(0) @binding(0) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rho: array<f32>;
@group(0) @binding(3) var<storage, read_write> press: array<f32>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(10) var<storage, read> grads: array<vec4<f32>>;
@group(3) @binding(4) var<storage, read> diag: array<u32, 4>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn shift(@builtin(workgroup_id) wid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let u_max = bitcast<f32>(diag[0]);
    // Joubert eq. (17).
    let g = GRAD_STRIDE * i;
    let dr = limit_shift(pos[i].xyz, SHIFTING_BETA * u_max * params.dt * grads[g + GRAD_SLOT_S].xyz);
    // Joubert eq. (18).
    let gu = GRAD_SLOT_U;
    let du = vec3<f32>(dot(grads[g + gu].xyz, dr), dot(grads[g + gu + 1u].xyz, dr), dot(grads[g + gu + 2u].xyz, dr));
    let dp = dot(grads[g + GRAD_SLOT_P].xyz, dr);
    // Joubert eq. (19) on the intrinsic density ρ/ε, which the EOS takes among unresolved
    // grains (Robinson eq. 15); the superficial density is ε times it. Without grains
    // ε = 1, and the division and the product are exact.
    let eps = porosity(i);
    let r = rho[i] / eps;
    let r_new = r + pow(RHO0 / r, GAMMA - 1.0) * dp / (SOUND_SPEED * SOUND_SPEED);
    pos[i] = vec4<f32>(pos[i].xyz + dr, pos[i].w);
    vel[i] = vec4<f32>(vel[i].xyz + du, 0.0);
    rho[i] = eps * r_new;
    press[i] = tait_pressure(r_new);
}
