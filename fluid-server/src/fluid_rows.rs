//! The fluid in each neighbour-grid cell's row window, counted once per sort so that
//! the boundary passes (Adami's and Joubert's) skip the rows of a wall or marker
//! particle's neighbourhood that hold no fluid. Their sums run over fluid neighbours
//! only, so a skipped row would have added nothing: the results are bit for bit those
//! of walking every row. WGSL: `shaders/fluid_rows.wgsl` (the header says how the count
//! is defined).
//!
//! Why: in a tank most wall particles stand far from the fluid and each walked its
//! whole neighbourhood of walls. The SPHERIC-2 tank at δ = 0.04 m has 25 067 wall
//! particles to 10 850 fluid, and there the Adami pass was 45 % of the step on lavapipe
//! (`couplet bench scenes/spheric2-dam-break.toml --spacing 0.04 --steps 30`,
//! 2026-12-04: 30.0 ms of the stages' 66.7 ms a step, two passes a step); 28 % on an H200 at
//! 1.04 M particles (`results/2026-12-04-h200`).
//!
//! GPU memory: 4 B per grid cell.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::sph_kernel::{Access, PARAMS, PARTICLES, SphKernel, library, particle_binding as pb};

pub const FLUID_ROWS_WGSL: &str = include_str!("../shaders/fluid_rows.wgsl");

/// The part a boundary pass composes after grid_common: the count, bound read-only at
/// [`pb::ROW_FLUID`], and `row_has_fluid(c, dy, dz)`.
pub fn row_fluid_read_wgsl() -> String {
    format!(
        "@group(0) @binding({}) var<storage, read> row_fluid: array<u32>;\n{}",
        pb::ROW_FLUID,
        library(FLUID_ROWS_WGSL)
    )
}

/// The counting pass: one thread per grid cell.
pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: fluid_rows",
        &[&consts, STEP_PARAMS_WGSL, GRID_COMMON_WGSL, FLUID_ROWS_WGSL],
        "fluid_rows",
        &[
            (
                PARTICLES,
                &[(pb::ID, Access::Read), (pb::ROW_FLUID, Access::ReadWrite)],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// CPU twin: the count of every cell of a grid of `dims` cells (x fastest) whose x axis
/// is periodic or not, from the sorted state `cell_start` (n_cells + 1 entries) and
/// whether the particle in each slot is fluid. `reach` is the grid's R; on a periodic
/// x axis `dims[0] ≥ 2R + 1` (the grid guarantees it), so no cell is counted twice.
pub fn fluid_rows_cpu(
    dims: [u32; 3],
    periodic_x: bool,
    reach: u32,
    cell_start: &[u32],
    fluid_slot: &[bool],
) -> Vec<u32> {
    let (nx, r) = (dims[0] as i64, i64::from(reach));
    let in_cell = |ci: usize| -> u32 {
        let range = cell_start[ci] as usize..cell_start[ci + 1] as usize;
        fluid_slot[range].iter().map(|&f| u32::from(f)).sum()
    };
    let n_cells = dims.iter().map(|&d| d as usize).product::<usize>();
    (0..n_cells)
        .map(|ci| {
            let (x, row) = ((ci % nx as usize) as i64, ci - ci % nx as usize);
            (x - r..=x + r)
                .filter_map(|xi| match (periodic_x, (0..nx).contains(&xi)) {
                    (_, true) => Some(xi),
                    (true, false) => Some(xi.rem_euclid(nx)),
                    (false, false) => None,
                })
                .map(|xi| in_cell(row + xi as usize))
                .sum()
        })
        .collect()
}
