// ---- continuity.wgsl: standard WCSPH continuity (CPU twin: continuity.rs) ----
// dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij: the standard (uncorrected) form of Joubert eq. (12),
// summed over fluid, wall and marker neighbours. The pair loop is fused with momentum
// in fluid_rates.wgsl.

fn continuity_term(u_ij: vec3<f32>, grad_w: vec3<f32>) -> f32 {
    return MASS * dot(u_ij, grad_w);
}
