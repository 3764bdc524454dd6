//! The swappable DEM engine: one small trait, one file per implementation
//! (`rapier_engine.rs`, …), one registry (`registry.rs`), one conformance suite
//! (`tests/conformance.rs`) that every engine passes.

use couplet_protocol::vec3::quat_from_scaled_axis;
use couplet_protocol::{BodyLoad, BodyState, CouplingMode, Domain, Scene};

/// How an engine resolves contacts. The orchestrator needs it to pick the window:
/// a spring–dashpot engine has a contact time step that bounds the window, a
/// constraint-based one has not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactModel {
    /// Contacts are velocity constraints solved each step (rapier): no contact
    /// stiffness, no stability limit from contacts.
    VelocityConstraints,
    /// Contacts are spring–dashpot forces (soft-sphere DEM): stable only below a
    /// fraction of the contact period `π √(m/k)`.
    SpringDashpot,
}

/// Everything the DEM side can refuse or detect. Messages name the body (index and
/// name), the value, and what would be valid.
#[derive(Debug, thiserror::Error)]
pub enum DemError {
    /// `dem.engine` names no registered engine.
    #[error("dem.engine = \"{name}\": no such DEM engine; valid engines are: {valid}")]
    UnknownEngine { name: String, valid: String },
    /// An error about one scene body, with the body named.
    #[error("bodies[{index}] \"{name}\": {source}")]
    Body {
        index: usize,
        name: String,
        source: Box<DemError>,
    },
    /// A shape that cannot be built (degenerate hull, …).
    #[error("shape {what} = {value}: {why}")]
    Shape {
        what: String,
        value: String,
        why: String,
    },
    /// Two parts of a compound overlap: their volumes and surfaces would be counted twice.
    #[error(
        "shape.compound parts {first} and {second} overlap by {depth:e} m (separating-axis depth); \
         parts must only touch, so that the volume (Joubert eq. 28) and the outer surface are not counted twice"
    )]
    OverlappingParts {
        first: usize,
        second: usize,
        depth: f64,
    },
    /// The marker spacing is not a positive finite length.
    #[error("marker spacing {value} m: must be a positive finite length (the fluid spacing δ)")]
    Spacing { value: f64 },
    /// The shape is far larger than the spacing: the marker count would not fit.
    #[error(
        "surface area {area:e} m² at spacing {spacing:e} m needs about {estimated:e} markers; \
         at most {limit} per body are allowed (coarsen fluid.spacing or shrink the body)"
    )]
    TooManyMarkers {
        area: f64,
        spacing: f64,
        estimated: f64,
        limit: usize,
    },
    /// A body in a scene with a periodic axis does not span that axis.
    #[error(
        "axis {axis} is periodic, but the body reaches only {lo:.6e}..{hi:.6e} m of the domain's {min:.6e}..{max:.6e} m: a body on a periodic axis must span it from face to face (one crossing the periodic face is not handled)"
    )]
    PeriodicSpan {
        axis: usize,
        lo: f64,
        hi: f64,
        min: f64,
        max: f64,
    },
    /// A fluid load names a body the scene does not have.
    #[error(
        "fluid load #{entry} names body {body}; the scene has {count} bodies (valid 0..{count})"
    )]
    LoadBody {
        entry: usize,
        body: u32,
        count: usize,
    },
    /// Two fluid loads name the same body.
    #[error(
        "fluid loads #{first} and #{second} both name body {body} \"{name}\"; send one load per body"
    )]
    DuplicateLoad {
        first: usize,
        second: usize,
        body: u32,
        name: String,
    },
    /// A fluid load with NaN or infinity.
    #[error(
        "fluid load on body {body} \"{name}\" is not finite: force {force:?} N, moment {moment:?} N·m"
    )]
    NonFiniteLoad {
        body: u32,
        name: String,
        force: [f64; 3],
        moment: [f64; 3],
    },
    /// A step length that is not positive and finite.
    #[error(
        "DEM step dt = {dt} s: must be a positive finite time (at most stable_dt = {max_dt} s)"
    )]
    InvalidStep { dt: f64, max_dt: f64 },
    /// A body whose state became NaN/infinite during a step.
    #[error(
        "body {body} \"{name}\" became non-finite in DEM step {step} (t = {time} s): \
         position {position:?} m, velocity {velocity:?} m/s"
    )]
    NonFiniteState {
        body: usize,
        name: String,
        step: u64,
        time: f64,
        position: [f64; 3],
        velocity: [f64; 3],
    },
    /// A body's centre left the domain (through an open face, or pushed through a wall).
    #[error(
        "body {body} \"{name}\" left the domain in DEM step {step} (t = {time} s): centre {position:?} m, \
         velocity {velocity:?} m/s, domain {:?}..{:?} m; the fluid cannot follow it (enlarge the domain or close its top)",
        domain.0,
        domain.1
    )]
    LeftDomain {
        body: usize,
        name: String,
        step: u64,
        time: f64,
        position: [f64; 3],
        velocity: [f64; 3],
        /// The domain's min and max corners, m (boxed: keeps `DemError` small).
        domain: Box<([f64; 3], [f64; 3])>,
    },
    /// A scene this engine cannot simulate (a shape or boundary it does not have).
    #[error("dem.engine = \"{engine}\": {what}")]
    Unsupported { engine: &'static str, what: String },
    /// A live change names a body that is not kinematic (or does not exist).
    #[error(
        "body {body} ({name}) is {motion}: only a kinematic body's velocity can be prescribed during a run"
    )]
    NotKinematic {
        body: usize,
        name: String,
        motion: String,
    },
    /// A saved state that does not fit this engine and scene.
    #[error("dem.engine = \"{engine}\": cannot {what} its state: {detail}")]
    State {
        engine: &'static str,
        what: &'static str,
        detail: String,
    },
}

