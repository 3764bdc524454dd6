//! Settling cylinder (Joubert §3.2/§4.1, scenes/settling-cylinder.toml: the 12-face
//! cylinder spanning a periodic z, the corrected scheme with particle shifting) end to end
//! through `couplet validate settling-cylinder --quick`, issue 4's reduced case 1: the
//! body falls, and at its plateau the fluid force carries the submerged weight
//! (ρs − ρf) V g within 3 % (reference: the body's own weight; the force is the recorded
//! loads of Joubert eqs. 31 and 36); no NaN. The plateau itself (velocity change over the
//! last fifth of the fall) is reported at this radius, r = 1.25δ (`PLATEAU_JUDGED_RADIUS`
//! in `orchestrator/src/validate/joubert.rs`), and the test checks that it is. Re at the plateau is
//! reported: Table 2's figures are at δ = 0.25 mm and finer, which need a GPU
//! (`couplet validate settling-cylinder`).
//!
//! Quick version: δ = 1 mm (r = 1.25 δ), the box 20 × 40 mm with the release at 32 mm,
//! z span 8 mm, to t = 0.55 s (0.6 s until 2026-11-27; the fall ends at 0.497 s).
//! Measured 2026-11-25 before and after rapier took the bodies in a length unit of its
//! own (round-off only): force 2.65 % and 2.56 % above the
//! submerged weight (the body still slowing from its overshoot), plateau change 2.74 % and
//! 6.57 % (the 12-gon at r = 1.25δ rocks, its speed swinging ±10 % over about 0.02 s),
//! Re 13.84 and 13.94; 199 s. With Joubert's mass correction (Γ = 2) and particle
//! shifting counting each marker as its patch (2026-11-26): force 0.22 % off, plateau
//! change 0.39 %, Re 14.56; 245 s. Cut to 0.55 s (2026-11-27, 324 s beside another run):
//! force 0.06 % off, plateau change 0.19 %, Re 14.60.
//!
//! CI cuts the quick further (2026-11-28, when a clean-clone CI run took 54 minutes):
//! the box 30 mm high with the release at 22 mm, to t = 0.35 s. The fall (to two
//! diameters above the floor) then ends at t = 0.326 s, its last fifth well past the
//! overshoot (the speed within 56.4–57.6 mm/s from 0.18 s on). Measured to 0.42 s
//! (226 s on lavapipe, alone; the quick took 391 s in that CI run): force 0.12 % off,
//! plateau change 0.33 %, Re 14.34; the test as cut, 181 s alone and 157 s in the next
//! clean-clone CI run.

use couplet_tests::{assert_rows, couplet_validate, report_rows};

use crate::CLI;

#[test]
fn settling_cylinder_quick_validation_passes() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_validate(
        CLI,
        "settling-cylinder",
        out.path(),
        &[
            "--set",
            "domain.max=[0.02, 0.03, 0.008]",
            "--set",
            "fluid.blocks.0.max=[0.02, 0.03, 0.008]",
            "--set",
            "bodies.0.position=[0.01, 0.022, 0.004]",
            "--set",
            "time.end=0.35",
        ],
    );
    let rows = report_rows(out.path());
    assert_rows(&rows, "PASS", &["body state finite", "submerged weight"]);
    // The plateau at r = 1.25δ.
    assert_rows(&rows, "reported", &["last fifth of the fall"]);
    assert!(o.status.success(), "a judged row failed: {rows:?}");
}
