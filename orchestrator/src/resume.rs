//! A run longer than one sitting: `--checkpoint-every SECONDS` makes `couplet run` and
//! `couplet validate` write a checkpoint ([`crate::run::CoupledRun::checkpoint`]) every so
//! many seconds of wall time, keeping only the newest of each sitting, and `--resume`
//! continues from the newest checkpoint under the output folder.
//!
//! Layout of an output folder OUT after two sittings:
//!
//! ```text
//! OUT/run.mcap, scene.toml, bodies.csv      the first sitting, from window 0
//! OUT/checkpoints/step-00001200/            its newest checkpoint
//! OUT/resume-1200/run.mcap, scene.toml, …   the second, from window 1200
//! OUT/resume-1200/checkpoints/step-…/       its newest checkpoint
//! ```
//!
//! Each sitting records from its first window on; the first one ran past its newest
//! checkpoint until it was stopped, and those windows were run again by the next, so
//! [`read_chain`] takes from each sitting the windows before the next one's first. On the
//! same machine the continuation repeats the original to the last bit (ARCHITECTURE.md,
//! "Checkpoints: each process saves its own state"), so the chain is the recording one
//! sitting would have made (`tests/tests/resumed_run.rs`, a sitting stopped by SIGTERM).
//! A checkpoint first writes out the recording, so a sitting killed outright (SIGKILL)
//! still reaches its newest checkpoint; older runs may not, and [`read_chain`] lists the
//! windows no sitting recorded as gaps.
//! A sitting stopped by `--windows` instead records a snapshot at its last window, as
//! every run so stopped does, and the chain keeps it: one snapshot off the output clock.
//! `bodies.csv` and VTK files stay per sitting.

use crate::record::{Gap, Recording, read_recording_before};
use crate::run::{RunError, RunOptions, RunSummary, checkpoint_scene, run};
use couplet_protocol::Role;
use couplet_protocol::state::state_file;
use std::path::{Path, PathBuf};

/// Folder name prefix of a later sitting: `resume-<first window>`.
const SITTING_PREFIX: &str = "resume-";

/// The folder a sitting that starts at window `step` records into.
pub fn sitting_dir(out: &Path, step: u64) -> PathBuf {
    out.join(format!("{SITTING_PREFIX}{step}"))
}

/// The entries `<prefix><N>` of folder `dir` that are folders, as `(N, path)` sorted by
/// N; none when `dir` does not exist.
fn numbered(dir: &Path, prefix: &str) -> Result<Vec<(u64, PathBuf)>, String> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(format!("{}: {e}", dir.display())),
    };
    let mut found = Vec::new();
    for e in entries {
        let e = e.map_err(|e| format!("{}: {e}", dir.display()))?;
        let n = (e.file_name().to_str())
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|n| n.parse::<u64>().ok());
        if let Some(n) = n.filter(|_| e.path().is_dir()) {
            found.push((n, e.path()));
        }
    }
    found.sort();
    Ok(found)
}

/// The sittings of the run in `out`, in order: `(first window, folder)`, `out` itself
/// first (window 0), then its `resume-N` folders by N.
pub fn sittings(out: &Path) -> Result<Vec<(u64, PathBuf)>, String> {
    let mut all = vec![(0, out.to_owned())];
    all.extend(numbered(out, SITTING_PREFIX)?);
    Ok(all)
}

/// Removes the later sittings (`resume-N`, not `out` itself) that start at window `from`
/// or later: a continuation from `from` replaces them, and a fresh run (`from` = 0)
/// removes every one, so that [`read_chain`] never joins an older run's.
pub fn remove_sittings_from(out: &Path, from: u64) -> Result<(), String> {
    for (step, dir) in sittings(out)?.into_iter().skip(1) {
        if step >= from {
            std::fs::remove_dir_all(&dir)
                .map_err(|e| format!("removing {}: {e}", dir.display()))?;
        }
    }
    Ok(())
}

