//! Shared helpers of the fluid-server tests: scenes from TOML text, seeded particle sets.
#![allow(dead_code)]

use couplet_fluid::gpu::{Gpu, shared_test_gpu};
use couplet_fluid::neighbour_grid::{TEAM_LANES_CPU, TEAM_LANES_GPU};
use couplet_fluid::{ParticleKinds, ParticleSet, SphConstants};
use couplet_protocol::{BodyState, CouplingPoint, Scene};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// A scene with a fluid block; `extra` is appended to the TOML (effects, bodies…).
pub fn scene(fluid: &str, extra: &str) -> Scene {
    let text = format!(
        r#"
[meta]
name = "test"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.2]
[fluid]
density = 1000.0
kinematic_viscosity = 1e-3
sound_speed = 20.0
spacing = 0.01
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, 0.2, 0.2] }}]
{fluid}
{extra}
"#
    );
    match Scene::parse(&text, Path::new("test.toml")) {
        Ok(s) => s,
        Err(e) => panic!("test scene: {e}\n{text}"),
    }
}

/// A seeded set: a lattice of spacing δ over `n_side³` points inside the domain, the
/// first `n_fluid` fluid, the rest wall, each position perturbed by up to `jitter`·δ,
/// random velocities (|u| ≲ u_scale) and densities ρ0 (1 ± 1 %), pressures from the EOS
/// (walls: random around the fluid's).
pub fn random_set(
    c: &SphConstants,
    n_side: usize,
    wall_fraction: f64,
    jitter: f64,
    u_scale: f64,
    seed: u64,
) -> ParticleSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = c.spacing;
    let n = n_side * n_side * n_side;
    let mut idx: Vec<usize> = (0..n).collect();
    // Walls: a random subset (its ids come after the fluid's).
    let n_wall = (n as f64 * wall_fraction) as usize;
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        idx.swap(i, j);
    }
    let mut set = ParticleSet::default();
    for &k in &idx {
        let (x, y, z) = (k % n_side, (k / n_side) % n_side, k / (n_side * n_side));
        let mut jit = || (rng.random::<f64>() - 0.5) * 2.0 * jitter * d;
        let p = [
            0.02 + (x as f64 + 0.5) * d + jit(),
            0.02 + (y as f64 + 0.5) * d + jit(),
            0.02 + (z as f64 + 0.5) * d + jit(),
        ];
        set.pos.push(p);
    }
    let n_fluid = n - n_wall;
    for i in 0..n {
        let u = if i < n_fluid {
            [0, 1, 2].map(|_| (rng.random::<f64>() - 0.5) * 2.0 * u_scale)
        } else {
            [0.0; 3]
        };
        set.vel.push(u);
        let rho = c.rho0 * (1.0 + 0.02 * (rng.random::<f64>() - 0.5));
        set.rho.push(rho);
        set.mass.push(c.mass);
        set.press.push(c.pressure(rho));
        set.id.push(i as u32);
    }
    set.kinds = ParticleKinds {
        n_fluid,
        n_wall,
        n_markers: 0,
    };
    set
}

/// A fluid-only cubic lattice of `n³` particles at spacing `s` from `origin` (cell
/// centres), at rest, each of mass `m`, density `rho` and pressure 0.
#[allow(dead_code)] // not every test binary that includes `common` builds lattices
pub fn fluid_lattice(n: usize, s: f64, origin: f64, m: f64, rho: f64) -> ParticleSet {
    let mut set = ParticleSet::default();
    for k in 0..n * n * n {
        set.pos
            .push([k % n, (k / n) % n, k / (n * n)].map(|x| origin + (x as f64 + 0.5) * s));
        set.vel.push([0.0; 3]);
        set.rho.push(rho);
        set.mass.push(m);
        set.press.push(0.0);
        set.id.push(k as u32);
    }
    set.kinds = ParticleKinds {
        n_fluid: n * n * n,
        n_wall: 0,
        n_markers: 0,
    };
    set
}

