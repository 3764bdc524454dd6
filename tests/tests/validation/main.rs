//! The validation cases that CI runs end to end, one module per case, all in one test
//! binary.
//!
//! **Why one binary.** Cargo runs test binaries one after another, and libtest runs the
//! tests of one binary side by side (as many as the machine has cores). A case run on
//! lavapipe keeps only about 1.5 of the CI machine's 2 cores busy: the lid-driven cavity's
//! test alone took 130.4 s of wall time for 198.5 s of CPU (2026-11-28). Two of them side
//! by side took 184 s for both, against 261 s one after the other. Each case used to be
//! a binary of its own, so a binary with one test ran with the other core half idle.
//! Here libtest always has a second case to run beside the first. The sixteen tests
//! took 1785 s as twelve binaries in the clean-clone CI run of 2026-11-28 (the cavity's
//! 132 s of them) and 1610 s as this binary on the same machine the same day, with 1.92
//! cores busy (3091 s of CPU). Giving each lavapipe one thread (`LP_NUM_THREADS=1`)
//! made the cavity pair slower: 202 s against 184 s.
//!
//! Tests that watch the clock or a process's life (`killed_child.rs`, `grpc.rs`,
//! `external_server.rs`) stay in their own binaries.
//!
//! One case: `cargo test --release -p couplet-tests --test validation dkt` (a filter on
//! the module path).

/// The `couplet` CLI that these tests drive (`tests/src/bin/couplet-cli.rs`).
const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

mod buoyancy;
mod channel_flow;
mod constant_porosity_block;
mod dam_break_boxes;
mod dkt;
mod hydrostatic_tank;
mod lid_driven_cavity;
mod settling_cylinder;
mod settling_sphere;
mod shape_drag;
mod single_particle_sedimentation;
mod taylor_green;