/// A checkpoint folder is whole once the orchestrator's state is in it: it is written
/// last, after both servers acknowledged theirs.
fn complete(dir: &Path) -> bool {
    state_file(dir, Role::Orchestrator).is_file()
}

/// The newest whole checkpoint of every sitting of `out`: `(window, folder)`.
pub fn newest_checkpoint(out: &Path) -> Result<Option<(u64, PathBuf)>, String> {
    let mut best: Option<(u64, PathBuf)> = None;
    for (_, dir) in sittings(out)? {
        for (step, cp) in numbered(&dir.join("checkpoints"), "step-")? {
            if complete(&cp) && best.as_ref().is_none_or(|b| step > b.0) {
                best = Some((step, cp));
            }
        }
    }
    Ok(best)
}

/// The recording of the run in `out` over all its sittings ([`sittings`]): from each,
/// the windows before the next sitting's first. `has_summary` and `truncated` are the
/// last sitting's. Windows that no sitting recorded (a sitting killed before its
/// recorder wrote out what its checkpoint had passed) are listed in `gaps`, and
/// printed as a warning: the analysis goes on over the rest, and `couplet validate`
/// reports what the gaps lost. A sitting that recorded nothing adds nothing.
pub fn read_chain(out: &Path) -> Result<Recording, String> {
    let all = sittings(out)?;
    let mut chain = Recording::default();
    for (k, (_, dir)) in all.iter().enumerate() {
        let next = all.get(k + 1).map(|s| s.0);
        let path = dir.join("run.mcap");
        let r = read_recording_before(&path, next)?;
        // The window the chain has next: every sitting's recording starts at its first.
        let expected = chain.last_window.map_or(0, |w| w.step + 1);
        if let Some(first) = r.first_window.filter(|f| f.step > expected) {
            let n = (first.step - expected) as f64;
            let gap = Gap {
                from_step: expected,
                to_step: first.step,
                from_time: chain
                    .last_window
                    .map_or(first.time - n * first.window, |w| w.time + w.window),
                to_time: first.time,
            };
            eprintln!(
                "warning: {}: windows {}–{} (t = {:.6e} … {:.6e} s) are in no sitting's \
                 recording (the sitting before was killed before it wrote them out)",
                out.display(),
                gap.from_step,
                gap.to_step - 1,
                gap.from_time,
                gap.to_time
            );
            chain.gaps.push(gap);
        }
        chain.snapshots.extend(r.snapshots);
        chain.bodies.extend(r.bodies);
        chain.loads.extend(r.loads);
        chain.windows += r.windows;
        chain.reflected += r.reflected;
        chain.first_reflected = chain.first_reflected.or(r.first_reflected);
        chain.first_window = chain.first_window.or(r.first_window);
        chain.last_window = r.last_window.or(chain.last_window);
        chain.has_summary = r.has_summary;
        chain.truncated = r.truncated;
    }
    Ok(chain)
}

/// What `--resume` finds in an output folder.
#[derive(Debug, Clone, PartialEq)]
pub enum Resume {
    /// Nothing to continue; why (no recording, or no checkpoint).
    Start(String),
    /// Continue from checkpoint `checkpoint`, taken before window `step` ([`continue_run`]
    /// records into `resume-<step>`).
    Continue { step: u64, checkpoint: PathBuf },
    /// The recording runs to the end: the run is done.
    Finished,
}

