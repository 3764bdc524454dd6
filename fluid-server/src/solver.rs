//! The fluid solver: standard WCSPH on the GPU, one window at a time.
//!
//! [`SphPipelines`] (compiled kernels, built once from the scene) and [`SphData`] (the
//! buffers of one particle set, with its neighbour grid and bound kernels) are joined
//! by [`FluidSolver::queue_step`], one predictor–corrector step made of labelled compute
//! passes:
//!
//! ```text
//! marker_update?  grid sort  smoothing_lengths?  gradients? │ boundary pressure  fluid_rates  marker_loads?  predict
//!                                                           │ boundary pressure  fluid_rates  marker_loads?  correct
//!                                                           │ shift?  body_ or wall_non_penetration?  advance_clock?
//! ```
//!
//! and, once per window, `reduce_body_loads?` and the blow-up check. Stages switched off
//! by the scene (see [`crate::plan::stages`]) are compiled out or not dispatched, and
//! marker buffers exist only once markers do. No buffer is allocated and nothing is
//! read back inside a step. Positions live on the GPU relative to the domain centre
//! (DESIGN.md, "Numbers on the GPU").
//!
//! `gradients` (Joubert eq. 10 and the corrected ∇u, ∇p; [`crate::joubert2020_gradients`])
//! runs with the gradient correction or particle shifting; its B matrix enters the
//! continuity and pressure terms of `fluid_rates` (eqs. 12–13). The boundary pass is
//! Adami's extrapolation, or with `domain.wall_model = "joubert"` Joubert's Neumann
//! values (eqs. 25, 27; [`crate::joubert2020_boundary_values`]) at walls and markers.
//! With the gradient correction the marker loads' velocity gradient takes a one-sided
//! B ([`crate::joubert2020_body_loads`]). A fluid particle that ends a step behind a
//! body's surface (with markers) or a wall face is mirrored back and counted
//! ([`crate::body_non_penetration`]).

use crate::checkpoint::{self, FluidState};
use crate::constants::{SphConstants, StepParams};
use crate::gpu::Gpu;
use crate::joubert2020_boundary_values::BoundaryFrame;
use crate::joubert2020_gradients::GradientFields;
use crate::limits::FluidLimits;
use crate::marker_update::AccelerationEstimate;
use crate::marker_update::{
    BodyAcceleration, Clock, GpuBody, GpuMarker, marker_mass, point_acceleration,
};
use crate::neighbour_grid::{GridBox, NeighbourGrid};
use crate::particles::{Kind, ParticleKinds, ParticleSet, initial_particles, wall_layers};
use crate::plan::Stage;
use crate::sph_kernel::{
    BODIES, BoundKernel, PARAMS, PARTICLES, SphKernel, body_binding as bb, param_binding as qb,
    particle_binding as pb,
};
use crate::timing::{self, StageTimer};
use crate::window_stats::WindowStats;
use crate::{
    adami2012_boundary_pressure, blowup_check, body_load_reduce, body_non_penetration, fluid_rates,
    fluid_rows, integrate, joubert2020_body_loads, joubert2020_boundary_values,
    joubert2020_gradients, marker_update, neighbour_count, particle_shifting, plan,
    robinson_variable_h, tait_eos, window_stats,
};
use couplet_protocol::{BodyLoad, BodyState, CouplingPoint, ParticleRecord, Scene};
use wgpu::util::DeviceExt;

pub use crate::error::FluidError;

/// Particles per kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ParticleCounts {
    pub fluid: u32,
    pub wall: u32,
    /// Sum of the coupling points given to [`FluidSolver::set_bodies`] (0 before).
    pub markers: u32,
}

/// Window sum of one marker's (force, moment), N and N·m.
pub type MarkerLoad = ([f64; 3], [f64; 3]);

/// One stage of a step, for tests and benchmarks that run stages one by one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    TaitEos,
    MarkerUpdate,
    Sort,
    BoundaryPressure,
    FluidRates,
    MarkerLoads,
    Predict,
    Correct,
    AdvanceClock,
    ReduceBodyLoads,
    /// The gradient pass (absent without correction and shifting).
    Gradients,
    /// Particle shifting (absent without it).
    Shift,
    /// The grains' reaction joins du/dt (absent without two-way grains).
    GrainReaction,
    /// Robinson's (h, Ω) per particle (absent without variable h).
    SmoothingLengths,
    /// Fluid behind a body's surface or a wall face mirrored back (absent without
    /// markers).
    NonPenetration,
}

/// Kernels of the marker coupling (compiled only for scenes with resolved bodies, or at
/// the first `set_bodies`).
pub struct MarkerPipelines {
    marker_update: SphKernel,
    advance_clock: SphKernel,
    marker_loads: SphKernel,
    reduce: SphKernel,
    non_penetration: SphKernel,
    /// Adami's boundary pass with fill points extrapolated from one side, bound in place
    /// of `SphPipelines::boundary_pressure` once bodies exist (absent with Joubert's
    /// walls, whose bodies have no fill).
    boundary_pressure_fill: Option<SphKernel>,
    /// Particle shifting that keeps fluid off the surfaces, bound in place of
    /// `SphPipelines::shift` once bodies exist (absent without shifting).
    shift_near_surfaces: Option<SphKernel>,
}

/// The compiled kernels of a scene (no data).
pub struct SphPipelines {
    tait_eos: SphKernel,
    fluid_rows: SphKernel,
    boundary_pressure: SphKernel,
    fluid_rates: SphKernel,
    predict: SphKernel,
    correct: SphKernel,
    find_bad: SphKernel,
    capture_bad: SphKernel,
    window_stats: SphKernel,
    neighbour_count: SphKernel,
    gradients: Option<SphKernel>,
    shift: Option<SphKernel>,
    smoothing_lengths: Option<SphKernel>,
    grain_reaction: Option<SphKernel>,
    /// Fluid kept inside the wall faces where no marker pass does it (a scene without
    /// resolved bodies that has a wall face).
    wall_non_penetration: Option<SphKernel>,
    markers: Option<MarkerPipelines>,
}

impl SphPipelines {
    fn new(
        gpu: &Gpu,
        c: &SphConstants,
        grid_layout: &wgpu::BindGroupLayout,
        with_markers: bool,
    ) -> Self {
        SphPipelines {
            tait_eos: tait_eos::kernel(gpu, c),
            fluid_rows: fluid_rows::kernel(gpu, c, grid_layout),
            boundary_pressure: if c.joubert_walls {
                joubert2020_boundary_values::kernel(gpu, c, grid_layout)
            } else {
                adami2012_boundary_pressure::kernel(gpu, c, grid_layout, false)
            },
            fluid_rates: fluid_rates::kernel(gpu, c, grid_layout),
            predict: integrate::predict_kernel(gpu, c),
            correct: integrate::correct_kernel(gpu, c),
            find_bad: blowup_check::find_kernel(gpu, c),
            capture_bad: blowup_check::capture_kernel(gpu, c),
            window_stats: window_stats::kernel(gpu, c),
            neighbour_count: neighbour_count::kernel(gpu, c, grid_layout),
            gradients: c
                .gradient_pass()
                .then(|| joubert2020_gradients::kernel(gpu, c, grid_layout)),
            shift: (c.shifting_beta > 0.0).then(|| particle_shifting::kernel(gpu, c, None)),
            smoothing_lengths: c
                .variable_h
                .is_some()
                .then(|| robinson_variable_h::kernel(gpu, c, grid_layout)),
            grain_reaction: c
                .grain_reaction
                .then(|| crate::unresolved_coupling::add_kernel(gpu, c)),
            wall_non_penetration: (!with_markers && c.has_wall_face())
                .then(|| body_non_penetration::wall_kernel(gpu, c)),
            markers: with_markers.then(|| MarkerPipelines::new(gpu, c, grid_layout)),
        }
    }
}

