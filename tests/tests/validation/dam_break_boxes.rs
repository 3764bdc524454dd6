//! Dam break with boxes (scenes/dam-break-boxes.toml) run end to end: it runs to the
//! end with every box moved by the flow, no box inside another and none outside the
//! domain. CI runs δ = 0.02 m, support 2.4 δ, to t = 0.35 s (the surge reaches the boxes
//! at ≈ 0.1 s and has carried them ≈ 0.15 m by 0.25 s); the shipped scene is δ = 0.01 m
//! to 0.8 s. At δ = 0.02 m the boxes are 1.5 δ wide, and once the surge has pressed them
//! against the far wall (t ≈ 0.5 s) a fluid particle squeezed in the gap reaches c_s and
//! the blow-up check stops the run (measured 2026-11-22); hence the shorter CI end.

use couplet_tests::{couplet_run, read_recording, scene, track};
use parry3d::math::{Pose, Rotation, Vector};
use parry3d::shape::Cuboid;

use crate::CLI;
/// Half extent of the boxes in the scene, m.
const H: f64 = 0.015;
/// Interpenetration rapier may leave between resting contacts (its allowed linear
/// error is 1 mm at this length unit); a box "inside another" is far beyond it.
const PENETRATION_TOLERANCE: f64 = 2e-3;

fn pose(p: [f64; 3], q: [f64; 4]) -> Pose {
    let q = Rotation::from_xyzw(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32).normalize();
    Pose::from_parts(Vector::new(p[0] as f32, p[1] as f32, p[2] as f32), q)
}

/// The eight corners of a cube of half extent `H` in its own frame.
fn corners() -> impl Iterator<Item = Vector> {
    (0..8).map(|i| {
        let s = |bit: i32| if i & bit == 0 { -H as f32 } else { H as f32 };
        Vector::new(s(1), s(2), s(4))
    })
}

#[test]
fn boxes_are_pushed_and_stay_apart_and_inside() {
    let out = tempfile::tempdir().unwrap();
    let o = couplet_run(
        CLI,
        &scene("dam-break-boxes"),
        out.path(),
        &[
            "--spacing",
            "0.02",
            "--set",
            "fluid.support=2.4",
            "--set",
            "time.end=0.35",
        ],
    );
    assert!(o.status.success());
    let rec = read_recording(&out.path().join("run.mcap")).unwrap();
    let tracks: Vec<_> = (0..3).map(|b| track(&rec, b)).collect();
    let end = tracks[0].last().unwrap().time;
    assert!(end > 0.34, "ended at {end}");
    let cube = Cuboid::new(Vector::splat(H as f32));
    for (b, t) in tracks.iter().enumerate() {
        let (first, last) = (t.first().unwrap(), t.last().unwrap());
        let moved = (0..3)
            .map(|k| (last.position[k] - first.position[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        eprintln!("box {b}: moved {moved:.3} m, final {:?}", last.position);
        assert!(moved > 0.02, "box {b} moved only {moved} m");
    }
    for i in 0..t_len(&tracks) {
        for a in 0..3 {
            let sa = tracks[a][i];
            let pa = pose(sa.position, sa.orientation);
            // Inside the domain: every corner, within the tolerance.
            for c in corners() {
                let w = pa * c;
                let (lo, hi) = ([0.0, 0.0, 0.0], [0.6, 0.4, 0.1]);
                for k in 0..3 {
                    assert!(
                        (w[k] as f64) > lo[k] - PENETRATION_TOLERANCE
                            && (w[k] as f64) < hi[k] + PENETRATION_TOLERANCE,
                        "box {a} corner {w:?} outside the domain at t = {}",
                        sa.time
                    );
                }
            }
            for b in a + 1..3 {
                let sb = tracks[b][i];
                let d =
                    parry3d::query::distance(&pa, &cube, &pose(sb.position, sb.orientation), &cube)
                        .unwrap();
                let depth = if d.distance > 0.0 {
                    0.0
                } else {
                    parry3d::query::contact(
                        &pa,
                        &cube,
                        &pose(sb.position, sb.orientation),
                        &cube,
                        0.0,
                    )
                    .unwrap()
                    .map_or(0.0, |c| -c.dist)
                };
                assert!(
                    (depth as f64) < PENETRATION_TOLERANCE,
                    "boxes {a} and {b} overlap by {depth} m at t = {}",
                    sa.time
                );
            }
        }
    }
}

fn t_len(t: &[Vec<couplet_tests::BodySample>]) -> usize {
    t.iter().map(|v| v.len()).min().unwrap_or(0)
}