/// Where the run of scene `text` (as resolved, overrides applied), which ends at
/// simulated time `end`, stands in `out` (see [`Resume`]). A scene other than the one
/// `out` was run with is an error. A run that failed (a blow-up, say) before its end is
/// continued from its newest checkpoint, and fails again there.
pub fn resume_point(out: &Path, text: &str, end: f64) -> Result<Resume, String> {
    if !out.join("run.mcap").is_file() {
        return Ok(Resume::Start(format!(
            "{} holds no recording",
            out.display()
        )));
    }
    let first = out.join("scene.toml");
    match std::fs::read_to_string(&first) {
        Ok(t) if t == text => {}
        Ok(_) => {
            return Err(format!(
                "{} was run with another scene than this one: give the first sitting's \
                 scene and --set/--spacing again",
                first.display()
            ));
        }
        Err(e) => return Err(format!("{}: {e}", first.display())),
    }
    // Whether the run ended is the last sitting's to say: reading it alone spares
    // decoding the others (the RTI's first sitting holds ~190 MB of grain states), which
    // `validate` reads once more for its analysis.
    let (_, dir) = (sittings(out)?.pop()).expect("`out` itself is the first sitting");
    let last = read_recording_before(&dir.join("run.mcap"), None)?;
    if let (true, Some(w)) = (last.has_summary, last.last_window)
        && w.time + w.window >= end - 0.5 * w.window
    {
        return Ok(Resume::Finished);
    }
    Ok(match newest_checkpoint(out)? {
        Some((step, checkpoint)) => Resume::Continue { step, checkpoint },
        None => Resume::Start(format!(
            "{} holds no checkpoint (`--checkpoint-every SECONDS` writes them)",
            out.display()
        )),
    })
}

