//! The rapier3d engine (`dem.engine = "rapier"`): contacts as velocity constraints
//! (rapier's soft TGS solver), bodies and domain walls as rapier colliders.

use crate::engine::{
    ContactModel, DemEngine, DemError, GravityScales, Kinematic, check_in_domain, check_loads,
    decode_state, encode_state, not_kinematic,
};
use crate::geometry::BodyGeometry;
use couplet_protocol::vec3::sub;
use couplet_protocol::{BodyLoad, BodyState, Motion, Scene};
use rapier3d::prelude::{
    CoefficientCombineRule, ColliderBuilder, PhysicsWorld, Pose, Real, RigidBodyBuilder,
    RigidBodyHandle, Rotation, SharedShape, Vector,
};
use std::collections::HashMap;

/// rapier's allowed linear error (its contact slop) in units of `length_unit`
/// (rapier's default, 0.005): penetrations are corrected towards zero, and contacts
/// rest well within this much of touching (with contact recycling off, see `new`).
pub const NORMALIZED_ALLOWED_LINEAR_ERROR: f64 = 0.005;

/// One scene body as the engine holds it.
#[derive(Debug, Clone)]
struct Body {
    handle: RigidBodyHandle,
    name: String,
    motion: Motion,
    /// ρ·V, kg (f64: rapier keeps an f32 copy).
    mass: f64,
    /// Solid volume, m³ (Joubert eq. 28).
    volume: f64,
    /// Kinematic bodies only: their motion in closed form (see [`Kinematic`]).
    kinematic: Option<Kinematic>,
}

/// Mass properties of one body as rapier integrates it (body frame, about the COM).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Mass, kg (0 for fixed and kinematic bodies: rapier gives them infinite mass).
    pub mass: f64,
    /// Centre of mass in the body frame, m (zero up to `f32` round-off: the body frame is
    /// centred on the COM).
    pub local_com: [f64; 3],
    /// Inertia tensor about the COM in body axes, kg·m².
    pub inertia: [[f64; 3]; 3],
}

/// rapier3d behind the [`DemEngine`] trait.
///
/// * Gravity is rapier's world gravity; a dynamic, resolved body in a scene whose
///   gravity does not act on the fluid gets the gravity scale `1 − ρ_f/ρ_s`, so that
///   the net body force is `(m − ρ_f V) g` (Joubert eq. 28). Otherwise the scale is 1
///   and buoyancy, if any, comes from the fluid pressure in the loads.
/// * Fluid loads are rapier *user forces*, which rapier keeps applying at every step
///   until reset: [`set_fluid_loads`](DemEngine::set_fluid_loads) resets them all and
///   adds the new ones, so a window's load acts in each substep exactly once.
/// * Positions are held relative to the domain centre: rapier is `f32`, and a small
///   displacement per substep on top of a large coordinate would lose its digits.
/// * rapier works in a length unit of its own, `length_unit` = the smallest body's size
///   `∛V` (or the domain's, if smaller): every length, velocity, acceleration and force
///   goes in divided by it, every moment and inertia by its square, and comes back
///   multiplied. rapier's `length_unit` parameter alone (which scales its slop and
///   prediction distances) did not make millimetre polyhedra collide: parry's contacts
///   between convex hulls keep tolerances of their own, and two of Joubert's 12-face
///   cylinders (r = 1 mm) fell through each other, two 2 mm hull cubes came to rest
///   0.2 mm deep in each other (`dem-server/tests/conformance.rs`,
///   `millimetre_hulls_do_not_interpenetrate`), while the same bodies at metre size
///   rested face to face.
pub struct RapierEngine {
    world: PhysicsWorld,
    bodies: Vec<Body>,
    index_of: HashMap<RigidBodyHandle, usize>,
    /// Scene coordinates of rapier's origin (the domain centre), m.
    origin: [f64; 3],
    /// rapier length units per metre, 1/`length_unit`.
    scale: f64,
    domain: couplet_protocol::Domain,
    max_dt: f64,
    time: f64,
    steps: u64,
    /// Each dynamic body's gravity scale over time (Joubert eq. 28, the scene's
    /// excess-weight ramp), and the fraction of the excess weight the bodies' rapier
    /// scales now carry (NaN after a restore: the next step sets them).
    gravity_scales: GravityScales,
    weight_set: f64,
}

