//! Joubert's one-layer walls (`domain.wall_model = "joubert"`, Joubert §2.5): the GPU
//! kernel against its CPU twin, and the Neumann pressure of eq. (25) and the symmetry
//! velocity of eq. (27) on analytic fields at faces, edges and corners.

mod common;

use common::max_err;
use couplet_fluid::adami2012_boundary_pressure::extrapolate_cpu;
use couplet_fluid::gpu::{Gpu, shared_test_gpu};
use couplet_fluid::joubert2020_body_loads::{MarkerGeometry, marker_load_cpu};
use couplet_fluid::joubert2020_boundary_values::{BoundaryFrame, boundary_values_cpu, wall_frames};
use couplet_fluid::marker_update::BodyAcceleration;
use couplet_fluid::{FluidSolver, Kind, Op, ParticleSet, SphConstants, initial_particles};
use couplet_protocol::{CouplingPoint, Scene};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// Gravity in no axis direction, so that every face, edge and corner normal sees a
/// normal component of it (m/s²).
const G: [f64; 3] = [3.0, -9.0, 2.0];

/// A closed 0.2 m box of Joubert walls, no-slip on x and y, symmetry planes on z,
/// gradient correction on; fluid up to `fill_height`; gravity `G` on the fluid.
/// c = 200 m/s keeps ρ within 5e-5 of ρ0 over the box, so eq. (25)'s 1/ρ_j weights
/// are those of a uniform density to that order.
fn joubert_box(kernel: &str, fill_height: f64) -> Scene {
    let text = format!(
        r#"
[meta]
name = "joubert-walls"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.2]
closed_top = true
wall_model = "joubert"
symmetry = [false, false, true]
[fluid]
density = 1000.0
kinematic_viscosity = 1e-3
sound_speed = 200.0
spacing = 0.02
kernel = "{kernel}"
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, {fill_height}, 0.2] }}]
[gravity]
vector = [{}, {}, {}]
[effects]
gradient_correction = true
"#,
        G[0], G[1], G[2]
    );
    Scene::parse(&text, Path::new("joubert-walls.toml")).expect("test scene")
}

/// Hydrostatic pressure of the fluid at rest under `G`, 5 kPa at the box centre top.
fn p_hydro(c: &SphConstants, x: [f64; 3]) -> f64 {
    p_linear(c, G, x)
}

/// The pressure of fluid at rest in a frame accelerating under the effective gravity
/// `g` (∇p = ρ0 g), 5 kPa at the box centre top.
fn p_linear(c: &SphConstants, g: [f64; 3], x: [f64; 3]) -> f64 {
    let x0 = [0.1, 0.2, 0.1];
    c.rho0 * (0..3).map(|k| g[k] * (x[k] - x0[k])).sum::<f64>() + 5000.0
}

/// A velocity field with no z dependence and no z component: tangential to the z
/// symmetry planes, zero normal derivative there (m/s).
fn u_planar(x: [f64; 3]) -> [f64; 3] {
    [
        0.3 + 2.0 * x[0] - 1.5 * x[1],
        -0.2 + 1.0 * x[0] - 2.0 * x[1],
        0.0,
    ]
}

/// The scene's initial set with the fluid jittered by up to `jitter` δ and given the
/// hydrostatic pressure (ρ from the inverted Tait equation) and `velocity`.
fn imposed_set(
    s: &Scene,
    c: &SphConstants,
    jitter: f64,
    velocity: impl Fn([f64; 3], &mut ChaCha8Rng) -> [f64; 3],
) -> ParticleSet {
    imposed_set_with(s, c, jitter, G, velocity)
}

/// [`imposed_set`] with the pressure of [`p_linear`] under `g`.
fn imposed_set_with(
    s: &Scene,
    c: &SphConstants,
    jitter: f64,
    g: [f64; 3],
    velocity: impl Fn([f64; 3], &mut ChaCha8Rng) -> [f64; 3],
) -> ParticleSet {
    let mut set = initial_particles(s, c).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for i in 0..set.kinds.n_fluid {
        for k in 0..3 {
            set.pos[i][k] += (rng.random::<f64>() - 0.5) * 2.0 * jitter * c.spacing;
        }
        let p = p_linear(c, g, set.pos[i]);
        set.rho[i] = c.density(p);
        set.press[i] = p;
        set.vel[i] = velocity(set.pos[i], &mut rng);
    }
    set
}

