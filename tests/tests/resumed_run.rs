//! A run in two sittings (`orchestrator/src/resume.rs`): `couplet run --checkpoint-every`
//! stopped part way, then `--resume` on the same folder, records what one sitting
//! records, bit for bit on one machine; and `--resume` refuses what it cannot continue.

use couplet_orchestrator::record::{Recording, read_recording};
use couplet_orchestrator::resume::read_chain;
use couplet_tests::{couplet_run, scene};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");
/// The small dam break with boxes (fluid and DEM), 207 windows to 30 ms.
const SCENE_ARGS: [&str; 4] = ["--spacing", "0.02", "--set", "time.end=0.03"];

fn run(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let args: Vec<&str> = SCENE_ARGS.iter().chain(extra).copied().collect();
    couplet_run(CLI, &scene("dam-break-boxes"), out, &args)
}

/// Every window's body states, loads and snapshots, as bits.
fn bits(r: &Recording) -> (Vec<u64>, Vec<u64>, Vec<u32>) {
    let bodies = (r.bodies.iter())
        .flat_map(|b| {
            [b.time]
                .into_iter()
                .chain(b.position)
                .chain(b.orientation)
                .chain(b.velocity)
        })
        .chain(
            r.loads
                .iter()
                .flat_map(|l| [l.time].into_iter().chain(l.force).chain(l.moment)),
        )
        .map(f64::to_bits)
        .collect();
    let times = r.snapshots.iter().map(|s| s.0.to_bits()).collect();
    let particles = (r.snapshots.iter())
        .flat_map(|s| s.1.iter().flatten().map(|x| x.to_bits()))
        .collect();
    (bodies, times, particles)
}

#[test]
fn a_run_resumed_from_its_checkpoint_records_what_one_sitting_records() {
    let whole = tempfile::tempdir().unwrap();
    assert!(run(whole.path(), &[]).status.success());
    let one = read_recording(&whole.path().join("run.mcap")).unwrap();
    assert_eq!(
        one.windows, 207,
        "the scene's plan changed: update this test"
    );

    // First sitting: stopped after 150 windows, a checkpoint every 0.3 s of wall time
    // (about every 15 windows on lavapipe): it ran past its newest checkpoint, unless
    // that fell after window 150.
    let two = tempfile::tempdir().unwrap();
    let first = run(
        two.path(),
        &["--windows", "150", "--checkpoint-every", "0.3"],
    );
    assert!(first.status.success());
    assert_eq!(
        read_recording(&two.path().join("run.mcap"))
            .unwrap()
            .windows,
        150
    );
    let second = run(two.path(), &["--resume"]);
    assert!(second.status.success());
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(stderr.contains("resuming"), "{stderr}");
    let sittings = couplet_orchestrator::resume::sittings(two.path()).unwrap();
    assert!(
        sittings.len() == 2 && sittings[1].0 <= 150,
        "one later sitting, from the newest checkpoint: {sittings:?}"
    );
    let chain = read_chain(two.path()).unwrap();
    assert_eq!(chain.windows, one.windows);
    assert!(chain.has_summary);
    assert_eq!(chain.snapshots.len(), one.snapshots.len());
    assert!(
        bits(&chain) == bits(&one),
        "the resumed run differs from the run in one sitting"
    );
    // The wall clock runs on across the sittings.
    let wall = chain.last_window.unwrap().wall_s;
    assert!(wall > 0.0 && wall.is_finite(), "{wall}");

    // Done: nothing to resume. Another scene: refused, naming the cause.
    let done = run(two.path(), &["--resume"]);
    let e = String::from_utf8_lossy(&done.stderr);
    assert!(
        !done.status.success() && e.contains("already ran to its end"),
        "{e}"
    );
    let other = couplet_run(
        CLI,
        &scene("dam-break-boxes"),
        two.path(),
        &["--spacing", "0.02", "--set", "time.end=0.04", "--resume"],
    );
    let e = String::from_utf8_lossy(&other.stderr);
    assert!(
        !other.status.success() && e.contains("another scene"),
        "{e}"
    );
}
