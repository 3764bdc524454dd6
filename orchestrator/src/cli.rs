//! The `couplet` command line: run, plan and benchmark coupled SPH–DEM scenes; also the
//! fluid and DEM server roles, so that one binary is all a machine needs. It lives in
//! the library so that the cross-process tests can build the same CLI as their own
//! binary (`tests/src/bin/couplet-cli.rs`).

use crate::{RunOptions, RunSummary, bench, plan, run, validate};
use anyhow::Context;
use clap::{Parser, Subcommand};
use couplet_protocol::Role;
use couplet_protocol::transport::Orchestrator;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "couplet",
    version,
    about = "SPH fluid (GPU) + DEM co-simulation"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

/// Scene overrides shared by `run`, `plan` and `bench`.
#[derive(clap::Args, Clone, Default)]
struct Overrides {
    /// Override fluid.spacing, m (shorthand for `--set fluid.spacing=M`).
    #[arg(long)]
    spacing: Option<f64>,
    /// Override any scene field: `--set time.end=0.5 --set fluid.kernel='"quintic"'`
    /// (the value is TOML). Checked like the file.
    #[arg(long = "set", value_name = "PATH=VALUE")]
    set: Vec<String>,
}

impl Overrides {
    fn list(&self) -> anyhow::Result<Vec<(String, String)>> {
        let mut out = Vec::new();
        if let Some(s) = self.spacing {
            out.push(("fluid.spacing".to_owned(), format!("{s:e}")));
        }
        for kv in &self.set {
            let (k, v) = kv.split_once('=').ok_or_else(|| {
                anyhow::anyhow!("--set {kv}: expected PATH=VALUE, e.g. time.end=0.5")
            })?;
            out.push((k.trim().to_owned(), v.trim().to_owned()));
        }
        Ok(out)
    }
}

/// A run longer than one sitting (`crate::resume`), shared by `run` and `validate`.
#[derive(clap::Args, Clone, Default)]
struct Sittings {
    /// Write a checkpoint (OUT/checkpoints/step-N: both servers' whole state and the
    /// orchestrator's) after the window that ends each SECONDS of wall time, keeping only
    /// the newest, so that --resume can continue the run after a time limit or a crash.
    /// Taking one does not change the run.
    #[arg(long, value_name = "SECONDS", value_parser = seconds)]
    checkpoint_every: Option<std::time::Duration>,
    /// Continue the run in OUT from its newest checkpoint, recording the rest into
    /// OUT/resume-N (N its first window); the analysis and `validate --recording` read all
    /// the sittings as one recording. Give the first sitting's command line again: a
    /// scene (with --set/--spacing) other than OUT/scene.toml is refused.
    #[arg(long)]
    resume: bool,
}