impl DemError {
    /// Wraps an error about the shape or state of scene body `index` so that the message names it.
    pub fn in_body(self, index: usize, name: &str) -> Self {
        Self::Body {
            index,
            name: name.to_owned(),
            source: Box::new(self),
        }
    }
}

/// A rigid-body/granular engine as the DEM server drives it, one coupling window at
/// a time (DESIGN.md "One coupling step"): read [`states`](Self::states), receive the
/// fluid loads with [`set_fluid_loads`](Self::set_fluid_loads), then call
/// [`step`](Self::step) as many times as the window needs at no more than
/// [`stable_dt`](Self::stable_dt) each.
///
/// Every engine applies the same body forces (Joubert eq. 34–35): gravity, reduced
/// by the buoyancy of Joubert eq. (28) when gravity does not act on the fluid,
/// contact forces, and the fluid loads held constant over the window.
pub trait DemEngine: Send {
    /// Registry name (`dem.engine` in a scene).
    fn name(&self) -> &'static str;
    /// How this engine resolves contacts.
    fn contact_model(&self) -> ContactModel;
    /// Number of scene bodies (`scene.bodies.len()`).
    fn body_count(&self) -> usize;
    /// States of all scene bodies (index = position in scene.bodies), world frame, at the current time.
    /// Clears `out` first.
    fn states(&self, out: &mut Vec<BodyState>);
    /// Fluid loads held constant over the next window (force and moment about the COM, world frame).
    /// Replaces previous loads: a body absent from `loads` carries none. Loads on fixed and
    /// kinematic bodies are accepted and have no effect (those bodies ignore forces).
    fn set_fluid_loads(&mut self, loads: &[BodyLoad]) -> Result<(), DemError>;
    /// Advance by dt (one DEM substep); gravity, buoyancy, contacts, held fluid loads.
    fn step(&mut self, dt: f64) -> Result<(), DemError>;
    /// Largest stable substep of this engine, s.
    fn stable_dt(&self) -> f64;
    /// Gravity becomes `g`, m/s², from the next step on (each body keeps its buoyancy
    /// scale of Joubert eq. 28).
    fn set_gravity(&mut self, g: [f64; 3]);
    /// Kinematic body `body` moves from now on with `linear` (m/s) and `angular` (rad/s,
    /// world frame) velocity, starting from where it is. Refused for a body that is not
    /// kinematic.
    fn set_kinematic_velocity(
        &mut self,
        body: usize,
        linear: [f64; 3],
        angular: [f64; 3],
    ) -> Result<(), DemError>;
    /// Everything that evolves (poses, velocities, contacts and their history, prescribed
    /// motions, gravity, time), encoded: [`restore_state`](Self::restore_state) on an
    /// engine built from the same scene continues exactly as this one would.
    fn save_state(&self) -> Result<Vec<u8>, DemError>;
    /// Continues from a state saved by an engine of the same kind on the same scene.
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), DemError>;
}

