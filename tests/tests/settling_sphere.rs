//! Settling sphere (Joubert 2020 §4.2, scenes/settling-sphere.toml), coarse: the sphere
//! accelerates, reaches a plateau (velocity changes by less than 3 % over the last fifth
//! of its fall), lands on the floor and comes to rest there through DEM contact; no NaN.
//! The plateau velocity is printed next to the terminal velocity of the drag
//! correlation of Joubert eqs. (37)–(38).
//!
//! "Its fall" ends where the floor starts to slow it: two diameters above the floor
//! (wall effects reach about that far at this Reynolds number).

use couplet_tests::{couplet_run, joubert_terminal_velocity, read_recording, scene, track};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn sphere_accelerates_plateaus_lands_and_rests() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_run(CLI, &scene("settling-sphere"), out.path(), &["--spacing", "1e-3"]);
    assert!(o.status.success());
    let rec = read_recording(&out.path().join("run.mcap")).unwrap();
    let s = track(&rec, 0);
    assert!(s.len() > 100, "only {} states", s.len());
    for b in &s {
        assert!(b.position.iter().chain(&b.velocity).all(|v| v.is_finite()), "NaN at t = {}", b.time);
    }
    let (r, d) = (1.25e-3, 2.5e-3);
    let vy: Vec<f64> = s.iter().map(|b| b.velocity[1]).collect();
    // Accelerates: downward speed grows over the first 0.05 s.
    let early = s.iter().position(|b| b.time >= 0.05).unwrap();
    assert!(-vy[early] > 0.005, "v(0.05 s) = {}", vy[early]);
    // The fall: until the sphere is two diameters above the floor.
    let end = s.iter().position(|b| b.position[1] < r + 2.0 * d).expect("the sphere never got near the floor");
    let t_end = s[end].time;
    let fifth: Vec<f64> = s.iter().filter(|b| b.time >= 0.8 * t_end && b.time <= t_end).map(|b| -b.velocity[1]).collect();
    let (vmin, vmax) = fifth.iter().fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    let plateau = fifth.iter().sum::<f64>() / fifth.len() as f64;
    let correlation = joubert_terminal_velocity(r, 1250.0, 1000.0, 1e-5, 9.81);
    eprintln!(
        "settling sphere: plateau {plateau:.4} m/s (spread {:.2} % over the last fifth of the fall, t ≤ {t_end:.3} s); \
         Joubert eqs. (37)–(38): {correlation:.4} m/s",
        100.0 * (vmax - vmin) / plateau
    );
    assert!((vmax - vmin) / plateau < 0.03, "no plateau: {vmin} … {vmax}");
    // Lands and rests on the floor through DEM contact.
    let last = s.last().unwrap();
    assert!((last.position[1] - r).abs() < 0.1 * r, "final height {} vs radius {r}", last.position[1]);
    let speed = last.velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(speed < 1e-3, "still moving at {speed} m/s");
}
