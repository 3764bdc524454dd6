//! Cross-process integration and validation tests; helpers to run the `couplet` CLI and
//! read back what it recorded.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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
