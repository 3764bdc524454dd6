// ---- momentum.wgsl: pair terms of the WCSPH momentum equation (CPU twin: momentum.rs) ----
// du_i/dt = −Σ m (p_i/ρ_i² + p_j/ρ_j²) ∇W_ij                      (symmetric pressure gradient)
//         + Σ m (μ_i + μ_j) r_ij·∇W_ij / (ρ_i ρ_j (r² + η²)) u_ij  (Morris, Fox & Zhu 1997, eq. 8)
//         − Σ m Π_ij ∇W_ij                                       (Monaghan 1992, eq. 4.1)
//         + g
// with μ = ρ ν and η² = 0.01 h². The pair loop is fluid_rates.wgsl.

fn pressure_term(m_j: f32, p_i: f32, rho_i: f32, p_j: f32, rho_j: f32, grad_w: vec3<f32>) -> vec3<f32> {
    return -m_j * (p_i / (rho_i * rho_i) + p_j / (rho_j * rho_j)) * grad_w;
}

// Pressure part of Robinson eq. (12) (variable h): −m_j (P_i/(Ω_i ρ_i²) ∇W(h_i) +
// P_j/(Ω_j ρ_j²) ∇W(h_j)); `q_i` = P_i/Ω_i and `q_j` = P_j/Ω_j.
fn robinson_pressure_term(m_j: f32, q_i: f32, rho_i: f32, q_j: f32, rho_j: f32, grad_w_i: vec3<f32>, grad_w_j: vec3<f32>) -> vec3<f32> {
    return -m_j * ((q_i / (rho_i * rho_i)) * grad_w_i + (q_j / (rho_j * rho_j)) * grad_w_j);
}

// Pressure part of Joubert eq. (13), gradient-corrected: −(1/ρ_i) Σ_j V_j (p_j − p_i) B_i ∇W_ij,
// V_j = m/ρ_j; `grad_w_c` = B_i ∇W_ij.
fn corrected_pressure_term(m_j: f32, p_i: f32, rho_i: f32, p_j: f32, rho_j: f32, grad_w_c: vec3<f32>) -> vec3<f32> {
    return (-m_j / (rho_i * rho_j)) * (p_j - p_i) * grad_w_c;
}

// Morris, Fox & Zhu (1997) eq. (8), μ = ρν.
fn morris1997_viscous_term(m_j: f32, rho_i: f32, rho_j: f32, r_ij: vec3<f32>, r2: f32, u_ij: vec3<f32>,
                           grad_w: vec3<f32>) -> vec3<f32> {
    let mu_sum = NU * (rho_i + rho_j);
    return (m_j * mu_sum * dot(r_ij, grad_w) / (rho_i * rho_j * (r2 + VISCOUS_ETA2))) * u_ij;
}

// Monaghan (1992) eq. (4.1)–(4.2) with β = 0: Π_ij = −α c μ_ij / ρ̄_ij for approaching
// pairs, μ_ij = h u_ij·r_ij/(r² + η²).
fn monaghan1992_artificial_viscous_term(m_j: f32, rho_i: f32, rho_j: f32, r_ij: vec3<f32>, r2: f32,
                                        u_ij: vec3<f32>, grad_w: vec3<f32>) -> vec3<f32> {
    let vr = dot(u_ij, r_ij);
    if vr >= 0.0 {
        return vec3<f32>(0.0);
    }
    let mu_ij = H * vr / (r2 + VISCOUS_ETA2);
    let pi_ij = -ALPHA * SOUND_SPEED * mu_ij / (0.5 * (rho_i + rho_j));
    return -m_j * pi_ij * grad_w;
}
