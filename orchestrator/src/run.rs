//! `couplet run`: the serial-explicit coupling loop between the fluid and DEM servers.
//!
//! Per window n (DESIGN.md "One coupling step"): the orchestrator sends `Advance(n)` to
//! every server; the DEM publishes states and points for t_n; the fluid advances and
//! publishes loads; the DEM advances with the loads held; each side reports. The
//! orchestrator records what crossed and starts window n+1 when both reports are in.
//! It waits spin-then-block on its wake event and checks its children after every
//! block slice (100 ms), so a dead server stops the run within a second.

use crate::launch::{LaunchError, Server};
use crate::record::{RecordError, Recorder};
use crate::window::{WindowPlan, choose_window};
use couplet_protocol::transport::{Endpoint, TransportError, ValueReceiver};
use couplet_protocol::{
    BodyLoad, BodyState, Command, CommandKind, HandshakeError, Hello, PROTOCOL_VERSION,
    ParticleRecord, Role, Scene, SceneError, ServiceLeaf, SideReport, check_hello,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How long the servers may take to start (GPU device creation and pipeline compilation
/// on lavapipe take seconds; the grid and particle set up of a large scene more).
const HELLO_TIMEOUT: Duration = Duration::from_secs(300);

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Launch(#[from] LaunchError),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error(transparent)]
    Record(#[from] RecordError),
    #[error(transparent)]
    Handshake(#[from] HandshakeError),
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    #[error("the scene has neither fluid nor bodies: nothing to simulate")]
    Empty,
}

/// What `couplet run` (and `bench`) is asked to do.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub scene: PathBuf,
    /// Output folder (recording, resolved scene). None: `out/<scene name>`.
    pub out: Option<PathBuf>,
    /// Scene overrides `(dotted.path, TOML value)`, applied in order (`--set`, `--spacing`).
    pub overrides: Vec<(String, String)>,
    /// Stop after this many windows (benchmarks); None: run to `time.end`.
    pub max_windows: Option<u64>,
    /// Write an MCAP recording.
    pub record: bool,
    /// Show a progress bar.
    pub progress: bool,
}

/// Measured over a run.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    pub windows: u64,
    pub sim_time: f64,
    pub wall_s: f64,
    pub plan: Option<WindowPlan>,
    pub recording: Option<PathBuf>,
    /// Mean per window (from window 1: window 0 carries set-up), µs: fluid compute, DEM
    /// compute, exchange (both directions: points+states to the fluid, loads to the DEM,
    /// hop time plus validation/copy/upload), and the window's whole wall time as the
    /// orchestrator sees it.
    pub fluid_compute_us: f64,
    pub dem_compute_us: f64,
    pub exchange_us: f64,
    pub window_wall_us: f64,
    pub fluid_substeps: u64,
    /// Fluid particle-steps that kept the uncorrected gradient (near-singular truncation
    /// matrix, Joubert eq. 10), over the run.
    pub near_singular: u64,
    /// Last body states received.
    pub final_states: Vec<BodyState>,
    /// Every window's states of body 0 (time, height, vertical velocity) for validation.
    pub body0_track: Vec<(f64, [f64; 3], [f64; 3])>,
}

/// Loads a scene and applies the command-line overrides; returns the scene and the TOML
/// text the servers will load (written next to the recording).
pub fn resolve_scene(
    path: &Path,
    overrides: &[(String, String)],
) -> Result<(Scene, String), RunError> {
    let mut text = std::fs::read_to_string(path).map_err(|source| {
        RunError::Scene(SceneError::Io {
            file: path.to_owned(),
            source,
        })
    })?;
    for (field, value) in overrides {
        text = couplet_protocol::scene::override_field(&text, path, field, value)?;
    }
    let scene = Scene::parse(&text, path)?;
    Ok((scene, text))
}

struct Peers {
    fluid: Option<Server>,
    dem: Option<Server>,
}

impl Peers {
    fn check(&mut self) -> Result<(), TransportError> {
        for s in [self.fluid.as_mut(), self.dem.as_mut()]
            .into_iter()
            .flatten()
        {
            s.check()
                .map_err(|e| TransportError::PeerGone(e.to_string()))?;
        }
        Ok(())
    }
}

/// Runs a scene end to end.
pub fn run(opts: &RunOptions) -> Result<RunSummary, RunError> {
    let (scene, text) = resolve_scene(&opts.scene, &opts.overrides)?;
    for w in scene.warnings() {
        eprintln!("warning: {w}");
    }
    let has_fluid = scene.fluid.is_some();
    let has_dem = scene.needs_dem();
    if !has_fluid && !has_dem {
        return Err(RunError::Empty);
    }
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.meta.name));
    std::fs::create_dir_all(&out).map_err(|source| RunError::Io {
        what: format!("creating {}", out.display()),
        source,
    })?;
    let scene_path = out.join("scene.toml");
    std::fs::write(&scene_path, &text).map_err(|source| RunError::Io {
        what: format!("writing {}", scene_path.display()),
        source,
    })?;

    let run_id = format!(
        "{}-{}",
        std::process::id(),
        couplet_protocol::monotonic_ns() % 1_000_000_000
    );
    let ep = Endpoint::new(&run_id)?;
    let commands = ep.value_sender::<Command>(ServiceLeaf::Command)?;
    let hellos = ep.value_receiver::<Hello>(ServiceLeaf::Hello)?;
    let reports = ep.value_receiver::<SideReport>(ServiceLeaf::Report)?;
    let bodies_rx = ep.slice_receiver::<BodyState>(ServiceLeaf::Bodies)?;
    let loads_rx = ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads)?;
    let particles_rx = ep.slice_receiver::<ParticleRecord>(ServiceLeaf::Particles)?;
    let wake = ep.wake_listener(ServiceLeaf::OrchestratorWake)?;
    let wake_fluid = ep.waker(ServiceLeaf::FluidWake)?;
    let wake_dem = ep.waker(ServiceLeaf::DemWake)?;

    let mut recorder = if opts.record {
        Some(Recorder::create(
            &out.join("run.mcap"),
            &scene.meta.name,
            &text,
        )?)
    } else {
        None
    };

    let mut peers = Peers {
        fluid: if has_fluid {
            Some(Server::spawn(Role::Fluid, &run_id, &scene_path)?)
        } else {
            None
        },
        dem: if has_dem {
            Some(Server::spawn(Role::Dem, &run_id, &scene_path)?)
        } else {
            None
        },
    };
    let result = drive(
        &scene,
        opts,
        &mut peers,
        &mut recorder,
        Ports {
            commands: &commands,
            hellos: &hellos,
            reports: &reports,
            bodies_rx: &bodies_rx,
            loads_rx: &loads_rx,
            particles_rx: &particles_rx,
            wake: &wake,
            wake_fluid: &wake_fluid,
            wake_dem: &wake_dem,
        },
    );

    // On success the servers are told to shut down and given time to exit cleanly; on
    // failure the run is lost and the survivors are killed at once (one may be blocked
    // waiting for data from the dead one), so the error surfaces within a second.
    let grace = if result.is_ok() {
        Duration::from_secs(5)
    } else {
        Duration::ZERO
    };
    let _ = commands.send(Command {
        protocol_version: PROTOCOL_VERSION,
        kind: CommandKind::Shutdown as u32,
        ..Default::default()
    });
    let _ = wake_fluid.wake();
    let _ = wake_dem.wake();
    for s in [peers.fluid.as_mut(), peers.dem.as_mut()]
        .into_iter()
        .flatten()
    {
        s.finish(grace);
    }
    let recording = recorder.as_ref().map(|r| r.path().to_owned());
    if let Some(r) = recorder.as_mut() {
        r.close()?;
    }
    let mut summary = result?;
    summary.recording = recording;
    Ok(summary)
}

