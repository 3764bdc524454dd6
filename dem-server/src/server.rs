//! The DEM server's process loop (iceoryx2 exchange).
//!
//! Serial-explicit window n → n+1 (DESIGN.md): publish body states and coupling points
//! for t_n, wait for the fluid loads of window n, hold them over as many DEM substeps
//! as `stable_dt` needs, report. States for t_{n+1} are published right after the
//! substeps so that the fluid finds them waiting when the next command arrives.

use crate::engine::{DemEngine, DemError};
use crate::markers::MarkerSet;
use crate::registry::create_engine;
use couplet_protocol::state::{
    StateDirs, StateError, checkpoint_dir, read_state, state_file, write_state,
};
use couplet_protocol::transport::{Control, Endpoint, Inbox, Orchestrator, TransportError};
use couplet_protocol::{
    BodyLoad, BodyState, Command, CommandKind, CouplingPoint, Hello, PROTOCOL_VERSION, Role, Scene,
    ServiceLeaf, SideReport, WindowHeader, monotonic_ns, validate_loads,
};
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error(transparent)]
    Dem(#[from] DemError),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error(
        "command for window {step} speaks protocol {got}, this dem-server speaks {PROTOCOL_VERSION}"
    )]
    Version { step: u64, got: u32 },
    #[error("unknown command kind {0}")]
    UnknownCommand(u32),
    #[error(transparent)]
    State(#[from] StateError),
    #[error("asked for a checkpoint, but this dem-server was started without --checkpoints DIR")]
    NoCheckpointDir,
    #[error("the checkpoint in {dir} is of dem.engine \"{saved}\"; this scene runs \"{engine}\"")]
    EngineMismatch {
        dir: String,
        saved: String,
        engine: String,
    },
    #[error("window {step}: fluid sent {got} loads for {expected} coupled bodies")]
    LoadCount {
        step: u64,
        got: usize,
        expected: usize,
    },
}

/// What a checkpoint holds of the DEM side: the engine's own state, named.
#[derive(serde::Serialize, serde::Deserialize)]
struct DemCheckpoint {
    engine: String,
    state: Vec<u8>,
}

/// Runs the DEM side of run `run_id` until the orchestrator says shutdown or goes away;
/// from the checkpoint `dirs.restore` when given. `orchestrator` says how to tell that it
/// is still there (it started this process, or it runs apart); `scene_digest` is
/// [`couplet_protocol::scene_digest`] of the scene file loaded, which the orchestrator
/// checks against its own.
pub fn serve(
    run_id: &str,
    scene: &Scene,
    orchestrator: &Orchestrator,
    scene_digest: u32,
    dirs: &StateDirs,
) -> Result<(), ServerError> {
    // On a thread of the worker pool, which then takes its share of the CPU sums
    // (`couplet_protocol::worker_pool`).
    couplet_protocol::in_worker_pool(|| serve_here(run_id, scene, orchestrator, scene_digest, dirs))
}