/// A wall-time interval in seconds: finite and not negative (0: after every window).
fn seconds(s: &str) -> Result<std::time::Duration, String> {
    let x: f64 = s.parse().map_err(|e| format!("{s}: {e}"))?;
    std::time::Duration::try_from_secs_f64(x)
        .map_err(|_| format!("{s}: a wall time in seconds, finite and at least 0"))
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a scene end to end and record it to OUT/run.mcap.
    Run {
        scene: PathBuf,
        /// Output folder. Default: out/<scene name>.
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
        /// Stop after this many coupling windows.
        #[arg(long)]
        windows: Option<u64>,
        /// The run's id (its iceoryx2 namespace). Default: made up from the pid and the
        /// clock. Servers started apart (--external) are given the same id.
        #[arg(long, value_name = "ID")]
        run_id: Option<String>,
        /// Do not start this server; wait (up to 300 s) for one started apart as
        /// `couplet ROLE RUN_ID SCENE --detached`, on this scene file, sharing this
        /// machine's /dev/shm and /tmp/iceoryx2 (another container); repeatable. Its
        /// liveness is its iceoryx2 node: a dead one stops the run within a second. Not
        /// with --set/--spacing: the server loads the scene file as it is, and the digest
        /// of it in its hello must match this run's.
        #[arg(long = "external", value_name = "ROLE", requires = "run_id",
              conflicts_with_all = ["spacing", "set"],
              value_parser = ["fluid-server", "dem-server"])]
        external: Vec<String>,
        #[command(flatten)]
        sittings: Sittings,
    },
    /// Print the processes, GPU stages and time-step limits a scene will use, and why.
    Plan {
        scene: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Time the fluid of a scene headless and the exchange of a short coupled run.
    Bench {
        scene: PathBuf,
        /// Fluid steps to time.
        #[arg(long, default_value_t = 50)]
        steps: u32,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Time the soft-sphere DEM engine alone on a block of pressed spheres.
    BenchDem {
        /// Number of spheres.
        #[arg(long, default_value_t = 10_000)]
        spheres: usize,
        /// Contact law: linear or hertz-mindlin.
        #[arg(long, default_value = "hertz-mindlin", value_parser = ["linear", "hertz-mindlin"])]
        contact: String,
        /// Steps to time.
        #[arg(long, default_value_t = 200)]
        steps: u32,
    },
    /// Run a validation case and compare it with its reference: prints a markdown table
    /// and writes it with CSV series and SVG plots to OUT; fails when a judged row fails.
    Validate {
        /// The case (`--list` names them).
        #[arg(required_unless_present = "list")]
        name: Option<String>,
        /// List the cases.
        #[arg(long)]
        list: bool,
        /// The CI-sized version (minutes on a CPU) instead of the full case.
        #[arg(long)]
        quick: bool,
        /// The accuracy-against-cost sweep: the quick version at the case's spacings
        /// with each of its schemes; a table of error against wall time and particles.
        #[arg(long, conflicts_with = "quick")]
        sweep: bool,
        /// With --sweep: run only point K of the sweep (0-based, in the order
        /// --list-points prints) and write its row to OUT/<scheme>-<spacing>/sweep-point.json
        /// for --gather. One process per point fans a sweep out over a cluster (a job
        /// array's index as K, a shared OUT); a run that fails is a row, not an error.
        #[arg(long, requires = "sweep", value_name = "K")]
        point: Option<usize>,
        /// With --sweep: do not run; build the sweep's table (sweep.md, .csv, .svg in OUT)
        /// from the rows its points wrote under OUT, the same table --sweep prints. Fails,
        /// after writing the table of the rows found, when a point has no row.
        #[arg(long, requires = "sweep", conflicts_with_all = ["point", "variants", "spacing", "set"])]
        gather: bool,
        /// With --sweep: print the number of points (the size of a job array) and exit.
        #[arg(long, requires = "sweep", conflicts_with_all = ["point", "gather"])]
        count: bool,
        /// With --sweep: print each point, one a line (index, spacing in m, scheme), and exit.
        #[arg(long, requires = "sweep", conflicts_with_all = ["point", "gather", "count"])]
        list_points: bool,
        /// Run only this variant of a case made of several (its label as the report
        /// prints it, or its folder name: `--variant "water, ε = 0.8"` or
        /// `--variant water-ε-0.8`); repeatable. Default: every variant.
        #[arg(long = "variant", value_name = "LABEL")]
        variants: Vec<String>,
        /// Output folder. Default: out/validate/<name>.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Folder of the scene files. Default: ./scenes, else the repository's.
        #[arg(long)]
        scenes: Option<PathBuf>,
        /// Analyse the run already in this folder (its scene.toml and run.mcap, as
        /// `couplet run --out` leaves them) instead of running: a run made on another
        /// machine, or one variant of a case run by hand. The report and its series go to
        /// --out when given (the folder may be read-only, or a run still going), else to
        /// the folder. The scene is the folder's, so --set, --spacing and --scenes are refused.
        #[arg(long, conflicts_with_all = ["quick", "sweep", "variants", "set", "spacing", "scenes"])]
        recording: Option<PathBuf>,
        #[command(flatten)]
        overrides: Overrides,
        #[command(flatten)]
        sittings: Sittings,
    },
    /// Serve the gRPC control API (protocol/proto/couplet/v1/couplet.proto), with
    /// reflection and the standard health service; Ctrl-C or SIGTERM stops every live
    /// run cleanly and exits.
    Serve {
        /// Address to listen on. Anything but loopback needs --token-file.
        #[arg(long, default_value = "127.0.0.1:50051")]
        listen: std::net::SocketAddr,
        /// Runs write their output (scene.toml, run.mcap) under DIR/<run id>/.
        #[arg(long, default_value = "out/runs")]
        data_dir: PathBuf,
        /// Live runs at most (each holds a fluid and a DEM server process); more
        /// CreateRun calls answer RESOURCE_EXHAUSTED.
        #[arg(long, default_value_t = crate::serve::DEFAULT_MAX_RUNS)]
        max_runs: usize,
        /// File whose content (trimmed) every client must send as
        /// `authorization: Bearer <token>`.
        #[arg(long)]
        token_file: Option<PathBuf>,
        /// TLS certificate chain (PEM); needs --tls-key.
        #[arg(long, requires = "tls_key")]
        tls_cert: Option<PathBuf>,
        /// TLS private key (PEM); needs --tls-cert.
        #[arg(long, requires = "tls_cert")]
        tls_key: Option<PathBuf>,
    },
    /// Drive a `couplet serve` over gRPC: create, start, pause, step, watch, stop runs.
    Ctl {
        #[command(flatten)]
        conn: crate::ctl::Connection,
        #[command(subcommand)]
        cmd: crate::ctl::CtlCmd,
    },
    /// Serve the fluid side of run RUN_ID. `couplet run` starts it itself; start it by
    /// hand, with --detached, for `couplet run --external fluid-server` (another container).
    #[command(name = "fluid-server")]
    FluidServer {
        run_id: String,
        scene: PathBuf,
        #[command(flatten)]
        start: ServerStart,
    },
    /// Serve the DEM side of run RUN_ID. `couplet run` starts it itself; start it by hand,
    /// with --detached, for `couplet run --external dem-server` (another container).
    #[command(name = "dem-server")]
    DemServer {
        run_id: String,
        scene: PathBuf,
        #[command(flatten)]
        start: ServerStart,
    },
}

/// How a server role was started.
#[derive(clap::Args, Clone)]
struct ServerStart {
    /// Started apart from the orchestrator (`couplet run --run-id RUN_ID --external ROLE`,
    /// on the same machine or in a container sharing its /dev/shm and /tmp/iceoryx2): wait
    /// up to 300 s for it, say hello until it listens, and exit when its iceoryx2 node
    /// goes. SCENE must be the file the orchestrator runs, unchanged (it checks).
    #[arg(long)]
    detached: bool,
    /// Root folder of the run's checkpoints (`Checkpoint` commands write under it; the
    /// orchestrator passes `OUT/checkpoints`).
    #[arg(long)]
    checkpoints: Option<PathBuf>,
    /// Start from this checkpoint folder (`ROOT/step-N`) instead of the scene's initial
    /// state.
    #[arg(long)]
    restore: Option<PathBuf>,
}

impl ServerStart {
    fn state_dirs(&self) -> couplet_protocol::state::StateDirs {
        couplet_protocol::state::StateDirs {
            checkpoints: self.checkpoints.clone(),
            restore: self.restore.clone(),
        }
    }

    fn orchestrator(&self, run_id: &str) -> Orchestrator {
        if self.detached {
            Orchestrator::detached(run_id)
        } else {
            Orchestrator::parent()
        }
    }
}

/// The error and its causes, `: `-separated, each cause once. `{e:#}` appends every
/// cause to its parent's text, but our error types already end their text with their
/// source's (thiserror's `{source}`), so `{e:#}` printed such a cause twice.
fn chain_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if text.ends_with(&s) {
            continue;
        }
        if !text.is_empty() {
            text += ": ";
        }
        text += &s;
    }
    text
}

