//! Neighbours inside the support radius per fluid particle (diagnostics and pair
//! throughput, BENCHMARKS.md). WGSL: `shaders/neighbour_count.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet};
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, param_binding as qb, particle_binding as pb,
};

pub const NEIGHBOUR_COUNT_WGSL: &str = include_str!("../shaders/neighbour_count.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: neighbour_count",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            NEIGHBOUR_COUNT_WGSL,
        ],
        "neighbour_count",
        &[
            (
                PARTICLES,
                &[(pb::POS, Access::Read), (pb::ID, Access::Read)],
            ),
            (
                PARAMS,
                &[(0, Access::Uniform), (qb::COUNTS, Access::ReadWrite)],
            ),
        ],
        Some(grid_layout),
    )
}

/// CPU twin: mean number of neighbours inside the support of the fluid particles.
pub fn mean_neighbours_cpu(c: &SphConstants, set: &ParticleSet) -> f64 {
    let fluid: Vec<usize> = (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Fluid)
        .collect();
    let total: usize = fluid
        .iter()
        .map(|&i| set.neighbours(i, c.support_radius(), c.period).count())
        .sum();
    total as f64 / fluid.len().max(1) as f64
}