/// Fluid only, one particle at each of `points` with the lattice mass of `c`, velocity
/// `u`, density `rho(x)` and the equation of state's pressure of it.
#[allow(dead_code)] // not every test binary that includes `common` builds fluid sets
pub fn fluid_at(
    c: &SphConstants,
    points: &[[f64; 3]],
    u: [f64; 3],
    rho: impl Fn([f64; 3]) -> f64,
) -> ParticleSet {
    let mut set = ParticleSet::default();
    for (k, &p) in points.iter().enumerate() {
        let r = rho(p);
        set.pos.push(p);
        set.vel.push(u);
        set.rho.push(r);
        set.mass.push(c.mass);
        set.press.push(c.pressure(r));
        set.id.push(k as u32);
    }
    set.kinds = ParticleKinds {
        n_fluid: points.len(),
        n_wall: 0,
        n_markers: 0,
    };
    set
}

/// Largest |a − b| and largest |b| over pairs of scalars.
pub fn max_err(pairs: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    pairs.fold((0.0, 0.0), |(e, m), (a, b)| {
        (f64::max(e, (a - b).abs()), f64::max(m, b.abs()))
    })
}

/// The particles before and after one gradient pass and shift (Joubert eqs. 17–19)
/// with substep `dt`: what the shift twins compare.
#[allow(dead_code)] // not every test binary that includes `common` shifts
pub fn around_a_shift(
    gpu: &Gpu,
    solver: &mut couplet_fluid::FluidSolver,
    dt: f64,
) -> (ParticleSet, ParticleSet) {
    let before = solver.data().read(gpu).unwrap();
    (solver.run_ops(
        gpu,
        &[couplet_fluid::Op::Gradients, couplet_fluid::Op::Shift],
        dt,
        1.0,
    ))
    .unwrap();
    (before, solver.data().read(gpu).unwrap())
}

/// Largest fluid speed of `set`: ‖u‖max of Joubert eq. (17), as the gradient pass finds it.
#[allow(dead_code)] // not every test binary that includes `common` shifts
pub fn largest_fluid_speed(set: &ParticleSet) -> f64 {
    (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == couplet_fluid::Kind::Fluid)
        .map(|i| set.vel[i].iter().map(|x| x * x).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

/// Body 0 at rest at `position`, unrotated, dynamic (`motion` 2), of unit mass and
/// volume: the state a test hands the fluid beside its markers.
pub fn body_at_rest(position: [f64; 3]) -> BodyState {
    BodyState {
        position,
        orientation: [0.0, 0.0, 0.0, 1.0],
        motion: 2,
        mass: 1.0,
        volume: 1.0,
        ..Default::default()
    }
}

/// `n` markers of body 0 on a sphere (Fibonacci lattice): outward normals, equal areas
/// summing to 4πr², at rest.
#[allow(dead_code)] // not every test binary that includes `common` has bodies
pub fn sphere_markers(centre: [f64; 3], radius: f64, n: usize) -> Vec<CouplingPoint> {
    let area = 4.0 * std::f64::consts::PI * radius * radius / n as f64;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let rad = (1.0 - y * y).sqrt();
            let th = golden * k as f64;
            let nrm = [rad * th.cos(), y, rad * th.sin()];
            CouplingPoint {
                position: std::array::from_fn(|a| (centre[a] + radius * nrm[a]) as f32),
                measure: area as f32,
                normal: nrm.map(|x| x as f32),
                ..Default::default()
            }
        })
        .collect()
}

/// Runs `check` on the one test device once at each lane count of the team passes
/// (`neighbour_grid::TEAM_LANES_CPU`, which lavapipe runs, and `TEAM_LANES_GPU`, which a
/// GPU runs), so that a parity test covers both forms whatever adapter it runs on.
pub fn at_each_team_width(check: impl Fn(&Gpu)) {
    let mut gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    for lanes in [TEAM_LANES_CPU, TEAM_LANES_GPU] {
        gpu.team_lanes = lanes;
        println!("team lanes {lanes}:");
        check(&gpu);
    }
}
