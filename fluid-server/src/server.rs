//! The fluid server's process loop (iceoryx2 exchange).
//!
//! Serial-explicit window n → n+1 (DESIGN.md): take the DEM's coupling points and body
//! states for t_n, advance the fluid over the window in as many substeps as its own
//! limit needs, publish the per-body loads (reduced on the GPU), and at output times a
//! particle snapshot for the recording.

use crate::checkpoint::FluidState;
use crate::error::FluidError;
use crate::gpu::{Gpu, GpuError};
use crate::marker_update::AccelerationEstimate;
use crate::solver::FluidSolver;
use couplet_protocol::state::{
    StateDirs, StateError, checkpoint_dir, read_state, state_file, write_state,
};
use couplet_protocol::transport::{Control, Endpoint, Inbox, Orchestrator, TransportError};
use couplet_protocol::{
    BodyLoad, BodyState, CommandKind, CouplingPoint, Hello, PROTOCOL_VERSION, ParticleRecord, Role,
    Scene, ServiceLeaf, SideReport, WindowHeader, monotonic_ns, validate_points, validate_states,
};
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Fluid(#[from] FluidError),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("the scene has no [fluid] section: there is nothing for a fluid server to do")]
    NoFluid,
    #[error(
        "command for window {step} speaks protocol {got}, this fluid-server speaks {PROTOCOL_VERSION}"
    )]
    Version { step: u64, got: u32 },
    #[error("unknown command kind {0}")]
    UnknownCommand(u32),
    #[error(transparent)]
    State(#[from] StateError),
    #[error("asked for a checkpoint, but this fluid-server was started without --checkpoints DIR")]
    NoCheckpointDir,
}

