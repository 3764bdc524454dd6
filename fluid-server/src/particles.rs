//! Initial particles from the scene: fluid blocks on a cubic lattice, wall particles
//! around the domain and inside fixed box obstacles, and the initial density.
//!
//! Ids (= indices here) are grouped by kind: `[0, n_fluid)` fluid,
//! `[n_fluid, n_fluid + n_wall)` wall; body markers are appended after them by the
//! solver when the DEM sends coupling points.

use crate::constants::SphConstants;
use crate::error::FluidError;
use crate::initial_mass::summation_consistent_masses;
use crate::porosity::{PorosityField, Solid};
/// Re-exported for the CPU twins, which take them from here.
pub use couplet_protocol::vec3::{dot, sub};
use couplet_protocol::{InitialFlow, Scene, Shape, WallModel};

/// A particle set in world coordinates (SI units), indexed by id: the initial state of
/// a solver, and the CPU side of the kernel twins (`f64`).
#[derive(Debug, Clone, Default)]
pub struct ParticleSet {
    pub pos: Vec<[f64; 3]>,
    pub vel: Vec<[f64; 3]>,
    pub rho: Vec<f64>,
    pub press: Vec<f64>,
    /// Mass of each particle, kg: the lattice mass ρ0 δ³ ([`SphConstants::mass`]); for
    /// fluid among unresolved grains about the porosity of its starting point times that,
    /// as [`crate::initial_mass`] solves it.
    pub mass: Vec<f64>,
    /// Original id of each entry (equal to the index for a fresh set; GPU readbacks are
    /// in sorted order).
    pub id: Vec<u32>,
    pub kinds: ParticleKinds,
}

/// How many particles of each kind; kinds are id ranges.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ParticleKinds {
    pub n_fluid: usize,
    pub n_wall: usize,
    pub n_markers: usize,
}

/// What a particle is, from its id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Fluid,
    Wall,
    Marker,
}

impl ParticleKinds {
    pub fn total(&self) -> usize {
        self.n_fluid + self.n_wall + self.n_markers
    }
    pub fn marker_base(&self) -> usize {
        self.n_fluid + self.n_wall
    }
    pub fn kind(&self, id: u32) -> Kind {
        let id = id as usize;
        if id < self.n_fluid {
            Kind::Fluid
        } else if id < self.marker_base() {
            Kind::Wall
        } else {
            Kind::Marker
        }
    }
}

impl ParticleSet {
    pub fn len(&self) -> usize {
        self.pos.len()
    }
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }
    /// Indices of the particles within `radius` of particle `i` (itself excluded), the
    /// distance taken to the nearest image on the axes where `period[k] > 0`
    /// ([`nearest_image`], `SphConstants::period`), as the GPU's `pair_vec` takes it:
    /// brute force, for the CPU twins.
    pub fn neighbours(
        &self,
        i: usize,
        radius: f64,
        period: [f64; 3],
    ) -> impl Iterator<Item = usize> + '_ {
        let p = self.pos[i];
        let r2 = radius * radius;
        (0..self.len()).filter(move |&j| {
            let d = nearest_image(p, self.pos[j], period);
            j != i && dot(d, d) < r2
        })
    }
    /// Entry index of each id (inverse of `id`).
    pub fn index_of_id(&self) -> Vec<usize> {
        let mut inv = vec![usize::MAX; self.len()];
        for (k, &id) in self.id.iter().enumerate() {
            if let Some(slot) = inv.get_mut(id as usize) {
                *slot = k;
            }
        }
        inv
    }
}

/// `a − b` as the nearest image on the axes where `period[k] > 0` (0: not periodic):
/// the f64 form of `pair_vec` in `grid_common.wgsl`, for the CPU twins.
pub fn nearest_image(a: [f64; 3], b: [f64; 3], period: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| {
        let d = a[k] - b[k];
        let p = period[k];
        if p > 0.0 { d - p * (d / p).round() } else { d }
    })
}

