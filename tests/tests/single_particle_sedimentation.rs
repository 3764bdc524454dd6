//! Robinson's single-particle sedimentation (scenes/single-particle-sedimentation.toml:
//! one unresolved grain d = 0.1 mm, ρp = 2500, in a 4 × 4 × 6 mm water column periodic
//! across, Stokes drag, gravity on the fluid) end to end through `couplet validate
//! single-particle-sedimentation --quick`: the grain's velocity within 2 % of v_t of
//! Robinson eq. (34) after one relaxation time (Robinson §5.1's bound). The comparison
//! is in `orchestrator/src/validate.rs` (`single_particle_sedimentation`).
//!
//! Quick version: δ = 0.5 mm (h/d = 5), 800 fluid particles. Measured 2026-11-23:
//! 0.86 % at c_s = 10 m/s (5.45 % at c_s = 2.5 m/s, where the column's acoustic
//! breathing shakes the sampled pressure gradient).

use couplet_tests::{couplet_validate, report_rows};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn single_particle_sedimentation_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(CLI, "single-particle-sedimentation", out.path(), &[]);
    let rows = report_rows(out.path());
    assert!(
        rows.iter()
            .any(|(q, r)| q.contains("eq. (34)") && r == "PASS"),
        "eq. (34) row: {rows:?}"
    );
    assert!(o.status.success(), "a judged row failed: {rows:?}");
}