struct Ports<'a> {
    commands: &'a couplet_protocol::transport::ValueSender<Command>,
    hellos: &'a ValueReceiver<Hello>,
    reports: &'a ValueReceiver<SideReport>,
    bodies_rx: &'a couplet_protocol::transport::SliceReceiver<BodyState>,
    loads_rx: &'a couplet_protocol::transport::SliceReceiver<BodyLoad>,
    particles_rx: &'a couplet_protocol::transport::SliceReceiver<ParticleRecord>,
    wake: &'a couplet_protocol::transport::WakeListener,
    wake_fluid: &'a couplet_protocol::transport::Waker,
    wake_dem: &'a couplet_protocol::transport::Waker,
}

fn drive(
    scene: &Scene,
    opts: &RunOptions,
    peers: &mut Peers,
    recorder: &mut Option<Recorder>,
    p: Ports<'_>,
) -> Result<RunSummary, RunError> {
    // Handshake: every server says hello once its ports exist; a wrong version is refused.
    let (mut fluid_hello, mut dem_hello) = (None::<Hello>, None::<Hello>);
    let expect_fluid = peers.fluid.is_some();
    let expect_dem = peers.dem.is_some();
    let start = Instant::now();
    while (expect_fluid && fluid_hello.is_none()) || (expect_dem && dem_hello.is_none()) {
        let h = p.wake.wait_for(
            || p.hellos.try_next(),
            || {
                peers.check()?;
                if start.elapsed() > HELLO_TIMEOUT {
                    return Err(TransportError::PeerGone(format!(
                        "no hello within {HELLO_TIMEOUT:?}"
                    )));
                }
                Ok(())
            },
        )?;
        match check_hello(&h)? {
            Role::Dem => dem_hello = Some(h),
            _ => fluid_hello = Some(h),
        }
    }

    let plan = choose_window(
        scene,
        fluid_hello.map(|h| h.dt_limit),
        dem_hello.map(|h| h.dt_limit),
    );
    let windows = opts
        .max_windows
        .map_or(plan.windows, |m| m.min(plan.windows));
    let bar = progress_bar(
        opts.progress,
        scene.time.end.min(windows as f64 * plan.window),
    );

    let mut summary = RunSummary {
        plan: Some(plan.clone()),
        ..Default::default()
    };
    let mut next_output = scene.time.output_interval;
    let run_start = Instant::now();
    let (mut fluid_compute, mut dem_compute, mut exchange, mut window_wall) = (0.0, 0.0, 0.0, 0.0);
    let mut last_states: Vec<BodyState> = Vec::new();
    // The first window's states are recorded: the start of every track.
    let mut next_body_record = 0.0;

    for step in 0..windows {
        let time = step as f64 * plan.window;
        let end = time + plan.window;
        // Snapshot at every output time the window reaches (and at the very end).
        let snapshot = expect_fluid && (end >= next_output * (1.0 - 1e-9) || step + 1 == windows);
        if snapshot {
            while next_output <= end * (1.0 + 1e-9) {
                next_output += scene.time.output_interval;
            }
        }
        let w_start = Instant::now();
        p.commands.send(Command {
            protocol_version: PROTOCOL_VERSION,
            kind: CommandKind::Advance as u32,
            step,
            time,
            window: plan.window,
            snapshot: snapshot as u32,
            _pad: 0,
        })?;
        if expect_fluid {
            p.wake_fluid.wake()?;
        }
        if expect_dem {
            p.wake_dem.wake()?;
        }

        let (mut fluid_report, mut dem_report) = (None::<SideReport>, None::<SideReport>);
        p.wake.wait_for(
            || {
                while let Some(r) = p.reports.try_next()? {
                    if r.step != step {
                        return Err(TransportError::OutOfSequence {
                            service: "report".into(),
                            expected: step,
                            got: r.step,
                        });
                    }
                    match Role::from_u32(r.role) {
                        Some(Role::Fluid) => fluid_report = Some(r),
                        Some(Role::Dem) => dem_report = Some(r),
                        _ => {}
                    }
                }
                Ok(((!expect_fluid || fluid_report.is_some())
                    && (!expect_dem || dem_report.is_some()))
                .then_some(()))
            },
            || peers.check(),
        )?;
        // Window 0 also carries one-off set-up (the fluid's first markers rebuild its
        // buffers), so the per-window means start at window 1 when there is one.
        if step > 0 || windows == 1 {
            window_wall += w_start.elapsed().as_secs_f64() * 1e6;
            if let Some(r) = &fluid_report {
                fluid_compute += r.compute_us;
                exchange += r.exchange_us;
            }
            if let Some(r) = &dem_report {
                dem_compute += r.compute_us;
                exchange += r.exchange_us;
            }
        }
        if let Some(r) = &fluid_report {
            summary.fluid_substeps += r.substeps as u64;
            summary.near_singular += u64::from(r.near_singular);
        }

        // Drain what crossed this window; record it (bodies and loads every window, or
        // at `time.body_output_interval`).
        let record_bodies = match scene.time.body_output_interval {
            Some(interval) if end + 1e-9 * interval < next_body_record && step + 1 < windows => {
                false
            }
            Some(interval) => {
                while next_body_record <= end + 1e-9 * interval {
                    next_body_record += interval;
                }
                true
            }
            None => true,
        };
        while let Some(s) = p.bodies_rx.try_latest()? {
            last_states.clear();
            last_states.extend_from_slice(s.payload());
            let t = s.user_header().time;
            if let Some(b) = last_states.first() {
                summary.body0_track.push((t, b.position, b.linear_velocity));
            }
            if let Some(r) = recorder.as_ref().filter(|_| record_bodies) {
                r.bodies(t, &last_states);
            }
        }
        if let Some(s) = p.loads_rx.try_latest()? {
            if let Some(r) = recorder.as_ref().filter(|_| record_bodies) {
                r.loads(time, s.payload());
            }
        }
        if snapshot {
            let s = p
                .wake
                .wait_for(|| p.particles_rx.try_step(step), || peers.check())?;
            if let Some(r) = recorder.as_ref() {
                r.particles(s.user_header().time, s.payload());
            }
        }
        if let Some(r) = recorder.as_ref() {
            r.window(
                step,
                time,
                plan.window,
                fluid_report.as_ref(),
                dem_report.as_ref(),
            );
        }
        bar.set_position((end * 1e6) as u64);
        bar.set_message(format!("{end:.4}"));
        summary.windows = step + 1;
        summary.sim_time = end;
    }
    bar.finish_and_clear();
    let n = if summary.windows > 1 {
        summary.windows - 1
    } else {
        1
    } as f64;
    summary.wall_s = run_start.elapsed().as_secs_f64();
    summary.fluid_compute_us = fluid_compute / n;
    summary.dem_compute_us = dem_compute / n;
    summary.exchange_us = exchange / n;
    summary.window_wall_us = window_wall / n;
    summary.final_states = last_states;
    Ok(summary)
}

/// Simulated time (µs resolution) as position: the bar shows simulated time, speed
/// (simulated per wall second) and ETA.
fn progress_bar(show: bool, end: f64) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new((end * 1e6) as u64);
    let style = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} t = {msg} s  ({per_sec} sim-µs/s, ETA {eta})",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}