fn serve_here(
    run_id: &str,
    scene: &Scene,
    orchestrator: &Orchestrator,
    scene_digest: u32,
    dirs: &StateDirs,
) -> Result<(), ServerError> {
    let mut engine = create_engine(scene)?;
    if let Some(dir) = &dirs.restore {
        let (_, saved): (_, DemCheckpoint) = read_state(&state_file(dir, Role::Dem), Role::Dem)?;
        if saved.engine != engine.name() {
            return Err(ServerError::EngineMismatch {
                dir: dir.display().to_string(),
                saved: saved.engine,
                engine: engine.name().into(),
            });
        }
        engine.restore_state(&saved.state)?;
    }
    let markers = MarkerSet::from_scene(scene)?;
    let coupled = scene.exchanges_loads();
    // One load per body with markers and one per unresolved grain.
    let expected_loads = markers.body_count() + scene.grains().len();
    let n_bodies = engine.body_count();

    let ep = Endpoint::named(run_id, Role::Dem.name())?;
    let report = Control::report_sender(&ep)?;
    let bodies_tx = ep.slice_sender::<BodyState>(ServiceLeaf::Bodies, n_bodies)?;
    let points_tx = ep.slice_sender::<CouplingPoint>(ServiceLeaf::Points, markers.len())?;
    let loads_rx = ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads)?;
    let wake = ep.wake_listener(ServiceLeaf::DemWake)?;
    let wake_fluid = ep.waker(ServiceLeaf::FluidWake)?;
    let wake_orchestrator = ep.waker(ServiceLeaf::OrchestratorWake)?;

    // Hello last: once the orchestrator has it, every port of this process exists.
    let greeting = Hello {
        protocol_version: PROTOCOL_VERSION,
        role: Role::Dem as u32,
        pid: std::process::id(),
        scene_digest,
        dt_limit: engine.stable_dt(),
        count: n_bodies as u64,
        ..Default::default()
    };
    let mut inbox = Inbox::greet(&ep, greeting, &wake, &wake_orchestrator, orchestrator)?;

    let mut states = Vec::with_capacity(n_bodies);
    let mut points = Vec::with_capacity(markers.len());
    let mut loads: Vec<BodyLoad> = Vec::with_capacity(n_bodies);
    let mut published: Option<u64> = None;
    let alive = || orchestrator.check();

    loop {
        let cmd = inbox.next_command()?;
        if cmd.protocol_version != PROTOCOL_VERSION {
            return Err(ServerError::Version {
                step: cmd.step,
                got: cmd.protocol_version,
            });
        }
        match cmd.kind() {
            Some(CommandKind::Shutdown) => return Ok(()),
            Some(CommandKind::Advance) => {}
            Some(kind) => {
                apply(&mut *engine, &cmd, kind, dirs)?;
                if kind == CommandKind::SetKinematicVelocity && published == Some(cmd.step) {
                    // The states already published for this window carry the old
                    // velocity: publish them again before the acknowledgement, so the
                    // fluid finds only the new ones newest when the window starts.
                    publish(
                        &*engine,
                        &markers,
                        cmd.step,
                        cmd.time,
                        cmd.window,
                        &mut states,
                        &mut points,
                        &bodies_tx,
                        &points_tx,
                    )?;
                }
                report.send(SideReport::acknowledging(Role::Dem, &cmd))?;
                wake_orchestrator.wake()?;
                continue;
            }
            None => return Err(ServerError::UnknownCommand(cmd.kind)),
        }
        let (step, window) = (cmd.step, cmd.window);
        let mut exchange_us = 0.0;
        if published != Some(step) {
            exchange_us += publish(
                &*engine,
                &markers,
                step,
                cmd.time,
                window,
                &mut states,
                &mut points,
                &bodies_tx,
                &points_tx,
            )?;
            wake_fluid.wake()?;
        }

        let wait_start = Instant::now();
        let wait_start_ns = monotonic_ns();
        let mut wait_us = 0.0;
        loads.clear();
        if coupled {
            let sample = wake.wait_for(|| loads_rx.try_step(step), alive)?;
            wait_us = wait_start.elapsed().as_secs_f64() * 1e6;
            let t = Instant::now();
            // From the later of send and the start of the wait (see the fluid server's hop_us).
            let hop_us = monotonic_ns()
                .saturating_sub(sample.user_header().sent_ns.max(wait_start_ns))
                as f64
                * 1e-3;
            validate_loads(sample.payload(), n_bodies).map_err(|source| {
                TransportError::Invalid {
                    service: loads_rx.service.clone(),
                    source,
                }
            })?;
            loads.extend_from_slice(sample.payload());
            if loads.len() != expected_loads {
                return Err(ServerError::LoadCount {
                    step,
                    got: loads.len(),
                    expected: expected_loads,
                });
            }
            exchange_us += hop_us + t.elapsed().as_secs_f64() * 1e6;
        }

        let compute = Instant::now();
        engine.set_fluid_loads(&loads)?;
        let dt_limit = engine.stable_dt();
        let substeps = (window / dt_limit).ceil().max(1.0) as u32;
        let dt = window / substeps as f64;
        for _ in 0..substeps {
            engine.step(dt)?;
        }
        let compute_us = compute.elapsed().as_secs_f64() * 1e6;

        exchange_us += publish(
            &*engine,
            &markers,
            step + 1,
            cmd.time + window,
            window,
            &mut states,
            &mut points,
            &bodies_tx,
            &points_tx,
        )?;
        published = Some(step + 1);
        report.send(SideReport {
            protocol_version: PROTOCOL_VERSION,
            role: Role::Dem as u32,
            step,
            substeps,
            compute_us,
            wait_us,
            exchange_us,
            dt_limit,
            kind: CommandKind::Advance as u32,
            ..Default::default()
        })?;
        wake_orchestrator.wake()?;
    }
}

/// A change between windows: gravity, a kinematic body's velocity, or a checkpoint.
fn apply(
    engine: &mut dyn DemEngine,
    cmd: &Command,
    kind: CommandKind,
    dirs: &StateDirs,
) -> Result<(), ServerError> {
    let v = cmd.values;
    match kind {
        CommandKind::SetGravity => engine.set_gravity([v[0], v[1], v[2]]),
        CommandKind::SetKinematicVelocity => engine.set_kinematic_velocity(
            cmd.body as usize,
            [v[0], v[1], v[2]],
            [v[3], v[4], v[5]],
        )?,
        CommandKind::Checkpoint => {
            let root = dirs
                .checkpoints
                .as_ref()
                .ok_or(ServerError::NoCheckpointDir)?;
            let state = DemCheckpoint {
                engine: engine.name().into(),
                state: engine.save_state()?,
            };
            let path = state_file(&checkpoint_dir(root, cmd.step), Role::Dem);
            write_state(&path, Role::Dem, cmd.step, cmd.time, &state)?;
        }
        CommandKind::Advance | CommandKind::Shutdown => {}
    }
    Ok(())
}

/// Publishes states and world-frame coupling points for window `step`; returns the µs spent.
#[allow(clippy::too_many_arguments)]
fn publish(
    engine: &dyn DemEngine,
    markers: &MarkerSet,
    step: u64,
    time: f64,
    window: f64,
    states: &mut Vec<BodyState>,
    points: &mut Vec<CouplingPoint>,
    bodies_tx: &couplet_protocol::transport::SliceSender<BodyState>,
    points_tx: &couplet_protocol::transport::SliceSender<CouplingPoint>,
) -> Result<f64, ServerError> {
    let t = Instant::now();
    states.clear();
    engine.states(states);
    points.clear();
    markers.world_points(states, points);
    // Points first: the fluid waits for both and reads bodies last.
    points_tx.send(WindowHeader::new(step, time, window, points.len()), points)?;
    bodies_tx.send(WindowHeader::new(step, time, window, states.len()), states)?;
    Ok(t.elapsed().as_secs_f64() * 1e6)
}
