//! Hydrostatic tank (scenes/hydrostatic-tank.toml), run end to end through `couplet
//! run`: after settling, the pressure along the depth matches ρ g h within 2 % of the
//! bottom pressure away from the walls and the free surface, and the fluid mass
//! (particle count × constant particle mass) is conserved exactly.
//!
//! CI runs it at δ = 0.02 m, support 2.4 δ, to t = 0.5 s, and compares each particle's
//! pressure averaged over the last three snapshots (0.4–0.5 s: the residual acoustic
//! oscillation of the start averages out); `couplet run scenes/hydrostatic-tank.toml` is
//! the full δ = 0.01 m case to 1 s.

use couplet_tests::{couplet_run, read_recording, scene};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn pressure_matches_rho_g_h_and_mass_is_conserved() {
    let out = tempfile::tempdir().unwrap();
    let spacing = 0.02;
    let o = couplet_run(CLI, &scene("hydrostatic-tank"), out.path(), &["--spacing", "0.02", "--set", "fluid.support=2.4", "--set", "time.end=0.5", "--set", "time.output_interval=0.05"]);
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
    assert!(*t > 0.49, "last snapshot at {t}");
    // Snapshots list fluid particles in id order: average each over the last three.
    let tail = &rec.snapshots[rec.snapshots.len() - 3..];
    let last: Vec<[f32; 8]> = (0..n0)
        .map(|i| {
            let mut a = [0f32; 8];
            for (_, s) in tail {
                for k in 0..8 {
                    a[k] += s[i][k] / tail.len() as f32;
                }
            }
            a
        })
        .collect();
    let last = &last;
    let (rho, g, support) = (1000.0, 9.81, 2.4 * spacing);
    // Free surface: the top of the fluid particles plus half a spacing.
    let surface = last.iter().map(|p| p[1]).fold(f32::MIN, f32::max) as f64 + 0.5 * spacing;
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
