//! Hydrostatic tank, in process: the standard WCSPH scheme holds a column of water at
//! rest with the hydrostatic pressure.

mod common;

use couplet_fluid::FluidSolver;
use couplet_fluid::gpu::shared_test_gpu;
use couplet_protocol::Scene;
use std::path::Path;
use std::time::Instant;

/// Fluid 0.2 (x) × 0.3 (y) × 0.2 (z) m at δ = 0.02 m in a no-slip tank (Wendland C2,
/// support 2δ so that the test stays under a minute on lavapipe, c_s = 17.5 m/s ≈
/// 10 √(gH)), initialised hydrostatically, damped by Monaghan artificial viscosity (no physical viscosity:
/// ν ≈ 0 for water at this resolution) α = 0.2, settled SETTLE_S seconds.
fn tank(settle: f64, extra_effects: &str) -> Scene {
    let text = format!(
        r#"
[meta]
name = "hydrostatic-tank"
source = "analytic: p = ρ g (H − y)"
[time]
end = {settle}
output_interval = 0.1
cfl = 0.2
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.32, 0.2]
walls = "no-slip"
[fluid]
density = 1000.0
kinematic_viscosity = 0.0
sound_speed = 17.5
spacing = 0.02
kernel = "wendland-c2"
support = 2.0
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, 0.3, 0.2] }}]
[effects]
viscosity = "none"
artificial_viscosity = 0.2
{extra_effects}
"#
    );
    Scene::parse(&text, Path::new("tank.toml")).unwrap()
}

/// Largest |p − ρ0 g (H − y)| / (ρ0 g H) over particles farther than `r` from the walls
/// and the surface, their number, and the largest speed of all.
fn worst_error(snap: &[couplet_protocol::ParticleRecord], r: f64) -> (f64, usize, f64) {
    let (rho0, g, h_surf) = (1000.0, 9.81, 0.3);
    let p_bottom = rho0 * g * h_surf;
    let mut worst: f64 = 0.0;
    let mut n = 0;
    let mut max_speed: f64 = 0.0;
    for p in snap {
        let [x, y, z] = p.position.map(f64::from);
        let speed = p
            .velocity
            .iter()
            .map(|v| f64::from(*v).powi(2))
            .sum::<f64>()
            .sqrt();
        max_speed = max_speed.max(speed);
        if x > r && x < 0.2 - r && z > r && z < 0.2 - r && y > r && y < h_surf - r {
            let want = rho0 * g * (h_surf - y);
            worst = worst.max((f64::from(p.pressure) - want).abs() / p_bottom);
            n += 1;
        }
    }
    (worst, n, max_speed)
}

const SETTLE_S: f64 = 0.3;
const AVERAGE_S: f64 = 0.1;

/// After settling, the pressure of particles farther than the support from the walls
/// and the free surface, averaged over the last AVERAGE_S (more than the acoustic period
/// of the column), matches ρ0 g (H − y) within 2 % of the bottom pressure ρ0 g H
/// (reference: hydrostatics; the standard scheme's wall error is confined to the
/// excluded layer); the fluid count and particle mass are constant, so the fluid mass is
/// conserved exactly.
#[test]
fn hydrostatic_tank_settles_to_rho_g_h() {
    let worst = settle("standard", "");
    assert!(worst < 0.02, "worst |p − ρ g h| / (ρ g H) = {worst}");
}

/// The same tank with δ-SPH density diffusion (Antuono et al. 2010, δ = 0.1, renormalised
/// density gradient): within 1 % of ρ0 g H (issue 3's bound; measured 0.71 % on
/// 2026-11-22 against 1.6 % without it). Reference: hydrostatics.
#[test]
fn hydrostatic_tank_with_density_diffusion_settles_within_one_percent() {
    let worst = settle("δ-SPH", "density_diffusion = 0.1");
    assert!(worst < 0.01, "worst |p − ρ g h| / (ρ g H) = {worst}");
}

/// The same tank with δ-SPH in Fourtakas et al. 2019's form (δ = 0.1, the hydrostatic
/// density difference removed instead of the renormalised gradients): within 1 % of
/// ρ0 g H, the bound of Antuono's form above (measured 0.880 % on 2026-12-04, Antuono's
/// 0.782 % the same day, 7 s each). Reference: hydrostatics.
#[test]
fn hydrostatic_tank_with_fourtakas_diffusion_settles_within_one_percent() {
    let worst = settle(
        "δ-SPH (Fourtakas)",
        "density_diffusion = 0.1\ndensity_diffusion_form = \"fourtakas\"",
    );
    assert!(worst < 0.01, "worst |p − ρ g h| / (ρ g H) = {worst}");
}

