//! Tait equation of state, Joubert eq. (4): `p = ρ0 c²/γ ((ρ/ρ0)^γ − 1) + P_b`, with
//! the scene's background pressure P_b (`fluid.background_pressure`, 0 by default).
//! WGSL: `shaders/tait_eos.wgsl` (its library part is fused into the integrator and the
//! boundary pressure; its kernel sets the pressures at the start of a run).

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::particles::{Kind, ParticleSet};
use crate::porosity::porosity_wgsl;
use crate::sph_kernel::{Access, PARAMS, PARTICLES, SphKernel, particle_binding as pb};

pub const TAIT_EOS_WGSL: &str = include_str!("../shaders/tait_eos.wgsl");

/// Compiles the `tait_eos` kernel (pressure of every fluid particle from its density).
pub fn kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    let consts = c.wgsl();
    let (porosity, binding) = porosity_wgsl(c);
    let mut bindings = vec![
        (pb::RHO, Access::Read),
        (pb::PRESS, Access::ReadWrite),
        (pb::ID, Access::Read),
    ];
    bindings.extend(binding);
    SphKernel::new(
        gpu,
        "sph: tait_eos",
        &[&consts, STEP_PARAMS_WGSL, porosity, TAIT_EOS_WGSL],
        "tait_eos",
        &[(PARTICLES, &bindings), (PARAMS, &[(0, Access::Uniform)])],
        None,
    )
}

/// CPU twin: the pressure of every fluid particle (others unchanged), Joubert eq. (4),
/// at porosity 1 (with grains the kernel takes ρ/ε, Robinson eq. 15;
/// `tests/unresolved.rs` checks that against [`crate::porosity`]).
pub fn tait_eos_cpu(c: &SphConstants, set: &ParticleSet) -> Vec<f64> {
    (0..set.len())
        .map(|k| {
            if set.kinds.kind(set.id[k]) == Kind::Fluid {
                c.pressure(set.rho[k])
            } else {
                set.press[k]
            }
        })
        .collect()
}
