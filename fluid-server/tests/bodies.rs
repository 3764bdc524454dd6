//! The fluid around resolved bodies. Fill points take Adami's pressure from the fluid in
//! front of their nearest surface only; fluid behind a body's surface is mirrored out
//! (`body_non_penetration`), and fluid beyond a wall face is mirrored back, with bodies
//! or without. Each GPU kernel against its CPU twin.
//!
//! Non-penetration: A sphere of 300 surface markers (r = 5δ) carves the fluid out of itself,
//! then moves 0.8δ along +x at 0.1 m/s, so the fluid that stood δ/2 to 0.8δ outside its
//! +x side is now behind the surface; fill points (area 0) at 0.9 r, δ/2 inside (the shallowest fill), must
//! not count as surface (a fluid particle's nearest point is often one of them).
//! Reference: the twin, `non_penetration_cpu`, applied to the GPU's own state before
//! the pass.

mod common;

use couplet_fluid::adami2012_boundary_pressure::{
    boundary_pressure_cpu, boundary_pressure_with_fill_cpu,
};
use couplet_fluid::body_non_penetration::{
    SurfacePoint, nearest_surface_marker_cpu, non_penetration_cpu, surface_markers,
};
use couplet_fluid::gpu::{Gpu, shared_test_gpu};
use couplet_fluid::joubert2020_gradients::gradients_cpu;
use couplet_fluid::marker_update::marker_mass;
use couplet_fluid::particle_shifting::{Shifted, shift_cpu};
use couplet_fluid::particles::{ParticleSet, dot, sub};
use couplet_fluid::{FluidSolver, Kind, Op, SphConstants, initial_particles};
use couplet_protocol::{BodyState, CouplingPoint};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A fixed sphere's coupling points: `n` surface markers (`common::sphere_markers`), then
/// fill points (area 0) at `depth_fraction` r under every third of them, with its state.
fn filled_sphere(
    centre: [f64; 3],
    r: f64,
    n: usize,
    depth_fraction: f64,
) -> (Vec<CouplingPoint>, BodyState) {
    let mut points = common::sphere_markers(centre, r, n);
    let fill: Vec<CouplingPoint> = points
        .iter()
        .step_by(3)
        .map(|p| {
            let n = p.normal.map(f64::from);
            CouplingPoint {
                position: std::array::from_fn(|k| (centre[k] + depth_fraction * r * n[k]) as f32),
                measure: 0.0,
                ..*p
            }
        })
        .collect();
    points.extend(fill);
    let state = common::body_at_rest(centre);
    (points, state)
}

/// The marker update, the sort and the non-penetration pass on `solver` (its bodies set
/// to `points`), and the twin on the state just before the pass. Returns the GPU's state
/// after the pass, the twin's, and how many particles each moved.
fn non_penetration_pass(
    gpu: &Gpu,
    c: &SphConstants,
    solver: &mut FluidSolver,
    points: &[CouplingPoint],
) -> (ParticleSet, ParticleSet, u32, u32) {
    solver
        .run_ops(gpu, &[Op::MarkerUpdate, Op::Sort], 1e-5, 1.0)
        .unwrap();
    let mut twin = solver.data().read(gpu).unwrap();
    solver
        .run_ops(gpu, &[Op::NonPenetration], 1e-5, 1.0)
        .unwrap();
    let got = solver.data().read(gpu).unwrap();
    let count = solver.data().read_reflected(gpu).unwrap();
    let twin_count = non_penetration_cpu(c, &mut twin, &surface_points(points));
    (got, twin, count, twin_count)
}

/// Moves the body of `state` (set on `solver` with `points`) by `dx` along +x, its points
/// with it, now at `speed` m/s along +x.
fn move_along_x(
    gpu: &Gpu,
    solver: &mut FluidSolver,
    points: &mut [CouplingPoint],
    state: BodyState,
    dx: f64,
    speed: f64,
) {
    for p in points.iter_mut() {
        p.position[0] += dx as f32;
        p.velocity = [speed as f32, 0.0, 0.0];
    }
    let moved = BodyState {
        position: [state.position[0] + dx, state.position[1], state.position[2]],
        linear_velocity: [speed, 0.0, 0.0],
        ..state
    };
    solver.set_bodies(gpu, &[moved], points, &[]).unwrap();
}

