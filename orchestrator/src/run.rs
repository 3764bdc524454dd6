//! `couplet run`: the serial-explicit coupling loop between the fluid and DEM servers.
//!
//! Per window n (DESIGN.md "One coupling step"): the orchestrator sends `Advance(n)` to
//! every server; the DEM publishes states and points for t_n; the fluid advances and
//! publishes loads; the DEM advances with the loads held; each side reports. The
//! orchestrator records what crossed and starts window n+1 when both reports are in.
//! It waits spin-then-block on its wake event and checks its children after every
//! block slice (100 ms), so a dead server stops the run within a second.

use crate::interrupt::Interrupt;
use crate::launch::{LaunchError, Server};
use crate::outputs::Outputs;
use crate::record::RecordError;
use crate::window::{WindowPlan, choose_window};
use couplet_protocol::state::{
    StateDirs, StateError, checkpoint_dir, read_state, state_file, write_state,
};
use couplet_protocol::transport::{
    Endpoint, SliceReceiver, TransportError, ValueReceiver, ValueSender, WakeListener, Waker,
    node_alive,
};
use couplet_protocol::{
    BodyLoad, BodyState, Command, CommandKind, HandshakeError, Hello, Motion, PROTOCOL_VERSION,
    ParticleRecord, Role, Scene, SceneError, ServiceLeaf, SideReport, check_hello_for,
    scene_digest,
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
    /// Resuming a run across sittings (`crate::resume`).
    #[error("{0}")]
    Resume(String),
    #[error(transparent)]
    State(#[from] StateError),
    /// A live change the run cannot take (the message says why and what can).
    #[error("{0}")]
    Refused(String),
    /// A server answered a command out of turn.
    #[error("the {role} answered command {got} while the orchestrator waited for {expected}")]
    UnexpectedReport {
        role: &'static str,
        got: u32,
        expected: u32,
    },
    #[error("--external {role}: this scene starts no {role} (it has {what})")]
    ExternalUnused {
        role: &'static str,
        what: &'static str,
    },
    #[error(
        "run id `{0}` is taken: a live orchestrator already runs it (give each run its own --run-id)"
    )]
    RunIdTaken(String),
    /// Ctrl-C or SIGTERM ([`crate::interrupt`]): the run stopped between windows.
    #[error(
        "interrupted by {signal} at t = {time:.6e} s of {end:.6e} s, after {windows} windows{how}"
    )]
    Interrupted {
        signal: String,
        time: f64,
        end: f64,
        windows: u64,
        /// How the run stopped and what is left of it.
        how: String,
    },
}

impl RunError {
    pub fn is_interrupted(&self) -> bool {
        matches!(self, Self::Interrupted { .. })
    }
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
    /// Write the outputs: `run.mcap`, and `bodies.csv` and VTK as the scene's `[output]` asks.
    pub record: bool,
    /// Show a progress bar.
    pub progress: bool,
    /// The run's id (iceoryx2 namespace); None: made up from the pid and the clock.
    pub run_id: Option<String>,
    /// Servers started apart (`couplet ROLE RUN_ID SCENE --detached`), not by this run.
    pub external: Vec<Role>,
    /// Write a checkpoint (`OUT/checkpoints/step-N`) whenever this much wall time has
    /// passed since the run started or since the last one, keeping only the newest
    /// (`crate::resume`). None: none.
    pub checkpoint_every: Option<Duration>,
    /// Continue from this checkpoint folder instead of the scene's initial state; `scene`
    /// must be its `scene.toml` and `overrides` empty. None: a fresh run, which removes
    /// the later sittings (`resume-N`) a resumed run left in OUT.
    pub restore: Option<PathBuf>,
}

/// Measured over a run.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    pub windows: u64,
    pub sim_time: f64,
    pub wall_s: f64,
    /// Wall time of the sittings before this one, from the checkpoint it continued
    /// from (0 for a run from the start), s.
    pub earlier_wall_s: f64,
    /// This sitting's first window and its start time, s (0 and 0 for a run from the
    /// start): `windows` and `sim_time` count from window 0 and t = 0, while `wall_s`
    /// and the per-window means cover this sitting only.
    pub first_window: u64,
    pub first_time: f64,
    pub plan: Option<WindowPlan>,
    pub recording: Option<PathBuf>,
    /// Mean per window of this sitting (from its second: its first carries set-up), µs:
    /// fluid compute, DEM compute, exchange (both directions: points+states to the
    /// fluid, loads to the DEM, hop time plus validation/copy/upload), and the window's
    /// whole wall time as the orchestrator sees it.
    pub fluid_compute_us: f64,
    pub dem_compute_us: f64,
    pub exchange_us: f64,
    pub window_wall_us: f64,
    /// Mean per window, µs: the orchestrator's own work after both reports came in
    /// (the states and loads drained and recorded, a particle snapshot awaited and
    /// written), during which neither server computes. Not in `window_wall_us`.
    pub after_reports_us: f64,
    pub fluid_substeps: u64,
    /// Fluid particle-steps that kept the uncorrected gradient (near-singular truncation
    /// matrix, Joubert eq. 10), over the run.
    pub near_singular: u64,
    /// Fluid particle-steps mirrored back out of a resolved body or across a wall face,
    /// over the run.
    pub reflected: u64,
    /// Fluid particle-steps whose shift was cut short δ/2 in front of a resolved body's
    /// surface (couplet_fluid::particle_shifting::limit_toward_surface), over the run.
    pub shift_limited: u64,
    /// Last body states received.
    pub final_states: Vec<BodyState>,
    /// Every window's states of body 0 (time, height, vertical velocity) for validation.
    pub body0_track: Vec<(f64, [f64; 3], [f64; 3])>,
}

