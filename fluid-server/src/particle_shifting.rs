//! Particle shifting of Joubert §2.3.3 (Xu et al. 2009), eqs. (17)–(19), applied once per
//! step after the corrector has moved the particles:
//!
//! - `δr_i = β ‖u‖max Δt s_i` (eq. 17), `s_i = r̄_i² Σ_j e_ij / r_ij²` and `‖u‖max` from
//!   the gradient pass at the start of the step ([`crate::joubert2020_gradients`]);
//! - `δf_i = ⟨∇f⟩ᶜ_i · δr_i` for the velocity components and the pressure (eq. 18);
//! - `δρ_i = (ρ0/ρ_i)^(γ−1) δp_i / c_s²` (eq. 19), and the pressure from the EOS.
//!
//! The gradients are those of the step start (the pass runs on the sorted state, before
//! the rates): a first-order Taylor correction over a shift of O(β) of the distance
//! moved in the step. Only with `effects.particle_shifting` = β > 0.
//! WGSL: `shaders/particle_shifting.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::joubert2020_gradients::Gradients;
use crate::particles::dot;
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, library, param_binding as qb, particle_binding as pb,
};
use crate::tait_eos::TAIT_EOS_WGSL;

pub const PARTICLE_SHIFTING_WGSL: &str = include_str!("../shaders/particle_shifting.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: particle_shifting",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            library(TAIT_EOS_WGSL),
            PARTICLE_SHIFTING_WGSL,
        ],
        "shift",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::ReadWrite),
                    (pb::VEL, Access::ReadWrite),
                    (pb::RHO, Access::ReadWrite),
                    (pb::PRESS, Access::ReadWrite),
                    (pb::ID, Access::Read),
                    (pb::GRADS, Access::Read),
                ],
            ),
            (
                PARAMS,
                &[(qb::PARAMS, Access::Uniform), (qb::DIAG, Access::Read)],
            ),
        ],
        None,
    )
}

/// One fluid particle before and after the shift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shifted {
    pub pos: [f64; 3],
    pub vel: [f64; 3],
    pub rho: f64,
}

/// CPU twin of eqs. (17)–(19) for one particle.
pub fn shift_cpu(c: &SphConstants, g: &Gradients, u_max: f64, dt: f64, s: Shifted) -> Shifted {
    let dr: [f64; 3] = g.shift.map(|x| c.shifting_beta * u_max * dt * x);
    let dp = dot(g.grad_p, dr);
    Shifted {
        pos: std::array::from_fn(|k| s.pos[k] + dr[k]),
        vel: std::array::from_fn(|k| s.vel[k] + dot(g.grad_u[k], dr)),
        rho: s.rho + (c.rho0 / s.rho).powf(c.gamma - 1.0) * dp / (c.sound_speed * c.sound_speed),
    }
}
