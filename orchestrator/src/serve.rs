//! `couplet serve`: the gRPC control service (`protocol/proto/couplet/v1/couplet.proto`).
//!
//! Every run lives on its own thread, which owns a [`CoupledRun`] (its pair of servers,
//! under an iceoryx2 namespace of its own, and its recording) and advances it window by
//! window as long as its [`Control`] allows. The async gRPC handlers never touch the
//! run: they change its `Control` under a mutex and wake the thread, then await the
//! state it publishes on a `watch` channel. Telemetry goes out on a `broadcast`
//! channel, whose sender never waits: a watcher that falls behind loses the oldest
//! frames and is told how many (DESIGN.md: a slow client never slows the simulation).

use crate::run::{CoupledRun, LaunchOptions, RunError, WindowDone, checkpoint_scene};
use couplet_protocol::grpc::{
    self, BodyFrame, CheckpointResponse, CreateRunRequest, DeleteRunRequest, DeleteRunResponse,
    Engine, ListEnginesRequest, ListEnginesResponse, ListRunsRequest, ListRunsResponse, Quat,
    RestoreRunRequest, Run, RunRequest, RunState, SetParameterRequest, StepRunRequest, Vec3,
    WatchEvent, WindowFrame,
    couplet_server::{Couplet, CoupletServer},
    watch_event,
};
use couplet_protocol::{Motion, Scene, SceneError};
use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::sync::{Arc, Condvar, Mutex};
use tokio::sync::{broadcast, mpsc, oneshot, watch};
use tokio_stream::Stream;
use tokio_stream::wrappers::{ReceiverStream, TcpListenerStream};
use tonic::{Request, Response, Status};

/// Frames a watcher may fall behind by before it loses the oldest: a few seconds of a
/// fast run, and at most a few MB for a scene of a hundred bodies.
const WATCH_BUFFER: usize = 256;

/// What the service is set up with.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// Runs write their output under `DATA/<run id>/` (scene.toml, run.mcap).
    pub data_dir: PathBuf,
    /// Live runs (not FINISHED, STOPPED or FAILED) at most; each holds two server
    /// processes and a GPU context, so the default is small.
    pub max_runs: usize,
    /// The executable started in the server roles; None: this one.
    pub server_exe: Option<PathBuf>,
    /// When set, every call to the Couplet service must carry
    /// `authorization: Bearer TOKEN` (health and reflection stay open for probes).
    pub token: Option<String>,
}

/// Live runs at most by default: two is what one GPU serves without either run
/// waiting long for the other.
pub const DEFAULT_MAX_RUNS: usize = 2;

/// What a run's thread may do next; changed by the handlers under the mutex.
#[derive(Default)]
struct Control {
    /// Windows the thread may still advance before it pauses; None: to the end.
    budget: Option<u64>,
    /// Stop at the next window boundary.
    stop: bool,
    /// Changes to make at the next window boundary, in the order asked.
    pending: Vec<Pending>,
}

/// A change a handler asks of a run; its thread makes it between two windows.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Change {
    OutputInterval(f64),
    Gravity([f64; 3]),
    /// A kinematic body's velocities; a `None` keeps the current one.
    Kinematic {
        body: usize,
        linear: Option<[f64; 3]>,
        angular: Option<[f64; 3]>,
    },
    Checkpoint,
}

/// What a change gave back.
enum Applied {
    Done,
    Checkpoint { path: PathBuf, step: u64, time: f64 },
}

struct Pending {
    change: Change,
    /// The refusal, or the run's error, as text.
    reply: oneshot::Sender<Result<Applied, String>>,
}

/// One run as the service holds it.
struct RunHandle {
    id: String,
    /// Name and motion of every scene body (SetParameter resolves `bodies.NAME`).
    bodies: Vec<(String, Motion)>,
    ctl: Mutex<Control>,
    wake: Condvar,
    status: watch::Sender<Run>,
    frames: broadcast::Sender<Arc<WindowFrame>>,
}

impl RunHandle {
    fn snapshot(&self) -> Run {
        self.status.borrow().clone()
    }