/// One sort and one boundary pass on the GPU: the particles afterwards (sorted, relative
/// to the domain centre) and the diagnostics word (diag[2]: the fallbacks).
fn boundary_pass(gpu: &Gpu, s: &Scene, set: ParticleSet) -> (ParticleSet, [u32; 4]) {
    let mut solver = FluidSolver::from_particles(gpu, s, set).unwrap();
    solver
        .run_ops(gpu, &[Op::Sort, Op::BoundaryPressure], 1e-5, 1.0)
        .unwrap();
    let got = solver.data().read(gpu).unwrap();
    let diag = solver.data().read_diag(gpu).unwrap().unwrap();
    (got, diag)
}

/// GPU `joubert2020_boundary_values` against its CPU twin on a half-filled box (so that
/// walls near the free surface hit the near-singular guard), random fluid velocities:
/// |Δp_w| ≤ 1e-4 max |p_w|, |Δu_w| ≤ 1e-4 max |u| on the symmetry planes, and the
/// kernel's fallback count (diag[2]) equals the twin's.
#[test]
fn joubert_boundary_values_match_cpu_twin() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    for kernel in ["wendland-c2", "quintic"] {
        let s = joubert_box(kernel, 0.1);
        let c = SphConstants::from_scene(&s).unwrap();
        let set = imposed_set(&s, &c, 0.2, |_, rng| {
            [0, 1, 2].map(|_| rng.random::<f64>() - 0.5)
        });
        let normals = wall_frames(&s, &set);
        let (got, diag) = boundary_pass(&gpu, &s, set);
        let want = boundary_values_cpu(&c, &got, &normals);
        let walls: Vec<usize> = (0..got.len()).filter(|&i| want[i].is_some()).collect();
        let w = |i: usize| want[i].expect("a wall entry");
        let (ep, mp) = max_err(walls.iter().map(|&i| (got.press[i], w(i).press)));
        let vel = &got.vel;
        let (eu, mu) = max_err(
            walls
                .iter()
                .flat_map(|&i| (0..3).map(move |k| (vel[i][k], w(i).vel[k]))),
        );
        let fallbacks = walls.iter().filter(|&&i| w(i).fallback).count();
        println!(
            "{kernel}: {} walls, max |Δp_w| = {ep:e} of {mp:e}, max |Δu_w| = {eu:e} of {mu:e}, fallbacks {fallbacks} (GPU {})",
            walls.len(),
            diag[2]
        );
        assert!(ep <= 1e-4 * mp, "{kernel}: max |Δp_w| = {ep:e} of {mp:e}");
        assert!(
            mu > 0.1 && eu <= 1e-4 * mu,
            "{kernel}: max |Δu_w| = {eu:e} of {mu:e}"
        );
        assert!(fallbacks > 0, "the half-filled box exercises the guard");
        assert_eq!(diag[2] as usize, fallbacks, "{kernel}: fallback count");
    }
}

