//! `couplet ctl`: the command-line client of `couplet serve` (the same gRPC API any
//! other client uses).

use anyhow::Context;
use clap::Subcommand;
use couplet_protocol::grpc::{
    CreateRunRequest, DeleteRunRequest, ListEnginesRequest, ListRunsRequest, Override,
    RestoreRunRequest, Run, RunRequest, RunState, SetParameterRequest, StepRunRequest, Vec3,
    WindowFrame, couplet_client::CoupletClient, watch_event,
};
use std::path::PathBuf;
use tonic::metadata::{Ascii, MetadataValue};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

/// Where the server is and how to reach it.
#[derive(clap::Args, Clone)]
pub struct Connection {
    /// The server's address (`https://…` for TLS).
    #[arg(long, default_value = "http://127.0.0.1:50051")]
    pub server: String,
    /// File holding the bearer token the server was started with (`serve --token-file`).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// CA certificate (PEM) to verify an `https://` server with.
    #[arg(long)]
    pub ca_cert: Option<PathBuf>,
}

#[derive(Subcommand, Clone)]
pub enum CtlCmd {
    /// Create a run from a scene file (its servers start; it waits READY unless --start).
    Create {
        scene: PathBuf,
        /// Override a scene field, as `couplet run --set PATH=VALUE`.
        #[arg(long = "set", value_name = "PATH=VALUE")]
        set: Vec<String>,
        /// Write no MCAP recording.
        #[arg(long)]
        no_record: bool,
        /// Start it at once.
        #[arg(long)]
        start: bool,
    },
    /// Run a READY run to its end time.
    Start { run: String },
    /// Pause at the next window boundary.
    Pause { run: String },
    /// Continue a paused run.
    Resume { run: String },
    /// Advance a READY or PAUSED run by N coupling windows, then pause.
    Step { run: String, windows: u64 },
    /// Stop a run: its servers shut down and its recording is closed.
    Stop { run: String },
    /// Show one run.
    Get { run: String },
    /// List the server's runs.
    List,
    /// Forget an ended run (with --files, remove its output folder too).
    Delete {
        run: String,
        #[arg(long)]
        files: bool,
    },
    /// Print one line per window (and the bodies) until the run ends.
    Watch {
        run: String,
        /// Bodies printed per window (the first N by index).
        #[arg(long, default_value_t = 4)]
        bodies: usize,
    },
    /// Change a live parameter: `time.output_interval`, `gravity.vector`,
    /// `bodies.NAME.velocity` or `bodies.NAME.angular_velocity` (a kinematic body; NAME
    /// or its index), the value as TOML (`'[0, -9.81, 0]'`).
    Set {
        run: String,
        path: String,
        value: String,
    },
    /// Write a checkpoint at the next window boundary; prints its folder.
    Checkpoint { run: String },
    /// Create a run that continues from a checkpoint folder (as `checkpoint` printed
    /// it, or relative to the server's data folder), READY at its window.
    Restore {
        checkpoint: String,
        /// Write no MCAP recording.
        #[arg(long)]
        no_record: bool,
        /// Start it at once.
        #[arg(long)]
        start: bool,
    },
    /// The DEM engines the server offers.
    Engines,
}

/// Adds `authorization: Bearer …` to every call when a token is given.
#[derive(Clone)]
struct Token(Option<MetadataValue<Ascii>>);

impl tonic::service::Interceptor for Token {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(t) = &self.0 {
            req.metadata_mut().insert("authorization", t.clone());
        }
        Ok(req)
    }
}

type Client = CoupletClient<InterceptedService<Channel, Token>>;