    fn control(&self, f: impl FnOnce(&mut Control)) {
        let mut c = self.ctl.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut c);
        self.wake.notify_all();
    }

    /// Hands `change` to the run's thread and waits until it has been made.
    async fn submit(&self, change: Change) -> Result<Applied, Status> {
        let (reply, answer) = oneshot::channel();
        self.control(|c| c.pending.push(Pending { change, reply }));
        match answer.await {
            Ok(Ok(applied)) => Ok(applied),
            Ok(Err(why)) => Err(Status::failed_precondition(why)),
            Err(_) => Err(Status::failed_precondition(format!(
                "run {} ended before the change was made",
                self.id
            ))),
        }
    }

    /// Waits until `done` holds for the published state, or the run has ended.
    async fn wait_for(&self, done: impl Fn(&Run) -> bool) -> Run {
        let mut rx = self.status.subscribe();
        let r = rx
            .wait_for(|r| done(r) || ended(r.state()))
            .await
            .map(|r| r.clone());
        // The sender lives in `self`: the wait cannot lose it.
        r.unwrap_or_else(|_| self.snapshot())
    }
}

fn ended(s: RunState) -> bool {
    matches!(s, RunState::Finished | RunState::Stopped | RunState::Failed)
}

fn state_name(s: RunState) -> &'static str {
    match s {
        RunState::Unspecified => "UNSPECIFIED",
        RunState::Starting => "STARTING",
        RunState::Ready => "READY",
        RunState::Running => "RUNNING",
        RunState::Paused => "PAUSED",
        RunState::Finished => "FINISHED",
        RunState::Stopped => "STOPPED",
        RunState::Failed => "FAILED",
    }
}

/// The service: the runs it holds and how it was set up.
#[derive(Clone)]
pub struct CoupletService {
    cfg: Arc<ServeConfig>,
    runs: Arc<Mutex<BTreeMap<String, Arc<RunHandle>>>>,
}

impl CoupletService {
    pub fn new(cfg: ServeConfig) -> Self {
        Self {
            cfg: Arc::new(cfg),
            runs: Arc::default(),
        }
    }

    fn get(&self, id: &str) -> Result<Arc<RunHandle>, Status> {
        self.runs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(id)
            .cloned()
            .ok_or_else(|| Status::not_found(format!("no run {id:?} (ListRuns lists them)")))
    }

    /// Stops every live run and waits for each to end: the server's shutdown path, so
    /// that no server process outlives it and every recording is closed.
    pub async fn stop_all(&self) {
        let runs: Vec<_> = self
            .runs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .values()
            .cloned()
            .collect();
        for r in &runs {
            r.control(|c| c.stop = true);
        }
        for r in &runs {
            r.wait_for(|_| false).await;
        }
    }

    /// Parses the scene with its overrides: INVALID_ARGUMENT names the line or field.
    fn scene(req: &CreateRunRequest) -> Result<(Scene, String), Status> {
        let file = Path::new("<CreateRun scene_toml>");
        let mut text = req.scene_toml.clone();
        let bad = |e: SceneError| Status::invalid_argument(e.to_string());
        for o in &req.overrides {
            text = couplet_protocol::scene::override_field(&text, file, &o.path, &o.value)
                .map_err(bad)?;
        }
        let scene = Scene::parse(&text, file).map_err(bad)?;
        Ok((scene, text))
    }