impl MarkerPipelines {
    fn new(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> Self {
        MarkerPipelines {
            marker_update: marker_update::marker_update_kernel(gpu, c),
            advance_clock: marker_update::advance_clock_kernel(gpu, c),
            marker_loads: joubert2020_body_loads::kernel(gpu, c, grid_layout),
            reduce: body_load_reduce::kernel(gpu, c),
            non_penetration: body_non_penetration::kernel(gpu, c, grid_layout),
            boundary_pressure_fill: (!c.joubert_walls)
                .then(|| adami2012_boundary_pressure::kernel(gpu, c, grid_layout, true)),
            shift_near_surfaces: (c.shifting_beta > 0.0)
                .then(|| particle_shifting::kernel(gpu, c, Some(grid_layout))),
        }
    }
}

/// Buffers of the marker coupling.
pub struct BodyBuffers {
    pub markers_in: wgpu::Buffer,
    pub bodies: wgpu::Buffer,
    pub clock: wgpu::Buffer,
    pub marker_load: wgpu::Buffer,
    pub marker_load_c: wgpu::Buffer,
    pub load_ranges: wgpu::Buffer,
    pub body_loads: wgpu::Buffer,
    /// Entries of `bodies` (body indices it can hold).
    pub body_capacity: usize,
}

struct BoundMarkers {
    marker_update: BoundKernel,
    advance_clock: BoundKernel,
    marker_loads: BoundKernel,
    reduce: BoundKernel,
    non_penetration: BoundKernel,
}

struct Bound {
    tait_eos: BoundKernel,
    fluid_rows: BoundKernel,
    boundary_pressure: BoundKernel,
    fluid_rates: BoundKernel,
    predict: BoundKernel,
    correct: BoundKernel,
    find_bad: BoundKernel,
    capture_bad: BoundKernel,
    window_stats: BoundKernel,
    gradients: Option<BoundKernel>,
    shift: Option<BoundKernel>,
    smoothing_lengths: Option<BoundKernel>,
    grain_reaction: Option<BoundKernel>,
    wall_non_penetration: Option<BoundKernel>,
    markers: Option<BoundMarkers>,
}

/// The buffers of one particle set (struct of arrays, permuted by the grid every step),
/// its neighbour grid and its bound kernels.
pub struct SphData {
    pub kinds: ParticleKinds,
    pub n_total: u32,
    /// vec4<f32>: xyz position relative to the solver origin, m; w the particle's mass, kg.
    pub pos: wgpu::Buffer,
    /// vec4<f32>: xyz velocity, m/s.
    pub vel: wgpu::Buffer,
    pub rho: wgpu::Buffer,
    pub press: wgpu::Buffer,
    /// Original id (kind by range).
    pub id: wgpu::Buffer,
    pub drho: wgpu::Buffer,
    /// du/dt of the last rate evaluation (permuted by the sort only in scenes with
    /// grains, whose sampling reads it after a sort).
    pub dvel: wgpu::Buffer,
    /// ρⁿ and uⁿ during a step (written by `predict`, not permuted); `vel_n.w` holds
    /// Δt dρⁿ/dt for `correct`.
    pub rho_n: wgpu::Buffer,
    pub vel_n: wgpu::Buffer,
    /// The low words of the fluid's positions (xyz) and densities (w): what f32 rounded
    /// off, carried into the next step (`integrate.wgsl`; permuted by the sort).
    pub low_words: wgpu::Buffer,
    pub params: wgpu::Buffer,
    pub status: wgpu::Buffer,
    pub bad_values: wgpu::Buffer,
    /// The window's telemetry, one vec4 per workgroup ([`crate::window_stats`]).
    pub stats_partials: wgpu::Buffer,
    pub grid: NeighbourGrid,
    /// The fluid in each grid cell's row window (one u32 per cell, written after every
    /// sort; [`crate::fluid_rows`]), which the boundary passes read to skip rows.
    pub row_fluid: wgpu::Buffer,
    pub bodies: Option<BodyBuffers>,
    /// The gradient pass's outputs (see [`crate::joubert2020_gradients`]); only with
    /// the gradient correction or particle shifting.
    pub gradients: Option<GradientBuffers>,
    /// No-slip walls' velocity in the viscous sums (one vec4 per particle; written by
    /// the boundary pass after every sort, so not permuted, and lent to the reorder as
    /// scratch), when a viscous term meets no-slip walls
    /// ([`SphConstants::wall_velocity_extrapolation`]).
    pub wall_vel: Option<wgpu::Buffer>,
    /// Joubert boundaries' frames ([`BoundaryFrame`]: walls from
    /// [`joubert2020_boundary_values::wall_frames`], then the markers', rewritten by
    /// every [`FluidSolver::set_bodies`]), only with `domain.wall_model = "joubert"`.
    pub boundary_frame: Option<wgpu::Buffer>,
    /// The grains' solid fraction per particle (u32 counts of 2^-31, permuted; Robinson
    /// eq. 9), in scenes with grains.
    pub solid: Option<wgpu::Buffer>,
    /// ∇ε per particle (i32 counts, four per particle, permuted), with
    /// `coupling.porosity_pressure = "energy-pair"`.
    pub solid_grad: Option<wgpu::Buffer>,
    /// The grains' reaction per particle (permuted), with two-way grains.
    pub reaction: Option<crate::unresolved_coupling::ReactionBuffers>,
    /// (h_i, Ω_i) of Robinson's variable smoothing length, one vec2 per particle
    /// (written after every sort, not permuted), with variable h.
    pub smoothing: Option<wgpu::Buffer>,
    bound: Bound,
    /// The lanes per item the team passes in `bound` were compiled with
    /// (`SphConstants::team_lanes`), which their dispatches must match.
    team_lanes: u32,
    /// The lanes per particle the dense team passes in `bound` were compiled with
    /// (`SphConstants::dense_lanes`).
    dense_lanes: u32,
}

/// Buffers of the gradient pass (not permuted: written after every sort).
pub struct GradientBuffers {
    /// Three vec4 columns of B_i per particle, where the rates read B (`fields.store_b`;
    /// else 16 bytes).
    pub bmat: wgpu::Buffer,
    /// Of ⟨∇u_x⟩ᶜ, ⟨∇u_y⟩ᶜ, ⟨∇u_z⟩ᶜ, ⟨∇p⟩ᶜ, s_i, ⟨∇ρ⟩ᶜ those the scene reads: `fields.stride()`
    /// vec4 per particle (16 bytes when none is).
    pub grads: wgpu::Buffer,
    /// B̂_i of the corrected Laplacian, two vec4 per particle, when it is on.
    pub bhat: Option<wgpu::Buffer>,
    /// [max fluid speed of the step (f32 bits), near-singular particle-steps in the
    /// window, 0, 0].
    pub diag: wgpu::Buffer,
    /// What the buffers hold.
    pub fields: GradientFields,
}

const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// The widest of the solver's per-particle buffers and its bytes a particle: the state's
/// vec4 arrays, or the gradient pass's B and packed slots where the scene keeps them
/// (`SphData::new` allocates them). One storage binding must hold it for every particle.
fn widest_particle_buffer(fields: GradientFields, gradient_pass: bool) -> (&'static str, u64) {
    let pass = |bytes: u64| if gradient_pass { bytes } else { 0 };
    [
        ("sph: pos", 16),
        ("sph: B matrix", pass(fields.b_bytes())),
        ("sph: corrected gradients", pass(fields.slot_bytes())),
    ]
    .into_iter()
    .reduce(|a, b| if b.1 > a.1 { b } else { a })
    .unwrap_or(("sph: pos", 16))
}

/// A storage buffer holding `bytes`, refused when one binding cannot hold it (every
/// buffer here is bound whole; wgpu would panic).
fn storage_init(gpu: &Gpu, label: &str, bytes: &[u8]) -> Result<wgpu::Buffer, FluidError> {
    let limit = gpu.storage_binding_limit;
    if bytes.len() as u64 > limit {
        return Err(FluidError::TooLarge {
            what: format!("the GPU buffer `{label}`"),
            needed: bytes.len() as u64,
            limit,
        });
    }
    // Bindings need a non-empty buffer: an empty array still gets 16 bytes.
    let mut contents = bytes.to_vec();
    if contents.len() < 16 {
        contents.resize(16, 0);
    }
    Ok(gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &contents,
            usage: STORAGE,
        }))
}

/// A storage buffer of `stride` bytes for each of `n` particles, zeroed (WebGPU zeroes
/// every new buffer), refused with the most particles one binding holds at this stride
/// when it cannot hold `n` (ARCHITECTURE.md, "GPU memory per particle").
fn particle_buffer(
    gpu: &Gpu,
    label: &str,
    n: usize,
    stride: u64,
) -> Result<wgpu::Buffer, FluidError> {
    let limit = gpu.storage_binding_limit;
    let bytes = n as u64 * stride;
    // (A stride of 0, a buffer the scene never reads, still binds its 16 bytes.)
    if bytes > limit {
        return Err(FluidError::TooManyParticles {
            n,
            buffer: label.to_owned(),
            stride,
            limit,
            max: limit / stride,
        });
    }
    Ok(gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16),
        usage: STORAGE,
        mapped_at_creation: false,
    }))
}

fn vec4s(v: &[[f64; 3]]) -> Vec<[f32; 4]> {
    v.iter()
        .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32, 0.0])
        .collect()
}

/// An internal error: a kernel's binding has no buffer.
pub(crate) fn missing(what: &str) -> FluidError {
    FluidError::Grid {
        step: 0,
        message: format!("internal: kernel binding for {what} is missing"),
    }
}

