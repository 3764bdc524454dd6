//! The grain-sampling kernel of unresolved coupling (`unresolved_coupling.rs`): WGSL
//! against its CPU twin on a jittered particle set with walls, and the exactness of the
//! Shepard interpolation on a constant field (Robinson eq. 8).

mod common;

use common::{max_err, random_set, scene};
use couplet_fluid::drag::DragLaw;
use couplet_fluid::gpu::{Gpu, shared_test_gpu};
use couplet_fluid::unresolved_coupling::{
    Grain, GrainBuffers, GrainSample, kernel, sample_grains_cpu,
};
use couplet_fluid::{FluidSolver, Kind, Op, ParticleSet, SphConstants};
use couplet_protocol::Scene;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Runs the sort and the rates on `set`, then `sample_grains` on `grains`; returns the
/// GPU samples, the CPU twin's, and the set as the GPU holds it.
fn sample(
    gpu: &Gpu,
    s: &Scene,
    set: ParticleSet,
    law: DragLaw,
    grains: &[Grain],
) -> (Vec<GrainSample>, Vec<GrainSample>) {
    let c = SphConstants::from_scene(s).unwrap();
    let mut solver = FluidSolver::from_particles(gpu, s, set).unwrap();
    solver
        .run_ops(
            gpu,
            &[Op::Sort, Op::BoundaryPressure, Op::FluidRates],
            1e-4,
            1.0,
        )
        .unwrap();
    let data = solver.data();
    let k = kernel(gpu, &c, law, data.grid.bind_group_layout());
    let buffers = GrainBuffers::new(gpu, grains);
    let bound = k
        .bind(
            gpu,
            |g, b| match g {
                0 => match b {
                    0 => Some(&data.pos),
                    1 => Some(&data.vel),
                    2 => Some(&data.rho),
                    4 => Some(&data.id),
                    6 => Some(&data.dvel),
                    _ => None,
                },
                2 => buffers.binding(b),
                3 => Some(&data.params),
                _ => None,
            },
            Some(data.grid.bind_group()),
        )
        .expect("every binding");
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        bound.dispatch(&mut pass, buffers.count);
    }
    gpu.queue.submit([encoder.finish()]);
    let got = buffers.read(gpu).unwrap();
    let set = data.read(gpu).unwrap();
    let (_, dvel) = data.read_rates(gpu).unwrap();
    let want = sample_grains_cpu(&c, law, &set, &dvel, grains);
    (got, want)
}

/// Grains at random points among the fluid particles (relative to the solver origin),
/// at least a support radius inside their bounding box.
fn grains_inside(
    set: &ParticleSet,
    origin: [f64; 3],
    margin: f64,
    n: usize,
    seed: u64,
) -> Vec<Grain> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let fluid: Vec<[f64; 3]> = (0..set.len())
        .filter(|i| set.kinds.kind(set.id[*i]) == Kind::Fluid)
        .map(|i| set.pos[i])
        .collect();
    let lo: [f64; 3] =
        std::array::from_fn(|k| fluid.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
    let hi: [f64; 3] =
        std::array::from_fn(|k| fluid.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
    (0..n)
        .map(|_| Grain {
            position: std::array::from_fn(|k| {
                rng.random_range(lo[k] + margin..hi[k] - margin) - origin[k]
            }),
            velocity: std::array::from_fn(|_| rng.random_range(-0.3..0.3)),
            volume: 5e-7,
            diameter: 1e-2,
            porosity: rng.random_range(0.5..1.0),
        })
        .collect()
}

/// Parity on 2744 jittered particles (30 % walls, random velocities, rates from the
/// real `fluid_rates` pass) and 60 grains, for every drag law: u_f, V ρθ̄ and the drag
/// each within 1e-4 of their largest magnitude (f32 sums of O(100) terms, as the pair
/// kernels' parity bound).
#[test]
fn sample_grains_matches_cpu_twin() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = scene("kernel = \"wendland-c2\"", "");
    let c = SphConstants::from_scene(&s).unwrap();
    let origin = [0.1; 3]; // the domain centre: the solver's origin
    for (k, law) in DragLaw::ALL.into_iter().enumerate() {
        let set = random_set(&c, 14, 0.3, 0.2, 0.5, 10 + k as u64);
        let grains = grains_inside(&set, origin, c.support_radius(), 60, k as u64);
        let (got, want) = sample(&gpu, &s, set, law, &grains);
        for (name, f) in [
            (
                "u_f",
                (|s: &GrainSample| s.fluid_velocity) as fn(&GrainSample) -> [f64; 3],
            ),
            ("resolved", |s| s.resolved),
            ("drag", |s| s.drag),
        ] {
            let (e, m) = max_err(got.iter().zip(&want).flat_map(|(g, w)| {
                let (a, b) = (f(g), f(w));
                (0..3).map(move |i| (a[i], b[i]))
            }));
            println!("{law:?} {name}: max |Δ| = {e:e} of {m:e}");
            assert!(
                m > 0.0 && e <= 1e-4 * m,
                "{law:?} {name}: max |Δ| {e:e} of {m:e}"
            );
        }
        let (e, _) = max_err(got.iter().zip(&want).map(|(g, w)| (g.shepard, w.shepard)));
        assert!(e < 1e-4, "{law:?}: Shepard sums differ by {e}");
    }
}

/// Robinson eq. (8) interpolates a constant exactly: with every fluid particle at
/// U = (0.3, −0.2, 0.1) m/s (jittered lattice, no walls), u_f = U at every grain to
/// f32 round-off (rel 1e-6), and the Stokes drag is 3π μ d ε (U − v) (Robinson eq. 28)
/// to rel 1e-5.
#[test]
fn shepard_interpolation_of_a_constant_field_is_exact() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = scene("kernel = \"wendland-c2\"", "");
    let c = SphConstants::from_scene(&s).unwrap();
    let u = [0.3, -0.2, 0.1];
    let mut set = random_set(&c, 14, 0.0, 0.2, 0.0, 5);
    set.vel.iter_mut().for_each(|v| *v = u);
    let grains = grains_inside(&set, [0.1; 3], c.support_radius(), 40, 9);
    let (got, _) = sample(&gpu, &s, set, DragLaw::Stokes, &grains);
    let mu = c.rho0 * c.nu;
    for (g, x) in grains.iter().zip(&got) {
        for k in 0..3 {
            assert!(
                (x.fluid_velocity[k] - u[k]).abs() < 1e-6 * 0.3,
                "u_f {:?}",
                x.fluid_velocity
            );
            let stokes =
                3.0 * std::f64::consts::PI * mu * g.diameter * g.porosity * (u[k] - g.velocity[k]);
            assert!(
                (x.drag[k] - stokes).abs() < 1e-5 * stokes.abs().max(1e-3 * mu),
                "drag {:?} vs {stokes}",
                x.drag
            );
        }
        // Inside the fluid (so the check above is not vacuous): a jittered lattice's
        // kernel sum Σ V_b W is near 1 (1.11 here at the scene's support).
        assert!(
            x.shepard > 0.8,
            "Shepard sum {}: the grain is not in the fluid",
            x.shepard
        );
    }
}