/// After a non-penetration pass: the same particles in the same order (the pass does
/// not sort), fluid positions to f32 round-off of the 0.2 m domain (the nearest image on
/// a periodic axis) and velocities to that of 0.1 m/s.
fn assert_fluid_agrees(c: &SphConstants, got: &ParticleSet, twin: &ParticleSet) {
    let (mut dx, mut du) = (0.0f64, 0.0f64);
    for i in 0..got.len() {
        assert_eq!(got.id[i], twin.id[i]);
        if got.kinds.kind(got.id[i]) == Kind::Fluid {
            let e = c.pair_vec(got.pos[i], twin.pos[i]);
            dx = dx.max(dot(e, e).sqrt());
            let e = sub(got.vel[i], twin.vel[i]);
            du = du.max(dot(e, e).sqrt());
        }
    }
    println!("largest difference: position {dx:e} m, velocity {du:e} m/s");
    assert!(dx <= 1e-6 * 0.2, "position {dx:e}");
    assert!(du <= 1e-5 * 0.1, "velocity {du:e}");
}

fn surface_points(points: &[CouplingPoint]) -> Vec<SurfacePoint> {
    points
        .iter()
        .map(|p| SurfacePoint {
            normal: p.normal.map(f64::from),
            area: f64::from(p.measure),
        })
        .collect()
}

/// Regression (cross_leading_face_pile_up, 2026-11-27): Joubert eq. (17)'s shift drew
/// fluid onto the leading faces of Joubert's cross at δ = 0.25 mm, 2.4 mm/s toward a
/// face while the particle's own velocity pointed away, until it sat on the face and the
/// fluid force burst (ARCHITECTURE.md, "Joubert's cross at δ = 0.25 mm runs with Γ = 4").
/// Near a body the shift may not carry a particle closer than δ/2 in front of its nearest
/// surface marker's plane. A filled sphere (r = 5δ) carves jittered fluid (±0.3δ, random
/// velocities up to 0.5 m/s) and then moves 0.2δ along +x, so fluid on that side stands
/// 0.3δ and more off its surface; one gradient pass and one shift with Δt = 1e-3 s.
/// Reference: the twins (`gradients_cpu`, `shift_cpu` with `nearest_surface_marker_cpu`)
/// on the GPU's state before the pass; without the rule the twin moves particles inside
/// δ/2 that the rule holds. The kernel's count of shifts cut short (`shift_limited`) is
/// the twin's, but for shifts within 2e-8 m of the rule's edge.
#[test]
fn shift_keeps_fluid_off_a_surface_as_the_twin_does() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = common::scene(
        "",
        "[effects]\ngradient_correction = true\nparticle_shifting = 0.1",
    );
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    let (centre, r) = ([0.1, 0.1, 0.1], 5.0 * d);
    let (mut points, state) = filled_sphere(centre, r, 300, 0.9);
    let mut set = initial_particles(&s, &c).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    for i in 0..set.len() {
        if set.kinds.kind(set.id[i]) == Kind::Fluid {
            for k in 0..3 {
                set.pos[i][k] += (rng.random::<f64>() - 0.5) * 0.6 * d;
                set.vel[i][k] = (rng.random::<f64>() - 0.5) * 1.0;
            }
        }
    }
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    move_along_x(&gpu, &mut solver, &mut points, state, 0.2 * d, 0.0);
    let dt = 1e-3;
    solver
        .run_ops(&gpu, &[Op::MarkerUpdate, Op::Sort], dt, 1.0)
        .unwrap();
    let (before, after) = common::around_a_shift(&gpu, &mut solver, dt);
    let count = solver.data().read_shift_limited(&gpu).unwrap();
    let markers = surface_points(&points);
    let surface = surface_markers(&before, &markers);
    let cpu = gradients_cpu(&c, &before);
    let u_max = common::largest_fluid_speed(&before);
    let (mut pairs, mut held, mut worst_gap) = (Vec::new(), 0, f64::INFINITY);
    // Shifts the rule cuts short (the free shift goes past where the rule stops it), and
    // those within f32's resolution of positions near 0.1 m of that edge.
    let (mut limited, mut borderline) = (0u32, 0u32);
    let mut largest_hold = 0.0f64;
    for i in 0..before.len() {
        let Some(g) = cpu[i] else { continue };
        let s0 = Shifted::of(&before, i);
        let near = nearest_surface_marker_cpu(&c, &before, &markers, &surface, i);
        let twin = shift_cpu(&c, &g, u_max, dt, s0, 1.0, near.map(|(_, r, n)| (r, n)));
        let free = shift_cpu(&c, &g, u_max, dt, s0, 1.0, None);
        for k in 0..3 {
            pairs.push((after.pos[i][k] - s0.pos[k], twin.pos[k] - s0.pos[k]));
        }
        if let Some((j, r, n)) = near {
            // Where the rule stops the particle in front of the marker's plane, and how
            // far past that the shift without the rule would carry it.
            let floor = dot(r, n).min(0.5 * d);
            let excess = floor - dot(sub(free.pos, before.pos[j]), n);
            limited += u32::from(excess > 0.0);
            borderline += u32::from(excess.abs() < 2e-8);
            if excess > 1e-9 {
                held += 1;
                let e = sub(free.pos, twin.pos);
                largest_hold = largest_hold.max(dot(e, e).sqrt());
            }
            // The GPU's particle after the shift, against the same marker's plane.
            let gap = dot(sub(after.pos[i], before.pos[j]), n);
            worst_gap = worst_gap.min(gap - floor);
        }
    }
    let (e, m) = common::max_err(pairs.into_iter());
    println!(
        "shift δr: max |GPU − twin| = {e:e} of {m:e}; {held} particles held off, by up to {largest_hold:e} m; worst gap {worst_gap:e} m; shifts cut short: GPU {count}, twin {limited} ({borderline} borderline)"
    );
    // f32 positions near 0.1 m resolve 1e-8 m.
    let tolerance = 1e-3 * m + 2e-8;
    assert!(m > 0.0 && e <= tolerance, "δr: {e:e} of {m:e}");
    // The configuration tests the rule: without it the GPU would miss the twin.
    assert!(
        held >= 5 && largest_hold > 10.0 * tolerance,
        "{held} held, by up to {largest_hold:e} m"
    );
    assert!(
        worst_gap >= -2e-8,
        "a particle shifted inside δ/2: {worst_gap:e} m"
    );
    // The kernel counts what it cut short (status[4], reported as `shift_limited`).
    assert!(
        limited >= 5 && count.abs_diff(limited) <= borderline,
        "shifts cut short: GPU counted {count}, the twin {limited} ({borderline} borderline)"
    );
}

