//! Cross-process integration and validation tests; helpers to run the `couplet` CLI and
//! read back what it recorded.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output};
use std::time::{Duration, Instant};

/// The repository root (the scenes live in `scenes/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A shipped scene by name.
pub fn scene(name: &str) -> PathBuf {
    repo_root().join("scenes").join(format!("{name}.toml"))
}

/// Runs `couplet run SCENE --out OUT EXTRA…` with the CLI binary `cli` and returns its output.
pub fn couplet_run(cli: &str, scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let o = Command::new(cli)
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("cannot start the couplet CLI");
    eprintln!("{}", String::from_utf8_lossy(&o.stdout));
    eprintln!("{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// Runs `couplet validate NAME --quick --out OUT EXTRA…` and returns its output; the
/// report table is echoed to stderr (shown by `cargo test -- --nocapture`).
pub fn couplet_validate(cli: &str, name: &str, out: &Path, extra: &[&str]) -> Output {
    let o = Command::new(cli)
        .args(["validate", name, "--quick", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("cannot start the couplet CLI");
    eprintln!("{}", String::from_utf8_lossy(&o.stdout));
    eprintln!("{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The pids of process `pid`'s children.
pub fn children_of(pid: u32) -> Vec<u32> {
    std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children"))
        .unwrap_or_default()
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect()
}

/// Waits until the orchestrator `cli` runs its `servers` and its recording `mcap` has grown
/// past its header: its first chunk, closed only once it holds a megabyte of windows, is on
/// disk, so windows are running. Returns the servers' pids (fluid first, as
/// orchestrator/src/run.rs starts them). (Waiting a fixed 3 s instead failed on a loaded
/// machine, with no window done by then.)
pub fn wait_for_windows(cli: &mut Child, mcap: &Path, servers: usize) -> Vec<u32> {
    let start = Instant::now();
    let mut header = None;
    loop {
        let c = children_of(cli.id());
        let recording = std::fs::metadata(mcap).map(|m| m.len()).unwrap_or(0);
        if recording > 0 && header.is_none() {
            header = Some(recording);
        }
        if c.len() == servers && header.is_some_and(|h| recording > h) {
            return c;
        }
        assert!(
            cli.try_wait().unwrap().is_none(),
            "couplet ended before its windows could be watched"
        );
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "servers did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Waits for `cli` to exit, at most `limit` (else fails saying `what` did not happen);
/// returns its status and its stderr, echoed.
pub fn exit_within(cli: &mut Child, limit: Duration, what: &str) -> (ExitStatus, String) {
    let start = Instant::now();
    let status = loop {
        if let Some(s) = cli.try_wait().unwrap() {
            break s;
        }
        assert!(start.elapsed() < limit, "{what} within {limit:?}");
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(cli.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    eprintln!(
        "{stderr}
exit {status}"
    );
    (status, stderr)
}

/// The judged rows of a validation report (`OUT/report.md`): (quantity, result).
pub fn report_rows(out: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(out.join("report.md")).unwrap_or_default();
    text.lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| quantity") && !l.starts_with("|---"))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (cells[1].to_owned(), cells[cells.len() - 2].to_owned())
        })
        .collect()
}

/// Asserts that for each of `parts` some row of `rows` (from [`report_rows`]) whose
/// quantity contains it has the result `result` ("PASS", "FAIL" or "reported").
pub fn assert_rows(rows: &[(String, String)], result: &str, parts: &[&str]) {
    for part in parts {
        assert!(
            rows.iter().any(|(q, r)| q.contains(part) && r == result),
            "no row containing {part:?} is {result}: {rows:?}"
        );
    }
}

pub use couplet_orchestrator::record::{BodySample, Particle, Recording, read_recording, track};
pub use couplet_orchestrator::validate::joubert_terminal_velocity;

/// The share of a series' successive changes whose sign is the opposite of the change
/// before: a body's velocity recorded per window flips in nearly every window when a
/// partitioned coupling lags an added mass heavier than the body (the instability the
/// implicit scheme of issue 4 would cure), and in a few percent of windows when the flow
/// alone shakes it. `None` with fewer than three values.
pub fn sign_flip_share(series: &[f64]) -> Option<f64> {
    let changes: Vec<f64> = series.windows(2).map(|w| w[1] - w[0]).collect();
    let pairs = changes.len().checked_sub(1).filter(|&n| n > 0)?;
    let flips = changes.windows(2).filter(|c| c[0] * c[1] < 0.0).count();
    Some(flips as f64 / pairs as f64)
}

#[cfg(test)]
mod tests {
    use super::sign_flip_share;

    #[test]
    fn sign_flip_share_counts_reversals_of_the_change() {
        // Changes +1, −2, +2, +1: two of three successive pairs reverse.
        assert_eq!(
            sign_flip_share(&[0.0, 1.0, -1.0, 1.0, 2.0]),
            Some(2.0 / 3.0)
        );
        // A steady acceleration never reverses; an alternating one always does.
        assert_eq!(sign_flip_share(&[0.0, 1.0, 2.0, 3.0]), Some(0.0));
        assert_eq!(sign_flip_share(&[0.0, 1.0, 0.0, 1.0]), Some(1.0));
        assert_eq!(sign_flip_share(&[0.0, 1.0]), None);
    }
}
