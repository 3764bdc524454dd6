//! The solver's public API end to end: plan and limits (no GPU), bodies and loads,
//! blow-up reporting, marker bookkeeping.

mod common;

use couplet_fluid::gpu::shared_test_gpu;
use couplet_fluid::{
    FluidError, FluidLimits, FluidSolver, Op, ParticleSet, SphConstants, WindowStats, stages,
};
use couplet_protocol::{BodyState, Scene};
use std::path::Path;

fn tank(extra: &str) -> Scene {
    tank_with(0.02, 0.3, extra)
}

/// The tank at fluid spacing `spacing`, its fluid `height` deep.
fn tank_with(spacing: f64, height: f64, extra: &str) -> Scene {
    let text = format!(
        r#"
[meta]
name = "tank"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.32, 0.2]
[fluid]
density = 1000.0
kinematic_viscosity = 1e-6
sound_speed = 17.5
spacing = {spacing}
support = 2.0
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, {height}, 0.2] }}]
{extra}
"#
    );
    Scene::parse(&text, Path::new("tank.toml")).unwrap()
}

/// The stage list follows the effects: viscosity and artificial viscosity appear only
/// when on; markers and loads only with resolved bodies; gravity only on the fluid; the
/// gradient pass only with the correction, shifting or Antuono's δ-SPH, the shift only
/// with shifting; fluid is kept inside the wall faces by the bodies' pass with resolved
/// bodies, by the walls' alone without, and by neither where every axis is periodic.
#[test]
fn stages_follow_the_scene() {
    let names = |s: &Scene| stages(s).iter().map(|s| s.name).collect::<Vec<_>>();
    let plain = tank("[effects]\nviscosity = \"none\"\n[gravity]\non_fluid = false");
    let n = names(&plain);
    assert!(
        !n.contains(&"morris1997_viscosity") && !n.contains(&"monaghan1992_artificial_viscosity")
    );
    assert!(
        !n.contains(&"gravity")
            && !n.contains(&"marker_update")
            && !n.contains(&"joubert2020_body_loads")
    );
    assert!(!n.contains(&"joubert2020_gradients") && !n.contains(&"particle_shifting"));
    assert!(n.contains(&"wall_non_penetration") && !n.contains(&"body_non_penetration"));
    let mut periodic = tank("");
    periodic.domain.periodic = [true; 3];
    let periodic = names(&periodic);
    assert!(
        !periodic.contains(&"wall_non_penetration") && !periodic.contains(&"body_non_penetration"),
        "{periodic:?}"
    );
    let full = tank(
        "[effects]\nviscosity = \"laminar\"\nartificial_viscosity = 0.1\ngradient_correction = true\nparticle_shifting = 0.05\n[[bodies]]\nname = \"s\"\nshape.sphere.radius = 0.02\ndensity = 1200.0\nposition = [0.1, 0.2, 0.1]",
    );
    let n = names(&full);
    for s in [
        "morris1997_viscosity",
        "monaghan1992_artificial_viscosity",
        "gravity",
        "marker_update",
        "joubert2020_body_loads",
        "joubert2020_gradients",
        "particle_shifting",
        "body_non_penetration",
    ] {
        assert!(n.contains(&s), "{s} missing from {n:?}");
    }
    assert!(!n.contains(&"wall_non_penetration"), "{n:?}");
    assert!(stages(&full).iter().all(|s| !s.reason.is_empty()));
    // δ-SPH: Antuono's form needs the gradient pass's ∇ρ, Fourtakas's does not.
    let antuono = names(&tank("[effects]\ndensity_diffusion = 0.1"));
    assert!(
        antuono.contains(&"joubert2020_gradients")
            && antuono.contains(&"antuono2010_density_diffusion"),
        "{antuono:?}"
    );
    let fourtakas = names(&tank(
        "[effects]\ndensity_diffusion = 0.1\ndensity_diffusion_form = \"fourtakas\"",
    ));
    assert!(
        !fourtakas.contains(&"joubert2020_gradients")
            && fourtakas.contains(&"fourtakas2019_density_diffusion")
            && !fourtakas.contains(&"antuono2010_density_diffusion"),
        "{fourtakas:?}"
    );
}

/// Joubert eq. (24): Δt = s min(δ/(c + c/10), δ²/ν), with Morris's 0.125 h²/ν when smaller.
#[test]
fn limits_follow_joubert_eq_24() {
    let s = tank("");
    let l = FluidLimits::from_scene(&s).unwrap();
    let acoustic = 0.2 * 0.02 / (17.5 * 1.1);
    assert!((l.dt_acoustic - acoustic).abs() < 1e-15);
    // Wendland support 2δ: h = δ, Morris 0.125 δ²/ν < 0.2 δ²/ν.
    assert!((l.dt_viscous - 0.125 * 0.02 * 0.02 / 1e-6).abs() < 1e-9);
    assert_eq!(l.dt, acoustic);
    assert_eq!(l.delta_min, 0.02);
}