/// Number of wall layers: `ceil(support − ½)`. The first fluid row sits δ/2 inside the
/// face and wall layer k at (k + ½)δ outside it, so a fluid particle reaches
/// (support − ½)δ into the wall; one more layer would lie beyond every kernel (and
/// costs a boundary-pressure pass over it every step: walls are half the particles of
/// a small closed box). A particle pressed closer than δ/2 to the wall sees at most the
/// kernel's near-zero tail truncated.
///
/// Joubert's walls (`domain.wall_model = "joubert"`, §2.5) are one layer on the face
/// itself, half a spacing from the first fluid row.
pub fn wall_layers(scene: &Scene) -> usize {
    if scene.domain.wall_model == WallModel::Joubert {
        return 1;
    }
    // With variable h the layers fill the largest support allowed (Robinson eq. 19).
    scene.fluid.as_ref().map_or(0, |f| {
        let reach = if scene.effects.variable_smoothing_length {
            f.support * f.max_smoothing_ratio()
        } else {
            f.support
        };
        (reach - 0.5).ceil().max(1.0) as usize
    })
}

/// Lattice coordinates along one axis of `[min, max]`, cell-centred: min + δ/2 + iδ.
fn lattice(min: f64, max: f64, delta: f64) -> Vec<f64> {
    let n = ((max - min) / delta).round().max(0.0) as usize;
    (0..n).map(|i| min + (i as f64 + 0.5) * delta).collect()
}

