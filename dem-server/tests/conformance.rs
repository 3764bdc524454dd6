//! The `DemEngine` conformance suite: every engine in the registry passes the same
//! tests (iceoryx2 `conformance-tests` style). Adding an engine adds one line to the
//! `conformance!` invocation at the bottom.

mod common;

use common::{WATER, cuboid, scene, sphere};
use couplet_dem::{DemEngine, DemError, create_engine};
use couplet_protocol::{BodyLoad, BodyState, Scene};

const G: f64 = 9.81;

/// What an engine may deviate by, where engines legitimately differ.
#[derive(Clone, Copy)]
pub struct Allowance {
    /// Largest overlap of resting contacts, as a fraction of the smallest body's size ∛V.
    pub penetration_rel: f64,
}

fn engine(name: &str, extra: &str) -> Box<dyn DemEngine> {
    let s: Scene = scene(&format!(
        "[dem]\nengine = \"{name}\"\nmax_dt = 1e-4\n{extra}"
    ));
    let e = create_engine(&s).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(e.name(), name);
    assert_eq!(e.body_count(), s.bodies.len());
    e
}

fn states(e: &dyn DemEngine) -> Vec<BodyState> {
    let mut v = vec![BodyState::default(); 7]; // stale content must be replaced
    e.states(&mut v);
    v
}

/// Advances `t` in windows of `window`, each holding `loads` over substeps of at most stable_dt.
fn run(e: &mut dyn DemEngine, t: f64, window: f64, loads: &[BodyLoad]) {
    let windows = (t / window).round() as usize;
    for _ in 0..windows {
        e.set_fluid_loads(loads).unwrap();
        let n = (window / e.stable_dt()).ceil().max(1.0) as usize;
        for _ in 0..n {
            e.step(window / n as f64).unwrap();
        }
    }
}

