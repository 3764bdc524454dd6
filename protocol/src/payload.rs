//! Zero-copy payloads exchanged through iceoryx2: `#[repr(C)]`, no pointers, arrays as slices.
//!
//! Body-level quantities are `f64` (the DEM integrates in double precision and the
//! per-body loads are reductions whose digits matter); coupling points are `f32`
//! because they are uploaded to the GPU as they are, three `vec4<f32>` each.

use iceoryx2::prelude::ZeroCopySend;

/// Bumped whenever a payload layout or the meaning of a field changes; a peer with
/// another version is refused at the handshake.
pub const PROTOCOL_VERSION: u32 = 3;

/// User header of every windowed sample: which coupling window the slice belongs to.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct WindowHeader {
    pub protocol_version: u32,
    /// Number of elements the sender meant to send (checked against the slice length).
    pub count: u32,
    /// Coupling-window index `n` (the data describe time `t_n`, or the window `n → n+1`).
    pub step: u64,
    /// Simulation time of the data, s.
    pub time: f64,
    /// Length of the coupling window, s.
    pub window: f64,
    /// CLOCK_MONOTONIC of the sender when it sent the sample, ns: the receiver measures
    /// the hop (both run on one host, and that clock is system-wide).
    pub sent_ns: u64,
}

impl WindowHeader {
    pub fn new(step: u64, time: f64, window: f64, count: usize) -> Self {
        Self {
            protocol_version: PROTOCOL_VERSION,
            count: count as u32,
            step,
            time,
            window,
            sent_ns: 0,
        }
    }
}

/// CLOCK_MONOTONIC, ns: comparable between processes on one host (unlike `Instant`).
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// State of one rigid body at the start of a window, world frame, SI units.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, serde::Serialize, serde::Deserialize,
)]
#[repr(C)]
pub struct BodyState {
    /// Centre of mass, m.
    pub position: [f64; 3],
    /// Index of the body in the scene's `[[bodies]]` list.
    pub body: u32,
    /// 0 fixed, 1 kinematic, 2 dynamic (see [`crate::Motion`]).
    pub motion: u32,
    /// Unit quaternion `[x, y, z, w]` rotating body axes to world axes.
    pub orientation: [f64; 4],
    /// Velocity of the centre of mass, m/s.
    pub linear_velocity: [f64; 3],
    /// Angular velocity, rad/s, world frame.
    pub angular_velocity: [f64; 3],
    /// Mass, kg.
    pub mass: f64,
    /// Solid volume, m³ (buoyancy of Joubert eq. 28 uses it).
    pub volume: f64,
}

/// One world-frame coupling point: a surface marker of a resolved body (Joubert §2.6),
/// a fill point behind its surface (Adami's wall model: `measure` = 0), or an
/// unresolved grain. 48 bytes: three `vec4<f32>` on the GPU.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct CouplingPoint {
    /// Position, m.
    pub position: [f32; 3],
    /// Surface area the marker stands for (resolved), m²; 0 for a fill point, which
    /// completes the fluid's support inside the body and carries no surface (no load);
    /// or particle volume (unresolved), m³.
    pub measure: f32,
    /// Rigid-body velocity at the point (Joubert eq. 33), m/s.
    pub velocity: [f32; 3],
    /// Index of the owning body.
    pub body: u32,
    /// Outward unit normal (of the nearest surface, for a fill point).
    pub normal: [f32; 3],
    pub _pad: u32,
}

/// Fluid load on one body over a window: force and moment about its centre of mass
/// (Joubert eqs. 31–32).
#[derive(
    Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, serde::Serialize, serde::Deserialize,
)]
#[repr(C)]
pub struct BodyLoad {
    /// N.
    pub force: [f64; 3],
    pub body: u32,
    pub _pad: u32,
    /// N·m, about the centre of mass, world frame.
    pub moment: [f64; 3],
}

/// One fluid particle in a recording snapshot (sent at the output interval only).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct ParticleRecord {
    pub position: [f32; 3],
    /// Pa.
    pub pressure: f32,
    pub velocity: [f32; 3],
    /// kg/m³.
    pub density: f32,
}

/// Which process speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum Role {
    Orchestrator = 0,
    Fluid = 1,
    Dem = 2,
}

impl Role {
    pub fn from_u32(v: u32) -> Option<Self> {
        match v {
            0 => Some(Self::Orchestrator),
            1 => Some(Self::Fluid),
            2 => Some(Self::Dem),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Self::Orchestrator => "orchestrator",
            Self::Fluid => "fluid-server",
            Self::Dem => "dem-server",
        }
    }
}

/// FNV-1a (32 bit) of a scene's TOML text, as loaded: the same text gives the same
/// digest on every machine; any edit, override included, changes it.
pub fn scene_digest(text: &str) -> u32 {
    text.bytes().fold(0x811c_9dc5_u32, |h, b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    })
}