/// Joubert eq. (25) on fluid at rest under gravity in no axis direction, in a full box
/// with jittered fluid: every boundary particle — faces, edges, corners, no-slip walls
/// and symmetry planes alike — gets the hydrostatic pressure at its own position, to
/// round-off: ≤ 1e-9 of the pressure range in the f64 twin with ρ = ρ0 exactly, and on
/// the GPU within 4× the f32 quantisation of the fluid's own Tait pressure (≈ 2.4 Pa
/// at c = 200 m/s, 1e-3 of the range; bounded by 4 ulp), none falling back.
/// Eq. (27) with ∂u/∂n = 0 gives the symmetry-plane particles a z-independent planar
/// velocity exactly; the uncorrected Shepard average of the fluid (Adami's wall velocity
/// without its 2 v_w term) is shown off by more than 1 % of the velocity range at the
/// plane's edges, where the fluid lies to one side in x or y as well.
#[test]
fn neumann_wall_pressure_and_symmetry_velocity_are_exact_for_linear_fields() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = joubert_box("quintic", 0.2);
    let c = SphConstants::from_scene(&s).unwrap();
    let set = imposed_set(&s, &c, 0.2, |x, _| u_planar(x));
    let normals = wall_frames(&s, &set);
    let walls: Vec<usize> = (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Wall)
        .collect();
    let n_fluid = set.kinds.n_fluid;
    let symmetric = |id: u32| normals[id as usize - n_fluid].normal[3] > 0.5;
    let n_sym = walls.iter().filter(|&&i| symmetric(set.id[i])).count();
    let p_range = c.rho0 * G.iter().map(|g| g.abs() * 0.2).sum::<f64>();
    let u_range = 0.2 * 3.5;

    // f64 twin, ρ = ρ0 on the fluid: the identity is exact.
    let mut uniform = set.clone();
    uniform.rho[..set.kinds.n_fluid].fill(c.rho0);
    let twin = boundary_values_cpu(&c, &uniform, &normals);
    let (mut ep, mut eu, mut shepard) = (0.0f64, 0.0f64, 0.0f64);
    for &i in &walls {
        let v = twin[i].unwrap();
        assert!(!v.fallback, "wall at {:?} fell back", set.pos[i]);
        ep = ep.max((v.press - p_hydro(&c, set.pos[i])).abs());
        if symmetric(set.id[i]) {
            let exact = u_planar(set.pos[i]);
            eu = eu.max(
                (0..3)
                    .map(|k| (v.vel[k] - exact[k]).abs())
                    .fold(0.0, f64::max),
            );
            // Adami's wall velocity without its 2 v_w term: the Shepard average.
            let (_, avg) = extrapolate_cpu(&c, &set, i, [0.0; 3]).unwrap();
            shepard = shepard.max((avg[0] - exact[0]).abs().max((avg[1] - exact[1]).abs()));
        }
    }
    println!(
        "twin: {} walls ({n_sym} on symmetry planes), max |p_w − p| = {ep:e} Pa of {p_range:e}, max |u_w − u| = {eu:e} m/s, Shepard {shepard:e} m/s",
        walls.len()
    );
    assert!(n_sym > 100);
    assert!(ep <= 1e-9 * p_range, "twin pressure error {ep:e} Pa");
    assert!(eu <= 1e-9 * u_range, "twin velocity error {eu:e} m/s");
    assert!(
        shepard > 1e-2 * u_range,
        "the uncorrected average should be visibly off: {shepard:e} m/s"
    );

    // GPU, f32, the Tait densities.
    let (got, diag) = boundary_pass(&gpu, &s, set);
    let origin = [0.1; 3];
    let world = |p: [f64; 3]| std::array::from_fn::<f64, 3, _>(|k| p[k] + origin[k]);
    // The fluid's own pressure on the GPU is the Tait pressure of an f32 density:
    // ρ ≈ 1000 carries an ulp of 2⁻¹⁴ = ε/2 · 1024 = 6e-5 kg/m³, c² times that is
    // 2.4 Pa at c = 200 m/s; the f32 `pow` adds a few more.
    let fluid_quantum = (0..got.len())
        .filter(|&i| got.kinds.kind(got.id[i]) == Kind::Fluid)
        .map(|i| (got.press[i] - p_hydro(&c, world(got.pos[i]))).abs())
        .fold(0.0, f64::max);
    let (mut ep, mut eu) = (0.0f64, 0.0f64);
    for i in (0..got.len()).filter(|&i| got.kinds.kind(got.id[i]) == Kind::Wall) {
        let x = world(got.pos[i]);
        ep = ep.max((got.press[i] - p_hydro(&c, x)).abs());
        if symmetric(got.id[i]) {
            let exact = u_planar(x);
            eu = eu.max(
                (0..3)
                    .map(|k| (got.vel[i][k] - exact[k]).abs())
                    .fold(0.0, f64::max),
            );
        }
    }
    println!(
        "GPU: max |p_w − p| = {ep:e} Pa (fluid's own f32 pressure error {fluid_quantum:e} Pa), max |u_w − u| = {eu:e} m/s, fallbacks {}",
        diag[2]
    );
    assert_eq!(diag[2], 0, "no boundary particle of a full box falls back");
    assert!(
        fluid_quantum <= 4.0 * c.sound_speed.powi(2) * f64::from(f32::EPSILON) * 0.5 * 1024.0
            && ep <= 4.0 * fluid_quantum,
        "GPU pressure error {ep:e} Pa against the fluid's {fluid_quantum:e} Pa"
    );
    assert!(eu <= 1e-4 * u_range, "GPU velocity error {eu:e} m/s");
}