/// Joubert's one-layer walls sit δ/2 from the first fluid row: eq. (24)'s smallest
/// spacing is then δ/2 (regression: with δ the closed tank at rest blew up at 0.08 s).
#[test]
fn joubert_walls_halve_eq_24s_smallest_spacing() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/poiseuille.toml"
    ))
    .unwrap();
    let text = text
        .replace("[domain]", "[domain]\nwall_model = \"joubert\"")
        .replace("[effects]", "[effects]\ngradient_correction = true");
    let s = couplet_protocol::Scene::parse(&text, std::path::Path::new("p.toml")).unwrap();
    let l = FluidLimits::from_scene(&s).unwrap();
    // δ = 5e-5 m, ν = 1e-6 m²/s, Wendland support 3δ (h = 1.5δ): s δ_min²/ν with
    // δ_min = δ/2 binds below Morris's 0.125 h²/ν.
    assert_eq!(l.delta_min, 2.5e-5);
    assert!((l.dt_viscous - 0.2 * 2.5e-5 * 2.5e-5 / 1e-6).abs() < 1e-12);
    assert!((l.dt_acoustic - 0.2 * 2.5e-5 / (2.5e-3 * 1.1)).abs() < 1e-12);
    assert_eq!(l.dt, l.dt_viscous);
}

/// A closed sphere of 400 static markers (R = 0.05 m) in the hydrostatic tank at rest:
/// the load (Joubert eq. 31, uncorrected, pressure from the boundary-pressure stage,
/// reduced on the GPU) is the buoyancy ρ0 g V within
/// 5 % (Archimedes; the markers see the fluid on both sides, so ∮ −p n dS of the
/// extrapolated pressure must integrate the hydrostatic field), the horizontal force
/// and the moment about the centre vanish to 2 % of ρ0 g V resp. ρ0 g V R.
#[test]
fn buoyancy_of_a_marker_sphere() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = tank("[effects]\nartificial_viscosity = 0.05");
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let (r, centre) = (0.05, [0.1, 0.15, 0.1]);
    let n = 400;
    let points = common::sphere_markers(centre, r, n);
    let state = BodyState {
        position: centre,
        body: 0,
        motion: 2,
        orientation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    solver.set_bodies(&gpu, &[state], &points, &[]).unwrap();
    assert_eq!(solver.counts().markers, n as u32);
    // One load evaluation on the initial (hydrostatic) state: after a window the markers,
    // which the uncorrected scheme treats as a dense wall inside the fluid, have already
    // disturbed the pressure around them.
    solver
        .run_ops(
            &gpu,
            &[
                Op::MarkerUpdate,
                Op::Sort,
                Op::BoundaryPressure,
                Op::MarkerLoads,
                Op::ReduceBodyLoads,
            ],
            1e-4,
            1.0,
        )
        .unwrap();
    let loads = solver.loads(&gpu).unwrap();
    assert_eq!(loads.len(), 1);
    let l = loads[0];
    let v = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    let buoyancy = 1000.0 * 9.81 * v;
    println!(
        "force {:?} N, moment {:?} N·m, ρ0 g V = {buoyancy:.4} N",
        l.force, l.moment
    );
    assert!(
        (l.force[1] - buoyancy).abs() < 0.05 * buoyancy,
        "F_y = {} vs ρ0 g V = {buoyancy}",
        l.force[1]
    );
    assert!(l.force[0].abs() < 0.02 * buoyancy && l.force[2].abs() < 0.02 * buoyancy);
    assert!(
        l.moment.iter().all(|m| m.abs() < 0.02 * buoyancy * r),
        "moment {:?}",
        l.moment
    );
    // A full window through the step path (marker_update, two load evaluations per
    // step, clock, tree reduction): finite loads for the one body.
    let substeps = solver.advance(&gpu, 0.002, None).unwrap();
    let after = solver.loads(&gpu).unwrap();
    println!(
        "after a window of {substeps} substeps: force {:?} N",
        after[0].force
    );
    assert!(
        after.len() == 1
            && after[0]
                .force
                .iter()
                .chain(&after[0].moment)
                .all(|x| x.is_finite())
    );
    // Later windows must keep the marker count.
    let err = solver
        .set_bodies(&gpu, &[state], &points[..10], &[])
        .unwrap_err();
    assert!(
        matches!(
            err,
            FluidError::MarkerCount {
                got: 10,
                capacity: 400
            }
        ),
        "{err}"
    );
}

