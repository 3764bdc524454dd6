//! The `DemEngine` conformance suite: every engine in the registry passes the same
//! tests (iceoryx2 `conformance-tests` style). Adding an engine adds one line to the
//! `conformance!` invocation at the bottom.

mod common;

use common::{WATER, cuboid, scene, sphere};
use couplet_dem::{DemEngine, DemError, create_engine};
use couplet_protocol::{BodyLoad, BodyState, Scene};

const G: f64 = 9.81;

/// What an engine needs and may deviate by, where engines legitimately differ.
#[derive(Clone, Copy)]
pub struct Allowance {
    /// Registry name (`dem.engine`).
    pub engine: &'static str,
    /// Lines after `[dem]`'s own: the engine's contact law and material.
    pub dem: &'static str,
    /// Largest overlap of resting contacts, as a fraction of the smallest body's size ∛V.
    pub penetration_rel: f64,
    /// Relative error of the restitution coefficient measured in a head-on impact.
    pub restitution_rel: f64,
    /// Whether the engine simulates non-spherical bodies (else it must refuse them).
    pub polyhedra: bool,
}

/// Linear spring–dashpot material for the conformance spheres (r = 0.05 m, 0.5–2.6 kg):
/// a resting sphere overlaps the floor by m g / k ≈ 3e-5 m, 5e-4 r.
const LINEAR: &str = "[dem.soft_sphere]\ncontact = \"linear\"\nstiffness = 1e6";
/// Hertz–Mindlin material: E = 1e8 Pa (rubber-hard, so that the conformance runs take
/// ~1e-5 s steps); a resting 1 kg sphere overlaps the floor by (m g / k_n)^{2/3} ≈ 5e-5 m.
const HERTZ: &str = "[dem.soft_sphere]\ncontact = \"hertz-mindlin\"\nyoungs_modulus = 1e8";

