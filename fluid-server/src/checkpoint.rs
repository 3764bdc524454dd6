//! What a checkpoint holds of the fluid ([`FluidState`]): every GPU buffer that carries
//! state from one step or window to the next, byte for byte and in buffer order (the
//! neighbour sort is stable, so the order is part of the state: the same order gives
//! the same pair sums), and the solver's CPU bookkeeping. A solver built for the same
//! scene and given this state continues bit for bit as the saved one would have
//! ([`crate::FluidSolver::save_state`], [`crate::FluidSolver::restore`]).

use crate::error::FluidError;
use crate::gpu::Gpu;
use crate::marker_update::AccelerationEstimate;
use crate::particles::{ParticleKinds, ParticleSet};
use crate::solver::SphData;
use crate::window_stats::WindowStats;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FluidState {
    /// Particles per kind (fluid, wall, markers).
    pub kinds: [usize; 3],
    pub marker_capacity: Option<usize>,
    pub body_capacity: usize,
    pub load_bodies: Vec<u32>,
    /// [`crate::StepParams`] as its bytes.
    pub step_params: Vec<u8>,
    /// Gravity on the fluid (it may have changed during the run).
    pub gravity_fluid: [f64; 3],
    pub time: f64,
    pub steps: u64,
    pub loads_ready: bool,
    pub near_singular: u32,
    pub stats: [f64; 3],
    /// Named buffers, whole (see [`state_buffers`]).
    pub buffers: Vec<(String, Vec<u8>)>,
    /// The fluid server's estimate of the bodies' accelerations (Joubert eq. 25 at markers).
    pub acceleration: AccelerationEstimate,
}

/// Every buffer of `d` that carries state across steps or windows, by name. Scratch
/// (the neighbour grid's sort buffers, the blow-up status, telemetry partials) is left
/// out: each step or window rewrites it before reading.
pub fn state_buffers(d: &SphData) -> Vec<(&'static str, &wgpu::Buffer)> {
    let mut out = vec![
        ("pos", &d.pos),
        ("vel", &d.vel),
        ("rho", &d.rho),
        ("press", &d.press),
        ("id", &d.id),
        ("drho", &d.drho),
        ("dvel", &d.dvel),
        ("rho_n", &d.rho_n),
        ("vel_n", &d.vel_n),
        ("low_words", &d.low_words),
    ];
    if let Some(b) = &d.bodies {
        out.extend([
            ("markers_in", &b.markers_in),
            ("bodies", &b.bodies),
            ("clock", &b.clock),
            ("marker_load", &b.marker_load),
            ("marker_load_c", &b.marker_load_c),
            ("load_ranges", &b.load_ranges),
            ("body_loads", &b.body_loads),
        ]);
    }
    if let Some(g) = &d.gradients {
        out.extend([("bmat", &g.bmat), ("grads", &g.grads), ("diag", &g.diag)]);
        if let Some(b) = &g.bhat {
            out.push(("bhat", b));
        }
    }
    out.extend(d.wall_vel.as_ref().map(|b| ("wall_vel", b)));
    out.extend(d.boundary_frame.as_ref().map(|b| ("boundary_frame", b)));
    out.extend(d.solid.as_ref().map(|b| ("solid", b)));
    if let Some(r) = &d.reaction {
        out.extend([("reaction_lo", &r.lo), ("reaction_hi", &r.hi)]);
    }
    out
}

/// Reads every state buffer of `d` back.
pub fn read_buffers(gpu: &Gpu, d: &SphData) -> Result<Vec<(String, Vec<u8>)>, FluidError> {
    state_buffers(d)
        .into_iter()
        .map(|(name, b)| {
            let words: Vec<u32> = gpu.read_buffer(b, 0, b.size() / 4)?;
            Ok((name.to_owned(), bytemuck::cast_slice(&words).to_vec()))
        })
        .collect()
}

/// Writes the saved buffers into `d`, which must hold the same buffers at the same sizes.
pub fn write_buffers(
    gpu: &Gpu,
    d: &SphData,
    saved: &[(String, Vec<u8>)],
) -> Result<(), FluidError> {
    let here = state_buffers(d);
    let names = |v: &mut dyn Iterator<Item = &str>| v.collect::<Vec<_>>().join(", ");
    if here.len() != saved.len() || here.iter().zip(saved).any(|((a, _), (b, _))| a != b) {
        return Err(FluidError::Restore(format!(
            "the checkpoint holds the buffers [{}], this scene's solver has [{}]: another scene or build",
            names(&mut saved.iter().map(|(n, _)| n.as_str())),
            names(&mut here.iter().map(|(n, _)| *n)),
        )));
    }
    for ((name, buffer), (_, bytes)) in here.iter().zip(saved) {
        if buffer.size() != bytes.len() as u64 {
            return Err(FluidError::Restore(format!(
                "buffer {name}: {} bytes saved, {} here",
                bytes.len(),
                buffer.size()
            )));
        }
        gpu.queue.write_buffer(buffer, 0, bytes);
    }
    Ok(())
}

/// A particle set of the saved kinds and positions (world frame): what the solver is
/// built from before the saved buffers overwrite its state.
pub fn particle_set(
    state: &FluidState,
    origin: [f64; 3],
    lattice_mass: f64,
) -> Result<ParticleSet, FluidError> {
    let buffer = |name: &str| {
        state
            .buffers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.as_slice())
            .ok_or_else(|| FluidError::Restore(format!("the checkpoint has no {name} buffer")))
    };
    let [n_fluid, n_wall, n_markers] = state.kinds;
    let kinds = ParticleKinds {
        n_fluid,
        n_wall,
        n_markers,
    };
    let n = kinds.total();
    let pos: &[[f32; 4]] = bytemuck::try_cast_slice(buffer("pos")?)
        .map_err(|e| FluidError::Restore(format!("pos buffer: {e}")))?;
    let ids: &[u32] = bytemuck::try_cast_slice(buffer("id")?)
        .map_err(|e| FluidError::Restore(format!("id buffer: {e}")))?;
    if pos.len() < n || ids.len() < n {
        return Err(FluidError::Restore(format!(
            "{} positions and {} ids saved for {n} particles",
            pos.len(),
            ids.len()
        )));
    }
    Ok(ParticleSet {
        pos: pos[..n]
            .iter()
            .map(|p| std::array::from_fn(|k| f64::from(p[k]) + origin[k]))
            .collect(),
        vel: vec![[0.0; 3]; n],
        rho: vec![0.0; n],
        press: vec![0.0; n],
        mass: vec![lattice_mass; n],
        id: ids[..n].to_vec(),
        kinds,
    })
}

impl FluidState {
    pub fn stats(&self) -> WindowStats {
        let [kinetic_energy, max_speed, max_density_error] = self.stats;
        WindowStats {
            kinetic_energy,
            max_speed,
            max_density_error,
        }
    }
}