impl SphData {
    /// Uploads `set` (positions relative to the origin already) and builds its grid
    /// over `bounds` (relative).
    fn new(
        gpu: &Gpu,
        c: &SphConstants,
        pipelines: &SphPipelines,
        set: &ParticleSet,
        wall_frames: &[BoundaryFrame],
        bounds: GridBox,
        body_capacity: usize,
    ) -> Result<SphData, FluidError> {
        let n = set.len();
        for (what, got) in [
            ("vel", set.vel.len()),
            ("rho", set.rho.len()),
            ("press", set.press.len()),
            ("mass", set.mass.len()),
            ("id", set.id.len()),
        ] {
            if got != n {
                return Err(FluidError::BadParticleSet {
                    what,
                    got,
                    expected: n,
                });
            }
        }
        if set.kinds.total() != n {
            return Err(FluidError::BadParticleSet {
                what: "kinds (fluid + wall + markers)",
                got: set.kinds.total(),
                expected: n,
            });
        }
        // The widest per-particle buffer first, so that a scene too large for one
        // binding learns the most particles it may have.
        let fields = GradientFields::of(c);
        let gradient_pass = pipelines.gradients.is_some();
        let (widest, stride) = widest_particle_buffer(fields, gradient_pass);
        let limit = gpu.storage_binding_limit;
        if n as u64 * stride > limit {
            return Err(FluidError::TooManyParticles {
                n,
                buffer: widest.into(),
                stride,
                limit,
                max: limit / stride,
            });
        }
        let f32s = |v: &[f64]| v.iter().map(|x| *x as f32).collect::<Vec<f32>>();
        // pos.w carries the particle's mass.
        let pos_mass: Vec<[f32; 4]> = (set.pos.iter().zip(&set.mass))
            .map(|(p, m)| [p[0] as f32, p[1] as f32, p[2] as f32, *m as f32])
            .collect();
        let pos = storage_init(gpu, "sph: pos", bytemuck::cast_slice(&pos_mass))?;
        let vel = storage_init(gpu, "sph: vel", bytemuck::cast_slice(&vec4s(&set.vel)))?;
        let rho = storage_init(gpu, "sph: rho", bytemuck::cast_slice(&f32s(&set.rho)))?;
        let press = storage_init(gpu, "sph: press", bytemuck::cast_slice(&f32s(&set.press)))?;
        let id = storage_init(gpu, "sph: id", bytemuck::cast_slice(&set.id))?;
        let drho = particle_buffer(gpu, "sph: drho", n, 4)?;
        let dvel = particle_buffer(gpu, "sph: dvel", n, 16)?;
        let rho_n = particle_buffer(gpu, "sph: rho_n", n, 4)?;
        let vel_n = particle_buffer(gpu, "sph: vel_n", n, 16)?;
        let low_words = particle_buffer(gpu, "sph: position and density low words", n, 16)?;
        let step_params = StepParams {
            n_total: n as u32,
            n_fluid: set.kinds.n_fluid as u32,
            n_wall: set.kinds.n_wall as u32,
            n_markers: set.kinds.n_markers as u32,
            gravity: StepParams::gravity_of(c.gravity_fluid),
            ..Default::default()
        };
        let params = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sph: step params"),
                contents: bytemuck::bytes_of(&step_params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        let status = storage_init(
            gpu,
            "sph: blow-up status",
            // [bad id, near-singular counts ×2, particles kept out of bodies, shifts cut
            // short in front of a body].
            bytemuck::cast_slice(&[
                blowup_check::NO_BAD_ID,
                blowup_check::NO_BAD_ID,
                blowup_check::NO_BAD_ID,
                0,
                0,
            ]),
        )?;
        let bad_values = storage_init(gpu, "sph: blow-up values", &[0u8; 48])?;
        let stats_partials = storage_init(
            gpu,
            "sph: window stats partials",
            &vec![0u8; window_stats::partials_bytes(n as u32) as usize],
        )?;

        let mut grid = NeighbourGrid::new(gpu, bounds, c.grid_radius(), c.grid_reach, n as u32)?;
        grid.register(&pos, 16)?;
        grid.register(&vel, 16)?;
        grid.register(&rho, 4)?;
        grid.register(&press, 4)?;
        grid.register_ids(&id)?;
        grid.register(&low_words, 16)?;
        // uⁿ is written by `predict` before `correct` reads it, every step after the
        // sort, so the reorder may gather into it (the 4-byte buffers, 12 or 16 B a
        // particle, need no scratch of their own).
        grid.lend_scratch(&vel_n, 16)?;
        let row_fluid = storage_init(
            gpu,
            "sph: fluid per row window",
            &vec![0u8; grid.params.n_cells as usize * 4],
        )?;
        let solid = c
            .grains
            .then(|| particle_buffer(gpu, "sph: grain solid fraction", n, 4))
            .transpose()?;
        if let Some(s) = &solid {
            // Grains are sampled after a sort, from the rates of the step before it; the
            // porosity is set once per window.
            grid.register(&dvel, 16)?;
            grid.register(s, 4)?;
        }
        let solid_grad = c
            .porosity_pair
            .then(|| particle_buffer(gpu, "sph: grain porosity gradient", n, 16))
            .transpose()?;
        if let Some(s) = &solid_grad {
            grid.register(s, 16)?;
        }
        let reaction = c
            .grain_reaction
            .then(|| -> Result<_, FluidError> {
                Ok(crate::unresolved_coupling::ReactionBuffers {
                    lo: particle_buffer(gpu, "sph: grain reaction (low words)", n, 16)?,
                    hi: particle_buffer(gpu, "sph: grain reaction (high words)", n, 16)?,
                })
            })
            .transpose()?;
        if let Some(r) = &reaction {
            grid.register(&r.lo, 16)?;
            grid.register(&r.hi, 16)?;
        }

        let gradients = gradient_pass
            .then(|| -> Result<_, FluidError> {
                // Only the fields the scene reads (at most 96 B a particle), and B only
                // where the rates read it (48 B): a binding of 16 B where none is.
                let (slots, b) = (fields.slot_bytes(), fields.b_bytes());
                Ok(GradientBuffers {
                    grads: particle_buffer(gpu, "sph: corrected gradients", n, slots)?,
                    bmat: particle_buffer(gpu, "sph: B matrix", n, b)?,
                    bhat: c
                        .uses_b_hat()
                        .then(|| particle_buffer(gpu, "sph: Laplacian truncation", n, 32))
                        .transpose()?,
                    diag: storage_init(gpu, "sph: gradient diagnostics", &[0u8; 16])?,
                    fields,
                })
            })
            .transpose()?;
        if let Some(g) = &gradients {
            // B and the gradient slots are written by the gradient pass after every
            // sort, for every fluid particle, before anything reads them (the rates read
            // a neighbour's slots only where it is fluid): the reorder's 16-byte buffers
            // (48 B a particle in the standard scheme's three) may gather into either, or
            // as many of them as the slots hold (δ-SPH's one slot: the low words).
            if g.fields.store_b {
                grid.lend_scratch(&g.bmat, 48)?;
            }
            if g.fields.slot_bytes() > 0 {
                grid.lend_scratch(&g.grads, g.fields.slot_bytes() as u32)?;
            }
        }
        let smoothing = c
            .variable_h
            .is_some()
            .then(|| particle_buffer(gpu, "sph: smoothing lengths", n, 8))
            .transpose()?;
        let wall_vel = c
            .wall_velocity_extrapolation
            .then(|| particle_buffer(gpu, "sph: wall velocity", n, 16))
            .transpose()?;
        if let Some(w) = &wall_vel {
            // The boundary pass writes every wall's entry, in both halves of every step,
            // before the rates read it (at walls only): dead at a sort. With nothing
            // larger lent it takes one of the standard 16-byte buffers (16 B a particle).
            grid.lend_scratch(w, 16)?;
        }
        let boundary_frame = c.joubert_walls.then(|| {
            // Markers' frames are written by every set_bodies.
            let mut frames = wall_frames.to_vec();
            frames.resize(
                set.kinds.n_wall + set.kinds.n_markers,
                BoundaryFrame::default(),
            );
            storage_init(gpu, "sph: boundary frames", bytemuck::cast_slice(&frames))
        });
        let boundary_frame = boundary_frame.transpose()?;
        let bodies = (set.kinds.n_markers > 0)
            .then(|| -> Result<_, FluidError> {
                let m = set.kinds.n_markers;
                let cap = body_capacity.max(1);
                Ok(BodyBuffers {
                    markers_in: storage_init(gpu, "sph: markers in", &vec![0u8; m * 48])?,
                    bodies: storage_init(gpu, "sph: bodies", &vec![0u8; cap * 32])?,
                    clock: storage_init(gpu, "sph: clock", &[0u8; 16])?,
                    marker_load: storage_init(gpu, "sph: marker load", &vec![0u8; m * 32])?,
                    marker_load_c: storage_init(
                        gpu,
                        "sph: marker load compensation",
                        &vec![0u8; m * 32],
                    )?,
                    load_ranges: storage_init(gpu, "sph: load ranges", &vec![0u8; cap * 16])?,
                    body_loads: storage_init(gpu, "sph: body loads", &vec![0u8; cap * 32])?,
                    body_capacity: cap,
                })
            })
            .transpose()?;

        let bound = {
            let particle = |b: u32| -> Option<&wgpu::Buffer> {
                Some(match b {
                    pb::POS => &pos,
                    pb::VEL => &vel,
                    pb::RHO => &rho,
                    pb::PRESS => &press,
                    pb::ID => &id,
                    pb::DRHO => &drho,
                    pb::DVEL => &dvel,
                    pb::RHO_N => &rho_n,
                    pb::VEL_N => &vel_n,
                    pb::LOW_WORDS => &low_words,
                    pb::BMAT => &gradients.as_ref()?.bmat,
                    pb::GRADS => &gradients.as_ref()?.grads,
                    pb::WALL_VEL => wall_vel.as_ref()?,
                    pb::BOUNDARY_FRAME => boundary_frame.as_ref()?,
                    pb::BHAT => gradients.as_ref()?.bhat.as_ref()?,
                    pb::SOLID => solid.as_ref()?,
                    pb::SOLID_GRAD => solid_grad.as_ref()?,
                    pb::ROW_FLUID => &row_fluid,
                    pb::SMOOTHING => smoothing.as_ref()?,
                    pb::REACTION_LO => &reaction.as_ref()?.lo,
                    pb::REACTION_HI => &reaction.as_ref()?.hi,
                    _ => return None,
                })
            };
            let resolve = |g: u32, b: u32| -> Option<&wgpu::Buffer> {
                match g {
                    PARTICLES => particle(b),
                    BODIES => {
                        let bb_ = bodies.as_ref()?;
                        Some(match b {
                            bb::MARKERS_IN => &bb_.markers_in,
                            bb::BODIES => &bb_.bodies,
                            bb::CLOCK => &bb_.clock,
                            bb::MARKER_LOAD => &bb_.marker_load,
                            bb::MARKER_LOAD_C => &bb_.marker_load_c,
                            bb::LOAD_RANGES => &bb_.load_ranges,
                            bb::BODY_LOADS => &bb_.body_loads,
                            _ => return None,
                        })
                    }
                    PARAMS => match b {
                        qb::PARAMS => Some(&params),
                        qb::STATUS => Some(&status),
                        qb::BAD_VALUES => Some(&bad_values),
                        qb::PARTIALS => Some(&stats_partials),
                        qb::DIAG => gradients.as_ref().map(|g| &g.diag),
                        _ => None,
                    },
                    _ => None,
                }
            };
            let g = Some(grid.bind_group());
            let p = pipelines;
            let markers = match (&p.markers, &bodies) {
                (Some(m), Some(_)) => Some(BoundMarkers {
                    marker_update: m
                        .marker_update
                        .bind(gpu, resolve, None)
                        .ok_or_else(|| missing("marker_update"))?,
                    advance_clock: m
                        .advance_clock
                        .bind(gpu, resolve, None)
                        .ok_or_else(|| missing("advance_clock"))?,
                    marker_loads: m
                        .marker_loads
                        .bind(gpu, resolve, g)
                        .ok_or_else(|| missing("marker_loads"))?,
                    reduce: m
                        .reduce
                        .bind(gpu, resolve, None)
                        .ok_or_else(|| missing("reduce_body_loads"))?,
                    non_penetration: m
                        .non_penetration
                        .bind(gpu, resolve, g)
                        .ok_or_else(|| missing("body_non_penetration"))?,
                }),
                _ => None,
            };
            Bound {
                tait_eos: p
                    .tait_eos
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("tait_eos"))?,
                fluid_rows: p
                    .fluid_rows
                    .bind(gpu, resolve, g)
                    .ok_or_else(|| missing("fluid_rows"))?,
                boundary_pressure: match (&p.markers, &bodies) {
                    (
                        Some(MarkerPipelines {
                            boundary_pressure_fill: Some(k),
                            ..
                        }),
                        Some(_),
                    ) => k,
                    _ => &p.boundary_pressure,
                }
                .bind(gpu, resolve, g)
                .ok_or_else(|| missing("boundary pressure"))?,
                fluid_rates: p
                    .fluid_rates
                    .bind(gpu, resolve, g)
                    .ok_or_else(|| missing("fluid_rates"))?,
                predict: p
                    .predict
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("predict"))?,
                correct: p
                    .correct
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("correct"))?,
                find_bad: p
                    .find_bad
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("find_bad"))?,
                capture_bad: p
                    .capture_bad
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("capture_bad"))?,
                window_stats: p
                    .window_stats
                    .bind(gpu, resolve, None)
                    .ok_or_else(|| missing("window_stats"))?,
                gradients: match &p.gradients {
                    Some(k) => Some(
                        k.bind(gpu, resolve, g)
                            .ok_or_else(|| missing("gradients"))?,
                    ),
                    None => None,
                },
                shift: match (&p.markers, &bodies, &p.shift) {
                    (
                        Some(MarkerPipelines {
                            shift_near_surfaces: Some(k),
                            ..
                        }),
                        Some(_),
                        _,
                    ) => Some(
                        k.bind(gpu, resolve, g)
                            .ok_or_else(|| missing("particle_shifting (surfaces)"))?,
                    ),
                    (_, _, Some(k)) => Some(
                        k.bind(gpu, resolve, None)
                            .ok_or_else(|| missing("particle_shifting"))?,
                    ),
                    _ => None,
                },
                smoothing_lengths: match &p.smoothing_lengths {
                    Some(k) => Some(
                        k.bind(gpu, resolve, g)
                            .ok_or_else(|| missing("smoothing_lengths"))?,
                    ),
                    None => None,
                },
                grain_reaction: match &p.grain_reaction {
                    Some(k) => Some(
                        k.bind(gpu, resolve, None)
                            .ok_or_else(|| missing("add_grain_reaction"))?,
                    ),
                    None => None,
                },
                wall_non_penetration: match &p.wall_non_penetration {
                    Some(k) => Some(
                        k.bind(gpu, resolve, None)
                            .ok_or_else(|| missing("wall_non_penetration"))?,
                    ),
                    None => None,
                },
                markers,
            }
        };
        Ok(SphData {
            kinds: set.kinds,
            n_total: n as u32,
            pos,
            vel,
            rho,
            press,
            id,
            drho,
            dvel,
            rho_n,
            vel_n,
            low_words,
            params,
            status,
            bad_values,
            stats_partials,
            grid,
            bodies,
            gradients,
            wall_vel,
            boundary_frame,
            solid,
            row_fluid,
            solid_grad,
            reaction,
            smoothing,
            bound,
            team_lanes: c.team_lanes,
            dense_lanes: c.dense_lanes,
        })
    }

    /// Records one stage as a labelled compute pass (nothing when the stage is not
    /// present for this data).
    pub fn queue_op(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut StageTimer>,
        op: Op,
    ) {
        let n = self.n_total;
        let b = &self.bound;
        let m = b.markers.as_ref();
        let (kernel, label): (&BoundKernel, &str) = match op {
            Op::Sort => {
                let mut timer = timer;
                self.grid
                    .queue_sort(gpu, encoder, &self.pos, timer.as_deref_mut());
                let mut pass = timing::begin_pass(timer, gpu, encoder, "sph: fluid_rows");
                b.fluid_rows.dispatch(&mut pass, self.grid.params.n_cells);
                return;
            }
            Op::TaitEos => (&b.tait_eos, "sph: tait_eos"),
            Op::BoundaryPressure => (
                &b.boundary_pressure,
                if self.boundary_frame.is_some() {
                    "sph: joubert2020_boundary_values"
                } else {
                    "sph: adami2012_boundary_pressure"
                },
            ),
            Op::FluidRates => (&b.fluid_rates, "sph: fluid_rates"),
            Op::Predict => (&b.predict, "sph: predict"),
            Op::Gradients => match (&b.gradients, &self.gradients) {
                (Some(k), Some(g)) => {
                    // ‖u‖max is the step's own: reset before the pass.
                    encoder.clear_buffer(&g.diag, 0, Some(4));
                    (k, "sph: joubert2020_gradients")
                }
                _ => return,
            },
            Op::Shift => match &b.shift {
                Some(k) => (k, "sph: particle_shifting"),
                None => return,
            },
            Op::SmoothingLengths => match &b.smoothing_lengths {
                Some(k) => (k, "sph: robinson_variable_h"),
                None => return,
            },
            Op::GrainReaction => match &b.grain_reaction {
                Some(k) => (k, "sph: add_grain_reaction"),
                None => return,
            },
            Op::Correct => (&b.correct, "sph: correct"),
            Op::MarkerUpdate => match m {
                Some(m) => (&m.marker_update, "sph: marker_update"),
                None => return,
            },
            Op::MarkerLoads => match m {
                Some(m) => (&m.marker_loads, "sph: joubert2020_marker_loads"),
                None => return,
            },
            Op::NonPenetration => match (m, &b.wall_non_penetration) {
                (Some(m), _) => (&m.non_penetration, "sph: body_non_penetration"),
                (None, Some(k)) => (k, "sph: wall_non_penetration"),
                (None, None) => return,
            },
            Op::AdvanceClock => {
                if let Some(m) = m {
                    let mut pass = timing::begin_pass(timer, gpu, encoder, "sph: advance_clock");
                    m.advance_clock.dispatch_groups(&mut pass, 1);
                }
                return;
            }
            Op::ReduceBodyLoads => {
                if let Some(m) = m {
                    let groups = self.bodies.as_ref().map_or(0, |b| b.body_capacity as u32);
                    let mut pass =
                        timing::begin_pass(timer, gpu, encoder, "sph: reduce_body_loads");
                    m.reduce.dispatch_groups(&mut pass, groups);
                }
                return;
            }
        };
        let threads = match op {
            Op::BoundaryPressure if self.boundary_frame.is_none() => {
                crate::neighbour_grid::team_threads(n, self.team_lanes)
            }
            Op::FluidRates | Op::Gradients => {
                crate::neighbour_grid::team_threads(n, self.dense_lanes)
            }
            _ => n,
        };
        let mut pass = timing::begin_pass(timer, gpu, encoder, label);
        kernel.dispatch(&mut pass, threads);
    }

    /// Reads the particle arrays back (buffer order, positions relative to the origin).
    pub fn read(&self, gpu: &Gpu) -> Result<ParticleSet, FluidError> {
        let n = u64::from(self.n_total);
        let pos: Vec<[f32; 4]> = gpu.read_buffer(&self.pos, 0, n)?;
        let vel: Vec<[f32; 4]> = gpu.read_buffer(&self.vel, 0, n)?;
        let rho: Vec<f32> = gpu.read_buffer(&self.rho, 0, n)?;
        let press: Vec<f32> = gpu.read_buffer(&self.press, 0, n)?;
        let id: Vec<u32> = gpu.read_buffer(&self.id, 0, n)?;
        let v3 = |v: &[f32; 4]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
        Ok(ParticleSet {
            pos: pos.iter().map(v3).collect(),
            vel: vel.iter().map(v3).collect(),
            rho: rho.iter().map(|x| f64::from(*x)).collect(),
            press: press.iter().map(|x| f64::from(*x)).collect(),
            mass: pos.iter().map(|p| f64::from(p[3])).collect(),
            id,
            kinds: self.kinds,
        })
    }

    /// Reads the rates (buffer order): dρ/dt and du/dt.
    pub fn read_rates(&self, gpu: &Gpu) -> Result<(Vec<f64>, Vec<[f64; 3]>), FluidError> {
        let n = u64::from(self.n_total);
        let drho: Vec<f32> = gpu.read_buffer(&self.drho, 0, n)?;
        let dvel: Vec<[f32; 4]> = gpu.read_buffer(&self.dvel, 0, n)?;
        Ok((
            drho.iter().map(|x| f64::from(*x)).collect(),
            dvel.iter()
                .map(|v| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])])
                .collect(),
        ))
    }

    /// Reads the gradient pass's outputs: `B_i` as rows, `[∇u_x, ∇u_y, ∇u_z, ∇p, s, ∇ρ]`
    /// (zero where the scene reads a field not), and the diagnostics word (max
    /// speed of the last step, near-singular particle-steps of the window). `None` without
    /// the pass.
    pub fn read_gradients(&self, gpu: &Gpu) -> Result<Option<GradientReadback>, FluidError> {
        let Some(g) = &self.gradients else {
            return Ok(None);
        };
        let fields = g.fields;
        let n = u64::from(self.n_total);
        let b: Vec<[f32; 4]> = if fields.store_b {
            gpu.read_buffer(&g.bmat, 0, 3 * n)?
        } else {
            Vec::new()
        };
        let stride = u64::from(fields.stride());
        let f: Vec<[f32; 4]> = gpu.read_buffer(&g.grads, 0, stride * n)?;
        let field = |i: usize, k: usize| {
            fields.slot_of(k).map_or([0.0; 3], |at| {
                let v = f[stride as usize * i + at as usize];
                [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])]
            })
        };
        let with_b = if b.is_empty() { 0 } else { n as usize };
        Ok(Some(GradientReadback {
            // Columns on the GPU, rows here.
            b: (0..with_b)
                .map(|i| {
                    std::array::from_fn(|r| std::array::from_fn(|c| f64::from(b[3 * i + c][r])))
                })
                .collect(),
            fields: (0..n as usize)
                .map(|i| std::array::from_fn(|k| field(i, k)))
                .collect(),
            near_free_surface: (0..with_b).map(|i| b[3 * i][3] > 0.5).collect(),
            diag: self.read_diag(gpu)?.unwrap_or_default(),
        }))
    }

    /// Fluid particles kept out of bodies since the window's start (status[3]; tests).
    pub fn read_reflected(&self, gpu: &Gpu) -> Result<u32, FluidError> {
        Ok(gpu.read_buffer::<u32>(&self.status, 3, 1)?[0])
    }

    /// Shifts cut short in front of a body's surface since the window's start
    /// (status[4]; tests).
    pub fn read_shift_limited(&self, gpu: &Gpu) -> Result<u32, FluidError> {
        Ok(gpu.read_buffer::<u32>(&self.status, 4, 1)?[0])
    }

    /// The gradient pass's diagnostics word, `None` without the pass.
    pub fn read_diag(&self, gpu: &Gpu) -> Result<Option<[u32; 4]>, FluidError> {
        let Some(g) = &self.gradients else {
            return Ok(None);
        };
        let d: Vec<u32> = gpu.read_buffer(&g.diag, 0, 4)?;
        Ok(Some([d[0], d[1], d[2], d[3]]))
    }

    /// Reads the per-marker window sums (force, moment) in marker (DEM) order.
    pub fn read_marker_loads(&self, gpu: &Gpu) -> Result<Vec<MarkerLoad>, FluidError> {
        let Some(b) = &self.bodies else {
            return Ok(Vec::new());
        };
        let m = self.kinds.n_markers as u64;
        let s: Vec<[f32; 4]> = gpu.read_buffer(&b.marker_load, 0, 2 * m)?;
        let c: Vec<[f32; 4]> = gpu.read_buffer(&b.marker_load_c, 0, 2 * m)?;
        let v = |k: usize| std::array::from_fn(|a| f64::from(s[k][a]) - f64::from(c[k][a]));
        Ok((0..m as usize).map(|k| (v(2 * k), v(2 * k + 1))).collect())
    }
}

