//! Particle shifting of Joubert §2.3.3 (Xu et al. 2009), eqs. (17)–(19), applied once per
//! step after the corrector has moved the particles:
//!
//! - `δr_i = β ‖u‖max Δt s_i` (eq. 17), `s_i = r̄_i² Σ_j e_ij / r_ij²` and `‖u‖max` from
//!   the gradient pass at the start of the step ([`crate::joubert2020_gradients`]);
//! - `δf_i = ⟨∇f⟩ᶜ_i · δr_i` for the velocity components and the pressure (eq. 18);
//! - `δρ_i = (ρ0/ρ_i)^(γ−1) δp_i / c_s²` (eq. 19), and the pressure from the EOS.
//!
//! Among unresolved grains ρ_i in eq. (19) is the intrinsic density ρ/ε that the EOS
//! takes (Robinson eq. 15), and the superficial density moves by ε δρ_i; eq. (17)'s sum
//! counts a neighbour as m_j/(ε_j m0) lattice particles (the gradient pass). Until
//! 2026-12-06 the shift set p = EOS(ρ) on the superficial ρ (water at c_s = 10 m/s in a
//! block at ε = 0.8: −11.3 kPa where EOS(ρ/ε) gives the column's hydrostatic tens of Pa),
//! and the next step's gradient, wall and first rate passes read it
//! (`regression_particle_shifting_among_grains_keeps_the_eos_on_rho_over_eps`). The
//! porosity's own change over δr_i is left to the next step's porosity (a shift is
//! O(β) of the step's motion).
//!
//! The gradients are those of the step start (the pass runs on the sorted state, before
//! the rates): a first-order Taylor correction over a shift of O(β) of the distance
//! moved in the step. Only with `effects.particle_shifting` = β > 0.
//!
//! Near a resolved body's surface the shift may not carry a particle closer than δ/2 in
//! front of its nearest surface marker's tangent plane ([`limit_toward_surface`]): eq.
//! (17)'s sum has an unstable equilibrium in front of a plane of markers a spacing
//! apart, and drew fluid onto the leading faces of Joubert's cross (ARCHITECTURE.md,
//! "Joubert's cross at δ = 0.25 mm runs with Γ = 4"). The kernel with that rule is bound
//! once bodies exist ([`kernel`] with a grid layout); it counts the shifts it cuts short,
//! reported per window as `shift_limited` (`SideReport`, `/run/windows`, the run summary).
//! WGSL: `shaders/particle_shifting.wgsl`, `shaders/particle_shifting_surface.wgsl`.

use crate::body_non_penetration::BODY_NON_PENETRATION_WGSL;
use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::joubert2020_gradients::Gradients;
use crate::marker_update::MARKER_UPDATE_WGSL;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{ParticleSet, dot};
use crate::porosity::porosity_wgsl;
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, library, param_binding as qb,
    particle_binding as pb,
};
use crate::tait_eos::TAIT_EOS_WGSL;

pub const PARTICLE_SHIFTING_WGSL: &str = include_str!("../shaders/particle_shifting.wgsl");
pub const PARTICLE_SHIFTING_SURFACE_WGSL: &str =
    include_str!("../shaders/particle_shifting_surface.wgsl");
/// `limit_shift` without bodies: the shift as eq. (17) gives it.
const PLAIN_SHIFT_WGSL: &str =
    "fn limit_shift(p_i: vec3<f32>, dr: vec3<f32>) -> vec3<f32> {\n    return dr;\n}\n";

