//! Uniform neighbour grid: stable counting sort of the particles by cell, every step, on
//! the GPU.
//!
//! [`NeighbourGrid::queue_sort`] records five labelled compute passes and no CPU
//! round trip:
//! 1. `grid: count`   — one thread per particle: position wrapped into the period on
//!    periodic axes ([`GridBox`]), cell index, rank in the cell by one `atomicAdd` on
//!    the cell's counter (the sort's only atomics);
//! 2. `grid: scan`    — exclusive prefix sum of the n_cells + 1 counters → `cell_start`;
//! 3. `grid: scatter` — `unordered[cell_start[cell] + rank] = i` (order inside a cell
//!    is whatever the atomics gave);
//! 4. `grid: order`   — one thread per slot counts the particles of its cell with a
//!    smaller index and puts its particle that far into the cell's slice of `src_of`,
//!    so particles keep their previous relative order: the sort is stable and a run
//!    repeats bit for bit (without it, runs differed in round-off and a coarse
//!    settling sphere's plateau varied 0.55–5.14 % between identical runs);
//! 5. `grid: reorder` — the registered buffers gathered into scratch slices, up to
//!    [`GATHER_BUFFERS_PER_PASS`] of one element size a pass (so 2 passes for the
//!    grain columns' 9 buffers instead of 9), then each copied back
//!    (`copy_buffer_to_buffer`), so callers' buffers and bind groups stay valid; timed
//!    together as one span.
//!
//! Pair kernels read the result through `shaders/grid_common.wgsl`
//! ([`GRID_COMMON_WGSL`]), bound at group 1 ([`NeighbourGrid::bind_group`]).
//!
//! GPU memory: 16 B per particle (cell, rank, unordered and stable gather map) + a
//! scratch slice as large as each registered buffer (16 or 4 B per particle each) + 4 B
//! per cell, less what a pass gathers into a buffer the caller lends
//! ([`NeighbourGrid::lend_scratch`]: one whose contents no reader needs across a sort).

use std::num::NonZeroU64;

use wgpu::util::DeviceExt;

use crate::gpu::{Gpu, GpuError};
use crate::prefix_sum::{PrefixSum, PrefixSumError};
use crate::shaders;
use crate::timing::{self, StageTimer};

/// WGSL for pair kernels: `GridParams`, the group-1 bindings, `cell_coord`,
/// `cell_index`, `cell_in_grid`, `cell_range`, `row_base`, `row_ranges`, `row_slot`, `pair_vec` and the loop pattern (see
/// the file's header).
pub const GRID_COMMON_WGSL: &str = include_str!("../shaders/grid_common.wgsl");
const NEIGHBOUR_GRID_WGSL: &str = include_str!("../shaders/neighbour_grid.wgsl");
const REORDER_WGSL: &str = include_str!("../shaders/reorder.wgsl");

/// Cells per grid radius R on a GPU, and so how many cells the pair loops reach on each
/// side of a particle's own cell (`GRID_REACH` in WGSL, from `SphConstants::wgsl`),
/// unless `COUPLET_GRID_REACH` (`gpu::GRID_REACH_ENV`) sets another to measure it.
/// [`grid_reach_for`] picks it or [`GRID_REACH_CPU`] by the adapter.
///
/// Cells of support/R and (2R+1)² rows of 2R+1 contiguous cells visit (2R+1)³/R³
/// support³ of space per particle: 27 (R = 1), 15.6 (R = 2), 12.7 (R = 3), 11.4 (R = 4),
/// against the support sphere's 4.2; a larger R tests fewer candidates but walks more
/// rows ((2R+1)², each two `cell_start` loads, most of them nearly empty once a cell is
/// narrower than a particle spacing) and sorts into R³ times as many cells.
///
/// On an NVIDIA H200 (2026-12-04, `couplet bench SCENE --steps N`, alone on the GPU,
/// `results/2026-12-04-h200/bench-r2-r3.txt` and `bench-r3.txt`), fluid steps/s:
///
/// | scene | R = 2 | R = 3 |
/// |---|---|---|
/// | SPHERIC-2 dam break δ = 0.02 m (180 k particles, support 3 δ) | 1070 | 1499 |
/// | the same, corrected gradients + Laplacian + shifting | 472 | 646 |
/// | SPHERIC-2 δ = 0.01 m (1.04 M) | 284 | 354 |
/// | SPHERIC-2 δ = 0.005 m (6.87 M) | 49.2 | 62.2 |
/// | `lid-driven-cavity` (112 k, twice each) | 328, 328 | 480, 479 |
/// | `settling-cylinder` (177 k, markers, a DEM exchange every step) | 226 | 288 |
///
/// so R = 3 on a GPU: 25–46 % faster on every scene measured. R = 4 is not measured
/// there.
pub const GRID_REACH_GPU: u32 = 3;

/// Cells per grid radius R on a CPU adapter (lavapipe). There (Mesa 25.0.7, 2026-11-28,
/// 2 vCPU, R = 2 and 3 alternated, machine otherwise idle) cells no wider than a spacing
/// made the dense pair stages faster and whole runs no faster:
///
/// | `COUPLET_GRID_REACH=R couplet …` | R = 2 | R = 3 |
/// |---|---|---|
/// | bench hydrostatic tank δ = 0.02 m, support 2 δ: pair stages, ms/step | 5.0–5.8 | 6.9–7.7 |
/// | the same, support 2.4 δ | 11.4–11.8 | 9.5–9.6 |
/// | the same, support 3 δ | 21.7–22.9 | 16.3–17.9 |
/// | bench SPHERIC-2 δ = 0.02 m (3 δ): steps/s | 1.99 | 2.43 |
/// | run dam-break-boxes δ = 0.02 m, 2.4 δ (README's main job): wall s | 108.2, 108.7 | 118.0, 110.1 |
/// | the CI validation cases (`cargo test --release -p couplet-tests --test validation`): s | 1440.1 | 1422.7 |
///
/// so a CPU adapter keeps R = 2, and with it every figure CI and the tests' references
/// were measured at. (On Mesa 22.3.6, R = 3 had been level with R = 2 on the
/// hydrostatic tank and the settling sphere.)
pub const GRID_REACH_CPU: u32 = 2;

/// The neighbour grid's reach an adapter of `device_type` takes unless
/// `COUPLET_GRID_REACH` says otherwise: [`GRID_REACH_CPU`] on a CPU adapter,
/// [`GRID_REACH_GPU`] on any other.
pub fn grid_reach_for(device_type: wgpu::DeviceType) -> u32 {
    match device_type {
        wgpu::DeviceType::Cpu => GRID_REACH_CPU,
        _ => GRID_REACH_GPU,
    }
}

/// The values `COUPLET_GRID_REACH` may take.
pub const GRID_REACH_RANGE: std::ops::RangeInclusive<u32> = 1..=4;