fn load(body: u32, force: [f64; 3], moment: [f64; 3]) -> BodyLoad {
    BodyLoad {
        body,
        force,
        moment,
        ..Default::default()
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Free fall with no fluid: y = y0 − ½ g t² (Galileo). Tolerance rel 1e-3 on the drop
/// after 0.1 s; rapier's symplectic Euler with dt = 1e-4 s is off by g t dt/8, 2.5e-4 relative.
pub fn free_fall(name: &str, _: Allowance) {
    let mut e = engine(name, &sphere("ball", 0.05, 2000.0, [0.5, 0.8, 0.5], ""));
    let y0 = states(&*e)[0].position[1];
    run(&mut *e, 0.1, 0.01, &[]);
    let s = states(&*e)[0];
    let drop = y0 - s.position[1];
    assert!(
        rel(drop, 0.5 * G * 0.01) < 1e-3,
        "drop {drop} m, expected {}",
        0.5 * G * 0.01
    );
    assert!(
        rel(-s.linear_velocity[1], G * 0.1) < 1e-4,
        "v = {:?}",
        s.linear_velocity
    );
    assert!(
        s.position[0] == 0.5 && s.position[2] == 0.5,
        "no sideways drift: {:?}",
        s.position
    );
}

/// Joubert eq. (28): with gravity off the fluid, a resolved sphere of ρ_s = 1250 in water
/// accelerates at g (1 − 1000/1250) = 0.2 g; an uncoupled one (coupling = "none") at g.
/// Tolerance rel 1e-3 on the drop after 0.1 s.
pub fn buoyancy_eq28(name: &str, _: Allowance) {
    let bodies = sphere("resolved", 0.05, 1250.0, [0.3, 0.4, 0.5], "")
        + &sphere("dry", 0.05, 1250.0, [0.7, 0.8, 0.5], "coupling = \"none\"");
    let mut e = engine(
        name,
        &format!("{WATER}\n[gravity]\non_fluid = false\n{bodies}"),
    );
    let y0: Vec<f64> = states(&*e).iter().map(|s| s.position[1]).collect();
    run(&mut *e, 0.1, 0.01, &[]);
    let s = states(&*e);
    let expected = 0.5 * G * (1.0 - 1000.0 / 1250.0) * 0.01;
    assert!(
        rel(y0[0] - s[0].position[1], expected) < 1e-3,
        "drop {} vs {expected}",
        y0[0] - s[0].position[1]
    );
    assert!(
        rel(y0[1] - s[1].position[1], 0.5 * G * 0.01) < 1e-3,
        "uncoupled drop {}",
        y0[1] - s[1].position[1]
    );
    // The reported mass and volume are what eq. (28) uses.
    let v = 4.0 / 3.0 * std::f64::consts::PI * 0.05f64.powi(3);
    assert!(rel(s[0].volume, v) < 1e-12 && rel(s[0].mass, 1250.0 * v) < 1e-12);
}

/// Newton's second law under a held fluid load, no gravity: Δv = F t / m, and a new
/// load replaces the old one (windows 1–5 carry F, 6–10 carry 2F: Δv = 3 F (t/2) / m).
/// Loads re-sent every window must not accumulate. Tolerance rel 1e-3.
pub fn held_force(name: &str, _: Allowance) {
    let mut e = engine(
        name,
        &format!(
            "[gravity]\nvector = [0, 0, 0]\n{}",
            sphere("ball", 0.05, 1000.0, [0.5, 0.5, 0.5], "")
        ),
    );
    let m = states(&*e)[0].mass;
    let f = [0.3, -0.2, 0.1];
    run(&mut *e, 0.05, 0.01, &[load(0, f, [0.0; 3])]);
    run(
        &mut *e,
        0.05,
        0.01,
        &[load(0, f.map(|x| 2.0 * x), [0.0; 3])],
    );
    let v = states(&*e)[0].linear_velocity;
    for k in 0..3 {
        let expected = 3.0 * f[k] * 0.05 / m;
        assert!(
            rel(v[k], expected) < 1e-3,
            "v[{k}] = {} expected {expected}",
            v[k]
        );
    }
    // No load: the body coasts.
    run(&mut *e, 0.02, 0.01, &[]);
    let v2 = states(&*e)[0].linear_velocity;
    assert!((0..3).all(|k| rel(v2[k], v[k]) < 1e-5), "{v2:?} vs {v:?}");
}

/// Euler's equation with an isotropic inertia: Δω = I⁻¹ M t, I = 2/5 m r² for a sphere
/// (no gyroscopic term since ω ∥ Iω). Tolerance rel 1e-3.
pub fn held_moment(name: &str, _: Allowance) {
    let r = 0.05;
    let mut e = engine(
        name,
        &format!(
            "[gravity]\nvector = [0, 0, 0]\n{}",
            sphere("ball", r, 1000.0, [0.5, 0.5, 0.5], "")
        ),
    );
    let m = states(&*e)[0].mass;
    let inertia = 0.4 * m * r * r;
    let moment = [1e-3, 0.0, -2e-3];
    run(&mut *e, 0.1, 0.01, &[load(0, [0.0; 3], moment)]);
    let w = states(&*e)[0].angular_velocity;
    for k in [0, 2] {
        assert!(
            rel(w[k], moment[k] * 0.1 / inertia) < 1e-3,
            "ω[{k}] = {} expected {}",
            w[k],
            moment[k] * 0.1 / inertia
        );
    }
    assert!(w[1].abs() < 1e-6 * w[2].abs());
}

/// A sphere dropped on the floor comes to rest on it: centre height = r within 2 % of r,
/// speed < 1e-3 m/s after 1.5 s (restitution 0).
pub fn sphere_rests_on_floor(name: &str, _: Allowance) {
    let r = 0.05;
    let mut e = engine(name, &sphere("ball", r, 2000.0, [0.5, 0.2, 0.5], ""));
    run(&mut *e, 1.5, 1e-3, &[]);
    let s = states(&*e)[0];
    assert!(
        (s.position[1] - r).abs() < 0.02 * r,
        "height {} vs r = {r}",
        s.position[1]
    );
    let speed = s.linear_velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(speed < 1e-3, "speed {speed}");
}

/// Two boxes dropped on each other settle as a stack: neither overlaps the other or the
/// floor by more than the engine's contact allowance (rapier: its allowed linear error,
/// 0.005 ∛V of the smallest body).
pub fn boxes_do_not_interpenetrate(name: &str, allow: Allowance) {
    let h = 0.05;
    let bodies = cuboid("lower", [h; 3], 1000.0, [0.5, 0.2, 0.5], "")
        + &cuboid(
            "upper",
            [h; 3],
            1000.0,
            [0.51, 0.4, 0.49],
            "rotation = [0, 0.3, 0]",
        );
    let mut e = engine(name, &bodies);
    let tol = allow.penetration_rel * 2.0 * h;
    let mut worst: f64 = 0.0;
    for _ in 0..150 {
        run(&mut *e, 0.01, 1e-3, &[]);
        let s = states(&*e);
        // Both boxes stay upright here (yaw only), so vertical gaps are face gaps.
        worst = worst
            .max(h - s[0].position[1])
            .max(2.0 * h - (s[1].position[1] - s[0].position[1]));
    }
    let s = states(&*e);
    assert!(worst < tol + 0.02 * h, "worst transient overlap {worst} m");
    assert!(
        (s[0].position[1] - h).abs() < tol,
        "lower box at {}",
        s[0].position[1]
    );
    assert!(
        (s[1].position[1] - 3.0 * h).abs() < 2.0 * tol,
        "upper box at {}",
        s[1].position[1]
    );
}

/// A kinematic body moves with its set velocities whatever acts on it: x = x0 + v t,
/// rotation angle ω t, under gravity and a large load. Tolerance 1e-9 m and 1e-9 rad:
/// the motion is prescribed, so nothing but round-off may move it off.
pub fn kinematic_ignores_loads(name: &str, _: Allowance) {
    let extra = "motion = \"kinematic\"\nvelocity = [0.2, 0.1, 0]\nangular_velocity = [0, 0, 1.0]";
    let mut e = engine(
        name,
        &sphere("piston", 0.05, 1000.0, [0.3, 0.5, 0.5], extra),
    );
    run(
        &mut *e,
        0.5,
        0.01,
        &[load(0, [100.0, 100.0, 100.0], [1.0, 1.0, 1.0])],
    );
    let s = states(&*e)[0];
    let expected = [0.3 + 0.2 * 0.5, 0.5 + 0.1 * 0.5, 0.5];
    assert!(
        (0..3).all(|k| (s.position[k] - expected[k]).abs() < 1e-9),
        "{:?} vs {expected:?}",
        s.position
    );
    assert_eq!(
        s.linear_velocity.map(|v| (v * 1e6).round()),
        [0.2e6, 0.1e6, 0.0]
    );
    let angle = 2.0 * s.orientation[2].atan2(s.orientation[3]);
    assert!((angle - 0.5).abs() < 1e-9, "angle {angle}");
}

/// A fixed body never moves, even under a load and with a dynamic body landing on it.
pub fn fixed_never_moves(name: &str, _: Allowance) {
    let bodies = cuboid(
        "table",
        [0.2, 0.05, 0.2],
        1000.0,
        [0.5, 0.3, 0.5],
        "motion = \"fixed\"\nvelocity = [1, 0, 0]",
    ) + &sphere("ball", 0.05, 5000.0, [0.5, 0.6, 0.5], "");
    let mut e = engine(name, &bodies);
    let before = states(&*e)[0];
    run(
        &mut *e,
        0.5,
        0.01,
        &[load(0, [1e3, 1e3, 1e3], [1e2, 1e2, 1e2])],
    );
    let s = states(&*e);
    assert_eq!(s[0].position, before.position);
    assert_eq!(s[0].orientation, before.orientation);
    assert_eq!(s[0].linear_velocity, [0.0; 3]);
    // The ball rests on the table top (y = 0.35) rather than falling through.
    assert!(
        (s[1].position[1] - 0.4).abs() < 0.02 * 0.05,
        "ball at {}",
        s[1].position[1]
    );
}

/// Bad loads are refused with the body and the value named; good loads still apply after.
pub fn bad_loads_are_refused(name: &str, _: Allowance) {
    let mut e = engine(name, &sphere("ball", 0.05, 1000.0, [0.5, 0.5, 0.5], ""));
    let msg = e
        .set_fluid_loads(&[load(3, [0.0; 3], [0.0; 3])])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("body 3") && msg.contains("0..1"), "{msg}");
    let msg = e
        .set_fluid_loads(&[load(0, [f64::NAN, 0.0, 0.0], [0.0; 3])])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("\"ball\"") && msg.contains("NaN"), "{msg}");
    let msg = e
        .set_fluid_loads(&[load(0, [0.0; 3], [0.0; 3]); 2])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("twice") || msg.contains("both"), "{msg}");
    assert!(matches!(e.step(-1.0), Err(DemError::InvalidStep { .. })));
    assert!(matches!(
        e.step(f64::NAN),
        Err(DemError::InvalidStep { .. })
    ));
}