/// Joubert eq. (25) at the markers of a sphere (r = 0.05 m, 100 markers, about one per
/// δ²) accelerating at A in the full box of fluid at rest relative to it: the fluid's
/// pressure is linear with ∇p = ρ0 (G − A), and eq. (25) with the body's acceleration
/// gives every marker that pressure at its own position. Reference: the linear field.
/// Tolerances as in the wall test above (the f64 twin to 1e-9 of the range, the GPU
/// within 4× the fluid's own f32 pressure error); the GPU matches the twin on the same
/// particles to 1e-4 of the range; and the twin without A is off by more than twice
/// the GPU tolerance, so a kernel that dropped the acceleration term would fail
/// (measured: twin 4.5e-12 Pa, GPU 1.7 Pa, tolerance 15 Pa, without A 56 Pa).
#[test]
fn neumann_marker_pressure_includes_the_body_acceleration() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = joubert_box("quintic", 0.2);
    let c = SphConstants::from_scene(&s).unwrap();
    let a_body = [1.5, 2.0, -0.5];
    let g_eff: [f64; 3] = std::array::from_fn(|k| G[k] - a_body[k]);
    let set = imposed_set_with(&s, &c, 0.2, g_eff, |_, _| [0.0; 3]);
    let walls = wall_frames(&s, &set);

    let (centre, radius, n) = ([0.1, 0.1, 0.1], 0.05, 100);
    let points = common::sphere_markers(centre, radius, n);
    let state = common::body_at_rest(centre);
    let acc = BodyAcceleration {
        linear: a_body,
        angular: [0.0; 3],
    };
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[acc]).unwrap();
    solver
        .run_ops(&gpu, &[Op::Sort, Op::BoundaryPressure], 1e-5, 1.0)
        .unwrap();
    let got = solver.data().read(&gpu).unwrap();
    let diag = solver.data().read_diag(&gpu).unwrap().unwrap();

    let origin = [0.1; 3];
    let world = |p: [f64; 3]| std::array::from_fn::<f64, 3, _>(|k| p[k] + origin[k]);
    let p_exact = |x: [f64; 3]| p_linear(&c, g_eff, world(x));
    let frames = |with_acc: bool| -> Vec<BoundaryFrame> {
        let a = if with_acc { a_body } else { [0.0; 3] };
        let mut f = walls.clone();
        f.extend(points.iter().map(|p| BoundaryFrame::marker(p.normal, a)));
        f
    };
    let markers: Vec<usize> = (0..got.len())
        .filter(|&i| got.kinds.kind(got.id[i]) == Kind::Marker)
        .collect();
    assert_eq!(markers.len(), n);
    let p_range = c.rho0 * g_eff.iter().map(|g| g.abs() * 0.2).sum::<f64>();

    // f64 twin on the GPU's particles with ρ = ρ0 and the exact pressures.
    // (`got` is sorted: the fluid is found by kind, not by index.)
    let fluid: Vec<usize> = (0..got.len())
        .filter(|&i| got.kinds.kind(got.id[i]) == Kind::Fluid)
        .collect();
    let mut exact = got.clone();
    for &i in &fluid {
        exact.rho[i] = c.rho0;
        exact.press[i] = p_exact(exact.pos[i]);
    }
    let twin = boundary_values_cpu(&c, &exact, &frames(true));
    let twin_no_acc = boundary_values_cpu(&c, &exact, &frames(false));
    let err = |v: &[Option<couplet_fluid::joubert2020_boundary_values::BoundaryValues>]| {
        markers
            .iter()
            .map(|&i| (v[i].unwrap().press - p_exact(got.pos[i])).abs())
            .fold(0.0, f64::max)
    };
    let (e_twin, e_no_acc) = (err(&twin), err(&twin_no_acc));
    assert!(markers.iter().all(|&i| !twin[i].unwrap().fallback));

    // GPU against the field and against the twin on its own (f32-Tait) fluid.
    let fluid_quantum = fluid
        .iter()
        .map(|&i| (got.press[i] - p_exact(got.pos[i])).abs())
        .fold(0.0, f64::max);
    let e_gpu = markers
        .iter()
        .map(|&i| (got.press[i] - p_exact(got.pos[i])).abs())
        .fold(0.0, f64::max);
    let same = boundary_values_cpu(&c, &got, &frames(true));
    let (e_parity, _) = max_err(
        markers
            .iter()
            .map(|&i| (got.press[i], same[i].unwrap().press)),
    );
    println!(
        "markers: twin {e_twin:e} Pa, twin without A {e_no_acc:e} Pa, GPU {e_gpu:e} Pa \
         (fluid's f32 error {fluid_quantum:e}), GPU vs twin {e_parity:e} Pa, range {p_range:e} Pa, fallbacks {}",
        diag[2]
    );
    assert!(
        e_twin <= 1e-9 * p_range,
        "twin marker pressure error {e_twin:e} Pa"
    );
    assert!(
        fluid_quantum <= 4.0 * c.sound_speed.powi(2) * f64::from(f32::EPSILON) * 0.5 * 1024.0
            && e_gpu <= 4.0 * fluid_quantum,
        "GPU marker pressure error {e_gpu:e} Pa against the fluid's {fluid_quantum:e} Pa"
    );
    assert!(e_parity <= 1e-4 * p_range, "GPU vs twin {e_parity:e} Pa");
    assert!(
        e_no_acc > 2.0 * 4.0 * fluid_quantum,
        "without the acceleration the markers should be visibly off: {e_no_acc:e} Pa"
    );
}