/// The gradient pass's outputs read back (tests).
#[derive(Debug, Clone, Default)]
pub struct GradientReadback {
    /// `B_i`, row-major; empty where the scene's rates read no B (Antuono's δ-SPH or the
    /// mass correction without the corrected forms: `GradientFields::store_b`).
    pub b: Vec<[[f64; 3]; 3]>,
    /// In the free-surface zone (`effects.free_surface`, `det M_i` below
    /// [`crate::joubert2020_gradients::free_surface_det`]); empty with `b`.
    pub near_free_surface: Vec<bool>,
    /// `[∇u_x, ∇u_y, ∇u_z, ∇p, s, ∇ρ]` per particle.
    pub fields: Vec<[[f64; 3]; 6]>,
    /// [max fluid speed (f32 bits), near-singular count, 0, 0].
    pub diag: [u32; 4],
}

/// The fluid solver of a scene; see the module doc.
pub struct FluidSolver {
    consts: SphConstants,
    limits: FluidLimits,
    stages: Vec<Stage>,
    /// World position of the GPU coordinate origin (the domain centre), m.
    origin: [f64; 3],
    /// The grid's box relative to `origin`: the domain plus the wall layers and a
    /// spacing of slack on closed axes, exactly one period on periodic ones.
    bounds: GridBox,
    n_scene_bodies: usize,
    pipelines: SphPipelines,
    data: SphData,
    marker_capacity: Option<usize>,
    /// Body index of each load range (contiguous markers of one body).
    load_bodies: Vec<u32>,
    step_params: StepParams,
    time: f64,
    steps: u64,
    /// CPU time spent recording the steps of every `advance` (encoding, bind groups, up
    /// to `CommandEncoder::finish`) and submitting them, s: where the GPU runs behind the
    /// CPU, a step whose GPU time is below its share of the two is bound by the CPU
    /// (`couplet bench` prints both). Lavapipe's submit returns only once the work before
    /// it is done (2026-11-30: 0.3 ms to record a CPB step here, 240 ms in the submit), so
    /// there the submit is the wall time and the recording alone is the CPU's share.
    record_s: f64,
    submit_s: f64,
    loads_ready: bool,
    /// Particle-steps of the last window whose truncation matrix was near-singular
    /// (kept the uncorrected gradient); 0 without the gradient pass.
    near_singular: u32,
    /// Fluid particle-steps of the last window mirrored back out of a body
    /// ([`crate::body_non_penetration`]); recomputed every window, not checkpointed.
    reflected: u32,
    /// Fluid particle-steps of the last window whose shift was cut short in front of a
    /// body ([`crate::particle_shifting::limit_toward_surface`]); not checkpointed.
    shift_limited: u32,
    /// The fluid's kinetic energy, largest speed and density error at the end of the
    /// last window.
    stats: WindowStats,
    /// Joubert walls' frames by wall index (empty with Adami walls); the carve-out of
    /// bodies renumbers fluid ids only, so the wall order, and these, stay valid.
    wall_frames: Vec<BoundaryFrame>,
    /// The unresolved grains' sampling, when the scene has grains.
    grains: Option<crate::unresolved_coupling::GrainCoupling>,
    /// `grain_loads` has just sorted the particles and set their porosity at τ = 0, and
    /// nothing has run on them since: the next window's first step skips its sort and
    /// porosity, which would repeat both on the same positions (the sort is stable, so
    /// sorting sorted particles is the identity, and the porosity's sums are integer).
    /// Set by [`FluidSolver::grain_loads`], taken by [`FluidSolver::advance`], cleared
    /// by every other method that runs passes on the particles.
    start_sorted: bool,
}

impl FluidSolver {
    /// Builds the particles of `scene` ([`initial_particles`]) and the solver.
    pub fn new(gpu: &Gpu, scene: &Scene) -> Result<FluidSolver, FluidError> {
        let c = SphConstants::from_scene(scene)?;
        let set = initial_particles(scene, &c)?;
        Self::from_particles(gpu, scene, set)
    }

    /// A solver for `scene` started from an explicit particle set (world coordinates;
    /// ids and kinds as in [`ParticleSet`]); fluid pressures are set from the densities
    /// by the Tait equation. For tests and restarts.
    pub fn from_particles(
        gpu: &Gpu,
        scene: &Scene,
        set: ParticleSet,
    ) -> Result<FluidSolver, FluidError> {
        Self::build(gpu, scene, set, scene.bodies.len())
    }