impl RunSummary {
    /// Where a window's time went, on one line (`couplet run`'s summary; `couplet
    /// validate` and a stopped run print it too).
    pub fn per_window(&self) -> String {
        format!(
            "per window: {:.1} µs wall; fluid {:.1} µs ({} substeps total); DEM {:.1} µs; exchange {:.1} µs ({:.2} %); then recording {:.1} µs",
            self.window_wall_us,
            self.fluid_compute_us,
            self.fluid_substeps,
            self.dem_compute_us,
            self.exchange_us,
            100.0 * self.exchange_us / self.window_wall_us.max(1e-9),
            self.after_reports_us,
        )
    }
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

/// A server of the run: a child process, or one started apart (`--external`).
enum Peer {
    Child(Server),
    External {
        role: Role,
        run_id: String,
        greeted: bool,
    },
}

impl Peer {
    fn check(&mut self) -> Result<(), TransportError> {
        match self {
            Peer::Child(s) => s
                .check()
                .map_err(|e| TransportError::PeerGone(e.to_string())),
            // Before its hello the handshake's time-out bounds the wait; after it the
            // server's iceoryx2 node is its pulse (it is no child to wait on).
            Peer::External { greeted: false, .. } => Ok(()),
            Peer::External { role, run_id, .. } => {
                if node_alive(run_id, role.name())? {
                    Ok(())
                } else {
                    Err(TransportError::PeerGone(format!(
                        "the {} of run {run_id}, started apart, has exited (its iceoryx2 node is gone)",
                        role.name()
                    )))
                }
            }
        }
    }
}

struct Peers {
    fluid: Option<Peer>,
    dem: Option<Peer>,
}

impl Peers {
    fn check(&mut self) -> Result<(), TransportError> {
        for p in [self.fluid.as_mut(), self.dem.as_mut()]
            .into_iter()
            .flatten()
        {
            p.check()?;
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
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.meta.name));
    let end = scene.time.end;
    if opts.restore.is_none() && opts.record {
        crate::resume::remove_sittings_from(&out, 0).map_err(RunError::Resume)?;
    }
    let launched = CoupledRun::launch(
        scene,
        &text,
        &out,
        &LaunchOptions {
            record: opts.record,
            max_windows: opts.max_windows,
            server_exe: None,
            restore: opts.restore.clone(),
            run_id: opts.run_id.clone(),
            external: opts.external.clone(),
        },
    );
    let mut run = match (launched, crate::interrupt::requested()) {
        (Ok(run), _) => run,
        (Err(_), Some(signal)) => {
            return Err(RunError::Interrupted {
                signal: signal.name(),
                time: 0.0,
                end,
                windows: 0,
                how: " (while the servers started)".into(),
            });
        }
        (Err(e), None) => return Err(e),
    };
    let mut progress = Progress::new(opts.progress, run.end_time());
    let mut result = Ok(());
    let recording = opts.record.then(|| out.join("run.mcap"));
    let mut checkpoints = Checkpoints::new(opts.checkpoint_every);
    while !run.done() {
        match run.advance() {
            Ok(w) => progress.update(w.end),
            Err(e) => {
                result = Err(e);
                break;
            }
        }
        if let Err(e) = checkpoints.after_window(&mut run) {
            result = Err(e);
            break;
        }
        // Read after the window: one in progress when the signal came is finished.
        if let Some(signal) = crate::interrupt::requested() {
            result = Err(interrupted(&run, signal, recording.as_deref(), false));
            break;
        }
    }
    progress.finish();
    // A signal sent to the whole process group (`timeout`, `kill -- -PGID`) also ends the
    // servers, which fails the window in progress: that too is the interruption.
    if let (Err(e), Some(signal)) = (&result, crate::interrupt::requested())
        && !e.is_interrupted()
    {
        result = Err(interrupted(&run, signal, recording.as_deref(), true));
    }
    let summary = run.close(matches!(result, Ok(()) | Err(RunError::Interrupted { .. })));
    // A stopped run's summary is not returned: where its windows' time went is said here
    // (a run cut by a time limit on a GPU machine is often all there is to go by).
    if let (Err(RunError::Interrupted { .. }), Ok(s), true) = (&result, &summary, opts.progress) {
        eprintln!("{}", s.per_window());
    }
    result?;
    summary
}

/// `RunOptions::checkpoint_every` at work: a checkpoint after the window that ends a
/// stretch of that much wall time, the one before removed once the new one is whole.
struct Checkpoints {
    every: Option<Duration>,
    since: Instant,
    last: Option<PathBuf>,
}

impl Checkpoints {
    fn new(every: Option<Duration>) -> Self {
        Self {
            every,
            since: Instant::now(),
            last: None,
        }
    }