/// The error of one window of two steps over a random set of 10³ particles (30 % walls,
/// velocity scale `u_scale`) that `spoil` has edited; panics if the window succeeds.
fn spoiled_window_error(u_scale: f64, spoil: impl FnOnce(&mut ParticleSet)) -> FluidError {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = common::scene("", "");
    let c = SphConstants::from_scene(&scene).unwrap();
    let mut set = common::random_set(&c, 10, 0.3, 0.1, u_scale, 9);
    spoil(&mut set);
    let mut solver = FluidSolver::from_particles(&gpu, &scene, set).unwrap();
    let dt = solver.limits().dt;
    solver.advance(&gpu, 2.0 * dt, None).unwrap_err()
}

/// A fluid particle with a non-finite velocity is reported at the end of the window
/// with its id, the quantity and the step.
#[test]
fn blow_up_names_the_particle() {
    let bad = 17;
    let err = spoiled_window_error(0.1, |set| set.vel[bad] = [f64::NAN, 0.0, 0.0]);
    let msg = err.to_string();
    println!("{msg}");
    match err {
        FluidError::BlowUp {
            id,
            step,
            since_step,
            since_time,
            ..
        } => {
            // NaN spreads to the neighbours within the window; the smallest bad id is
            // reported, which can only be the seeded one or a neighbour.
            assert!(id as usize <= bad || msg.contains("NaN"), "{msg}");
            assert_eq!(step, 2);
            // Checked once a window: the one window of two steps began at step 0.
            assert_eq!((since_step, since_time), (0, 0.0));
            assert!(msg.contains("it began after step 0"), "{msg}");
        }
        other => panic!("expected a blow-up, got {other}"),
    }
}

/// A fluid particle placed beyond the grid's padding is reported at the end of the
/// window as a grid error naming it, while the window's other checks (read in the same
/// round trip, `Gpu::read_buffers`) find nothing: its position, velocity and density are
/// finite and sane. Reference: the id the test gives it.
#[test]
fn particle_outside_the_grid_is_named_at_the_window_end() {
    let id = 23;
    let err = spoiled_window_error(0.0, |set| {
        assert!((id as usize) < set.kinds.n_fluid);
        let fluid = set.id.iter().position(|&i| i == id).unwrap();
        set.pos[fluid] = [40.0, 0.05, 0.05];
    });
    let msg = err.to_string();
    match err {
        FluidError::Grid { step, .. } => {
            assert_eq!(step, 2, "{msg}");
            assert!(msg.contains(&format!("particle id {id} ")), "{msg}");
        }
        other => panic!("expected a grid error, got {other}"),
    }
}

/// Snapshots hold the fluid only, in id order, in world coordinates; mass is m N.
#[test]
fn snapshot_is_fluid_in_id_order() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = tank("");
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let snap = solver.snapshot(&gpu).unwrap();
    assert_eq!(snap.len(), solver.counts().fluid as usize);
    // Id 0 is the first lattice point of the block (x, z = δ/2), at the bottom.
    assert!((snap[0].position[0] - 0.01).abs() < 1e-6 && (snap[0].position[2] - 0.01).abs() < 1e-6);
    assert!(
        snap.iter()
            .all(|p| p.position[1] > 0.0 && p.position[1] < 0.3)
    );
}

/// Regression for "settling-sphere plateau varied between identical runs" (0.55–5.14 %
/// in session 2): the grid sort took the order inside a cell from its atomics, so pair
/// sums ran in a different order each run and round-off grew into a different wake.
/// With the stable sort two runs from the same particles agree bit for bit. Reference:
/// the first run (exact equality of every f32 of the fluid's state).
#[test]
fn identical_runs_repeat_bit_for_bit() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = common::scene(
        "",
        "[effects]\ngradient_correction = true\nparticle_shifting = 0.05\ndensity_diffusion = 0.1",
    );
    let c = SphConstants::from_scene(&scene).unwrap();
    let run = || {
        let set = common::random_set(&c, 14, 0.25, 0.2, 0.2, 21);
        let mut solver = FluidSolver::from_particles(&gpu, &scene, set).unwrap();
        let dt = solver.limits().dt;
        solver.advance(&gpu, 20.0 * dt, None).unwrap();
        solver.snapshot(&gpu).unwrap()
    };
    let (a, b) = (run(), run());
    assert_eq!(a.len(), b.len());
    let differ = a
        .iter()
        .zip(&b)
        .filter(|(p, q)| {
            let bits = |r: &couplet_protocol::ParticleRecord| {
                let f = [r.position, r.velocity, [r.density, r.pressure, 0.0]];
                f.map(|v| v.map(f32::to_bits))
            };
            bits(p) != bits(q)
        })
        .count();
    assert_eq!(
        differ,
        0,
        "{differ} of {} particles differ between two runs",
        a.len()
    );
}

