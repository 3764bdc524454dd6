//! Drafting, kissing and tumbling (Joubert §3.3, scenes/dkt.toml: two 12-face cylinders
//! along a periodic z, the corrected scheme with particle shifting, contact by rapier)
//! end to end through `couplet validate dkt --quick`, issue 4's reduced case 5. Every row
//! is judged (`dkt` in `orchestrator/src/validate.rs`): the trailing body falls more than
//! 5 % faster than the leading one before they meet (drafting), their centres come within
//! 2r + δ (kissing), the line between them turns past 90° from vertical (tumbling), the
//! prisms never overlap by more than rapier's contact slop, and the states stay finite.
//!
//! Quick version: δ = 0.5 mm (r = 2 δ) at support 2.4 δ, z span 3 mm, the box cut to
//! 14 × 38 mm with the pair released 30 and 33 mm up, the upper one 0.05 mm (0.1 δ) off
//! the centre line so that the tumbling, an instability growing from that offset, comes
//! sooner, to t = 0.5 s. Measured 2026-11-27 (the same run to 0.6 s, 585 s): drafting
//! 34.22 %, kiss at 1.9460 mm (t = 0.356 s; the 12-gons touch at 1.932 mm), tumbling
//! 119.5° (past 90° at t = 0.458 s), overlap 1.4e-7 m. The quick before (a 20 × 40 mm
//! box, the scene's 0.01 mm offset, to 0.6 s, 871 s of a 43-minute CI run): 33.35 %,
//! 1.9350 mm at 0.371 s, 104.4° (past 90° at 0.560 s), overlap 4.8e-7 m.

use couplet_tests::{assert_rows, couplet_validate, report_rows};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn dkt_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(CLI, "dkt", out.path(), &[]);
    let rows = report_rows(out.path());
    assert_rows(
        &rows,
        "PASS",
        &[
            "body states finite",
            "drafting",
            "kissing",
            "tumbling",
            "deepest overlap",
        ],
    );
    assert!(o.status.success(), "a judged row failed: {rows:?}");
}