/// Rotation matrix of a scaled axis (Rodrigues).
fn rotation(scaled_axis: [f64; 3]) -> [[f64; 3]; 3] {
    let theta = (scaled_axis[0].powi(2) + scaled_axis[1].powi(2) + scaled_axis[2].powi(2)).sqrt();
    if theta == 0.0 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let [x, y, z] = scaled_axis.map(|a| a / theta);
    let (s, c) = theta.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// A fixed box obstacle: centre, rotation (body → world) and half extents.
struct Obstacle {
    centre: [f64; 3],
    rot: [[f64; 3]; 3],
    half: [f64; 3],
}

impl Obstacle {
    /// Depth of `p` inside the box (distance to the nearest face; negative outside).
    fn depth(&self, p: [f64; 3]) -> f64 {
        let d = [
            p[0] - self.centre[0],
            p[1] - self.centre[1],
            p[2] - self.centre[2],
        ];
        let mut depth = f64::INFINITY;
        for k in 0..3 {
            // Body coordinate k = (Rᵀ d)_k.
            let local = self.rot[0][k] * d[0] + self.rot[1][k] * d[1] + self.rot[2][k] * d[2];
            depth = depth.min(self.half[k] - local.abs());
        }
        depth
    }
}

/// Builds the initial particles of `scene`.
///
/// * Fluid: each `[[fluid.blocks]]` on a cubic lattice of `spacing`, first particle at
///   `min + δ/2`; particles inside a fixed box obstacle are removed.
/// * Walls: [`wall_layers`] layers outside each face of the domain (the +y face only
///   when `closed_top`; none on periodic axes), edges and corners included, on the
///   lattice continued outward from each face (`min − δ/2 − kδ`, `max + δ/2 + kδ`; with
///   `wall_model = "joubert"` one layer on the face itself, `min` and `max`).
///   They rest, except the +y layers, which move at `domain.lid_velocity`.
/// * Fixed box obstacles (`motion = "fixed"`, `shape.box`): wall particles on the
///   domain lattice inside the box, down to the support radius below its surface
///   (deeper ones would never see the fluid).
/// * Density: hydrostatic when gravity acts on the fluid: p = ρ0 |g_y| s with s the
///   particle's depth on the lattice below h_s, the top of the highest block over its
///   (x, z) column (so p is exactly the weight of the lattice mass above), ρ from the
///   inverted Tait equation (Joubert eq. 4); assumes y is up (the scene default). The
///   column is then compressed along y towards its bottom, the particle at mass depth s
///   going to height d(H) − d(s) above the block bottom with d(s) = ∫₀ˢ ρ0/ρ ds', so that
///   each particle's volume m/ρ matches its density: on an uncompressed lattice standard
///   SPH sees a uniform particle density but a varying ρ, an imbalance of ≈ 3 p/(ρ c²) of
///   g that sets the column oscillating (measured: ±3 % of ρgH). The bottom row keeps
///   its lattice gap to the wall (a wider gap pulls it down at ~g); the free surface
///   drops by H − d(H) ≈ H·ρgH/(2ρc²) (2 mm for 0.3 m at c_s = 17.5 m/s).
///   Without gravity on the fluid: ρ0.
/// * `fluid.initial_flow`: the fluid's velocity and (through the inverted Tait
///   equation) density from the analytic field.
///   Walls start at ρ0; the boundary-pressure stage sets them before they are used.
pub fn initial_particles(scene: &Scene, c: &SphConstants) -> Result<ParticleSet, FluidError> {
    let f = scene.fluid.as_ref().ok_or(FluidError::NoFluid)?;
    let delta = f.spacing;
    let dom = &scene.domain;
    let obstacles: Vec<Obstacle> = scene
        .bodies
        .iter()
        .filter(|b| scene.is_fluid_obstacle(b))
        .filter_map(|b| match &b.shape {
            Shape::Box { half_extents } => Some(Obstacle {
                centre: b.position,
                rot: rotation(b.rotation),
                half: *half_extents,
            }),
            _ => None,
        })
        .collect();

    let mut pos = Vec::new();
    for b in &f.blocks {
        let (xs, ys, zs) = (
            lattice(b.min[0], b.max[0], delta),
            lattice(b.min[1], b.max[1], delta),
            lattice(b.min[2], b.max[2], delta),
        );
        for &x in &xs {
            for &y in &ys {
                for &z in &zs {
                    let p = [x, y, z];
                    if obstacles.iter().all(|o| o.depth(p) <= 0.0) {
                        pos.push(p);
                    }
                }
            }
        }
    }
    let n_fluid = pos.len();
    if n_fluid == 0 {
        return Err(FluidError::NoParticles { spacing: delta });
    }

    let layers = wall_layers(scene);
    // Layer l's distance behind a face: (l + ½)δ for Adami's layers, 0 for Joubert's one
    // layer on the face.
    let offset = if dom.wall_model == WallModel::Joubert {
        0.0
    } else {
        0.5
    };
    // Per axis: outer layers below, the interior lattice, outer layers above.
    // A periodic axis has no wall layers (its lattice tiles the period).
    let axis = |k: usize, upper: bool| -> (Vec<f64>, usize) {
        let layers = if dom.periodic[k] { 0 } else { layers };
        let mut v: Vec<f64> = (0..layers)
            .rev()
            .map(|l| dom.min[k] - (l as f64 + offset) * delta)
            .collect();
        let n_below = v.len();
        v.extend(lattice(dom.min[k], dom.max[k], delta));
        if upper {
            v.extend((0..layers).map(|l| dom.max[k] + (l as f64 + offset) * delta));
        }
        (v, n_below)
    };
    let (ax, bx) = axis(0, true);
    let (ay, by) = axis(1, dom.closed_top);
    let (az, bz) = axis(2, true);
    let inside = |i: usize, below: usize, n: usize| i >= below && i < below + n;
    let (nx, ny, nz) = (
        lattice(dom.min[0], dom.max[0], delta).len(),
        lattice(dom.min[1], dom.max[1], delta).len(),
        lattice(dom.min[2], dom.max[2], delta).len(),
    );
    for (i, &x) in ax.iter().enumerate() {
        for (j, &y) in ay.iter().enumerate() {
            for (k, &z) in az.iter().enumerate() {
                if !(inside(i, bx, nx) && inside(j, by, ny) && inside(k, bz, nz)) {
                    pos.push([x, y, z]);
                }
            }
        }
    }
    let support = c.grid_radius();
    if !obstacles.is_empty() {
        let (xs, ys, zs) = (
            lattice(dom.min[0], dom.max[0], delta),
            lattice(dom.min[1], dom.max[1], delta),
            lattice(dom.min[2], dom.max[2], delta),
        );
        for &x in &xs {
            for &y in &ys {
                for &z in &zs {
                    let p = [x, y, z];
                    if obstacles.iter().any(|o| {
                        let d = o.depth(p);
                        d > 0.0 && d <= support
                    }) {
                        pos.push(p);
                    }
                }
            }
        }
    }
    let n_wall = pos.len() - n_fluid;

    let g_y = if scene.gravity.on_fluid {
        scene.gravity.vector[1]
    } else {
        0.0
    };
    let mut rho = vec![c.rho0; pos.len()];
    if g_y < 0.0 {
        let g = -g_y;
        // k = ρ0 g / B: ρ(s) = ρ0 (1 + k s)^(1/γ) at mass depth s (Joubert eq. 4 inverted).
        let k = c.rho0 * g / c.tait_b();
        let inv_gamma = 1.0 / c.gamma;
        for (p, r) in pos.iter_mut().zip(rho.iter_mut()).take(n_fluid) {
            let column = f.blocks.iter().filter(|b| {
                (b.min[0]..=b.max[0]).contains(&p[0]) && (b.min[2]..=b.max[2]).contains(&p[2])
            });
            let surface = column
                .clone()
                .map(|b| b.max[1])
                .fold(f64::NEG_INFINITY, f64::max);
            let bottom = column.map(|b| b.min[1]).fold(f64::INFINITY, f64::min);
            // Mass depth: the lattice holds ρ0 per unit volume, so the weight above the
            // particle is exactly ρ0 g s.
            let s = (surface - p[1]).max(0.0);
            // The column's pressure is P_b (fluid.background_pressure) at its top.
            let p_h = c.background_pressure + c.rho0 * g * s;
            *r = c.density(p_h);
            // Compress the column towards its bottom so that each particle's volume m/ρ
            // matches its density: compressed depth d(s) = ∫₀ˢ ρ0/ρ ds'.
            let depth =
                |s: f64| ((1.0 + k * s).powf(1.0 - inv_gamma) - 1.0) / (k * (1.0 - inv_gamma));
            let height = surface - bottom;
            p[1] = bottom + depth(height) - depth(s);
        }
    }
    // Walls rest, except the +y wall's layers (on or behind the face), which slide at
    // the lid velocity.
    let mut vel: Vec<[f64; 3]> = pos
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if i >= n_fluid && dom.closed_top && p[1] > dom.max[1] - 0.25 * delta {
                dom.lid_velocity
            } else {
                [0.0; 3]
            }
        })
        .collect();
    if let Some(InitialFlow::TaylorGreen {
        velocity: u0,
        wavelength,
    }) = f.initial_flow
    {
        // `fluid.initial_flow` (scene.rs): the Taylor–Green vortex from domain.min.
        let k = 2.0 * std::f64::consts::PI / wavelength;
        for i in 0..n_fluid {
            let (x, y) = (pos[i][0] - dom.min[0], pos[i][1] - dom.min[1]);
            vel[i] = [
                -u0 * (k * x).cos() * (k * y).sin(),
                u0 * (k * x).sin() * (k * y).cos(),
                0.0,
            ];
            let p = c.background_pressure
                - c.rho0 * u0 * u0 / 4.0 * ((2.0 * k * x).cos() + (2.0 * k * y).cos());
            rho[i] = c.density(p);
        }
    }
    let n = pos.len();
    let press = rho
        .iter()
        .take(n_fluid)
        .map(|r| c.pressure(*r))
        .chain(std::iter::repeat_n(0.0, n_wall))
        .collect();
    // Among unresolved grains the fluid's density is superficial, ε ρ_f (Robinson §3.1):
    // a particle of the lattice starts at ε of the intrinsic density, at its starting
    // porosity (eq. 9); the pressure above is the intrinsic one (eq. 15). Its mass is
    // about ε of the lattice mass, solved so that the density starts as the summation
    // density of the masses, which continuity then keeps (initial_mass.rs). Walls start
    // at porosity 1; the boundary pass gives them the porosity where they stand
    // (porosity.rs, boundary_state_wgsl).
    let mut mass = vec![c.mass; n];
    let solids: Vec<Solid> = (scene.grains().into_iter())
        .filter_map(|i| match scene.bodies[i].shape {
            Shape::Sphere { radius } => Some(Solid {
                position: scene.bodies[i].position,
                volume: 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
            }),
            _ => None,
        })
        .collect();
    if !solids.is_empty() {
        let field = PorosityField::of_scene(c, scene);
        let eps = field.porosity(&pos[..n_fluid], &solids);
        for (i, &e) in eps.iter().enumerate() {
            if !(e > 0.0) {
                return Err(FluidError::Porosity {
                    at: format!("fluid particle {i} at {:?} m (initial state)", pos[i]),
                    porosity: e,
                });
            }
            mass[i] *= e;
            rho[i] *= e;
        }
        // With Robinson's variable h (eq. 19) each particle sums with its own kernel,
        // which depends on the masses: not solved for (ARCHITECTURE.md).
        if c.variable_h.is_none() {
            summation_consistent_masses(
                c,
                &pos,
                n_fluid,
                &eps,
                field.period,
                field.origin,
                &mut mass,
            )?;
        }
    }
    Ok(ParticleSet {
        vel,
        mass,
        id: (0..n as u32).collect(),
        pos,
        rho,
        press,
        kinds: ParticleKinds {
            n_fluid,
            n_wall,
            n_markers: 0,
        },
    })
}