/// First message of each server: who it is, which protocol it speaks, and the
/// time-step limits it will need (the orchestrator picks the window from them).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct Hello {
    pub protocol_version: u32,
    /// [`Role`] as u32.
    pub role: u32,
    pub pid: u32,
    /// [`scene_digest`] of the scene file this server loaded: the orchestrator refuses a
    /// server that runs another scene (one started apart, on the wrong file).
    pub scene_digest: u32,
    /// Largest stable step of this side, s (fluid: Joubert eq. 24; DEM: contact step).
    pub dt_limit: f64,
    /// Acoustic CFL limit, s (fluid only, else 0).
    pub dt_acoustic: f64,
    /// Viscous limit, s (fluid only, else 0).
    pub dt_viscous: f64,
    /// Number of bodies (DEM) or particles (fluid).
    pub count: u64,
}

/// What the orchestrator asks of a server. Every kind but `Advance` and `Shutdown`
/// acts at the window boundary before window `step` and is acknowledged by a
/// [`SideReport`] of the same kind and step, so the orchestrator knows it took effect
/// before it sends the next command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum CommandKind {
    /// Advance the window `step` of length `window` starting at `time`.
    Advance = 1,
    /// Finish: release resources and exit 0.
    Shutdown = 2,
    /// Gravity becomes `values[0..3]`, m/s², from window `step` on (on the fluid when the
    /// scene has `gravity.on_fluid`, on the bodies in any case).
    SetGravity = 3,
    /// Kinematic body `body` moves from now on with linear velocity `values[0..3]`, m/s,
    /// and angular velocity `values[3..6]`, rad/s (world frame), from where it is.
    SetKinematicVelocity = 4,
    /// Write this server's whole state for the boundary before window `step` into the
    /// checkpoint directory it was started with (`--checkpoints DIR`), as
    /// `DIR/step-<step>/<role>.state`.
    Checkpoint = 5,
}

impl CommandKind {
    pub fn from_u32(v: u32) -> Option<Self> {
        match v {
            1 => Some(Self::Advance),
            2 => Some(Self::Shutdown),
            3 => Some(Self::SetGravity),
            4 => Some(Self::SetKinematicVelocity),
            5 => Some(Self::Checkpoint),
            _ => None,
        }
    }
}

/// A command from the orchestrator to both servers.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct Command {
    pub protocol_version: u32,
    /// [`CommandKind`] as u32.
    pub kind: u32,
    pub step: u64,
    pub time: f64,
    pub window: f64,
    /// 1 when the fluid server must publish a particle snapshot at the end of this window.
    pub snapshot: u32,
    /// The body a `SetKinematicVelocity` names (scene index).
    pub body: u32,
    /// The values of a parameter change (see [`CommandKind`]); zero otherwise.
    pub values: [f64; 6],
}

impl Command {
    pub fn kind(&self) -> Option<CommandKind> {
        CommandKind::from_u32(self.kind)
    }
}

/// What a server did in one window, for progress, benchmarks and the exchange share.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
pub struct SideReport {
    pub protocol_version: u32,
    /// [`Role`] as u32.
    pub role: u32,
    pub step: u64,
    pub substeps: u32,
    /// Fluid: particle-steps of the window whose truncation matrix (Joubert eq. 10) was
    /// near-singular, so they kept the uncorrected gradient; 0 without the correction
    /// and for the DEM.
    pub near_singular: u32,
    /// Wall time spent computing the window, µs.
    pub compute_us: f64,
    /// Wall time spent waiting for the peer's data, µs.
    pub wait_us: f64,
    /// Wall time spent reading, validating and publishing exchanged data, µs.
    pub exchange_us: f64,
    /// Largest stable step this side saw during the window, s.
    pub dt_limit: f64,
    /// The [`CommandKind`] this report answers (`Advance` for a window's report, or the
    /// parameter change or checkpoint it acknowledges).
    pub kind: u32,
    /// Fluid: particle-steps of the window that ended behind a resolved body's surface
    /// or a wall face and were mirrored back (couplet_fluid::body_non_penetration); 0
    /// for the DEM.
    pub reflected: u32,
    /// Fluid: particle-steps of the window whose shift (Joubert eq. 17) was cut short
    /// δ/2 in front of a resolved body's surface
    /// (couplet_fluid::particle_shifting::limit_toward_surface); 0 for the DEM.
    pub shift_limited: u32,
    /// Fluid at the end of the window: kinetic energy Σ ½ m |u|², J; largest speed,
    /// m/s; largest density error |ρ/(ε ρ0) − 1| (ε the grains' porosity, 1 without
    /// grains). Zero for the DEM and in acknowledgements.
    pub kinetic_energy: f64,
    pub max_speed: f64,
    pub max_density_error: f64,
}

impl SideReport {
    pub fn kind(&self) -> Option<CommandKind> {
        CommandKind::from_u32(self.kind)
    }

    /// `role`'s acknowledgement that `cmd` (a change between windows) took effect.
    pub fn acknowledging(role: Role, cmd: &Command) -> Self {
        Self {
            protocol_version: PROTOCOL_VERSION,
            role: role as u32,
            step: cmd.step,
            kind: cmd.kind,
            ..Default::default()
        }
    }
}

const _: () = {
    assert!(core::mem::size_of::<CouplingPoint>() == 48);
    assert!(core::mem::size_of::<ParticleRecord>() == 32);
    assert!(core::mem::size_of::<BodyLoad>() == 56);
    assert!(core::mem::size_of::<WindowHeader>() == 40);
    assert!(core::mem::size_of::<Command>() == 88);
    assert!(core::mem::size_of::<SideReport>() == 96);
};
