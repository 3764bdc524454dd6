//! The fused pair loop of a fluid particle: continuity ([`crate::continuity`]) and
//! momentum ([`crate::momentum`]) in one pass over the neighbour cells, one thread per
//! particle, no atomics. WGSL: `shaders/fluid_rates.wgsl`. Switched-off effects are
//! compiled out (constants generated from the scene), so they cost nothing.

use crate::constants::{SphConstants, STEP_PARAMS_WGSL};
use crate::continuity::{continuity_cpu, CONTINUITY_WGSL};
use crate::gpu::Gpu;
use crate::kernel::kernel_library;
use crate::momentum::{momentum_cpu, MOMENTUM_WGSL};
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet};
use crate::sph_kernel::{particle_binding as pb, Access, SphKernel, PARAMS, PARTICLES};

pub const FLUID_RATES_WGSL: &str = include_str!("../shaders/fluid_rates.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: fluid_rates",
        &[&consts, STEP_PARAMS_WGSL, GRID_COMMON_WGSL, kernel_library(), CONTINUITY_WGSL, MOMENTUM_WGSL, FLUID_RATES_WGSL],
        "fluid_rates",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::Read),
                    (pb::VEL, Access::Read),
                    (pb::RHO, Access::Read),
                    (pb::PRESS, Access::Read),
                    (pb::ID, Access::Read),
                    (pb::DRHO, Access::ReadWrite),
                    (pb::DVEL, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// CPU twin: (dρ/dt, du/dt) of every fluid entry; `None` for other particles.
pub fn fluid_rates_cpu(c: &SphConstants, set: &ParticleSet) -> Vec<Option<(f64, [f64; 3])>> {
    (0..set.len())
        .map(|i| {
            (set.kinds.kind(set.id[i]) == Kind::Fluid).then(|| (continuity_cpu(c, set, i), momentum_cpu(c, set, i)))
        })
        .collect()
}