/// The shift kernel: without `grid_layout` the plain eqs. (17)–(19); with it (bound once
/// bodies exist) the variant that keeps the shift from carrying fluid within δ/2 of a
/// surface ([`limit_toward_surface`]).
pub fn kernel(
    gpu: &Gpu,
    c: &SphConstants,
    grid_layout: Option<&wgpu::BindGroupLayout>,
) -> SphKernel {
    let consts = c.wgsl();
    let layout = crate::joubert2020_gradients::GradientFields::of(c).layout_wgsl();
    let (porosity, porosity_binding) = porosity_wgsl(c);
    let mut particles = vec![
        (pb::POS, Access::ReadWrite),
        (pb::VEL, Access::ReadWrite),
        (pb::RHO, Access::ReadWrite),
        (pb::PRESS, Access::ReadWrite),
        (pb::ID, Access::Read),
        (pb::GRADS, Access::Read),
    ];
    particles.extend(porosity_binding);
    let particles = particles.as_slice();
    let params: &[(u32, Access)] = &[(qb::PARAMS, Access::Uniform), (qb::DIAG, Access::Read)];
    // With bodies, the count of shifts cut short (status[4]).
    let params_surface: &[(u32, Access)] = &[
        (qb::PARAMS, Access::Uniform),
        (qb::STATUS, Access::ReadWrite),
        (qb::DIAG, Access::Read),
    ];
    match grid_layout {
        None => SphKernel::new(
            gpu,
            "sph: particle_shifting",
            &[
                &consts,
                &layout,
                STEP_PARAMS_WGSL,
                library(TAIT_EOS_WGSL),
                porosity,
                PLAIN_SHIFT_WGSL,
                PARTICLE_SHIFTING_WGSL,
            ],
            "shift",
            &[(PARTICLES, particles), (PARAMS, params)],
            None,
        ),
        Some(grid) => SphKernel::new(
            gpu,
            "sph: particle_shifting (surfaces)",
            &[
                &consts,
                &layout,
                STEP_PARAMS_WGSL,
                GRID_COMMON_WGSL,
                library(MARKER_UPDATE_WGSL),
                library(BODY_NON_PENETRATION_WGSL),
                library(TAIT_EOS_WGSL),
                porosity,
                PARTICLE_SHIFTING_SURFACE_WGSL,
                PARTICLE_SHIFTING_WGSL,
            ],
            "shift",
            &[
                (PARTICLES, particles),
                (BODIES, &[(bb::MARKERS_IN, Access::Read)]),
                (PARAMS, params_surface),
            ],
            Some(grid),
        ),
    }
}

/// The shift `dr` of a particle whose nearest surface marker within δ is `nearest`
/// (`r = x_i − x_m` and the marker's outward unit normal), limited so that it carries
/// the particle no closer than δ/2 in front of the marker's tangent plane: the inward
/// part beyond that is dropped (all of it for a particle already closer). CPU twin of
/// `limit_shift` in `particle_shifting_surface.wgsl`.
pub fn limit_toward_surface(
    c: &SphConstants,
    dr: [f64; 3],
    nearest: Option<([f64; 3], [f64; 3])>,
) -> [f64; 3] {
    let Some((r, n)) = nearest else {
        return dr;
    };
    let inward = -dot(dr, n);
    if inward <= 0.0 {
        return dr;
    }
    let allowed = (dot(r, n) - 0.5 * c.spacing).max(0.0);
    let back = inward - inward.min(allowed);
    std::array::from_fn(|k| dr[k] + back * n[k])
}

/// One fluid particle before and after the shift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shifted {
    pub pos: [f64; 3],
    pub vel: [f64; 3],
    pub rho: f64,
}

impl Shifted {
    /// Entry `i` of `set`, as the shift takes it.
    pub fn of(set: &ParticleSet, i: usize) -> Self {
        Shifted {
            pos: set.pos[i],
            vel: set.vel[i],
            rho: set.rho[i],
        }
    }
}

/// CPU twin of eqs. (17)–(19) for one particle at porosity `porosity` (1 without grains;
/// eq. 19 then acts on ρ/ε); `nearest` as [`limit_toward_surface`] takes it (None
/// without bodies). The pressure after the shift is the EOS's at `rho / porosity`.
pub fn shift_cpu(
    c: &SphConstants,
    g: &Gradients,
    u_max: f64,
    dt: f64,
    s: Shifted,
    porosity: f64,
    nearest: Option<([f64; 3], [f64; 3])>,
) -> Shifted {
    let dr = limit_toward_surface(
        c,
        g.shift.map(|x| c.shifting_beta * u_max * dt * x),
        nearest,
    );
    let dp = dot(g.grad_p, dr);
    let (intrinsic, c2) = (s.rho / porosity, c.sound_speed * c.sound_speed);
    Shifted {
        pos: std::array::from_fn(|k| s.pos[k] + dr[k]),
        vel: std::array::from_fn(|k| s.vel[k] + dot(g.grad_u[k], dr)),
        rho: porosity * (intrinsic + (c.rho0 / intrinsic).powf(c.gamma - 1.0) * dp / c2),
    }
}