/// Parses the process arguments and runs; the exit code is what `main` returns.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match real_main(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A gRPC status (from `couplet ctl`) reads as its code and message.
            match e.downcast_ref::<tonic::Status>() {
                Some(s) => eprintln!("couplet: {:?}: {}", s.code(), s.message()),
                None => eprintln!("couplet: {}", chain_text(&e)),
            }
            // Stopped by Ctrl-C or SIGTERM: the exit code a shell gives the signal.
            match crate::interrupt::requested() {
                Some(signal) => ExitCode::from(signal.exit_code()),
                None => ExitCode::FAILURE,
            }
        }
    }
}

/// Whether `cmd` runs coupling windows in this process, so that Ctrl-C and SIGTERM stop
/// it cleanly between them (`interrupt.rs`). Not `validate` analysing a recording,
/// gathering a sweep or listing: nothing there reads the flag, so the signals keep their
/// usual effect.
fn runs_windows(cmd: &Cmd) -> bool {
    matches!(
        cmd,
        Cmd::Run { .. }
            | Cmd::Validate {
                list: false,
                gather: false,
                count: false,
                list_points: false,
                recording: None,
                ..
            }
    )
}

fn real_main(cli: Cli) -> anyhow::Result<()> {
    match &cli.command {
        cmd if runs_windows(cmd) => {
            crate::interrupt::install().context("installing the SIGINT and SIGTERM handlers")?
        }
        // The orchestrator that started a server ends the run; a detached one is the
        // user's to stop.
        Cmd::FluidServer { start, .. } | Cmd::DemServer { start, .. } if !start.detached => {
            crate::interrupt::ignore_sigint()
        }
        _ => {}
    }
    match cli.command {
        Cmd::Run {
            scene,
            out,
            overrides,
            windows,
            run_id,
            external,
            sittings,
        } => {
            let opts = RunOptions {
                scene: scene.clone(),
                out,
                overrides: overrides.list()?,
                max_windows: windows,
                record: true,
                progress: true,
                run_id,
                external: external
                    .iter()
                    .map(|r| match r.as_str() {
                        "fluid-server" => Role::Fluid,
                        _ => Role::Dem,
                    })
                    .collect(),
                checkpoint_every: sittings.checkpoint_every,
                restore: None,
            };
            let s = if sittings.resume {
                if !opts.external.is_empty() {
                    anyhow::bail!(
                        "--resume starts both servers from the checkpoint: not with --external"
                    );
                }
                let (sc, text) = crate::run::resolve_scene(&scene, &opts.overrides)?;
                let out =
                    (opts.out.clone()).unwrap_or_else(|| PathBuf::from("out").join(&sc.meta.name));
                match crate::resume::resume_point(&out, &text, sc.time.end)
                    .map_err(|e| anyhow::anyhow!("--resume: {e}"))?
                {
                    crate::resume::Resume::Start(why) => {
                        anyhow::bail!("--resume: nothing to continue: {why}")
                    }
                    crate::resume::Resume::Finished => anyhow::bail!(
                        "--resume: the run in {} already ran to its end",
                        out.display()
                    ),
                    crate::resume::Resume::Continue { step, checkpoint } => {
                        eprintln!(
                            "resuming {} at window {step} from {}",
                            out.display(),
                            checkpoint.display()
                        );
                        crate::resume::continue_run(&opts, &out, step, &checkpoint)
                    }
                }
            } else {
                run(&opts)
            }
            .with_context(|| format!("running {}", scene.display()))?;
            println!("{}", summary_text(&s));
        }
        Cmd::Plan { scene, overrides } => print!("{}", plan::plan(&scene, &overrides.list()?)?),
        Cmd::Bench {
            scene,
            steps,
            overrides,
        } => {
            let overrides = overrides.list()?;
            // On the worker pool, as the servers run (`couplet_protocol::worker_pool`).
            let text =
                couplet_protocol::in_worker_pool(|| bench::bench(&scene, steps, &overrides))?;
            print!("{text}")
        }
        Cmd::BenchDem {
            spheres,
            contact,
            steps,
        } => print!(
            "{}",
            couplet_protocol::in_worker_pool(|| bench::bench_dem(spheres, &contact, steps))?
        ),
        Cmd::Validate {
            sweep,
            recording,
            sittings,
            ..
        } if (sweep || recording.is_some())
            && (sittings.resume || sittings.checkpoint_every.is_some()) =>
        {
            anyhow::bail!(
                "--checkpoint-every and --resume are for a case's runs: not with --sweep or --recording"
            )
        }
        Cmd::Validate { list: true, .. } => {
            for c in validate::cases() {
                println!(
                    "{:<18} {}\n{:<18} --quick: {}",
                    c.name, c.about, "", c.quick_why
                );
            }
        }
        Cmd::Validate {
            name,
            recording: Some(dir),
            out,
            ..
        } => {
            let name = name.unwrap_or_default();
            let r = validate::analyse_recording(&name, &dir, out.as_deref().unwrap_or(&dir))
                .with_context(|| format!("analysing {} as {name}", dir.display()))?;
            println!("{}", r.markdown());
            if !r.passed() {
                std::process::exit(1);
            }
        }
        Cmd::Validate {
            name,
            sweep: true,
            count,
            list_points,
            ..
        } if count || list_points => {
            let specs = validate::sweep_specs(&name.unwrap_or_default())?;
            if count {
                println!("{}", specs.len());
            } else {
                for p in specs {
                    println!("{}\t{:e}\t{}", p.index, p.spacing, p.scheme);
                }
            }
        }
        Cmd::Validate {
            name,
            sweep: true,
            gather: true,
            out,
            ..
        } => {
            let name = name.unwrap_or_default();
            let g = validate::sweep_gather(&name, out)
                .with_context(|| format!("gathering the sweep of {name}"))?;
            println!("{}", g.markdown);
            if !g.missing.is_empty() {
                anyhow::bail!(
                    "{name}: {} of the sweep's points have no row yet (the table above leaves them out): {}",
                    g.missing.len(),
                    g.missing
                        .iter()
                        .map(|(k, f)| format!("point {k} ({})", f.display()))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        Cmd::Validate {
            name,
            sweep: true,
            point: Some(point),
            variants,
            out,
            scenes,
            overrides,
            ..
        } => {
            let name = name.unwrap_or_default();
            let (p, row) = validate::sweep_point(
                &name,
                point,
                &variants,
                out,
                &overrides.list()?,
                scenes.as_deref(),
                true,
            )
            .with_context(|| format!("sweeping {name}, point {point}"))?;
            match &p.failure {
                Some(f) => println!(
                    "point {point} ({}, δ = {:e} m): the run failed: {f}",
                    p.scheme, p.spacing
                ),
                None => println!(
                    "point {point} ({}, δ = {:e} m): {} fluid particles, {:.1} s, error {}, all rows pass: {}",
                    p.scheme,
                    p.spacing,
                    p.particles,
                    p.wall_s,
                    p.headline
                        .as_ref()
                        .map_or("none".into(), |(m, e)| format!("{e:e} ({m})")),
                    p.passed
                ),
            }
            println!("row: {}", row.display());
        }
        Cmd::Validate {
            name,
            sweep: true,
            variants,
            out,
            scenes,
            overrides,
            ..
        } => {
            let name = name.unwrap_or_default();
            let o = overrides.list()?;
            let md = validate::sweep(&name, &variants, out, &o, scenes.as_deref(), true)
                .with_context(|| format!("sweeping {name}"))?;
            println!("{md}");
        }
        Cmd::Validate {
            name,
            quick,
            variants,
            out,
            scenes,
            overrides,
            sittings,
            ..
        } => {
            let name = name.unwrap_or_default();
            let r = validate::validate(
                &name,
                quick,
                &variants,
                out,
                &overrides.list()?,
                scenes.as_deref(),
                &validate::HowToRun {
                    progress: true,
                    checkpoint_every: sittings.checkpoint_every,
                    resume: sittings.resume,
                },
            )
            .with_context(|| format!("validating {name}"))?;
            println!("{}", r.markdown());
            println!("report, CSV and SVG: {}", r.out.display());
            if !r.passed() {
                anyhow::bail!(
                    "{name}: {} of {} judged rows failed",
                    r.rows.iter().filter(|r| r.pass == Some(false)).count(),
                    r.rows.iter().filter(|r| r.pass.is_some()).count()
                );
            }
        }
        Cmd::Serve {
            listen,
            data_dir,
            max_runs,
            token_file,
            tls_cert,
            tls_key,
        } => {
            if max_runs == 0 {
                anyhow::bail!("--max-runs 0 would refuse every run");
            }
            let token = match token_file {
                Some(f) => {
                    let t = std::fs::read_to_string(&f)
                        .with_context(|| format!("reading {}", f.display()))?;
                    let t = t.trim().to_owned();
                    if t.is_empty() {
                        anyhow::bail!("{}: the token file is empty", f.display());
                    }
                    Some(t)
                }
                None => None,
            };
            let tls = tls_cert
                .zip(tls_key)
                .map(|(cert, key)| crate::serve::TlsFiles { cert, key });
            crate::serve::serve(
                listen,
                crate::serve::ServeConfig {
                    data_dir,
                    max_runs,
                    server_exe: None,
                    token,
                },
                tls,
            )?;
        }
        Cmd::Ctl { conn, cmd } => crate::ctl::ctl(&conn, cmd)?,
        Cmd::FluidServer {
            run_id,
            scene,
            start,
        } => {
            let orchestrator = start.orchestrator(&run_id);
            let (s, digest) = couplet_protocol::Scene::load_with_digest(&scene)?;
            couplet_fluid::server::serve(&run_id, &s, &orchestrator, digest, &start.state_dirs())
                .context("fluid-server")?;
        }
        Cmd::DemServer {
            run_id,
            scene,
            start,
        } => {
            let orchestrator = start.orchestrator(&run_id);
            let (s, digest) = couplet_protocol::Scene::load_with_digest(&scene)?;
            couplet_dem::server::serve(&run_id, &s, &orchestrator, digest, &start.state_dirs())
                .context("dem-server")?;
        }
    }
    Ok(())
}

fn summary_text(s: &RunSummary) -> String {
    let rate = (s.sim_time - s.first_time) / s.wall_s.max(1e-9);
    let mut t = if s.first_window == 0 {
        format!(
            "done: {} windows, t = {:.4} s simulated in {:.1} s wall ({rate:.3e} sim-s/s)\n",
            s.windows, s.sim_time, s.wall_s,
        )
    } else {
        // A resumed sitting: its own windows, time and speed.
        format!(
            "done: windows {}–{} of {}, t = {:.4} → {:.4} s simulated in {:.1} s wall ({rate:.3e} sim-s/s)\n",
            s.first_window,
            s.windows.saturating_sub(1),
            s.windows,
            s.first_time,
            s.sim_time,
            s.wall_s,
        )
    };
    t += &s.per_window();
    t.push('\n');
    if s.near_singular > 0 {
        t += &format!(
            "gradient correction: {} particle-steps had a near-singular truncation matrix (det M < {}) and kept the uncorrected gradient (per window in /run/windows)\n",
            s.near_singular,
            couplet_fluid::joubert2020_gradients::B_DET_MIN
        );
    }
    if s.reflected > 0 {
        t += &format!(
            "non-penetration: {} fluid particle-steps ended behind a body's surface or a wall face and were mirrored back (per window in /run/windows; many mean a gap or a body under-resolved, or a disturbed flow at a wall)\n",
            s.reflected
        );
    }
    if s.shift_limited > 0 {
        t += &format!(
            "bodies: {} fluid particle-steps had their shift cut short δ/2 in front of a body's surface (per window in /run/windows)\n",
            s.shift_limited
        );
    }
    if let Some(r) = &s.recording {
        t += &format!("recording: {}\n", r.display());
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(args: &[&str]) -> Cmd {
        Cli::try_parse_from(std::iter::once("couplet").chain(args.iter().copied()))
            .unwrap()
            .command
    }

    /// Regression (analysis_ignored_ctrl_c, 2026-11-29): with the handlers installed for
    /// every `validate`, Ctrl-C on `--recording` set a flag nothing read, and the
    /// analysis ran on.
    #[test]
    fn only_commands_that_run_windows_take_the_signals() {
        for args in [
            &["run", "scenes/dam-break.toml"][..],
            &["validate", "dam-break", "--quick"],
            &["validate", "dam-break", "--sweep"],
            &["validate", "dam-break", "--sweep", "--point", "1"],
        ] {
            assert!(runs_windows(&parsed(args)), "{args:?}");
        }
        for args in [
            &["validate", "dam-break", "--recording", "out/x"][..],
            &["validate", "dam-break", "--sweep", "--gather"],
            &["validate", "dam-break", "--sweep", "--count"],
            &["validate", "dam-break", "--sweep", "--list-points"],
            &["validate", "--list"],
            &["serve"],
            &["plan", "scenes/dam-break.toml"],
        ] {
            assert!(!runs_windows(&parsed(args)), "{args:?}");
        }
    }

    /// Regression (recording_ignored_out_and_set, 2026-12-02): `validate --recording DIR`
    /// accepted `--out`, `--set`, `--spacing` and `--scenes` and used none of them, writing
    /// its report into DIR (a read-only folder fetched from a GPU machine, or a run still
    /// going). `--out` is now where the report goes; the others are refused, since the
    /// scene is DIR's own.
    #[test]
    fn a_recording_takes_out_and_refuses_scene_overrides() {
        let Cmd::Validate { recording, out, .. } =
            parsed(&["validate", "cpb", "--recording", "runs/a", "--out", "x"])
        else {
            panic!("not validate")
        };
        assert_eq!(recording.as_deref(), Some(std::path::Path::new("runs/a")));
        assert_eq!(out.as_deref(), Some(std::path::Path::new("x")));
        for extra in [
            &["--set", "time.end=1"][..],
            &["--spacing", "0.01"],
            &["--scenes", "scenes"],
        ] {
            let args = ["couplet", "validate", "cpb", "--recording", "runs/a"];
            let e = Cli::try_parse_from(args.iter().chain(extra)).err();
            let kind = e.as_ref().map(|e| e.kind());
            assert_eq!(
                kind,
                Some(clap::error::ErrorKind::ArgumentConflict),
                "{extra:?}: {e:?}"
            );
        }
    }

    /// Regression (error_cause_printed_twice, 2026-12-02): a scene file that could not be
    /// read printed "…: cannot read: No such file or directory (os error 2): No such file
    /// or directory (os error 2)", the io error once in SceneError's text and once as
    /// its source.
    #[test]
    fn an_error_prints_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        let scene = couplet_protocol::scene::SceneError::Io {
            file: "s.toml".into(),
            source: io,
        };
        let e = anyhow::Error::new(scene).context("analysing d");
        assert_eq!(chain_text(&e), "analysing d: s.toml: cannot read: gone");
        // A cause that is not in its parent's text is still printed.
        let e = anyhow::anyhow!("inner").context("outer");
        assert_eq!(chain_text(&e), "outer: inner");
    }
}