fn engine(allow: Allowance, extra: &str) -> Box<dyn DemEngine> {
    let name = allow.engine;
    let s: Scene = scene(&format!(
        "[dem]\nengine = \"{name}\"\nmax_dt = 1e-4\n{}\n{extra}",
        allow.dem
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
pub fn free_fall(allow: Allowance) {
    let mut e = engine(allow, &sphere("ball", 0.05, 2000.0, [0.5, 0.8, 0.5], ""));
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
pub fn buoyancy_eq28(allow: Allowance) {
    let bodies = sphere("resolved", 0.05, 1250.0, [0.3, 0.4, 0.5], "")
        + &sphere("dry", 0.05, 1250.0, [0.7, 0.8, 0.5], "coupling = \"none\"");
    let mut e = engine(
        allow,
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
pub fn held_force(allow: Allowance) {
    let mut e = engine(
        allow,
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
pub fn held_moment(allow: Allowance) {
    let r = 0.05;
    let mut e = engine(
        allow,
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
pub fn sphere_rests_on_floor(allow: Allowance) {
    let r = 0.05;
    let mut e = engine(allow, &sphere("ball", r, 2000.0, [0.5, 0.2, 0.5], ""));
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

/// An engine without polyhedra refuses `bodies`, naming the first, "lower".
fn assert_refuses_lower(allow: Allowance, bodies: &str) {
    let s = scene(&format!(
        "[dem]\nengine = \"{}\"\n{}\n{bodies}",
        allow.engine, allow.dem
    ));
    let msg = create_engine(&s)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        msg.contains("bodies[0] \"lower\"") && msg.contains("spheres only"),
        "{msg}"
    );
}

/// Two boxes dropped on each other settle as a stack: neither overlaps the other or the
/// floor by more than the engine's contact allowance (rapier: its allowed linear error,
/// 0.005 ∛V of the smallest body).
/// An engine without polyhedra refuses the boxes, naming the body.
pub fn boxes_do_not_interpenetrate(allow: Allowance) {
    let h = 0.05;
    let bodies = cuboid("lower", [h; 3], 1000.0, [0.5, 0.2, 0.5], "")
        + &cuboid(
            "upper",
            [h; 3],
            1000.0,
            [0.51, 0.4, 0.49],
            "rotation = [0, 0.3, 0]",
        );
    if !allow.polyhedra {
        assert_refuses_lower(allow, &bodies);
        return;
    }
    let mut e = engine(allow, &bodies);
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

/// `[[bodies]]` table of Joubert's 12-face cylinder of §3.3 (r = 1 mm), 4 mm long and
/// laid along z, at (x, y, 0.5); `extra` adds fields (`motion`).
fn joubert_prism(name: &str, x: f64, y: f64, extra: &str) -> String {
    format!(
        "[[bodies]]\nname = \"{name}\"\nshape.prism = {{ sides = 12, radius = 1e-3, half_height = 2e-3 }}\ndensity = 1100.0\nposition = [{x:?}, {y:?}, 0.5]\nrotation = [{:?}, 0.0, 0.0]\n{extra}\n",
        std::f64::consts::FRAC_PI_2
    )
}

/// The prism's apothem r cos 15° (half the centre distance of two touching face to face).
const PRISM_APOTHEM: f64 = 1e-3 * 0.965_925_826_289_068_3;

/// The prism's size ∛V: the 12-gon's area is 3r², the prism 4 mm long.
fn prism_size() -> f64 {
    (3.0 * 1e-6 * 4e-3_f64).cbrt()
}

/// Millimetre polyhedra collide: Joubert's 12-face cylinders of §3.3 (r = 1 mm, laid
/// along z; the upper one 0.3 mm off the lower's axis, so it rolls off), and two hull
/// cubes of 2 mm edge stacked face on face, never bring their centres closer than the
/// bodies allow — face to face 2r cos 15° for the 12-gons, the edge for the cubes — less
/// the engine's contact allowance (of ∛V) and, as for the boxes above, 2 % of the size
/// for the landing. Regression: rapier took these
/// in metres with only its `length_unit` parameter scaled, and the cylinders fell
/// through each other (their centres came within 0.004 mm), the cubes rested 0.2 mm deep.
/// An engine without polyhedra refuses them, naming the body.
pub fn millimetre_hulls_do_not_interpenetrate(allow: Allowance) {
    let cube = |name: &str, y: f64, x: f64| {
        let v: Vec<[f64; 3]> = (0..8)
            .map(|i| [0, 1, 2].map(|k| if i >> k & 1 == 1 { 1e-3 } else { -1e-3 }))
            .collect();
        format!(
            "[[bodies]]\nname = \"{name}\"\nshape.convex = {{ vertices = {v:?} }}\ndensity = 1100.0\nposition = [{x:?}, {y:?}, 0.5]\n"
        )
    };
    let cases = [
        (
            joubert_prism("lower", 0.5, 1.1e-3, "") + &joubert_prism("upper", 0.5003, 3.5e-3, ""),
            2.0 * PRISM_APOTHEM,
            prism_size(),
        ),
        (
            cube("lower", 1.1e-3, 0.5) + &cube("upper", 3.5e-3, 0.5),
            2e-3,
            2e-3,
        ),
    ];
    for (bodies, closest, size) in cases {
        if !allow.polyhedra {
            assert_refuses_lower(allow, &bodies);
            continue;
        }
        let mut e = engine(allow, &bodies);
        let mut nearest = f64::INFINITY;
        for _ in 0..300 {
            run(&mut *e, 1e-3, 1e-3, &[]);
            let s = states(&*e);
            let d = (0..2)
                .map(|k| (s[1].position[k] - s[0].position[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            nearest = nearest.min(d);
        }
        let tol = (allow.penetration_rel + 0.02) * size;
        println!(
            "{}: nearest {nearest:.4e} m, touching at {closest:.4e} m",
            allow.engine
        );
        assert!(
            nearest > closest - tol,
            "centres {nearest:.4e} m apart, the bodies touch at {closest:.4e} m (tolerance {tol:.1e})"
        );
    }
}

/// A 12-face prism (Joubert's r = 1 mm, 4 mm long) placed face on face on a fixed one
/// and left under gravity for 0.2 s stays within 1e-3 ∛V (2.3 µm) of touching. The
/// reference is the contact spring's sag: rapier's static contacts (60 Hz, scaled by
/// √(1/∛V) as `RapierEngine::new` does) sink g/ω² = 0.16 µm. Regression: rapier 0.36's
/// contact recycling kept the first step's contact (depth 0) while the pose drifted less
/// than its recycle distance, and the prism sank 118 µm (0.05 ∛V) into the fixed one;
/// in the quick DKT with the mass correction, the resting pair sank 12.5 µm, past the
/// slop the judge allows. An engine without polyhedra refuses the prisms.
pub fn resting_hulls_do_not_sink_into_each_other(allow: Allowance) {
    let bodies = joubert_prism("lower", 0.5, 0.5, "motion = \"fixed\"")
        + &joubert_prism("upper", 0.5, 0.5 + 2.0 * PRISM_APOTHEM, "");
    if !allow.polyhedra {
        assert_refuses_lower(allow, &bodies);
        return;
    }
    let mut e = engine(allow, &bodies);
    let size = prism_size();
    let mut deepest: f64 = 0.0;
    for _ in 0..2000 {
        run(&mut *e, 1e-4, 1e-4, &[]);
        let s = states(&*e);
        deepest = deepest.max(2.0 * PRISM_APOTHEM - (s[1].position[1] - s[0].position[1]));
    }
    println!("{}: deepest overlap {deepest:.3e} m", allow.engine);
    assert!(
        deepest <= 1e-3 * size,
        "the resting prism sank {deepest:.3e} m into the fixed one (allowed {:.1e} m)",
        1e-3 * size
    );
}

/// A kinematic body moves with its set velocities whatever acts on it: x = x0 + v t,
/// rotation angle ω t, under gravity and a large load. Tolerance 1e-9 m and 1e-9 rad:
/// the motion is prescribed, so nothing but round-off may move it off.
pub fn kinematic_ignores_loads(allow: Allowance) {
    let extra = "motion = \"kinematic\"\nvelocity = [0.2, 0.1, 0]\nangular_velocity = [0, 0, 1.0]";
    let mut e = engine(
        allow,
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

/// A fixed body never moves, even under a load and with a dynamic body landing on it:
/// a box table (a sphere for engines without polyhedra) with the ball resting on top.
pub fn fixed_never_moves(allow: Allowance) {
    let fixed = "motion = \"fixed\"\nvelocity = [1, 0, 0]";
    let (table, top) = if allow.polyhedra {
        (
            cuboid("table", [0.2, 0.05, 0.2], 1000.0, [0.5, 0.3, 0.5], fixed),
            0.35,
        )
    } else {
        (sphere("table", 0.15, 1000.0, [0.5, 0.3, 0.5], fixed), 0.45)
    };
    let bodies = table + &sphere("ball", 0.05, 5000.0, [0.5, 0.6, 0.5], "");
    let mut e = engine(allow, &bodies);
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
    // The ball rests on the table top rather than falling through.
    assert!(
        (s[1].position[1] - (top + 0.05)).abs() < 0.02 * 0.05,
        "ball at {}, table top at {top}",
        s[1].position[1]
    );
}

/// Head-on impact of two equal spheres without gravity or friction, restitution 0.5
/// and 0.9: each rebounds at e times its approach speed (the definition of e), and
/// momentum is conserved to round-off.
pub fn two_body_impact_restitution(allow: Allowance) {
    for e_set in [0.5, 0.9] {
        let extra = format!("velocity = [1, 0, 0]\nrestitution = {e_set}\nfriction = 0.0");
        let back = format!("velocity = [-1, 0, 0]\nrestitution = {e_set}\nfriction = 0.0");
        let bodies = sphere("left", 0.05, 1000.0, [0.3, 0.5, 0.5], &extra)
            + &sphere("right", 0.05, 1000.0, [0.7, 0.5, 0.5], &back);
        let mut e = engine(allow, &format!("[gravity]\nvector = [0, 0, 0]\n{bodies}"));
        run(&mut *e, 0.3, 0.01, &[]);
        let s = states(&*e);
        let (v0, v1) = (s[0].linear_velocity, s[1].linear_velocity);
        let e_measured = (v1[0] - v0[0]) / 2.0;
        assert!(
            rel(e_measured, e_set) < allow.restitution_rel,
            "e = {e_set}: measured {e_measured} ({v0:?}, {v1:?})"
        );
        assert!((v0[0] + v1[0]).abs() < 1e-6, "momentum {}", v0[0] + v1[0]);
        assert!(v0[1].abs() + v0[2].abs() < 1e-9, "off-axis {v0:?}");
    }
}

/// A sphere on a slope (the floor under gravity tilted by θ = 20°): with μ = 0.5 above
/// (2/7) tan θ = 0.104 it rolls without slipping, `a = 5/7 g sin θ` and ω = v/r; with
/// μ = 0.05 it slides, `a = g (sin θ − μ cos θ)` and `ω̇ = 5 μ g cos θ / (2 r)` (rigid-body
/// textbook results). Tolerance 2 % after 0.3 s (the soft engines' contacts settle
/// within the first few ms).
pub fn friction_on_slope(allow: Allowance) {
    let (theta, r) = (20f64.to_radians(), 0.05);
    let gravity = format!(
        "[gravity]\nvector = [{}, {}, 0]",
        G * theta.sin(),
        -G * theta.cos()
    );
    let t = 0.3;
    for mu in [0.5, 0.05] {
        let ball = sphere(
            "ball",
            r,
            2000.0,
            [0.2, r, 0.5],
            &format!("friction = {mu}"),
        );
        let mut e = engine(allow, &format!("{gravity}\n{ball}"));
        run(&mut *e, t, 0.01, &[]);
        let s = states(&*e)[0];
        let (a, alpha) = if mu > 2.0 / 7.0 * theta.tan() {
            (5.0 / 7.0 * G * theta.sin(), 5.0 / 7.0 * G * theta.sin() / r)
        } else {
            (
                G * (theta.sin() - mu * theta.cos()),
                5.0 * mu * G * theta.cos() / (2.0 * r),
            )
        };
        let (v, w) = (s.linear_velocity[0], -s.angular_velocity[2]);
        assert!(
            rel(v, a * t) < 0.02,
            "μ = {mu}: v = {v}, expected {}",
            a * t
        );
        assert!(
            rel(w, alpha * t) < 0.02,
            "μ = {mu}: ω = {w}, expected {}",
            alpha * t
        );
    }
}

/// A sphere thrown up through the open top is reported when its centre leaves the
/// domain, at t = (8 − √(64 − 2 g · 0.5)) / g = 0.0651 s (y = 0.5 + 8 t − g t²/2 = 1),
/// naming the body; within one DEM step of that time.
pub fn leaving_the_domain_is_reported(allow: Allowance) {
    let mut e = engine(
        allow,
        &sphere(
            "ball",
            0.05,
            1000.0,
            [0.5, 0.5, 0.5],
            "velocity = [0, 8, 0]",
        ),
    );
    let exit = (8.0 - (64.0 - 2.0 * G * 0.5f64).sqrt()) / G;
    let dt = e.stable_dt();
    let mut t = 0.0;
    let err = loop {
        match e.step(dt) {
            Ok(()) => t += dt,
            Err(err) => break err,
        }
        assert!(t < 0.2, "still inside at t = {t}");
    };
    let msg = err.to_string();
    assert!(
        matches!(err, DemError::LeftDomain { body: 0, .. }) && msg.contains("\"ball\""),
        "{msg}"
    );
    assert!(
        t + dt >= exit && t < exit + dt,
        "reported at {t} s, left at {exit} s"
    );
}

/// Bad loads are refused with the body and the value named; good loads still apply after.
pub fn bad_loads_are_refused(allow: Allowance) {
    let mut e = engine(allow, &sphere("ball", 0.05, 1000.0, [0.5, 0.5, 0.5], ""));
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

/// Gravity changed between windows: a ball falls 0.05 s under g, then 0.05 s under 2g
/// sideways-tilted (−2g in y, g in x). Galileo piecewise: Δv = g t₁ + g' t₂ and
/// Δx = ½ g t₁² + g t₁ t₂ + ½ g' t₂². Tolerance rel 1e-3, as in `free_fall`.
pub fn gravity_changes_between_windows(allow: Allowance) {
    let mut e = engine(allow, &sphere("ball", 0.05, 2000.0, [0.5, 0.8, 0.5], ""));
    let y0 = states(&*e)[0].position[1];
    run(&mut *e, 0.05, 0.01, &[]);
    let g2 = [G, -2.0 * G, 0.0];
    e.set_gravity(g2);
    run(&mut *e, 0.05, 0.01, &[]);
    let s = states(&*e)[0];
    let (t1, t2) = (0.05, 0.05);
    let vy = -G * t1 + g2[1] * t2;
    let dy = -0.5 * G * t1 * t1 - G * t1 * t2 + 0.5 * g2[1] * t2 * t2;
    let dx = 0.5 * g2[0] * t2 * t2;
    assert!(
        rel(s.linear_velocity[1], vy) < 1e-3,
        "vy {:?} vs {vy}",
        s.linear_velocity
    );
    assert!(
        rel(s.linear_velocity[0], G * t2) < 1e-3,
        "vx {:?}",
        s.linear_velocity
    );
    assert!(
        rel(s.position[1] - y0, dy) < 1e-3,
        "dy {} vs {dy}",
        s.position[1] - y0
    );
    assert!(
        rel(s.position[0] - 0.5, dx) < 1e-3,
        "dx {} vs {dx}",
        s.position[0] - 0.5
    );
}

/// A kinematic body's velocity prescribed during a run: it moves on from where it is,
/// x = x(t₁) + v' (t − t₁), turning at the new ω; a dynamic body is refused by name.
/// Tolerance 1e-9 m and 1e-9 rad (prescribed motion: round-off only).
pub fn kinematic_velocity_changes_live(allow: Allowance) {
    let extra = "motion = \"kinematic\"\nvelocity = [0.2, 0.1, 0]\nangular_velocity = [0, 0, 1.0]";
    let bodies = sphere("piston", 0.05, 1000.0, [0.3, 0.5, 0.5], extra)
        + &sphere("ball", 0.05, 1000.0, [0.7, 0.5, 0.5], "");
    let mut e = engine(allow, &bodies);
    run(&mut *e, 0.2, 0.01, &[]);
    e.set_kinematic_velocity(0, [-0.1, 0.0, 0.3], [0.0, 0.0, -2.0])
        .unwrap();
    run(&mut *e, 0.3, 0.01, &[]);
    let s = states(&*e)[0];
    let expected = [
        0.3 + 0.2 * 0.2 - 0.1 * 0.3,
        0.5 + 0.1 * 0.2,
        0.5 + 0.3 * 0.3,
    ];
    assert!(
        (0..3).all(|k| (s.position[k] - expected[k]).abs() < 1e-9),
        "{:?} vs {expected:?}",
        s.position
    );
    assert_eq!(
        s.linear_velocity.map(|v| (v * 1e6).round()),
        [-0.1e6, 0.0, 0.3e6]
    );
    let angle = 2.0 * s.orientation[2].atan2(s.orientation[3]);
    assert!((angle - (0.2 - 2.0 * 0.3)).abs() < 1e-9, "angle {angle}");
    let refused = e
        .set_kinematic_velocity(1, [1.0, 0.0, 0.0], [0.0; 3])
        .unwrap_err();
    assert!(
        matches!(&refused, DemError::NotKinematic { body: 1, name, .. } if name == "ball"),
        "{refused}"
    );
    assert!(e.set_kinematic_velocity(9, [0.0; 3], [0.0; 3]).is_err());
}

/// A checkpoint continues exactly: two spheres bounce on the floor and on each other
/// (contacts with history) under a held load; after 0.15 s the state is saved, the
/// original runs on 0.1 s, and an engine built afresh from the same scene, restored
/// from the save, runs the same 0.1 s. Same machine, same code: the states must be
/// equal bit for bit (the issue asks for round-off; nothing here is order-dependent).
pub fn checkpoint_restores_exactly(allow: Allowance) {
    let bodies = sphere("a", 0.05, 2000.0, [0.5, 0.06, 0.5], "restitution = 0.5")
        + &sphere(
            "b",
            0.05,
            1500.0,
            [0.52, 0.3, 0.5],
            "restitution = 0.5\nvelocity = [0.3, 0, 0]",
        )
        + &sphere(
            "piston",
            0.05,
            1000.0,
            [0.2, 0.5, 0.5],
            "motion = \"kinematic\"\nvelocity = [0.1, 0, 0]",
        );
    let loads = [load(0, [0.5, 0.0, 0.0], [0.0, 0.0, 0.01])];
    let mut original = engine(allow, &bodies);
    run(&mut *original, 0.15, 0.01, &loads);
    original.set_gravity([0.0, -12.0, 0.0]);
    original
        .set_kinematic_velocity(2, [0.0, 0.1, 0.0], [0.0; 3])
        .unwrap();
    let saved = original.save_state().unwrap();
    run(&mut *original, 0.1, 0.01, &loads);
    let mut restored = engine(allow, &bodies);
    restored.restore_state(&saved).unwrap();
    run(&mut *restored, 0.1, 0.01, &loads);
    let (a, b) = (states(&*original), states(&*restored));
    assert!(
        a[1].position[1] < 0.3 - 0.01,
        "the second sphere must have fallen onto the first: {:?}",
        a[1].position
    );
    assert_eq!(a, b, "restored run differs from the original");
    // A state is refused by an engine of another scene.
    let mut other = engine(allow, &sphere("lonely", 0.05, 1000.0, [0.5, 0.5, 0.5], ""));
    let e = other.restore_state(&saved).unwrap_err();
    assert!(matches!(e, DemError::State { .. }), "{e}");
}

/// `gravity.excess_weight_ramp = T`: a body the fluid sees carries, beyond the part of
/// its weight that the fluid balances (b = ρ_f/ρ_s with gravity on the fluid, 0 under
/// eq. 28), the fraction r(t/T) = 10x³ − 15x⁴ + 6x⁵ of the rest. With no fluid loads its
/// fall is closed-form: ∫₀ᵀ r = T/2 and ∫₀ᵀ∫₀ᵗ r = T²/7, so at T the speed is
/// g_s (b T + (1 − b) T/2) and the drop g_s (b T²/2 + (1 − b) T²/7), g_s its full
/// gravity; then it falls freely. A body the fluid does not see falls at g throughout.
/// Tolerance rel 1e-3 after 0.1 s (T = 0.05 s), as `free_fall`; a checkpoint taken
/// during the ramp continues bit for bit, as `checkpoint_restores_exactly`.
pub fn excess_weight_ramp(allow: Allowance) {
    let (ramp, t) = (0.05, 0.1);
    let bodies = sphere("wet", 0.05, 1250.0, [0.3, 0.8, 0.5], "")
        + &sphere("dry", 0.05, 1250.0, [0.7, 0.8, 0.5], "coupling = \"none\"");
    for (on_fluid, g_s, b) in [(true, G, 0.8), (false, 0.2 * G, 0.0)] {
        let scene = format!(
            "{WATER}\n[gravity]\non_fluid = {on_fluid}\nexcess_weight_ramp = {ramp}\n{bodies}"
        );
        let mut e = engine(allow, &scene);
        let y0: Vec<f64> = states(&*e).iter().map(|s| s.position[1]).collect();
        run(&mut *e, 0.02, 0.01, &[]);
        let saved = e.save_state().unwrap();
        run(&mut *e, t - 0.02, 0.01, &[]);
        let s = states(&*e);
        let v_ramp = g_s * (b * ramp + (1.0 - b) * ramp / 2.0);
        let drop_ramp = g_s * (b * ramp * ramp / 2.0 + (1.0 - b) * ramp * ramp / 7.0);
        let rest = t - ramp;
        let (v, drop) = (
            v_ramp + g_s * rest,
            drop_ramp + v_ramp * rest + 0.5 * g_s * rest * rest,
        );
        assert!(
            rel(-s[0].linear_velocity[1], v) < 1e-3,
            "on_fluid = {on_fluid}: v {:?} vs {v}",
            s[0].linear_velocity
        );
        assert!(
            rel(y0[0] - s[0].position[1], drop) < 1e-3,
            "on_fluid = {on_fluid}: drop {} vs {drop}",
            y0[0] - s[0].position[1]
        );
        assert!(
            rel(y0[1] - s[1].position[1], 0.5 * G * t * t) < 1e-3,
            "on_fluid = {on_fluid}: uncoupled drop {}",
            y0[1] - s[1].position[1]
        );
        let mut restored = engine(allow, &scene);
        restored.restore_state(&saved).unwrap();
        run(&mut *restored, t - 0.02, 0.01, &[]);
        assert_eq!(
            s,
            states(&*restored),
            "on_fluid = {on_fluid}: restored run differs"
        );
    }
}

/// Generates one `#[test]` per conformance case for each `module: allowance` pair.
macro_rules! conformance {
    ($($module:ident: $allow:expr),* $(,)?) => {$(
        mod $module {
            use super::*;
            const ALLOW: Allowance = $allow;
            #[test] fn free_fall() { super::free_fall(ALLOW) }
            #[test] fn buoyancy_eq28() { super::buoyancy_eq28(ALLOW) }
            #[test] fn held_force() { super::held_force(ALLOW) }
            #[test] fn held_moment() { super::held_moment(ALLOW) }
            #[test] fn sphere_rests_on_floor() { super::sphere_rests_on_floor(ALLOW) }
            #[test] fn boxes_do_not_interpenetrate() { super::boxes_do_not_interpenetrate(ALLOW) }
            #[test] fn millimetre_hulls_do_not_interpenetrate() { super::millimetre_hulls_do_not_interpenetrate(ALLOW) }
            #[test] fn resting_hulls_do_not_sink_into_each_other() { super::resting_hulls_do_not_sink_into_each_other(ALLOW) }
            #[test] fn kinematic_ignores_loads() { super::kinematic_ignores_loads(ALLOW) }
            #[test] fn fixed_never_moves() { super::fixed_never_moves(ALLOW) }
            #[test] fn two_body_impact_restitution() { super::two_body_impact_restitution(ALLOW) }
            #[test] fn friction_on_slope() { super::friction_on_slope(ALLOW) }
            #[test] fn leaving_the_domain_is_reported() { super::leaving_the_domain_is_reported(ALLOW) }
            #[test] fn bad_loads_are_refused() { super::bad_loads_are_refused(ALLOW) }
            #[test] fn gravity_changes_between_windows() { super::gravity_changes_between_windows(ALLOW) }
            #[test] fn kinematic_velocity_changes_live() { super::kinematic_velocity_changes_live(ALLOW) }
            #[test] fn checkpoint_restores_exactly() { super::checkpoint_restores_exactly(ALLOW) }
            #[test] fn excess_weight_ramp() { super::excess_weight_ramp(ALLOW) }
        }
    )*};
}

conformance! {
    rapier: Allowance {
        engine: "rapier",
        dem: "",
        penetration_rel: couplet_dem::rapier_engine::NORMALIZED_ALLOWED_LINEAR_ERROR,
        restitution_rel: 0.05,
        polyhedra: true,
    },
    soft_sphere_linear: Allowance {
        engine: "soft-sphere",
        dem: LINEAR,
        penetration_rel: 1e-3,
        // The dashpot force jumps to β v when contact starts within a step: an O(Δt)
        // error, 1.8 % at 50 steps per contact for e = 0.5 (first order, see
        // soft_sphere.rs linear_restitution_converges_first_order).
        restitution_rel: 0.025,
        polyhedra: false,
    },
    soft_sphere_hertz: Allowance {
        engine: "soft-sphere",
        dem: HERTZ,
        penetration_rel: 1e-3,
        // Tsuji's dashpot vanishes with the overlap (δ^{1/4}): no jump, 0.6 % at 50 steps.
        restitution_rel: 0.01,
        polyhedra: false,
    },
}

/// Every registered engine is covered by this suite.
#[test]
fn suite_covers_every_registered_engine() {
    assert_eq!(couplet_dem::engine_names(), &["rapier", "soft-sphere"]);
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
        msg.contains("\"bullet\"") && msg.contains("rapier") && msg.contains("soft-sphere"),
        "{msg}"
    );
}
