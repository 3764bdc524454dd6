//! End-of-window blow-up check (DESIGN.md, "Failure model"): the smallest fluid id whose
//! position, velocity or density is non-finite, whose intrinsic density (ρ/ε among
//! grains) deviates from ρ0 by more than [`BLOWUP_DENSITY_DEVIATION`], whose speed exceeds
//! c_s, or (variable h) whose smoothing length exceeds the largest the neighbour grid was
//! built for, and that particle's values. Two small passes and a 64-byte readback per
//! window.
//! WGSL: `shaders/blowup_check.wgsl` (`find_bad`, `capture_bad`).

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::kernel::kernel_library;
use crate::porosity::porosity_wgsl;
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, param_binding as qb, particle_binding as pb,
};

pub const BLOWUP_CHECK_WGSL: &str = include_str!("../shaders/blowup_check.wgsl");

/// Largest |ρ/ρ0 − 1| of a healthy fluid particle. WCSPH keeps density variations near
/// 1 % (c_s ≥ 10 u_max, Joubert §2.1); 50 % is a run that has already failed.
pub const BLOWUP_DENSITY_DEVIATION: f64 = 0.5;

/// Status word meaning "no bad particle".
pub const NO_BAD_ID: u32 = u32::MAX;

const BINDINGS: &[(u32, Access)] = &[
    (pb::POS, Access::Read),
    (pb::VEL, Access::Read),
    (pb::RHO, Access::Read),
    (pb::PRESS, Access::Read),
    (pb::ID, Access::Read),
];

fn build(gpu: &Gpu, c: &SphConstants, label: &'static str, entry: &str) -> SphKernel {
    let consts = c.wgsl();
    let limit = format!("const BLOWUP_DENSITY_DEVIATION: f32 = {BLOWUP_DENSITY_DEVIATION:e};\n");
    let (porosity, binding) = porosity_wgsl(c);
    let mut bindings = BINDINGS.to_vec();
    bindings.extend(binding);
    SphKernel::new(
        gpu,
        label,
        &[
            &consts,
            &limit,
            STEP_PARAMS_WGSL,
            kernel_library(),
            porosity,
            BLOWUP_CHECK_WGSL,
        ],
        entry,
        &[
            (PARTICLES, &bindings),
            (
                PARAMS,
                &[
                    (0, Access::Uniform),
                    (qb::STATUS, Access::ReadWrite),
                    (qb::BAD_VALUES, Access::ReadWrite),
                ],
            ),
        ],
        None,
    )
}

pub fn find_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    build(gpu, c, "sph: blowup find", "find_bad")
}

pub fn capture_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    build(gpu, c, "sph: blowup capture", "capture_bad")
}