    /// After each window: a checkpoint when one is due and the plan has windows left (a
    /// run stopped by `max_windows` still has).
    fn after_window(&mut self, run: &mut CoupledRun) -> Result<(), RunError> {
        let Some(every) = self.every else {
            return Ok(());
        };
        if self.since.elapsed() < every || run.windows_done() >= run.plan().windows {
            return Ok(());
        }
        let dir = run.checkpoint()?;
        if let Some(old) = self.last.replace(dir) {
            std::fs::remove_dir_all(&old).map_err(|source| RunError::Io {
                what: format!("removing the older checkpoint {}", old.display()),
                source,
            })?;
        }
        self.since = Instant::now();
        Ok(())
    }
}

/// The error of a run that `signal` stopped after its last complete window.
fn interrupted(
    run: &CoupledRun,
    signal: Interrupt,
    recording: Option<&Path>,
    lost: bool,
) -> RunError {
    let mut how = String::new();
    if lost {
        how += " (the signal ended the servers too: the window in progress is lost)";
    }
    if let Some(r) = recording {
        how += &format!("; the recording {} is closed there", r.display());
    }
    RunError::Interrupted {
        signal: signal.name(),
        time: run.windows_done() as f64 * run.plan().window,
        end: run.end_time(),
        windows: run.windows_done(),
        how,
    }
}

/// How [`CoupledRun::launch`] starts a run.
#[derive(Debug, Clone, Default)]
pub struct LaunchOptions {
    /// Write the outputs to `OUT` (`run.mcap`, and `bodies.csv` and VTK as the scene's
    /// `[output]` asks; `outputs.rs`).
    pub record: bool,
    /// Stop after this many windows (benchmarks); None: run to `time.end`.
    pub max_windows: Option<u64>,
    /// The executable to start in the server roles (`EXE fluid-server RUN_ID SCENE`);
    /// None: this executable, which is the `couplet` CLI.
    pub server_exe: Option<PathBuf>,
    /// Continue from this checkpoint folder (`OUT/checkpoints/step-N` of an earlier run,
    /// written by [`CoupledRun::checkpoint`]) instead of the scene's initial state; the
    /// scene must be the checkpoint's own `scene.toml`.
    pub restore: Option<PathBuf>,
    /// The run's id (iceoryx2 namespace); None: made up from the pid and the clock.
    pub run_id: Option<String>,
    /// Roles not to start: servers started apart (`couplet ROLE RUN_ID SCENE --detached`),
    /// waited for by their hello and watched through their iceoryx2 nodes.
    pub external: Vec<Role>,
}

/// The orchestrator's part of a checkpoint: where the run stands between windows.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct OrchestratorState {
    step: u64,
    plan: WindowPlan,
    output_interval: f64,
    next_output: f64,
    next_body_record: f64,
    last_states: Vec<BodyState>,
    last_loads: Vec<BodyLoad>,
    prescribed: Vec<([f64; 3], [f64; 3])>,
    /// Wall time the run had taken, over all its sittings, s.
    wall_s: f64,
}

/// The scene file a checkpoint folder holds: the run's scene with every live change
/// made before the checkpoint (gravity).
pub fn checkpoint_scene(dir: &Path) -> PathBuf {
    dir.join("scene.toml")
}

/// What one window did, as the orchestrator saw it.
#[derive(Debug, Clone)]
pub struct WindowDone {
    pub step: u64,
    /// Time at the end of the window, s.
    pub end: f64,
    pub window: f64,
    pub fluid: Option<SideReport>,
    pub dem: Option<SideReport>,
    /// Wall time of the whole window, s.
    pub wall_s: f64,
}

/// A launched run whose servers have said hello, advanced one window at a time: by
/// [`run`] to its end, by the gRPC service as its clients ask. Dropping it kills the
/// servers; [`CoupledRun::close`] shuts them down cleanly and closes the recording.
pub struct CoupledRun {
    scene: Scene,
    /// The scene's TOML with the live changes made so far (a checkpoint keeps it).
    text: String,
    /// Root of this run's checkpoints, `OUT/checkpoints`.
    checkpoints: PathBuf,
    /// Each body's velocity and angular velocity as the scene or a live change set them
    /// (what a kinematic body moves with).
    prescribed: Vec<([f64; 3], [f64; 3])>,
    plan: WindowPlan,
    /// Windows this run will advance (the plan's, or fewer with `max_windows`).
    windows: u64,
    /// Index of the next window.
    step: u64,
    output_interval: f64,
    next_output: f64,
    next_body_record: f64,
    last_states: Vec<BodyState>,
    last_loads: Vec<BodyLoad>,
    summary: RunSummary,
    /// When this sitting was launched (`summary.earlier_wall_s` holds the wall time of
    /// the earlier ones).
    launched: Instant,
    /// This sitting's first window (0, or the checkpoint's it resumed from).
    first_step: u64,
    /// Sums over this sitting's windows after its first (which carries the servers'
    /// set-up), µs, and how many windows they hold.
    timed_windows: u64,
    fluid_compute: f64,
    dem_compute: f64,
    exchange: f64,
    window_wall: f64,
    after_reports: f64,
    recorder: Option<Outputs>,
    peers: Peers,
    // The ports before the endpoint: fields drop in order, and the ports belong to it.
    commands: ValueSender<Command>,
    hellos: ValueReceiver<Hello>,
    reports: ValueReceiver<SideReport>,
    bodies_rx: SliceReceiver<BodyState>,
    loads_rx: SliceReceiver<BodyLoad>,
    particles_rx: SliceReceiver<ParticleRecord>,
    wake: WakeListener,
    wake_fluid: Waker,
    wake_dem: Waker,
    /// [`scene_digest`] of the scene text the servers must have loaded.
    scene_digest: u32,
    _endpoint: Endpoint,
}

