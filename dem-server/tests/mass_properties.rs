//! Mass properties rapier integrates with, against the textbook formulas (any
//! mechanics text, e.g. Goldstein, *Classical Mechanics*, inertia tables): density ×
//! the solid's volume, and inertia about the centre of mass. Tolerance rel 1e-4
//! (rapier stores them in f32).

mod common;

use common::{cuboid, scene, sphere};
use couplet_dem::{DemEngine, RapierEngine};
use couplet_protocol::BodyState;
use std::f64::consts::PI;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Sphere: m = ρ 4/3 π r³, I = 2/5 m r² about every axis.
#[test]
fn sphere_mass_and_inertia() {
    let (r, rho) = (0.05, 1250.0);
    let e = RapierEngine::new(&scene(&sphere("s", r, rho, [0.5, 0.5, 0.5], ""))).unwrap();
    let mp = e.mass_properties(0).unwrap();
    let m = rho * 4.0 / 3.0 * PI * r.powi(3);
    assert!(rel(mp.mass, m) < 1e-4, "{} vs {m}", mp.mass);
    for k in 0..3 {
        assert!(
            rel(mp.inertia[k][k], 0.4 * m * r * r) < 1e-4,
            "{:?}",
            mp.inertia
        );
    }
    let mut st = Vec::<BodyState>::new();
    e.states(&mut st);
    assert!(rel(st[0].mass, m) < 1e-12 && rel(st[0].volume, m / rho) < 1e-12);
}

/// Box of full edges (a, b, c): m = ρ abc, I_xx = m (b² + c²)/12 and cyclic, no products.
#[test]
fn box_inertia() {
    let (h, rho) = ([0.05, 0.1, 0.15], 800.0);
    let e = RapierEngine::new(&scene(&cuboid("b", h, rho, [0.5, 0.5, 0.5], ""))).unwrap();
    let mp = e.mass_properties(0).unwrap();
    let [a, b, c] = h.map(|x| 2.0 * x);
    let m = rho * a * b * c;
    assert!(rel(mp.mass, m) < 1e-4);
    let expected = [
        m * (b * b + c * c) / 12.0,
        m * (a * a + c * c) / 12.0,
        m * (a * a + b * b) / 12.0,
    ];
    for k in 0..3 {
        assert!(
            rel(mp.inertia[k][k], expected[k]) < 1e-4,
            "I[{k}] = {} vs {}",
            mp.inertia[k][k],
            expected[k]
        );
        assert!(mp.inertia[k][(k + 1) % 3].abs() < 1e-6 * expected[k]);
    }
}

/// Cylinder along y of radius r and height H: m = ρ π r² H, I_yy = m r²/2,
/// I_xx = I_zz = m (3r² + H²)/12.
#[test]
fn cylinder_inertia() {
    let (r, hh, rho) = (0.05, 0.08, 1000.0);
    let body = format!(
        "[[bodies]]\nname = \"c\"\nshape.cylinder = {{ radius = {r}, half_height = {hh} }}\ndensity = {rho}\nposition = [0.5, 0.5, 0.5]\n"
    );
    let e = RapierEngine::new(&scene(&body)).unwrap();
    let mp = e.mass_properties(0).unwrap();
    let m = rho * PI * r * r * 2.0 * hh;
    assert!(rel(mp.mass, m) < 1e-4);
    assert!(rel(mp.inertia[1][1], 0.5 * m * r * r) < 1e-4);
    let side = m * (3.0 * r * r + 4.0 * hh * hh) / 12.0;
    assert!(rel(mp.inertia[0][0], side) < 1e-4 && rel(mp.inertia[2][2], side) < 1e-4);
}

