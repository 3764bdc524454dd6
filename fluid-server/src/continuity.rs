//! Continuity equation, standard WCSPH form of Joubert eq. (12) without the gradient
//! correction: `dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij` over fluid, wall and marker
//! neighbours. WGSL: `shaders/continuity.wgsl` (the pair term); the pair loop is fused
//! with momentum in [`crate::fluid_rates`] (same neighbours, same ∇W).
//! With `effects.gradient_correction`: Joubert eq. (12) itself,
//! `dρ_i/dt = −ρ_i Σ_j V_j (u_j − u_i)·B_i ∇W_ij`, `V_j = m/ρ_j`, `B_i` from
//! [`crate::joubert2020_gradients`].
//!
//! With `effects.density_diffusion` = δ > 0, δ-SPH (Antuono, Colagrossi, Marrone &
//! Molteni 2010, eq. 5) adds over fluid neighbours `δ h c_s Σ_j V_j ψ_ij·∇W_ij`,
//! `ψ_ij = 2(ρ_j − ρ_i) r_ji/r_ij² − (⟨∇ρ⟩ᶜ_i + ⟨∇ρ⟩ᶜ_j)`, with the renormalised density
//! gradients of the gradient pass (h: the smoothing length of the kernel in use).

use crate::constants::SphConstants;
use crate::joubert2020_gradients::{b_matrix_cpu, mat_vec};
use crate::particles::{Kind, ParticleSet, dot, sub};

pub const CONTINUITY_WGSL: &str = include_str!("../shaders/continuity.wgsl");

/// CPU twin: dρ/dt of particle (entry) `i`; `grad_rho` holds every entry's corrected
/// density gradient when density diffusion is on (unused otherwise).
pub fn continuity_cpu(c: &SphConstants, set: &ParticleSet, i: usize, grad_rho: &[[f64; 3]]) -> f64 {
    let b = c.gradient_correction.then(|| b_matrix_cpu(c, set, i).0);
    let mut d = 0.0;
    for j in set.neighbours(i, c.support_radius()) {
        let grad_w = c.kernel.grad(sub(set.pos[i], set.pos[j]));
        let u_ij = sub(set.vel[i], set.vel[j]);
        d += match &b {
            Some(b) => set.rho[i] * (c.mass / set.rho[j]) * dot(u_ij, mat_vec(b, grad_w)),
            None => c.mass * dot(u_ij, grad_w),
        };
        if c.density_diffusion > 0.0 && set.kinds.kind(set.id[j]) == Kind::Fluid {
            let r_ij = sub(set.pos[i], set.pos[j]);
            let (rho_i, rho_j) = (set.rho[i], set.rho[j]);
            let f = -2.0 * (rho_j - rho_i) / dot(r_ij, r_ij);
            let psi: [f64; 3] =
                std::array::from_fn(|k| f * r_ij[k] - (grad_rho[i][k] + grad_rho[j][k]));
            d += c.density_diffusion
                * c.kernel.h
                * c.sound_speed
                * (c.mass / rho_j)
                * dot(psi, grad_w);
        }
    }
    d
}
