//! A server started apart from its orchestrator (`couplet run --run-id ID --external ROLE`
//! with `couplet ROLE ID SCENE --detached`, as deploy/compose.split.yaml runs them in two
//! containers): the run goes through in either start order, each side notices the other's
//! death within a second through its iceoryx2 node (DESIGN.md failure model: "A dead peer
//! is detected within a second"), and a server on another scene is refused.
//!
//! The DEM-only Newton's cradle keeps these tests off the GPU. The one-second bounds are
//! the failure model's requirement on detection, not performance figures.

use couplet_tests::{read_recording, scene};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

/// A run id no other test (or run on this machine) uses.
fn run_id(tag: &str) -> String {
    format!("test-{tag}-{}", std::process::id())
}

fn dem_server(id: &str, scene_file: &std::path::Path) -> Child {
    Command::new(CLI)
        .args(["dem-server", id])
        .arg(scene_file)
        .arg("--detached")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn orchestrator(id: &str, out: &std::path::Path, extra: &[&str]) -> Child {
    Command::new(CLI)
        .arg("run")
        .arg(scene("newton-cradle"))
        .arg("--out")
        .arg(out)
        .args(["--run-id", id, "--external", "dem-server"])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits for `child` to exit, at most `limit`; its status and stderr.
fn finish(child: &mut Child, limit: Duration, what: &str) -> (ExitStatus, String) {
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("{what} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    (status, err)
}

/// Waits until the run is recording windows (both sides past the handshake).
fn wait_until_recording(out: &std::path::Path, run: &mut Child) {
    let start = Instant::now();
    while std::fs::metadata(out.join("run.mcap")).map_or(0, |m| m.len()) == 0
        || start.elapsed() < Duration::from_secs(1)
    {
        assert!(run.try_wait().unwrap().is_none(), "the run ended early");
        assert!(start.elapsed() < Duration::from_secs(60), "never started");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Server first or orchestrator first, the run's 200 windows are recorded and closed,
/// and the server exits cleanly on the orchestrator's shutdown.
#[test]
fn detached_server_runs_in_either_start_order() {
    for server_first in [true, false] {
        let id = run_id(if server_first {
            "server-first"
        } else {
            "run-first"
        });
        let out = tempfile::tempdir().unwrap();
        let (mut dem, mut run);
        if server_first {
            dem = dem_server(&id, &scene("newton-cradle"));
            std::thread::sleep(Duration::from_millis(500));
            run = orchestrator(&id, out.path(), &["--windows", "200"]);
        } else {
            run = orchestrator(&id, out.path(), &["--windows", "200"]);
            std::thread::sleep(Duration::from_millis(500));
            dem = dem_server(&id, &scene("newton-cradle"));
        }
        let (status, err) = finish(&mut run, Duration::from_secs(120), "couplet run");
        assert!(status.success(), "server first: {server_first}: {err}");
        let (status, err) = finish(&mut dem, Duration::from_secs(10), "the dem-server");
        assert!(status.success(), "server first: {server_first}: {err}");
        let rec = read_recording(&out.path().join("run.mcap")).unwrap();
        assert!(rec.has_summary);
        assert_eq!(rec.windows, 200, "server first: {server_first}");
        // Every window's states of the five balls crossed from the server apart.
        assert_eq!(rec.bodies.iter().map(|b| b.body).max(), Some(4));
        assert!(
            rec.bodies.len() >= 5 * 200,
            "{} body samples",
            rec.bodies.len()
        );
    }
}

/// A detached server killed mid-run stops the run within a second, with an error that
/// says which server, started apart, went; the recording is closed.
#[test]
fn killed_detached_server_stops_the_run_within_a_second() {
    let id = run_id("kill-server");
    let out = tempfile::tempdir().unwrap();
    let mut dem = dem_server(&id, &scene("newton-cradle"));
    let mut run = orchestrator(&id, out.path(), &[]);
    wait_until_recording(out.path(), &mut run);
    dem.kill().unwrap();
    let killed = Instant::now();
    let (status, err) = finish(&mut run, Duration::from_secs(10), "couplet run");
    let took = killed.elapsed();
    let _ = dem.wait();
    assert!(!status.success());
    assert!(took < Duration::from_secs(1), "took {took:?}");
    assert!(
        err.contains(&format!(
            "the dem-server of run {id}, started apart, has exited"
        )),
        "{err}"
    );
    assert!(
        read_recording(&out.path().join("run.mcap"))
            .unwrap()
            .has_summary
    );
}

/// The orchestrator killed mid-run ends its detached server within a second, naming it.
#[test]
fn killed_orchestrator_ends_the_detached_server_within_a_second() {
    let id = run_id("kill-run");
    let out = tempfile::tempdir().unwrap();
    let mut dem = dem_server(&id, &scene("newton-cradle"));
    let mut run = orchestrator(&id, out.path(), &[]);
    wait_until_recording(out.path(), &mut run);
    run.kill().unwrap();
    let killed = Instant::now();
    let (status, err) = finish(&mut dem, Duration::from_secs(10), "the dem-server");
    let took = killed.elapsed();
    let _ = run.wait();
    assert!(!status.success());
    assert!(took < Duration::from_secs(1), "took {took:?}");
    assert!(
        err.contains(&format!("the orchestrator of run {id} has exited")),
        "{err}"
    );
}

/// A server that loaded another scene (here: the same one with a changed comment) is
/// refused at the handshake, naming it and both digests; a second orchestrator on a run
/// id in use is refused before it starts anything.
#[test]
fn server_on_another_scene_and_a_taken_run_id_are_refused() {
    let id = run_id("other-scene");
    let out = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scene("newton-cradle")).unwrap();
    let other = out.path().join("other.toml");
    std::fs::write(&other, format!("# changed\n{text}")).unwrap();
    let mut dem = dem_server(&id, &other);
    let mut run = orchestrator(&id, &out.path().join("run"), &[]);
    let (status, err) = finish(&mut run, Duration::from_secs(60), "couplet run");
    assert!(!status.success());
    assert!(
        err.contains("the dem-server (pid") && err.contains("loaded another scene than this run's"),
        "{err}"
    );
    let (status, _) = finish(&mut dem, Duration::from_secs(10), "the dem-server");
    assert!(status.success(), "told to shut down, it exits cleanly");

    let id = run_id("taken");
    let mut dem = dem_server(&id, &scene("newton-cradle"));
    let mut first = orchestrator(&id, &out.path().join("first"), &[]);
    wait_until_recording(&out.path().join("first"), &mut first);
    let mut second = orchestrator(&id, &out.path().join("second"), &[]);
    let (status, err) = finish(&mut second, Duration::from_secs(10), "the second run");
    assert!(!status.success());
    assert!(err.contains(&format!("run id `{id}` is taken")), "{err}");
    first.kill().unwrap();
    let _ = first.wait();
    let _ = finish(&mut dem, Duration::from_secs(10), "the dem-server");
}
