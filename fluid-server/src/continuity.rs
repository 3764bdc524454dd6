//! Continuity equation, standard WCSPH form of Joubert eq. (12) without the gradient
//! correction: `dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij` over fluid, wall and marker
//! neighbours. WGSL: `shaders/continuity.wgsl` (the pair term); the pair loop is fused
//! with momentum in [`crate::fluid_rates`] (same neighbours, same ∇W).
//! With `effects.gradient_correction`: Joubert eq. (12) itself,
//! `dρ_i/dt = −ρ_i Σ_j V_j (u_j − u_i)·B_i ∇W_ij`, `V_j = m/ρ_j`, `B_i` from
//! [`crate::joubert2020_gradients`].

use crate::constants::SphConstants;
use crate::joubert2020_gradients::{b_matrix_cpu, mat_vec};
use crate::particles::{dot, sub, ParticleSet};

pub const CONTINUITY_WGSL: &str = include_str!("../shaders/continuity.wgsl");

/// CPU twin: dρ/dt of particle (entry) `i`.
pub fn continuity_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> f64 {
    let b = c.gradient_correction.then(|| b_matrix_cpu(c, set, i).0);
    let mut d = 0.0;
    for j in set.neighbours(i, c.support_radius()) {
        let grad_w = c.kernel.grad(sub(set.pos[i], set.pos[j]));
        let u_ij = sub(set.vel[i], set.vel[j]);
        d += match &b {
            Some(b) => set.rho[i] * (c.mass / set.rho[j]) * dot(u_ij, mat_vec(b, grad_w)),
            None => c.mass * dot(u_ij, grad_w),
        };
    }
    d
}