/// The window's telemetry (`window_stats.wgsl`) against its CPU twin on a seeded set
/// after a window: kinetic energy Σ ½ m |u|² within 1e-5 relative (f32 sums of 128
/// terms per workgroup, f64 across them), largest speed and density error to f32
/// round-off (1e-6 relative: the same f32 values, max is exact, the square root in f64).
#[test]
fn window_stats_match_their_cpu_twin() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = common::scene("", "");
    let c = SphConstants::from_scene(&scene).unwrap();
    let set = common::random_set(&c, 12, 0.3, 0.1, 0.5, 5);
    let mut solver = FluidSolver::from_particles(&gpu, &scene, set).unwrap();
    let dt = solver.limits().dt;
    solver.advance(&gpu, 3.0 * dt, None).unwrap();
    let gpu_stats = solver.stats();
    let twin = WindowStats::of_particles(&solver.particles(&gpu).unwrap(), c.rho0, |_| 1.0);
    println!("GPU {gpu_stats:?}\nCPU {twin:?}");
    assert!(twin.kinetic_energy > 0.0 && twin.max_density_error > 0.0);
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(gpu_stats.kinetic_energy, twin.kinetic_energy) < 1e-5);
    assert!(rel(gpu_stats.max_speed, twin.max_speed) < 1e-6);
    assert!(rel(gpu_stats.max_density_error, twin.max_density_error) < 1e-6);
}

/// A solver restored from a saved state continues exactly as the saved one: a seeded
/// set with the corrected scheme's optional buffers (gradient pass, shifting, δ-SPH; the
/// seeded walls of `identical_runs_repeat_bit_for_bit`, which the mass correction and the
/// corrected Laplacian do not survive) advances 6 steps, is saved, advances 8 more; a new
/// solver of the same scene restored from the save advances the same 8. Reference: the
/// original run, every f32 of the fluid's state equal (the sort is stable, so the
/// buffer order saved with the state fixes every pair sum's order).
#[test]
fn a_restored_solver_continues_bit_for_bit() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = common::scene(
        "",
        "[effects]\ngradient_correction = true\nparticle_shifting = 0.05\ndensity_diffusion = 0.1",
    );
    let c = SphConstants::from_scene(&scene).unwrap();
    let set = common::random_set(&c, 14, 0.25, 0.2, 0.2, 21);
    let mut original = FluidSolver::from_particles(&gpu, &scene, set).unwrap();
    let dt = original.limits().dt;
    original.advance(&gpu, 6.0 * dt, None).unwrap();
    let acceleration = couplet_fluid::marker_update::AccelerationEstimate::default();
    let saved = original.save_state(&gpu, &acceleration).unwrap();
    original.advance(&gpu, 8.0 * dt, None).unwrap();
    let mut restored = FluidSolver::restore(&gpu, &scene, &saved).unwrap();
    assert_eq!((restored.time(), restored.steps()), (6.0 * dt, 6));
    restored.advance(&gpu, 8.0 * dt, None).unwrap();
    let (a, b) = (
        original.snapshot(&gpu).unwrap(),
        restored.snapshot(&gpu).unwrap(),
    );
    assert_eq!(a, b, "the restored solver left the original's path");
    assert_eq!(original.stats(), restored.stats());
    // Another scene's solver refuses the state, naming what differs.
    let plain = common::scene("", "");
    let err = FluidSolver::restore(&gpu, &plain, &saved).err().unwrap();
    assert!(err.to_string().contains("buffers"), "{err}");
}

