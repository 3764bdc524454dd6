//! The native soft-sphere engine (`dem.engine = "soft-sphere"`): spheres only, contacts
//! as spring–dashpot forces, in `f64`. The engine of many small grains (Robinson,
//! DEMocritus): a linear spring–dashpot (Robinson eq. 21) or Hertz–Mindlin with a
//! tangential spring and a Coulomb limit (DEMocritus eqs. 18–31), contact detection on
//! a cell grid (dense over the domain, [`ContactCells`], or hashed where the domain
//! holds too many cells for the spheres), the step from the contact duration (Robinson
//! §3.2, t_c / 50), and optionally DEMocritus's lubrication force (eq. 34).
//!
//! Where this departs from the papers' text, and why:
//! * Hertz normal force `k_n δ^{3/2}`: DEMocritus eq. (18) writes `−k_n δ_n` with the
//!   Hertz coefficient of eq. (28), `k_n = 4/3 E* √R*` (N/m^{3/2}); only `δ^{3/2}` makes
//!   that a force (Hertz's law, their ref. [20]).
//! * Damping from the bodies' restitution e: DEMocritus eqs. (32)–(33) fix
//!   `c = 2 √(2 m* k)`, a damping ratio of √2 (over-damped, e = 0) and no restitution
//!   parameter. Here the linear law takes `c_n = 2 ζ √(m* k)` with
//!   `ζ = −ln e / √(π² + ln² e)` (exact restitution of the linear oscillator), and the Hertz
//!   law takes Tsuji et al.'s (1992) `c_n = α √(m* k_n) δ^{1/4}` with α solved from e
//!   (see [`hertz_alpha`]), whose restitution does not depend on the impact speed. A scene
//!   that wants DEMocritus's inelastic contacts sets restitution = 0.
//! * Tangential velocity `v_t = v_ij − (v_ij·n) n − (R_i ω_i + R_j ω_j) × n` with n from j
//!   to i: DEMocritus eq. (23) prints `+`, which is the slip of the contact points only for
//!   n from i to j; the rolling-sphere conformance case fails with `+`.
//! * Tangential history: the spring ξ is carried over to the new tangent plane
//!   (projected, length kept), then `ξ += v_t Δt`; at the Coulomb limit (eq. 27) it is
//!   reset to the length the limit allows. DEMocritus eq. (25) instead turns ξ along the
//!   current v_t every step, which flips the spring force whenever the slip reverses
//!   (a rolling sphere's v_t oscillates about zero).
//! * Tangential stiffness `k_t = k_n' / (2 (1 + ν))` (DEMocritus eq. 31) with `k_n'` the
//!   normal stiffness `dF_n/dδ`: k for the linear law, `3/2 k_n √δ` for Hertz.
//! * Robinson's `t_c = π / √(2k/m − β/m)` is the damped period of two equal spheres with
//!   `β/m` for `(β/m)²`; its Table 1 value (2.54e-3 s) does not follow from the listed k and
//!   m (it gives 8.0e-3 s). The step here uses the undamped duration `π √(m*/k)`, which
//!   is what bounds the explicit integration's stability.
//!
//! Integration is velocity Verlet (kick–drift–kick), exact for a constant force, with
//! the dashpots acting on the end-of-step velocity predicted from the step's start.

use crate::contact_cells::ContactCells;
use crate::engine::{
    ContactModel, DemEngine, DemError, GravityScales, Kinematic, check_in_domain, check_loads,
    decode_state, encode_state, not_kinematic,
};
use crate::geometry::BodyGeometry;
use couplet_protocol::cell_hash::CellHash;
use couplet_protocol::vec3::{add, add_to, cross, dot, norm, quat_from_scaled_axis, scale, sub};
use couplet_protocol::{BodyLoad, BodyState, ContactLaw, Domain, Motion, Scene, Shape};
use rayon::prelude::*;
use std::ops::Range;

/// Normal law with its material constants.
#[derive(Debug, Clone, Copy)]
enum Law {
    /// Robinson eq. (21); k in N/m.
    Linear { k: f64 },
    /// DEMocritus eqs. (18)–(30): `k_n = 4/3 E* √R*`; E* of two spheres and of a sphere
    /// on a rigid wall, Pa.
    Hertz { e_pair: f64, e_wall: f64 },
}

/// DEMocritus eq. (34) in the form `F_i = 6π μ R*² (v_j − v_i) / gap` (equal to
/// `3π μ d² /(8 gap)` for two spheres of diameter d = 4R*).
#[derive(Debug, Clone, Copy)]
struct Lubrication {
    /// Fluid dynamic viscosity ρν, Pa·s.
    mu: f64,
    /// Centre distance beyond which no force acts: the fluid's kernel support radius, m.
    cutoff: f64,
    /// Smallest gap, as a fraction of the pair's diameter 4R*.
    min_gap: f64,
}

/// A planar domain face: points with `x[axis]` beyond `coord` on the outside.
#[derive(Debug, Clone, Copy)]
struct Wall {
    axis: usize,
    /// +1 for the face at `domain.min` (normal into the domain along +axis), −1 at `max`.
    inward: f64,
    coord: f64,
}

/// Contact between sphere i and partner j (a sphere or a wall), as [`contact_force`] needs it.
struct Contact {
    /// Unit normal from j to i.
    n: [f64; 3],
    /// Overlap, m (> 0).
    overlap: f64,
    /// Relative velocity of i's contact point to j's, m/s.
    v_rel: [f64; 3],
    /// Effective mass `1/(1/m_i + 1/m_j)`, kg.
    m_eff: f64,
    /// Effective radius `R_i R_j / (R_i + R_j)` (R_i for a wall), m.
    r_eff: f64,
    /// E* of the pair (Hertz), Pa.
    e_star: f64,
    /// Normal damping: ζ (linear) or α (Hertz).
    damping: f64,
    /// Damping ratio of the tangential dashpot.
    zeta_t: f64,
    /// Coulomb coefficient of the pair.
    mu: f64,
}

/// Tangential springs of the contacts of one force evaluation, listed by their owner
/// (a pair's lower body index; walls are partners n + k): the contacts of the sphere in
/// slot q are `partner[start[q]..start[q + 1]]` (body indices), their springs ξ alongside.
/// The slots are the traversal order of the evaluation that wrote them ([`Sorted`]), so
/// the next one, walking nearly the same order, finds each list near the last. A sphere
/// has a handful of contacts, so scanning its own list finds a pair sooner than hashing
/// every pair into one map (which took a fifth of a step at 100 k spheres).
#[derive(Debug, Clone, Default)]
struct Springs {
    start: Vec<u32>,
    partner: Vec<u32>,
    spring: Vec<[f64; 3]>,
    /// Slot → body index, and body index → slot.
    owner: Vec<u32>,
    slot: Vec<u32>,
}

impl Springs {
    /// The spring of the contact of the sphere in `slot` with `partner`, zero when the
    /// pair was not in contact (or `slot` is none: u32::MAX).
    fn get(&self, slot: u32, partner: u32) -> [f64; 3] {
        let q = slot as usize;
        let Some(&first) = self.start.get(q) else {
            return [0.0; 3];
        };
        let range = first as usize..self.start[q + 1] as usize;
        (self.partner[range.clone()].iter())
            .position(|p| *p == partner)
            .map_or([0.0; 3], |k| self.spring[range.start + k])
    }

    fn len(&self) -> usize {
        self.partner.len()
    }

    /// Lists the contacts of `chunks` ((owner's traversal position, partner, spring), in
    /// any order) by owner, slots being the positions of `order`, reusing this value's
    /// buffers. Within an owner they keep the chunks' order.
    fn collect(&mut self, order: &[u32], chunks: &[ChunkForces]) {
        let n = order.len();
        self.start.clear();
        self.start.resize(n + 1, 0);
        for (q, _, _) in chunks.iter().flat_map(|c| &c.contacts) {
            self.start[*q as usize + 1] += 1;
        }
        for q in 0..n {
            self.start[q + 1] += self.start[q];
        }
        let total = self.start[n] as usize;
        self.partner.resize(total, 0);
        self.spring.resize(total, [0.0; 3]);
        let mut fill = self.start[..n].to_vec();
        for (q, partner, spring) in chunks.iter().flat_map(|c| &c.contacts) {
            let k = &mut fill[*q as usize];
            self.partner[*k as usize] = *partner;
            self.spring[*k as usize] = *spring;
            *k += 1;
        }
        self.owner.clear();
        self.owner.extend_from_slice(order);
        self.slot.resize(n, 0);
        for (q, i) in order.iter().enumerate() {
            self.slot[*i as usize] = q as u32;
        }
    }

