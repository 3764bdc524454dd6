//! Continuity equation, standard WCSPH form of Joubert eq. (12) without the gradient
//! correction: `dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij` over fluid, wall and marker
//! neighbours. WGSL: `shaders/continuity.wgsl` (the pair term); the pair loop is fused
//! with momentum in [`crate::fluid_rates`] (same neighbours, same ∇W).
//! The B-matrix correction (Joubert eq. 10) will multiply `∇W_ij` by `B_i` here.

use crate::constants::SphConstants;
use crate::particles::{dot, sub, ParticleSet};

pub const CONTINUITY_WGSL: &str = include_str!("../shaders/continuity.wgsl");

/// CPU twin: dρ/dt of particle (entry) `i`.
pub fn continuity_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> f64 {
    let mut d = 0.0;
    for j in set.neighbours(i, c.support_radius()) {
        let grad_w = c.kernel.grad(sub(set.pos[i], set.pos[j]));
        d += c.mass * dot(sub(set.vel[i], set.vel[j]), grad_w);
    }
    d
}