    /// A fresh run id `<scene name>-<n>` whose output folder does not exist yet.
    fn fresh_id(&self, runs: &BTreeMap<String, Arc<RunHandle>>, name: &str) -> String {
        let safe: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '-'
                }
            })
            .collect();
        (1..)
            .map(|n| format!("{safe}-{n}"))
            .find(|id| !runs.contains_key(id) && !self.cfg.data_dir.join(id).exists())
            .unwrap_or_default()
    }

    /// A checkpoint folder the client named: absolute or relative to the data folder,
    /// and inside it (a client may only restore what this server wrote or was given).
    fn checkpoint_dir(&self, given: &str) -> Result<PathBuf, Status> {
        if given.is_empty() {
            return Err(Status::invalid_argument(
                "RestoreRun needs the checkpoint folder Checkpoint returned",
            ));
        }
        let data = std::fs::canonicalize(&self.cfg.data_dir).map_err(|e| {
            Status::internal(format!("data folder {}: {e}", self.cfg.data_dir.display()))
        })?;
        let dir = std::fs::canonicalize(data.join(given))
            .map_err(|e| Status::not_found(format!("checkpoint {given}: {e}")))?;
        if !dir.starts_with(&data) {
            return Err(Status::invalid_argument(format!(
                "checkpoint {given} lies outside this server's data folder {}: copy it there first",
                data.display()
            )));
        }
        Ok(dir)
    }

    /// Registers a run and starts its thread, which launches the servers (from the
    /// checkpoint `restore` when given).
    fn launch(
        &self,
        scene: Scene,
        text: String,
        record: bool,
        restore: Option<PathBuf>,
    ) -> Result<Arc<RunHandle>, Status> {
        if scene.fluid.is_none() && !scene.needs_dem() {
            return Err(Status::invalid_argument(
                "the scene has neither fluid nor bodies: nothing to simulate",
            ));
        }
        let handle = {
            let mut runs = self.runs.lock().unwrap_or_else(|e| e.into_inner());
            let live = runs
                .values()
                .filter(|r| !ended(r.snapshot().state()))
                .count();
            if live >= self.cfg.max_runs {
                return Err(Status::resource_exhausted(format!(
                    "{live} live runs, the most this server takes (--max-runs {}): stop or wait for one",
                    self.cfg.max_runs
                )));
            }
            let id = self.fresh_id(&runs, &scene.meta.name);
            let out = self.cfg.data_dir.join(&id);
            let status = Run {
                run_id: id.clone(),
                scene_name: scene.meta.name.clone(),
                state: RunState::Starting as i32,
                end_time: scene.time.end,
                output_dir: out.display().to_string(),
                output_interval: scene.time.output_interval,
                warnings: scene.warnings(),
                gravity: vec3(scene.gravity.vector),
                ..Default::default()
            };
            let handle = Arc::new(RunHandle {
                id: id.clone(),
                bodies: (scene.bodies.iter())
                    .map(|b| (b.name.clone(), b.motion))
                    .collect(),
                // Created paused: StartRun or StepRun give it windows.
                ctl: Mutex::new(Control {
                    budget: Some(0),
                    ..Default::default()
                }),
                wake: Condvar::new(),
                status: watch::Sender::new(status),
                frames: broadcast::Sender::new(WATCH_BUFFER),
            });
            runs.insert(id, handle.clone());
            let opts = LaunchOptions {
                record,
                max_windows: None,
                server_exe: self.cfg.server_exe.clone(),
                restore,
                run_id: None,
                external: Vec::new(),
            };
            let h = handle.clone();
            std::thread::Builder::new()
                .name(format!("run {}", handle.id))
                .spawn(move || run_thread(&h, scene, &text, &out, &opts))
                .map_err(|e| Status::internal(format!("cannot start the run's thread: {e}")))?;
            handle
        };
        Ok(handle)
    }
}

type WatchStream = Pin<Box<dyn Stream<Item = Result<WatchEvent, Status>> + Send>>;

#[tonic::async_trait]
impl Couplet for CoupletService {
    async fn create_run(&self, req: Request<CreateRunRequest>) -> Result<Response<Run>, Status> {
        let req = req.into_inner();
        let (scene, text) = Self::scene(&req)?;
        let handle = self.launch(scene, text, !req.skip_recording, None)?;
        Ok(Response::new(handle.snapshot()))
    }

    async fn restore_run(&self, req: Request<RestoreRunRequest>) -> Result<Response<Run>, Status> {
        let req = req.into_inner();
        let dir = self.checkpoint_dir(&req.checkpoint)?;
        let file = checkpoint_scene(&dir);
        let text = std::fs::read_to_string(&file).map_err(|e| {
            Status::not_found(format!(
                "{}: {e} (a checkpoint folder holds scene.toml and one .state file per process)",
                file.display()
            ))
        })?;
        let scene =
            Scene::parse(&text, &file).map_err(|e| Status::invalid_argument(e.to_string()))?;
        let handle = self.launch(scene, text, !req.skip_recording, Some(dir))?;
        Ok(Response::new(handle.snapshot()))
    }