impl RapierEngine {
    /// Registry name.
    pub const NAME: &'static str = "rapier";

    /// Builds the bodies, their colliders and the domain walls of `scene`.
    pub fn new(scene: &Scene) -> Result<Self, DemError> {
        let d = &scene.domain;
        let origin = [0, 1, 2].map(|k| 0.5 * (d.min[k] + d.max[k]));
        let geometries = scene
            .bodies
            .iter()
            .enumerate()
            .map(|(i, b)| BodyGeometry::from_shape(&b.shape).map_err(|e| e.in_body(i, &b.name)))
            .collect::<Result<Vec<_>, _>>()?;
        let extent = [0, 1, 2].map(|k| d.max[k] - d.min[k]);
        let length_unit = geometries.iter().map(|g| g.volume().cbrt()).fold(
            extent.iter().copied().fold(f64::INFINITY, f64::min),
            f64::min,
        );

        let scale = 1.0 / length_unit;
        let mut world = PhysicsWorld::new();
        world.gravity = scaled(scene.gravity.vector, scale);
        let p = &mut world.integration_parameters;
        p.dt = scene.dem.max_dt as Real;
        // One rapier length unit is `length_unit` metres (see the struct doc).
        p.length_unit = 1.0;
        // rapier's contacts are springs of 30 Hz (60 Hz against fixed bodies), tuned
        // for metre-sized bodies: under gravity a resting contact sinks g/ω², 0.28 mm
        // at 30 Hz whatever the length unit, 14 % of a 2 mm body (two 2 mm hull cubes
        // stacked 0.18 mm into each other). Their frequencies scale as 1/√length_unit, as
        // a body's own time √(L/g) does, so a body of any size sinks the same fraction
        // of itself that a metre body does at rapier's defaults.
        let froude = scale.sqrt() as Real;
        p.contact_softness.natural_frequency *= froude;
        p.static_contact_softness.natural_frequency *= froude;
        p.normalized_allowed_linear_error = NORMALIZED_ALLOWED_LINEAR_ERROR as Real;
        // rapier 0.36 recycles a contact pair whose relative pose moved less than 10 slops
        // since its last full narrow-phase update, keeping its old points and depths. A
        // body resting on another sank into it until the pose had drifted that far: a
        // 12-face prism placed on a fixed one sank 118 µm (0.05 ∛V, the recycle distance)
        // instead of rapier's spring sag g/ω² = 0.16 µm, and the quick DKT's pair, once
        // in contact with the mass correction on, sank 12.5 µm before the manifold was
        // refreshed (`conformance.rs`, `resting_hulls_do_not_sink_into_each_other`). Every
        // step recomputes its contacts instead: correct depths over speed.
        p.contact_recycling = false;
        // rapier caps speeds (400 length units/s) to keep game scenes sane; a physics
        // run must not be silently clamped (DESIGN.md failure model).
        p.normalized_max_linear_velocity = Real::MAX;

        let gravity_scales = GravityScales::new(scene);
        let weight_set = gravity_scales.fraction(0.0);
        let mut bodies = Vec::with_capacity(scene.bodies.len());
        let mut index_of = HashMap::with_capacity(scene.bodies.len());
        for (i, (spec, geometry)) in scene.bodies.iter().zip(&geometries).enumerate() {
            let volume = geometry.volume();
            let mass = spec.density * volume;
            let builder = match spec.motion {
                Motion::Fixed => RigidBodyBuilder::fixed(),
                // Velocity-based: moves with its velocities, ignores forces and contacts.
                Motion::Kinematic => RigidBodyBuilder::kinematic_velocity_based(),
                // Fluid loads change every window: a sleeping body would miss them.
                Motion::Dynamic => RigidBodyBuilder::dynamic().can_sleep(false),
            };
            let mut builder = builder
                .translation(scaled(sub(spec.position, origin), scale))
                .rotation(vec3(spec.rotation));
            if spec.motion != Motion::Fixed {
                builder = builder
                    .linvel(scaled(spec.velocity, scale))
                    .angvel(vec3(spec.angular_velocity));
            }
            if spec.motion == Motion::Dynamic {
                builder = builder.gravity_scale(gravity_scales.at(i, weight_set) as Real);
            }
            let handle = world.insert_body(builder);
            let len = |x: f64| (x * scale) as Real;
            let shape = match geometry {
                BodyGeometry::Sphere { radius } => ColliderBuilder::ball(len(*radius)),
                BodyGeometry::Box {
                    half_extents: [a, b, c],
                } => ColliderBuilder::cuboid(len(*a), len(*b), len(*c)),
                BodyGeometry::Cylinder {
                    radius,
                    half_height,
                } => ColliderBuilder::cylinder(len(*half_height), len(*radius)),
                BodyGeometry::Polyhedra(parts) => {
                    let hulls = parts
                        .iter()
                        .enumerate()
                        .map(|(k, part)| {
                            let pts: Vec<Vector> =
                                part.vertices.iter().map(|v| scaled(*v, scale)).collect();
                            SharedShape::convex_hull(&pts).ok_or_else(|| {
                                DemError::Shape {
                                    what: format!("part {k} vertices"),
                                    value: format!("{:?}", part.vertices),
                                    why: "rapier cannot build a convex hull of them (degenerate in f32)"
                                        .into(),
                                }
                                .in_body(i, &spec.name)
                            })
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    match <[SharedShape; 1]>::try_from(hulls) {
                        Ok([hull]) => ColliderBuilder::new(hull),
                        Err(hulls) => ColliderBuilder::compound(
                            hulls.into_iter().map(|h| (Pose::IDENTITY, h)).collect(),
                        ),
                    }
                }
            };
            // One collider per body, with the mass properties given, not integrated by
            // parry: parry's f32 principal-axis decomposition (glamx `SymmetricEigen3`)
            // builds eigenvectors from cross products of inertia columns, whose squares
            // underflow f32 below about 1e-10 kg·m², so a body of millimetre size gets its
            // principal moments on the wrong axes (a 12-face prism r = 1.25 mm put its
            // small axial moment on x). The same decomposition runs whenever rapier adds
            // the mass properties of two colliders, hence the single collider.
            world.insert_collider(
                shape
                    .mass_properties(mass_properties(geometry, spec.density, scale))
                    .friction(spec.friction as Real)
                    .restitution(spec.restitution as Real),
                Some(handle),
            );
            index_of.insert(handle, i);
            let kinematic = (spec.motion == Motion::Kinematic).then(|| Kinematic::from_spec(spec));
            bodies.push(Body {
                handle,
                name: spec.name.clone(),
                motion: spec.motion,
                mass,
                volume,
                kinematic,
            });
        }
        add_walls(&mut world, scene, origin, scale);
        Ok(Self {
            world,
            bodies,
            index_of,
            origin,
            scale,
            domain: scene.domain.clone(),
            max_dt: scene.dem.max_dt,
            time: 0.0,
            steps: 0,
            gravity_scales,
            weight_set,
        })
    }

    /// Mass properties rapier integrates body `index` with.
    pub fn mass_properties(&self, index: usize) -> Option<MassProperties> {
        let b = self.world.bodies.get(self.bodies.get(index)?.handle)?;
        let m = &b.mass_properties().local_mprops;
        let i = m.reconstruct_inertia_matrix();
        let col = [i.x_axis, i.y_axis, i.z_axis];
        let s2 = self.scale * self.scale;
        Some(MassProperties {
            mass: m.mass() as f64,
            local_com: unscaled(m.local_com, self.scale),
            inertia: [0, 1, 2].map(|r| [0, 1, 2].map(|c| col[c][r] as f64 / s2)),
        })
    }

    /// Contact slop in metres (rapier's allowed linear error): the overlap the DKT judge
    /// allows. rapier 0.36 corrects penetrations all the way to zero (its slop is no
    /// dead zone), so resting contacts sit well inside it, at the spring sag g/ω².
    pub fn allowed_penetration(&self) -> f64 {
        self.world.integration_parameters.allowed_linear_error() as f64 / self.scale
    }

    /// Simulated time since construction, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    fn state_of(&self, i: usize, b: &Body) -> BodyState {
        let mut s = BodyState {
            body: i as u32,
            motion: b.motion.as_u32(),
            mass: b.mass,
            volume: b.volume,
            orientation: [0.0, 0.0, 0.0, 1.0],
            ..Default::default()
        };
        if let Some(rb) = self.world.bodies.get(b.handle) {
            let t = unscaled(rb.translation(), self.scale);
            s.position = std::array::from_fn(|k| t[k] + self.origin[k]);
            let q = rb.rotation();
            let q = [q.x as f64, q.y as f64, q.z as f64, q.w as f64];
            // Renormalised in f64 so that R·p keeps marker distances to the COM.
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            s.orientation = if n > 0.0 { q.map(|x| x / n) } else { q };
            let (v, w) = (rb.linvel(), rb.angvel());
            s.linear_velocity = unscaled(v, self.scale);
            s.angular_velocity = [w.x as f64, w.y as f64, w.z as f64];
        }
        if let Some(k) = &b.kinematic {
            (s.position, s.orientation) = k.pose(self.time);
            (s.linear_velocity, s.angular_velocity) = (k.v, k.w);
        }
        s
    }
}

/// The domain faces as fixed slabs one domain-width thick (thick enough that nothing
/// tunnels through), the top only when `closed_top`. Friction and restitution 0 with the
/// `Max` rule, which outranks rapier's default `Average`: a body–wall contact takes the
/// body's own coefficients.
fn add_walls(world: &mut PhysicsWorld, scene: &Scene, origin: [f64; 3], scale: f64) {
    let d = &scene.domain;
    let half = [0, 1, 2].map(|k| 0.5 * (d.max[k] - d.min[k]));
    let t = 2.0 * half.iter().copied().fold(0.0, f64::max);
    let walls = world.insert_body(RigidBodyBuilder::fixed());
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            if axis == 1 && side > 0.0 && !d.closed_top {
                continue;
            }
            let mut centre = sub([0, 1, 2].map(|k| 0.5 * (d.min[k] + d.max[k])), origin);
            centre[axis] += side * (half[axis] + 0.5 * t);
            let mut he = half.map(|h| h + t);
            he[axis] = 0.5 * t;
            let he = he.map(|h| (h * scale) as Real);
            world.insert_collider(
                ColliderBuilder::cuboid(he[0], he[1], he[2])
                    .translation(scaled(centre, scale))
                    .friction(0.0)
                    .restitution(0.0)
                    .friction_combine_rule(CoefficientCombineRule::Max)
                    .restitution_combine_rule(CoefficientCombineRule::Max),
                Some(walls),
            );
        }
    }
}