/// Runs the next sitting of the run in `out` from its checkpoint `checkpoint`, taken
/// before window `step`: `opts` as for the first sitting, with the checkpoint's scene
/// (which holds the first sitting's overrides) and its recording in `resume-<step>`,
/// which replaces any sitting from `step` on.
pub fn continue_run(
    opts: &RunOptions,
    out: &Path,
    step: u64,
    checkpoint: &Path,
) -> Result<RunSummary, RunError> {
    remove_sittings_from(out, step).map_err(RunError::Resume)?;
    run(&RunOptions {
        scene: checkpoint_scene(checkpoint),
        out: Some(sitting_dir(out, step)),
        overrides: Vec::new(),
        restore: Some(checkpoint.to_owned()),
        ..opts.clone()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::Recorder;
    use couplet_protocol::BodyState;

    const SCENE: &str = "name = \"test\"\n";

    /// A sitting in `dir` that recorded windows `from..to` (1 s each, body 0 at
    /// x = `mark` + step at each window's end, wall time 10 s a window) and kept a
    /// checkpoint before each window in `checkpoints` (`whole`: with the orchestrator's
    /// state, else only the servers' as a checkpoint cut off while it was written).
    fn sitting(dir: &Path, from: u64, to: u64, mark: f64, checkpoints: &[(u64, bool)]) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join("scene.toml"), SCENE).unwrap();
        let mut r = Recorder::create(&dir.join("run.mcap"), "test", SCENE, &[]).unwrap();
        for step in from..to {
            let s = BodyState {
                position: [mark + step as f64, 0.0, 0.0],
                orientation: [0.0, 0.0, 0.0, 1.0],
                ..Default::default()
            };
            r.bodies(step as f64 + 1.0, &[s]);
            r.window(step, step as f64, 1.0, 10.0 * (step + 1) as f64, None, None);
        }
        r.close().unwrap();
        for &(step, whole) in checkpoints {
            let cp = couplet_protocol::state::checkpoint_dir(&dir.join("checkpoints"), step);
            std::fs::create_dir_all(&cp).unwrap();
            std::fs::write(state_file(&cp, Role::Fluid), b"x").unwrap();
            if whole {
                std::fs::write(state_file(&cp, Role::Orchestrator), b"x").unwrap();
            }
        }
    }

    /// The first sitting ran past its checkpoint at window 6 to window 9 before it was
    /// stopped; the second ran 6–11 again. The chain takes 0–5 from the first and 6–11
    /// from the second: each window once, in order, the last sitting's wall clock.
    #[test]
    fn the_chain_takes_each_window_once_from_the_sitting_that_ran_it_last() {
        let out = tempfile::tempdir().unwrap();
        sitting(out.path(), 0, 10, 0.0, &[(6, true)]);
        sitting(&sitting_dir(out.path(), 6), 6, 12, 100.0, &[]);
        let rec = read_chain(out.path()).unwrap();
        assert_eq!(rec.windows, 12);
        let x: Vec<f64> = rec.bodies.iter().map(|b| b.position[0]).collect();
        let want: Vec<f64> = (0..6)
            .map(f64::from)
            .chain((6..12).map(|s| 100.0 + f64::from(s)))
            .collect();
        assert_eq!(x, want);
        let t: Vec<f64> = rec.bodies.iter().map(|b| b.time).collect();
        assert_eq!(t, (1..13).map(f64::from).collect::<Vec<_>>());
        let last = rec.last_window.unwrap();
        assert_eq!((last.step, last.wall_s), (11, 120.0));
        assert!(rec.has_summary && rec.truncated.is_none());
    }

    /// A sitting whose recording stops before the next one's first window (it was
    /// killed before it wrote them out) leaves a gap: listed with its windows and times,
    /// and the windows on both sides read. Until 2026-12-06 a gap was an error, which
    /// left a lavapipe RTI's six hours unreadable for windows 7433–7600 (1.3 ms) lost.
    /// A sitting that recorded nothing adds nothing.
    #[test]
    fn a_gap_between_sittings_is_listed_and_both_sides_read() {
        let out = tempfile::tempdir().unwrap();
        sitting(out.path(), 0, 5, 0.0, &[]);
        sitting(&sitting_dir(out.path(), 7), 7, 9, 0.0, &[]);
        sitting(&sitting_dir(out.path(), 9), 9, 9, 0.0, &[]);
        let rec = read_chain(out.path()).unwrap();
        let gap = Gap {
            from_step: 5,
            to_step: 7,
            from_time: 5.0,
            to_time: 7.0,
        };
        assert_eq!(rec.gaps, vec![gap]);
        let x: Vec<f64> = rec.bodies.iter().map(|b| b.position[0]).collect();
        assert_eq!(x, [0.0, 1.0, 2.0, 3.0, 4.0, 7.0, 8.0]);
        assert_eq!(rec.windows, 7);
        assert_eq!(rec.last_window.map(|w| w.step), Some(8));
    }

    /// `--resume` continues from the newest whole checkpoint of any sitting, analyses a
    /// run that reached its end, starts a folder without a recording afresh, and
    /// refuses another scene.
    #[test]
    fn resume_finds_the_newest_whole_checkpoint_or_the_end() {
        let out = tempfile::tempdir().unwrap();
        let o = out.path();
        assert!(matches!(resume_point(o, SCENE, 12.0), Ok(Resume::Start(_))));
        // Whole at 4 (first sitting) and 9 (second); 10 was cut off mid-write.
        sitting(o, 0, 8, 0.0, &[(4, true)]);
        sitting(&sitting_dir(o, 4), 4, 11, 0.0, &[(9, true), (10, false)]);
        assert_eq!(
            resume_point(o, SCENE, 12.0).unwrap(),
            Resume::Continue {
                step: 9,
                checkpoint: couplet_protocol::state::checkpoint_dir(
                    &sitting_dir(o, 4).join("checkpoints"),
                    9
                ),
            }
        );
        // The recording ends at t = 11 s: a run to 11 s is done (half a window's slack).
        assert_eq!(resume_point(o, SCENE, 11.0).unwrap(), Resume::Finished);
        let e = resume_point(o, "name = \"other\"\n", 12.0).unwrap_err();
        assert!(e.contains("another scene"), "{e}");
        // A continuation from 4 replaces the sitting that began there.
        remove_sittings_from(o, 4).unwrap();
        assert_eq!(sittings(o).unwrap(), vec![(0, o.to_owned())]);
    }
}