/// bincode of an engine's state (`save_state`).
pub(crate) fn encode_state<T: serde::Serialize>(
    engine: &'static str,
    state: &T,
) -> Result<Vec<u8>, DemError> {
    bincode::serde::encode_to_vec(state, bincode::config::standard()).map_err(|e| DemError::State {
        engine,
        what: "save",
        detail: e.to_string(),
    })
}

/// The inverse of [`encode_state`] (`restore_state`).
pub(crate) fn decode_state<T: serde::de::DeserializeOwned>(
    engine: &'static str,
    bytes: &[u8],
) -> Result<T, DemError> {
    let bad = |detail: String| DemError::State {
        engine,
        what: "restore",
        detail,
    };
    let (state, used) = bincode::serde::decode_from_slice(bytes, bincode::config::standard())
        .map_err(|e| bad(e.to_string()))?;
    if used != bytes.len() {
        return Err(bad(format!("{} bytes left over", bytes.len() - used)));
    }
    Ok(state)
}

/// The error of [`DemEngine::set_kinematic_velocity`] for a body that is not kinematic.
pub(crate) fn not_kinematic(
    body: usize,
    name: &str,
    motion: Option<couplet_protocol::Motion>,
) -> DemError {
    DemError::NotKinematic {
        body,
        name: name.to_owned(),
        motion: motion.map_or("not in the scene".into(), |m| {
            format!("{m:?}").to_lowercase()
        }),
    }
}

/// The first body whose centre lies outside the domain on a non-periodic axis, as a
/// [`DemError::LeftDomain`] (the engines call it after every step: the failure model
/// reports a body leaving, it does not let it go silently).
pub(crate) fn check_in_domain(
    domain: &Domain,
    positions: impl IntoIterator<Item = [f64; 3]>,
    velocity: impl Fn(usize) -> [f64; 3],
    names: impl Fn(usize) -> String,
    step: u64,
    time: f64,
) -> Result<(), DemError> {
    let out = |p: &[f64; 3]| {
        (0..3).any(|k| {
            let inside = (domain.min[k]..=domain.max[k]).contains(&p[k]);
            !(domain.periodic[k] || inside)
        })
    };
    match positions.into_iter().enumerate().find(|(_, p)| out(p)) {
        None => Ok(()),
        Some((i, position)) => Err(DemError::LeftDomain {
            body: i,
            name: names(i),
            step,
            time,
            position,
            velocity: velocity(i),
            domain: Box::new((domain.min, domain.max)),
        }),
    }
}

/// A kinematic body's prescribed motion, kept in `f64`: x(t) = x₀ + v (t − t₀) and
/// q(t) = exp(ω (t − t₀)) q₀ (world-frame ω). An engine in `f32` (rapier) would accumulate
/// `x += v dt` in `f32` every substep, which drifts by 1e-3 of the travel over a few
/// thousand steps; the engine instead puts the body where this says after each step.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub(crate) struct Kinematic {
    /// Time the velocities took effect (0, or a live change's), s.
    pub t0: f64,
    /// Scene coordinates at t₀, m.
    pub x0: [f64; 3],
    /// Unit quaternion [x, y, z, w] at t₀.
    pub q0: [f64; 4],
    pub v: [f64; 3],
    pub w: [f64; 3],
}

impl Kinematic {
    /// The scene's motion, from t = 0.
    pub fn from_spec(b: &couplet_protocol::BodySpec) -> Self {
        Self {
            t0: 0.0,
            x0: b.position,
            q0: quat_from_scaled_axis(b.rotation),
            v: b.velocity,
            w: b.angular_velocity,
        }
    }

    pub fn pose(&self, t: f64) -> ([f64; 3], [f64; 4]) {
        let tau = t - self.t0;
        let x = [0, 1, 2].map(|k| self.x0[k] + self.v[k] * tau);
        (
            x,
            quat_mul(quat_from_scaled_axis(self.w.map(|c| c * tau)), self.q0),
        )
    }