/// Runs the fluid side of run `run_id` until the orchestrator says shutdown or goes away;
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
    if scene.fluid.is_none() {
        return Err(ServerError::NoFluid);
    }
    let gpu = Gpu::new()?;
    // Joubert eq. (25) needs the markers' acceleration; the DEM sends velocities.
    let mut acceleration_estimate = AccelerationEstimate::default();
    let mut solver = match &dirs.restore {
        None => FluidSolver::new(&gpu, scene)?,
        Some(dir) => {
            let (_, state): (_, FluidState) =
                read_state(&state_file(dir, Role::Fluid), Role::Fluid)?;
            acceleration_estimate = state.acceleration.clone();
            FluidSolver::restore(&gpu, scene, &state)?
        }
    };
    let coupled = scene.exchanges_loads();
    let resolved = scene.has_resolved_bodies();
    // The same loads and states as when sent after the advance (serial-explicit,
    // DESIGN.md); only the DEM's step leaves the window's critical path.
    let loads_before_advance = scene.loads_known_at_window_start();
    let n_bodies = scene.bodies.len();
    let counts = solver.counts();
    let limits = solver.limits();

    let ep = Endpoint::named(run_id, Role::Fluid.name())?;
    let report = Control::report_sender(&ep)?;
    let points_rx = ep.slice_receiver::<CouplingPoint>(ServiceLeaf::Points)?;
    let bodies_rx = ep.slice_receiver::<BodyState>(ServiceLeaf::Bodies)?;
    let loads_tx = ep.slice_sender::<BodyLoad>(ServiceLeaf::Loads, n_bodies)?;
    let particles_tx =
        ep.slice_sender::<ParticleRecord>(ServiceLeaf::Particles, counts.fluid as usize)?;
    let wake = ep.wake_listener(ServiceLeaf::FluidWake)?;
    let wake_dem = ep.waker(ServiceLeaf::DemWake)?;
    let wake_orchestrator = ep.waker(ServiceLeaf::OrchestratorWake)?;

    let greeting = Hello {
        protocol_version: PROTOCOL_VERSION,
        role: Role::Fluid as u32,
        pid: std::process::id(),
        scene_digest,
        dt_limit: limits.dt,
        dt_acoustic: limits.dt_acoustic,
        dt_viscous: limits.dt_viscous,
        count: counts.fluid as u64,
    };
    let mut inbox = Inbox::greet(&ep, greeting, &wake, &wake_orchestrator, orchestrator)?;

    let alive = || orchestrator.check();
    let mut points: Vec<CouplingPoint> = Vec::new();
    let mut states: Vec<BodyState> = Vec::new();
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
                let v = cmd.values;
                match kind {
                    CommandKind::SetGravity => solver.set_gravity(&gpu, [v[0], v[1], v[2]]),
                    CommandKind::Checkpoint => {
                        let root = dirs
                            .checkpoints
                            .as_ref()
                            .ok_or(ServerError::NoCheckpointDir)?;
                        let state = solver.save_state(&gpu, &acceleration_estimate)?;
                        let path = state_file(&checkpoint_dir(root, cmd.step), Role::Fluid);
                        write_state(&path, Role::Fluid, cmd.step, cmd.time, &state)?;
                    }
                    // A kinematic body's new velocity reaches the fluid with its state.
                    _ => {}
                }
                report.send(SideReport::acknowledging(Role::Fluid, &cmd))?;
                wake_orchestrator.wake()?;
                continue;
            }
            None => return Err(ServerError::UnknownCommand(cmd.kind)),
        }
        let step = cmd.step;
        let mut exchange_us = 0.0;
        let mut wait_us = 0.0;
        if coupled {
            let wait_start = Instant::now();
            let wait_start_ns = monotonic_ns();
            let (mut got_points, mut got_states) = (false, false);
            wake.wait_for(
                || {
                    if !got_points && let Some(s) = points_rx.try_step(step)? {
                        exchange_us += hop_us(s.user_header(), wait_start_ns);
                        validate_points(s.payload(), n_bodies).map_err(|source| {
                            TransportError::Invalid {
                                service: points_rx.service.clone(),
                                source,
                            }
                        })?;
                        points.clear();
                        points.extend_from_slice(s.payload());
                        got_points = true;
                    }
                    if !got_states && let Some(s) = bodies_rx.try_step(step)? {
                        exchange_us += hop_us(s.user_header(), wait_start_ns);
                        validate_states(s.payload(), n_bodies).map_err(|source| {
                            TransportError::Invalid {
                                service: bodies_rx.service.clone(),
                                source,
                            }
                        })?;
                        states.clear();
                        states.extend_from_slice(s.payload());
                        got_states = true;
                    }
                    Ok((got_points && got_states).then_some(()))
                },
                alive,
            )?;
            wait_us = wait_start.elapsed().as_secs_f64() * 1e6;
            let t = Instant::now();
            if resolved {
                let accelerations = acceleration_estimate.update(solver.time(), &states);
                solver.set_bodies(&gpu, &states, &points, &accelerations)?;
            }
            exchange_us += t.elapsed().as_secs_f64() * 1e6;
        }

        let compute = Instant::now();
        // Unresolved grains: the force at t_n, held over the window like the markers' loads
        // (with energy-pair, plus the pressure force averaged over the window's stages).
        let mut grain_loads = solver.grain_loads(&gpu, &states, None)?;
        let mut compute_us = compute.elapsed().as_secs_f64() * 1e6;
        let mut send_loads = |loads: &[BodyLoad]| -> Result<(), ServerError> {
            let t = Instant::now();
            loads_tx.send(
                WindowHeader::new(step, cmd.time, cmd.window, loads.len()),
                loads,
            )?;
            wake_dem.wake()?;
            exchange_us += t.elapsed().as_secs_f64() * 1e6;
            Ok(())
        };
        if loads_before_advance {
            send_loads(&grain_loads)?;
        }
        let advance = Instant::now();
        let substeps = solver.advance(&gpu, cmd.window, None)?;
        solver.add_grain_pressure_forces(&gpu, &mut grain_loads)?;
        let loads_after_advance = if coupled && !loads_before_advance {
            let mut loads = solver.loads(&gpu)?;
            loads.extend_from_slice(&grain_loads);
            Some(loads)
        } else {
            None
        };
        compute_us += advance.elapsed().as_secs_f64() * 1e6;
        if let Some(loads) = loads_after_advance {
            send_loads(&loads)?;
        }
        if cmd.snapshot != 0 {
            let snapshot = solver.snapshot(&gpu)?;
            particles_tx.send(
                WindowHeader::new(step, cmd.time + cmd.window, cmd.window, snapshot.len()),
                &snapshot,
            )?;
        }
        report.send(SideReport {
            protocol_version: PROTOCOL_VERSION,
            role: Role::Fluid as u32,
            step,
            substeps,
            compute_us,
            wait_us,
            exchange_us,
            dt_limit: limits.dt,
            near_singular: solver.near_singular(),
            reflected: solver.reflected(),
            shift_limited: solver.shift_limited(),
            kind: CommandKind::Advance as u32,
            kinetic_energy: solver.stats().kinetic_energy,
            max_speed: solver.stats().max_speed,
            max_density_error: solver.stats().max_density_error,
        })?;
        wake_orchestrator.wake()?;
    }
}

/// The hop's share of the exchange, µs: from the later of the sample's send and the
/// moment this side started waiting for it, to now. A sample sent while this side was
/// still busy elsewhere (the DEM publishes t_{n+1} before the next command) waited in
/// shared memory at no cost to the window.
pub(crate) fn hop_us(h: &WindowHeader, wait_start_ns: u64) -> f64 {
    monotonic_ns().saturating_sub(h.sent_ns.max(wait_start_ns)) as f64 * 1e-3
}
