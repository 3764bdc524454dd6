//! Predictor–corrector of Joubert eqs. (20)–(23):
//! `f* = fⁿ + Δt dfⁿ/dt`, p* from the EOS; the rates are re-evaluated at f* (same
//! positions); `f** = fⁿ + Δt df*/dt`, `f^{n+1} = ½(f* + f**)`, and
//! `r^{n+1} = rⁿ + Δt u^{n+1}`. Fluid only: walls never move, markers are placed by
//! [`crate::marker_update`]. WGSL: `shaders/integrate.wgsl` (`predict`, `correct`).

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::porosity::porosity_wgsl;
use crate::sph_kernel::{Access, PARAMS, PARTICLES, SphKernel, library, particle_binding as pb};
use crate::tait_eos::TAIT_EOS_WGSL;

pub const INTEGRATE_WGSL: &str = include_str!("../shaders/integrate.wgsl");

const BINDINGS: &[(u32, Access)] = &[
    (pb::POS, Access::ReadWrite),
    (pb::VEL, Access::ReadWrite),
    (pb::RHO, Access::ReadWrite),
    (pb::PRESS, Access::ReadWrite),
    (pb::ID, Access::Read),
    (pb::DRHO, Access::Read),
    (pb::DVEL, Access::Read),
    (pb::RHO_N, Access::ReadWrite),
    (pb::VEL_N, Access::ReadWrite),
    (pb::LOW_WORDS, Access::ReadWrite),
];

/// The `predict` kernel (Joubert eq. 20).
pub fn predict_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    build(gpu, c, "sph: predict", "predict")
}

/// The `correct` kernel (Joubert eqs. 21–23).
pub fn correct_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    build(gpu, c, "sph: correct", "correct")
}

fn build(gpu: &Gpu, c: &SphConstants, label: &'static str, entry: &str) -> SphKernel {
    let consts = c.wgsl();
    let (porosity, binding) = porosity_wgsl(c);
    let mut bindings = BINDINGS.to_vec();
    bindings.extend(binding);
    SphKernel::new(
        gpu,
        label,
        &[
            &consts,
            STEP_PARAMS_WGSL,
            library(TAIT_EOS_WGSL),
            porosity,
            INTEGRATE_WGSL,
        ],
        entry,
        &[(PARTICLES, &bindings), (PARAMS, &[(0, Access::Uniform)])],
        None,
    )
}

/// State of one fluid particle for the CPU twin of the integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FluidState {
    pub pos: [f64; 3],
    pub vel: [f64; 3],
    pub rho: f64,
}

/// CPU twin of one step of Joubert eqs. (20)–(23) for a single particle whose rates
/// come from `rates(state)` (both evaluations at rⁿ).
pub fn predictor_corrector_cpu(
    s: FluidState,
    dt: f64,
    mut rates: impl FnMut(&FluidState) -> (f64, [f64; 3]),
) -> FluidState {
    let (drho_n, dvel_n) = rates(&s);
    let star = FluidState {
        pos: s.pos,
        rho: s.rho + dt * drho_n,
        vel: std::array::from_fn(|k| s.vel[k] + dt * dvel_n[k]),
    };
    let (drho_s, dvel_s) = rates(&star);
    let rho = 0.5 * (star.rho + s.rho + dt * drho_s);
    let vel: [f64; 3] = std::array::from_fn(|k| 0.5 * (star.vel[k] + s.vel[k] + dt * dvel_s[k]));
    FluidState {
        pos: std::array::from_fn(|k| s.pos[k] + dt * vel[k]),
        vel,
        rho,
    }
}