    async fn checkpoint(
        &self,
        req: Request<RunRequest>,
    ) -> Result<Response<CheckpointResponse>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        let s = h.snapshot().state();
        if ended(s) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: its servers are gone, nothing to checkpoint",
                h.id,
                state_name(s)
            )));
        }
        match h.submit(Change::Checkpoint).await? {
            Applied::Checkpoint { path, step, time } => Ok(Response::new(CheckpointResponse {
                run_id: h.id.clone(),
                path: path.display().to_string(),
                step,
                time,
            })),
            Applied::Done => Err(Status::internal("a checkpoint gave no folder")),
        }
    }

    async fn start_run(&self, req: Request<RunRequest>) -> Result<Response<Run>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        let s = h.snapshot().state();
        if !matches!(s, RunState::Starting | RunState::Ready) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: StartRun starts a READY run{}",
                h.id,
                state_name(s),
                if s == RunState::Paused {
                    " (ResumeRun continues a paused one)"
                } else {
                    ""
                }
            )));
        }
        h.control(|c| c.budget = None);
        Ok(Response::new(
            h.wait_for(|r| r.state() == RunState::Running).await,
        ))
    }

    async fn pause_run(&self, req: Request<RunRequest>) -> Result<Response<Run>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        let s = h.snapshot().state();
        if ended(s) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: nothing to pause",
                h.id,
                state_name(s)
            )));
        }
        h.control(|c| c.budget = Some(0));
        Ok(Response::new(
            h.wait_for(|r| matches!(r.state(), RunState::Paused | RunState::Ready))
                .await,
        ))
    }

    async fn resume_run(&self, req: Request<RunRequest>) -> Result<Response<Run>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        let s = h.snapshot().state();
        if s != RunState::Paused {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: ResumeRun continues a PAUSED run{}",
                h.id,
                state_name(s),
                if s == RunState::Ready {
                    " (StartRun starts a READY one)"
                } else {
                    ""
                }
            )));
        }
        h.control(|c| c.budget = None);
        Ok(Response::new(
            h.wait_for(|r| r.state() == RunState::Running).await,
        ))
    }

    async fn step_run(&self, req: Request<StepRunRequest>) -> Result<Response<Run>, Status> {
        let req = req.into_inner();
        let h = self.get(&req.run_id)?;
        if req.windows == 0 {
            return Err(Status::invalid_argument("StepRun needs windows ≥ 1"));
        }
        // A starting run is stepped once its servers are up.
        let now = h.wait_for(|r| r.state() != RunState::Starting).await;
        if !matches!(now.state(), RunState::Ready | RunState::Paused) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: StepRun advances a READY or PAUSED run{}",
                h.id,
                state_name(now.state()),
                if now.state() == RunState::Running {
                    " (PauseRun first)"
                } else {
                    ""
                }
            )));
        }
        let target = now.windows_done + req.windows;
        h.control(|c| c.budget = Some(req.windows));
        Ok(Response::new(
            h.wait_for(|r| r.windows_done >= target && r.state() != RunState::Running)
                .await,
        ))
    }

    async fn stop_run(&self, req: Request<RunRequest>) -> Result<Response<Run>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        h.control(|c| c.stop = true);
        Ok(Response::new(h.wait_for(|_| false).await))
    }

    async fn get_run(&self, req: Request<RunRequest>) -> Result<Response<Run>, Status> {
        Ok(Response::new(
            self.get(&req.into_inner().run_id)?.snapshot(),
        ))
    }

    async fn list_runs(
        &self,
        _: Request<ListRunsRequest>,
    ) -> Result<Response<ListRunsResponse>, Status> {
        let runs = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        Ok(Response::new(ListRunsResponse {
            runs: runs.values().map(|r| r.snapshot()).collect(),
        }))
    }

    async fn delete_run(
        &self,
        req: Request<DeleteRunRequest>,
    ) -> Result<Response<DeleteRunResponse>, Status> {
        let req = req.into_inner();
        let h = self.get(&req.run_id)?;
        let now = h.snapshot();
        if !ended(now.state()) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: StopRun it before deleting",
                h.id,
                state_name(now.state())
            )));
        }
        self.runs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&req.run_id);
        if req.delete_files {
            std::fs::remove_dir_all(&now.output_dir).map_err(|e| {
                Status::internal(format!(
                    "run {} forgotten, but its folder {} stays: {e}",
                    h.id, now.output_dir
                ))
            })?;
        }
        Ok(Response::new(DeleteRunResponse {
            run_id: req.run_id,
            files_deleted: req.delete_files,
        }))
    }

    type WatchRunStream = WatchStream;

    async fn watch_run(
        &self,
        req: Request<RunRequest>,
    ) -> Result<Response<Self::WatchRunStream>, Status> {
        let h = self.get(&req.into_inner().run_id)?;
        let mut frames = h.frames.subscribe();
        let mut status = h.status.subscribe();
        let (tx, rx) = mpsc::channel(16);
        tokio::spawn(async move {
            let mut missed = 0u64;
            let frame = |f: &WindowFrame, missed: &mut u64| WatchEvent {
                event: Some(watch_event::Event::Frame(WindowFrame {
                    missed: std::mem::take(missed),
                    ..f.clone()
                })),
            };
            loop {
                enum Next {
                    Frame(Result<Arc<WindowFrame>, broadcast::error::RecvError>),
                    // Boxed: a `Run` is large beside a frame's `Arc`.
                    Ended(Option<Box<Run>>),
                }
                let next = tokio::select! {
                    biased;
                    f = frames.recv() => Next::Frame(f),
                    r = status.wait_for(|r| ended(r.state())) => {
                        Next::Ended(r.ok().map(|r| Box::new(r.clone())))
                    }
                };
                match next {
                    Next::Frame(Ok(f)) => {
                        if tx.send(Ok(frame(&f, &mut missed))).await.is_err() {
                            return; // the watcher hung up
                        }
                    }
                    Next::Frame(Err(broadcast::error::RecvError::Lagged(n))) => missed += n,
                    Next::Frame(Err(broadcast::error::RecvError::Closed)) => return,
                    Next::Ended(end) => {
                        // The frames sent before the end are still queued.
                        loop {
                            match frames.try_recv() {
                                Ok(f) => {
                                    if tx.send(Ok(frame(&f, &mut missed))).await.is_err() {
                                        return;
                                    }
                                }
                                Err(broadcast::error::TryRecvError::Lagged(n)) => missed += n,
                                Err(_) => break,
                            }
                        }
                        if let Some(r) = end {
                            let _ = tx
                                .send(Ok(WatchEvent {
                                    event: Some(watch_event::Event::Ended(*r)),
                                }))
                                .await;
                        }
                        return;
                    }
                }
            }
        });
        Ok(Response::new(Box::pin(ReceiverStream::new(rx))))
    }

    async fn set_parameter(
        &self,
        req: Request<SetParameterRequest>,
    ) -> Result<Response<Run>, Status> {
        let req = req.into_inner();
        let h = self.get(&req.run_id)?;
        let s = h.snapshot().state();
        if ended(s) {
            return Err(Status::failed_precondition(format!(
                "run {} is {}: nothing to change",
                h.id,
                state_name(s)
            )));
        }
        let change = parse_change(&req.path, &req.value, &h.bodies)?;
        h.submit(change).await?;
        Ok(Response::new(h.snapshot()))
    }

    async fn list_engines(
        &self,
        _: Request<ListEnginesRequest>,
    ) -> Result<Response<ListEnginesResponse>, Status> {
        let default = couplet_protocol::DemSpec::default().engine;
        Ok(Response::new(ListEnginesResponse {
            engines: couplet_dem::engine_names()
                .iter()
                .map(|n| Engine {
                    name: (*n).to_owned(),
                    is_default: *n == default,
                })
                .collect(),
        }))
    }
}

