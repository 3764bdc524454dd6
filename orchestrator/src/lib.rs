//! The `couplet` orchestrator: launches the fluid and DEM servers, keeps them in lockstep
//! window by window, records runs (MCAP, CSV, VTK), plans and benchmarks scenes, and serves the
//! gRPC control API.

pub use run::{RunError, RunOptions, RunSummary, run};
pub use window::{WindowPlan, choose_window};

pub mod bench;
pub mod cli;
pub mod ctl;
pub mod interrupt;
pub mod launch;
pub mod outputs;
pub mod plan;
pub mod record;
pub mod resume;
pub mod robinson_reference;
pub mod run;
pub mod serve;
pub mod validate;
pub mod vtk;
pub mod window;