/// The WGSL declaration of `GRID_REACH` = `reach`, which grid_common.wgsl's loops and
/// every pair kernel read (SPH kernels get it from `SphConstants::wgsl`).
pub fn grid_reach_wgsl(reach: u32) -> String {
    format!(
        "// Cells per grid radius: pair loops visit rows dy, dz in -GRID_REACH..=GRID_REACH.\n\
         const GRID_REACH: i32 = {reach};\n"
    )
}

/// The WGSL declaration of `TEAM_LANES` = `lanes`, which the team passes read (they get
/// it from `SphConstants::wgsl`).
pub fn team_lanes_wgsl(lanes: u32) -> String {
    format!(
        "// Lanes of a team that shares one item's rows (grid_common.wgsl, team_row).\n\
         const TEAM_LANES: u32 = {lanes}u;\n"
    )
}

/// Lanes per item on a GPU in the passes that run a team of threads per particle or
/// grain, each lane summing every `TEAM_LANES`-th of the item's (2R + 1)² rows
/// (`team_row` in `shaders/grid_common.wgsl`): Adami's boundary pressure (per wall or
/// marker particle) and the grains' passes (per grain: solid fraction, pressure force,
/// sampling, reaction spread). Sums of integer counts are unchanged by the split; float
/// sums are added in lane order by the team's first lane, so runs still repeat bit for
/// bit at any lane count. One thread per item left such a pass, over a few thousand
/// items, bound by the latency of each thread's ~300 dependent loads: on an H200
/// (2026-11-29, `results/2026-11-29-h200-2/grains-bench.txt`) the grain columns' 2 883
/// wall particles took 0.245 ms a step, half the time of the rates of their 41 323 fluid
/// particles (0.509 ms), where on lavapipe, which has no latency to hide, they took 6 %.
/// 8 lanes give 3–4 rows each at R = 2.
pub const TEAM_LANES_GPU: u32 = 8;

/// Lanes per item on a CPU adapter (lavapipe). A CPU core runs a workgroup's threads
/// one after another and has no load latency for a team to hide, so a team only adds
/// the workgroup-memory sum and its barrier: the small dam break with boxes (`couplet
/// bench scenes/dam-break-boxes.toml --spacing 0.02 --steps 50`, 7 296 wall and 600
/// fluid particles) spends 14.1–14.5 ms a step in the boundary pass with 8 lanes and
/// 7.3 ms with 1, 20.0–21.5 and 13.5–15.3 ms a step in all (2026-11-30, Mesa 25.0.7,
/// 2 vCPU, runs alternated).
pub const TEAM_LANES_CPU: u32 = 1;

/// The environment variable that overrides the lanes per item of the team passes
/// ([`team_lanes_for`]), for measuring them on a machine without a rebuild. Results do
/// not depend on the lanes beyond round-off (the order of the float sums); speed does.
pub const TEAM_LANES_ENV: &str = "COUPLET_TEAM_LANES";

/// The lanes per item an adapter of `device_type` runs the team passes with, unless
/// [`TEAM_LANES_ENV`] sets them: [`TEAM_LANES_CPU`] on a CPU adapter, else
/// [`TEAM_LANES_GPU`].
pub fn team_lanes_for(device_type: wgpu::DeviceType) -> u32 {
    match device_type {
        wgpu::DeviceType::Cpu => TEAM_LANES_CPU,
        _ => TEAM_LANES_GPU,
    }
}

/// Whether `lanes` may run the team passes: at least one, and a divisor of
/// `WORKGROUP_SIZE`, so that no team straddles two workgroups (its lanes share
/// workgroup memory).
pub fn team_lanes_valid(lanes: u32) -> bool {
    lanes >= 1 && crate::shaders::WORKGROUP_SIZE.is_multiple_of(lanes)
}
const _: () = assert!(crate::shaders::WORKGROUP_SIZE.is_multiple_of(TEAM_LANES_GPU));
const _: () = assert!(crate::shaders::WORKGROUP_SIZE.is_multiple_of(TEAM_LANES_CPU));

/// Threads a team pass of `lanes` lanes per item is dispatched with for `n` items.
pub fn team_threads(n: u32, lanes: u32) -> u32 {
    n * lanes
}

/// Threads the dense team passes (those over every fluid particle: the fused rates,
/// `fluid_rates.wgsl`) aim to dispatch: about twice what an H100 or H200 holds at once
/// (132 multiprocessors × 2 048 threads = 270 k), so that the GPU has other warps to run
/// while one waits on its neighbours' loads. A chosen figure, not a measured one: the
/// grain columns' 41 323 fluid particles, one thread each, spent 0.51 ms a step in the
/// rates on an H200 (2026-11-29), twice what 2 883 wall particles spent in a pass of
/// the same loop, where the work is 14 times less: the pass waited on latency, not
/// arithmetic. 5.4 M particles, one thread each, made 8.6e10 pair-interactions/s there
/// (README, "Measured on a GPU"): there a team would only add its sums.
pub const DENSE_TEAM_THREADS: u64 = 1 << 19;

/// Lanes per fluid particle in the dense team passes for `n` particles, at most `cap`
/// (the device's team lanes, `Gpu::team_lanes`, a power of two as every divisor of
/// `WORKGROUP_SIZE` is): `cap` halved while half as many lanes still give
/// [`DENSE_TEAM_THREADS`] threads, so 1 from 524 288 particles on, and `cap` (8 on a
/// GPU) below 131 072; on a CPU adapter `cap` is 1.
pub fn dense_team_lanes(n: usize, cap: u32) -> u32 {
    let mut lanes = cap.max(1);
    while lanes > 1 && n as u64 * u64::from(lanes / 2) >= DENSE_TEAM_THREADS {
        lanes /= 2;
    }
    lanes
}

/// The environment variable that sets the lanes per particle of the dense team passes
/// outright ([`dense_team_lanes`] otherwise), for measuring them on a GPU without a
/// rebuild. Results do not depend on the lanes beyond round-off; speed does.
pub const DENSE_LANES_ENV: &str = "COUPLET_DENSE_LANES";

/// WGSL of a dense team pass of `lanes` lanes per particle: `DENSE_LANES` and
/// `dense_team_sum(v, lid)`, the sum of `v` over the team of the workgroup's thread
/// `lid`, added in lane order (so that runs repeat bit for bit), valid in the team's
/// first lane. Every thread of the workgroup must call it the same number of times, in
/// uniform control flow (it holds two barriers). With one lane it is `v`, no barrier
/// and no workgroup memory, and the pass is the one-thread-per-particle loop it was.
pub fn dense_team_wgsl(lanes: u32) -> String {
    let sum = if lanes == 1 {
        "fn dense_team_sum(v: vec4<f32>, lid: u32) -> vec4<f32> {
    return v;
}
"
    } else {
        "var<workgroup> dense_team_part: array<vec4<f32>, WORKGROUP_SIZE>;
fn dense_team_sum(v: vec4<f32>, lid: u32) -> vec4<f32> {
    // The first barrier keeps this call's writes off the last call's reads.
    workgroupBarrier();
    dense_team_part[lid] = v;
    workgroupBarrier();
    var s = v;
    if lid % DENSE_LANES == 0u {
        for (var l = 1u; l < DENSE_LANES; l++) {
            s += dense_team_part[lid + l];
        }
    }
    return s;
}
"
    };
    format!(
        "// Lanes per fluid particle of the dense team passes (neighbour_grid.rs, dense_team_lanes).
const DENSE_LANES: u32 = {lanes}u;
{sum}"
    )
}