/// The live change `path = value` asks for (SetParameter), checked against the scene's
/// bodies: INVALID_ARGUMENT for a value of the wrong kind, FAILED_PRECONDITION for what
/// cannot change during a run.
fn parse_change(path: &str, value: &str, bodies: &[(String, Motion)]) -> Result<Change, Status> {
    const LIVE: &str = "time.output_interval, gravity.vector, bodies.NAME.velocity and \
                        bodies.NAME.angular_velocity (kinematic bodies)";
    let toml_value = || -> Result<toml::Value, Status> {
        let t: toml::Table = toml::from_str(&format!("v = {value}"))
            .map_err(|_| Status::invalid_argument(format!("{path} = {value}: not a TOML value")))?;
        t.get("v")
            .cloned()
            .ok_or_else(|| Status::invalid_argument(format!("{path} = {value}: no value")))
    };
    let number = |v: &toml::Value| match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    };
    let vector = |unit: &str| -> Result<[f64; 3], Status> {
        let bad = || {
            Status::invalid_argument(format!(
                "{path} = {value}: expected three finite numbers [x, y, z] in {unit}"
            ))
        };
        let v = toml_value()?;
        let a = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
        let mut out = [0.0; 3];
        for (o, x) in out.iter_mut().zip(a) {
            *o = number(x).filter(|x| x.is_finite()).ok_or_else(bad)?;
        }
        Ok(out)
    };
    match path.split('.').collect::<Vec<_>>().as_slice() {
        ["time", "output_interval"] => {
            let dt = number(&toml_value()?).ok_or_else(|| {
                Status::invalid_argument(format!(
                    "time.output_interval = {value}: expected a number of seconds"
                ))
            })?;
            if !(dt.is_finite() && dt > 0.0) {
                return Err(Status::invalid_argument(format!(
                    "time.output_interval = {dt}: must be a positive number of seconds"
                )));
            }
            Ok(Change::OutputInterval(dt))
        }
        ["gravity", "vector"] => Ok(Change::Gravity(vector("m/s²")?)),
        ["bodies", name, field @ ("velocity" | "angular_velocity")] => {
            let body = bodies
                .iter()
                .position(|(n, _)| n == name)
                .or_else(|| name.parse().ok().filter(|i| *i < bodies.len()))
                .ok_or_else(|| {
                    let names: Vec<&str> = bodies.iter().map(|(n, _)| n.as_str()).collect();
                    Status::invalid_argument(format!(
                        "{path}: no body {name:?}; the scene's bodies are {names:?} (or their indices 0..{})",
                        bodies.len()
                    ))
                })?;
            let (body_name, motion) = &bodies[body];
            if *motion != Motion::Kinematic {
                return Err(Status::failed_precondition(format!(
                    "{path}: body {body} \"{body_name}\" is {motion:?}; only a kinematic body's \
                     velocity can be prescribed during a run (a dynamic one moves under its forces)"
                )));
            }
            let (linear, angular) = if *field == "velocity" {
                (Some(vector("m/s")?), None)
            } else {
                (None, Some(vector("rad/s")?))
            };
            Ok(Change::Kinematic {
                body,
                linear,
                angular,
            })
        }
        ["gravity", "on_fluid"] => Err(Status::failed_precondition(
            "gravity.on_fluid cannot change during a run: it decides whether the fluid's \
             pressure or Joubert eq. (28) carries the bodies' buoyancy, and the fluid's \
             hydrostatic start follows it. Create a new run with the override",
        )),
        _ => Err(Status::failed_precondition(format!(
            "{path} cannot change during a run (create a new run with the override); what can: {LIVE}"
        ))),
    }
}