fn vec3(v: [f64; 3]) -> Vector {
    Vector::new(v[0] as Real, v[1] as Real, v[2] as Real)
}

/// A length-dimensioned vector (position, velocity, acceleration, force) in rapier's units.
fn scaled(v: [f64; 3], scale: f64) -> Vector {
    vec3(v.map(|x| x * scale))
}

/// A rapier length-dimensioned vector back in SI.
fn unscaled(v: Vector, scale: f64) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64].map(|x| x / scale)
}

impl DemEngine for RapierEngine {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn contact_model(&self) -> ContactModel {
        ContactModel::VelocityConstraints
    }

    fn body_count(&self) -> usize {
        self.bodies.len()
    }

    fn states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend(
            self.bodies
                .iter()
                .enumerate()
                .map(|(i, b)| self.state_of(i, b)),
        );
    }

    fn set_fluid_loads(&mut self, loads: &[BodyLoad]) -> Result<(), DemError> {
        // Check everything before touching the bodies: a refused set leaves the old loads.
        check_loads(loads, self.bodies.len(), |i| self.bodies[i].name.clone())?;
        for b in &self.bodies {
            if let Some(rb) = self.world.bodies.get_mut(b.handle) {
                rb.reset_forces(false);
                rb.reset_torques(false);
            }
        }
        for l in loads {
            if let Some(rb) = self
                .bodies
                .get(l.body as usize)
                .and_then(|b| self.world.bodies.get_mut(b.handle))
            {
                // User forces persist across steps until reset (rapier `add_force`): the
                // load is held over the whole window. Ignored by fixed/kinematic bodies.
                // Mass stays in kg: a force scales as a length, a moment as its square.
                rb.add_force(scaled(l.force, self.scale), true);
                rb.add_torque(scaled(l.moment, self.scale * self.scale), true);
            }
        }
        Ok(())
    }

    fn step(&mut self, dt: f64) -> Result<(), DemError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(DemError::InvalidStep {
                dt,
                max_dt: self.max_dt,
            });
        }
        // The excess weight at the step's middle (rapier applies gravity once a step).
        let weight = self.gravity_scales.fraction(self.time + 0.5 * dt);
        if weight != self.weight_set {
            for (i, b) in self.bodies.iter().enumerate() {
                if let (Motion::Dynamic, Some(rb)) = (b.motion, self.world.bodies.get_mut(b.handle))
                {
                    rb.set_gravity_scale(self.gravity_scales.at(i, weight) as Real, false);
                }
            }
            self.weight_set = weight;
        }
        self.world.integration_parameters.dt = dt as Real;
        self.world.step();
        self.steps += 1;
        self.time += dt;
        for b in &self.bodies {
            if let (Some(k), Some(rb)) = (&b.kinematic, self.world.bodies.get_mut(b.handle)) {
                let (x, q) = k.pose(self.time);
                let rotation = rapier3d::math::Rotation::from_xyzw(
                    q[0] as Real,
                    q[1] as Real,
                    q[2] as Real,
                    q[3] as Real,
                );
                rb.set_position(
                    Pose::from_parts(
                        scaled(sub(x, self.origin), self.scale),
                        rotation.normalize(),
                    ),
                    false,
                );
            }
        }
        // rapier quarantines (disables, restores) bodies that went non-finite; report the first.
        let bad = self
            .world
            .quarantine()
            .bodies()
            .iter()
            .find_map(|h| self.index_of.get(h).copied())
            .or_else(|| {
                self.bodies.iter().enumerate().find_map(|(i, b)| {
                    let s = self.state_of(i, b);
                    let finite = s
                        .position
                        .iter()
                        .chain(&s.linear_velocity)
                        .chain(&s.angular_velocity)
                        .all(|x| x.is_finite());
                    (!finite).then_some(i)
                })
            });
        if let Some(i) = bad {
            let s = self.state_of(i, &self.bodies[i]);
            return Err(DemError::NonFiniteState {
                body: i,
                name: self.bodies[i].name.clone(),
                step: self.steps,
                time: self.time,
                position: s.position,
                velocity: s.linear_velocity,
            });
        }
        let states: Vec<BodyState> = (self.bodies.iter().enumerate())
            .map(|(i, b)| self.state_of(i, b))
            .collect();
        check_in_domain(
            &self.domain,
            states.iter().map(|s| s.position),
            |i| states[i].linear_velocity,
            |i| self.bodies[i].name.clone(),
            self.steps,
            self.time,
        )
    }

    /// `scene.dem.max_dt`: rapier solves contacts as velocity constraints, which are
    /// stable at any step (no contact stiffness to resolve), so only accuracy bounds it.
    /// Integration is symplectic Euler over rapier's 4 internal substeps, so a constant
    /// acceleration `a` is off by `a·t·dt/8` in position after time t.
    fn stable_dt(&self) -> f64 {
        self.max_dt
    }

    fn set_gravity(&mut self, g: [f64; 3]) {
        self.world.gravity = scaled(g, self.scale);
    }

    fn set_kinematic_velocity(
        &mut self,
        body: usize,
        linear: [f64; 3],
        angular: [f64; 3],
    ) -> Result<(), DemError> {
        let Some(b) = self.bodies.get_mut(body) else {
            return Err(not_kinematic(body, "", None));
        };
        let Some(k) = &b.kinematic else {
            return Err(not_kinematic(body, &b.name, Some(b.motion)));
        };
        b.kinematic = Some(k.rebased(self.time, linear, angular));
        if let Some(rb) = self.world.bodies.get_mut(b.handle) {
            // rapier moves a velocity-based kinematic body by these (and contacts see
            // them); the pose is then reset to the closed form after each step.
            rb.set_linvel(scaled(linear, self.scale), true);
            rb.set_angvel(vec3(angular), true);
        }
        Ok(())
    }

    fn save_state(&self) -> Result<Vec<u8>, DemError> {
        encode_state(
            Self::NAME,
            &RapierState {
                world: &self.world,
                kinematic: self.bodies.iter().map(|b| b.kinematic).collect(),
                time: self.time,
                steps: self.steps,
            },
        )
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), DemError> {
        let s: RapierState<PhysicsWorld> = decode_state(Self::NAME, bytes)?;
        let missing = self
            .bodies
            .iter()
            .position(|b| s.world.bodies.get(b.handle).is_none());
        if s.kinematic.len() != self.bodies.len() || missing.is_some() {
            return Err(DemError::State {
                engine: Self::NAME,
                what: "restore",
                detail: format!(
                    "it holds {} bodies ({} prescribed motions) for a scene of {}",
                    s.world.bodies.len(),
                    s.kinematic.len(),
                    self.bodies.len()
                ),
            });
        }
        self.world = s.world;
        // The integration parameters carry the last substep; the next step sets its own.
        for (b, k) in self.bodies.iter_mut().zip(s.kinematic) {
            b.kinematic = k;
        }
        (self.time, self.steps) = (s.time, s.steps);
        self.weight_set = f64::NAN;
        Ok(())
    }
}