    /// The springs keyed by `i << 32 | j` (owner i, partner j), in key order (the saved
    /// state's form).
    fn keyed(&self) -> Vec<(u64, [f64; 3])> {
        let mut out: Vec<(u64, [f64; 3])> = (0..self.owner.len())
            .flat_map(|q| {
                let i = u64::from(self.owner[q]);
                (self.start[q] as usize..self.start[q + 1] as usize)
                    .map(move |k| (i << 32 | u64::from(self.partner[k]), k))
            })
            .map(|(key, k)| (key, self.spring[k]))
            .collect();
        out.sort_unstable_by_key(|(key, _)| *key);
        out
    }

    /// The inverse of [`Springs::keyed`] for `n` spheres, in slots of body order; `None`
    /// when a key names a sphere past `n`.
    fn from_keyed(n: usize, keyed: &[(u64, [f64; 3])]) -> Option<Springs> {
        let mut sorted = keyed.to_vec();
        sorted.sort_unstable_by_key(|(key, _)| *key);
        let mut start = vec![0u32; n + 1];
        for (key, _) in &sorted {
            let i = (key >> 32) as usize;
            if i >= n {
                return None;
            }
            start[i + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        Some(Springs {
            start,
            partner: sorted.iter().map(|(key, _)| *key as u32).collect(),
            spring: sorted.iter().map(|(_, xi)| *xi).collect(),
            owner: (0..n as u32).collect(),
            slot: (0..n as u32).collect(),
        })
    }
}

/// What the spheres of one chunk add in a force evaluation: forces and torques by
/// position in the traversal order ([`Sorted`]; written over `touched` only), and the
/// springs of its contacts as (owner's position, partner's body index, ξ).
#[derive(Debug, Default)]
struct ChunkForces {
    force: Vec<[f64; 3]>,
    torque: Vec<[f64; 3]>,
    /// The positions written, `[lo, hi)`; zeroed again before the chunk's next evaluation.
    touched: Range<usize>,
    contacts: Vec<(u32, u32, [f64; 3])>,
}

/// The spheres in traversal order: by cell of the contact grid, z, then y, then x, and
/// by body index within a cell. The force loop walks this order and reads copies of what
/// it needs laid out in it, so that a sphere's neighbours sit near it in memory whatever
/// order the scene listed the bodies in. `couplet bench-dem --spheres 100000 --contact
/// hertz-mindlin`, two cores, with the lattice's spheres listed in lattice order and
/// shuffled: 11.2–12.6 and 6.0–6.8 steps/s walking the body order, 9.8–11.0 and
/// 9.3–11.3 walking this one (the copies cost a tenth where the listing was already
/// ideal). The order is sorted again every step, from the last one (nearly sorted
/// already, which the stable sort runs through in about linear time), and it depends on
/// the positions alone, so that a restored state sums its forces in the same order as
/// the run it was saved from.
#[derive(Debug, Default)]
struct Sorted {
    /// Traversal position → body index.
    order: Vec<u32>,
    /// (cell key, body index) of the sort, kept to reuse the buffer.
    keys: Vec<(u64, u32)>,
    /// Traversal position → the sphere's slot in the last evaluation's [`Springs`]
    /// (u32::MAX: none).
    spring_slot: Vec<u32>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    inv_mass: Vec<f64>,
    friction: Vec<f64>,
    restitution_class: Vec<usize>,
    group: Vec<u32>,
    x: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
    w: Vec<[f64; 3]>,
}

/// `group_of` of a body in no translation group.
const NO_GROUP: u32 = u32::MAX;

/// Bits of a cell coordinate in the sort key (three in a u64). Coordinates wrap beyond
/// 2^21 cells along an axis, which only costs locality, never a contact.
const SORT_KEY_BITS: u32 = 21;

impl ChunkForces {
    /// Clears what the last evaluation wrote, for a scene of `n` bodies.
    fn reset(&mut self, n: usize) {
        if self.force.len() != n {
            self.force = vec![[0.0; 3]; n];
            self.torque = vec![[0.0; 3]; n];
        } else {
            let t = self.touched.clone();
            self.force[t.clone()].fill([0.0; 3]);
            self.torque[t].fill([0.0; 3]);
        }
        self.touched = 0..0;
        self.contacts.clear();
    }

    fn touch(&mut self, i: usize) {
        self.touched = if self.touched.is_empty() {
            i..i + 1
        } else {
            self.touched.start.min(i)..self.touched.end.max(i + 1)
        };
    }

    fn add_force(&mut self, i: usize, f: [f64; 3]) {
        self.touch(i);
        add_to(&mut self.force[i], f);
    }

    fn add_torque(&mut self, i: usize, t: [f64; 3]) {
        self.touch(i);
        add_to(&mut self.torque[i], t);
    }
}

/// Spheres below which the force evaluation runs as one chunk on one thread: handing the
/// chunks to the worker pool costs about 12 µs a step, a few per cent of a step of this
/// many spheres.
const PARALLEL_MIN_SPHERES: usize = 4096;

/// Chunks of a parallel force evaluation. Fixed, not the machine's thread count, so that
/// the sums (each chunk's, then the chunks' in order) and hence the trajectories are the
/// same on every machine; 16 keeps that many cores busy.
const FORCE_CHUNKS: usize = 16;

/// Spheres of a scene under spring–dashpot contacts, gravity (with the buoyancy of
/// Joubert eq. 28 when gravity is off the fluid, as in every engine) and held fluid loads.
pub struct SoftSphereEngine {
    names: Vec<String>,
    motion: Vec<Motion>,
    kinematic: Vec<Option<Kinematic>>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    volume: Vec<f64>,
    /// 1/m for dynamic bodies, 0 for fixed and kinematic ones (infinite mass in contacts).
    inv_mass: Vec<f64>,
    /// 1/(2/5 m r²), 0 for fixed and kinematic bodies.
    inv_inertia: Vec<f64>,
    /// Gravity on each body as a multiple of `gravity` (buoyancy of Joubert eq. 28, the
    /// scene's excess-weight ramp).
    gravity_scales: GravityScales,
    friction: Vec<f64>,
    /// Index into `damping` of the body's restitution (its rank among the scene's
    /// distinct restitutions).
    restitution_class: Vec<usize>,
    /// Normal damping (ζ or α) and tangential ζ per pair of restitution classes, and per
    /// class against a wall (the body's own restitution).
    damping: Vec<Vec<(f64, f64)>>,
    wall_damping: Vec<(f64, f64)>,
    x: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
    w: Vec<[f64; 3]>,
    q: Vec<[f64; 4]>,
    /// Predicted end-of-step velocities the dashpots act on (see [`Self::predict`]).
    v_pred: Vec<[f64; 3]>,
    w_pred: Vec<[f64; 3]>,
    contact_force: Vec<[f64; 3]>,
    contact_torque: Vec<[f64; 3]>,
    fluid_force: Vec<[f64; 3]>,
    fluid_torque: Vec<[f64; 3]>,
    law: Law,
    lubrication: Option<Lubrication>,
    /// `1 / (2 (1 + ν))` (DEMocritus eq. 31).
    tangential_ratio: f64,
    /// The springs of the last force evaluation's contacts.
    springs: Springs,
    /// The last evaluation's springs, kept to reuse their buffers.
    spare_springs: Springs,
    /// Scratch of the force evaluation, one per chunk (kept to reuse the buffers).
    chunks: Vec<ChunkForces>,
    sorted: Sorted,
    /// Spheres from which the force evaluation is chunked: [`PARALLEL_MIN_SPHERES`]
    /// (the tests move it to compare with one chunk).
    parallel_min: usize,
    walls: Vec<Wall>,
    /// Length of each periodic axis, m (spheres wrap, pairs take the minimum image).
    period: [Option<f64>; 3],
    gravity: [f64; 3],
    domain: Domain,
    /// The contact search's cells: dense over the domain when it holds few enough
    /// (`cells`), else hashed (`grid`, built every step).
    cells: Option<ContactCells>,
    grid: CellHash,
    max_dt: f64,
    steps_per_contact: f64,
    /// Hertz: the impact speed the step resolves at least, m/s.
    impact_speed: f64,
    /// `impact_speed` follows gravity (the scene gave none): a live change of gravity
    /// changes it.
    impact_speed_from_gravity: bool,
    /// Hertz: dimensionless undamped contact duration (≈ 3.218).
    hertz_tau: f64,
    /// The part of [`Self::contact_duration`] that the spheres' masses and radii fix,
    /// its least over them (`Self::duration_scale_of_spheres`), so that a step's
    /// duration takes one power, not two per sphere.
    duration_scale: f64,
    /// Members of each translation group (`bodies[i].translation_group`): they share one
    /// acceleration and never rotate.
    groups: Vec<Vec<usize>>,
    /// Body i's translation group (an index into `groups`), [`NO_GROUP`] for none.
    group_of: Vec<u32>,
    /// Every sphere is in one translation group: no pair's force can change the motion
    /// (see [`Self::chunk_forces`]), so the pair search is skipped.
    one_group: bool,
    time: f64,
    steps: u64,
}

impl SoftSphereEngine {
    /// Registry name.
    pub const NAME: &'static str = "soft-sphere";

    /// Builds the spheres and domain walls of `scene`; refuses other shapes, and periodic
    /// axes shorter than two diameters.
    pub fn new(scene: &Scene) -> Result<Self, DemError> {
        let unsupported = |what: String| DemError::Unsupported {
            engine: Self::NAME,
            what,
        };
        let spec = scene.dem.soft_sphere.as_ref().ok_or_else(|| {
            unsupported("needs [dem.soft_sphere] (contact law and material)".into())
        })?;
        let n = scene.bodies.len();
        let mut radius = Vec::with_capacity(n);
        for (i, b) in scene.bodies.iter().enumerate() {
            match b.shape {
                Shape::Sphere { radius: r } => radius.push(r),
                _ => {
                    return Err(unsupported(
                        "spheres only (shape.sphere); use dem.engine = \"rapier\" for boxes, prisms and compounds"
                            .into(),
                    )
                    .in_body(i, &b.name));
                }
            }
        }
        let d_max = 2.0 * radius.iter().copied().fold(0.0, f64::max);
        let d = &scene.domain;
        let mut period = [None; 3];
        for k in (0..3).filter(|k| d.periodic[*k]) {
            let length = d.max[k] - d.min[k];
            // Minimum image is the only image in reach only if the period is two diameters.
            if length < 2.0 * d_max {
                return Err(unsupported(format!(
                    "periodic axis {k} is {length:e} m long, shorter than two diameters of the largest sphere ({:e} m): a sphere would touch two images of another",
                    2.0 * d_max
                )));
            }
            period[k] = Some(length);
        }
        let nu = spec.poisson_ratio;
        let law = match spec.contact {
            ContactLaw::Linear => Law::Linear {
                k: spec.stiffness.unwrap_or(f64::NAN),
            },
            // DEMocritus eqs. (29)–(30): 1/E* = (1 − ν_i²)/E_i + (1 − ν_j²)/E_j; a rigid
            // wall contributes nothing.
            ContactLaw::HertzMindlin => {
                let e = spec.youngs_modulus.unwrap_or(f64::NAN);
                Law::Hertz {
                    e_pair: e / (2.0 * (1.0 - nu * nu)),
                    e_wall: e / (1.0 - nu * nu),
                }
            }
        };
        if let Law::Linear { k } | Law::Hertz { e_pair: k, .. } = law
            && !(k.is_finite() && k > 0.0)
        {
            return Err(unsupported(
                "the contact law's stiffness or Young's modulus is missing or not positive".into(),
            ));
        }

        let mut restitutions: Vec<f64> = Vec::new();
        let mut restitution_class = Vec::with_capacity(n);
        for (i, b) in scene.bodies.iter().enumerate() {
            if !(0.0..=1.0).contains(&b.restitution) {
                return Err(DemError::Shape {
                    what: "restitution".into(),
                    value: b.restitution.to_string(),
                    why: "must lie in [0, 1]".into(),
                }
                .in_body(i, &b.name));
            }
            let c = match restitutions.iter().position(|e| *e == b.restitution) {
                Some(c) => c,
                None => {
                    restitutions.push(b.restitution);
                    restitutions.len() - 1
                }
            };
            restitution_class.push(c);
        }
        let damp = |e: f64| match law {
            Law::Linear { .. } => (linear_zeta(e), linear_zeta(e)),
            Law::Hertz { .. } => (hertz_alpha(e), linear_zeta(e)),
        };
        // A pair takes the mean of the two restitutions (rapier's default rule, so that
        // a scene behaves alike on both engines); a wall takes the body's own.
        let damping = (restitutions.iter())
            .map(|a| restitutions.iter().map(|b| damp(0.5 * (a + b))).collect())
            .collect();
        let wall_damping = restitutions.iter().map(|e| damp(*e)).collect();

        let mut e = Self {
            names: scene.bodies.iter().map(|b| b.name.clone()).collect(),
            motion: scene.bodies.iter().map(|b| b.motion).collect(),
            kinematic: (scene.bodies.iter())
                .map(|b| (b.motion == Motion::Kinematic).then(|| Kinematic::from_spec(b)))
                .collect(),
            mass: Vec::with_capacity(n),
            volume: Vec::with_capacity(n),
            inv_mass: Vec::with_capacity(n),
            inv_inertia: Vec::with_capacity(n),
            gravity_scales: GravityScales::new(scene),
            friction: scene.bodies.iter().map(|b| b.friction).collect(),
            restitution_class,
            damping,
            wall_damping,
            x: scene.bodies.iter().map(|b| b.position).collect(),
            v: (scene.bodies.iter())
                .map(|b| match b.motion {
                    Motion::Fixed => [0.0; 3],
                    _ => b.velocity,
                })
                .collect(),
            w: (scene.bodies.iter())
                .map(|b| match b.motion {
                    Motion::Fixed => [0.0; 3],
                    _ => b.angular_velocity,
                })
                .collect(),
            q: (scene.bodies.iter())
                .map(|b| quat_from_scaled_axis(b.rotation))
                .collect(),
            v_pred: Vec::new(),
            w_pred: Vec::new(),
            contact_force: vec![[0.0; 3]; n],
            contact_torque: vec![[0.0; 3]; n],
            fluid_force: vec![[0.0; 3]; n],
            fluid_torque: vec![[0.0; 3]; n],
            law,
            lubrication: match (&scene.fluid, spec.lubrication) {
                (Some(f), true) => Some(Lubrication {
                    mu: f.density * f.kinematic_viscosity,
                    cutoff: f.support_radius(),
                    min_gap: spec.lubrication_min_gap,
                }),
                _ => None,
            },
            tangential_ratio: 1.0 / (2.0 * (1.0 + nu)),
            springs: Springs::default(),
            spare_springs: Springs::default(),
            chunks: Vec::new(),
            sorted: Sorted::default(),
            parallel_min: PARALLEL_MIN_SPHERES,
            walls: walls(&scene.domain),
            period,
            gravity: scene.gravity.vector,
            domain: scene.domain.clone(),
            cells: None,
            grid: CellHash::default(),
            max_dt: scene.dem.max_dt,
            steps_per_contact: spec.steps_per_contact,
            impact_speed: 0.0,
            impact_speed_from_gravity: false,
            hertz_tau: 0.0,
            duration_scale: f64::INFINITY,
            radius,
            groups: Vec::new(),
            group_of: vec![NO_GROUP; n],
            one_group: false,
            time: 0.0,
            steps: 0,
        };
        for (i, b) in scene.bodies.iter().enumerate() {
            let g = BodyGeometry::from_shape(&b.shape).map_err(|e| e.in_body(i, &b.name))?;
            let volume = g.volume();
            let mass = b.density * volume;
            let dynamic = b.motion == Motion::Dynamic;
            e.volume.push(volume);
            e.mass.push(mass);
            e.inv_mass.push(if dynamic { 1.0 / mass } else { 0.0 });
            e.inv_inertia.push(if dynamic {
                1.0 / (0.4 * mass * e.radius[i] * e.radius[i])
            } else {
                0.0
            });
        }
        if let Law::Hertz { .. } = law {
            e.hertz_tau = hertz_impact(0.0).1;
            let height = scene.domain.max[1] - scene.domain.min[1];
            e.impact_speed_from_gravity = spec.impact_speed.is_none();
            e.impact_speed = spec
                .impact_speed
                .unwrap_or_else(|| fall_speed(scene.gravity.vector, height));
        }
        let mut names: Vec<&str> = Vec::new();
        for (i, b) in scene.bodies.iter().enumerate() {
            if let Some(g) = &b.translation_group {
                let k = match names.iter().position(|n| n == g) {
                    Some(k) => k,
                    None => {
                        names.push(g);
                        e.groups.push(Vec::new());
                        names.len() - 1
                    }
                };
                e.groups[k].push(i);
                e.group_of[i] = k as u32;
            }
        }
        e.one_group = n > 0 && e.group_of.iter().all(|g| *g == 0);
        e.duration_scale = e.duration_scale_of_spheres();
        e.cells = ContactCells::new(e.domain.min, e.domain.max, e.contact_cell(), e.period, n);
        e.predict(0.0);
        e.compute_forces(0.0);
        Ok(e)
    }

    /// Simulated time since construction, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Threads the force evaluation can run on: from [`PARALLEL_MIN_SPHERES`] spheres,
    /// the worker pool's (rayon's, the machine's threads unless `RAYON_NUM_THREADS` says
    /// otherwise), at most one per chunk; else one.
    pub fn force_threads(&self) -> usize {
        if self.x.len() >= self.parallel_min {
            rayon::current_num_threads().min(FORCE_CHUNKS)
        } else {
            1
        }
    }

    /// Contacts (sphere–sphere and sphere–wall) active at the last force evaluation.
    pub fn contact_count(&self) -> usize {
        self.springs.len()
    }

    /// Undamped contact duration that bounds the step, s: the shortest over a pair of
    /// identical dynamic spheres and a sphere on a wall, for every dynamic sphere. Linear:
    /// `π √(m*/k)`; Hertz: `τ (m*/k_n)^{2/5} v^{-1/5}` at the larger of the impact speed
    /// and twice the fastest body's speed (two bodies meeting head on).
    pub fn contact_duration(&self) -> f64 {
        match self.law {
            Law::Linear { .. } => std::f64::consts::PI * self.duration_scale,
            Law::Hertz { .. } => {
                let vmax = (0..self.x.len())
                    .filter(|i| self.inv_mass[*i] > 0.0)
                    .map(|i| norm(self.v[i]))
                    .fold(0.0, f64::max);
                let v = self.impact_speed.max(2.0 * vmax);
                self.hertz_tau * self.duration_scale * v.powf(-0.2)
            }
        }
    }

    /// The least over every dynamic sphere, against its twin and against a wall, of
    /// `√(m*/k)` (linear) or `(m*/k_n)^{2/5}` (Hertz); infinite without one. Each factor
    /// of [`Self::contact_duration`] is positive and rounding is monotonic, so taking the
    /// least before multiplying gives the same bits as the least of the products.
    fn duration_scale_of_spheres(&self) -> f64 {
        let mut t = f64::INFINITY;
        for i in (0..self.x.len()).filter(|i| self.inv_mass[*i] > 0.0) {
            let (m, r) = (self.mass[i], self.radius[i]);
            // (m*, R*, E*) of the sphere against its twin and against a wall.
            for (m_eff, r_eff, wall) in [(0.5 * m, 0.5 * r, false), (m, r, true)] {
                let scale = match self.law {
                    Law::Linear { k } => (m_eff / k).sqrt(),
                    Law::Hertz { e_pair, e_wall } => {
                        let kn = 4.0 / 3.0 * if wall { e_wall } else { e_pair } * r_eff.sqrt();
                        (m_eff / kn).powf(0.4)
                    }
                };
                t = t.min(scale);
            }
        }
        t
    }

    /// Largest step at which the stiffest lubrication dashpot c stays within `c Δt / m* ≤ 1`
    /// (an explicit dashpot is unstable past 2): at the smallest gap, `4 m g_min / (6π μ R)`
    /// for every dynamic sphere (the same for a pair of twins and against a fixed sphere).
    /// Infinite without lubrication.
    pub fn lubrication_dt(&self) -> f64 {
        let Some(l) = self.lubrication else {
            return f64::INFINITY;
        };
        (0..self.x.len())
            .filter(|i| self.inv_mass[*i] > 0.0)
            .map(|i| {
                4.0 * self.mass[i] * l.min_gap
                    / (6.0 * std::f64::consts::PI * l.mu * self.radius[i])
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The contact search's cell edge: the largest diameter, or the lubrication's reach
    /// if longer.
    fn contact_cell(&self) -> f64 {
        let rmax = self.radius.iter().copied().fold(0.0, f64::max);
        let lub_reach = self.lubrication.map_or(0.0, |l| l.cutoff);
        (2.0 * rmax).max(lub_reach)
    }

    /// Sphere–sphere and sphere–wall contact forces and torques at the current positions
    /// and velocities; the tangential springs advance by `dt`. The spheres are walked in
    /// [`Sorted`] order; from [`PARALLEL_MIN_SPHERES`] on, that order splits into
    /// [`FORCE_CHUNKS`] chunks over the worker pool's threads.
    fn compute_forces(&mut self, dt: f64) {
        let n = self.x.len();
        let cell = self.contact_cell();
        self.sort_spheres(cell);
        if !self.one_group && self.cells.is_none() {
            self.grid
                .build(&self.sorted.x, cell, self.domain.min, self.period);
        }
        let n_chunks = if n >= self.parallel_min {
            FORCE_CHUNKS
        } else {
            1
        };
        let mut chunks = std::mem::take(&mut self.chunks);
        chunks.resize_with(n_chunks, ChunkForces::default);
        let ranges: Vec<Range<usize>> = (0..n_chunks)
            .map(|c| c * n / n_chunks..(c + 1) * n / n_chunks)
            .collect();
        if n_chunks == 1 {
            self.chunk_forces(0..n, dt, &mut chunks[0]);
        } else {
            // On the worker pool (`couplet_protocol::worker_pool`), whose threads wait
            // between steps instead of being spawned for each. Which thread sums a
            // chunk changes no bit.
            let engine = &*self;
            chunks
                .par_iter_mut()
                .zip(ranges.par_iter())
                .for_each(|(out, range)| engine.chunk_forces(range.clone(), dt, out));
        }
        self.contact_force.fill([0.0; 3]);
        self.contact_torque.fill([0.0; 3]);
        for chunk in &chunks {
            for s in chunk.touched.clone() {
                let i = self.sorted.order[s] as usize;
                add_to(&mut self.contact_force[i], chunk.force[s]);
                add_to(&mut self.contact_torque[i], chunk.torque[s]);
            }
        }
        let mut springs = std::mem::take(&mut self.spare_springs);
        springs.collect(&self.sorted.order, &chunks);
        self.spare_springs = std::mem::replace(&mut self.springs, springs);
        self.chunks = chunks;
    }

    /// Sorts the traversal order by cell (edge `cell`), then copies into it what the
    /// force loop reads.
    fn sort_spheres(&mut self, cell: f64) {
        fn gather<T: Copy>(out: &mut Vec<T>, order: &[u32], v: &[T]) {
            out.clear();
            out.extend(order.iter().map(|i| v[*i as usize]));
        }
        let n = self.x.len();
        let srt = &mut self.sorted;
        if srt.order.len() != n {
            srt.order = (0..n as u32).collect();
        }
        // Positions in the last order, keyed by cell; the same order comes back unless a
        // sphere changed cells (in a packing at rest it seldom does), and only then is
        // anything gathered twice.
        gather(&mut srt.x, &srt.order, &self.x);
        let (inv, min, mask) = (1.0 / cell, self.domain.min, (1u64 << SORT_KEY_BITS) - 1);
        let coord = |p: [f64; 3], k: usize| ((p[k] - min[k]) * inv).floor() as i64 as u64 & mask;
        let (cells, one_group) = (self.cells.as_mut(), self.one_group);
        srt.keys.clear();
        srt.keys.extend(srt.x.iter().zip(&srt.order).map(|(p, i)| {
            let key = match &cells {
                Some(c) => c.key(*p),
                None => {
                    (coord(*p, 2) << (2 * SORT_KEY_BITS))
                        | (coord(*p, 1) << SORT_KEY_BITS)
                        | coord(*p, 0)
                }
            };
            (key, *i)
        }));
        srt.keys.sort();
        if let Some(c) = cells.filter(|_| !one_group) {
            c.fill(srt.keys.iter().map(|k| k.0));
        }
        if srt.radius.len() != n || srt.keys.iter().map(|k| k.1).ne(srt.order.iter().copied()) {
            srt.order.clear();
            srt.order.extend(srt.keys.iter().map(|k| k.1));
            let order = &srt.order;
            gather(&mut srt.x, order, &self.x);
            gather(&mut srt.radius, order, &self.radius);
            gather(&mut srt.mass, order, &self.mass);
            gather(&mut srt.inv_mass, order, &self.inv_mass);
            gather(&mut srt.friction, order, &self.friction);
            gather(&mut srt.restitution_class, order, &self.restitution_class);
            gather(&mut srt.group, order, &self.group_of);
        }
        let order = &srt.order;
        gather(&mut srt.v, order, &self.v_pred);
        gather(&mut srt.w, order, &self.w_pred);
        srt.spring_slot.clear();
        srt.spring_slot.extend(order.iter().map(|i| {
            self.springs
                .slot
                .get(*i as usize)
                .copied()
                .unwrap_or(u32::MAX)
        }));
    }

    /// The contacts of the spheres at traversal positions `range` into `out`: each pair
    /// once, from the earlier position, and computed for its lower body index (the
    /// owner of its spring, and the side the contact's normal points to), so that a pair
    /// gives the same force whichever order the spheres are walked in.
    fn chunk_forces(&self, range: Range<usize>, dt: f64, out: &mut ChunkForces) {
        let n = self.x.len();
        let srt = &self.sorted;
        out.reset(n);
        let lub_reach = self.lubrication.map_or(0.0, |l| l.cutoff);
        let periodic = self.period.iter().any(Option::is_some);
        // Two members of one translation group are skipped: the pair's forces are equal
        // and opposite, so they cancel in the group's sum, which is all that moves a
        // member (`kick_into`); skipping the pair changes that sum only by round-off and
        // leaves the contact's spring unborn. With every sphere in one group there is no
        // pair to look for (nor a grid filled).
        let pairs = !self.one_group;
        for s in range {
            let (dense, hashed) = match (&self.cells, pairs) {
                (_, false) => (None, None),
                (Some(c), true) => (Some(c.runs(srt.x[s])), None),
                (None, true) => (None, Some(self.grid.candidates(srt.x[s]))),
            };
            let dense = dense
                .into_iter()
                .flat_map(|(runs, m)| runs.into_iter().take(m).flatten());
            for t in dense.chain(hashed.into_iter().flatten()) {
                let t = t as usize;
                if t <= s
                    || srt.inv_mass[s] + srt.inv_mass[t] == 0.0
                    || (srt.group[s] != NO_GROUP && srt.group[s] == srt.group[t])
                {
                    continue;
                }
                let (a, b) = if srt.order[s] < srt.order[t] {
                    (s, t)
                } else {
                    (t, s)
                };
                let mut d = sub(srt.x[a], srt.x[b]);
                if periodic {
                    for (k, p) in self.period.iter().enumerate() {
                        if let Some(l) = p {
                            d[k] -= l * (d[k] / l).round();
                        }
                    }
                }
                let dist2 = dot(d, d);
                let (ra, rb) = (srt.radius[a], srt.radius[b]);
                let reach = ra + rb;
                let search = reach.max(lub_reach);
                if dist2 >= search * search || dist2 == 0.0 {
                    continue;
                }
                let dist = dist2.sqrt();
                if let Some(l) = self.lubrication
                    && dist < l.cutoff
                {
                    let r_eff = ra * rb / (ra + rb);
                    let gap = (dist - reach).max(l.min_gap * 4.0 * r_eff);
                    let c = 6.0 * std::f64::consts::PI * l.mu * r_eff * r_eff / gap;
                    let f = scale(sub(srt.v[b], srt.v[a]), c);
                    out.add_force(a, f);
                    out.add_force(b, scale(f, -1.0));
                }
                if dist >= reach {
                    continue;
                }
                let nrm = scale(d, 1.0 / dist);
                let spin = add(scale(srt.w[a], ra), scale(srt.w[b], rb));
                let (damping, zeta_t) =
                    self.damping[srt.restitution_class[a]][srt.restitution_class[b]];
                let c = Contact {
                    n: nrm,
                    overlap: reach - dist,
                    v_rel: sub(sub(srt.v[a], srt.v[b]), cross(spin, nrm)),
                    m_eff: 1.0 / (srt.inv_mass[a] + srt.inv_mass[b]),
                    r_eff: ra * rb / (ra + rb),
                    e_star: match self.law {
                        Law::Hertz { e_pair, .. } => e_pair,
                        Law::Linear { .. } => 0.0,
                    },
                    damping,
                    zeta_t,
                    mu: 0.5 * (srt.friction[a] + srt.friction[b]),
                };
                let (f, ft) = self.resolve(&c, a, srt.order[b], dt, out);
                let torque = cross(nrm, ft);
                out.add_force(a, f);
                out.add_force(b, scale(f, -1.0));
                out.add_torque(a, scale(torque, -ra));
                out.add_torque(b, scale(torque, -rb));
            }
            if srt.inv_mass[s] > 0.0 {
                let r = srt.radius[s];
                for (k, wall) in self.walls.iter().enumerate() {
                    let gap = wall.inward * (srt.x[s][wall.axis] - wall.coord);
                    if gap >= r {
                        continue;
                    }
                    let mut nrm = [0.0; 3];
                    nrm[wall.axis] = wall.inward;
                    let (damping, zeta_t) = self.wall_damping[srt.restitution_class[s]];
                    let c = Contact {
                        n: nrm,
                        overlap: r - gap,
                        v_rel: sub(srt.v[s], cross(scale(srt.w[s], r), nrm)),
                        m_eff: srt.mass[s],
                        r_eff: r,
                        e_star: match self.law {
                            Law::Hertz { e_wall, .. } => e_wall,
                            Law::Linear { .. } => 0.0,
                        },
                        damping,
                        zeta_t,
                        mu: srt.friction[s],
                    };
                    let (f, ft) = self.resolve(&c, s, (n + k) as u32, dt, out);
                    out.add_force(s, f);
                    out.add_torque(s, scale(cross(nrm, ft), -r));
                }
            }
        }
    }

    /// Force on the sphere at traversal position `owner` of its contact with `partner`
    /// (a body index) and its tangential part; the contact's spring, carried from the
    /// last evaluation and advanced by `dt`, goes into `out`.
    fn resolve(
        &self,
        c: &Contact,
        owner: usize,
        partner: u32,
        dt: f64,
        out: &mut ChunkForces,
    ) -> ([f64; 3], [f64; 3]) {
        let slot = self.sorted.spring_slot[owner];
        let spring = self.springs.get(slot, partner);
        let (f, ft, spring) = contact_force(self.law, self.tangential_ratio, c, spring, dt);
        out.contacts.push((owner as u32, partner, spring));
        (f, ft)
    }

    fn check_finite(&self) -> Result<(), DemError> {
        let bad = (0..self.x.len()).find(|i| {
            !(self.x[*i].iter())
                .chain(&self.v[*i])
                .chain(&self.w[*i])
                .all(|c| c.is_finite())
        });
        match bad {
            None => Ok(()),
            Some(i) => Err(DemError::NonFiniteState {
                body: i,
                name: self.names[i].clone(),
                step: self.steps,
                time: self.time,
                position: self.x[i],
                velocity: self.v[i],
            }),
        }
    }

    /// Half a kick: v += a dt/2, ω += α dt/2 for every dynamic sphere.
    fn kick(&mut self, half_dt: f64) {
        let (mut v, mut w) = (std::mem::take(&mut self.v), std::mem::take(&mut self.w));
        self.kick_into(&mut v, &mut w, half_dt);
        (self.v, self.w) = (v, w);
    }

    /// The velocities at the end of the step as the forces of its start predict them
    /// (`v_{n+½} + a_n dt/2`): the dashpots act on these. Damping on the half-step
    /// velocity lags by half a step and took 3 % off a linear contact's restitution at
    /// 50 steps per contact (0.484 for e = 0.5); the prediction leaves 0.3 %.
    fn predict(&mut self, half_dt: f64) {
        let (mut v, mut w) = (
            std::mem::take(&mut self.v_pred),
            std::mem::take(&mut self.w_pred),
        );
        v.clone_from(&self.v);
        w.clone_from(&self.w);
        self.kick_into(&mut v, &mut w, half_dt);
        (self.v_pred, self.w_pred) = (v, w);
    }

    fn kick_into(&self, v: &mut [[f64; 3]], w: &mut [[f64; 3]], half_dt: f64) {
        let weight = self.gravity_scales.fraction(self.time);
        let scale = |i: usize| self.gravity_scales.at(i, weight);
        // A translation group: Σ F / Σ m for every member, no rotation.
        for members in &self.groups {
            let (mut f, mut m) = ([0.0; 3], 0.0);
            for &i in members {
                let (force, s) = (add(self.contact_force[i], self.fluid_force[i]), scale(i));
                for k in 0..3 {
                    f[k] += force[k] + self.mass[i] * self.gravity[k] * s;
                }
                m += self.mass[i];
            }
            for &i in members {
                for k in 0..3 {
                    v[i][k] += f[k] / m * half_dt;
                }
            }
        }
        for i in 0..self.x.len() {
            let (im, ii) = (self.inv_mass[i], self.inv_inertia[i]);
            if im == 0.0 || self.group_of[i] != NO_GROUP {
                continue;
            }
            let force = add(self.contact_force[i], self.fluid_force[i]);
            let torque = add(self.contact_torque[i], self.fluid_torque[i]);
            let s = scale(i);
            for k in 0..3 {
                let a = force[k] * im + self.gravity[k] * s;
                v[i][k] += a * half_dt;
                w[i][k] += torque[k] * ii * half_dt;
            }
        }
    }
}

/// The faces of the domain as walls: every face but the top when it is open and the
/// faces of periodic axes.
fn walls(d: &Domain) -> Vec<Wall> {
    let mut out = Vec::new();
    for axis in (0..3).filter(|k| !d.periodic[*k]) {
        out.push(Wall {
            axis,
            inward: 1.0,
            coord: d.min[axis],
        });
        if axis != 1 || d.closed_top {
            out.push(Wall {
                axis,
                inward: -1.0,
                coord: d.max[axis],
            });
        }
    }
    out
}

/// Force on body i of one contact `c` (normal plus tangential, N), its tangential part,
/// and the tangential spring ξ after the step `dt` (DEMocritus eqs. 18–27 with the
/// departures listed in the module notes).
fn contact_force(
    law: Law,
    tangential_ratio: f64,
    c: &Contact,
    spring: [f64; 3],
    dt: f64,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let vn = dot(c.v_rel, c.n);
    let overlap_rate = -vn;
    // Normal force along n (positive pushes i away from j) and the normal stiffness dF/dδ.
    let (fn_, kn_tangent) = match law {
        // Robinson eq. (21); β = 2 ζ √(m* k).
        Law::Linear { k } => {
            let beta = 2.0 * c.damping * (c.m_eff * k).sqrt();
            (k * c.overlap + beta * overlap_rate, k)
        }
        // DEMocritus eqs. (18), (28): k_n = 4/3 E* √R*; Tsuji's c_n = α √(m* k_n) δ^{1/4}.
        Law::Hertz { .. } => {
            let kn = 4.0 / 3.0 * c.e_star * c.r_eff.sqrt();
            // δ^{1/4} and δ^{3/2} by square roots: powf was 3 % of a step at 100 k spheres.
            let root = c.overlap.sqrt();
            let cn = c.damping * (c.m_eff * kn).sqrt() * root.sqrt();
            (kn * c.overlap * root + cn * overlap_rate, 1.5 * kn * root)
        }
    };
    // DEMocritus eq. (31) and the Kelvin–Voigt tangential dashpot of eq. (33).
    let kt = tangential_ratio * kn_tangent;
    let ct = 2.0 * c.zeta_t * (c.m_eff * kt).sqrt();
    let vt = sub(c.v_rel, scale(c.n, vn));
    // Carry the spring into the current tangent plane, keeping its length, then add the slip.
    let along = sub(spring, scale(c.n, dot(spring, c.n)));
    let (len, len_t) = (norm(spring), norm(along));
    let carried = if len_t > 0.0 {
        scale(along, len / len_t)
    } else {
        [0.0; 3]
    };
    let mut xi = add(carried, scale(vt, dt));
    let mut ft = scale(add(scale(xi, kt), scale(vt, ct)), -1.0);
    // DEMocritus eq. (27): Coulomb's limit; the spring keeps the length that gives it.
    let limit = c.mu * fn_.abs();
    let ft_len = norm(ft);
    if ft_len > limit {
        ft = scale(ft, limit / ft_len);
        xi = if kt > 0.0 {
            scale(add(ft, scale(vt, ct)), -1.0 / kt)
        } else {
            [0.0; 3]
        };
    }
    (add(scale(c.n, fn_), ft), ft, xi)
}

/// Damping ratio of a linear spring–dashpot with restitution e:
/// `e = exp(−π ζ / √(1 − ζ²))`, so `ζ = −ln e / √(π² + ln² e)`; e = 0 → critical (ζ = 1).
pub fn linear_zeta(e: f64) -> f64 {
    if e <= 0.0 {
        return 1.0;
    }
    let l = e.ln();
    -l / (std::f64::consts::PI.powi(2) + l * l).sqrt()
}

/// Restitution and duration of a Hertz contact with Tsuji's damping, in the units that
/// make it parameter-free: `s'' = −s^{3/2} − α s^{1/4} s'`, s(0) = 0, s'(0) = 1 (s the
/// overlap over `v (m*/k_n)^{2/5} v^{-1/5}…`, τ time over `(m*/k_n)^{2/5} v^{-1/5}`).
/// Returns (e, τ_c): the rebound speed and the contact duration; e = 0 and τ_c = ∞ when
/// the spheres do not separate. RK4 at Δτ = 2e-4 (τ_c ≈ 3.22 undamped).
pub fn hertz_impact(alpha: f64) -> (f64, f64) {
    let rhs = |s: f64, u: f64| {
        let s = s.max(0.0);
        -s.powf(1.5) - alpha * s.powf(0.25) * u
    };
    let h = 2e-4;
    let (mut s, mut u, mut t) = (0.0f64, 1.0f64, 0.0f64);
    // Ten undamped durations: a sphere still pressed by then has e < 1e-4 (it creeps back).
    while t < 32.0 {
        let (k1s, k1u) = (u, rhs(s, u));
        let (k2s, k2u) = (u + 0.5 * h * k1u, rhs(s + 0.5 * h * k1s, u + 0.5 * h * k1u));
        let (k3s, k3u) = (u + 0.5 * h * k2u, rhs(s + 0.5 * h * k2s, u + 0.5 * h * k2u));
        let (k4s, k4u) = (u + h * k3u, rhs(s + h * k3s, u + h * k3u));
        let s_new = s + h / 6.0 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s);
        let u_new = u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
        if s_new < 0.0 {
            // Linear interpolation of the crossing for the duration.
            let frac = s / (s - s_new);
            return (-(u + frac * (u_new - u)), t + frac * h);
        }
        if u_new >= 0.0 && u < 0.0 {
            return (0.0, f64::INFINITY); // stopped while pressed: no rebound
        }
        (s, u, t) = (s_new, u_new, t + h);
    }
    (0.0, f64::INFINITY)
}

/// Tsuji's α for restitution e: the smallest α with `hertz_impact(α).0 ≤ e`, by bisection
/// to 1e-6 (e = 0 gives the threshold beyond which spheres stick, ≈ 1.27).
pub fn hertz_alpha(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while hertz_impact(hi).0 > e {
        hi *= 2.0;
    }
    while hi - lo > 1e-6 {
        let mid = 0.5 * (lo + hi);
        if hertz_impact(mid).0 > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

impl DemEngine for SoftSphereEngine {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn contact_model(&self) -> ContactModel {
        ContactModel::SpringDashpot
    }

    fn body_count(&self) -> usize {
        self.x.len()
    }

    fn states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend((0..self.x.len()).map(|i| BodyState {
            body: i as u32,
            motion: self.motion[i].as_u32(),
            mass: self.mass[i],
            volume: self.volume[i],
            position: self.x[i],
            orientation: self.q[i],
            linear_velocity: self.v[i],
            angular_velocity: self.w[i],
        }));
    }

    fn set_fluid_loads(&mut self, loads: &[BodyLoad]) -> Result<(), DemError> {
        check_loads(loads, self.x.len(), |i| self.names[i].clone())?;
        self.fluid_force.fill([0.0; 3]);
        self.fluid_torque.fill([0.0; 3]);
        for l in loads {
            self.fluid_force[l.body as usize] = l.force;
            self.fluid_torque[l.body as usize] = l.moment;
        }
        Ok(())
    }

    fn step(&mut self, dt: f64) -> Result<(), DemError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(DemError::InvalidStep {
                dt,
                max_dt: self.stable_dt(),
            });
        }
        self.kick(0.5 * dt);
        let t_new = self.time + dt;
        for i in 0..self.x.len() {
            if let Some(k) = &self.kinematic[i] {
                (self.x[i], self.q[i]) = k.pose(t_new);
            } else if self.inv_mass[i] > 0.0 {
                for c in 0..3 {
                    self.x[i][c] += self.v[i][c] * dt;
                }
                let turn = quat_from_scaled_axis(scale(self.w[i], dt));
                let q = crate::engine::quat_mul(turn, self.q[i]);
                let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                self.q[i] = q.map(|c| c / len);
            }
        }
        for (k, p) in self.period.iter().enumerate() {
            if let Some(l) = p {
                let lo = self.domain.min[k];
                for x in &mut self.x {
                    x[k] = lo + (x[k] - lo).rem_euclid(*l);
                }
            }
        }
        self.time = t_new;
        self.predict(0.5 * dt);
        self.compute_forces(dt);
        self.kick(0.5 * dt);
        self.steps += 1;
        self.check_finite()?;
        check_in_domain(
            &self.domain,
            self.x.iter().copied(),
            |i| self.v[i],
            |i| self.names[i].clone(),
            self.steps,
            self.time,
        )
    }

    /// `min(dem.max_dt, t_c / steps_per_contact, lubrication limit)` with t_c from
    /// [`contact_duration`](SoftSphereEngine::contact_duration) (Robinson §3.2: t_c / 50)
    /// and the lubrication limit from [`lubrication_dt`](SoftSphereEngine::lubrication_dt).
    fn stable_dt(&self) -> f64 {
        self.max_dt
            .min(self.contact_duration() / self.steps_per_contact)
            .min(self.lubrication_dt())
    }

    fn set_gravity(&mut self, g: [f64; 3]) {
        self.gravity = g;
        if self.impact_speed_from_gravity {
            self.impact_speed = fall_speed(g, self.domain.max[1] - self.domain.min[1]);
        }
    }

    fn set_kinematic_velocity(
        &mut self,
        body: usize,
        linear: [f64; 3],
        angular: [f64; 3],
    ) -> Result<(), DemError> {
        let Some(Some(k)) = self.kinematic.get(body) else {
            let name = self.names.get(body).map_or("", String::as_str);
            return Err(not_kinematic(body, name, self.motion.get(body).copied()));
        };
        self.kinematic[body] = Some(k.rebased(self.time, linear, angular));
        (self.v[body], self.w[body]) = (linear, angular);
        Ok(())
    }

    fn save_state(&self) -> Result<Vec<u8>, DemError> {
        let history = self.springs.keyed();
        encode_state(
            Self::NAME,
            &SoftSphereState {
                x: self.x.clone(),
                v: self.v.clone(),
                w: self.w.clone(),
                q: self.q.clone(),
                v_pred: self.v_pred.clone(),
                w_pred: self.w_pred.clone(),
                contact_force: self.contact_force.clone(),
                contact_torque: self.contact_torque.clone(),
                fluid_force: self.fluid_force.clone(),
                fluid_torque: self.fluid_torque.clone(),
                history,
                kinematic: self.kinematic.clone(),
                gravity: self.gravity,
                impact_speed: self.impact_speed,
                time: self.time,
                steps: self.steps,
            },
        )
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), DemError> {
        let s: SoftSphereState = decode_state(Self::NAME, bytes)?;
        let n = self.x.len();
        let lengths = [
            s.x.len(),
            s.v.len(),
            s.w.len(),
            s.q.len(),
            s.v_pred.len(),
            s.w_pred.len(),
            s.contact_force.len(),
            s.contact_torque.len(),
            s.fluid_force.len(),
            s.fluid_torque.len(),
            s.kinematic.len(),
        ];
        if lengths.iter().any(|l| *l != n) {
            return Err(DemError::State {
                engine: Self::NAME,
                what: "restore",
                detail: format!("it holds {lengths:?} entries for a scene of {n} spheres"),
            });
        }
        (self.x, self.v, self.w, self.q) = (s.x, s.v, s.w, s.q);
        (self.v_pred, self.w_pred) = (s.v_pred, s.w_pred);
        (self.contact_force, self.contact_torque) = (s.contact_force, s.contact_torque);
        (self.fluid_force, self.fluid_torque) = (s.fluid_force, s.fluid_torque);
        self.springs = Springs::from_keyed(n, &s.history).ok_or_else(|| DemError::State {
            engine: Self::NAME,
            what: "restore",
            detail: format!("a contact names a sphere past the scene's {n}"),
        })?;
        self.kinematic = s.kinematic;
        (self.gravity, self.impact_speed) = (s.gravity, s.impact_speed);
        (self.time, self.steps) = (s.time, s.steps);
        Ok(())
    }
}

/// What evolves in a [`SoftSphereEngine`]: the rest follows from the scene.
#[derive(serde::Serialize, serde::Deserialize)]
struct SoftSphereState {
    x: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
    w: Vec<[f64; 3]>,
    q: Vec<[f64; 4]>,
    v_pred: Vec<[f64; 3]>,
    w_pred: Vec<[f64; 3]>,
    contact_force: Vec<[f64; 3]>,
    contact_torque: Vec<[f64; 3]>,
    fluid_force: Vec<[f64; 3]>,
    fluid_torque: Vec<[f64; 3]>,
    /// Tangential springs ξ by pair key, sorted by key.
    history: Vec<(u64, [f64; 3])>,
    kinematic: Vec<Option<Kinematic>>,
    gravity: [f64; 3],
    impact_speed: f64,
    time: f64,
    steps: u64,
}

/// The speed of a fall through `height` under `g`: the fastest impact gravity alone
/// makes. Without gravity nothing falls and 1 m/s stands in; a scene whose impacts are
/// faster sets `dem.soft_sphere.impact_speed`.
fn fall_speed(g: [f64; 3], height: f64) -> f64 {
    let g = g.iter().map(|c| c * c).sum::<f64>().sqrt();
    if g > 0.0 {
        (2.0 * g * height).sqrt()
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SplitMix64 mapped to [lo, hi): deterministic, no dependency.
    fn uniform(state: &mut u64, lo: f64, hi: f64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        lo + (hi - lo) * ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `n` polydisperse spheres (r 0.9–1.1 mm, Hertz, μ = 0.5) on a jiggled lattice of
    /// pitch 1.98 mm, the first layer pressed into the walls, with random velocities and
    /// spins: sphere and wall contacts, sticking and sliding springs.
    fn pressed_block(n: usize) -> SoftSphereEngine {
        pressed_block_listed(n, false)
    }

    /// [`pressed_block`] with the bodies listed in reverse (`reversed`): the same spheres,
    /// the last one first.
    fn pressed_block_listed(n: usize, reversed: bool) -> SoftSphereEngine {
        let mut rng = 11;
        let (r, pitch) = (1e-3, 1.98e-3);
        let side = (n as f64).cbrt().ceil() as usize;
        let extent = side as f64 * pitch + 2.0 * r;
        let text = format!(
            "[meta]\nname = \"pressed\"\n[time]\nend = 1.0\noutput_interval = 0.1\n\
             [domain]\nmin = [0, 0, 0]\nmax = [{extent}, {extent}, {extent}]\n\
             [dem]\nengine = \"soft-sphere\"\n[dem.soft_sphere]\n\
             contact = \"hertz-mindlin\"\nyoungs_modulus = 1e7\n\
             [[bodies]]\nname = \"grain\"\nshape.sphere.radius = {r}\ndensity = 2500.0\n\
             position = [{r}, {r}, {r}]\nrestitution = 0.5\nfriction = 0.5\n"
        );
        let mut scene = Scene::parse(&text, std::path::Path::new("pressed")).unwrap();
        let template = scene.bodies.pop().unwrap();
        for k in 0..n {
            let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
            let mut b = template.clone();
            b.name = format!("grain{k}");
            b.shape = Shape::Sphere {
                radius: uniform(&mut rng, 0.9e-3, 1.1e-3),
            };
            b.position =
                [i, j, l].map(|c| 0.98e-3 + c as f64 * pitch + uniform(&mut rng, -5e-5, 5e-5));
            b.velocity = [0, 1, 2].map(|_| uniform(&mut rng, -0.05, 0.05));
            b.angular_velocity = [0, 1, 2].map(|_| uniform(&mut rng, -50.0, 50.0));
            scene.bodies.push(b);
        }
        if reversed {
            scene.bodies.reverse();
        }
        SoftSphereEngine::new(&scene).unwrap()
    }

    /// The order the scene lists its bodies in changes nothing but the order of the sums:
    /// the same pressed block listed forwards and backwards (every pair's owner, the lower
    /// index, swaps, and every spring with it) gives the same forces over 20 steps, to
    /// 1e-11 of the largest (round-off grown over 20 steps; measured: 1.1e-14). A state saved
    /// at step 10 and restored into a fresh engine continues bit for bit, on the chunked
    /// path (the conformance suite checks it on one chunk).
    #[test]
    fn body_order_changes_only_round_off_and_restores_are_exact() {
        let n = 2 * PARALLEL_MIN_SPHERES;
        let mut forward = pressed_block_listed(n, false);
        let mut backward = pressed_block_listed(n, true);
        let dt = forward.stable_dt();
        let mut worst: f64 = 0.0;
        let mut restored = None;
        for step in 0..20 {
            forward.step(dt).unwrap();
            backward.step(dt).unwrap();
            if let Some(r) = &mut restored {
                SoftSphereEngine::step(r, dt).unwrap();
            }
            if step == 9 {
                let mut r = pressed_block_listed(n, false);
                r.restore_state(&forward.save_state().unwrap()).unwrap();
                restored = Some(r);
            }
            let largest = (forward.contact_force.iter())
                .map(|f| norm(*f))
                .fold(0.0, f64::max);
            for (i, f) in forward.contact_force.iter().enumerate() {
                worst = worst.max(norm(sub(*f, backward.contact_force[n - 1 - i])) / largest);
            }
            assert_eq!(
                forward.contact_count(),
                backward.contact_count(),
                "step {step}"
            );
        }
        println!("largest force difference, bodies listed backwards: {worst:.2e} of the largest");
        assert!(
            worst < 1e-11,
            "reversed listing off by {worst:e} of the largest"
        );
        let r = restored.unwrap();
        assert_eq!(r.x, forward.x, "the restored run left the original");
        assert_eq!(r.contact_force, forward.contact_force);
        assert_eq!(r.springs.keyed(), forward.springs.keyed());
    }

    /// The chunked force evaluation (from `PARALLEL_MIN_SPHERES`) gives the same bits on
    /// one thread and on three, and the forces of one chunk up to the order of the sums,
    /// over 20 steps of 2 × PARALLEL_MIN_SPHERES pressed spheres (so springs carry over
    /// from step to step). Reference: the same engine with one chunk (the serial loop);
    /// tolerance 1e-11 of the largest force, round-off of a different summation order
    /// grown over 20 steps (measured: 1.2e-13).
    #[test]
    fn chunked_forces_match_one_chunk_and_do_not_depend_on_threads() {
        let n = 2 * PARALLEL_MIN_SPHERES;
        let mut serial = pressed_block(n);
        serial.parallel_min = usize::MAX;
        let mut one = pressed_block(n);
        let mut three = pressed_block(n);
        let pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
        };
        let (pool1, pool3) = (pool(1), pool(3));
        // What bench-dem reports: the pool's threads, at most one per chunk.
        let threads = |threads| pool(threads).install(|| one.force_threads());
        assert_eq!([1, 2, 3, 12, 64].map(threads), [1, 2, 3, 12, 16]);
        assert_eq!(serial.force_threads(), 1);
        let dt = serial.stable_dt();
        let mut worst: f64 = 0.0;
        for step in 0..20 {
            serial.step(dt).unwrap();
            pool1.install(|| one.step(dt)).unwrap();
            pool3.install(|| three.step(dt)).unwrap();
            assert_eq!(
                one.x, three.x,
                "step {step}: positions depend on the threads"
            );
            assert_eq!(one.contact_force, three.contact_force, "step {step}");
            assert_eq!(one.contact_torque, three.contact_torque, "step {step}");
            assert_eq!(one.springs.keyed(), three.springs.keyed(), "step {step}");
            assert_eq!(serial.contact_count(), one.contact_count(), "step {step}");
            worst = worst.max(force_difference(&serial, &one));
        }
        println!("largest force difference, one chunk against 16: {worst:.2e} of the largest");
        assert!(
            worst < 1e-11,
            "chunked forces off by {worst:e} of the largest"
        );
        let walls = (one.springs.partner.iter())
            .filter(|p| **p as usize >= n)
            .count();
        let per_sphere = 2.0 * one.contact_count() as f64 / n as f64;
        assert!(
            walls > 100 && per_sphere > 3.0,
            "{walls} wall contacts, {per_sphere} per sphere: too few to test"
        );
    }

    /// The hashed grid lists, for every sphere, every other sphere it overlaps (checked
    /// against all N² pairs), each once, for 2000 polydisperse spheres (r 0.5–2 mm) packed
    /// densely enough to touch, including negative coordinates (floor of the cell key).
    #[test]
    fn grid_candidates_cover_every_touching_pair_once_also_through_periodic_faces() {
        let mut rng = 7;
        let n = 2000;
        let r: Vec<f64> = (0..n).map(|_| uniform(&mut rng, 0.5e-3, 2e-3)).collect();
        let x: Vec<[f64; 3]> = (0..n)
            .map(|_| [0, 1, 2].map(|_| uniform(&mut rng, -0.02, 0.02)))
            .collect();
        let mut grid = CellHash::default();
        grid.build(&x, 2.0 * 2e-3, [-0.02; 3], [None; 3]);
        let mut touching = 0;
        for i in 0..n {
            let c: Vec<u32> = grid.candidates(x[i]).collect();
            let mut sorted = c.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), c.len(), "sphere {i} listed a candidate twice");
            for j in (0..n).filter(|j| *j != i) {
                let d = norm(sub(x[i], x[j]));
                if d < r[i] + r[j] {
                    touching += 1;
                    assert!(c.contains(&(j as u32)), "pair {i}–{j} at {d} m missed");
                }
            }
        }
        assert!(
            touching > 1000,
            "only {touching} touching pairs: the test is too sparse"
        );

        // Periodic in x and z over the same box: pairs touching through the faces
        // (minimum image) are listed too.
        let period = [Some(0.04), None, Some(0.04)];
        grid.build(&x, 2.0 * 2e-3, [-0.02; 3], period);
        let mut across = 0;
        for i in 0..n {
            let c: Vec<u32> = grid.candidates(x[i]).collect();
            for j in (0..n).filter(|j| *j != i) {
                let mut d = sub(x[i], x[j]);
                for k in [0, 2] {
                    d[k] -= 0.04 * (d[k] / 0.04).round();
                }
                if norm(d) < r[i] + r[j] {
                    across += usize::from(norm(sub(x[i], x[j])) >= r[i] + r[j]);
                    assert!(c.contains(&(j as u32)), "periodic pair {i}–{j} missed");
                }
            }
        }
        assert!(
            across > 20,
            "only {across} pairs touch through a periodic face"
        );
    }

    /// The largest difference between two engines' contact forces on the same sphere,
    /// over the largest contact force of `a`.
    fn force_difference(a: &SoftSphereEngine, b: &SoftSphereEngine) -> f64 {
        let largest = (a.contact_force.iter())
            .map(|f| norm(*f))
            .fold(0.0, f64::max);
        (a.contact_force.iter().zip(&b.contact_force))
            .map(|(x, y)| norm(sub(*x, *y)) / largest)
            .fold(0.0, f64::max)
    }

    /// Members of a translation group are not paired (their forces on each other are
    /// equal and opposite and cancel in the group's sum), but a sphere outside the group
    /// still is. Three spheres in a row, r = 0.05 m, centres 0.09 m apart (each pair
    /// 0.01 m into the next), no gravity: a and b a group, c free. Reference: Newton's
    /// third law for the one pair computed, b–c: after 50 steps the group (2m) and c (m)
    /// carry equal and opposite momenta, to 1e-12 of c's; a and b share one velocity;
    /// one contact. With c in the group too, every sphere is in one group, the pair
    /// search is skipped, and nothing moves.
    #[test]
    fn a_translation_group_pairs_only_with_spheres_outside_it() {
        let build = |c_group: &str| {
            let sphere = |name: &str, x: f64, extra: &str| {
                format!(
                    "[[bodies]]\nname = \"{name}\"\nshape.sphere.radius = 0.05\n\
                     density = 1000.0\nposition = [{x}, 0.5, 0.5]\n{extra}\n"
                )
            };
            let group = "translation_group = \"block\"";
            let text = format!(
                "[meta]\nname = \"group\"\n[time]\nend = 1.0\noutput_interval = 0.1\n\
                 [domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n[gravity]\nvector = [0, 0, 0]\n\
                 [dem]\nengine = \"soft-sphere\"\n[dem.soft_sphere]\n\
                 contact = \"linear\"\nstiffness = 1e4\n{}{}{}",
                sphere("a", 0.41, group),
                sphere("b", 0.5, group),
                sphere("c", 0.59, c_group),
            );
            SoftSphereEngine::new(&Scene::parse(&text, std::path::Path::new("group")).unwrap())
                .unwrap()
        };
        let mut e = build("");
        let dt = 0.1 * e.stable_dt();
        for _ in 0..50 {
            e.step(dt).unwrap();
        }
        assert_eq!(e.contact_count(), 1, "only b–c is a contact");
        assert_eq!(e.v[0], e.v[1], "a and b move as one");
        let group = 2.0 * e.mass[0] * e.v[0][0];
        let free = e.mass[2] * e.v[2][0];
        assert!(free > 0.0, "c was not pushed: {free}");
        assert!(
            (group + free).abs() < 1e-12 * free,
            "momentum {group} + {free}"
        );

        let mut all = build("translation_group = \"block\"");
        assert!(all.one_group);
        for _ in 0..50 {
            all.step(dt).unwrap();
        }
        assert_eq!(all.contact_count(), 0);
        assert!(all.v.iter().all(|v| *v == [0.0; 3]), "{:?}", all.v);
    }

    /// The dense cell grid and the hashed one find the same contacts: the same pressed
    /// block (2 × PARALLEL_MIN_SPHERES spheres, chunked) stepped 20 times with each,
    /// the same contact count every step and forces within 1e-11 of the largest (the
    /// two walk a sphere's candidates in different orders, so the sums differ by
    /// round-off grown over 20 steps).
    #[test]
    fn the_dense_and_the_hashed_search_find_the_same_contacts() {
        let n = 2 * PARALLEL_MIN_SPHERES;
        let mut dense = pressed_block(n);
        let mut hashed = pressed_block(n);
        assert!(dense.cells.is_some(), "a pressed block is dense");
        hashed.cells = None;
        let dt = dense.stable_dt();
        let mut worst: f64 = 0.0;
        for step in 0..20 {
            dense.step(dt).unwrap();
            hashed.step(dt).unwrap();
            assert_eq!(dense.contact_count(), hashed.contact_count(), "step {step}");
            worst = worst.max(force_difference(&dense, &hashed));
        }
        println!("largest force difference, dense against hashed: {worst:.2e} of the largest");
        assert!(
            worst < 1e-11,
            "dense and hashed differ by {worst:e} of the largest"
        );
    }
}