/// Generates one `#[test]` per conformance case for each `engine: allowance` pair.
macro_rules! conformance {
    ($($engine:ident: $allow:expr),* $(,)?) => {$(
        mod $engine {
            use super::*;
            const ALLOW: Allowance = $allow;
            #[test] fn free_fall() { super::free_fall(stringify!($engine), ALLOW) }
            #[test] fn buoyancy_eq28() { super::buoyancy_eq28(stringify!($engine), ALLOW) }
            #[test] fn held_force() { super::held_force(stringify!($engine), ALLOW) }
            #[test] fn held_moment() { super::held_moment(stringify!($engine), ALLOW) }
            #[test] fn sphere_rests_on_floor() { super::sphere_rests_on_floor(stringify!($engine), ALLOW) }
            #[test] fn boxes_do_not_interpenetrate() { super::boxes_do_not_interpenetrate(stringify!($engine), ALLOW) }
            #[test] fn kinematic_ignores_loads() { super::kinematic_ignores_loads(stringify!($engine), ALLOW) }
            #[test] fn fixed_never_moves() { super::fixed_never_moves(stringify!($engine), ALLOW) }
            #[test] fn bad_loads_are_refused() { super::bad_loads_are_refused(stringify!($engine), ALLOW) }
        }
    )*};
}

conformance! {
    rapier: Allowance { penetration_rel: couplet_dem::rapier_engine::NORMALIZED_ALLOWED_LINEAR_ERROR },
}

/// Every registered engine is covered by this suite.
#[test]
fn suite_covers_every_registered_engine() {
    assert_eq!(couplet_dem::engine_names(), &["rapier"]);
}

/// An unknown engine name is refused with the valid names listed.
#[test]
fn unknown_engine_lists_valid_names() {
    let s = scene(&format!(
        "[dem]\nengine = \"bullet\"\n{}",
        sphere("b", 0.05, 1000.0, [0.5, 0.5, 0.5], "")
    ));
    let msg = create_engine(&s)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        msg.contains("\"bullet\"") && msg.contains("rapier"),
        "{msg}"
    );
}