#[test]
fn fluid_behind_a_body_surface_is_mirrored_out_as_the_twin_does() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = common::scene("", "");
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    let (centre, r) = ([0.1, 0.1, 0.1], 5.0 * d);
    let (mut points, state) = filled_sphere(centre, r, 300, 0.9);
    let mut solver =
        FluidSolver::from_particles(&gpu, &s, initial_particles(&s, &c).unwrap()).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    // The body moves: every point 0.8δ along +x, at 0.1 m/s.
    move_along_x(&gpu, &mut solver, &mut points, state, 0.8 * d, 0.1);
    let (got, twin, count, twin_count) = non_penetration_pass(&gpu, &c, &mut solver, &points);
    println!("mirrored out: GPU {count}, twin {twin_count}");
    assert!(
        twin_count >= 10,
        "the moved surface should hold fluid behind it: {twin_count}"
    );
    assert_eq!(count, twin_count);
    assert_fluid_agrees(&c, &got, &twin);
    // Afterwards no fluid particle is behind its nearest surface marker's plane.
    let base = got.kinds.marker_base();
    for i in (0..got.len()).filter(|&i| got.kinds.kind(got.id[i]) == Kind::Fluid) {
        let nearest = (0..got.len())
            .filter(|&j| {
                got.kinds.kind(got.id[j]) == Kind::Marker
                    && points[got.id[j] as usize - base].measure > 0.0
            })
            .min_by(|&a, &b| {
                let (ra, rb) = (sub(got.pos[i], got.pos[a]), sub(got.pos[i], got.pos[b]));
                dot(ra, ra).total_cmp(&dot(rb, rb))
            })
            .unwrap();
        let r = sub(got.pos[i], got.pos[nearest]);
        if dot(r, r) < d * d {
            let n = points[got.id[nearest] as usize - base]
                .normal
                .map(f64::from);
            assert!(
                dot(r, n) >= -1e-6 * d,
                "particle {} still behind: {:e}",
                got.id[i],
                dot(r, n)
            );
        }
    }
}