/// Makes one change between windows. A refusal is the client's answer; any other error
/// has cost the run its servers, and ends it.
fn apply(run: &mut CoupledRun, h: &RunHandle, change: Change) -> Result<Applied, RunError> {
    match change {
        Change::OutputInterval(dt) => {
            run.set_output_interval(dt);
            h.status.send_modify(|r| r.output_interval = dt);
        }
        Change::Gravity(g) => {
            run.set_gravity(g)?;
            h.status.send_modify(|r| r.gravity = vec3(g));
        }
        Change::Kinematic {
            body,
            linear,
            angular,
        } => {
            let (v, w) = run.prescribed_velocity(body)?;
            run.set_kinematic_velocity(body, linear.unwrap_or(v), angular.unwrap_or(w))?;
        }
        Change::Checkpoint => {
            let path = run.checkpoint()?;
            let step = run.windows_done();
            return Ok(Applied::Checkpoint {
                path,
                step,
                time: step as f64 * run.plan().window,
            });
        }
    }
    Ok(Applied::Done)
}

/// The life of one run: launch, then advance while its control allows, then close.
fn run_thread(h: &RunHandle, scene: Scene, text: &str, out: &Path, opts: &LaunchOptions) {
    let mut run = match CoupledRun::launch(scene, text, out, opts) {
        Ok(r) => r,
        Err(e) => {
            h.status.send_modify(|r| {
                r.set_state(RunState::Failed);
                r.error = e.to_string();
            });
            return;
        }
    };
    h.status.send_modify(|r| {
        r.set_state(RunState::Ready);
        r.windows_total = run.windows();
        r.windows_done = run.windows_done();
        r.time = run.windows_done() as f64 * run.plan().window;
        r.window = run.plan().window;
        r.window_reason = run.plan().reason.clone();
        r.end_time = run.end_time();
    });
    // A restored run starts READY at its checkpoint's window.
    let first = run.windows_done();
    let mut failure = None;
    let mut stopped = false;
    loop {
        enum Next {
            Apply(Vec<Pending>),
            Advance,
            Stop,
            Done,
        }
        let next = {
            let mut c = h.ctl.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if !c.pending.is_empty() {
                    break Next::Apply(std::mem::take(&mut c.pending));
                }
                if c.stop {
                    break Next::Stop;
                }
                if run.done() {
                    break Next::Done;
                }
                if c.budget != Some(0) {
                    if let Some(b) = c.budget.as_mut() {
                        *b -= 1;
                    }
                    break Next::Advance;
                }
                let idle = if run.windows_done() == first {
                    RunState::Ready
                } else {
                    RunState::Paused
                };
                h.status.send_if_modified(|r| {
                    let change = r.state() != idle;
                    r.set_state(idle);
                    change
                });
                c = h.wake.wait(c).unwrap_or_else(|e| e.into_inner());
            }
        };
        match next {
            // Made with the lock released: a checkpoint takes a while.
            Next::Apply(list) => {
                for p in list {
                    match apply(&mut run, h, p.change) {
                        Ok(a) => {
                            let _ = p.reply.send(Ok(a));
                        }
                        Err(RunError::Refused(why)) => {
                            let _ = p.reply.send(Err(why));
                        }
                        Err(e) => {
                            let _ = p.reply.send(Err(format!("the run failed: {e}")));
                            failure = Some(e.to_string());
                        }
                    }
                }
                if failure.is_some() {
                    break;
                }
            }
            Next::Stop => {
                stopped = true;
                break;
            }
            Next::Done => break,
            Next::Advance => {
                h.status.send_if_modified(|r| {
                    let change = r.state() != RunState::Running;
                    r.set_state(RunState::Running);
                    change
                });
                match run.advance() {
                    Ok(w) => {
                        // No watcher is no error: the frame is simply not kept.
                        let _ = h.frames.send(Arc::new(frame(&w, &run)));
                        h.status.send_modify(|r| {
                            r.windows_done = w.step + 1;
                            r.time = w.end;
                            r.wall_seconds += w.wall_s;
                        });
                    }
                    Err(e) => {
                        failure = Some(e.to_string());
                        break;
                    }
                }
            }
        }
    }
    // Changes asked for after the last boundary are answered by the run's end.
    for p in std::mem::take(&mut h.ctl.lock().unwrap_or_else(|e| e.into_inner()).pending) {
        let _ = p.reply.send(Err(format!(
            "run {} ended before the change was made",
            h.id
        )));
    }
    let closed = run.close(failure.is_none());
    let failure = failure.or_else(|| closed.err().map(|e| e.to_string()));
    h.status.send_modify(|r| match failure {
        Some(e) => {
            r.set_state(RunState::Failed);
            r.error = e;
        }
        None if stopped => r.set_state(RunState::Stopped),
        None => r.set_state(RunState::Finished),
    });
}

