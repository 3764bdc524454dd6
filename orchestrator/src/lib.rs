//! The `couplet` orchestrator: launches the fluid and DEM servers, keeps them in lockstep
//! window by window, records runs to MCAP, plans and benchmarks scenes.

pub use run::{run, RunError, RunOptions, RunSummary};
pub use window::{choose_window, WindowPlan};

pub mod bench;
pub mod cli;
pub mod launch;
pub mod plan;
pub mod record;
pub mod run;
pub mod window;
