//! Robinson's variable smoothing length (eqs. 10–12, 19; `robinson_variable_h.rs`):
//! the (h, Ω) pass and the rates against their CPU twins, the grad-h factor and the
//! neighbour count on lattices where the answer is known, and the guard on h.

mod common;

use common::{fluid_lattice, max_err, random_set, scene};
use couplet_fluid::adami2012_boundary_pressure::boundary_pressure_cpu;
use couplet_fluid::fluid_rates::fluid_rates_cpu;
use couplet_fluid::gpu::shared_test_gpu;
use couplet_fluid::momentum::momentum_cpu;
use couplet_fluid::robinson_variable_h::{
    kernel_at, lattice_omega, omega_cpu, pair_neighbours, smoothing_cpu, smoothing_length_cpu,
};
use couplet_fluid::{FluidError, FluidSolver, Kind, Op, ParticleSet, SphConstants};

/// Relative parity bound for the pair kernels (f32 sums of O(100) terms), as in
/// `operators.rs`.
const PAIR_RTOL: f64 = 1e-4;

const VARIABLE_H: &str = "[effects]\nvariable_smoothing_length = true\nartificial_viscosity = 0.1";

/// Eq. (19) keeps the neighbours: particles of full mass m0 at the superficial density
/// ε ρ0 (a lattice stretched to spacing δ ε^(−1/3), the fluid among grains of porosity
/// ε) get h = h0 ε^(−1/3) and exactly the neighbour count of the unstretched lattice
/// (the stretch is a similarity). Ω_i of eq. (11) is 1 in the continuum limit
/// (∫(3W + r ∂W/∂r) dV = 3 − 3 = 0, integrating by parts) and on the lattice is
/// 1 − Σ_lattice (3W + r²F) δ³/3, the same at every stretch (Wendland C2, support 3.2δ,
/// which puts no lattice shell on the support's edge): −2.8210e-3, summed directly over
/// the lattice points within 3.2 spacings (an independent Python sum, see
/// ARCHITECTURE.md "Variable h"). A fixed h would leave the stretched particle about ε
/// of its neighbours (within the lattice's shell steps).
#[test]
fn eq19_keeps_the_neighbours_and_omega_is_one() {
    let s = scene("support = 3.2", VARIABLE_H);
    let c = SphConstants::from_scene(&s).unwrap();
    let n = 13;
    let centre = n * n * n / 2;
    let count = |set: &ParticleSet| pair_neighbours(&c, set, centre).count();
    let dense = fluid_lattice(n, c.spacing, 0.0, c.mass, c.rho0);
    assert!((smoothing_length_cpu(&c, &dense, centre) / c.kernel.h - 1.0).abs() < 1e-12);
    let n_dense = count(&dense);
    for eps in [0.8f64, 0.6, 0.4] {
        let stretch = eps.powf(-1.0 / 3.0);
        let loose = fluid_lattice(n, c.spacing * stretch, 0.0, c.mass, eps * c.rho0);
        let h = smoothing_length_cpu(&c, &loose, centre);
        assert!(
            (h / c.kernel.h - stretch).abs() < 1e-12,
            "ε = {eps}: h/h0 = {}",
            h / c.kernel.h
        );
        assert_eq!(count(&loose), n_dense, "ε = {eps}");
        let omega = omega_cpu(&c, &loose, centre);
        println!(
            "ε = {eps}: h/h0 = {:.4}, {} neighbours, Ω − 1 = {:e}",
            h / c.kernel.h,
            n_dense,
            omega - 1.0
        );
        assert!(
            (omega - 1.0 + 2.8210e-3).abs() < 1e-7,
            "ε = {eps}: Ω = {omega}"
        );
        assert!((lattice_omega(&c) - omega).abs() < 1e-9);
        // With one h the same particle keeps about ε of them.
        let fixed = loose
            .neighbours(centre, c.support_radius(), c.period)
            .count() as f64;
        // The lattice's shells make it 0.63, 0.55, 0.38 of them at ε = 0.8, 0.6, 0.4.
        assert!(
            (fixed / n_dense as f64 - eps).abs() < 0.2,
            "ε = {eps}: {fixed}"
        );
    }
    assert!((omega_cpu(&c, &dense, centre) - 1.0 + 2.8210e-3).abs() < 1e-7);
}