/// Bytes of GPU buffer a particle costs, against the inventory of every per-particle
/// buffer the solver allocates (ARCHITECTURE.md, "GPU memory per particle"). Standard
/// scheme, closed tank with Adami's no-slip walls: the state (pos 16, vel 16, ρ 4, p 4,
/// id 4, dρ/dt 4, du/dt 16, ρ_n 4, u_n 16, the low words of position and density 16 =
/// 100 B), the grid's sort (cell, rank, slot in the atomics' order, gather map: 16 B),
/// the walls' extrapolated velocity (16 B, kept for every slot), the reorder's scratch
/// for pos and vel (32 B; ρ, p and id are gathered into u_n, the low words into the
/// walls' velocity, both lent) and the window statistics' partials (16 B per workgroup
/// of 128 = 0.125 B): 164.125 B (180.125 until 2026-12-06, the walls' velocity not
/// lent). The gradient pass stores only what the scene reads (`GradientFields`): with
/// Joubert's correction alone B (48 B), lent to the reorder for pos, vel and the low
/// words, and no gradient slot, 180.125 B; with Antuono's δ-SPH alone the ∇ρ slot
/// (16 B) and no B, lent to the reorder for the low words (a pass of their own, as the
/// walls' velocity then takes vel), which leaves 16 B of its own scratch, 164.125 B
/// (196.125, then 180.125, until 2026-12-06); shifting alone ∇u, ∇p and s (80 B), which
/// take the reorder's 48 B (212.125 B); the correction with the corrected Laplacian adds
/// B̂ (32 B), 212.125 B; with the correction, shifting and δ-SPH every
/// slot, 276.125 B. Until 2026-12-05 every gradient pass kept B and all six
/// slots (144 B), there were no low words (32 B with their scratch), and the reorder's
/// scratch was all its own (60 B).
///
/// Measured as wgpu-hal's count of live buffer bytes (Gpu::buffer_memory) with the fluid
/// at two heights in the same box, so that the walls and the grid's cells are the same
/// and only fluid particles differ (64 000 of them): the allocations' alignment moves
/// the difference by at most a few hundred bytes a buffer, under 0.2 B a particle.
/// What stays beside n × that is the grid's cells (`grid_cell_bytes`) and a few small
/// buffers (uniforms, diagnostics): within 1 MiB.
#[test]
fn buffer_memory_per_particle_matches_the_inventory() {
    let gpu = shared_test_gpu().unwrap();
    for (effects, inventory) in [
        ("", 164.125),
        ("gradient_correction = true", 180.125),
        ("density_diffusion = 0.1", 164.125),
        ("particle_shifting = 0.1", 212.125),
        (
            "gradient_correction = true\nlaplacian_correction = true",
            212.125,
        ),
        (
            "gradient_correction = true\nparticle_shifting = 0.1\ndensity_diffusion = 0.1",
            276.125,
        ),
    ] {
        let before = gpu.buffer_memory().unwrap();
        let mut sizes = Vec::new();
        for height in [0.1, 0.3] {
            let scene = tank_with(0.005, height, &format!("[effects]\n{effects}"));
            let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
            // Both kinds of step and a read-back: every buffer a run keeps.
            let dt = solver.limits().dt;
            solver.advance(&gpu, 2.0 * dt, None).unwrap();
            let bytes = gpu.buffer_memory().unwrap() - before;
            let c = solver.counts();
            sizes.push((
                bytes as f64,
                f64::from(c.fluid + c.wall),
                solver.grid_cell_bytes() as f64,
            ));
        }
        let [(b0, n0, cells0), (b1, n1, cells1)] = [sizes[0], sizes[1]];
        assert_eq!(cells0, cells1, "{effects}: the same box, the same cells");
        assert_eq!(
            n1 - n0,
            64_000.0,
            "{effects}: 40 × 40 × 40 more fluid particles"
        );
        let per_particle = (b1 - b0) / (n1 - n0);
        assert!(
            (per_particle - inventory).abs() < 0.2,
            "{effects:?}: {per_particle:.3} B a particle, the inventory says {inventory}"
        );
        // (A buffer of another test that wgpu frees meanwhile moves it by its size: a few
        // hundred bytes were seen, hence no lower bound at 0.)
        let rest = b0 - inventory * n0 - cells0;
        assert!(
            rest.abs() < 1024.0 * 1024.0,
            "{effects:?}: {rest} B beside the particles' and the cells'"
        );
    }
}

/// Regression (2026-12-05): a scene whose corrected gradients (96 B a particle) outgrew
/// one storage binding panicked in wgpu's bind-group validation (`couplet bench
/// scenes/spheric2-dam-break.toml --spacing 0.008 --set effects.gradient_correction=true`
/// on lavapipe, 1.9 M particles against 128 MiB: "Buffer binding 10 range 182502432
/// exceeds `max_*_buffer_binding_size`"; on an H200 any corrected scene past 22 M
/// particles). Now every buffer is checked before it is bound and the scene is refused
/// with the most particles its effects allow; with the correction alone the widest
/// buffer is now B's, 48 B a particle (the gradient slots it does not read are not
/// kept). The binding limit is lowered here so that a small tank crosses it.
#[test]
fn buffers_past_one_binding_are_refused_not_a_panic() {
    let mut gpu = shared_test_gpu().unwrap();
    // The tank at δ = 0.01 m, 12 000 fluid particles: a binding for 32 B each still
    // holds the grid's 4 B a cell.
    let standard = tank_with(0.01, 0.3, "[effects]\nviscosity = \"none\"");
    let corrected = tank_with(
        0.01,
        0.3,
        "[effects]\nviscosity = \"none\"\ngradient_correction = true",
    );
    let n = {
        let c = FluidSolver::new(&gpu, &standard).unwrap().counts();
        (c.fluid + c.wall) as usize
    };
    // Room for the state's 16 B a particle, not for B's 48.
    gpu.storage_binding_limit = n as u64 * 32;
    let fits = FluidSolver::new(&gpu, &standard).expect("the standard scheme's widest buffer fits");
    assert_eq!(fits.widest_particle_buffer(), ("sph: pos", 16));
    match FluidSolver::new(&gpu, &corrected) {
        Err(FluidError::TooManyParticles {
            n: got,
            buffer,
            stride,
            max,
            ..
        }) => {
            assert_eq!((got, buffer.as_str(), stride), (n, "sph: B matrix", 48));
            assert_eq!(
                max,
                n as u64 * 2 / 3,
                "32 B a particle's room holds 2/3 at 48 B"
            );
        }
        Err(e) => panic!("refused for another reason: {e}"),
        Ok(_) => panic!("{n} particles at 48 B passed a binding of {} B", n * 32),
    }
    // Too small for the state itself (12 B a particle: the grid's cells still fit):
    // refused at its positions, 16 B a particle.
    gpu.storage_binding_limit = n as u64 * 12;
    match FluidSolver::new(&gpu, &standard) {
        Err(e @ FluidError::TooManyParticles { stride: 16, .. }) => {
            let text = e.to_string();
            assert!(
                text.contains(&format!("at most {} particles", n * 3 / 4))
                    && text.contains("sph: pos"),
                "{text}"
            );
        }
        Err(e) => panic!("refused for another reason: {e}"),
        Ok(_) => panic!("{n} particles at 16 B passed a binding of {} B", n * 12),
    }
    // There, a scene keeping every gradient slot (96 B) is told its own cap, not the
    // state's.
    let every_slot = tank_with(
        0.01,
        0.3,
        "[effects]\nviscosity = \"none\"\ngradient_correction = true\n\
         particle_shifting = 0.1\ndensity_diffusion = 0.1",
    );
    match FluidSolver::new(&gpu, &every_slot) {
        Err(FluidError::TooManyParticles {
            buffer,
            stride,
            max,
            ..
        }) => assert_eq!(
            (buffer.as_str(), stride, max),
            ("sph: corrected gradients", 96, n as u64 * 12 / 96)
        ),
        Err(e) => panic!("refused for another reason: {e}"),
        Ok(_) => panic!("{n} particles at 96 B passed a binding of {} B", n * 12),
    }
}

