//! couplet's fluid server: weakly compressible SPH (standard scheme) on wgpu compute
//! shaders, one operator per `.rs` + `shaders/*.wgsl` pair, each with its CPU `f64` twin.

pub use constants::{SphConstants, StepParams};
pub use error::FluidError;
pub use kernel::SmoothingKernel;
pub use limits::FluidLimits;
pub use particles::{Kind, ParticleKinds, ParticleSet, initial_particles};
pub use plan::{Stage, stages};
pub use solver::{FluidSolver, GradientReadback, Op, ParticleCounts};
pub use window_stats::WindowStats;

pub mod gpu;
pub mod neighbour_grid;
pub mod prefix_sum;
pub mod server;
pub mod shaders;
pub mod timing;

pub mod adami2012_boundary_pressure;
pub mod blowup_check;
pub mod body_load_reduce;
pub mod body_non_penetration;
pub mod checkpoint;
pub mod constants;
pub mod continuity;
pub mod drag;
pub mod error;
pub mod fluid_rates;
pub mod fluid_rows;
pub mod initial_mass;
pub mod integrate;
pub mod joubert2020_body_loads;
pub mod joubert2020_boundary_values;
pub mod joubert2020_gradients;
pub mod kernel;
pub mod limits;
pub mod linear_acoustics;
pub mod marker_update;
pub mod momentum;
pub mod neighbour_count;
pub mod particle_shifting;
pub mod particles;
pub mod plan;
pub mod porosity;
pub mod robinson_variable_h;
pub mod solver;
pub mod sph_kernel;
pub mod tait_eos;
pub mod unresolved_coupling;
pub mod window_stats;
