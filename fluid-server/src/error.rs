//! Errors of the fluid solver: one enum, every variant names the thing, the value and
//! what would be valid (STYLE.md, "Errors").

use crate::gpu::GpuError;

#[derive(Debug, thiserror::Error)]
pub enum FluidError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("neighbour grid: {0}")]
    GridSetup(#[from] crate::neighbour_grid::GridError),
    #[error("the scene has no [fluid] section: there is nothing for the fluid solver to do")]
    NoFluid,
    #[error("cannot continue from the checkpoint: {0}")]
    Restore(String),
    #[error("linear acoustics about rest: {0}")]
    LinearAcoustics(String),
    #[error("fluid.blocks fill no particle: spacing {spacing} m is larger than every block")]
    NoParticles { spacing: f64 },
    #[error("{what} needs {needed} bytes in one GPU buffer, the adapter allows {limit}")]
    TooLarge {
        what: String,
        needed: u64,
        limit: u64,
    },
    #[error(
        "{n} particles need {} bytes in the GPU buffer `{buffer}` ({stride} B a particle), \
         and one storage binding holds at most {limit} bytes on this adapter: this scene's \
         effects allow at most {max} particles (ARCHITECTURE.md, \"GPU memory per particle\")",
        *n as u64 * stride
    )]
    TooManyParticles {
        n: usize,
        buffer: String,
        stride: u64,
        limit: u64,
        max: u64,
    },
    #[error(
        "set_bodies: {got} coupling points, but the marker capacity fixed at the first call is {capacity}"
    )]
    MarkerCount { got: usize, capacity: usize },
    #[error(
        "set_bodies: coupling point {index} names body {body}, but only {n_bodies} body states were given"
    )]
    MarkerBody {
        index: usize,
        body: u32,
        n_bodies: usize,
    },
    #[error(
        "set_bodies: coupling points are not contiguous per body: point {index} returns to body {body}"
    )]
    MarkerOrder { index: usize, body: u32 },
    #[error(
        "set_bodies: {got} body accelerations for {states} body states (give one per state, or none)"
    )]
    AccelerationCount { got: usize, states: usize },
    #[error("set_bodies: {what} of {item} is not finite: {value}")]
    NonFiniteInput {
        what: &'static str,
        item: String,
        value: String,
    },
    #[error(
        "set_bodies: body state {index} names body {body}, beyond the {capacity} bodies the solver was set up for"
    )]
    BodyIndex {
        index: usize,
        body: u32,
        capacity: usize,
    },
    #[error("particle set: {what} has {got} entries, expected {expected}")]
    BadParticleSet {
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error("advance: window {window} s must be a positive finite number")]
    BadWindow { window: f64 },
    #[error(
        "blow-up at step {step} (t = {time:.6e} s): particle {id} ({kind}) has {what} = {value}; \
         valid: finite, density within [{rho_min}, {rho_max}] kg/m³, speed below {u_max} m/s \
         (checked once a coupling window: it began after step {since_step}, t = {since_time:.6e} s, \
         where the last check passed)"
    )]
    BlowUp {
        step: u64,
        time: f64,
        /// The window's start: the last step at which the check passed. The state is
        /// checked once a window, so the blow-up began in (since_step, step]; by the
        /// check, NaN may have spread to every particle, which is why `id` (the smallest
        /// bad id) need not be where it began.
        since_step: u64,
        since_time: f64,
        id: u32,
        kind: &'static str,
        what: &'static str,
        value: String,
        rho_min: f64,
        rho_max: f64,
        u_max: f64,
    },
    #[error("neighbour grid at step {step}: {message}")]
    Grid { step: u64, message: String },
    #[error(
        "porosity ε = {porosity} ≤ 0 at {at} (Robinson eq. 9): the grains within one kernel \
         support there hold more solid volume than the kernel can smooth; lengthen the \
         coupling length (fluid.smoothing_length or fluid.spacing) or space the grains out"
    )]
    Porosity { at: String, porosity: f64 },
    #[error(
        "starting masses among unresolved grains (initial_mass.rs): {0}; the grains and the \
         fluid lattice make a system the solve does not expect: report it with the scene"
    )]
    InitialMass(String),
}