fn vec3(v: [f64; 3]) -> Option<Vec3> {
    Some(Vec3 {
        x: v[0],
        y: v[1],
        z: v[2],
    })
}

/// The telemetry frame of a window just done.
fn frame(w: &WindowDone, run: &CoupledRun) -> WindowFrame {
    let loads = crate::outputs::loads_by_body(run.loads());
    WindowFrame {
        step: w.step,
        time: w.end,
        window: w.window,
        fluid_substeps: w.fluid.map_or(0, |r| r.substeps),
        dem_substeps: w.dem.map_or(0, |r| r.substeps),
        wall_seconds: w.wall_s,
        fluid_compute_seconds: w.fluid.map_or(0.0, |r| r.compute_us * 1e-6),
        dem_compute_seconds: w.dem.map_or(0.0, |r| r.compute_us * 1e-6),
        kinetic_energy: w.fluid.map_or(0.0, |r| r.kinetic_energy),
        max_speed: w.fluid.map_or(0.0, |r| r.max_speed),
        max_density_error: w.fluid.map_or(0.0, |r| r.max_density_error),
        bodies: run
            .states()
            .iter()
            .map(|s| {
                let load = loads.get(s.body as usize).copied().flatten();
                let o = s.orientation;
                BodyFrame {
                    body: s.body,
                    position: vec3(s.position),
                    orientation: Some(Quat {
                        x: o[0],
                        y: o[1],
                        z: o[2],
                        w: o[3],
                    }),
                    linear_velocity: vec3(s.linear_velocity),
                    angular_velocity: vec3(s.angular_velocity),
                    force: vec3(load.map_or([0.0; 3], |l| l.force)),
                    moment: vec3(load.map_or([0.0; 3], |l| l.moment)),
                }
            })
            .collect(),
        missed: 0,
    }
}

/// Refuses calls without the configured bearer token.
#[derive(Clone)]
struct BearerToken(Option<Arc<str>>);

impl tonic::service::Interceptor for BearerToken {
    fn call(&mut self, req: Request<()>) -> Result<Request<()>, Status> {
        let Some(token) = &self.0 else {
            return Ok(req);
        };
        let given = req
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "));
        if given == Some(&**token) {
            Ok(req)
        } else {
            Err(Status::unauthenticated(
                "this server needs `authorization: Bearer <token>` (couplet ctl --token-file)",
            ))
        }
    }
}

/// TLS identity, PEM files.
#[derive(Debug, Clone)]
pub struct TlsFiles {
    pub cert: PathBuf,
    pub key: PathBuf,
}