/// The reorder gathers into uⁿ, B, the gradient slots and the walls' velocity
/// (`NeighbourGrid::lend_scratch`, ARCHITECTURE.md "The reorder gathers into buffers that
/// are dead at a sort"), which is sound only if nothing reads them after a sort before
/// writing them. Here each is filled with NaN right after each sort, and the rest of the
/// step must come out the same bit for bit over three steps, in two tanks: Joubert's
/// correction with shifting and δ-SPH (B, the slots and uⁿ taken), and the standard
/// scheme (uⁿ and the walls' velocity taken). Reference: the same steps on an identical
/// solver without the poison. The comparison does see a read: the low words, which carry
/// state across the sort, poisoned alike change the result.
#[test]
fn buffers_lent_to_the_reorder_are_dead_after_a_sort() {
    let gpu = shared_test_gpu().unwrap();
    let halves = [
        Op::BoundaryPressure,
        Op::FluidRates,
        Op::Predict,
        Op::BoundaryPressure,
        Op::FluidRates,
        Op::Correct,
    ];
    let corrected = [&[Op::Gradients][..], &halves, &[Op::Shift]].concat();
    let nan = |buf: &wgpu::Buffer| {
        gpu.queue
            .write_buffer(buf, 0, &vec![0xFFu8; buf.size() as usize])
    };
    for (effects, rest) in [
        (
            "gradient_correction = true\nparticle_shifting = 0.1\ndensity_diffusion = 0.1",
            &corrected[..],
        ),
        ("", &halves[..]),
    ] {
        let scene = tank_with(0.02, 0.3, &format!("[effects]\n{effects}"));
        let run = |poison: &dyn Fn(&couplet_fluid::solver::SphData)| {
            let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
            let dt = solver.limits().dt;
            for _ in 0..3 {
                solver.run_ops(&gpu, &[Op::Sort], dt, 1.0).unwrap();
                poison(solver.data());
                solver.run_ops(&gpu, rest, dt, 1.0).unwrap();
            }
            let s = solver.data().read(&gpu).unwrap();
            let bits = |v: &[[f64; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            let scalars = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (
                bits(&s.pos),
                bits(&s.vel),
                scalars(&s.rho),
                scalars(&s.press),
            )
        };
        let plain = run(&|_| {});
        let lent = run(&|d| {
            nan(&d.vel_n);
            nan(d
                .wall_vel
                .as_ref()
                .expect("no-slip walls under a viscous fluid"));
            // The corrected tank stores B and slots; the standard one has no gradient pass.
            assert_eq!(d.gradients.is_some(), !effects.is_empty(), "{effects:?}");
            if let Some(g) = &d.gradients {
                assert!(g.fields.store_b && g.fields.slot_bytes() > 0);
                nan(&g.bmat);
                nan(&g.grads);
            }
        });
        assert!(
            plain == lent,
            "{effects:?}: a buffer lent to the reorder was read after a sort before being written"
        );
        let live = run(&|d| nan(&d.low_words));
        assert!(
            plain != live,
            "{effects:?}: poisoning a live buffer went unseen"
        );
    }
}

/// `predict` and `correct` (integrate.wgsl) against their CPU twin
/// (`predictor_corrector_cpu`, f64), particle by particle: seeded velocities (±0.5 m/s),
/// and rates imposed before each pass, different ones for the corrector (dρ/dt ±200 /s,
/// du/dt ±20 m/s² a component), over one step of Δt = 1e-4 s. After `predict`, ρ*, u*
/// and p* = EOS(ρ*) (Joubert eq. 20) with the positions unmoved; after `correct`,
/// ρ^{n+1} and u^{n+1} (eqs. 21–22), the positions moved by Δt u^{n+1} (eq. 23) and
/// p^{n+1}. Walls keep their state. Tolerances: f32 round-off of the stored words (with
/// the low words for positions and densities; without them a position 0.3 m up is off
/// by up to 1.5e-8 m): 2e-7 m/s, 1e-9 m, 1e-4 kg/m³, 0.05 Pa (dp/dρ = c² = 306 Pa
/// m³/kg), against steps of 2e-3 m/s, 5e-5 m, 0.02 kg/m³; measured 3.6e-8 m/s, 6.0e-12
/// m, 3.0e-5 kg/m³, 0.010 Pa (lavapipe, 2026-12-05).
#[test]
fn predict_and_correct_match_their_cpu_twin() {
    use couplet_fluid::integrate::{FluidState, predictor_corrector_cpu};
    use couplet_fluid::particles::Kind;
    use rand::{Rng, SeedableRng};
    let gpu = shared_test_gpu().unwrap();
    let scene = tank_with(0.02, 0.3, "[effects]\nviscosity = \"none\"");
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let c = solver.constants().clone();
    let before = solver.data().read(&gpu).unwrap();
    let n = before.len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let mut vec4s = |scale: f32| -> Vec<[f32; 4]> {
        (0..n)
            .map(|_| {
                let mut v = [0.0f32; 4];
                v[..3]
                    .iter_mut()
                    .for_each(|x| *x = scale * rng.random_range(-1.0..1.0));
                v
            })
            .collect()
    };
    let (vel, dvel_n, dvel_s) = (vec4s(0.5), vec4s(20.0), vec4s(20.0));
    let drho_n: Vec<f32> = (0..n).map(|_| rng.random_range(-200.0..200.0)).collect();
    let drho_s: Vec<f32> = (0..n).map(|_| rng.random_range(-200.0..200.0)).collect();
    let dt = 1e-4;
    let d = solver.data();
    let write = |buf: &wgpu::Buffer, bytes: &[u8]| gpu.queue.write_buffer(buf, 0, bytes);
    write(&d.vel, bytemuck::cast_slice(&vel));
    write(&d.dvel, bytemuck::cast_slice(&dvel_n));
    write(&d.drho, bytemuck::cast_slice(&drho_n));
    solver.run_ops(&gpu, &[Op::Predict], dt, 1.0).unwrap();
    let star = solver.data().read(&gpu).unwrap();
    let d = solver.data();
    write(&d.dvel, bytemuck::cast_slice(&dvel_s));
    write(&d.drho, bytemuck::cast_slice(&drho_s));
    solver.run_ops(&gpu, &[Op::Correct], dt, 1.0).unwrap();
    let after = solver.data().read(&gpu).unwrap();
    let low: Vec<[f32; 4]> = gpu
        .read_buffer(&solver.data().low_words, 0, n as u64)
        .unwrap();

    let f64s = |v: [f32; 4]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
    let mut worst = [0.0f64; 4]; // velocity, position, density, pressure
    let mut fluid = 0;
    let mut note = |k: usize, err: f64| worst[k] = worst[k].max(err);
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
    for i in 0..n {
        assert_eq!(before.id[i], after.id[i], "no sort ran");
        if before.kinds.kind(before.id[i]) != Kind::Fluid {
            assert_eq!(after.pos[i], before.pos[i], "a wall moved");
            assert_eq!(after.rho[i], before.rho[i], "a wall's density changed");
            continue;
        }
        fluid += 1;
        let start = FluidState {
            pos: before.pos[i],
            vel: f64s(vel[i]),
            rho: before.rho[i],
        };
        // The rates' first evaluation sees fⁿ, the second f*.
        let (mut calls, mut twin_star) = (0, start);
        let twin = predictor_corrector_cpu(start, dt, |s| {
            calls += 1;
            if calls == 1 {
                (f64::from(drho_n[i]), f64s(dvel_n[i]))
            } else {
                twin_star = *s;
                (f64::from(drho_s[i]), f64s(dvel_s[i]))
            }
        });
        assert_eq!(calls, 2, "the twin evaluates the rates twice");
        let ts = twin_star;
        // After predict.
        assert_eq!(star.pos[i], before.pos[i], "predict moved particle {i}");
        note(0, dist(star.vel[i], ts.vel));
        note(2, (star.rho[i] - ts.rho).abs());
        note(3, (star.press[i] - c.pressure(ts.rho)).abs());
        // After correct.
        let pos: [f64; 3] = std::array::from_fn(|k| after.pos[i][k] + f64::from(low[i][k]));
        note(0, dist(after.vel[i], twin.vel));
        note(1, dist(pos, twin.pos));
        note(2, (after.rho[i] + f64::from(low[i][3]) - twin.rho).abs());
        note(3, (after.press[i] - c.pressure(twin.rho)).abs());
    }
    assert!(fluid > 1000, "{fluid} fluid particles");
    let [du, dx, drho, dp] = worst;
    println!("worst: u {du:e} m/s, x {dx:e} m, ρ {drho:e}, p {dp:e} Pa over {fluid} particles");
    assert!(du < 2e-7, "velocity off by {du:e} m/s");
    assert!(dx < 1e-9, "position off by {dx:e} m");
    assert!(drho < 1e-4, "density off by {drho:e} kg/m³");
    assert!(dp < 0.05, "pressure off by {dp:e} Pa");
}

/// Regression (2026-12-05), the water–glycerol CPB's slow swing: increments below half
/// an f32 unit in the last place were rounded away every step. There u ~ 1e-4 m/s and
/// Δt ~ 2.5 μs move a particle 2.5e-10 m a step against the 4.7e-10 m ulp of a position
/// 5 mm up, and dρ/dt Δt fell below the 1.2e-4 ulp of ρ = 1150: the fluid near the floor
/// did not move at all while its velocity said 5e-5 m/s, and its pressure stood still
/// for milliseconds. Now `correct` sums positions and densities with compensation
/// (`integrate.wgsl`, the low words). Here every fluid particle of the tank moves
/// 1e-8 m a step (half an ulp is 1.49e-8 m above y = 0.25 m, 7.5e-9 m above 0.125 m:
/// rounded, it stood still or moved 1.49e-8) and its density grows 2e-5 a step (half
/// an ulp of 1000 is 3.05e-5) over 100 steps of predict and correct with imposed rates;
/// position (f32 word + low word) and density must be the exact sums to 1e-3 of the
/// increment's total. Reference: the integrator's CPU twin (`predictor_corrector_cpu`,
/// f64) over the same 100 steps, x⁰ + 100 U Δt and ρ⁰ + 100 Δt dρ/dt.
#[test]
fn positions_and_densities_keep_increments_below_half_an_ulp() {
    use couplet_fluid::integrate::{FluidState, predictor_corrector_cpu};
    let gpu = shared_test_gpu().unwrap();
    let scene = tank_with(0.01, 0.3, "[effects]\nviscosity = \"none\"");
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let (dt, u, drho, steps) = (1e-6f64, 0.01f64, 20.0f64, 100);
    let before = solver.data().read(&gpu).unwrap();
    let n = before.len();
    let d = solver.data();
    let vel: Vec<[f32; 4]> = vec![[0.0, u as f32, 0.0, 0.0]; n];
    gpu.queue
        .write_buffer(&d.vel, 0, bytemuck::cast_slice(&vel));
    gpu.queue.write_buffer(&d.dvel, 0, &vec![0u8; n * 16]);
    gpu.queue
        .write_buffer(&d.drho, 0, bytemuck::cast_slice(&vec![drho as f32; n]));
    for _ in 0..steps {
        solver
            .run_ops(&gpu, &[Op::Predict, Op::Correct], dt, 1.0)
            .unwrap();
    }
    let after = solver.data().read(&gpu).unwrap();
    let low: Vec<[f32; 4]> = gpu
        .read_buffer(&solver.data().low_words, 0, n as u64)
        .unwrap();
    let (dy, dr) = (steps as f64 * u * dt, steps as f64 * drho * dt);
    let (mut worst_y, mut worst_rho, mut fluid) = (0.0f64, 0.0f64, 0);
    for i in 0..n {
        if before.kinds.kind(before.id[i]) != couplet_fluid::particles::Kind::Fluid {
            continue;
        }
        assert_eq!(before.id[i], after.id[i], "no sort ran");
        fluid += 1;
        let mut twin = FluidState {
            pos: before.pos[i],
            vel: [0.0, u, 0.0],
            rho: before.rho[i],
        };
        for _ in 0..steps {
            twin = predictor_corrector_cpu(twin, dt, |_| (drho, [0.0; 3]));
        }
        let y = after.pos[i][1] + f64::from(low[i][1]);
        worst_y = worst_y.max((y - twin.pos[1]).abs());
        let rho = after.rho[i] + f64::from(low[i][3]);
        worst_rho = worst_rho.max((rho - twin.rho).abs());
    }
    assert!(fluid > 10_000);
    assert!(
        worst_y < 1e-3 * dy,
        "position off by {worst_y:e} m of {dy:e}"
    );
    assert!(
        worst_rho < 1e-3 * dr,
        "density off by {worst_rho:e} of {dr:e}"
    );
}