async fn connect(c: &Connection) -> anyhow::Result<Client> {
    let mut ep =
        Channel::from_shared(c.server.clone()).with_context(|| format!("--server {}", c.server))?;
    if let Some(ca) = &c.ca_cert {
        let pem = std::fs::read(ca).with_context(|| format!("reading {}", ca.display()))?;
        ep = ep.tls_config(
            tonic::transport::ClientTlsConfig::new()
                .ca_certificate(tonic::transport::Certificate::from_pem(pem)),
        )?;
    }
    let channel = ep
        .connect()
        .await
        .with_context(|| format!("connecting to {}", c.server))?;
    let token = match &c.token_file {
        Some(f) => {
            let t =
                std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
            Some(
                format!("Bearer {}", t.trim())
                    .parse()
                    .context("the token must be printable ASCII")?,
            )
        }
        None => None,
    };
    Ok(CoupletClient::with_interceptor(channel, Token(token)))
}

/// Runs one `couplet ctl` command.
pub fn ctl(conn: &Connection, cmd: CtlCmd) -> anyhow::Result<()> {
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async move {
        let mut c = connect(conn).await?;
        let id = |run: &str| RunRequest {
            run_id: run.to_owned(),
        };
        match cmd {
            CtlCmd::Create {
                scene,
                set,
                no_record,
                start,
            } => {
                let scene_toml = std::fs::read_to_string(&scene)
                    .with_context(|| format!("reading {}", scene.display()))?;
                let overrides = set
                    .iter()
                    .map(|kv| {
                        kv.split_once('=')
                            .map(|(p, v)| Override {
                                path: p.trim().to_owned(),
                                value: v.trim().to_owned(),
                            })
                            .ok_or_else(|| anyhow::anyhow!("--set {kv}: expected PATH=VALUE"))
                    })
                    .collect::<anyhow::Result<_>>()?;
                let mut r = c
                    .create_run(CreateRunRequest {
                        scene_toml,
                        overrides,
                        skip_recording: no_record,
                    })
                    .await?
                    .into_inner();
                if start {
                    r = c.start_run(id(&r.run_id)).await?.into_inner();
                }
                print!("{}", run_text_with(&r, true));
            }
            CtlCmd::Start { run } => {
                print!("{}", run_text(&c.start_run(id(&run)).await?.into_inner()))
            }
            CtlCmd::Pause { run } => {
                print!("{}", run_text(&c.pause_run(id(&run)).await?.into_inner()))
            }
            CtlCmd::Resume { run } => {
                print!("{}", run_text(&c.resume_run(id(&run)).await?.into_inner()))
            }
            CtlCmd::Step { run, windows } => {
                let r = c
                    .step_run(StepRunRequest {
                        run_id: run,
                        windows,
                    })
                    .await?
                    .into_inner();
                print!("{}", run_text(&r));
            }
            CtlCmd::Stop { run } => {
                print!("{}", run_text(&c.stop_run(id(&run)).await?.into_inner()))
            }
            CtlCmd::Get { run } => {
                print!(
                    "{}",
                    run_text_with(&c.get_run(id(&run)).await?.into_inner(), true)
                )
            }
            CtlCmd::List => {
                let runs = c.list_runs(ListRunsRequest {}).await?.into_inner().runs;
                if runs.is_empty() {
                    println!("no runs");
                }
                for r in runs {
                    print!("{}", run_text(&r));
                }
            }
            CtlCmd::Delete { run, files } => {
                let r = c
                    .delete_run(DeleteRunRequest {
                        run_id: run,
                        delete_files: files,
                    })
                    .await?
                    .into_inner();
                println!(
                    "deleted {}{}",
                    r.run_id,
                    if r.files_deleted {
                        " and its folder"
                    } else {
                        ""
                    }
                );
            }
            CtlCmd::Watch { run, bodies } => {
                let mut s = c.watch_run(id(&run)).await?.into_inner();
                while let Some(e) = s.message().await? {
                    match e.event {
                        Some(watch_event::Event::Frame(f)) => print!("{}", frame_text(&f, bodies)),
                        Some(watch_event::Event::Ended(r)) => print!("{}", run_text(&r)),
                        None => {}
                    }
                }
            }
            CtlCmd::Set { run, path, value } => {
                let r = c
                    .set_parameter(SetParameterRequest {
                        run_id: run,
                        path,
                        value,
                    })
                    .await?
                    .into_inner();
                print!("{}", run_text(&r));
            }
            CtlCmd::Checkpoint { run } => {
                let r = c.checkpoint(id(&run)).await?.into_inner();
                println!(
                    "{}: checkpoint of window {} (t = {:.6} s) in {}",
                    r.run_id, r.step, r.time, r.path
                );
            }
            CtlCmd::Restore {
                checkpoint,
                no_record,
                start,
            } => {
                let mut r = c
                    .restore_run(RestoreRunRequest {
                        checkpoint,
                        skip_recording: no_record,
                    })
                    .await?
                    .into_inner();
                if start {
                    r = c.start_run(id(&r.run_id)).await?.into_inner();
                }
                print!("{}", run_text_with(&r, true));
            }
            CtlCmd::Engines => {
                for e in c
                    .list_engines(ListEnginesRequest {})
                    .await?
                    .into_inner()
                    .engines
                {
                    println!("{}{}", e.name, if e.is_default { " (default)" } else { "" });
                }
            }
        }
        Ok(())
    })
}