    /// [`Self::from_particles`] with room for `body_capacity` bodies in the marker
    /// buffers.
    fn build(
        gpu: &Gpu,
        scene: &Scene,
        mut set: ParticleSet,
        body_capacity: usize,
    ) -> Result<FluidSolver, FluidError> {
        let mut consts = SphConstants::from_scene(scene)?.for_adapter(gpu);
        consts.dense_lanes = gpu.dense_lanes(set.len());
        let limits = FluidLimits::from_scene(scene)?;
        let stages = plan::stages(scene);
        let d = &scene.domain;
        let origin: [f64; 3] = std::array::from_fn(|k| 0.5 * (d.min[k] + d.max[k]));
        // Walls reach ceil(support) spacings outside the domain; one more spacing of
        // slack, and the grid pads another cell. A periodic axis is one period.
        let margin = (wall_layers(scene) as f64 + 1.0) * consts.spacing;
        let periodic = d.periodic;
        let bounds = GridBox {
            min: std::array::from_fn(|k| {
                d.min[k] - origin[k] - if periodic[k] { 0.0 } else { margin }
            }),
            max: std::array::from_fn(|k| {
                d.max[k] - origin[k] + if periodic[k] { 0.0 } else { margin }
            }),
            periodic,
        };
        // Only a throwaway grid gives the layout the pipelines are built with; wgpu
        // deduplicates identical bind group layouts, so later grids' bind groups fit.
        let probe = NeighbourGrid::new(gpu, bounds, consts.grid_radius(), consts.grid_reach, 1)?;
        let pipelines = SphPipelines::new(
            gpu,
            &consts,
            probe.bind_group_layout(),
            scene.has_resolved_bodies(),
        );
        let grains = crate::unresolved_coupling::GrainCoupling::new(
            gpu,
            &consts,
            scene,
            probe.bind_group_layout(),
        );
        drop(probe);
        let wall_frames = if consts.joubert_walls {
            joubert2020_boundary_values::wall_frames(scene, &set)
        } else {
            Vec::new()
        };
        for p in &mut set.pos {
            *p = std::array::from_fn(|k| p[k] - origin[k]);
        }
        let data = SphData::new(
            gpu,
            &consts,
            &pipelines,
            &set,
            &wall_frames,
            bounds,
            body_capacity,
        )?;
        let step_params = StepParams {
            n_total: data.n_total,
            n_fluid: data.kinds.n_fluid as u32,
            n_wall: data.kinds.n_wall as u32,
            n_markers: data.kinds.n_markers as u32,
            dt: limits.dt as f32,
            gravity: StepParams::gravity_of(consts.gravity_fluid),
            ..Default::default()
        };
        let solver = FluidSolver {
            consts,
            limits,
            stages,
            origin,
            bounds,
            n_scene_bodies: scene.bodies.len(),
            pipelines,
            data,
            marker_capacity: None,
            load_bodies: Vec::new(),
            step_params,
            time: 0.0,
            steps: 0,
            record_s: 0.0,
            submit_s: 0.0,
            loads_ready: false,
            near_singular: 0,
            reflected: 0,
            shift_limited: 0,
            stats: WindowStats::default(),
            wall_frames,
            grains,
            start_sorted: false,
        };
        // Fluid pressures from the initial densities (Joubert eq. 4).
        solver.write_params(gpu);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sph: init"),
            });
        solver.data.queue_op(gpu, &mut encoder, None, Op::TaitEos);
        gpu.queue.submit([encoder.finish()]);
        Ok(solver)
    }

    /// Bytes of this solver's GPU buffers that scale with the neighbour grid's cells (the
    /// domain's volume over the cell's) rather than with its particles: the grid's cell
    /// ranges and scan totals and the fluid count of each cell's row window.
    pub fn grid_cell_bytes(&self) -> u64 {
        self.data.grid.cell_bytes() + self.data.row_fluid.size()
    }

    /// The widest per-particle buffer of this solver and its bytes a particle: one storage
    /// binding ([`Gpu::storage_binding_limit`]) holds it for at most limit / that many
    /// particles.
    pub fn widest_particle_buffer(&self) -> (&'static str, u64) {
        match &self.data.gradients {
            Some(g) => widest_particle_buffer(g.fields, true),
            None => widest_particle_buffer(GradientFields::of(&self.consts), false),
        }
    }

    /// Cells of the neighbour grid.
    pub fn grid_cells(&self) -> u32 {
        self.data.grid.params.n_cells
    }

    pub fn counts(&self) -> ParticleCounts {
        let k = self.data.kinds;
        ParticleCounts {
            fluid: k.n_fluid as u32,
            wall: k.n_wall as u32,
            markers: k.n_markers as u32,
        }
    }

    pub fn limits(&self) -> FluidLimits {
        self.limits
    }

    pub fn stages(&self) -> &[Stage] {
        &self.stages
    }

    pub fn constants(&self) -> &SphConstants {
        &self.consts
    }

    /// World position of the GPU coordinate origin, m.
    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// The buffers (tests and benchmarks).
    pub fn data(&self) -> &SphData {
        &self.data
    }

    /// Particle-steps of the last window that kept the uncorrected gradient because
    /// their truncation matrix was near-singular (`det M < B_DET_MIN`, see
    /// [`crate::joubert2020_gradients::B_DET_MIN`]).
    pub fn near_singular(&self) -> u32 {
        self.near_singular
    }

    /// Fluid particle-steps of the last window that ended behind a body's surface or a
    /// wall face and were mirrored back ([`crate::body_non_penetration`]).
    pub fn reflected(&self) -> u32 {
        self.reflected
    }

    /// Fluid particle-steps of the last window whose shift (Joubert eq. 17) the surface
    /// rule cut short δ/2 in front of a body
    /// ([`crate::particle_shifting::limit_toward_surface`]).
    pub fn shift_limited(&self) -> u32 {
        self.shift_limited
    }

    /// Everything that carries this solver from one window to the next (see
    /// [`crate::checkpoint`]), with the server's body-acceleration estimate.
    pub fn save_state(
        &self,
        gpu: &Gpu,
        acceleration: &AccelerationEstimate,
    ) -> Result<FluidState, FluidError> {
        let k = self.data.kinds;
        Ok(FluidState {
            kinds: [k.n_fluid, k.n_wall, k.n_markers],
            marker_capacity: self.marker_capacity,
            body_capacity: self.data.bodies.as_ref().map_or(0, |b| b.body_capacity),
            load_bodies: self.load_bodies.clone(),
            step_params: bytemuck::bytes_of(&self.step_params).to_vec(),
            gravity_fluid: self.consts.gravity_fluid,
            time: self.time,
            steps: self.steps,
            loads_ready: self.loads_ready,
            near_singular: self.near_singular,
            stats: [
                self.stats.kinetic_energy,
                self.stats.max_speed,
                self.stats.max_density_error,
            ],
            buffers: checkpoint::read_buffers(gpu, &self.data)?,
            acceleration: acceleration.clone(),
        })
    }

    /// A solver for `scene` that continues from `state` (saved by [`Self::save_state`]
    /// of a solver of the same scene): built like a fresh one for the saved particle
    /// counts, then every state buffer and counter is overwritten with the saved one.
    pub fn restore(
        gpu: &Gpu,
        scene: &Scene,
        state: &FluidState,
    ) -> Result<FluidSolver, FluidError> {
        let consts = SphConstants::from_scene(scene)?;
        let d = &scene.domain;
        let origin: [f64; 3] = std::array::from_fn(|k| 0.5 * (d.min[k] + d.max[k]));
        let set = checkpoint::particle_set(state, origin, consts.mass)?;
        let mut solver = Self::build(gpu, scene, set, state.body_capacity)?;
        if solver.data.kinds.n_markers > 0 && solver.pipelines.markers.is_none() {
            return Err(FluidError::Restore(
                "the checkpoint has markers but this scene has no resolved body".into(),
            ));
        }
        checkpoint::write_buffers(gpu, &solver.data, &state.buffers)?;
        solver.step_params = bytemuck::try_pod_read_unaligned(&state.step_params)
            .map_err(|e| FluidError::Restore(format!("step parameters: {e}")))?;
        solver.consts.gravity_fluid = state.gravity_fluid;
        solver.marker_capacity = state.marker_capacity;
        solver.load_bodies = state.load_bodies.clone();
        solver.time = state.time;
        solver.steps = state.steps;
        solver.loads_ready = state.loads_ready;
        solver.near_singular = state.near_singular;
        solver.stats = state.stats();
        solver.write_params(gpu);
        gpu.wait()?;
        Ok(solver)
    }

    /// Kinetic energy, largest speed and largest density error of the fluid at the end
    /// of the last window ([`crate::window_stats`]).
    pub fn stats(&self) -> WindowStats {
        self.stats
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// CPU time spent recording steps and submitting them so far, s: (recording,
    /// submitting) (see the field).
    pub fn record_seconds(&self) -> (f64, f64) {
        (self.record_s, self.submit_s)
    }

    /// Gravity becomes `g`, m/s², from the next step on. It reaches the fluid only when
    /// the scene has `gravity.on_fluid` (the kernels read it from the per-window
    /// uniform); otherwise the fluid feels none and the DEM applies `g` to the bodies
    /// with Joubert eq. (28)'s buoyancy.
    pub fn set_gravity(&mut self, gpu: &Gpu, g: [f64; 3]) {
        if self.consts.gravity_on_fluid {
            self.consts.gravity_fluid = g;
            self.step_params.gravity = StepParams::gravity_of(g);
            self.write_params(gpu);
        }
    }

    fn write_params(&self, gpu: &Gpu) {
        gpu.queue
            .write_buffer(&self.data.params, 0, bytemuck::bytes_of(&self.step_params));
    }

    /// Sets the bodies and markers for the next window: `states` at the window start,
    /// the world-frame coupling points in DEM order (contiguous per body), and the
    /// bodies' accelerations in the order of `states` (empty: all zero; see
    /// [`crate::marker_update::AccelerationEstimate`]), which Joubert's boundaries
    /// (eq. 25) give the markers. The first call fixes the marker capacity (the marker
    /// particles are appended then); later calls must give the same number of points.
    pub fn set_bodies(
        &mut self,
        gpu: &Gpu,
        states: &[BodyState],
        points: &[CouplingPoint],
        accelerations: &[BodyAcceleration],
    ) -> Result<(), FluidError> {
        self.start_sorted = false;
        if !accelerations.is_empty() && accelerations.len() != states.len() {
            return Err(FluidError::AccelerationCount {
                got: accelerations.len(),
                states: states.len(),
            });
        }
        if let Some(cap) = self.marker_capacity
            && cap != points.len()
        {
            return Err(FluidError::MarkerCount {
                got: points.len(),
                capacity: cap,
            });
        }
        // Validate before touching anything.
        let body_capacity = match &self.data.bodies {
            Some(b) => b.body_capacity,
            None => self
                .n_scene_bodies
                .max(
                    states
                        .iter()
                        .map(|s| s.body as usize + 1)
                        .max()
                        .unwrap_or(0),
                )
                .max(
                    points
                        .iter()
                        .map(|p| p.body as usize + 1)
                        .max()
                        .unwrap_or(0),
                )
                .max(1),
        };
        let mut bodies = vec![GpuBody::default(); body_capacity];
        let mut has_state = vec![false; body_capacity];
        for (index, s) in states.iter().enumerate() {
            let b = s.body as usize;
            if b >= body_capacity {
                return Err(FluidError::BodyIndex {
                    index,
                    body: s.body,
                    capacity: body_capacity,
                });
            }
            if s.position
                .iter()
                .chain(&s.linear_velocity)
                .chain(&s.angular_velocity)
                .any(|x| !x.is_finite())
            {
                return Err(FluidError::NonFiniteInput {
                    what: "position or velocity",
                    item: format!("body state {index} (body {})", s.body),
                    value: format!(
                        "{:?} / {:?} / {:?}",
                        s.position, s.linear_velocity, s.angular_velocity
                    ),
                });
            }
            let rel = |k: usize| (s.position[k] - self.origin[k]) as f32;
            let v = s.linear_velocity.map(|x| x as f32);
            bodies[b] = GpuBody {
                cg: [rel(0), rel(1), rel(2), 0.0],
                vel: [v[0], v[1], v[2], 0.0],
            };
            has_state[b] = true;
        }
        let mut ranges: Vec<[u32; 4]> = Vec::new();
        let mut seen = vec![false; body_capacity];
        for (index, p) in points.iter().enumerate() {
            let b = p.body as usize;
            if b >= body_capacity || !has_state[b] {
                return Err(FluidError::MarkerBody {
                    index,
                    body: p.body,
                    n_bodies: states.len(),
                });
            }
            if p.position
                .iter()
                .chain(&p.velocity)
                .chain(&p.normal)
                .chain(std::iter::once(&p.measure))
                .any(|x| !x.is_finite())
            {
                return Err(FluidError::NonFiniteInput {
                    what: "position, velocity, normal or area",
                    item: format!("coupling point {index} (body {})", p.body),
                    value: format!("{:?}", p),
                });
            }
            match ranges.last_mut() {
                Some(r) if r[2] == p.body => r[1] += 1,
                _ => {
                    if seen[b] {
                        return Err(FluidError::MarkerOrder {
                            index,
                            body: p.body,
                        });
                    }
                    seen[b] = true;
                    ranges.push([index as u32, 1, p.body, 0]);
                }
            }
        }
        if self.marker_capacity.is_none() {
            self.marker_capacity = Some(points.len());
            if !points.is_empty() {
                self.append_markers(gpu, points, body_capacity)?;
            }
        }
        let Some(buffers) = &self.data.bodies else {
            return Ok(());
        };
        let markers: Vec<GpuMarker> = points
            .iter()
            .map(|p| GpuMarker::from_point(p, self.origin))
            .collect();
        gpu.queue
            .write_buffer(&buffers.markers_in, 0, bytemuck::cast_slice(&markers));
        if let Some(frames) = &self.data.boundary_frame {
            // Joubert eq. (25) at the markers: their normal and the rigid-body
            // acceleration of each point at the window start.
            let mut kinematics =
                vec![(BodyAcceleration::default(), [0.0; 3], [0.0; 3]); body_capacity];
            for (k, s) in states.iter().enumerate() {
                let acc = accelerations.get(k).copied().unwrap_or_default();
                kinematics[s.body as usize] = (acc, s.angular_velocity, s.position);
            }
            let marker_frames: Vec<BoundaryFrame> = points
                .iter()
                .map(|p| {
                    let (acc, omega, cg) = &kinematics[p.body as usize];
                    let r = std::array::from_fn(|k| f64::from(p.position[k]) - cg[k]);
                    BoundaryFrame::marker(p.normal, point_acceleration(acc, *omega, r))
                })
                .collect();
            let offset = (self.data.kinds.n_wall * std::mem::size_of::<BoundaryFrame>()) as u64;
            gpu.queue
                .write_buffer(frames, offset, bytemuck::cast_slice(&marker_frames));
        }
        gpu.queue
            .write_buffer(&buffers.bodies, 0, bytemuck::cast_slice(&bodies));
        gpu.queue
            .write_buffer(&buffers.load_ranges, 0, bytemuck::cast_slice(&ranges));
        self.load_bodies = ranges.iter().map(|r| r[2]).collect();
        self.step_params.n_load_bodies = ranges.len() as u32;
        self.loads_ready = false;
        Ok(())
    }

    /// Rebuilds the data with `points.len()` marker particles appended (first
    /// `set_bodies`): the current particle state is read back once.
    fn append_markers(
        &mut self,
        gpu: &Gpu,
        points: &[CouplingPoint],
        body_capacity: usize,
    ) -> Result<(), FluidError> {
        let read = self.data.read(gpu)?;
        let set = with_marker_particles(&self.consts, read, points, self.origin);
        if self.pipelines.markers.is_none() {
            // A scene without resolved bodies that still receives markers (tests).
            let probe = NeighbourGrid::new(
                gpu,
                self.bounds,
                self.consts.grid_radius(),
                self.consts.grid_reach,
                1,
            )?;
            self.pipelines.markers = Some(MarkerPipelines::new(
                gpu,
                &self.consts,
                probe.bind_group_layout(),
            ));
        }
        self.data = SphData::new(
            gpu,
            &self.consts,
            &self.pipelines,
            &set,
            &self.wall_frames,
            self.bounds,
            body_capacity,
        )?;
        self.step_params.n_total = self.data.n_total;
        self.step_params.n_fluid = self.data.kinds.n_fluid as u32;
        self.step_params.n_wall = self.data.kinds.n_wall as u32;
        self.step_params.n_markers = points.len() as u32;
        Ok(())
    }

    /// Records one predictor–corrector step (Joubert eqs. 20–23) as labelled passes.
    /// `tau`: the step's start since the window's (the grains' porosity moves them by v τ);
    /// `slot`: the step's place in the encoder's submission (steps before it in the same
    /// encoder, below `gpu::MAX_STEPS_PER_SUBMIT`), where its τ goes. `sorted`: the
    /// particles are as a sort left them, with their porosity at this τ, so the step
    /// starts after both (the window's first, after `grain_loads`; see `start_sorted`).
    pub fn queue_step(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut StageTimer>,
        tau: f64,
        slot: u32,
        sorted: bool,
    ) -> Result<(), FluidError> {
        let d = &self.data;
        if !sorted {
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::MarkerUpdate);
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::Sort);
            if let Some(g) = &self.grains {
                g.queue_solid_fraction(gpu, encoder, timer.as_deref_mut(), d, tau, slot)?;
            }
        }
        d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::SmoothingLengths);
        d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::Gradients);
        for update in [Op::Predict, Op::Correct] {
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::BoundaryPressure);
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::FluidRates);
            if let Some(g) = &self.grains {
                g.queue_pressure_force(gpu, encoder, timer.as_deref_mut(), d)?;
            }
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::GrainReaction);
            d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::MarkerLoads);
            d.queue_op(gpu, encoder, timer.as_deref_mut(), update);
        }
        d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::Shift);
        d.queue_op(gpu, encoder, timer.as_deref_mut(), Op::NonPenetration);
        d.queue_op(gpu, encoder, timer, Op::AdvanceClock);
        Ok(())
    }

    /// Resets the window accumulators (clock, marker load sums) in `encoder`.
    fn queue_window_start(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) {
        if let Some(g) = &self.data.gradients {
            encoder.clear_buffer(&g.diag, 0, None);
        }
        if let Some(b) = &self.data.bodies {
            gpu.queue
                .write_buffer(&b.clock, 0, bytemuck::bytes_of(&Clock::default()));
            encoder.clear_buffer(&b.marker_load, 0, None);
            encoder.clear_buffer(&b.marker_load_c, 0, None);
        }
        // status[3], status[4]: the window's counts of particles kept out of bodies and
        // of shifts cut short in front of them.
        encoder.clear_buffer(&self.data.status, 12, Some(8));
    }

    /// Runs `ops` once with substep `dt` and load weight `load_weight` after resetting the
    /// window accumulators, then waits (tests and benchmarks).
    pub fn run_ops(
        &mut self,
        gpu: &Gpu,
        ops: &[Op],
        dt: f64,
        load_weight: f64,
    ) -> Result<(), FluidError> {
        self.start_sorted = false;
        self.step_params.dt = dt as f32;
        self.step_params.load_weight = load_weight as f32;
        self.write_params(gpu);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sph: ops"),
            });
        self.queue_window_start(gpu, &mut encoder);
        for op in ops {
            self.data.queue_op(gpu, &mut encoder, None, *op);
        }
        gpu.queue.submit([encoder.finish()]);
        gpu.wait()?;
        if ops.contains(&Op::ReduceBodyLoads) {
            self.loads_ready = self.data.bodies.is_some();
        }
        Ok(())
    }

    /// Advances the fluid over `window` seconds in `ceil(window / dt)` equal substeps and
    /// returns their number. At the end: body loads reduced (when markers exist), the
    /// blow-up check and the grid's error record (each a small readback).
    pub fn advance(
        &mut self,
        gpu: &Gpu,
        window: f64,
        mut timer: Option<&mut StageTimer>,
    ) -> Result<u32, FluidError> {
        if !(window.is_finite() && window > 0.0) {
            return Err(FluidError::BadWindow { window });
        }
        // A window that is a whole number of steps up to round-off takes that many.
        let substeps = ((window / self.limits.dt) * (1.0 - 1e-9)).ceil().max(1.0) as u32;
        let dt = window / f64::from(substeps);
        self.step_params.dt = dt as f32;
        self.step_params.load_weight = (0.5 / f64::from(substeps)) as f32;
        self.write_params(gpu);
        // Submissions of 1, 2, 4, … steps up to `gpu.steps_per_submit`: the GPU starts
        // on the window's first step while the CPU records the next two, and so on, so
        // that recording stays behind the GPU's work (gpu::STEPS_PER_SUBMIT_DEFAULT).
        // One a submission when every stage is timed (the timer reads its queries back
        // after each).
        let most = if timer.is_some() {
            1
        } else {
            gpu.steps_per_submit
        };
        let mut per_submit = 1;
        let mut batch: Option<(wgpu::CommandEncoder, u32)> = None;
        // Not with markers: the first step moves them (MarkerUpdate), then sorts.
        let start_sorted =
            std::mem::take(&mut self.start_sorted) && self.pipelines.markers.is_none();
        for s in 0..substeps {
            let recording = std::time::Instant::now();
            let (encoder, slot) = batch.get_or_insert_with(|| {
                let encoder = gpu
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("sph: steps"),
                    });
                (encoder, 0)
            });
            if s == 0 {
                self.queue_window_start(gpu, encoder);
            }
            self.queue_step(
                gpu,
                encoder,
                timer.as_deref_mut(),
                f64::from(s) * dt,
                *slot,
                s == 0 && start_sorted,
            )?;
            *slot += 1;
            let last = s + 1 == substeps;
            if last {
                self.data
                    .queue_op(gpu, encoder, timer.as_deref_mut(), Op::ReduceBodyLoads);
            }
            if !(last || *slot == per_submit) {
                self.record_s += recording.elapsed().as_secs_f64();
                continue;
            }
            let (mut encoder, _) = batch.take().expect("the batch recorded above");
            per_submit = (2 * per_submit).min(most);
            if let Some(t) = timer.as_deref_mut() {
                t.finish(gpu, &mut encoder);
            }
            let commands = encoder.finish();
            let submitting = std::time::Instant::now();
            self.record_s += (submitting - recording).as_secs_f64();
            gpu.queue.submit([commands]);
            self.submit_s += submitting.elapsed().as_secs_f64();
            if let Some(t) = timer.as_deref_mut() {
                t.collect(gpu)?;
            }
        }
        let since = (self.steps, self.time);
        self.time += window;
        self.steps += u64::from(substeps);
        self.loads_ready = self.data.bodies.is_some();
        (
            self.near_singular,
            [self.reflected, self.shift_limited],
            self.stats,
        ) = self.check(gpu, since)?;
        Ok(substeps)
    }

    /// End-of-window checks: blow-up (non-finite, runaway density or speed) and
    /// particles outside the grid. Returns the window's near-singular particle-steps of
    /// the gradient pass and of Joubert's boundary values (0 without the pass), copied
    /// into `status[1..3]` so that one readback serves both; the particle-steps kept out
    /// of bodies (`status[3]`) and those whose shift was cut short in front of one
    /// (`status[4]`); and the window's telemetry.
    /// `since` is the window's start (step, time), where the last check passed.
    fn check(
        &self,
        gpu: &Gpu,
        since: (u64, f64),
    ) -> Result<(u32, [u32; 2], WindowStats), FluidError> {
        let d = &self.data;
        // status[3], status[4] hold the window's body counts: left alone.
        gpu.queue.write_buffer(
            &d.status,
            0,
            bytemuck::cast_slice(&[blowup_check::NO_BAD_ID; 3]),
        );
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sph: check"),
            });
        {
            let mut pass = timing::begin_pass(None, gpu, &mut encoder, "sph: blowup_check");
            d.bound.find_bad.dispatch(&mut pass, d.n_total);
            d.bound.capture_bad.dispatch(&mut pass, d.n_total);
            d.bound.window_stats.dispatch(&mut pass, d.n_total);
        }
        if let Some(g) = &d.gradients {
            encoder.copy_buffer_to_buffer(&g.diag, 4, &d.status, 4, 8);
        }
        gpu.queue.submit([encoder.finish()]);
        // One round trip for the three (each read waits for the GPU to drain).
        let [status, grid_record, partials] = gpu.read_buffers([
            (&d.status, 0, 5 * 4),
            d.grid.error_record(),
            (
                &d.stats_partials,
                0,
                window_stats::partial_count(d.n_total) as u64 * 16,
            ),
        ])?;
        let status: Vec<u32> = bytemuck::pod_collect_to_vec(&status);
        // Gradient-pass fallbacks per step, plus the one-sided matrices of Joubert
        // boundary particles and of the markers' corrected ∇u (each counted at both of
        // the step's rate evaluations).
        let near_singular = if d.gradients.is_some() {
            status[1] + status[2] / 2
        } else {
            0
        };
        if let Some(&id) = status.first()
            && id != blowup_check::NO_BAD_ID
        {
            let v: Vec<[f32; 4]> = gpu.read_buffer(&d.bad_values, 0, 3)?;
            let (pos, rho, vel, mass) = (v[0], v[0][3], v[1], v[2][0]);
            let finite = |x: &[f32]| x.iter().all(|a| a.is_finite());
            let c = &self.consts;
            let speed = (vel[..3].iter().map(|x| f64::from(*x).powi(2)).sum::<f64>()).sqrt();
            let world: [f64; 3] = std::array::from_fn(|k| f64::from(pos[k]) + self.origin[k]);
            let (what, value) = if !finite(&pos[..3]) {
                ("position", format!("{:?}", &pos[..3]))
            } else if !finite(&vel[..3]) {
                ("velocity", format!("{:?} at {world:?}", &vel[..3]))
            } else if let Some(ratio) = c.variable_h
                && rho > 0.0
                && (f64::from(mass) / (f64::from(rho) * c.spacing.powi(3))).cbrt() > ratio
            {
                // Robinson eq. (19): V/δ³ = (h/h0)³; among grains V/δ³ ≈ 1/ε.
                let volume = f64::from(mass) / (f64::from(rho) * c.spacing.powi(3));
                (
                    "smoothing length",
                    format!(
                        "{:.4e} m at {world:?}, above the largest the neighbour grid holds, \
                         fluid.max_smoothing_ratio = {ratio} times {:.4e} m (its volume is {volume:.3} δ³: \
                         a porosity near {:.3}); raise fluid.max_smoothing_ratio",
                        c.kernel.h * volume.cbrt(),
                        c.kernel.h,
                        1.0 / volume
                    ),
                )
            } else if !rho.is_finite()
                || (f64::from(rho) / c.rho0 - 1.0).abs() > blowup_check::BLOWUP_DENSITY_DEVIATION
            {
                ("density", format!("{rho} kg/m³ at {world:?}"))
            } else {
                ("speed", format!("{speed} m/s at {world:?}"))
            };
            return Err(FluidError::BlowUp {
                step: self.steps,
                time: self.time,
                since_step: since.0,
                since_time: since.1,
                id,
                kind: match d.kinds.kind(id) {
                    Kind::Fluid => "fluid",
                    Kind::Wall => "wall",
                    Kind::Marker => "marker",
                },
                what,
                value,
                rho_min: c.rho0 * (1.0 - blowup_check::BLOWUP_DENSITY_DEVIATION),
                rho_max: c.rho0 * (1.0 + blowup_check::BLOWUP_DENSITY_DEVIATION),
                u_max: c.sound_speed,
            });
        }
        if let Err(e) = d.grid.check_record(&grid_record) {
            d.grid.reset_error(gpu);
            return Err(FluidError::Grid {
                step: self.steps,
                message: e.to_string(),
            });
        }
        let partials: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&partials);
        Ok((
            near_singular,
            [status[3], status[4]],
            WindowStats::from_partials(&partials),
        ))
    }

    /// The fluid's force on each unresolved grain at the bodies' `states` (world frame),
    /// one load per grain in body order; empty without grains. Sampled at the window's
    /// start, from the rates the last step left (Robinson eqs. 23–33; see
    /// [`crate::unresolved_coupling`]).
    /// With `coupling.two_way` the fluid's reaction for the coming window is spread
    /// at once (Robinson eqs. 26–27). A `timer` (`couplet bench`) times each GPU stage
    /// and is finished before each of the two submissions; the caller collects it.
    pub fn grain_loads(
        &mut self,
        gpu: &Gpu,
        states: &[BodyState],
        mut timer: Option<&mut StageTimer>,
    ) -> Result<Vec<BodyLoad>, FluidError> {
        let Some(g) = &self.grains else {
            return Ok(Vec::new());
        };
        let (loads, samples) =
            g.sample(gpu, &self.data, self.origin, states, timer.as_deref_mut())?;
        self.start_sorted = true;
        if self.data.reaction.is_some() {
            self.step_params.reaction_unit =
                crate::unresolved_coupling::reaction_unit(&self.consts, &samples) as f32;
            self.write_params(gpu);
            g.spread(gpu, &self.data, timer)?;
        }
        Ok(loads)
    }

    /// After [`FluidSolver::advance`]: the grain loads [`FluidSolver::grain_loads`] gave
    /// at the window's start, with `coupling.porosity_pressure = "energy-pair"`'s
    /// pressure force added, averaged over the window's stages exactly as the fluid took
    /// its opposite ([`crate::unresolved_coupling`]). Unchanged otherwise.
    pub fn add_grain_pressure_forces(
        &self,
        gpu: &Gpu,
        loads: &mut [BodyLoad],
    ) -> Result<(), FluidError> {
        match &self.grains {
            Some(g) => g.add_pressure_forces(gpu, loads),
            None => Ok(()),
        }
    }

    /// One `grain_pressure_force` at the present state, with the load weight the last
    /// [`FluidSolver::run_ops`] set (tests); empty without grains.
    pub fn grain_pressure_forces_now(&self, gpu: &Gpu) -> Result<Vec<[f64; 3]>, FluidError> {
        match &self.grains {
            Some(g) => g.pressure_forces_now(gpu, &self.data),
            None => Ok(Vec::new()),
        }
    }

    /// Fluid force and moment per body, averaged over the last window (Joubert eqs.
    /// 31–32); one entry per body that has markers, in marker order. Empty without markers.
    pub fn loads(&mut self, gpu: &Gpu) -> Result<Vec<BodyLoad>, FluidError> {
        let Some(b) = &self.data.bodies else {
            return Ok(Vec::new());
        };
        if !self.loads_ready {
            return Ok(self
                .load_bodies
                .iter()
                .map(|&body| BodyLoad {
                    body,
                    ..Default::default()
                })
                .collect());
        }
        let n = self.load_bodies.len() as u64;
        let raw: Vec<[f32; 4]> = gpu.read_buffer(&b.body_loads, 0, 2 * n)?;
        let v = |x: [f32; 4]| [f64::from(x[0]), f64::from(x[1]), f64::from(x[2])];
        Ok(self
            .load_bodies
            .iter()
            .enumerate()
            .map(|(g, &body)| BodyLoad {
                force: v(raw[2 * g]),
                body,
                _pad: 0,
                moment: v(raw[2 * g + 1]),
            })
            .collect())
    }

    /// All particles (buffer order) in world coordinates.
    pub fn particles(&self, gpu: &Gpu) -> Result<ParticleSet, FluidError> {
        let mut set = self.data.read(gpu)?;
        for p in &mut set.pos {
            *p = std::array::from_fn(|k| p[k] + self.origin[k]);
        }
        Ok(set)
    }

    /// Fluid particles in id order, world coordinates.
    pub fn snapshot(&mut self, gpu: &Gpu) -> Result<Vec<ParticleRecord>, FluidError> {
        let set = self.particles(gpu)?;
        let n_fluid = set.kinds.n_fluid;
        let mut out = vec![ParticleRecord::default(); n_fluid];
        for k in 0..set.len() {
            let id = set.id[k] as usize;
            if id < n_fluid {
                out[id] = ParticleRecord {
                    position: set.pos[k].map(|x| x as f32),
                    pressure: set.press[k] as f32,
                    velocity: set.vel[k].map(|x| x as f32),
                    density: set.rho[k] as f32,
                };
            }
        }
        Ok(out)
    }

    /// Mean number of neighbours inside the support per fluid particle (sorts first).
    pub fn neighbour_stats(&mut self, gpu: &Gpu) -> Result<f64, FluidError> {
        self.start_sorted = false;
        let d = &self.data;
        let counts = particle_buffer(gpu, "sph: neighbour counts", d.n_total as usize, 4)?;
        let resolve = |g: u32, b: u32| -> Option<&wgpu::Buffer> {
            match (g, b) {
                (PARTICLES, pb::POS) => Some(&d.pos),
                (PARTICLES, pb::ID) => Some(&d.id),
                (PARAMS, qb::PARAMS) => Some(&d.params),
                (PARAMS, qb::COUNTS) => Some(&counts),
                _ => None,
            }
        };
        let bound = self
            .pipelines
            .neighbour_count
            .bind(gpu, resolve, Some(d.grid.bind_group()))
            .ok_or_else(|| missing("neighbour_count"))?;
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sph: neighbours"),
            });
        d.queue_op(gpu, &mut encoder, None, Op::Sort);
        {
            let mut pass = timing::begin_pass(None, gpu, &mut encoder, "sph: neighbour_count");
            bound.dispatch(&mut pass, d.n_total);
        }
        gpu.queue.submit([encoder.finish()]);
        let c: Vec<u32> = gpu.read_buffer(&counts, 0, u64::from(d.n_total))?;
        let total: u64 = c.iter().map(|x| u64::from(*x)).sum();
        Ok(total as f64 / d.kinds.n_fluid.max(1) as f64)
    }
}