impl CoupledRun {
    /// Writes `OUT/scene.toml`, opens the recording, starts the servers this scene needs
    /// under a fresh iceoryx2 namespace and waits for their hello; then plans the window.
    pub fn launch(
        scene: Scene,
        text: &str,
        out: &Path,
        opts: &LaunchOptions,
    ) -> Result<Self, RunError> {
        let launched = Instant::now();
        let has_fluid = scene.fluid.is_some();
        let has_dem = scene.needs_dem();
        if !has_fluid && !has_dem {
            return Err(RunError::Empty);
        }
        for (role, has, what) in [
            (Role::Fluid, has_fluid, "no [fluid]"),
            (Role::Dem, has_dem, "no body that needs a DEM"),
        ] {
            if opts.external.contains(&role) && !has {
                return Err(RunError::ExternalUnused {
                    role: role.name(),
                    what,
                });
            }
        }
        std::fs::create_dir_all(out).map_err(|source| RunError::Io {
            what: format!("creating {}", out.display()),
            source,
        })?;
        let scene_path = out.join("scene.toml");
        std::fs::write(&scene_path, text).map_err(|source| RunError::Io {
            what: format!("writing {}", scene_path.display()),
            source,
        })?;

        let run_id = opts.run_id.clone().unwrap_or_else(|| {
            format!(
                "{}-{}",
                std::process::id(),
                couplet_protocol::monotonic_ns() % 1_000_000_000
            )
        });
        // Two orchestrators in one namespace would take each other's reports.
        if node_alive(&run_id, Role::Orchestrator.name())? {
            return Err(RunError::RunIdTaken(run_id));
        }
        let ep = Endpoint::named(&run_id, Role::Orchestrator.name())?;
        let recorder = if opts.record {
            Some(Outputs::create(out, &scene, text)?)
        } else {
            None
        };
        let output_interval = scene.time.output_interval;
        let prescribed = (scene.bodies.iter())
            .map(|b| (b.velocity, b.angular_velocity))
            .collect();
        // The ports exist before the servers start: a hello sent to no subscriber is lost.
        let mut run = Self {
            plan: WindowPlan::default(),
            windows: 0,
            step: 0,
            output_interval,
            next_output: output_interval,
            // The first window's states are recorded: the start of every track.
            next_body_record: 0.0,
            last_states: Vec::new(),
            last_loads: Vec::new(),
            summary: RunSummary::default(),
            launched,
            fluid_compute: 0.0,
            dem_compute: 0.0,
            exchange: 0.0,
            first_step: 0,
            timed_windows: 0,
            window_wall: 0.0,
            after_reports: 0.0,
            recorder,
            peers: Peers {
                fluid: None,
                dem: None,
            },
            commands: ep.value_sender::<Command>(ServiceLeaf::Command)?,
            hellos: ep.value_receiver::<Hello>(ServiceLeaf::Hello)?,
            reports: ep.value_receiver::<SideReport>(ServiceLeaf::Report)?,
            bodies_rx: ep.slice_receiver::<BodyState>(ServiceLeaf::Bodies)?,
            loads_rx: ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads)?,
            particles_rx: ep.slice_receiver::<ParticleRecord>(ServiceLeaf::Particles)?,
            wake: ep.wake_listener(ServiceLeaf::OrchestratorWake)?,
            wake_fluid: ep.waker(ServiceLeaf::FluidWake)?,
            wake_dem: ep.waker(ServiceLeaf::DemWake)?,
            scene_digest: scene_digest(text),
            _endpoint: ep,
            scene,
            text: text.to_owned(),
            checkpoints: out.join("checkpoints"),
            prescribed,
        };
        let exe = opts.server_exe.as_deref();
        let dirs = StateDirs {
            checkpoints: Some(run.checkpoints.clone()),
            restore: opts.restore.clone(),
        };
        let start = |role| -> Result<Peer, LaunchError> {
            if opts.external.contains(&role) {
                Ok(Peer::External {
                    role,
                    run_id: run_id.clone(),
                    greeted: false,
                })
            } else {
                Server::spawn(role, &run_id, &scene_path, &dirs, exe).map(Peer::Child)
            }
        };
        let started = (|| {
            run.peers.fluid = has_fluid.then(|| start(Role::Fluid)).transpose()?;
            run.peers.dem = has_dem.then(|| start(Role::Dem)).transpose()?;
            run.handshake(opts.max_windows)?;
            match &opts.restore {
                Some(dir) => run.resume(dir, opts.max_windows),
                None => Ok(()),
            }
        })();
        match started {
            Ok(()) => Ok(run),
            Err(e) => {
                let _ = run.close(false);
                Err(e)
            }
        }
    }

    /// Every server says hello once its ports exist; a wrong version is refused.
    fn handshake(&mut self, max_windows: Option<u64>) -> Result<(), RunError> {
        let (mut fluid_hello, mut dem_hello) = (None::<Hello>, None::<Hello>);
        let expect_fluid = self.peers.fluid.is_some();
        let expect_dem = self.peers.dem.is_some();
        let start = Instant::now();
        while (expect_fluid && fluid_hello.is_none()) || (expect_dem && dem_hello.is_none()) {
            let peers = &mut self.peers;
            let h = self.wake.wait_for(
                || self.hellos.try_next(),
                || {
                    peers.check()?;
                    // Ctrl-C while the servers start (which can take minutes) stops
                    // here; `run` reports it as the interruption.
                    if let Some(signal) = crate::interrupt::requested() {
                        return Err(TransportError::PeerGone(format!(
                            "{} before every server said hello",
                            signal.name()
                        )));
                    }
                    if start.elapsed() > HELLO_TIMEOUT {
                        let apart: Vec<String> = [&peers.fluid, &peers.dem]
                            .into_iter()
                            .flatten()
                            .filter_map(|p| match p {
                                Peer::External {
                                    role,
                                    run_id,
                                    greeted: false,
                                } => Some(format!(
                                    "`couplet {} {run_id} SCENE --detached`",
                                    role.name()
                                )),
                                _ => None,
                            })
                            .collect();
                        return Err(TransportError::PeerGone(if apart.is_empty() {
                            format!("no hello within {HELLO_TIMEOUT:?}")
                        } else {
                            format!(
                                "no hello within {HELLO_TIMEOUT:?} from the servers started apart: {}",
                                apart.join(", ")
                            )
                        }));
                    }
                    Ok(())
                },
            )?;
            let role = check_hello_for(&h, self.scene_digest)?;
            let peer = match role {
                Role::Dem => {
                    dem_hello = Some(h);
                    self.peers.dem.as_mut()
                }
                _ => {
                    fluid_hello = Some(h);
                    self.peers.fluid.as_mut()
                }
            };
            if let Some(Peer::External { greeted, .. }) = peer {
                *greeted = true;
            }
        }
        self.plan = choose_window(
            &self.scene,
            fluid_hello.map(|h| h.dt_limit),
            dem_hello.map(|h| h.dt_limit),
        );
        self.windows = max_windows.map_or(self.plan.windows, |m| m.min(self.plan.windows));
        self.summary.plan = Some(self.plan.clone());
        Ok(())
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    pub fn plan(&self) -> &WindowPlan {
        &self.plan
    }
    /// Windows this run advances in all.
    pub fn windows(&self) -> u64 {
        self.windows
    }
    /// Windows advanced so far.
    pub fn windows_done(&self) -> u64 {
        self.step
    }
    /// Simulated time the run ends at, s.
    pub fn end_time(&self) -> f64 {
        self.scene
            .time
            .end
            .min(self.windows as f64 * self.plan.window)
    }
    pub fn done(&self) -> bool {
        self.step >= self.windows
    }
    /// Body states at the end of the last window.
    pub fn states(&self) -> &[BodyState] {
        &self.last_states
    }
    /// Fluid loads of the last window.
    pub fn loads(&self) -> &[BodyLoad] {
        &self.last_loads
    }
    pub fn output_interval(&self) -> f64 {
        self.output_interval
    }

    /// Wall time of the run so far over all its sittings, s.
    fn wall_so_far(&self) -> f64 {
        self.summary.earlier_wall_s + self.launched.elapsed().as_secs_f64()
    }

    /// Takes up where the checkpoint in `dir` left off (the servers have read their
    /// parts at start): the window plan, the output clocks and the last exchange.
    fn resume(&mut self, dir: &Path, max_windows: Option<u64>) -> Result<(), RunError> {
        let (_, saved): (_, OrchestratorState) =
            read_state(&state_file(dir, Role::Orchestrator), Role::Orchestrator)?;
        // The window is the saved run's, whatever the servers' hello says: a restored run
        // continues as the original would have.
        self.plan = saved.plan;
        self.windows = max_windows.map_or(self.plan.windows, |m| m.min(self.plan.windows));
        self.summary.plan = Some(self.plan.clone());
        self.step = saved.step;
        self.first_step = saved.step;
        self.output_interval = saved.output_interval;
        self.next_output = saved.next_output;
        self.next_body_record = saved.next_body_record;
        self.last_states = saved.last_states;
        self.last_loads = saved.last_loads;
        self.prescribed = saved.prescribed;
        self.summary.earlier_wall_s = saved.wall_s;
        self.summary.first_window = saved.step;
        self.summary.first_time = saved.step as f64 * self.plan.window;
        Ok(())
    }

    /// Writes a checkpoint of the boundary before the next window into
    /// `OUT/checkpoints/step-N/`: each server's whole state, the orchestrator's, and the
    /// scene with the live changes so far. Returns the folder; a run launched with
    /// [`LaunchOptions::restore`] set to it continues as this one will.
    pub fn checkpoint(&mut self) -> Result<PathBuf, RunError> {
        let dir = checkpoint_dir(&self.checkpoints, self.step);
        self.request(CommandKind::Checkpoint, 0, [0.0; 6])?;
        let scene = checkpoint_scene(&dir);
        std::fs::create_dir_all(&dir).map_err(|source| RunError::Io {
            what: format!("creating {}", dir.display()),
            source,
        })?;
        std::fs::write(&scene, &self.text).map_err(|source| RunError::Io {
            what: format!("writing {}", scene.display()),
            source,
        })?;
        let state = OrchestratorState {
            step: self.step,
            plan: self.plan.clone(),
            output_interval: self.output_interval,
            next_output: self.next_output,
            next_body_record: self.next_body_record,
            last_states: self.last_states.clone(),
            last_loads: self.last_loads.clone(),
            prescribed: self.prescribed.clone(),
            wall_s: self.wall_so_far(),
        };
        // The recording must reach the checkpoint before the checkpoint counts (its
        // orchestrator state, written last, makes it whole): a sitting killed outright
        // later loses only windows that the next sitting, starting here, records again.
        // Until 2026-12-06 it did not, and a lavapipe RTI killed by its machine's restart
        // left windows 7433–7600 in neither sitting's recording (`Gap`).
        if let Some(r) = self.recorder.as_mut() {
            r.flush()?;
        }
        let time = self.step as f64 * self.plan.window;
        write_state(
            &state_file(&dir, Role::Orchestrator),
            Role::Orchestrator,
            self.step,
            time,
            &state,
        )?;
        Ok(dir)
    }

    /// Gravity becomes `g`, m/s², from the next window on, on both sides (on the fluid
    /// only with `gravity.on_fluid`); a later checkpoint's scene has it.
    pub fn set_gravity(&mut self, g: [f64; 3]) -> Result<(), RunError> {
        if g.iter().any(|x| !x.is_finite()) {
            return Err(RunError::Refused(format!(
                "gravity.vector = {g:?}: must be three finite numbers, m/s²"
            )));
        }
        self.request(
            CommandKind::SetGravity,
            0,
            [g[0], g[1], g[2], 0.0, 0.0, 0.0],
        )?;
        self.scene.gravity.vector = g;
        self.text = couplet_protocol::scene::override_field(
            &self.text,
            Path::new("scene.toml"),
            "gravity.vector",
            &format!("[{:?}, {:?}, {:?}]", g[0], g[1], g[2]),
        )?;
        Ok(())
    }

    /// Kinematic body `body` moves on from where it is with `linear` (m/s) and `angular`
    /// (rad/s, world frame) velocity from the next window on.
    pub fn set_kinematic_velocity(
        &mut self,
        body: usize,
        linear: [f64; 3],
        angular: [f64; 3],
    ) -> Result<(), RunError> {
        let Some(spec) = self.scene.bodies.get(body) else {
            return Err(RunError::Refused(format!(
                "no body {body}: the scene has {} (bodies[0..{}])",
                self.scene.bodies.len(),
                self.scene.bodies.len()
            )));
        };
        if spec.motion != Motion::Kinematic {
            return Err(RunError::Refused(format!(
                "bodies[{body}] \"{}\" is {:?}: only a kinematic body's velocity can be prescribed during a run",
                spec.name, spec.motion
            )));
        }
        if linear.iter().chain(&angular).any(|x| !x.is_finite()) {
            return Err(RunError::Refused(format!(
                "bodies[{body}] velocity {linear:?} m/s, angular velocity {angular:?} rad/s: must be finite"
            )));
        }
        let [a, b, c] = linear;
        let [d, e, f] = angular;
        self.request(
            CommandKind::SetKinematicVelocity,
            body as u32,
            [a, b, c, d, e, f],
        )?;
        self.prescribed[body] = (linear, angular);
        Ok(())
    }

    /// Body `body`'s velocity and angular velocity as the scene or the last live change
    /// prescribed them.
    pub fn prescribed_velocity(&self, body: usize) -> Result<([f64; 3], [f64; 3]), RunError> {
        self.prescribed.get(body).copied().ok_or_else(|| {
            RunError::Refused(format!(
                "no body {body}: the scene has {}",
                self.prescribed.len()
            ))
        })
    }

    /// Sends a command that acts between windows to every server and waits until each
    /// has acknowledged it.
    fn request(&mut self, kind: CommandKind, body: u32, values: [f64; 6]) -> Result<(), RunError> {
        let step = self.step;
        self.commands.send(Command {
            protocol_version: PROTOCOL_VERSION,
            kind: kind as u32,
            step,
            time: step as f64 * self.plan.window,
            window: self.plan.window,
            snapshot: 0,
            body,
            values,
        })?;
        let expect_fluid = self.peers.fluid.is_some();
        let expect_dem = self.peers.dem.is_some();
        if expect_fluid {
            self.wake_fluid.wake()?;
        }
        if expect_dem {
            self.wake_dem.wake()?;
        }
        let (mut fluid, mut dem) = (!expect_fluid, !expect_dem);
        let peers = &mut self.peers;
        let reports = &self.reports;
        let mut unexpected = None;
        self.wake.wait_for(
            || {
                while let Some(r) = reports.try_next()? {
                    let role = Role::from_u32(r.role);
                    if r.step != step || r.kind != kind as u32 {
                        unexpected = Some(RunError::UnexpectedReport {
                            role: role.map_or("unknown role", Role::name),
                            got: r.kind,
                            expected: kind as u32,
                        });
                        return Ok(Some(()));
                    }
                    match role {
                        Some(Role::Fluid) => fluid = true,
                        Some(Role::Dem) => dem = true,
                        _ => {}
                    }
                }
                Ok((fluid && dem).then_some(()))
            },
            || peers.check(),
        )?;
        unexpected.map_or(Ok(()), Err)
    }

    /// Takes a new particle-snapshot interval from the next window on; the next snapshot
    /// falls on the first window end at or after the last one plus `interval` (every
    /// window when `interval` is shorter than the window).
    pub fn set_output_interval(&mut self, interval: f64) {
        let now = self.step as f64 * self.plan.window;
        let last = self.next_output - self.output_interval;
        self.output_interval = interval;
        self.next_output = (last + interval).max(now);
    }

    /// Advances one coupling window.
    pub fn advance(&mut self) -> Result<WindowDone, RunError> {
        let step = self.step;
        let windows = self.windows;
        let window = self.plan.window;
        let time = step as f64 * window;
        let end = time + window;
        let expect_fluid = self.peers.fluid.is_some();
        let expect_dem = self.peers.dem.is_some();
        // Snapshot at every output time the window reaches (and at the very end).
        let snapshot =
            expect_fluid && (end >= self.next_output * (1.0 - 1e-9) || step + 1 == windows);
        if snapshot {
            while self.next_output <= end * (1.0 + 1e-9) {
                self.next_output += self.output_interval;
            }
        }
        let w_start = Instant::now();
        self.commands.send(Command {
            protocol_version: PROTOCOL_VERSION,
            kind: CommandKind::Advance as u32,
            step,
            time,
            window,
            snapshot: snapshot as u32,
            body: 0,
            values: [0.0; 6],
        })?;
        if expect_fluid {
            self.wake_fluid.wake()?;
        }
        if expect_dem {
            self.wake_dem.wake()?;
        }

        let (mut fluid_report, mut dem_report) = (None::<SideReport>, None::<SideReport>);
        let peers = &mut self.peers;
        let reports = &self.reports;
        self.wake.wait_for(
            || {
                while let Some(r) = reports.try_next()? {
                    if r.step != step || r.kind != CommandKind::Advance as u32 {
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
        let reports_in = Instant::now();
        let summary = &mut self.summary;
        // A sitting's first window also carries one-off set-up (the fluid's first markers
        // rebuild its buffers; a resumed sitting's grains build their lists), so the
        // per-window means start at its second when there is one.
        let timed = step > self.first_step || windows == self.first_step + 1;
        if timed {
            self.timed_windows += 1;
            self.window_wall += w_start.elapsed().as_secs_f64() * 1e6;
            for r in [&fluid_report, &dem_report].into_iter().flatten() {
                match Role::from_u32(r.role) {
                    Some(Role::Fluid) => self.fluid_compute += r.compute_us,
                    _ => self.dem_compute += r.compute_us,
                }
                self.exchange += r.exchange_us;
            }
        }
        if let Some(r) = &fluid_report {
            summary.fluid_substeps += r.substeps as u64;
            summary.near_singular += u64::from(r.near_singular);
            summary.reflected += u64::from(r.reflected);
            summary.shift_limited += u64::from(r.shift_limited);
        }

        // Drain what crossed this window; record it (bodies and loads every window, or
        // at `time.body_output_interval`).
        let record_bodies = match self.scene.time.body_output_interval {
            Some(interval)
                if end + 1e-9 * interval < self.next_body_record && step + 1 < windows =>
            {
                false
            }
            Some(interval) => {
                while self.next_body_record <= end + 1e-9 * interval {
                    self.next_body_record += interval;
                }
                true
            }
            None => true,
        };
        let mut recorder = self.recorder.as_mut();
        while let Some(s) = self.bodies_rx.try_latest()? {
            self.last_states.clear();
            self.last_states.extend_from_slice(s.payload());
            let t = s.user_header().time;
            if let Some(b) = self.last_states.first() {
                summary.body0_track.push((t, b.position, b.linear_velocity));
            }
            if let Some(r) = recorder.as_deref_mut().filter(|_| record_bodies) {
                r.bodies(t, &self.last_states)?;
            }
        }
        if let Some(s) = self.loads_rx.try_latest()? {
            self.last_loads.clear();
            self.last_loads.extend_from_slice(s.payload());
            if let Some(r) = recorder.as_deref_mut().filter(|_| record_bodies) {
                r.loads(time, s.payload())?;
            }
        }
        if snapshot {
            let peers = &mut self.peers;
            let particles = &self.particles_rx;
            let s = self
                .wake
                .wait_for(|| particles.try_step(step), || peers.check())?;
            if let Some(r) = recorder.as_deref_mut() {
                r.particles(s.user_header().time, s.payload(), &self.last_states)?;
            }
        }
        if let Some(r) = recorder {
            r.window(
                step,
                time,
                window,
                summary.earlier_wall_s + self.launched.elapsed().as_secs_f64(),
                fluid_report.as_ref(),
                dem_report.as_ref(),
            )?;
        }
        if timed {
            self.after_reports += reports_in.elapsed().as_secs_f64() * 1e6;
        }
        let wall_s = w_start.elapsed().as_secs_f64();
        summary.wall_s += wall_s;
        summary.windows = step + 1;
        summary.sim_time = end;
        self.step = step + 1;
        Ok(WindowDone {
            step,
            end,
            window,
            fluid: fluid_report,
            dem: dem_report,
            wall_s,
        })
    }

    /// Shuts the servers down and closes the recording. After a failure (`ok` false)
    /// the run is lost and the survivors are killed at once (one may be blocked waiting
    /// for data from the dead one), so the error surfaces within a second; otherwise
    /// they are told to shut down and given time to exit cleanly.
    pub fn close(mut self, ok: bool) -> Result<RunSummary, RunError> {
        let grace = if ok {
            Duration::from_secs(5)
        } else {
            Duration::ZERO
        };
        let _ = self.commands.send(Command {
            protocol_version: PROTOCOL_VERSION,
            kind: CommandKind::Shutdown as u32,
            ..Default::default()
        });
        let _ = self.wake_fluid.wake();
        let _ = self.wake_dem.wake();
        // A server started apart exits on the shutdown command, or within a second of
        // this process's node going; it is no child to wait for or kill.
        for p in [self.peers.fluid.as_mut(), self.peers.dem.as_mut()]
            .into_iter()
            .flatten()
        {
            if let Peer::Child(s) = p {
                s.finish(grace);
            }
        }
        if let Some(r) = self.recorder.as_mut() {
            r.close()?;
            self.summary.recording = Some(r.mcap_path().to_owned());
        }
        let mut s = std::mem::take(&mut self.summary);
        // Over this sitting's timed windows: a resumed sitting's sums start at its
        // checkpoint, not at window 0 (`regression_resumed_sitting_averages_its_own_windows`).
        let n = self.timed_windows.max(1) as f64;
        s.fluid_compute_us = self.fluid_compute / n;
        s.dem_compute_us = self.dem_compute / n;
        s.exchange_us = self.exchange / n;
        s.window_wall_us = self.window_wall / n;
        s.after_reports_us = self.after_reports / n;
        s.final_states = std::mem::take(&mut self.last_states);
        Ok(s)
    }
}

/// A run's progress on stderr: on a terminal a bar (simulated time, speed, ETA); anywhere
/// else (a batch job's log, a pipe), where the bar would not draw, a line now and then
/// ([`ProgressLines`]).
enum Progress {
    Hidden,
    Bar(ProgressBar),
    Lines(ProgressLines),
}

impl Progress {
    fn new(show: bool, end: f64) -> Self {
        use std::io::IsTerminal;
        if !show {
            Self::Hidden
        } else if std::io::stderr().is_terminal() {
            // Simulated time (µs resolution) as position.
            let bar = ProgressBar::new((end * 1e6) as u64);
            let style = ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:30} t = {msg} s  ({per_sec} sim-µs/s, ETA {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar());
            bar.set_style(style);
            bar.enable_steady_tick(Duration::from_millis(250));
            Self::Bar(bar)
        } else {
            Self::Lines(ProgressLines::new(end, Instant::now()))
        }
    }

    /// The run has reached simulated time `t`.
    fn update(&mut self, t: f64) {
        match self {
            Self::Hidden => {}
            Self::Bar(bar) => {
                bar.set_position((t * 1e6) as u64);
                bar.set_message(format!("{t:.4}"));
            }
            Self::Lines(lines) => {
                if let Some(line) = lines.update(t, Instant::now()) {
                    eprintln!("{line}");
                }
            }
        }
    }

    fn finish(self) {
        if let Self::Bar(bar) = self {
            bar.finish_and_clear();
        }
    }
}

/// Plain progress lines for a run whose stderr is not a terminal: one each time the
/// simulated time passes another tenth of the run, and one whenever a minute of wall
/// time has gone by without a line, so that an hour-long run in a batch job's log says
/// where it is about once a minute and a short one says it ten times.
struct ProgressLines {
    end: f64,
    /// Simulated time and wall clock of the first update (a restored run starts late).
    first: Option<(f64, Instant)>,
    last_line: Instant,
    /// The next tenth of `end` that earns a line.
    next_tenth: u32,
}

/// Longest wall time between two progress lines.
const PROGRESS_LINE_EVERY: Duration = Duration::from_secs(60);

impl ProgressLines {
    fn new(end: f64, now: Instant) -> Self {
        Self {
            end,
            first: None,
            last_line: now,
            next_tenth: 1,
        }
    }

    /// The line to print now that the run has reached `t` at `now`, if one is due.
    fn update(&mut self, t: f64, now: Instant) -> Option<String> {
        let &mut (t0, wall0) = self.first.get_or_insert((t, now));
        let tenth = (10.0 * t / self.end).floor();
        let passed_a_tenth = tenth >= f64::from(self.next_tenth);
        if !passed_a_tenth && now.duration_since(self.last_line) < PROGRESS_LINE_EVERY {
            return None;
        }
        if passed_a_tenth {
            self.next_tenth = tenth as u32 + 1;
        }
        self.last_line = now;
        let wall = now.duration_since(wall0).as_secs_f64();
        let rate = if wall > 0.0 { (t - t0) / wall } else { 0.0 };
        let eta = if rate > 0.0 {
            format!("ETA {}", wall_time((self.end - t) / rate))
        } else {
            "ETA unknown".into()
        };
        Some(format!(
            "progress: t = {t:.4e} of {:.4e} s ({:.0} %), {rate:.3e} sim-s/s over {}, {eta}",
            self.end,
            100.0 * t / self.end,
            wall_time(wall)
        ))
    }
}

/// Seconds as `1 h 02 min`, `3 min 05 s` or `42 s`.
fn wall_time(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run to t = 1 s, away from a terminal: a line at each tenth passed (one line when
    /// an update jumps over several), none between them within a minute, and one after a
    /// minute without; speed and ETA from the first update. Reference: the arithmetic of
    /// the updates' times.
    #[test]
    fn progress_lines_come_at_each_tenth_and_at_least_once_a_minute() {
        let start = Instant::now();
        let at = |s: u64| start + Duration::from_secs(s);
        let mut p = ProgressLines::new(1.0, start);
        assert_eq!(p.update(0.0, at(0)), None);
        assert_eq!(p.update(0.05, at(5)), None);
        let line = p.update(0.1, at(10)).expect("a line at the first tenth");
        assert_eq!(
            line,
            "progress: t = 1.0000e-1 of 1.0000e0 s (10 %), 1.000e-2 sim-s/s over 10 s, ETA 1 min 30 s"
        );
        assert_eq!(p.update(0.15, at(15)), None);
        // Past 0.2 and 0.3 at once: one line, and the next at 0.4.
        assert!(p.update(0.35, at(35)).is_some());
        assert_eq!(p.update(0.39, at(39)), None);
        // A minute since the last line, still short of 0.4.
        let line = p.update(0.396, at(96)).expect("a line after a minute");
        assert!(
            line.contains("(40 %)") && line.contains("over 1 min 36 s"),
            "{line}"
        );
        assert!(p.update(0.4, at(97)).is_some());
        let line = p.update(1.0, at(240)).expect("a line at the end");
        assert!(
            line.contains("(100 %)") && line.contains("ETA 0 s"),
            "{line}"
        );
    }

    /// Reference: 3725 s = 1 h 02 min 05 s, shown to the minute.
    #[test]
    fn wall_times_read_in_hours_minutes_or_seconds() {
        assert_eq!(wall_time(42.4), "42 s");
        assert_eq!(wall_time(185.0), "3 min 05 s");
        assert_eq!(wall_time(3725.0), "1 h 02 min");
    }
}