    /// The same body moving on from its pose at `t` with new velocities.
    pub fn rebased(&self, t: f64, v: [f64; 3], w: [f64; 3]) -> Self {
        let (x0, q0) = self.pose(t);
        Self {
            t0: t,
            x0,
            q0,
            v,
            w,
        }
    }
}

/// Hamilton product p q (apply q, then p).
pub(crate) fn quat_mul(p: [f64; 4], q: [f64; 4]) -> [f64; 4] {
    let [px, py, pz, pw] = p;
    let [qx, qy, qz, qw] = q;
    [
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
        pw * qw - px * qx - py * qy - pz * qz,
    ]
}

/// `1 − ρ_f/ρ_s` for a dynamic body the fluid sees (resolved, or an unresolved grain)
/// when gravity does not act on the fluid (Joubert eq. 28: `F_s = (m_s − ρ_f V_s) g =
/// m_s g (1 − ρ_f/ρ_s)`), else 1: with gravity on the fluid its pressure carries the
/// buoyancy (on markers, or in a grain's resolved force V(−∇P), Robinson eq. 23).
pub(crate) fn gravity_scale(scene: &Scene, i: usize) -> f64 {
    let b = &scene.bodies[i];
    match &scene.fluid {
        Some(f) if !scene.gravity.on_fluid && b.coupling != CouplingMode::None => {
            1.0 - f.density / b.density
        }
        _ => 1.0,
    }
}

/// Every body's gravity scale over time: [`gravity_scale`] once the scene's
/// `gravity.excess_weight_ramp` is over; during it a dynamic body the fluid sees lacks
/// its excess-weight scale `1 − ρ_f/ρ_s` (the weight beyond the buoyancy that the
/// fluid's pressure or eq. 28 accounts for) times one minus the ramp's fraction
/// (`GravitySpec::excess_weight_fraction`).
#[derive(Debug, Clone)]
pub(crate) struct GravityScales {
    full: Vec<f64>,
    excess: Vec<f64>,
    gravity: couplet_protocol::GravitySpec,
}

impl GravityScales {
    pub(crate) fn new(scene: &Scene) -> Self {
        let excess = (scene.bodies.iter())
            .map(|b| match &scene.fluid {
                Some(f) if b.coupling != CouplingMode::None => 1.0 - f.density / b.density,
                // The fluid does not see it: its weight is no load on the fluid.
                _ => 0.0,
            })
            .collect();
        Self {
            full: (0..scene.bodies.len())
                .map(|i| gravity_scale(scene, i))
                .collect(),
            excess,
            gravity: scene.gravity.clone(),
        }
    }

    /// The fraction of the excess weight carried at time t (s): 1 after the ramp.
    pub(crate) fn fraction(&self, t: f64) -> f64 {
        self.gravity.excess_weight_fraction(t)
    }

    /// Body i's scale when the bodies carry `fraction` of their excess weight.
    pub(crate) fn at(&self, i: usize, fraction: f64) -> f64 {
        self.full[i] - self.excess[i] * (1.0 - fraction)
    }
}

/// Refuses a set of fluid loads that names a body the scene lacks, names one twice, or
/// carries NaN/infinity; `name(i)` names body i in the message. Engines call it before
/// touching their bodies, so that a refused set leaves the previous loads in place.
pub(crate) fn check_loads(
    loads: &[BodyLoad],
    count: usize,
    name: impl Fn(usize) -> String,
) -> Result<(), DemError> {
    let mut seen = vec![usize::MAX; count];
    for (entry, l) in loads.iter().enumerate() {
        let b = l.body as usize;
        if b >= count {
            return Err(DemError::LoadBody {
                entry,
                body: l.body,
                count,
            });
        }
        if seen[b] != usize::MAX {
            return Err(DemError::DuplicateLoad {
                first: seen[b],
                second: entry,
                body: l.body,
                name: name(b),
            });
        }
        seen[b] = entry;
        if l.force.iter().chain(&l.moment).any(|x| !x.is_finite()) {
            return Err(DemError::NonFiniteLoad {
                body: l.body,
                name: name(b),
                force: l.force,
                moment: l.moment,
            });
        }
    }
    Ok(())
}