/// `set` (positions relative to `origin`) with the fluid inside the bodies of `points`
/// carved out ([`carve_out_bodies`]) and a marker particle appended for each point, in
/// order: its position and velocity as the GPU holds them (f32, relative to `origin`),
/// ρ0, p = 0 until the boundary pass, and the mass of the slab it stands for
/// ([`marker_mass`]). What the first `set_bodies` uploads, and the linearisation's
/// bodies ([`crate::linear_acoustics::RestState::with_bodies`]).
pub(crate) fn with_marker_particles(
    c: &SphConstants,
    set: ParticleSet,
    points: &[CouplingPoint],
    origin: [f64; 3],
) -> ParticleSet {
    let mut set = carve_out_bodies(set, points, origin, c.spacing);
    let marker_base = set.kinds.marker_base() as u32;
    for (k, p) in points.iter().enumerate() {
        let m = GpuMarker::from_point(p, origin);
        set.pos
            .push(std::array::from_fn(|a| f64::from(m.pos_area[a])));
        set.vel
            .push(std::array::from_fn(|a| f64::from(m.vel_body[a])));
        set.rho.push(c.rho0);
        set.press.push(0.0);
        set.mass.push(marker_mass(c, p.measure));
        set.id.push(marker_base + k as u32);
    }
    set.kinds.n_markers = points.len();
    set
}