/// Longest cell slice the `grid: order` pass orders (each of its k slots counts over
/// the slice: O(k²) in all, at most this many loop iterations per thread, far below
/// the 65535 at which lavapipe cuts a shader's loops short). A cell of
/// support/R holds a few particles (about 2 at support 2.4 δ and R = 2, 8 at 4 δ);
/// a slice this long means the fluid has collapsed or particles outside the grid were
/// sorted into a border cell — both reported by the host — and it keeps the atomics'
/// order rather than stalling the GPU on a quadratic sort of a blown-up state.
pub const GRID_ORDER_MAX_SLICE: u32 = 1024;

/// Uniform of the grid (WGSL mirror: `GridParams` in grid_common.wgsl). Every vec4's
/// `[3]` is unused (0).
#[repr(C)]
#[derive(bytemuck::Pod, bytemuck::Zeroable, Clone, Copy, Debug, PartialEq)]
pub struct GridParams {
    /// Lower corner of the grid.
    pub origin: [f32; 4],
    /// Cell edge per axis: support/R (R the grid's reach, [`grid_reach_for`]), or on a
    /// periodic axis the period over a whole number of cells (at least that).
    pub cell_size: [f32; 4],
    pub inv_cell_size: [f32; 4],
    /// Cells per axis.
    pub dims: [u32; 4],
    /// Period per axis (m); 0 on an axis that is not periodic.
    pub period: [f32; 4],
    /// 1/period; 0 on an axis that is not periodic (so that the minimum image
    /// `r − period · round(r / period)` leaves it alone without a branch).
    pub inv_period: [f32; 4],
    pub n_particles: u32,
    pub n_cells: u32,
    pub _pad: [u32; 2],
}

// WGSL uniform layout: six vec4 at 0..96, two scalars, padded to 112.
const _: () = {
    assert!(std::mem::size_of::<GridParams>() == 112);
    assert!(std::mem::offset_of!(GridParams, origin) == 0);
    assert!(std::mem::offset_of!(GridParams, cell_size) == 16);
    assert!(std::mem::offset_of!(GridParams, inv_cell_size) == 32);
    assert!(std::mem::offset_of!(GridParams, dims) == 48);
    assert!(std::mem::offset_of!(GridParams, period) == 64);
    assert!(std::mem::offset_of!(GridParams, inv_period) == 80);
    assert!(std::mem::offset_of!(GridParams, n_particles) == 96);
    assert!(std::mem::offset_of!(GridParams, n_cells) == 100);
};

/// The box a grid covers: particles live in `[min, max]`; on a periodic axis that
/// interval is one period, positions are wrapped into it at every sort and pairs see
/// each other's nearest image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridBox {
    pub min: [f64; 3],
    pub max: [f64; 3],
    pub periodic: [bool; 3],
}

impl GridBox {
    /// A box with no periodic axis.
    pub fn closed(min: [f64; 3], max: [f64; 3]) -> GridBox {
        GridBox {
            min,
            max,
            periodic: [false; 3],
        }
    }
}

/// The first particle found outside the grid (WGSL mirror in neighbour_grid.wgsl).
#[repr(C)]
#[derive(bytemuck::Pod, bytemuck::Zeroable, Clone, Copy, Debug, Default)]
struct GridErrorRecord {
    outside_count: u32,
    index: u32,
    id: u32,
    _pad: u32,
    position: [f32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<GridErrorRecord>() == 32);
    assert!(std::mem::offset_of!(GridErrorRecord, position) == 16);
};

/// Why a grid cannot be built, a buffer registered, or a sort is invalid.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error(
        "grid box min {min:?} / max {max:?} is invalid: need finite values with min < max on every axis"
    )]
    InvalidBox { min: [f64; 3], max: [f64; 3] },
    #[error(
        "periodic axis {axis} is {length} m long, shorter than {need} m: a period must hold \
         2R + 1 = {cells} cells of at least support/R ({support} m / R) for R = {reach}, the \
         grid's reach here, and for R = {GRID_REACH_CPU} and R = {GRID_REACH_GPU}, the \
         defaults of a CPU adapter and a GPU, so that no pair is seen through two images \
         and a scene runs on any machine whatever COUPLET_GRID_REACH says; lengthen the \
         domain along that axis or reduce the support",
        axis = ["x", "y", "z"][*axis], cells = 2 * reach + 1
    )]
    PeriodTooShort {
        axis: usize,
        length: f64,
        need: f64,
        support: f64,
        reach: u32,
    },
    #[error(
        "grid support radius {support_radius} is invalid: need a finite value > 0 (the kernel support radius)"
    )]
    InvalidSupport { support_radius: f64 },
    #[error(
        "grid reach {reach} is invalid: need {} to {} cells per support radius",
        GRID_REACH_RANGE.start(), GRID_REACH_RANGE.end()
    )]
    InvalidReach { reach: u32 },
    #[error("a neighbour grid needs at least one particle (n = 0)")]
    NoParticles,
    #[error(
        "grid of {dims:?} cells ({n_cells} in all) is too large: the adapter binds at most \
         {max} cells (max storage buffer binding size); use a larger cell size or a smaller box"
    )]
    TooManyCells {
        dims: [u64; 3],
        n_cells: u64,
        max: u64,
    },
    #[error(
        "{n} particles need {bytes} bytes of scratch, more than the adapter's max storage \
         buffer binding size of {max} bytes"
    )]
    TooManyParticles { n: u32, bytes: u64, max: u64 },
    #[error("cannot register buffer `{buffer}` with the grid: {reason}")]
    BadBuffer { buffer: String, reason: String },
    #[error(
        "{} at ({}, {}, {}) is outside the neighbour grid [{:?}, {:?}] (non-finite, or beyond \
         the box padded by one support radius); {outside} particle sort(s) found outside \
         since the last reset",
        match id { Some(id) => format!("particle id {id} (slot {index} before the sort)"),
                   None => format!("particle in slot {index} before the sort (no id buffer registered)") },
        position[0], position[1], position[2], grid_min, grid_max
    )]
    ParticleOutside {
        /// Original particle id, when an id buffer was registered with `register_ids`.
        id: Option<u32>,
        /// Index in the particle arrays at the sort that found it.
        index: u32,
        position: [f32; 3],
        /// Outside particles counted over all sorts since the last reset.
        outside: u32,
        grid_min: [f32; 3],
        grid_max: [f32; 3],
    },
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    PrefixSum(#[from] PrefixSumError),
}

struct Registered {
    buffer: wgpu::Buffer,
    /// 16-byte (vec4) elements, else 4-byte.
    wide: bool,
}

