//! Drafting, kissing and tumbling (Joubert §3.3, scenes/dkt.toml: two 12-face cylinders
//! along a periodic z, the corrected scheme with particle shifting, contact by rapier)
//! end to end through `couplet validate dkt --quick`, issue 4's reduced case 5. Every row
//! is judged (`dkt` in `orchestrator/src/validate.rs`): the trailing body falls more than
//! 5 % faster than the leading one before they meet (drafting), their centres come within
//! 2r + δ (kissing), the line between them turns past 90° from vertical (tumbling), the
//! prisms never overlap by more than rapier's contact slop, and the states stay finite.
//!
//! Quick version: δ = 0.5 mm (r = 2 δ) at support 2.4 δ, z span 3 mm, the box cut to 40 mm
//! with the pair released 30 and 33 mm up, to t = 0.6 s. Measured 2026-11-25 (the same
//! run to 0.8 s, 677 s): drafting 24.9 %, kiss at 1.9341 mm (t = 0.339 s; the 12-gons
//! touch at 1.932 mm), tumbling 121.5° (past 90° at t = 0.611 s), overlap 9.6e-8 m.
//! With the scene's mass correction (Γ = 2) and particle shifting counting each marker
//! as its patch (2026-11-26, to 0.7 s, 801 s): drafting 33.35 %, kiss at 1.9350 mm
//! (t = 0.371 s), tumbling 120.2° (past 90° at t = 0.560 s), overlap 4.8e-7 m; cut to
//! 0.63 s to keep CI under 40 minutes (726 s): 32.15 %, 1.9374 mm at 0.365 s, 118.4°
//! (past 90° at 0.544 s), overlap 1.3e-7 m; cut to 0.6 s when CI had taken 45 minutes
//! (797 s beside another run): 33.35 %, 1.9350 mm at 0.371 s, 104.4° (past 90° at
//! 0.560 s), overlap 4.8e-7 m.

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