/// Removes the fluid particles that lie inside a resolved body, or less than half a
/// spacing outside its surface (the gap a wall keeps to the fluid lattice), and renumbers
/// the ids so that kinds stay contiguous id ranges. Inside-ness comes from the body's own
/// surface markers (fill points, of area 0, are not the surface): a point is inside when
/// it lies behind the outward normal of its nearest marker, `(x − m)·n < δ/2`; this
/// needs no shape code here and holds for any surface whose markers are denser than its
/// curvature radius (Joubert §2.6 meshes them at δ). A particle within round-off of δ/2
/// is kept: the markers come through f32, so on a face that lies exactly half a spacing
/// from a lattice layer (the cross's faces at the heights it is released from)
/// `(x − m)·n` lands on either side of δ/2 by the rounding of the face's coordinate.
/// Joubert's cross released at y = 8 mm had its side arms' tops at 8.5 mm, which f32
/// rounds up, so the layer above them went and the fluid stood 1.5δ off them; it
/// collapsed into that gap, and the cross blew up in the corner above
/// (ARCHITECTURE.md, "A face half a spacing from the lattice keeps its fluid layer").
/// `set` is in buffer order with GPU-relative positions; the result is in id order.
/// Distances are plain differences, not nearest images: on a periodic axis a body must
/// span the domain from face to face (the DEM server refuses any other,
/// `DemError::PeriodicSpan`), so no body has a part across a periodic face.
/// Cost: every fluid particle within a body's bounding sphere against that body's
/// markers, done once when the markers first arrive.
fn carve_out_bodies(
    set: ParticleSet,
    points: &[CouplingPoint],
    origin: [f64; 3],
    spacing: f64,
) -> ParticleSet {
    // Markers per body in GPU-relative coordinates (position, normal), with each body's
    // bounding sphere: (body, centre, radius, markers).
    type Markers = Vec<([f64; 3], [f64; 3])>;
    let mut bodies: Vec<(u32, [f64; 3], f64, Markers)> = Vec::new();
    for p in points.iter().filter(|p| p.measure > 0.0) {
        let m = std::array::from_fn(|k| f64::from(p.position[k]) - origin[k]);
        let n = p.normal.map(f64::from);
        match bodies.last_mut() {
            Some(b) if b.0 == p.body => b.3.push((m, n)),
            _ => bodies.push((p.body, [0.0; 3], 0.0, vec![(m, n)])),
        }
    }
    for b in &mut bodies {
        let c: [f64; 3] =
            std::array::from_fn(|k| b.3.iter().map(|(m, _)| m[k]).sum::<f64>() / b.3.len() as f64);
        b.1 = c;
        b.2 =
            b.3.iter()
                .map(|(m, _)| dist2(*m, c).sqrt())
                .fold(0.0, f64::max)
                + spacing;
    }
    let removed = |x: [f64; 3]| {
        bodies.iter().any(|(_, c, r, markers)| {
            if dist2(x, *c) > r * r {
                return false;
            }
            let nearest = markers
                .iter()
                .min_by(|a, b| dist2(x, a.0).total_cmp(&dist2(x, b.0)));
            nearest.is_some_and(|(m, n)| {
                // Round-off of δ/2: 1e-3 δ, and the f32 marker's own (4 ulp of its
                // largest world coordinate, the one f32 held).
                let scale = (0..3).fold(0.0_f64, |a, k| a.max((m[k] + origin[k]).abs()));
                let tol = 1e-3 * spacing + 4.0 * f64::from(f32::EPSILON) * scale;
                (0..3).map(|k| (x[k] - m[k]) * n[k]).sum::<f64>() < 0.5 * spacing - tol
            })
        })
    };
    let n = set.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| set.id[i]);
    let mut out = ParticleSet {
        pos: Vec::with_capacity(n),
        vel: Vec::with_capacity(n),
        rho: Vec::with_capacity(n),
        press: Vec::with_capacity(n),
        mass: Vec::with_capacity(n),
        id: Vec::with_capacity(n),
        kinds: set.kinds,
    };
    let mut dropped = 0;
    for i in order {
        if (set.id[i] as usize) < set.kinds.n_fluid && removed(set.pos[i]) {
            dropped += 1;
            continue;
        }
        out.id.push(out.pos.len() as u32);
        out.pos.push(set.pos[i]);
        out.vel.push(set.vel[i]);
        out.rho.push(set.rho[i]);
        out.mass.push(set.mass[i]);
        out.press.push(set.press[i]);
    }
    out.kinds.n_fluid -= dropped;
    out
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum()
}

