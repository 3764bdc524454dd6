// ---- continuity.wgsl: standard WCSPH continuity (CPU twin: continuity.rs) ----
// dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij (m_j: the neighbour's own mass, pos[j].w): the standard (uncorrected) form of Joubert eq. (12),
// summed over fluid, wall and marker neighbours. The pair loop is fused with momentum
// in fluid_rates.wgsl.

fn continuity_term(m_j: f32, u_ij: vec3<f32>, grad_w: vec3<f32>) -> f32 {
    return m_j * dot(u_ij, grad_w);
}

// δ-SPH density diffusion (Antuono, Colagrossi, Marrone & Molteni 2010, eq. 5) for a fluid
// neighbour j: δ h c_s V_j ψ_ij·∇W_ij, ψ_ij = 2(ρ_j − ρ_i) r_ji/r² − (⟨∇ρ⟩ᶜ_i + ⟨∇ρ⟩ᶜ_j), with
// r_ji = −r_ij and the renormalised gradients of the gradient pass. `rho_f_*` is the density
// diffused: the intrinsic ρ/ε among grains (the caller multiplies by ε_i), ρ otherwise;
// V_j = m_j/ρ_j takes the superficial one.
fn antuono2010_diffusion_term(m_j: f32, rho_f_i: f32, rho_f_j: f32, rho_j: f32, r_ij: vec3<f32>, r2: f32, grad_w: vec3<f32>,
                              grad_rho_i: vec3<f32>, grad_rho_j: vec3<f32>) -> f32 {
    let psi = (-2.0 * (rho_f_j - rho_f_i) / r2) * r_ij - (grad_rho_i + grad_rho_j);
    return DIFFUSION_DELTA * H * SOUND_SPEED * (m_j / rho_j) * dot(psi, grad_w);
}

// δ-SPH density diffusion of Fourtakas, Domínguez, Vacondio & Rogers 2019 (DualSPHysics
// DensityDT=2) for a fluid neighbour j: δ h c_s V_j ψ_ij·∇W_ij, ψ_ij = 2(ρ_j − ρ_i − ρ^H_ji)
// r_ji/r², with the hydrostatic difference ρ^H_ji of `fourtakas2019_hydrostatic_difference`
// at x = ρ0 g·r_ji/B (`gravity`: the fluid's, StepParams). No gradients: on a hydrostatic
// field it vanishes where the support is truncated too. `rho_f_*` as above.
fn fourtakas2019_diffusion_term(m_j: f32, rho_f_i: f32, rho_f_j: f32, rho_j: f32, r_ij: vec3<f32>, r2: f32, grad_w: vec3<f32>,
                                gravity: vec3<f32>) -> f32 {
    let rho_h = fourtakas2019_hydrostatic_difference(-RHO0 * dot(gravity, r_ij) / TAIT_B);
    let psi = (-2.0 * (rho_f_j - rho_f_i - rho_h) / r2) * r_ij;
    return DIFFUSION_DELTA * H * SOUND_SPEED * (m_j / rho_j) * dot(psi, grad_w);
}

// ρ^H = ρ0((1 + x)^(1/γ) − 1), the Tait density of the hydrostatic pressure step x B. For
// |x| < 1e-2 the binomial series to x³ (its error is below 0.3 x³ of the result): f32's
// pow(1 + x, 1/γ) − 1 would keep only the digits of x that survive 1 + x. pow beyond.
fn fourtakas2019_hydrostatic_difference(x: f32) -> f32 {
    let a = 1.0 / GAMMA;
    if abs(x) < 1e-2 {
        return RHO0 * a * x * (1.0 + 0.5 * (a - 1.0) * x * (1.0 + (a - 2.0) * x / 3.0));
    }
    return RHO0 * (pow(max(1.0 + x, MIN_TAIT_BASE), a) - 1.0);
}

// Joubert eq. (12), gradient-corrected: dρ_i/dt = −ρ_i Σ_j V_j (u_j − u_i)·B_i ∇W_ij with
// V_j = m/ρ_j; `grad_w_c` = B_i ∇W_ij.
fn corrected_continuity_term(m_j: f32, rho_i: f32, rho_j: f32, u_ij: vec3<f32>, grad_w_c: vec3<f32>) -> f32 {
    return rho_i * (m_j / rho_j) * dot(u_ij, grad_w_c);
}