/// The same across a periodic face. The box is periodic in x; the sphere (r = 5δ) moves
/// δ along −x, to where its −x pole stands 0.3δ beyond x = 0, across the face. For each
/// surface marker that ends beyond the face with the point 0.25δ behind its final
/// tangent plane on this side, a fluid particle (taken from far off) starts at that
/// point: at least 0.69δ in front of the surface before the move (the carve-out takes
/// what is nearer than δ/2), behind it after, with its nearest marker across the face. The kernel finds it through `row_ranges_within`'s
/// wrapped rows and `pair_vec`'s nearest image; the twin takes the nearest image too
/// (`SphConstants::pair_vec`). Reference: the twin on the GPU's state before the pass;
/// the particles behind a marker across the face are counted, so that the test shows
/// it reaches them (with plain differences in the twin it fails).
#[test]
fn fluid_behind_a_body_across_a_periodic_face_is_mirrored_out_as_the_twin_does() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let mut s = common::scene("", "");
    s.domain.periodic = [true, false, false];
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    assert_eq!(c.period, [0.2, 0.0, 0.0]);
    let (centre, r, shift) = ([5.7 * d, 0.1, 0.1], 5.0 * d, -d);
    let (mut points, state) = filled_sphere(centre, r, 300, 0.9);
    let mut set = initial_particles(&s, &c).unwrap();
    // Fluid far from the sphere (beyond r + 3δ of its centre, also through the face).
    let far: Vec<usize> = (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Fluid)
        .filter(|&i| {
            let e = c.pair_vec(set.pos[i], centre);
            dot(e, e).sqrt() > r + 3.0 * d
        })
        .collect();
    let mut placed = 0;
    for p in points.iter().filter(|p| p.measure > 0.0) {
        let m = [
            f64::from(p.position[0]) + shift,
            f64::from(p.position[1]),
            f64::from(p.position[2]),
        ];
        let n = p.normal.map(f64::from);
        let x: [f64; 3] = std::array::from_fn(|k| m[k] - 0.25 * d * n[k]);
        if !(m[0] < 0.0 && x[0] > 0.0) {
            continue;
        }
        let i = far[placed];
        set.pos[i] = x;
        set.vel[i] = [0.0; 3];
        placed += 1;
    }
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    move_along_x(&gpu, &mut solver, &mut points, state, shift, -0.1);
    solver
        .run_ops(&gpu, &[Op::MarkerUpdate, Op::Sort], 1e-5, 1.0)
        .unwrap();
    let before = solver.data().read(&gpu).unwrap();
    let markers = surface_points(&points);
    let surface = surface_markers(&before, &markers);
    let across = (0..before.len())
        .filter(|&i| before.kinds.kind(before.id[i]) == Kind::Fluid)
        .filter_map(|i| {
            let (j, r, n) = nearest_surface_marker_cpu(&c, &before, &markers, &surface, i)?;
            let far_side = (before.pos[i][0] - before.pos[j][0]).abs() > 0.5 * c.period[0];
            (far_side && dot(r, n) < 0.0).then_some(i)
        })
        .count();
    let (got, twin, count, twin_count) = non_penetration_pass(&gpu, &c, &mut solver, &points);
    println!(
        "placed {placed}; behind a marker across the face: {across}; mirrored out: GPU {count}, twin {twin_count}"
    );
    assert!(
        across >= 5,
        "fluid behind a marker across the face: {across}"
    );
    assert_eq!(count, twin_count);
    assert_fluid_agrees(&c, &got, &twin);
}

