//! Settling sphere (Joubert 2020 §4.2, scenes/settling-sphere.toml, with the scene's
//! gradient correction and particle shifting) end to end through `couplet validate
//! settling-sphere --quick`: the sphere accelerates, lands on the floor and comes to rest
//! there through DEM contact (vertical speed below 1 mm/s; the recirculating fluid rolls
//! it slowly along the floor, which is reported, not judged); no NaN. The plateau
//! (velocity change over the last fifth of the fall, issue 2's 3 %) is judged from
//! r = 2δ only (`PLATEAU_JUDGED_RADIUS` in `orchestrator/src/validate.rs`): at the quick's
//! r = 1.25δ it is reported, and the test checks that it is. The plateau velocity is
//! reported next to the correlation of Joubert eqs. (37)–(38).
//!
//! Quick version: δ = 1 mm (r = 1.25 δ), support 2.4 δ, the box cut to 30 mm high with the
//! release at 20 mm, to t = 0.5 s (0.6 s until 2026-11-26). Runs repeat bit for bit on one
//! machine (stable grid sort), but the plateau at this radius is decided by round-off:
//! 2.63 % before and 4.63 % after rapier took the bodies in a length unit of its own
//! (2026-11-25; the two tracks agree to three digits until 0.22 s, then the wake's wiggles
//! of ±4 % over 0.05–0.1 s part them); plateau 0.0566 and 0.0543 m/s against 0.0482 m/s
//! from the correlation (r = 1.25 δ does not resolve the boundary layer); 132 s. With
//! particle shifting counting each marker as its patch (2026-11-26): plateau 0.0594 m/s,
//! change 0.70 %; 186 s; cut to 0.5 s to keep CI near 40 minutes, the same plateau, at rest
//! on the floor (vertical speed 0). Earlier: 2.38 % with the markers' corrected velocity
//! gradient (2026-11-23), 1.00 % with the uncorrected one; 0.55–5.14 % over four identical
//! runs before the sort was stable.
//!
//! CI cuts the quick further (2026-11-28, when a clean-clone CI run took 54 minutes):
//! the box 24 mm high with the release at 14 mm, to t = 0.38 s (the sphere lands at
//! about 0.23 s). Measured (159 s on lavapipe, alone; the quick took 264 s in that CI
//! run): at 0.05 s 0.0402 m/s, plateau 0.0571 m/s with a change of 2.33 % over the
//! last fifth (reported), at rest on the floor (centre 1.250e-3 m, vertical speed
//! 7.5e-12 m/s), rolling at 1.61 % of the plateau over the last 0.1 s; 140 s alone as a
//! test, 134 s in the next clean-clone CI run.

use couplet_tests::{assert_rows, couplet_validate, report_rows};

use crate::CLI;

#[test]
fn settling_sphere_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(
        CLI,
        "settling-sphere",
        out.path(),
        &[
            "--set",
            "domain.max=[0.015, 0.024, 0.015]",
            "--set",
            "fluid.blocks.0.max=[0.015, 0.024, 0.015]",
            "--set",
            "bodies.0.position=[0.0075, 0.014, 0.0075]",
            "--set",
            "time.end=0.38",
        ],
    );
    let rows = report_rows(out.path());
    assert_rows(
        &rows,
        "PASS",
        &["final height", "final vertical speed", "accelerates"],
    );
    // The plateau at r = 1.25δ.
    assert_rows(&rows, "reported", &["last fifth of the fall"]);
    assert!(o.status.success(), "a judged row failed: {rows:?}");
}