#[cfg(test)]
mod carve_out_tests {
    use super::*;

    /// Fluid inside a resolved sphere is removed at the first markers, fluid outside
    /// beyond half a spacing is kept, and kinds stay contiguous id ranges. Reference:
    /// the geometry itself (|x − c| < r + δ/2 is removed, |x − c| > r + δ kept; between
    /// the two the nearest-marker test may go either way on a discrete surface).
    #[test]
    fn fluid_inside_a_resolved_sphere_is_removed() {
        let (delta, r, c) = (0.1, 0.45, [0.5, 0.5, 0.5]);
        let mut pos = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                for k in 0..10 {
                    pos.push([
                        (i as f64 + 0.5) * delta,
                        (j as f64 + 0.5) * delta,
                        (k as f64 + 0.5) * delta,
                    ]);
                }
            }
        }
        pos.push([-0.05, -0.05, -0.05]); // one wall particle
        let n = pos.len();
        // Markers on a Fibonacci sphere, ≈ one per δ².
        let m = (4.0 * std::f64::consts::PI * r * r / (delta * delta)).round() as usize;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let points: Vec<CouplingPoint> = (0..m)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f64 + 0.5) / m as f64;
                let rho = (1.0 - y * y).sqrt();
                let n = [
                    rho * (golden * i as f64).cos(),
                    y,
                    rho * (golden * i as f64).sin(),
                ];
                CouplingPoint {
                    position: std::array::from_fn(|k| (c[k] + r * n[k]) as f32),
                    measure: (delta * delta) as f32,
                    normal: n.map(|x| x as f32),
                    ..Default::default()
                }
            })
            .collect();
        let set = ParticleSet {
            vel: vec![[0.0; 3]; n],
            rho: vec![1000.0; n],
            press: vec![0.0; n],
            mass: vec![1.0; n],
            id: (0..n as u32).rev().collect(), // buffer order differs from id order
            pos: {
                let mut p = pos.clone();
                p.reverse();
                p
            },
            kinds: ParticleKinds {
                n_fluid: n - 1,
                n_wall: 1,
                n_markers: 0,
            },
        };
        let out = carve_out_bodies(set, &points, [0.0; 3], delta);
        assert_eq!(out.id, (0..out.len() as u32).collect::<Vec<_>>());
        assert_eq!(out.kinds.n_wall, 1);
        assert_eq!(
            out.pos[out.kinds.n_fluid],
            [-0.05, -0.05, -0.05],
            "the wall particle stays last"
        );
        for p in &out.pos[..out.kinds.n_fluid] {
            assert!(
                dist2(*p, c).sqrt() > r + 0.5 * delta - 1e-9 - 0.02,
                "kept a particle inside: {p:?}"
            );
        }
        let far_outside = pos[..n - 1]
            .iter()
            .filter(|p| dist2(**p, c).sqrt() > r + delta)
            .count();
        let kept_far = out.pos[..out.kinds.n_fluid]
            .iter()
            .filter(|p| dist2(**p, c).sqrt() > r + delta)
            .count();
        assert_eq!(kept_far, far_outside);
    }

    /// Regression (Joubert's cross blew up in its upper corners at δ = 0.25 mm): the
    /// lattice layer half a spacing above a face is kept whichever way f32 rounds the
    /// face's markers. The cross released at y = 8 mm has its side arms' tops at
    /// 8.5 mm, which f32 rounds up (to 8.50000046e-3), and its upper arm's top at
    /// 9.5 mm, which it rounds down; before, the layer at 8.625 mm went (the fluid then
    /// stood 1.5δ off the face) and the one at 9.625 mm stayed. Reference: the
    /// geometry, every particle at least δ/2 outside both faces kept, every one inside
    /// removed.
    #[test]
    fn fluid_half_a_spacing_off_a_face_is_kept_however_f32_rounds_the_face() {
        let delta = 2.5e-4;
        for face in [8.5e-3_f64, 9.5e-3] {
            assert_ne!(
                f64::from(face as f32),
                face,
                "the face must not be exact in f32"
            );
            // A 4δ × 4δ patch of the face at y = `face`, normal +y, and the lattice of
            // (i + ½)δ on either side, from 2.5δ below to 2.5δ above it (inside the
            // patch's bounding sphere, the only particles the carve-out looks at).
            let points: Vec<CouplingPoint> = (0..4)
                .flat_map(|i| (0..4).map(move |k| (i, k)))
                .map(|(i, k)| CouplingPoint {
                    position: [
                        (2.0e-3 + (i as f64 + 0.5) * delta) as f32,
                        face as f32,
                        (2.0e-3 + (k as f64 + 0.5) * delta) as f32,
                    ],
                    measure: (delta * delta) as f32,
                    normal: [0.0, 1.0, 0.0],
                    ..Default::default()
                })
                .collect();
            let mut pos = Vec::new();
            for i in 1..3 {
                for j in -3..3 {
                    for k in 1..3 {
                        pos.push([
                            2.0e-3 + (i as f64 + 0.5) * delta,
                            face + (j as f64 + 0.5) * delta,
                            2.0e-3 + (k as f64 + 0.5) * delta,
                        ]);
                    }
                }
            }
            let n = pos.len();
            let set = ParticleSet {
                vel: vec![[0.0; 3]; n],
                rho: vec![1000.0; n],
                press: vec![0.0; n],
                mass: vec![1.0; n],
                id: (0..n as u32).collect(),
                pos: pos.clone(),
                kinds: ParticleKinds {
                    n_fluid: n,
                    n_wall: 0,
                    n_markers: 0,
                },
            };
            let out = carve_out_bodies(set, &points, [0.0; 3], delta);
            let above = |p: &[f64; 3]| p[1] > face;
            assert_eq!(
                out.pos.iter().filter(|p| above(p)).count(),
                pos.iter().filter(|p| above(p)).count(),
                "face at {face} m: a layer above it went"
            );
            assert_eq!(
                out.pos.iter().filter(|p| !above(p)).count(),
                0,
                "face at {face} m"
            );
        }
    }
}