/// What evolves in a [`RapierEngine`]: rapier's whole world (bodies, colliders, contact
/// manifolds with their warm-start impulses, islands, broad phase, gravity) and the
/// prescribed motions; names, masses and the domain follow from the scene. `W` is a
/// reference when saving, the world itself when restoring.
#[derive(serde::Serialize, serde::Deserialize)]
struct RapierState<W> {
    world: W,
    kinematic: Vec<Option<Kinematic>>,
    time: f64,
    steps: u64,
}

/// rapier's mass properties of a body from the `f64` geometry: mass ρV, centre of mass
/// at the body origin, principal moments and axes from nalgebra's `f64` eigen
/// decomposition of [`BodyGeometry::inertia`] (axes made right-handed), the moments in
/// rapier's length unit (times `scale`²).
fn mass_properties(
    geometry: &BodyGeometry,
    density: f64,
    scale: f64,
) -> rapier3d::prelude::MassProperties {
    let eigen = geometry.inertia(density).symmetric_eigen();
    let mut axes = eigen.eigenvectors;
    if axes.determinant() < 0.0 {
        axes.set_column(2, &(-axes.column(2)));
    }
    let q = nalgebra::UnitQuaternion::from_matrix(&axes);
    let v = eigen.eigenvalues * (scale * scale);
    rapier3d::prelude::MassProperties::with_principal_inertia_frame(
        Vector::ZERO,
        (density * geometry.volume()) as Real,
        Vector::new(v.x as Real, v.y as Real, v.z as Real),
        Rotation::from_xyzw(q.i as Real, q.j as Real, q.k as Real, q.w as Real),
    )
}
