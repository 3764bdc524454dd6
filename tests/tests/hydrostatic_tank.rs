//! Hydrostatic tank (scenes/hydrostatic-tank.toml), run end to end through `couplet
//! run`: after settling, the pressure along the depth matches ρ g h within 2 % of the
//! bottom pressure away from the walls and the free surface, and the fluid mass
//! (particle count × constant particle mass) is conserved exactly.
//!
//! CI runs it at δ = 0.02 m with the settings of the in-process test
//! (fluid-server/tests/hydrostatic.rs: support 2 δ, c_s = 17.5 m/s, α = 0.2, ν = 0) to
//! t = 0.3 s, and compares each particle's pressure averaged over the snapshots of the
//! last 0.1 s, taken every 0.01 s: the standard scheme leaves a weakly damped acoustic
//! mode of period 4H/c ≈ 0.07 s that the average removes. Measured 2026-11-22: 1.6 %.
//! With support 2.4 δ the same run gave 8 % near the floor (the lattice rearranges
//! there); that is for issue 3's corrected scheme to settle. `couplet run
//! scenes/hydrostatic-tank.toml` is the full δ = 0.01 m case to 1 s.

use couplet_tests::{couplet_run, read_recording, scene};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn pressure_matches_rho_g_h_and_mass_is_conserved() {
    let out = tempfile::tempdir().unwrap();
    let spacing = 0.02;
    let o = couplet_run(
        CLI,
        &scene("hydrostatic-tank"),
        out.path(),
        &[
            "--spacing", "0.02",
            "--set", "fluid.support=2.0",
            "--set", "fluid.sound_speed=17.5",
            "--set", "effects.artificial_viscosity=0.2",
            "--set", "fluid.kinematic_viscosity=0.0",
            "--set", "time.end=0.3",
            "--set", "time.output_interval=0.01",
        ],
    );
    assert!(o.status.success());
    let rec = read_recording(&out.path().join("run.mcap")).unwrap();
    assert!(rec.has_summary);
    let n0 = rec.snapshots[0].1.len();
    // 0.2 × 0.3 × 0.2 m of fluid on a 0.02 m lattice.
    assert_eq!(n0, 10 * 15 * 10);
    for (t, s) in &rec.snapshots {
        assert_eq!(s.len(), n0, "particle count changed at t = {t}");
        assert!(s.iter().all(|p| p.iter().all(|v| v.is_finite())), "non-finite value at t = {t}");
    }
    let (t, _) = rec.snapshots.last().unwrap();
    assert!(*t > 0.299, "last snapshot at {t}");
    // Snapshots list fluid particles in id order: average each over the last 0.1 s.
    let tail: Vec<_> = rec.snapshots.iter().filter(|(s, _)| *s > t - 0.1 + 1e-6).cloned().collect();
    assert!(tail.len() >= 10, "only {} snapshots in the last 0.1 s", tail.len());
    let last: Vec<[f32; 8]> = (0..n0)
        .map(|i| {
            let mut a = [0f32; 8];
            for (_, s) in &tail {
                for k in 0..8 {
                    a[k] += s[i][k] / tail.len() as f32;
                }
            }
            a
        })
        .collect();
    let last = &last;
    let (rho, g, support) = (1000.0, 9.81, 2.0 * spacing);
    // Free surface: the mean height of the top row plus half a spacing.
    let top = last.iter().map(|p| p[1]).fold(f32::MIN, f32::max) as f64;
    let row: Vec<f64> = last.iter().map(|p| p[1] as f64).filter(|y| *y > top - 0.5 * spacing).collect();
    let surface = row.iter().sum::<f64>() / row.len() as f64 + 0.5 * spacing;
    let bottom_p = rho * g * surface;
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for p in last {
        let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
        let inside = x > support && x < 0.2 - support && z > support && z < 0.2 - support;
        if inside && y > support && y < surface - support {
            let err = (p[3] as f64 - rho * g * (surface - y)).abs() / bottom_p;
            worst = worst.max(err);
            n += 1;
        }
    }
    eprintln!("hydrostatic: {n} interior particles, worst |p − ρ g h| / p_bottom = {:.3} %", worst * 100.0);
    assert!(n > 20, "too few interior particles ({n})");
    assert!(worst < 0.02, "worst error {:.3} % of the bottom pressure", worst * 100.0);
}
