// ---- continuity.wgsl: standard WCSPH continuity (CPU twin: continuity.rs) ----
// dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij: the standard (uncorrected) form of Joubert eq. (12),
// summed over fluid, wall and marker neighbours. The pair loop is fused with momentum
// in fluid_rates.wgsl.

fn continuity_term(u_ij: vec3<f32>, grad_w: vec3<f32>) -> f32 {
    return MASS * dot(u_ij, grad_w);
}

// Joubert eq. (12), gradient-corrected: dρ_i/dt = −ρ_i Σ_j V_j (u_j − u_i)·B_i ∇W_ij with
// V_j = m/ρ_j; `grad_w_c` = B_i ∇W_ij.
fn corrected_continuity_term(rho_i: f32, rho_j: f32, u_ij: vec3<f32>, grad_w_c: vec3<f32>) -> f32 {
    return rho_i * (MASS / rho_j) * dot(u_ij, grad_w_c);
}