/// Three fluid particles of the 0.2 m box start 0.3δ below the floor, 0.3δ beyond the
/// +x wall and 0.3δ above the top, each moving outward at 0.05 m/s; then the
/// non-penetration pass alone, with the filled sphere of the tests above when `body`.
/// Reference: the mirror image, analytic — each particle beyond a wall face ends 0.3δ
/// inside it with no outward velocity, one above an open top is left alone — and the
/// twin, `non_penetration_cpu`, for the whole state.
fn fluid_beyond_the_walls_is_mirrored_back(closed_top: bool, body: bool) {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let mut s = common::scene("", "");
    s.domain.closed_top = closed_top;
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    let mut set = initial_particles(&s, &c).unwrap();
    let fluid: Vec<usize> = (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Fluid)
        .collect();
    // (particle, axis, where it goes in the scene's frame, outward velocity)
    let (a, b, t) = (fluid[0], fluid[1], fluid[2]);
    let cases = [
        (a, 1, -0.3 * d, -0.05),
        (b, 0, 0.2 + 0.3 * d, 0.05),
        (t, 1, 0.2 + 0.3 * d, 0.05),
    ];
    for &(i, k, x, u) in &cases {
        set.pos[i][k] = x;
        set.vel[i] = [0.0; 3];
        set.vel[i][k] = u;
    }
    let ids: Vec<u32> = cases.iter().map(|&(i, ..)| set.id[i]).collect();
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    let points = if body {
        let (points, state) = filled_sphere([0.1, 0.1, 0.1], 5.0 * d, 300, 0.9);
        solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
        points
    } else {
        Vec::new()
    };
    let (got, twin, count, twin_count) = non_penetration_pass(&gpu, &c, &mut solver, &points);
    println!("mirrored: GPU {count}, twin {twin_count}");
    assert_eq!(
        count,
        if closed_top { 3 } else { 2 },
        "the floor's, the +x wall's and, under a lid, the top's particles"
    );
    assert_eq!(twin_count, count);
    let origin = solver.origin();
    let at = |id: u32| (0..got.len()).find(|&i| got.id[i] == id).unwrap();
    // Positions to f32 round-off of the 0.2 m box (1e-7 · 0.2 m).
    let top = if closed_top {
        (1, 0.2 - 0.3 * d, 0.0)
    } else {
        (1, 0.2 + 0.3 * d, 0.05)
    };
    let expect = [(1, 0.3 * d, 0.0), (0, 0.2 - 0.3 * d, 0.0), top];
    for (&id, &(k, x, u)) in ids.iter().zip(&expect) {
        let i = at(id);
        let world = got.pos[i][k] + origin[k];
        println!(
            "particle {id}: axis {k} at {world:e} m, velocity {:e} m/s",
            got.vel[i][k]
        );
        assert!(
            (world - x).abs() <= 2e-8,
            "position {world:e}, expected {x:e}"
        );
        assert!(
            (got.vel[i][k] - u).abs() <= 1e-7,
            "velocity {:e}",
            got.vel[i][k]
        );
    }
    assert_fluid_agrees(&c, &got, &twin);
}

/// Regression (settling-sphere quick with Γ = 2, 2026-11-26: a sphere landing on the
/// floor pressed a fluid particle through it, where its density went to NaN): the
/// bodies' non-penetration pass also mirrors fluid back across the domain's wall
/// faces; in the open-topped box the particle above the top is left alone.
#[test]
fn fluid_pressed_through_a_wall_by_a_body_is_mirrored_back() {
    fluid_beyond_the_walls_is_mirrored_back(false, true);
}

/// Regression (the full water–glycerol RTI at α = 0, 2026-12-06: two fluid particles
/// above the lid at 110 ms, among its wall layers, where no pass saw them): a scene
/// without resolved bodies keeps fluid inside its wall faces too (the walls' pass,
/// `wall_non_penetration`), the lid's included.
#[test]
fn fluid_beyond_a_lid_without_bodies_is_mirrored_back() {
    fluid_beyond_the_walls_is_mirrored_back(true, false);
}