/// Serves the API on `listener` until `shutdown` resolves, then stops every live run.
/// Reflection and the standard health service are on.
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    service: CoupletService,
    tls: Option<&TlsFiles>,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<CoupletServer<CoupletService>>().await;
    // Reflection in both versions: grpcurl and most tools ask v1, older clients (and
    // Python's grpcio-reflection) v1alpha.
    let reflection = || {
        tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(grpc::FILE_DESCRIPTOR_SET)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
    };
    let reflection_v1 = reflection()
        .build_v1()
        .context("building the reflection service")?;
    let reflection_v1alpha = reflection()
        .build_v1alpha()
        .context("building the reflection service")?;
    let auth = BearerToken(service.cfg.token.as_deref().map(Arc::from));
    let mut builder = tonic::transport::Server::builder();
    if let Some(t) = tls {
        let read = |p: &Path| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
        let identity = tonic::transport::Identity::from_pem(read(&t.cert)?, read(&t.key)?);
        builder = builder
            .tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))
            .context("TLS set-up")?;
    }
    let svc = service.clone();
    builder
        .add_service(health_service)
        .add_service(reflection_v1)
        .add_service(reflection_v1alpha)
        .add_service(CoupletServer::with_interceptor(svc, auth))
        .serve_with_incoming_shutdown(TcpListenerStream::new(listener), shutdown)
        .await
        .context("gRPC server")?;
    service.stop_all().await;
    Ok(())
}

/// Loopback by default; any other address only with a token: whoever reaches the port
/// can start processes on this machine.
pub fn check_listen(listen: SocketAddr, has_token: bool) -> anyhow::Result<()> {
    if !listen.ip().is_loopback() && !has_token {
        anyhow::bail!(
            "--listen {listen} is not a loopback address: anyone who reaches it could start \
             processes on this machine, so it needs --token-file (and TLS: --tls-cert/--tls-key)"
        );
    }
    Ok(())
}

/// `couplet serve`: checks the address rule (loopback, or a token), binds, prints the
/// address and serves until Ctrl-C or SIGTERM.
pub fn serve(listen: SocketAddr, cfg: ServeConfig, tls: Option<TlsFiles>) -> anyhow::Result<()> {
    check_listen(listen, cfg.token.is_some())?;
    std::fs::create_dir_all(&cfg.data_dir)
        .map_err(|e| anyhow::anyhow!("creating {}: {e}", cfg.data_dir.display()))?;
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(listen)
            .await
            .map_err(|e| anyhow::anyhow!("binding {listen}: {e}"))?;
        eprintln!(
            "couplet serve: listening on {}{} (runs in {}, at most {} live)",
            listener.local_addr()?,
            if tls.is_some() { " with TLS" } else { "" },
            cfg.data_dir.display(),
            cfg.max_runs
        );
        let shutdown = async {
            let mut term =
                tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    .expect("SIGTERM handler");
            tokio::select! {
                _ = tokio::signal::ctrl_c() => {}
                _ = term.recv() => {}
            }
            eprintln!("couplet serve: shutting down; stopping live runs");
        };
        serve_on(listener, CoupletService::new(cfg), tls.as_ref(), shutdown).await
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_loopback_listens_without_a_token() {
        assert!(check_listen("127.0.0.1:50051".parse().unwrap(), false).is_ok());
        assert!(check_listen("[::1]:50051".parse().unwrap(), false).is_ok());
        let e = check_listen("0.0.0.0:50051".parse().unwrap(), false).unwrap_err();
        assert!(e.to_string().contains("--token-file"), "{e}");
        assert!(check_listen("0.0.0.0:50051".parse().unwrap(), true).is_ok());
    }

    #[test]
    fn a_call_without_the_bearer_token_is_unauthenticated() {
        use tonic::service::Interceptor;
        let mut auth = BearerToken(Some(Arc::from("s3cret")));
        let bare = auth.call(Request::new(())).unwrap_err();
        assert_eq!(bare.code(), tonic::Code::Unauthenticated);
        let mut wrong = Request::new(());
        wrong
            .metadata_mut()
            .insert("authorization", "Bearer nope".parse().unwrap());
        assert_eq!(
            auth.call(wrong).unwrap_err().code(),
            tonic::Code::Unauthenticated
        );
        let mut right = Request::new(());
        right
            .metadata_mut()
            .insert("authorization", "Bearer s3cret".parse().unwrap());
        assert!(auth.call(right).is_ok());
        assert!(BearerToken(None).call(Request::new(())).is_ok());
    }
}