/// Registered buffers a `grid: reorder` pass gathers at most: the bindings every adapter
/// couplet accepts offers ([`crate::gpu::MIN_STORAGE_BUFFERS_PER_STAGE`]) less the
/// gather map and the scratch, the same on every adapter so that the passes do not
/// depend on it.
///
/// Why passes of many buffers: with one pass and one copy per buffer through one shared
/// scratch, every pass waited for the copy before it, and on an H200 the stage cost
/// 0.147 ms of the 1.1 ms of GPU stages of the Rayleigh–Taylor column's step (47 k
/// particles, 9 buffers: 13.3 %; 13.7 % on the constant-porosity block), where moving
/// its 2.5 MB takes about a microsecond. Gathering several buffers a pass, each into its
/// own slice, leaves 2 passes, and the copies back wait on nothing but them.
pub const GATHER_BUFFERS_PER_PASS: usize = crate::gpu::MIN_STORAGE_BUFFERS_PER_STAGE as usize - 2;

/// One `grid: reorder` pass: `members` (indices into the registered buffers, all of one
/// element size) gathered into consecutive slices of `scratch`, slice k at k ×
/// `slice_bytes`. `scratch` is the grid's own, or a lent buffer when `lent`.
struct GatherPass {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    scratch: wgpu::Buffer,
    lent: bool,
    members: Vec<usize>,
    slice_bytes: u64,
}

/// A buffer lent to the reorder as scratch ([`NeighbourGrid::lend_scratch`]).
struct Lent {
    buffer: wgpu::Buffer,
    bytes_per_particle: u64,
}

/// The grid's buffers, pipelines and registered particle arrays.
pub struct NeighbourGrid {
    pub params: GridParams,
    /// `GridParams` uniform.
    pub params_buffer: wgpu::Buffer,
    /// n_cells + 1 u32: particles of cell c are `cell_start[c]..cell_start[c+1]` after
    /// the sort (also the counters during it).
    pub cell_start: wgpu::Buffer,
    /// 32-byte record of the first particle found outside (see [`NeighbourGrid::check`]).
    pub error_flag: wgpu::Buffer,
    cell_of: wgpu::Buffer,
    rank: wgpu::Buffer,
    /// Read only by the tests (the bind group holds it for the passes).
    #[cfg_attr(not(test), allow(dead_code))]
    unordered: wgpu::Buffer,
    src_of: wgpu::Buffer,
    /// Stand-in for the id buffer until one is registered.
    no_ids: wgpu::Buffer,
    ids: Option<wgpu::Buffer>,
    prefix_sum: PrefixSum,

    grid_layout: wgpu::BindGroupLayout,
    grid_bind_group: wgpu::BindGroup,
    params_bind_group: wgpu::BindGroup,
    count_layout: wgpu::BindGroupLayout,
    params_layout: wgpu::BindGroupLayout,
    scatter_bind_group: wgpu::BindGroup,

    count: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    order: wgpu::ComputePipeline,
    /// The grid's reach R, for the gather passes' WGSL.
    reach: u32,

    registered: Vec<Registered>,
    /// Buffers the caller lends the reorder as scratch, in the order lent.
    lent: Vec<Lent>,
    /// The reorder's passes over `registered`, built by the first sort after a
    /// registration or a loan ([`NeighbourGrid::reorder_passes`]).
    gather_passes: std::sync::OnceLock<Vec<GatherPass>>,
}

fn storage_buffer(gpu: &Gpu, label: &str, bytes: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(4),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn bad_buffer(buffer: &wgpu::Buffer, reason: String) -> GridError {
    GridError::BadBuffer {
        buffer: format!("{buffer:?}"),
        reason,
    }
}

fn sized(buffer: &wgpu::Buffer, bytes: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: NonZeroU64::new(bytes),
    })
}

