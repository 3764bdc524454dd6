//! Drafting, kissing and tumbling (Joubert §3.3, scenes/dkt.toml: two 12-face cylinders
//! along a periodic z, the corrected scheme with particle shifting, contact by rapier)
//! end to end through `couplet validate dkt --quick`, issue 4's reduced case 5. Every row
//! is judged (`dkt` in `orchestrator/src/validate/joubert.rs`): the trailing body falls more than
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
//!
//! CI cuts the quick further (2026-11-28, when a clean-clone CI run took 54 minutes, the
//! quick 793 s of them): the pair starts 2.5 mm apart (not 3) with the upper one 0.15 mm
//! (0.3 δ) off the centre line, so it kisses and tumbles sooner, and as by then it has
//! fallen only 10 mm the box is cut to 14 × 26 mm with the pair released 18 and 20.5 mm
//! up, to t = 0.4 s: 55 % of the quick's particle-steps. Starting 2.5 mm apart the pair
//! already meets the kissing row's 2r + δ, so the test also asserts that they came
//! within 2r, nearer than 2r + δ: the 12-gons touch at 2r cos 15° = 1.932 mm. Measured
//! (lavapipe, beside a build): drafting 38.75 %, kissing 1.9659 mm at t = 0.236 s,
//! tumbling 106.2° (past 90° at 0.356 s), overlap 9.7e-8 m; the lower body's centre
//! 7.6 mm above the floor at the end; 392 s alone, 424 s in the next clean-clone CI run
//! (44 min 36 s in all). The same start in the quick's box to 0.45 s: 39.46 %,
//! 1.9662 mm at 0.237 s, past 90° at 0.352 s.

use couplet_tests::{assert_rows, couplet_validate, report_rows};

use crate::CLI;

/// The pair's radius (scenes/dkt.toml), m.
const R: f64 = 1e-3;

#[test]
fn dkt_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(
        CLI,
        "dkt",
        out.path(),
        &[
            "--set",
            "domain.max=[0.014, 0.026, 0.003]",
            "--set",
            "fluid.blocks.0.max=[0.014, 0.026, 0.003]",
            "--set",
            "bodies.0.position=[0.007, 0.018, 0.0015]",
            "--set",
            "bodies.1.position=[0.00685, 0.0205, 0.0015]",
            "--set",
            "time.end=0.4",
        ],
    );
    let rows = report_rows(out.path());
    let report = std::fs::read_to_string(out.path().join("report.md")).unwrap();
    let closest: f64 = report
        .lines()
        .find(|l| l.starts_with("| kissing"))
        .and_then(|l| l.split('|').nth(2))
        .and_then(|m| m.trim().strip_suffix(" m"))
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("no kissing row with a distance: {report}"));
    assert!(closest < 2.0 * R, "closest centre distance {closest:e} m");
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
