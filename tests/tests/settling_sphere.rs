//! Settling sphere (Joubert 2020 §4.2, scenes/settling-sphere.toml, with the scene's
//! gradient correction and particle shifting), coarse: the sphere accelerates, reaches a
//! plateau (velocity change below 3 % over the last fifth of its fall), lands on the
//! floor and comes to rest there through DEM contact; no NaN.
//! The plateau velocity is printed next to the terminal velocity of the drag
//! correlation of Joubert eqs. (37)–(38).
//!
//! "Its fall" ends where the floor starts to slow it: two diameters above the floor
//! (wall effects reach about that far at this Reynolds number).
//!
//! CI size (lavapipe runs ≈ 1e7 pair interactions/s): δ = 1 mm (r = 1.25 δ), support
//! 2.4 δ (Joubert's Table 5 setting), and the box cut to 30 mm high with the sphere
//! released at 20 mm, so that the run takes minutes. The full scene (50 mm box, release
//! at 40 mm, δ = 0.625 mm) is `couplet run scenes/settling-sphere.toml`.

use couplet_tests::{couplet_run, joubert_terminal_velocity, read_recording, scene, track};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

#[test]
fn sphere_accelerates_plateaus_lands_and_rests() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_run(
        CLI,
        &scene("settling-sphere"),
        out.path(),
        &[
            "--spacing", "1e-3",
            "--set", "fluid.support=2.4",
            "--set", "domain.max=[0.015, 0.03, 0.015]",
            "--set", "fluid.blocks.0.max=[0.015, 0.03, 0.015]",
            "--set", "bodies.0.position=[0.0075, 0.02, 0.0075]",
            "--set", "time.end=0.6",
        ],
    );
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
    // The change over the last fifth: mean velocity over its first 20 % against its last
    // 20 % (single windows carry the SPH pressure noise of a few-marker sphere, ±5 %).
    let fifth: Vec<f64> = s.iter().filter(|b| b.time >= 0.8 * t_end && b.time <= t_end).map(|b| -b.velocity[1]).collect();
    let k = (fifth.len() / 5).max(1);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (v_start, v_end, plateau) = (mean(&fifth[..k]), mean(&fifth[fifth.len() - k..]), mean(&fifth));
    let change = (v_end - v_start).abs() / plateau;
    let correlation = joubert_terminal_velocity(r, 1250.0, 1000.0, 1e-5, 9.81);
    eprintln!(
        "settling sphere: plateau {plateau:.4} m/s, change {:.2} % over the last fifth of the fall (t ≤ {t_end:.3} s); \
         Joubert eqs. (37)–(38): {correlation:.4} m/s",
        100.0 * change
    );
    // Measured 1.3 % (2026-11-22). With `effects.particle_shifting = 0` the wake void
    // (see the scene file) let the sphere gain 3.4 % over the same stretch.
    assert!(change < 0.03, "no plateau: {v_start} → {v_end} m/s");
    // Lands and rests on the floor through DEM contact.
    let last = s.last().unwrap();
    assert!((last.position[1] - r).abs() < 0.1 * r, "final height {} vs radius {r}", last.position[1]);
    // At rest on the floor: no vertical motion, and at most a slow roll. The fluid keeps
    // recirculating after the impact and can roll the sphere along the floor at a few
    // percent of its fall speed (1–4 mm/s measured 0.05–0.25 s after landing; the GPU's
    // sort order within a cell is not fixed, so runs differ in round-off).
    // The roll is judged on its mean over the last 0.1 s, which the recirculation's
    // window-to-window jitter does not reach.
    let vertical = last.velocity[1].abs();
    let tail: Vec<f64> = s
        .iter()
        .filter(|b| b.time >= last.time - 0.1)
        .map(|b| b.velocity.iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect();
    let speed = mean(&tail);
    assert!(vertical < 1e-3, "still moving vertically at {vertical} m/s");
    assert!(speed < 0.05 * plateau, "still moving at {speed} m/s over the last 0.1 s (plateau {plateau} m/s)");
}