fn bind(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    entries: &[(u32, wgpu::BindingResource<'_>)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: resource.clone(),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

impl NeighbourGrid {
    /// Bytes of the grid's buffers that scale with its cells, not its particles:
    /// `cell_start` and the scan's block totals.
    pub fn cell_bytes(&self) -> u64 {
        self.cell_start.size() + self.prefix_sum.scratch_bytes()
    }

    /// Grid for `n` particles with cells of `support_radius / reach` (R, see
    /// [`grid_reach_for`]; the pair kernels' `GRID_REACH` must be the same), over
    /// [min − pad, max + pad] on a closed axis, pad = one support radius (R cells:
    /// particles may drift slightly past the domain — wall layers, a step's overshoot
    /// before the boundary pushes back — without an error), and over exactly [min, max)
    /// in a whole number of cells (each at least that size, at least 2R + 1 of them) on
    /// a periodic axis. A period must also hold the 2R + 1 cells of both defaults,
    /// [`GRID_REACH_CPU`] (2.5 supports) and [`GRID_REACH_GPU`] (7/3), so that a scene's
    /// acceptance depends neither on the machine nor on `COUPLET_GRID_REACH`.
    pub fn new(
        gpu: &Gpu,
        bounds: GridBox,
        support_radius: f64,
        reach: u32,
        n: u32,
    ) -> Result<Self, GridError> {
        let GridBox { min, max, periodic } = bounds;
        if !(support_radius.is_finite() && support_radius > 0.0) {
            return Err(GridError::InvalidSupport { support_radius });
        }
        if !GRID_REACH_RANGE.contains(&reach) {
            return Err(GridError::InvalidReach { reach });
        }
        let cell_min = support_radius / f64::from(reach);
        if (0..3).any(|a| !(min[a].is_finite() && max[a].is_finite() && min[a] < max[a])) {
            return Err(GridError::InvalidBox { min, max });
        }
        if n == 0 {
            return Err(GridError::NoParticles);
        }
        let max_binding = gpu.storage_binding_limit;
        let pad = support_radius;
        let mut origin = [0.0f64; 3];
        let mut cell_size = [cell_min; 3];
        let mut dims64 = [0u64; 3];
        for a in 0..3 {
            let length = max[a] - min[a];
            if periodic[a] {
                // Whole cells over one period, no padding: cells of at least support/R;
                // `fits(r)`: 2r + 1 whole cells of support/r fit in the period.
                let fits = |r: u32| {
                    (length * f64::from(r) / support_radius).floor() as u64 >= u64::from(2 * r + 1)
                };
                let reaches = [reach, GRID_REACH_CPU, GRID_REACH_GPU];
                if !reaches.iter().all(|&r| fits(r)) {
                    let need = |r: u32| f64::from(2 * r + 1) / f64::from(r);
                    let most = reaches.iter().map(|&r| need(r)).fold(0.0, f64::max);
                    return Err(GridError::PeriodTooShort {
                        axis: a,
                        length,
                        need: most * support_radius,
                        support: support_radius,
                        reach,
                    });
                }
                let cells = (length / cell_min).floor() as u64;
                origin[a] = min[a];
                cell_size[a] = length / cells as f64;
                dims64[a] = cells;
            } else {
                origin[a] = min[a] - pad;
                // floor + 1 (not ceil): a particle exactly on max + pad still has a cell.
                dims64[a] = ((length + 2.0 * pad) / cell_min).floor() as u64 + 1;
            }
        }
        let n_cells64 = dims64.iter().product::<u64>();
        let max_cells = (max_binding / 4)
            .saturating_sub(1)
            .min(u64::from(u32::MAX) - 1);
        if n_cells64 > max_cells {
            return Err(GridError::TooManyCells {
                dims: dims64,
                n_cells: n_cells64,
                max: max_cells,
            });
        }
        let scratch_bytes = u64::from(n) * 16;
        if scratch_bytes > max_binding {
            return Err(GridError::TooManyParticles {
                n,
                bytes: scratch_bytes,
                max: max_binding,
            });
        }
        let n_cells = n_cells64 as u32;
        let vec4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
        let period: [f64; 3] =
            std::array::from_fn(|a| if periodic[a] { max[a] - min[a] } else { 0.0 });
        let params = GridParams {
            origin: vec4(origin),
            cell_size: vec4(cell_size),
            inv_cell_size: vec4(cell_size.map(|c| 1.0 / c)),
            dims: [dims64[0] as u32, dims64[1] as u32, dims64[2] as u32, 0],
            period: vec4(period),
            inv_period: vec4(period.map(|l| if l > 0.0 { 1.0 / l } else { 0.0 })),
            n_particles: n,
            n_cells,
            _pad: [0; 2],
        };
        let params_buffer = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("grid: params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        let cell_start = storage_buffer(gpu, "grid: cell_start", (u64::from(n_cells) + 1) * 4);
        let error_flag = storage_buffer(gpu, "grid: error record", 32);
        let cell_of = storage_buffer(gpu, "grid: cell of particle", u64::from(n) * 4);
        let rank = storage_buffer(gpu, "grid: rank in cell", u64::from(n) * 4);
        let unordered = storage_buffer(gpu, "grid: slots in atomics' order", u64::from(n) * 4);
        let src_of = storage_buffer(gpu, "grid: gather map", u64::from(n) * 4);
        let no_ids = storage_buffer(gpu, "grid: no id buffer", 4);
        let prefix_sum = PrefixSum::new(gpu, &cell_start, n_cells + 1)?;

        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries,
                })
        };
        use shaders::{storage_entry as st, uniform_entry as un};
        let grid_layout = layout("grid (group 1)", &[un(0), st(1, true)]);
        let params_layout = layout("grid params (group 1)", &[un(0)]);
        let count_layout = layout(
            "grid: count",
            &[
                st(0, false),
                st(1, false),
                st(2, false),
                st(3, false),
                st(4, false),
                st(5, true),
            ],
        );
        let scatter_layout = layout(
            "grid: scatter",
            &[st(10, true), st(11, true), st(12, false), st(13, false)],
        );

        let cells_bytes = (u64::from(n_cells) + 1) * 4;
        let grid_bind_group = bind(
            gpu,
            "grid (group 1)",
            &grid_layout,
            &[
                (0, params_buffer.as_entire_binding()),
                (1, sized(&cell_start, cells_bytes)),
            ],
        );
        let params_bind_group = bind(
            gpu,
            "grid params (group 1)",
            &params_layout,
            &[(0, params_buffer.as_entire_binding())],
        );
        let n_bytes = u64::from(n) * 4;
        let scatter_bind_group = bind(
            gpu,
            "grid: scatter",
            &scatter_layout,
            &[
                (10, sized(&cell_of, n_bytes)),
                (11, sized(&rank, n_bytes)),
                (12, sized(&unordered, n_bytes)),
                (13, sized(&src_of, n_bytes)),
            ],
        );

        let max_slice = format!("const ORDER_MAX_SLICE: u32 = {GRID_ORDER_MAX_SLICE}u;\n");
        let sort_module = shaders::module(
            gpu,
            "grid: sort",
            &[
                &grid_reach_wgsl(reach),
                GRID_COMMON_WGSL,
                &max_slice,
                NEIGHBOUR_GRID_WGSL,
            ],
        );
        let count = shaders::compute_pipeline_with_layouts(
            gpu,
            "grid: count",
            &sort_module,
            "count_cells",
            &[Some(&count_layout), Some(&params_layout)],
        );
        let scatter = shaders::compute_pipeline_with_layouts(
            gpu,
            "grid: scatter",
            &sort_module,
            "scatter",
            &[Some(&scatter_layout), Some(&grid_layout)],
        );
        let order = shaders::compute_pipeline_with_layouts(
            gpu,
            "grid: order",
            &sort_module,
            "order_slots",
            &[Some(&scatter_layout), Some(&grid_layout)],
        );

        Ok(NeighbourGrid {
            params,
            params_buffer,
            cell_start,
            error_flag,
            cell_of,
            rank,
            unordered,
            src_of,
            no_ids,
            ids: None,
            prefix_sum,
            grid_layout,
            grid_bind_group,
            params_bind_group,
            count_layout,
            params_layout,
            scatter_bind_group,
            count,
            scatter,
            order,
            reach,
            registered: Vec::new(),
            lent: Vec::new(),
            gather_passes: std::sync::OnceLock::new(),
        })
    }

    /// Layout of group 1 (grid) for pair kernels: binding 0 = `GridParams` uniform,
    /// binding 1 = `cell_start` (read-only storage).
    pub fn bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.grid_layout
    }

    /// The group-1 bind group matching [`NeighbourGrid::bind_group_layout`].
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.grid_bind_group
    }

    pub fn n_particles(&self) -> u32 {
        self.params.n_particles
    }

    /// Lower and upper corner of the grid (particles outside are an error).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let p = &self.params;
        let lo = [p.origin[0], p.origin[1], p.origin[2]];
        let hi = std::array::from_fn(|a| lo[a] + p.dims[a] as f32 * p.cell_size[a]);
        (lo, hi)
    }

    /// Number of buffers each sort permutes.
    pub fn registered(&self) -> usize {
        self.registered.len()
    }

    /// Registers a per-particle buffer (`STORAGE | COPY_DST` usage, at least n × `elem_bytes`
    /// bytes, `elem_bytes` 16 for vec4 or 4 for f32/u32) to be permuted by every sort.
    /// After `queue_sort` the caller's buffer holds the sorted data. `pos` must be
    /// registered too.
    pub fn register(&mut self, buffer: &wgpu::Buffer, elem_bytes: u32) -> Result<(), GridError> {
        if elem_bytes != 16 && elem_bytes != 4 {
            return Err(bad_buffer(
                buffer,
                format!("element size {elem_bytes} bytes; valid: 16 (vec4) or 4 (f32/u32)"),
            ));
        }
        self.check_particle_buffer(buffer, wgpu::BufferUsages::COPY_DST, elem_bytes)?;
        self.registered.push(Registered {
            buffer: buffer.clone(),
            wide: elem_bytes == 16,
        });
        self.gather_passes = std::sync::OnceLock::new();
        Ok(())
    }

    /// Checks a buffer offered to [`NeighbourGrid::register`] or
    /// [`NeighbourGrid::lend_scratch`]: `STORAGE` and `copy` usage, room for n ×
    /// `bytes_per_particle` bytes, and neither registered nor lent already.
    fn check_particle_buffer(
        &self,
        buffer: &wgpu::Buffer,
        copy: wgpu::BufferUsages,
        bytes_per_particle: u32,
    ) -> Result<(), GridError> {
        let needs = wgpu::BufferUsages::STORAGE | copy;
        if !buffer.usage().contains(needs) {
            return Err(bad_buffer(
                buffer,
                format!("usage {:?} lacks {needs:?}", buffer.usage()),
            ));
        }
        let n = self.params.n_particles;
        let bytes = u64::from(n) * u64::from(bytes_per_particle);
        if bytes_per_particle == 0 || buffer.size() < bytes {
            return Err(bad_buffer(
                buffer,
                format!(
                    "{} bytes, but {n} particles × {bytes_per_particle} bytes need {bytes}",
                    buffer.size()
                ),
            ));
        }
        if self.registered.iter().any(|r| r.buffer == *buffer) {
            return Err(bad_buffer(buffer, "it is registered already".into()));
        }
        if self.lent.iter().any(|l| l.buffer == *buffer) {
            return Err(bad_buffer(
                buffer,
                "it is lent to the reorder as scratch, which a sort overwrites".into(),
            ));
        }
        Ok(())
    }

    /// Registers the particles' original-id buffer (`u32`): it is permuted like any
    /// registered buffer, and [`GridError::ParticleOutside`] names particles by it.
    pub fn register_ids(&mut self, ids: &wgpu::Buffer) -> Result<(), GridError> {
        self.register(ids, 4)?;
        self.ids = Some(ids.clone());
        Ok(())
    }

    /// Lends the reorder a per-particle buffer (`STORAGE | COPY_SRC` usage, at least n ×
    /// `bytes_per_particle` bytes) to gather into instead of scratch of its own: a
    /// reorder pass whose slices fit in it (its buffers' element size × their count ≤
    /// `bytes_per_particle`) uses it, the pass needing the most first, each lent buffer
    /// for one pass. The caller promises that no reader needs the buffer's contents
    /// across a sort: every sort leaves other buffers' data in it, and whatever reads it
    /// after a sort must have written it since. A registered buffer cannot be lent.
    pub fn lend_scratch(
        &mut self,
        buffer: &wgpu::Buffer,
        bytes_per_particle: u32,
    ) -> Result<(), GridError> {
        self.check_particle_buffer(buffer, wgpu::BufferUsages::COPY_SRC, bytes_per_particle)?;
        self.lent.push(Lent {
            buffer: buffer.clone(),
            bytes_per_particle: u64::from(bytes_per_particle),
        });
        self.gather_passes = std::sync::OnceLock::new();
        Ok(())
    }

    /// Bytes of scratch the reorder's passes hold of their own (not lent), once a sort
    /// has built them (`None` before the first sort after a registration or a loan).
    pub fn reorder_scratch_bytes(&self) -> Option<u64> {
        (self.gather_passes.get()).map(|passes| {
            (passes.iter())
                .filter(|g| !g.lent)
                .map(|g| g.slice_bytes * g.members.len() as u64)
                .sum()
        })
    }

    /// Records the sort (see the module doc): five labelled compute passes, timed when
    /// `timer` is given. `pos` (vec4, xyz used) must be one of the registered buffers
    /// so that it ends up sorted as well.
    pub fn queue_sort(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        pos: &wgpu::Buffer,
        mut timer: Option<&mut StageTimer>,
    ) {
        let n = self.params.n_particles;
        let n_bytes = u64::from(n) * 4;
        let ids = self.ids.as_ref().unwrap_or(&self.no_ids);
        let ids_bytes = if self.ids.is_some() { n_bytes } else { 4 };
        let count_bind_group = bind(
            gpu,
            "grid: count",
            &self.count_layout,
            &[
                (0, sized(pos, u64::from(n) * 16)),
                (1, self.cell_start.as_entire_binding()),
                (2, sized(&self.cell_of, n_bytes)),
                (3, sized(&self.rank, n_bytes)),
                (4, self.error_flag.as_entire_binding()),
                (5, sized(ids, ids_bytes)),
            ],
        );
        encoder.clear_buffer(&self.cell_start, 0, None);
        {
            let mut pass = timing::begin_pass(timer.as_deref_mut(), gpu, encoder, "grid: count");
            pass.set_pipeline(&self.count);
            pass.set_bind_group(0, &count_bind_group, &[]);
            pass.set_bind_group(1, &self.params_bind_group, &[]);
            shaders::dispatch_linear(&mut pass, n);
        }
        {
            let mut pass = timing::begin_pass(timer.as_deref_mut(), gpu, encoder, "grid: scan");
            self.prefix_sum.record(&mut pass);
        }
        self.queue_scatter_and_order(gpu, encoder, timer.as_deref_mut());
        if !self.registered.is_empty() {
            // Gather into the scratch slices, then plain buffer copies back: a copy is a
            // memcpy for the driver (lavapipe, 262k particles, 4 buffers: the stage
            // went from 68 ms with a copy kernel to 23 ms). Every gather before any
            // copy: the gathers share only the map they read, and each copy waits only
            // for its own pass.
            let passes = self
                .gather_passes
                .get_or_init(|| self.build_gather_passes(gpu));
            timing::begin_span(timer.as_deref_mut(), gpu, encoder, "grid: reorder");
            for g in passes {
                let mut pass = timing::begin_pass(None, gpu, encoder, "grid: reorder");
                pass.set_pipeline(&g.pipeline);
                pass.set_bind_group(0, &g.bind_group, &[]);
                pass.set_bind_group(1, &self.params_bind_group, &[]);
                shaders::dispatch_linear(&mut pass, n);
            }
            for g in passes {
                for (k, &r) in g.members.iter().enumerate() {
                    encoder.copy_buffer_to_buffer(
                        &g.scratch,
                        k as u64 * g.slice_bytes,
                        &self.registered[r].buffer,
                        0,
                        g.slice_bytes,
                    );
                }
            }
            timing::end_span(timer, gpu, encoder);
        }
    }

    /// The element sizes (16 or 4 bytes) and buffer counts of the reorder's passes, in
    /// order, once a sort has built them (`None` before the first sort after a
    /// registration or a loan).
    pub fn reorder_passes(&self) -> Option<Vec<(u32, usize)>> {
        let n = u64::from(self.params.n_particles);
        (self.gather_passes.get()).map(|passes| {
            (passes.iter())
                .map(|g| ((g.slice_bytes / n) as u32, g.members.len()))
                .collect()
        })
    }

    /// The reorder's passes: the 16-byte buffers, then the 4-byte ones, each in
    /// registration order and in passes of up to [`GATHER_BUFFERS_PER_PASS`], fewer where
    /// their slices would pass the adapter's largest storage binding (at least one:
    /// [`NeighbourGrid::new`] checked that a 16-byte slice fits). Each pass gathers into
    /// the smallest lent buffer it fits, the passes needing the most choosing first, or
    /// into scratch of its own; a loan left over that holds a 16-byte slice takes as
    /// many as it holds off a 16-byte pass with scratch of its own, as a pass of their
    /// own.
    fn build_gather_passes(&self, gpu: &Gpu) -> Vec<GatherPass> {
        let n = u64::from(self.params.n_particles);
        let max_binding = gpu.storage_binding_limit;
        let elem_bytes = |wide: bool| if wide { 16 } else { 4 };
        let mut plan: Vec<(bool, Vec<usize>)> = Vec::new();
        for wide in [true, false] {
            let slice_bytes = n * elem_bytes(wide);
            let per_pass = GATHER_BUFFERS_PER_PASS.min((max_binding / slice_bytes).max(1) as usize);
            let members: Vec<usize> = (0..self.registered.len())
                .filter(|&r| self.registered[r].wide == wide)
                .collect();
            plan.extend(members.chunks(per_pass).map(|c| (wide, c.to_vec())));
        }
        // Bytes a particle of each pass's scratch.
        let need: Vec<u64> = (plan.iter())
            .map(|(wide, members)| members.len() as u64 * elem_bytes(*wide))
            .collect();
        let mut by_need: Vec<usize> = (0..plan.len()).collect();
        by_need.sort_by_key(|&k| std::cmp::Reverse(need[k]));
        let mut free: Vec<usize> = (0..self.lent.len()).collect();
        free.sort_by_key(|&l| self.lent[l].bytes_per_particle);
        let mut scratch_of: Vec<Option<usize>> = vec![None; plan.len()];
        for k in by_need {
            if let Some(at) =
                (free.iter()).position(|&l| self.lent[l].bytes_per_particle >= need[k])
            {
                scratch_of[k] = Some(free.remove(at));
            }
        }
        // A loan too small for any whole pass still takes the 16-byte buffers it holds,
        // split off the largest 16-byte pass that has scratch of its own: one pass more
        // for at least 16 B a particle less (Antuono's δ-SPH lends its ∇ρ slot, 16 B,
        // which then takes one of the standard three; ARCHITECTURE.md, "GPU memory per
        // particle"). Largest loan first.
        for &l in free.iter().rev() {
            let fits = (self.lent[l].bytes_per_particle / 16) as usize;
            if fits == 0 {
                continue;
            }
            let own = (0..plan.len())
                .filter(|&k| plan[k].0 && scratch_of[k].is_none() && plan[k].1.len() > 1)
                .max_by_key(|&k| plan[k].1.len());
            let Some(k) = own else {
                break;
            };
            // fits < the pass's members: a loan holding them all took the whole pass.
            let members = &mut plan[k].1;
            let tail = members.split_off(members.len() - fits.min(members.len() - 1));
            plan.insert(k + 1, (true, tail));
            scratch_of.insert(k + 1, Some(l));
        }
        (plan.into_iter().zip(scratch_of))
            .map(|((wide, members), lent)| {
                let lent = lent.map(|l| &self.lent[l].buffer);
                self.gather_pass(gpu, wide, members, n * elem_bytes(wide), lent)
            })
            .collect()
    }

    /// One reorder pass over `members` (all of one element size): its WGSL (reorder.wgsl
    /// with a binding and a line per member), pipeline, scratch (`lent`, or its own) and
    /// bind group.
    fn gather_pass(
        &self,
        gpu: &Gpu,
        wide: bool,
        members: Vec<usize>,
        slice_bytes: u64,
        lent: Option<&wgpu::Buffer>,
    ) -> GatherPass {
        let elem = if wide { "vec4<u32>" } else { "u32" };
        let mut inputs = format!("alias Elem = {elem};\n");
        let mut body =
            String::from("fn gather_members(j: u32, s: u32) {\n    let n = grid.n_particles;\n");
        for k in 0..members.len() {
            inputs += &format!(
                "@group(0) @binding({}) var<storage, read> reorder_in{k}: array<Elem>;\n",
                k + 2
            );
            body += &format!("    reorder_out[{k}u * n + j] = reorder_in{k}[s];\n");
        }
        body += "}\n";
        let module = shaders::module(
            gpu,
            "grid: reorder",
            &[
                &inputs,
                &grid_reach_wgsl(self.reach),
                GRID_COMMON_WGSL,
                REORDER_WGSL,
                &body,
            ],
        );
        use shaders::storage_entry as st;
        let entries: Vec<wgpu::BindGroupLayoutEntry> = [st(0, true), st(1, false)]
            .into_iter()
            .chain((0..members.len()).map(|k| st(k as u32 + 2, true)))
            .collect();
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("grid: reorder"),
                entries: &entries,
            });
        let pipeline = shaders::compute_pipeline_with_layouts(
            gpu,
            "grid: reorder",
            &module,
            "gather",
            &[Some(&layout), Some(&self.params_layout)],
        );
        let scratch_bytes = slice_bytes * members.len() as u64;
        let scratch = match lent {
            Some(b) => b.clone(),
            None => storage_buffer(gpu, "grid: reorder scratch", scratch_bytes),
        };
        let map_bytes = u64::from(self.params.n_particles) * 4;
        let bindings: Vec<(u32, wgpu::BindingResource<'_>)> = [
            (0, sized(&self.src_of, map_bytes)),
            (1, sized(&scratch, scratch_bytes)),
        ]
        .into_iter()
        .chain(
            (members.iter().enumerate())
                .map(|(k, &r)| (k as u32 + 2, sized(&self.registered[r].buffer, slice_bytes))),
        )
        .collect();
        let bind_group = bind(gpu, "grid: reorder", &layout, &bindings);
        GatherPass {
            pipeline,
            bind_group,
            scratch,
            lent: lent.is_some(),
            members,
            slice_bytes,
        }
    }

    /// Records passes 3 and 4 of the sort: from `cell_of`, `rank` and `cell_start` to the
    /// stable gather map `src_of`.
    fn queue_scatter_and_order(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut StageTimer>,
    ) {
        let n = self.params.n_particles;
        for (label, pipeline) in [
            ("grid: scatter", &self.scatter),
            ("grid: order", &self.order),
        ] {
            let mut pass = timing::begin_pass(timer.as_deref_mut(), gpu, encoder, label);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.scatter_bind_group, &[]);
            pass.set_bind_group(1, &self.grid_bind_group, &[]);
            shaders::dispatch_linear(&mut pass, n);
        }
    }

    /// Reads the error record (waits for the GPU): `Err(ParticleOutside)` naming the
    /// first particle any sort since the last [`NeighbourGrid::reset_error`] found
    /// outside the grid. Nothing is clamped silently: such a particle was sorted into
    /// the nearest cell only to keep the permutation whole.
    pub fn check(&self, gpu: &Gpu) -> Result<(), GridError> {
        let [record] = gpu.read_buffers([self.error_record()])?;
        self.check_record(&record)
    }

    /// The range of the error record, `(buffer, offset, bytes)` as [`Gpu::read_buffers`]
    /// takes it, for a caller that reads it with other buffers and passes its bytes to
    /// [`NeighbourGrid::check_record`].
    pub fn error_record(&self) -> (&wgpu::Buffer, u64, u64) {
        (
            &self.error_flag,
            0,
            std::mem::size_of::<GridErrorRecord>() as u64,
        )
    }

    /// [`NeighbourGrid::check`] on the bytes of [`NeighbourGrid::error_record`].
    ///
    /// # Panics
    /// If `record` is not that range's size (32 bytes): a caller's mistake, not a state.
    pub fn check_record(&self, record: &[u8]) -> Result<(), GridError> {
        let rec: GridErrorRecord = bytemuck::pod_read_unaligned(record);
        if rec.outside_count == 0 {
            return Ok(());
        }
        let (grid_min, grid_max) = self.bounds();
        Err(GridError::ParticleOutside {
            id: self.ids.as_ref().map(|_| rec.id),
            index: rec.index,
            position: [rec.position[0], rec.position[1], rec.position[2]],
            outside: rec.outside_count,
            grid_min,
            grid_max,
        })
    }

    /// Clears the error record (after reporting it, or before a fresh start).
    pub fn reset_error(&self, gpu: &Gpu) {
        gpu.queue.write_buffer(
            &self.error_flag,
            0,
            bytemuck::bytes_of(&GridErrorRecord::default()),
        );
    }

    /// The gather map of the last sort (sorted slot → slot before the sort), for tests.
    pub fn gather_map(&self) -> &wgpu::Buffer {
        &self.src_of
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shared_test_gpu;

    /// What an adapter type takes by default: the team lanes (one on a CPU adapter, where
    /// a team only adds its sum and barrier; `TEAM_LANES_GPU` elsewhere) and the grid's
    /// reach (cells of support/2 on a CPU adapter, where R = 3 made whole runs no faster;
    /// support/3 elsewhere, 25–46 % faster on an H200), and the counts
    /// `COUPLET_TEAM_LANES` may set: the divisors of the workgroup size (128), so that no
    /// team straddles two workgroups. Reference: the definitions above and the tables in
    /// `GRID_REACH_GPU`'s and `GRID_REACH_CPU`'s documentation.
    #[test]
    fn adapter_defaults_and_the_team_counts_allowed() {
        assert_eq!(team_lanes_for(wgpu::DeviceType::Cpu), 1);
        assert_eq!(grid_reach_for(wgpu::DeviceType::Cpu), 2);
        for t in [
            wgpu::DeviceType::DiscreteGpu,
            wgpu::DeviceType::IntegratedGpu,
            wgpu::DeviceType::VirtualGpu,
            wgpu::DeviceType::Other,
        ] {
            assert_eq!(team_lanes_for(t), 8, "{t:?}");
            assert_eq!(grid_reach_for(t), 3, "{t:?}");
        }
        assert!(GRID_REACH_RANGE.contains(&GRID_REACH_CPU));
        assert!(GRID_REACH_RANGE.contains(&GRID_REACH_GPU));
        let allowed: Vec<u32> = (0..=300).filter(|&l| team_lanes_valid(l)).collect();
        assert_eq!(allowed, [1, 2, 4, 8, 16, 32, 64, 128]);
        assert_eq!(team_threads(1000, 8), 8000);
    }

    /// The dense passes' lanes by particle count: a GPU's 8 below 2^19 / 4 = 131 072
    /// particles, then halved at each doubling of the count, 1 from 524 288 on (the grain
    /// columns' 44 206 particles: 8; the cavity's 112 360: 8; SPHERIC-2's 1.04 M: 1), and
    /// never more than the device's team lanes (1 on lavapipe). Reference: the rule in
    /// `dense_team_lanes`'s documentation, counted by hand.
    #[test]
    fn dense_lanes_fall_as_the_particles_fill_the_gpu() {
        let cases = [
            (44_206, 8),
            (112_360, 8),
            (131_071, 8),
            (131_072, 4),
            (262_143, 4),
            (262_144, 2),
            (524_287, 2),
            (524_288, 1),
            (1_044_444, 1),
        ];
        for (n, lanes) in cases {
            assert_eq!(dense_team_lanes(n, TEAM_LANES_GPU), lanes, "{n} particles");
            assert_eq!(dense_team_lanes(n, TEAM_LANES_CPU), 1, "{n} particles, CPU");
        }
        assert_eq!(dense_team_lanes(1000, 2), 2);
        assert_eq!(dense_team_lanes(1000, 0), 1);
    }

    /// Regression: the order pass was an insertion sort, one thread per cell. Where the
    /// atomics left a cell's slice far from its previous order (a lavapipe worker
    /// thread delayed during `grid: count`), the sort needed more than the 65535 loop
    /// iterations lavapipe allows a shader and stopped half way: CI saw cells of about
    /// 560 particles with 2 of ~100 inversions left. Here the worst case is set up
    /// directly: one cell of 1000 particles (below GRID_ORDER_MAX_SLICE) whose ranks
    /// are the reverse of their indices (499 500 insertion-sort moves), next to a cell
    /// of one particle and empty cells. Reference: the stable order is 0..n (exact).
    #[test]
    fn grid_sort_is_stable_in_cells_far_from_sorted() {
        let gpu = shared_test_gpu().unwrap();
        let n = 1001u32;
        let grid = NeighbourGrid::new(
            &gpu,
            GridBox::closed([0.0; 3], [1.0; 3]),
            0.25,
            gpu.grid_reach(),
            n,
        )
        .unwrap();
        let big = 1000u32;
        assert!(big <= GRID_ORDER_MAX_SLICE);
        let nc = grid.params.n_cells;
        let lone_cell = nc - 1;
        let cell_of: Vec<u32> = (0..n)
            .map(|i| if i < big { 0 } else { lone_cell })
            .collect();
        let rank: Vec<u32> = (0..n)
            .map(|i| if i < big { big - 1 - i } else { 0 })
            .collect();
        let cell_start: Vec<u32> = (0..=nc)
            .map(|c| match c {
                0 => 0,
                c if c <= lone_cell => big,
                _ => n,
            })
            .collect();
        gpu.queue
            .write_buffer(&grid.cell_of, 0, bytemuck::cast_slice(&cell_of));
        gpu.queue
            .write_buffer(&grid.rank, 0, bytemuck::cast_slice(&rank));
        gpu.queue
            .write_buffer(&grid.cell_start, 0, bytemuck::cast_slice(&cell_start));
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        grid.queue_scatter_and_order(&gpu, &mut encoder, None);
        gpu.queue.submit([encoder.finish()]);

        let unordered: Vec<u32> = gpu.read_buffer(&grid.unordered, 0, u64::from(n)).unwrap();
        assert_eq!(unordered[0], big - 1, "scatter must follow the ranks");
        let src_of: Vec<u32> = gpu.read_buffer(grid.gather_map(), 0, u64::from(n)).unwrap();
        let misplaced: Vec<usize> = (0..n as usize).filter(|&s| src_of[s] != s as u32).collect();
        assert!(
            misplaced.is_empty(),
            "{} of {n} slots out of their stable order, first {:?}",
            misplaced.len(),
            &misplaced[..misplaced.len().min(8)]
        );
    }
}