/// Settles the tank with `extra_effects` (TOML lines of `[effects]`), checks that the
/// fluid mass is conserved exactly, and returns the worst time-averaged interior pressure
/// error as a fraction of ρ0 g H.
fn settle(label: &str, extra_effects: &str) -> f64 {
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let scene = tank(SETTLE_S, extra_effects);
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let counts = solver.counts();
    assert_eq!(counts.fluid, 10 * 15 * 10);
    let mass0 = f64::from(counts.fluid) * solver.constants().mass;
    let t0 = Instant::now();
    let window = 0.01;
    let mut substeps = 0;
    // Time average of each particle's pressure and position over the last AVERAGE_S
    // (longer than the column's acoustic period 4H/c = 0.069 s): the standard scheme
    // leaves a weakly damped acoustic mode that the average removes.
    let mut sum: Vec<[f64; 4]> = vec![[0.0; 4]; counts.fluid as usize];
    let mut samples = 0;
    while solver.time() < SETTLE_S - 1e-9 {
        substeps += solver.advance(&gpu, window, None).unwrap();
        if solver.time() > SETTLE_S - AVERAGE_S - 1e-9 {
            let snap = solver.snapshot(&gpu).unwrap();
            for (acc, p) in sum.iter_mut().zip(&snap) {
                for (a, x) in acc.iter_mut().zip(p.position) {
                    *a += f64::from(x);
                }
                acc[3] += f64::from(p.pressure);
            }
            samples += 1;
            if std::env::var_os("HYDROSTATIC_TRACE").is_some() {
                println!(
                    "t = {:.3} s: worst {:.3} %",
                    solver.time(),
                    100.0 * worst_error(&snap, solver.constants().support_radius()).0
                );
            }
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let mean: Vec<couplet_protocol::ParticleRecord> = sum
        .iter()
        .map(|a| couplet_protocol::ParticleRecord {
            position: [0, 1, 2].map(|k| (a[k] / f64::from(samples)) as f32),
            pressure: (a[3] / f64::from(samples)) as f32,
            ..Default::default()
        })
        .collect();
    let neighbours = solver.neighbour_stats(&gpu).unwrap();
    let snap = solver.snapshot(&gpu).unwrap();
    assert_eq!(snap.len(), counts.fluid as usize);
    let mass1 = snap.len() as f64 * solver.constants().mass;
    assert_eq!(mass0, mass1);

    let (worst, n, _) = worst_error(&mean, solver.constants().support_radius());
    let (worst_last, _, max_speed) = worst_error(&snap, solver.constants().support_radius());
    println!(
        "hydrostatic ({label}): {substeps} steps ({} in all) in {wall:.1} s, {neighbours:.1} neighbours/fluid particle, \
         {n} interior particles, worst |p̄ − ρgh| = {:.3} % of ρgH over the last {AVERAGE_S} s \
         ({:.3} % in the last snapshot), max speed {max_speed:.2e} m/s",
        solver.steps(),
        100.0 * worst,
        100.0 * worst_last
    );
    assert!(n > 0);
    worst
}

/// Regression (corrected scheme at a free surface): with Joubert's gradient correction
/// the open tank blew up at t = 0.024 s: a surface particle at a top corner reached
/// ρ = 455 kg/m³ (KE growing ×1000 every 5 ms from the first step; the difference-form
/// pressure term has nothing above a surface particle to hold it). With the free-surface
/// switch (on by default in an open domain) the two forms meet only where the support is
/// complete, and the tank settles: within 1 % of ρ0 g H (issue 3's bound for the
/// corrected scheme; reference: hydrostatics). Without the switch it still blows up.
#[test]
fn open_tank_with_the_gradient_correction_settles_within_one_percent() {
    let worst = settle("corrected", "gradient_correction = true");
    assert!(worst < 0.01, "worst |p − ρ g h| / (ρ g H) = {worst}");
    let gpu = shared_test_gpu().expect("a Vulkan adapter (lavapipe)");
    let unswitched = tank(0.05, "gradient_correction = true\nfree_surface = false");
    let mut solver = FluidSolver::new(&gpu, &unswitched).unwrap();
    let blew_up = (0..50).any(|_| solver.advance(&gpu, 0.001, None).is_err());
    assert!(
        blew_up,
        "the open tank without the switch ran 0.05 s: the regression test no longer shows the switch is needed"
    );
}
