//! Taylor–Green vortex at Re = 100 (scenes/taylor-green.toml: periodic in x, y and a
//! thin z span, Joubert's corrected gradients and Laplacian with particle shifting) end
//! to end through `couplet validate taylor-green --quick`: the decay rate of the
//! kinetic energy within 2 % of the analytic 2b = −16π²ν/L² (issue 3; the reference is
//! `../shared/validation/taylor_green_2d_decay.csv`'s b = −8π²/Re). The fit is in
//! `orchestrator/src/validate/fluid.rs` (`taylor_green`).
//!
//! Quick version: δ = L/25, z span 8 δ, to t = 0.3 s (5 000 particles). Measured
//! 2026-11-22: −1.5660 1/s against −1.5791 1/s, 0.83 %.

use couplet_tests::{assert_rows, couplet_validate, report_rows};

use crate::CLI;

#[test]
fn taylor_green_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(CLI, "taylor-green", out.path(), &[]);
    let rows = report_rows(out.path());
    assert_rows(&rows, "PASS", &["decay rate"]);
    assert!(o.status.success(), "a judged row failed: {rows:?}");
}