/// A run in a few lines (its scene's warnings only where asked: create and get).
fn run_text(r: &Run) -> String {
    run_text_with(r, false)
}

fn run_text_with(r: &Run, warnings: bool) -> String {
    let state = RunState::try_from(r.state).map_or("?", |s| s.as_str_name());
    let mut t = format!(
        "{}  {}  {}  window {}/{}  t = {:.6} / {:.6} s  wall {:.1} s\n",
        r.run_id,
        r.scene_name,
        state.trim_start_matches("RUN_STATE_"),
        r.windows_done,
        r.windows_total,
        r.time,
        r.end_time,
        r.wall_seconds
    );
    if r.window > 0.0 {
        t += &format!("  Δt_w = {:.3e} s: {}\n", r.window, r.window_reason);
    }
    t += &format!(
        "  output: {} (snapshots every {} s)  gravity {} m/s²\n",
        r.output_dir,
        r.output_interval,
        v(&r.gravity)
    );
    for w in r.warnings.iter().filter(|_| warnings) {
        t += &format!("  warning: {w}\n");
    }
    if !r.error.is_empty() {
        t += &format!("  error: {}\n", r.error);
    }
    t
}

fn v(x: &Option<Vec3>) -> String {
    x.as_ref().map_or("-".into(), |v| {
        format!("[{:.5e}, {:.5e}, {:.5e}]", v.x, v.y, v.z)
    })
}

fn frame_text(f: &WindowFrame, bodies: usize) -> String {
    let mut t = format!(
        "window {}  t = {:.6e} s  fluid {} substeps  DEM {}  wall {:.2} ms",
        f.step,
        f.time,
        f.fluid_substeps,
        f.dem_substeps,
        f.wall_seconds * 1e3
    );
    if f.missed > 0 {
        t += &format!("  ({} windows missed: this client was too slow)", f.missed);
    }
    t.push('\n');
    if f.fluid_substeps > 0 {
        t += &format!(
            "  fluid: kinetic energy {:.4e} J  |u|max {:.4e} m/s  |ρ/ρ0 − 1|max {:.3e}\n",
            f.kinetic_energy, f.max_speed, f.max_density_error
        );
    }
    for b in f.bodies.iter().take(bodies) {
        t += &format!(
            "  body {}: x = {}  v = {}  F = {}\n",
            b.body,
            v(&b.position),
            v(&b.linear_velocity),
            v(&b.force)
        );
    }
    if f.bodies.len() > bodies {
        t += &format!(
            "  … {} more bodies (--bodies N prints more)\n",
            f.bodies.len() - bodies
        );
    }
    t
}