/// A convex hull given off-centre (a cube of side a at [1, 2] … ) and a compound of two
/// such cubes: the body frame is recentred on the COM (local COM ≈ 0), the mass is ρ V of
/// the union, and the compound's I_xx is that of a 2a × a × a box.
#[test]
fn hull_and_compound_recentred_on_com() {
    let a = 0.1;
    let cube = |x0: f64| {
        (0..8)
            .map(|i| {
                let b = |k: usize| if i >> k & 1 == 1 { a } else { 0.0 };
                format!("[{}, {}, {}]", x0 + b(0), 1.0 + b(1), 2.0 + b(2))
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let bodies = format!(
        "[[bodies]]\nname = \"hull\"\nshape.convex.vertices = [{}]\ndensity = 500.0\nposition = [0.3, 0.5, 0.5]\n\
         [[bodies]]\nname = \"pair\"\nshape.compound.parts = [[{}], [{}]]\ndensity = 500.0\nposition = [0.7, 0.5, 0.5]\n",
        cube(1.0),
        cube(1.0),
        cube(1.0 + a)
    );
    let e = RapierEngine::new(&scene(&bodies)).unwrap();
    // The f64 volumes (outward face loops, divergence theorem) that eq. (28) uses.
    let mut st = Vec::<BodyState>::new();
    e.states(&mut st);
    assert!(rel(st[0].volume, a * a * a) < 1e-12 && rel(st[1].volume, 2.0 * a * a * a) < 1e-12);
    assert!(rel(st[1].mass, 1000.0 * a * a * a) < 1e-12);
    let hull = e.mass_properties(0).unwrap();
    assert!(rel(hull.mass, 500.0 * a * a * a) < 1e-4);
    assert!(
        hull.local_com.iter().all(|c| c.abs() < 1e-5 * a),
        "{:?}",
        hull.local_com
    );
    let pair = e.mass_properties(1).unwrap();
    let m = 1000.0 * a * a * a;
    assert!(rel(pair.mass, m) < 1e-4);
    assert!(
        pair.local_com.iter().all(|c| c.abs() < 1e-5 * a),
        "{:?}",
        pair.local_com
    );
    assert!(rel(pair.inertia[0][0], m * (a * a + a * a) / 12.0) < 1e-4);
    assert!(rel(pair.inertia[1][1], m * (4.0 * a * a + a * a) / 12.0) < 1e-4);
}

/// A degenerate hull (coplanar vertices) is refused, naming the body and the reason.
#[test]
fn degenerate_hull_is_refused_with_body_named() {
    let bodies = "[[bodies]]\nname = \"flat\"\nshape.convex.vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]\n\
                  density = 500.0\nposition = [0.5, 0.5, 0.5]\n";
    let msg = RapierEngine::new(&scene(bodies))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        msg.contains("bodies[0] \"flat\"") && msg.contains("convex hull"),
        "{msg}"
    );
}

/// Joubert's cross (§4.2, Table 3) as `shape.cross`: five cuboids b × h × w (x, y, z),
/// the centre one, two at ±w along z, two at ±h along y. Each has I_xx = m (h² + w²)/12
/// and cyclic about its own centre; the parallel-axis theorem adds m w² (I_xx, I_yy) for
/// the z arms and m h² (I_xx, I_zz) for the y arms. Mass ρ 5 b w h; the centre of mass
/// is the centre cuboid's. Reference: those textbook sums.
#[test]
fn cross_mass_and_inertia_are_the_five_cuboids() {
    let (b, w, h, rho) = (2.25e-3, 0.75e-3, 1.0e-3, 1250.0);
    let body = format!(
        "[[bodies]]\nname = \"cross\"\nshape.cross = {{ base = {b:?}, width = {w:?}, height = {h:?} }}\ndensity = {rho:?}\nposition = [0.5, 0.5, 0.5]\n"
    );
    let e = RapierEngine::new(&scene(&body)).unwrap();
    let mp = e.mass_properties(0).unwrap();
    let m = rho * b * w * h;
    assert!(rel(mp.mass, 5.0 * m) < 1e-4, "{} vs {}", mp.mass, 5.0 * m);
    assert!(
        mp.local_com.iter().all(|c| c.abs() < 1e-5 * b),
        "{:?}",
        mp.local_com
    );
    let expected = [
        5.0 * m * (h * h + w * w) / 12.0 + 2.0 * m * (w * w + h * h),
        5.0 * m * (b * b + w * w) / 12.0 + 2.0 * m * w * w,
        5.0 * m * (b * b + h * h) / 12.0 + 2.0 * m * h * h,
    ];
    for k in 0..3 {
        assert!(
            rel(mp.inertia[k][k], expected[k]) < 1e-4,
            "I[{k}] = {} vs {}",
            mp.inertia[k][k],
            expected[k]
        );
    }
    let mut st = Vec::<BodyState>::new();
    e.states(&mut st);
    assert!(rel(st[0].volume, 5.0 * b * w * h) < 1e-12);
}

/// Joubert's ring (§4.2, Table 3) as `shape.ring` with 12 trapezoidal prisms whose
/// corners lie on the inner and outer circles: the volume is the 12-gon annulus,
/// 3 (r_o² − r_i²) · 2h (a regular n-gon of circumradius r has area ½ n r² sin(2π/n)),
/// to round-off; rapier's mass is ρ times that, and the centre of mass is on the axis.
#[test]
fn ring_volume_is_the_polygonal_annulus() {
    let (ri, ro, hh, rho) = (0.725e-3, 1.45e-3, 0.875e-3, 1250.0);
    let body = format!(
        "[[bodies]]\nname = \"ring\"\nshape.ring = {{ sides = 12, inner_radius = {ri:?}, outer_radius = {ro:?}, half_height = {hh:?} }}\ndensity = {rho:?}\nposition = [0.5, 0.5, 0.5]\n"
    );
    let e = RapierEngine::new(&scene(&body)).unwrap();
    let volume = 3.0 * (ro * ro - ri * ri) * 2.0 * hh;
    let mut st = Vec::<BodyState>::new();
    e.states(&mut st);
    assert!(
        rel(st[0].volume, volume) < 1e-12,
        "{} vs {volume}",
        st[0].volume
    );
    let mp = e.mass_properties(0).unwrap();
    assert!(rel(mp.mass, rho * volume) < 1e-4);
    assert!(
        mp.local_com.iter().all(|c| c.abs() < 1e-5 * ro),
        "{:?}",
        mp.local_com
    );
    let axial = rho * 2.0 * hh * (polygon_polar_moment(12, ro) - polygon_polar_moment(12, ri));
    let side = 0.5 * axial + rho * volume * (2.0 * hh).powi(2) / 12.0;
    let i = mp.inertia;
    assert!(rel(i[1][1], axial) < 1e-4, "I_yy {} vs {axial}", i[1][1]);
    assert!(
        rel(i[0][0], side) < 1e-4 && rel(i[2][2], side) < 1e-4,
        "{i:?} vs {side}"
    );
}

/// Polar second moment of area of a regular n-gon of circumradius r about its centre:
/// n triangles from the centre, each (A/6)(|a|² + |b|² + a·b) = r⁴ sin θ (2 + cos θ)/12
/// with θ = 2π/n (polar moment of a triangle about a vertex). Its in-plane moments are
/// half of it each (a regular polygon's second moment of area is isotropic).
fn polygon_polar_moment(n: u32, r: f64) -> f64 {
    let theta = 2.0 * PI / f64::from(n);
    f64::from(n) * r.powi(4) * theta.sin() * (2.0 + theta.cos()) / 12.0
}

/// Regression, "parry's f32 principal axes at millimetre size": Joubert's 12-face
/// cylinder (r = 1.25 mm, 10 mm long) had rapier's principal moments on the wrong axes,
/// I_xx = 4.4e-11 and I_yy = 5.1e-10 kg·m² where the axis is y: parry's eigenvectors are
/// cross products of inertia columns whose squares underflow f32 at these sizes. The
/// engine now gives rapier the f64 tensor. Reference: I_yy = ρ H J and I_xx = I_zz =
/// ρ H J/2 + m H²/12, J the 12-gon's polar moment; the same prism at metre size passes.
#[test]
fn millimetre_prism_keeps_its_axial_moment_on_y() {
    for scale in [1.0, 1e-3] {
        let (r, hh, rho) = (1.25 * scale, 5.0 * scale, 1250.0);
        let body = format!(
            "[[bodies]]\nname = \"p\"\nshape.prism = {{ sides = 12, radius = {r:?}, half_height = {hh:?} }}\ndensity = {rho:?}\nposition = [0.5, 0.5, 0.5]\n"
        );
        let e = RapierEngine::new(&scene(&body)).unwrap();
        let i = e.mass_properties(0).unwrap().inertia;
        let m = rho * 3.0 * r * r * 2.0 * hh;
        let axial = rho * 2.0 * hh * polygon_polar_moment(12, r);
        let side = 0.5 * axial + m * (2.0 * hh).powi(2) / 12.0;
        assert!(
            rel(i[1][1], axial) < 1e-4,
            "scale {scale}: I_yy {} vs {axial}",
            i[1][1]
        );
        assert!(
            rel(i[0][0], side) < 1e-4 && rel(i[2][2], side) < 1e-4,
            "scale {scale}: {i:?} vs {side}"
        );
    }
}