/// Adami's boundary pass with a body's fill points (area 0) on one side: a sphere r = 1.5δ
/// with 30 surface markers and fill points at 0.3 r, whose support of 3δ reaches the
/// fluid on the body's far side too, in a fluid at rest whose pressure varies linearly
/// across it without gravity (so the extrapolation is a Shepard average, which the side
/// changes). The GPU's boundary pressures against the twin
/// `boundary_pressure_with_fill_cpu` to 1e-4 of the largest; the fill points' pressures
/// are shown to differ from the two-sided extrapolation (the twin's
/// `boundary_pressure_cpu`) by more than that, so the test sees the side rule.
#[test]
fn fill_points_extrapolate_from_their_own_side_as_the_twin_does() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = common::scene("", "[gravity]\nvector = [0.0, 0.0, 0.0]\n");
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    let (centre, r) = ([0.1, 0.1, 0.1], 1.5 * d);
    let (points, state) = filled_sphere(centre, r, 30, 0.3);
    // p = 1000 (3, −9, 2)·x Pa/m (x relative to the domain centre).
    let mut set = initial_particles(&s, &c).unwrap();
    for i in 0..set.kinds.n_fluid {
        let p = 1000.0 * (3.0 * set.pos[i][0] - 9.0 * set.pos[i][1] + 2.0 * set.pos[i][2]);
        set.press[i] = p;
        set.rho[i] = c.density(p);
    }
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    solver
        .run_ops(
            &gpu,
            &[Op::MarkerUpdate, Op::Sort, Op::BoundaryPressure],
            1e-5,
            1.0,
        )
        .unwrap();
    let got = solver.data().read(&gpu).unwrap();
    let base = got.kinds.marker_base();
    let side = |i: usize| {
        let id = got.id[i] as usize;
        (got.kinds.kind(got.id[i]) == Kind::Marker && points[id - base].measure == 0.0)
            .then(|| points[id - base].normal.map(f64::from))
    };
    let one_sided = boundary_pressure_with_fill_cpu(&c, &got, side);
    let two_sided = boundary_pressure_cpu(&c, &got);
    let scale = got.press.iter().fold(0.0f64, |m, p| m.max(p.abs()));
    let (mut e_gpu, mut d_side) = (0.0f64, 0.0f64);
    for i in 0..got.len() {
        if let Some((p, _)) = one_sided[i] {
            e_gpu = e_gpu.max((got.press[i] - p).abs());
            if side(i).is_some() {
                d_side = d_side.max((p - two_sided[i].unwrap().0).abs());
            }
        }
    }
    println!(
        "boundary pressure: GPU against twin {e_gpu:e} Pa, one- against two-sided at fill points {d_side:e} Pa, of {scale:e} Pa"
    );
    assert!(e_gpu <= 1e-4 * scale, "GPU {e_gpu:e} of {scale:e}");
    assert!(
        d_side > 1e-3 * scale,
        "the side rule changes nothing here: {d_side:e}"
    );
}

/// Regression: the ring's hole at δ = 1 mm (`couplet validate shape-drag --quick
/// --variant ring` blew up in the hole's column at t = 0.0313 s). Its twelve inner faces
/// carry two markers of 0.33 δ² each, 0.375 δ apart round the hole, and every marker
/// weighed the lattice mass ρ0 δ³, so the hole was walled by a wall denser than any
/// other. Now a marker's mass (`pos.w`, its volume m/ρ in every sum) is the slab it
/// stands for, ρ0 ΔS δ, and a fill point (ΔS = 0) keeps the lattice mass. Checked on the
/// GPU's particles after `set_bodies`, against `marker_mass` and against ρ0 ΔS δ written
/// out, to f32 round-off.
#[test]
fn ring_hole_markers_weigh_their_patch_not_a_lattice_particle() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = common::scene("", "");
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    // 30 markers on r = 1.5δ (0.94 δ² each) and 10 fill points.
    let (mut points, state) = filled_sphere([0.1, 0.1, 0.1], 1.5 * d, 30, 0.3);
    // A small patch such as the ring's inner faces.
    points[0].measure = (0.3 * d * d) as f32;
    let mut solver =
        FluidSolver::from_particles(&gpu, &s, initial_particles(&s, &c).unwrap()).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    let got = solver.data().read(&gpu).unwrap();
    let base = got.kinds.marker_base();
    let mut seen = [0usize; 2];
    for i in 0..got.len() {
        if got.kinds.kind(got.id[i]) != Kind::Marker {
            continue;
        }
        let p = &points[got.id[i] as usize - base];
        let area = f64::from(p.measure);
        let want = if area > 0.0 {
            c.rho0 * area * d
        } else {
            c.rho0 * d * d * d
        };
        assert!(
            (got.mass[i] - want).abs() <= 1e-6 * want,
            "marker of ΔS = {area:e} m²: mass {:e} kg, want {want:e}",
            got.mass[i]
        );
        assert!((marker_mass(&c, p.measure) - want).abs() <= 1e-12 * want);
        seen[usize::from(area > 0.0)] += 1;
    }
    assert_eq!(seen, [10, 30], "fill points and surface markers");
}

