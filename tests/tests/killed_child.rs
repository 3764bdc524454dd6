//! `couplet run` with a killed child process exits non-zero within a second and leaves
//! a readable MCAP file (DESIGN.md failure model: "A dead peer is detected within a
//! second … A recording is never left unreadable").
//!
//! The one-second bound is the failure model's requirement on detection, not a
//! performance figure: the orchestrator blocks in slices of 100 ms and checks its
//! children after each.

use couplet_tests::{exit_within, read_recording, scene, wait_for_windows};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");

fn kill_one_child_and_time_exit(victim: &str) {
    let out = tempfile::tempdir().unwrap();
    let mut cli = Command::new(CLI)
        .arg("run")
        .arg(scene("dam-break-boxes"))
        .arg("--out")
        .arg(out.path())
        .arg("--spacing")
        .arg("0.02")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let children = wait_for_windows(&mut cli, &out.path().join("run.mcap"), 2);
    // The fluid server is started first (see orchestrator/src/run.rs).
    let pid = if victim == "fluid" {
        children[0]
    } else {
        children[1]
    };
    let cmdline = std::fs::read_to_string(format!("/proc/{pid}/cmdline"))
        .unwrap()
        .replace('\0', " ");
    assert!(
        cmdline.contains(&format!("{victim}-server")),
        "pid {pid} is `{cmdline}`, not the {victim} server"
    );
    // SAFETY: kill(2) on a pid we just read from our own child's child list.
    unsafe { libc::kill(pid as i32, libc::SIGKILL) };
    let killed = Instant::now();
    let (status, stderr) = exit_within(
        &mut cli,
        Duration::from_secs(10),
        &format!("couplet run notices the dead {victim} server"),
    );
    let took = killed.elapsed();
    eprintln!("{took:?} after SIGKILL of the {victim} server");
    assert!(!status.success());
    assert!(took < Duration::from_secs(1), "took {took:?}");
    assert!(
        stderr.contains(&format!("{victim}-server")) && stderr.contains("signal: 9"),
        "error must name the child and its status: {stderr}"
    );
    let rec = read_recording(&out.path().join("run.mcap")).unwrap();
    assert!(rec.has_summary, "the recording was not closed");
    assert!(rec.windows > 0 && !rec.bodies.is_empty(), "{rec:?}");
}

#[test]
fn killed_dem_server_stops_the_run_within_a_second() {
    kill_one_child_and_time_exit("dem");
}

#[test]
fn killed_fluid_server_stops_the_run_within_a_second() {
    kill_one_child_and_time_exit("fluid");
}
