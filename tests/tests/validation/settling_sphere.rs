//! Settling sphere (Joubert 2020 §4.2, scenes/settling-sphere.toml, with the scene's
//! gradient correction and particle shifting) end to end through `couplet validate
//! settling-sphere --quick`: the sphere accelerates, lands on the floor and comes to rest
//! there through DEM contact (vertical speed below 1 mm/s; the recirculating fluid rolls
//! it slowly along the floor, which is reported, not judged); no NaN. The plateau
//! (velocity change over the last fifth of the fall, issue 2's 3 %) is judged from
//! r = 2δ only (`PLATEAU_JUDGED_RADIUS` in `orchestrator/src/validate/joubert.rs`): at the quick's
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

use couplet_tests::{
    assert_rows, couplet_run, couplet_validate, read_recording, report_rows, scene, sign_flip_share,
};

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

/// A light sphere rises steadily under the serial-explicit coupling (issue 4, "light
/// bodies"). The settling sphere's quick (δ = 1 mm, r = 1.25 δ, support 2.4 δ, the box
/// 30 mm high) with ρs = 300 kg/m³, released at 10 mm, to t = 0.15 s (it reaches the lid
/// at about 0.165 s). A sphere's added mass is half the fluid it displaces, 1.67 times
/// this body's own: a partitioned scheme whose loads lag the body's acceleration would
/// amplify each window's velocity change by −1.67 and flip its sign every window.
///
/// Judged over t ∈ [0.05, 0.15] s, where it rises at its terminal speed:
/// - the mean vertical fluid force against the net buoyancy (ρf − ρs) V g = 5.618e-5 N
///   (gravity acts on the solid only, Joubert eq. (28), so the fluid force is the drag,
///   which at terminal speed carries it), within 3 %;
/// - the share of windows whose velocity change has the opposite sign of the one before,
///   below 20 % (an added-mass instability makes it nearly 100 %).
///
/// Measured 2026-11-28 (lavapipe, `couplet run` of the same scene to 0.3 s): force
/// 0.9977 of the net buoyancy, speed 0.1106–0.1203 m/s, 18 sign changes in 604 windows
/// (3 %).
#[test]
fn a_light_sphere_rises_steadily_under_the_explicit_coupling() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_run(
        CLI,
        &scene("settling-sphere"),
        out.path(),
        &[
            "--set",
            "fluid.spacing=1e-3",
            "--set",
            "fluid.support=2.4",
            "--set",
            "domain.max=[0.015, 0.03, 0.015]",
            "--set",
            "fluid.blocks.0.max=[0.015, 0.03, 0.015]",
            "--set",
            "bodies.0.position=[0.0075, 0.01, 0.0075]",
            "--set",
            "bodies.0.density=300.0",
            "--set",
            "time.end=0.15",
        ],
    );
    assert!(o.status.success(), "the run failed");
    let rec = read_recording(&out.path().join("run.mcap")).unwrap();
    let judged = |t: f64| (0.05..=0.15 + 1e-9).contains(&t);
    let forces: Vec<f64> = rec
        .loads
        .iter()
        .filter(|l| l.body == 0 && judged(l.time))
        .map(|l| l.force[1])
        .collect();
    let speeds: Vec<f64> = rec
        .bodies
        .iter()
        .filter(|b| b.body == 0 && judged(b.time))
        .map(|b| b.velocity[1])
        .collect();
    assert!(
        forces.len() > 100 && speeds.len() > 100,
        "{} loads and {} states over the judged stretch",
        forces.len(),
        speeds.len()
    );
    let net_buoyancy =
        (1000.0 - 300.0) * 4.0 / 3.0 * std::f64::consts::PI * 1.25e-3f64.powi(3) * 9.81;
    let drag = -forces.iter().sum::<f64>() / forces.len() as f64;
    let share = sign_flip_share(&speeds).unwrap();
    let (lo, hi) = speeds
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    eprintln!(
        "drag {drag:.4e} N against the net buoyancy {net_buoyancy:.4e} N; speed {lo:.4}–{hi:.4} m/s; {:.1} % of the velocity changes flip sign",
        100.0 * share
    );
    assert!(lo > 0.0, "the sphere sank at {lo} m/s");
    let err = (drag - net_buoyancy).abs() / net_buoyancy;
    assert!(err < 0.03, "drag {drag} N is {err:.3} off the net buoyancy");
    assert!(share < 0.2, "{share:.2} of the velocity changes flip sign");
}