/// Regression: the ring's hole at δ = 1 mm again (`couplet validate shape-drag --quick
/// --variant ring`, cut to a 25 mm box and 0.3 s, blew up in the hole's column at
/// t = 0.093 s). Particle shifting (Joubert eq. 17) counted each of the 24 inner-face
/// markers, 0.375 δ apart, as a whole particle, drove the fluid particle in the hole out
/// against its flow and let continuity compress it. Now each neighbour counts as
/// m_j/(ρ0 δ³) lattice particles. A sphere whose markers stand for 0.3 δ² each, beside a
/// fluid at rest, over the fluid particles that see a marker: the GPU's shift direction
/// s_i against the twin's (`gradients_cpu`) to 1e-4 of the largest, and the twin's
/// against the weighted sum written out here; the unweighted sum differs from it by more
/// than 10 % somewhere, so the test sees the weights.
#[test]
fn shifting_counts_a_marker_as_the_patch_it_stands_for() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    // Support 2.9δ: the lattice has no pair at the support's edge (3δ), where eq. (17)'s
    // 1/r² does not vanish and f32 and f64 disagree on whether the pair counts.
    let s = common::scene(
        "support = 2.9",
        "[effects]\ngradient_correction = true\nparticle_shifting = 0.1\n",
    );
    let c = SphConstants::from_scene(&s).unwrap();
    let d = c.spacing;
    let (mut points, state) = filled_sphere([0.1, 0.1, 0.1], 1.5 * d, 30, 0.3);
    for p in points.iter_mut().filter(|p| p.measure > 0.0) {
        p.measure = (0.3 * d * d) as f32;
    }
    let mut solver =
        FluidSolver::from_particles(&gpu, &s, initial_particles(&s, &c).unwrap()).unwrap();
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    solver
        .run_ops(
            &gpu,
            &[Op::MarkerUpdate, Op::Sort, Op::Gradients],
            1e-5,
            1.0,
        )
        .unwrap();
    let set = solver.data().read(&gpu).unwrap();
    let gpu_shift: Vec<[f64; 3]> = solver
        .data()
        .read_gradients(&gpu)
        .unwrap()
        .unwrap()
        .fields
        .iter()
        .map(|f| f[4])
        .collect();
    let twin = couplet_fluid::joubert2020_gradients::gradients_cpu(&c, &set);
    let reach = c.kernel.radius();
    let norm = |v: [f64; 3]| dot(v, v).sqrt();
    let (mut e_gpu, mut e_sum, mut unweighted_off, mut scale, mut near) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0);
    for i in 0..set.len() {
        let Some(g) = twin[i] else { continue };
        // Eq. (17)'s sum written out, weighted and not.
        let (mut weighted, mut whole, mut r_sum, mut n, mut markers) =
            ([0.0; 3], [0.0; 3], 0.0, 0.0, 0);
        for j in set.neighbours(i, reach, c.period) {
            let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
            let r = dot(r_ij, r_ij).sqrt();
            let w = set.mass[j] / (c.rho0 * d * d * d);
            for k in 0..3 {
                weighted[k] += w * r_ij[k] / (r * r * r);
                whole[k] += r_ij[k] / (r * r * r);
            }
            r_sum += r;
            n += 1.0;
            markers += usize::from(set.kinds.kind(set.id[j]) == Kind::Marker);
        }
        if markers == 0 {
            continue;
        }
        near += 1;
        e_gpu = e_gpu.max(norm(sub(gpu_shift[i], g.shift)));
        let r2 = (r_sum / n) * (r_sum / n);
        let (weighted, whole) = (weighted.map(|x| r2 * x), whole.map(|x| r2 * x));
        scale = scale.max(norm(g.shift));
        e_sum = e_sum.max(norm(sub(g.shift, weighted)) / norm(weighted));
        unweighted_off = unweighted_off.max(norm(sub(whole, weighted)) / norm(weighted));
    }
    println!(
        "shift direction: GPU against twin {e_gpu:e} of {scale:e}; twin against the weighted sum {e_sum:e} (relative), the unweighted sum up to {unweighted_off:e} off, over {near} particles beside markers"
    );
    assert!(near > 10, "only {near} fluid particles see a marker");
    assert!(e_gpu <= 1e-4 * scale, "GPU {e_gpu:e} of {scale:e}");
    assert!(e_sum <= 1e-9, "twin against the weighted sum: {e_sum:e}");
    assert!(
        unweighted_off > 0.1,
        "weights change the shift by only {unweighted_off:e}"
    );
}