/// The (h, Ω) pass and the rates on a jittered set (30 % walls) where the fluid takes
/// three volumes: 0.7 δ³ (mass 0.7 m0 at ρ0), δ³ and 1.33 δ³ (full mass at 0.75 ρ0),
/// so that pairs mix smoothing lengths 0.89–1.10 h0. Standard and gradient-corrected
/// schemes, artificial and laminar viscosity: h, Ω within 1e-5 relative; the walls'
/// pressure (Adami's extrapolation at the largest h), dρ/dt and du/dt within 1e-4 of
/// their largest magnitude.
#[test]
fn variable_h_matches_cpu_twin() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    for (name, extra) in [
        ("standard", ""),
        ("corrected", "gradient_correction = true"),
    ] {
        let s = scene("", &format!("{VARIABLE_H}\n{extra}"));
        let c = SphConstants::from_scene(&s).unwrap();
        let mut set = random_set(&c, 14, 0.3, 0.2, 0.5, 11);
        for i in 0..set.kinds.n_fluid {
            match i % 3 {
                0 => set.mass[i] = 0.7 * c.mass,
                1 => {
                    set.rho[i] *= 0.75;
                    set.press[i] = c.pressure(set.rho[i] / 0.75);
                }
                _ => {}
            }
        }
        let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
        solver
            .run_ops(
                &gpu,
                // The boundary pass first: B_i reads the walls' V = m/ρ it writes.
                &[
                    Op::Sort,
                    Op::SmoothingLengths,
                    Op::BoundaryPressure,
                    Op::Gradients,
                    Op::FluidRates,
                ],
                1e-4,
                1.0,
            )
            .unwrap();
        let got = solver.data().read(&gpu).unwrap();
        let n = u64::from(solver.data().n_total);
        let buffer = solver.data().smoothing.as_ref().expect("the (h, Ω) buffer");
        let h_omega: Vec<[f32; 2]> = gpu.read_buffer(buffer, 0, n).unwrap();
        let want = smoothing_cpu(&c, &got);
        let fluid: Vec<usize> = (0..got.len())
            .filter(|&i| got.kinds.kind(got.id[i]) == Kind::Fluid)
            .collect();
        let (eh, mh) = max_err((0..got.len()).map(|i| (f64::from(h_omega[i][0]), want[i].0)));
        let (eo, _) = max_err((0..got.len()).map(|i| (f64::from(h_omega[i][1]), want[i].1)));
        let spread = fluid
            .iter()
            .map(|&i| want[i].0 / c.kernel.h)
            .fold((f64::MAX, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        println!(
            "{name}: h {eh:e} of {mh:e} (h/h0 in {:.3}–{:.3}), Ω {eo:e}",
            spread.0, spread.1
        );
        assert!(spread.0 < 0.9 && spread.1 > 1.09, "{spread:?}");
        assert!(eh <= 1e-5 * mh && eo <= 1e-5, "h {eh:e}, Ω {eo:e}");

        // Adami's walls extrapolate with the largest h's kernel (SphConstants::wall_kernel).
        let walls = boundary_pressure_cpu(&c, &got);
        let (ep, mp) =
            max_err((0..got.len()).filter_map(|i| walls[i].map(|w| (got.press[i], w.0))));
        println!("{name}: wall pressure {ep:e} of {mp:e}");
        assert!(
            mp > 0.0 && ep <= PAIR_RTOL * mp,
            "wall pressure {ep:e} of {mp:e}"
        );

        let (drho, dvel) = solver.data().read_rates(&gpu).unwrap();
        let rates = fluid_rates_cpu(&c, &got, 1e-4);
        let (ec, mc) = max_err(
            fluid
                .iter()
                .map(|&i| (drho[i], rates[i].map_or(0.0, |w| w.0))),
        );
        let g = c.gravity_fluid;
        let (em, mm) = max_err(fluid.iter().flat_map(|&i| {
            let w = rates[i].map_or([0.0; 3], |w| w.1);
            (0..3)
                .map(|k| (dvel[i][k] - g[k], w[k] - g[k]))
                .collect::<Vec<_>>()
        }));
        println!("{name}: continuity {ec:e} of {mc:e}; momentum {em:e} of {mm:e}");
        assert!(ec <= PAIR_RTOL * mc && em <= PAIR_RTOL * mm);
    }
}

/// The rates with variable h on a uniform lattice equal the fixed-h rates: every h is
/// h0 where V = δ³, and Ω only rescales the pressure and continuity terms by 1/Ω ≈ 1
/// (CPU twins). Ω moves away from 1 near the block's faces, where the continuity
/// density is not the kernel sum, and the p/Ω of eq. (12) then gains a spurious gradient;
/// so the comparison takes particles whose whole support is at least one support from
/// the faces (16³ block: the central 4³). There Ω is the lattice's, 1 − 2.52e-3 at
/// support 3δ (the same direct sum as above), and the pressure part is 1/Ω larger:
/// the difference is below 3e-3 of |du/dt|.
#[test]
fn uniform_lattice_rates_match_fixed_h() {
    let no_g = "[gravity]\non_fluid = false";
    let fixed = scene(
        "",
        &format!("[effects]\nartificial_viscosity = 0.1\n{no_g}"),
    );
    let variable = scene("", &format!("{VARIABLE_H}\n{no_g}"));
    let (cf, cv) = (
        SphConstants::from_scene(&fixed).unwrap(),
        SphConstants::from_scene(&variable).unwrap(),
    );
    let n = 16;
    let mut set = fluid_lattice(n, cf.spacing, 0.0, cf.mass, cf.rho0);
    for i in 0..set.len() {
        let x = set.pos[i];
        set.vel[i] = [0.3 * x[1] / 0.1, -0.2 * x[2] / 0.1, 0.1];
        set.press[i] = 200.0 * x[0] / 0.1;
    }
    let r = 2.0 * cf.support_radius();
    let hi = n as f64 * cf.spacing - r;
    let mut worst = 0.0f64;
    for i in 0..set.len() {
        if !set.pos[i].iter().all(|&x| x > r && x < hi) {
            continue;
        }
        assert!((kernel_at(&cv, &set, i).h / cv.kernel.h - 1.0).abs() < 1e-12);
        let (a, b) = (momentum_cpu(&cf, &set, i), momentum_cpu(&cv, &set, i));
        let scale = a.iter().map(|x| x.abs()).fold(0.0, f64::max);
        worst = worst.max(
            (0..3)
                .map(|k| (a[k] - b[k]).abs() / scale)
                .fold(0.0, f64::max),
        );
    }
    println!("interior: worst relative difference of du/dt {worst:e}");
    assert!(worst < 3e-3, "{worst:e}");
}

/// A fluid particle whose volume grows past (max_smoothing_ratio)³ δ³ (its h past the
/// largest the grid holds) stops the run at the window's end with an error naming the
/// smoothing length and the field to raise, not a silently truncated neighbour sum.
#[test]
fn smoothing_length_past_the_grid_is_an_error() {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let s = scene("max_smoothing_ratio = 1.2", VARIABLE_H);
    let c = SphConstants::from_scene(&s).unwrap();
    let mut set = random_set(&c, 10, 0.0, 0.0, 0.0, 3);
    // V = 2 δ³: h = 1.26 h0 > 1.2 h0, a density the blow-up check otherwise accepts.
    set.mass[7] = 2.0 * c.mass;
    let mut solver = FluidSolver::from_particles(&gpu, &s, set).unwrap();
    match solver.advance(&gpu, 1e-5, None) {
        Err(e @ FluidError::BlowUp { what, .. }) => {
            let text = e.to_string();
            println!("{text}");
            assert_eq!(what, "smoothing length");
            assert!(text.contains("fluid.max_smoothing_ratio"), "{text}");
        }
        other => panic!("expected a smoothing-length blow-up, got {other:?}"),
    }
}