/// Joubert eq. (31)'s viscous traction μ (∇u + ∇uᵀ)·n at a plane of markers (normal +y
/// at y = 0.1 m across the box, fluid above only) in a linear velocity field u = u0 + A x
/// that the markers share: with the gradient correction the one-sided B makes ∇u exact,
/// so every marker's viscous traction is μ (A + Aᵀ) n. Reference: the linear field.
/// A stray marker without fluid neighbours falls back to B = I, counted once on the GPU
/// (diag[2]) as in the twin.
/// Tolerances: the f64 twin to 1e-9, the GPU to 1e-3 of max |μ (A + Aᵀ) n|; the
/// uncorrected sum (B = I) must be off by more than 20 % at every marker (it sees half
/// a support). Measured: twin 4e-15 Pa, GPU 1.9e-6 Pa, uncorrected at least 1.69 Pa of 3.5.
#[test]
fn corrected_marker_traction_is_exact_for_a_linear_field() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = joubert_box("quintic", 0.2);
    let c = SphConstants::from_scene(&s).unwrap();
    let a = [[0.5, 2.0, -1.0], [1.5, -0.5, 0.3], [-0.7, 1.2, 0.0]];
    let u_lin = |x: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|r| 0.1 + (0..3).map(|k| a[r][k] * x[k]).sum::<f64>())
    };
    let set = imposed_set(&s, &c, 0.2, |x, _| u_lin(x));
    let d = c.spacing;
    let side = (0.2 / d).round() as usize;
    let mut points: Vec<CouplingPoint> = (0..side * side)
        .map(|k| {
            let x = [
                (k % side) as f64 * d + d / 2.0,
                0.1,
                (k / side) as f64 * d + d / 2.0,
            ];
            CouplingPoint {
                position: x.map(|v| v as f32),
                measure: 1.0,
                velocity: u_lin(x).map(|v| v as f32),
                normal: [0.0, 1.0, 0.0],
                ..Default::default()
            }
        })
        .collect();
    // One more marker below the floor, in the grid's padding, further than a support
    // radius from the lowest fluid (δ/2 − 0.2 δ of jitter; and the fluid under the plane
    // is carved out anyway): no fluid neighbour, so its one-sided M is zero and it
    // must fall back, counted once.
    let stray = points.len();
    let y_stray = 0.15 * d - c.support_radius();
    points.push(CouplingPoint {
        position: [0.1, y_stray as f32, 0.1],
        measure: 1.0,
        normal: [0.0, -1.0, 0.0],
        ..Default::default()
    });
    // And a fill point (area 0) beside it: no surface, so no load and no one-sided B,
    // hence no second fallback.
    let fill = points.len();
    points.push(CouplingPoint {
        position: [0.1 + d as f32, y_stray as f32, 0.1],
        measure: 0.0,
        normal: [0.0, -1.0, 0.0],
        ..Default::default()
    });
    let state = common::body_at_rest([0.1, 0.05, 0.1]);
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    solver
        .run_ops(&gpu, &[Op::Sort, Op::BoundaryPressure], 1e-5, 1.0)
        .unwrap();
    // The walls below the plane, with no fluid left near them, fall back in the
    // boundary pass; run_ops clears the count, so the loads pass's own is read alone.
    solver.run_ops(&gpu, &[Op::MarkerLoads], 1e-5, 1.0).unwrap();
    let got = solver.data().read(&gpu).unwrap();
    let loads = solver.data().read_marker_loads(&gpu).unwrap();
    let marker_fallbacks = solver.data().read_diag(&gpu).unwrap().unwrap()[2];

    let mu = c.rho0 * c.nu;
    let n = [0.0, 1.0, 0.0];
    let exact: [f64; 3] =
        std::array::from_fn(|r| mu * (0..3).map(|k| (a[r][k] + a[k][r]) * n[k]).sum::<f64>());
    let scale = exact.iter().map(|x| x.abs()).fold(0.0, f64::max);
    let index = got.index_of_id();
    let base = got.kinds.marker_base();
    let origin = [0.1; 3];
    let mut uncorrected = c.clone();
    uncorrected.gradient_correction = false;
    let (mut e_twin, mut e_gpu, mut e_plain) = (0.0f64, 0.0f64, f64::INFINITY);
    // The twin sees exact velocities (the GPU's are f32) on the GPU's positions.
    let mut exact_set = got.clone();
    for i in 0..got.len() {
        let x: [f64; 3] = std::array::from_fn(|k| got.pos[i][k] + origin[k]);
        exact_set.vel[i] = u_lin(x);
    }
    let stray_geom = MarkerGeometry {
        normal: [0.0, -1.0, 0.0],
        area: 1.0,
        cg: [0.0, -0.05, 0.0],
    };
    assert!(marker_load_cpu(&c, &exact_set, index[base + stray], &stray_geom).fallback);
    let fill_twin = marker_load_cpu(
        &c,
        &exact_set,
        index[base + fill],
        &MarkerGeometry {
            area: 0.0,
            ..stray_geom
        },
    );
    assert!(!fill_twin.fallback && fill_twin.traction == [0.0; 3] && fill_twin.moment == [0.0; 3]);
    assert_eq!(
        (loads[fill].0, loads[fill].1),
        ([0.0; 3], [0.0; 3]),
        "fill point load"
    );
    for (k, p) in points[..stray].iter().enumerate() {
        let i = index[base + k];
        let geom = MarkerGeometry {
            normal: n,
            area: 1.0,
            cg: [0.0, -0.05, 0.0],
        };
        // Viscous part: the traction plus p n.
        let viscous =
            |t: [f64; 3], p: f64| -> [f64; 3] { std::array::from_fn(|r| t[r] + p * n[r]) };
        let twin = marker_load_cpu(&c, &exact_set, i, &geom);
        assert!(!twin.fallback, "marker at {:?} fell back", p.position);
        let plain = marker_load_cpu(&uncorrected, &exact_set, i, &geom);
        let err = |v: [f64; 3]| (0..3).map(|r| (v[r] - exact[r]).abs()).fold(0.0, f64::max);
        e_twin = e_twin.max(err(viscous(twin.traction, got.press[i])));
        e_plain = e_plain.min(err(viscous(plain.traction, got.press[i])));
        e_gpu = e_gpu.max(err(viscous(loads[k].0, got.press[i])));
    }
    println!(
        "viscous traction μ(A+Aᵀ)n = {exact:?} Pa: twin {e_twin:e}, GPU {e_gpu:e}, uncorrected (smallest) {e_plain:e}; marker fallbacks {marker_fallbacks}"
    );
    assert_eq!(
        marker_fallbacks, 1,
        "only the stray marker falls back, not the fill point"
    );
    assert!(e_twin <= 1e-9 * scale, "twin {e_twin:e} of {scale:e}");
    assert!(e_gpu <= 1e-3 * scale, "GPU {e_gpu:e} of {scale:e}");
    assert!(
        e_plain >= 0.2 * scale,
        "the uncorrected traction should be far off: {e_plain:e}"
    );
}
