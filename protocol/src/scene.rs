//! The scene schema: one TOML file, SI units, every field documented, unknown fields
//! rejected with file, line and field. `docs/scene.md` is generated from nothing: the
//! doc comments here are the reference, and `scenes/*.toml` are worked examples.

use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Errors loading or checking a scene. Every variant names the file; parse errors
/// also the line and column.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}:{line}:{column}: {message}")]
    Parse {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{file}: {field} = {value}: {why}")]
    Invalid {
        file: PathBuf,
        field: String,
        value: String,
        why: String,
    },
}

/// A whole scene.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub meta: Meta,
    pub time: TimeSpec,
    /// Absent: no fluid (a DEM-only scene).
    pub fluid: Option<FluidSpec>,
    pub domain: Domain,
    #[serde(default)]
    pub gravity: GravitySpec,
    #[serde(default)]
    pub effects: EffectsSpec,
    #[serde(default)]
    pub dem: DemSpec,
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// `[[grain_lattices]]`: blocks of unresolved grains on a cubic lattice, appended to
    /// `bodies` when the scene is read (see [`GrainLattice`]).
    #[serde(default)]
    pub grain_lattices: Vec<GrainLattice>,
    #[serde(default)]
    pub coupling: CouplingSpec,
    #[serde(default)]
    pub output: OutputSpec,
}

/// `[[grain_lattices]]`: unresolved spherical grains on a simple cubic lattice filling a
/// box, as Robinson §4 sets up the constant-porosity block and the Rayleigh–Taylor
/// layer. The lattice spacing is `Δr = (V/(1 − ε))^(1/3)` for the grains' volume V and
/// the block's `porosity` ε (Robinson §4); the grains sit at `min + (i + ½) Δr` for
/// every i whose grain fits inside `max`. On reading, each grain becomes a body named
/// `NAME[i]` (`coupling = "unresolved"`, dynamic), after the scene's own `[[bodies]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrainLattice {
    pub name: String,
    /// The block's lower and upper corners, m. To fill a periodic axis evenly, make the
    /// span a whole number of Δr.
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// Grain radius, m.
    pub radius: f64,
    /// Grain density, kg/m³.
    pub density: f64,
    /// The block's porosity ε, 0 < ε < 1; sets the spacing.
    pub porosity: f64,
    /// The grains translate as one body, without rotating (Robinson §4: "the DEM
    /// particles are restricted from moving relative to each other and the layer of
    /// particles falls as a block"): their `translation_group` is the lattice's name.
    /// Default false (free grains, Robinson §7).
    #[serde(default)]
    pub rigid: bool,
    /// Coulomb friction of the grains' contacts. Default 0.5, as for bodies.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Restitution of the grains' contacts. Default 0, as for bodies.
    #[serde(default)]
    pub restitution: f64,
    /// A disturbance of the block's lower face (Robinson eq. 39, the Rayleigh–Taylor
    /// case of §7). Absent: the plain lattice.
    #[serde(default)]
    pub perturbation: Option<LatticePerturbation>,
}

/// `[grain_lattices.perturbation]`: Robinson eq. (39) with his vertical z as our y.
/// Every grain moves down (along −y) by `A (1 − cos(2π x/λ)) (1 − cos(2π z/λ))`, x and
/// z its horizontal coordinates from the origin: 0 on the lines x or z = 0 (mod λ), 4A
/// at the centre of each λ × λ cell. Robinson takes A = d/4 and λ the box width w.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LatticePerturbation {
    /// A, m: a quarter of the deepest displacement.
    pub amplitude: f64,
    /// λ, m: make it the period of the box's x and z for a single mode.
    pub wavelength: f64,
}

impl LatticePerturbation {
    /// The downward displacement of a grain at horizontal position (x, z), m.
    pub fn depth(&self, x: f64, z: f64) -> f64 {
        let k = 2.0 * std::f64::consts::PI / self.wavelength;
        // Robinson eq. (39)
        self.amplitude * (1.0 - (k * x).cos()) * (1.0 - (k * z).cos())
    }
}

impl GrainLattice {
    /// Lattice spacing Δr = (V/(1 − ε))^(1/3), m (Robinson §4).
    pub fn spacing(&self) -> f64 {
        let v = 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3);
        (v / (1.0 - self.porosity)).cbrt()
    }

    /// Grains along x, y and z: a grain fits when its lattice cell does, up to round-off
    /// in the span.
    pub fn counts(&self) -> [usize; 3] {
        let dr = self.spacing();
        std::array::from_fn(|k| ((self.max[k] - self.min[k]) / dr * (1.0 + 1e-9)).floor() as usize)
    }

    /// Grain centres, x fastest (grain i is at lattice cell (i mod n_x, (i / n_x) mod n_y,
    /// i / (n_x n_y)) of [`counts`](Self::counts)), moved down by the perturbation where
    /// there is one.
    pub fn centres(&self) -> Vec<[f64; 3]> {
        let (dr, n) = (self.spacing(), self.counts());
        let mut out = Vec::with_capacity(n[0] * n[1] * n[2]);
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let i = [x, y, z];
                    let mut c: [f64; 3] =
                        std::array::from_fn(|k| self.min[k] + (i[k] as f64 + 0.5) * dr);
                    if let Some(p) = &self.perturbation {
                        c[1] -= p.depth(c[0], c[2]);
                    }
                    out.push(c);
                }
            }
        }
        out
    }
}

/// `[meta]`: what the scene is and where it comes from.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Meta {
    /// Short name, used in recordings and reports.
    pub name: String,
    /// Where the set-up comes from (paper and section), if anywhere.
    #[serde(default)]
    pub source: Option<String>,
    #[serde(default)]
    pub description: Option<String>,
}

/// `[time]`: how long to simulate and how often to record.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Simulated end time, s.
    pub end: f64,
    /// Interval between recorded fluid snapshots, s. Body states and loads are
    /// recorded every coupling window unless `body_output_interval` says otherwise.
    pub output_interval: f64,
    /// Interval between recorded body states and loads, s. Default: every coupling
    /// window. Set it for scenes with many grains, whose states cost some 300 bytes per
    /// body and window in the recording.
    #[serde(default)]
    pub body_output_interval: Option<f64>,
    /// Stability factor `s` of Joubert eq. (24). Default 0.2: the paper keeps it in
    /// 0.1–0.2; 0.2 is also the usual acoustic CFL of Wendland WCSPH with a
    /// predictor–corrector.
    #[serde(default = "default_cfl")]
    pub cfl: f64,
    /// Upper bound on the coupling window, s. Default: none (the window is the
    /// smallest stable step of either side times `window_substeps`).
    #[serde(default)]
    pub max_window: Option<f64>,
}

fn default_cfl() -> f64 {
    0.2
}

/// Smoothing kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KernelKind {
    /// Wendland C2 (Wendland 1995), support radius 2h.
    WendlandC2,
    /// Quintic spline of Joubert eq. (6) (Morris 1997), support radius 3h.
    Quintic,
}

impl KernelKind {
    /// Support radius in units of the smoothing length h.
    pub fn radius_in_h(self) -> f64 {
        match self {
            Self::WendlandC2 => 2.0,
            Self::Quintic => 3.0,
        }
    }
}

/// `[fluid]`: the weakly compressible fluid.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidSpec {
    /// Reference density ρ0, kg/m³.
    pub density: f64,
    /// Kinematic viscosity ν, m²/s.
    pub kinematic_viscosity: f64,
    /// Numerical speed of sound c_s of the Tait equation (Joubert eq. 4), m/s. At
    /// least ten times the fastest expected flow (Joubert §2.1).
    pub sound_speed: f64,
    /// Initial particle spacing δ, m.
    pub spacing: f64,
    /// Kernel; default Wendland C2 (positive Fourier transform, no pairing instability).
    #[serde(default = "default_kernel")]
    pub kernel: KernelKind,
    /// Kernel support radius in units of `spacing`. Default 3.0: about 113 neighbours
    /// in 3D, the usual accuracy/cost balance (see BENCHMARKS.md).
    #[serde(default = "default_support")]
    pub support: f64,
    /// Exponent γ of the Tait equation (Joubert eq. 4). Default 7 (Monaghan, via Joubert §2.1).
    #[serde(default = "default_gamma")]
    pub gamma: f64,
    /// Background pressure P_b of the equation of state, Pa: the Tait pressure becomes
    /// ρ0 c²/γ ((ρ/ρ0)^γ − 1) + P_b, so ρ0 is the density at P_b and every initial
    /// pressure (the hydrostatic column, an `initial_flow`'s field) is P_b above its
    /// gauge value; the initial densities do not change. In a closed or periodic domain
    /// the level of the pressure is free, and the incompressible flow does not depend
    /// on it, but the symmetric pair sum (no `effects.gradient_correction`) does: where
    /// the pressure turns negative, pairs attract (the tensile instability), which a
    /// background pressure prevents. Keep it small beside ρ0 c² (≲ 1 %): the sum form's
    /// particle-scale forces grow with it. Among grains with `coupling.porosity_pressure
    /// = "energy-pair"` the grains' forces feel the level: 200 Pa slowed the
    /// constant-porosity block's quick by 25 % (the scene warns; ARCHITECTURE.md, "The
    /// fluid's lattice must not be the grains'"). Recorded pressures include it. Refused
    /// with an open top, where a free surface needs P = 0. Default 0: the pressure is
    /// the gauge pressure, 0 at a free surface.
    #[serde(default)]
    pub background_pressure: f64,
    /// Boxes filled with fluid particles on a cubic lattice of `spacing`.
    pub blocks: Vec<FluidBlock>,
    /// `[fluid.initial_flow]`: an analytic velocity and pressure field the fluid starts
    /// with. Default none: at rest (hydrostatic under gravity).
    #[serde(default)]
    pub initial_flow: Option<InitialFlow>,
    /// With `effects.variable_smoothing_length`: the largest smoothing length a fluid
    /// particle may take, in units of the scene's h. The neighbour grid is built for it
    /// (every pair loop's cells are this much wider, so the fixed-h passes visit up to
    /// its cube more candidates), and a particle whose h would exceed it stops the run
    /// with an error naming it. Among grains h = h0 ε^(−1/3) (Robinson eq. 19 with
    /// ρ = ε ρ_f), so the ratio sets the lowest porosity the fluid can enter: 1.4 (the
    /// default) reaches ε = 0.36, random close packing of equal spheres. Unset without
    /// variable h (setting it then is an error: it would do nothing).
    #[serde(default)]
    pub max_smoothing_ratio: Option<f64>,
}

/// `[fluid.initial_flow]`: an analytic initial state, selected by `kind`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum InitialFlow {
    /// The Taylor–Green vortex in the x–y plane, with x, y measured from `domain.min`:
    /// u = −U cos(2πx/L) sin(2πy/L), v = U sin(2πx/L) cos(2πy/L), w = 0,
    /// p = −ρ0 U²/4 (cos(4πx/L) + cos(4πy/L)) (the density from the inverted Tait
    /// equation). A solution of the Navier–Stokes equations whose amplitude decays as
    /// e^{bt}, b = −8π²ν/L² (`../shared/validation/taylor_green_2d_decay.csv`).
    /// Needs periodic x and y with periods that are whole wavelengths, and no gravity
    /// on the fluid.
    TaylorGreen {
        /// U, m/s.
        velocity: f64,
        /// L, m.
        wavelength: f64,
    },
}

fn default_kernel() -> KernelKind {
    KernelKind::WendlandC2
}
fn default_support() -> f64 {
    3.0
}
fn default_gamma() -> f64 {
    7.0
}

/// Default of `fluid.max_smoothing_ratio`: ε^(−1/3) at ε = 0.364, random close packing
/// of equal spheres (Robinson eq. 19 with ρ = ε ρ_f), rounded up.
pub const DEFAULT_MAX_SMOOTHING_RATIO: f64 = 1.4;

impl FluidSpec {
    /// Smoothing length h, m.
    pub fn smoothing_length(&self) -> f64 {
        self.support * self.spacing / self.kernel.radius_in_h()
    }
    /// Kernel support radius, m.
    pub fn support_radius(&self) -> f64 {
        self.support * self.spacing
    }
    /// `fluid.max_smoothing_ratio` with its default, for a scene with variable h.
    pub fn max_smoothing_ratio(&self) -> f64 {
        self.max_smoothing_ratio
            .unwrap_or(DEFAULT_MAX_SMOOTHING_RATIO)
    }
}

/// `[[fluid.blocks]]`: an axis-aligned box of fluid, m.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidBlock {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// Wall condition on the domain boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WallKind {
    /// Fixed wall particles with zero velocity.
    NoSlip,
    /// Fixed wall particles that carry pressure but no shear.
    FreeSlip,
}

/// `[domain]`: the closed box that holds fluid and bodies, m.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// Wall condition on every face. Default no-slip.
    #[serde(default = "default_walls")]
    pub walls: WallKind,
    /// Whether the top face (+y) is a wall. Default false: an open lid (fluid cannot
    /// leave the domain through it in practice since gravity points down; a particle
    /// that does is reported as an error).
    #[serde(default)]
    pub closed_top: bool,
    /// Axes `[x, y, z]` on which the domain is periodic. Default none. A periodic axis
    /// has no walls on its two faces: a particle leaving through one re-enters through
    /// the other, and particles interact across the faces through their nearest image.
    /// Each period must be a whole number of fluid spacings (the lattice tiles it
    /// without a seam) and at least 2.5 support radii long (the fluid server names the
    /// axis otherwise). Bodies: resolved ones must span every periodic axis from face to
    /// face, each its own periodic image (Joubert's infinitely long cylinder; the DEM
    /// server checks the span). Unresolved spheres (`coupling = "none"`) of the
    /// soft-sphere engine wrap across the faces; rapier does not wrap, so with it no
    /// other body may be on a periodic axis.
    /// Not a periodic y with `closed_top` or with gravity along y on the fluid.
    #[serde(default)]
    pub periodic: [bool; 3],
    /// Velocity of the +y wall, m/s: the lid of a driven cavity, the moving plate of
    /// Couette flow. Default 0. The wall particles stay in place (an infinite plate
    /// sliding in its own plane) and enter the viscous sums with this velocity.
    /// Needs `closed_top` and no-slip walls; must be tangential (y component 0).
    #[serde(default)]
    pub lid_velocity: [f64; 3],
    /// How the walls are built and given their pressure. Default `"adami"`.
    #[serde(default)]
    pub wall_model: WallModel,
    /// Axes `[x, y, z]` whose two faces are symmetry planes (zero normal gradient of
    /// every field, zero normal velocity) instead of `walls`. Default none. With
    /// `wall_model = "joubert"` the plane's boundary particles take the fluid's
    /// tangential velocity by Joubert eq. (27); with `"adami"` its wall layers carry
    /// the extrapolated pressure (which keeps the fluid out and has no normal gradient
    /// but the hydrostatic one) and enter the viscous sums with the fluid's velocity
    /// mirrored across the plane (its normal component reversed), so a flow along the
    /// plane feels no shear from it. Not on a periodic axis, nor on y with a lid
    /// velocity. A particle on the edge between a symmetry plane and a wall belongs to
    /// the wall (its velocity is the wall's).
    #[serde(default)]
    pub symmetry: [bool; 3],
}

impl Domain {
    /// Whether the faces of axis `k` are symmetry planes of Joubert's walls: listed in
    /// `symmetry`, or every face with `walls = "free-slip"` (not on a periodic axis,
    /// which has no faces).
    pub fn is_symmetry_axis(&self, k: usize) -> bool {
        !self.periodic[k] && (self.symmetry[k] || self.walls == WallKind::FreeSlip)
    }

    /// Whether the top is open (no lid, y not periodic): the fluid has a free surface.
    pub fn open_top(&self) -> bool {
        !self.closed_top && !self.periodic[1]
    }
}

/// `domain.wall_model`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WallModel {
    /// Layers of wall particles filling the support behind each face (the first δ/2
    /// behind it), pressure extrapolated from the fluid by Adami, Hu & Adams (2012),
    /// eq. (27). Works with every scheme; the default because it needs no correction.
    #[default]
    Adami,
    /// One layer of boundary particles on each face (Joubert §2.5): no-slip faces hold
    /// their velocity (a Dirichlet condition), symmetry faces (`domain.symmetry`, or
    /// every face with `walls = "free-slip"`) take the fluid's tangential velocity by
    /// eq. (27) with a zero normal derivative; the pressure of every boundary particle
    /// comes from the Neumann condition of eq. (25) with B over its fluid neighbours.
    /// Resolved bodies' markers take eq. (25) too, with the rigid-body acceleration of
    /// each surface point (estimated from the body's velocity change over the previous
    /// window). Needs `effects.gradient_correction` (a one-layer wall truncates the
    /// kernel, which only the corrected operators tolerate); not with fixed box
    /// obstacles yet (their wall particles have no normals).
    /// The time step (Joubert eq. 24) takes δ/2, the layer's distance from the fluid.
    /// Eq. (25)'s viscous term is not included yet (exact for fluid at rest and channel
    /// flows), and nothing but compression stops fluid crossing the one layer: a driven
    /// cavity blows up near its lid corners (ARCHITECTURE.md). Even at rest in a closed
    /// box a mode grows at the one layer (an eigenmode of the corrected operators there,
    /// `couplet_fluid::linear_acoustics`) unless δ-SPH and α together damp it
    /// ([`JOUBERT_WALL_DAMPING`]; the scene warns). Not for a free surface:
    /// every open tank and dam break tried blew up within 0.06 s, and the scene warns
    /// (`Scene::may_hold_a_free_surface`).
    Joubert,
}

fn default_walls() -> WallKind {
    WallKind::NoSlip
}

/// The damping measured to hold Joubert's one-layer walls' mode, as pairs (δ-SPH
/// coefficient, Monaghan's α): a scene with these walls is warned of unless it has at
/// least both numbers of one pair. In the closed hydrostatic tank's quick (ARCHITECTURE.md,
/// "Joubert's one-layer walls grow a mode") δ-SPH 0.2 with α = 0.2 decayed (the CI case)
/// and 0.1 with α = 0.5 held to 1 s, while 0.1 with α = 0.2 grew ×2 every 10 ms, α = 0.5
/// alone blew up at 0.096 s and δ-SPH 0.2 alone at 0.113 s (2026-12-05, 2026-12-07).
/// Neither alone removes it: linearised about rest, δ-SPH 0.2 leaves +99.9 1/s (the run
/// without α grew at 98) and α acts only between approaching particles.
pub const JOUBERT_WALL_DAMPING: [(f64, f64); 2] = [(0.2, 0.2), (0.1, 0.5)];

/// `[gravity]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GravitySpec {
    /// m/s². Default (0, -9.81, 0): y is up.
    #[serde(default = "default_g")]
    pub vector: [f64; 3],
    /// Whether gravity acts on the fluid. When false (Joubert §2.6), it acts on the
    /// bodies only, reduced by the buoyancy of Joubert eq. (28). When true, a resolved
    /// body's buoyancy is the hydrostatic pressure on its markers, which one layer of
    /// markers holds only with `effects.gradient_correction` (`tests/tests/validation/buoyancy.rs`:
    /// a fixed sphere 2.5 δ in radius gets ρ V g within 1.9 % corrected, 13 % low
    /// uncorrected in a closed tank, 58 % high under a free surface); `couplet run`
    /// warns of the uncorrected combination ([`Scene::warnings`]).
    #[serde(default = "default_true")]
    pub on_fluid: bool,
    /// Seconds over which the weight of each dynamic body the fluid sees, beyond the
    /// buoyancy the fluid gives it, grows from zero to full: such a body's gravity is
    /// `g [b + (s − b) r(t/T)]`, with s its full scale (1, or `1 − ρ_f/ρ_s` under Joubert
    /// eq. 28), b the part the fluid's pressure already balances (`ρ_f/ρ_s` with gravity
    /// on the fluid, else 0) and `r(x) = 10x³ − 15x⁴ + 6x⁵` (no jump in the load, its
    /// rate or its curvature). Bodies the fluid does not see (`coupling = "none"`) get
    /// their full weight from the start. Default 0: the full weight at t = 0, released
    /// from rest as in Robinson §4.
    ///
    /// Why: a weakly compressible fluid answers a load that arrives within its acoustic
    /// period (4H/c for an open column of height H) by ringing in that period, at about
    /// the load over its area over ρc. Unresolved grains in a viscous fluid hand the
    /// fluid their weight within their drag relaxation time, 0.16 ms in Robinson's
    /// water–glycerol, and at the scenes' c = 10 m/s that is short against the column's
    /// 2.4 ms: the block of `constant-porosity-block` rang at ±158 % of its settling
    /// speed (±1100 % at ε = 0.6). The real fluid's period is 16 µs, and the load
    /// arrives slowly against it; a ramp over a few artificial periods restores that
    /// order. The ramp leaves a ring of 2.9 % of the step's at two periods, 0.6 % at
    /// three, 0.2 % at four (the spectrum of r' at the mode). It changes the start, not
    /// a steady state: judge what comes after it.
    #[serde(default)]
    pub excess_weight_ramp: f64,
}

impl Default for GravitySpec {
    fn default() -> Self {
        Self {
            vector: default_g(),
            on_fluid: true,
            excess_weight_ramp: 0.0,
        }
    }
}

impl GravitySpec {
    /// The fraction of a fluid-coupled body's excess weight it carries at time t,
    /// `r(t / excess_weight_ramp)` (see [`excess_weight_ramp`](Self::excess_weight_ramp)):
    /// 0 at t = 0, 1 from the end of the ramp on, 1 throughout without one.
    pub fn excess_weight_fraction(&self, t: f64) -> f64 {
        let ramp = self.excess_weight_ramp;
        if ramp <= 0.0 || t >= ramp {
            return 1.0;
        }
        let x = (t / ramp).max(0.0);
        x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
    }
}

fn default_g() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}
fn default_true() -> bool {
    true
}

/// Viscosity model of the fluid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ViscosityModel {
    /// No physical viscosity stage.
    None,
    /// Laminar viscosity of Morris, Fox & Zhu (1997).
    Laminar,
}

/// The δ-SPH term of `effects.density_diffusion` (`effects.density_diffusion_form`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DensityDiffusionForm {
    /// Antuono, Colagrossi, Marrone & Molteni 2010: renormalised density gradients.
    #[default]
    Antuono,
    /// Fourtakas, Domínguez, Vacondio & Rogers 2019: the hydrostatic difference removed.
    Fourtakas,
}

/// `[effects]`: which physics the fluid server dispatches. An effect that is off
/// dispatches no kernel and allocates no buffer.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectsSpec {
    /// Default laminar (Morris 1997).
    #[serde(default = "default_viscosity")]
    pub viscosity: ViscosityModel,
    /// Monaghan (1992) artificial viscosity coefficient α; 0 switches the stage off.
    /// Default 0: the papers' cases are resolved with physical viscosity.
    #[serde(default)]
    pub artificial_viscosity: f64,
    /// Kernel-gradient correction of Joubert eq. (10): every fluid gradient (continuity,
    /// pressure gradient, the Taylor terms of particle shifting) is multiplied by the
    /// inverse B of the particle's truncation matrix, which makes the gradient of a
    /// linear field exact next to walls and free surfaces. With it the continuity and
    /// pressure terms take Joubert's difference form (eqs. 12–13) — except that among
    /// unresolved grains the continuity keeps the standard form, Robinson eq. (10): the
    /// corrected one lets the grains' swept volume compress the fluid (ARCHITECTURE.md,
    /// "Among grains the continuity keeps its standard form"). A particle whose
    /// matrix is near-singular (det < `couplet_fluid` `B_DET_MIN`: isolated or nearly so)
    /// keeps the uncorrected gradient and is counted in the run log. Default false: the
    /// standard scheme is the cheaper one and the foundation's tests are written for it.
    /// Under a free surface the difference forms blow up (the open tank in 0.024 s):
    /// `free_surface` below switches them off where the support reaches past the
    /// fluid's edge, and is on by default in a domain with an open top.
    #[serde(default)]
    pub gradient_correction: bool,
    /// Corrected Laplacian of Joubert eqs. (11) and (13) (Fatehi & Manzari) for the
    /// viscous term: a (d² + d)/2 = 6 unknown truncation B̂_i per particle, solved on the
    /// GPU, makes the Laplacian of a quadratic velocity field exact on any particle
    /// arrangement (Morris's operator is off by about 1.5 % on a lattice with Wendland
    /// support 3 δ, and more near walls and free surfaces). Needs laminar viscosity.
    /// Default false: it costs a 6 × 6 solve per particle and step.
    #[serde(default)]
    pub laplacian_correction: bool,
    /// Mass correction of Joubert eqs. (14)–(16) (Fatehi & Manzari's pressure
    /// smoothing): the smoothing factor Γ; 0 switches it off. Continuity gains
    /// `ρ_i Γ Δt (⟨∇·(∇p/ρ)⟩ᶜ_i − ⟨∇·⟨∇p/ρ⟩⟩ᶜ_i)`, the difference between a compact
    /// (eq. 15, corrected-Laplacian stencil) and a wide (eq. 16, divergence of the
    /// corrected gradient) pressure Laplacian. The two agree on smooth fields (the term
    /// vanishes for a quadratic pressure) and differ on particle-scale pressure noise,
    /// which the term damps. Joubert sets Γ ≥ 1; values below 1 are refused. It acts like
    /// a pressure diffusion with coefficient Γ Δt c_s², so with the usual CFL number
    /// (c_s Δt/h ≈ 0.1–0.2) Γ of a few is the stable range; larger Γ can go unstable and
    /// the blow-up check will say where. Needs `gradient_correction` (eq. 14 is built on
    /// the corrected divergence) and computes B̂ like `laplacian_correction` does.
    /// Default 0 (off): it costs the B̂ solve and a wider pair sum per step.
    #[serde(default)]
    pub mass_correction: f64,
    /// Particle shifting of Joubert eqs. (17)–(19) (Xu et al. 2009): the decrowding
    /// factor β; 0 switches it off. Joubert gives 0.001 ≤ β ≤ 0.1, and values outside
    /// that range are refused. Each neighbour in eq. (17)'s sum counts as the lattice
    /// particles it stands for, m_j/(ρ0 δ³): 1 for fluid, wall and fill particles, ΔS/δ²
    /// for a body's surface marker (ARCHITECTURE.md); among unresolved grains, where a
    /// lattice particle's mass is ε m0, m_j/(ε_j ρ0 δ³), and eq. (19) acts on the
    /// intrinsic density ρ/ε. Default 0 (off): shifting changes the particle
    /// distribution, which a scene asks for.
    #[serde(default)]
    pub particle_shifting: f64,
    /// δ-SPH density diffusion (Antuono, Colagrossi, Marrone & Molteni 2010) with the
    /// renormalised density gradient: the coefficient δ; 0 switches it off. Antuono et
    /// al. use δ = 0.1; values outside (0, 1] are refused. Default 0 (off): it is the
    /// free-surface stabiliser a scene picks instead of, or with, the correction. Among
    /// unresolved grains it diffuses the intrinsic density ρ/ε, and it damps the odd-even
    /// row mode of the pressure that a flow through a grain lattice raises
    /// (ARCHITECTURE.md, "An odd-even pressure mode among grains").
    #[serde(default)]
    pub density_diffusion: f64,
    /// Which δ-SPH term `density_diffusion` adds (unused when it is 0):
    /// - `"antuono"` (default): Antuono et al. 2010's ψ_ij = 2(ρ_j − ρ_i) r_ji/r² −
    ///   (⟨∇ρ⟩ᶜ_i + ⟨∇ρ⟩ᶜ_j), with renormalised density gradients from the gradient pass.
    ///   The gradients make the term vanish on a hydrostatic field where the support is
    ///   complete; where it is truncated (a free surface) the renormalisation is poorly
    ///   conditioned and the term is not zero.
    /// - `"fourtakas"`: Fourtakas, Domínguez, Vacondio & Rogers 2019 (Computers & Fluids
    ///   190, 346–361; DualSPHysics `DensityDT=2`): ψ_ij = 2(ρ_j − ρ_i − ρ^H_ji) r_ji/r²,
    ///   ρ^H_ji = ρ0((1 + ρ0 g·r_ji/B)^(1/γ) − 1), the hydrostatic density difference of
    ///   the equation of state (r_ji = r_j − r_i, g the gravity on the fluid, B the Tait
    ///   stiffness). No gradients, so it needs no gradient pass; it is zero on a
    ///   hydrostatic field at a free surface too, to second order in ρ0 g r/B.
    ///
    /// Default `"antuono"`: every scene validated before 2026-12 ran with it.
    #[serde(default)]
    pub density_diffusion_form: DensityDiffusionForm,
    /// The gradient correction's free-surface switch: where a particle's support reaches
    /// past the fluid's edge (its truncation matrix has det M below 0.95 of a complete
    /// support's, `couplet_fluid` `FREE_SURFACE_FRACTION`: the two rows below a flat
    /// surface at support 3δ, the one at 2δ), the continuity and pressure terms take the standard,
    /// symmetric forms instead of Joubert's corrected difference forms (eqs. 12–13); the
    /// correction stays on wherever the support is complete. Joubert runs no free
    /// surface; with the difference forms there the open hydrostatic tank blew up in
    /// 0.024 s and the dam break in 0.01 s (the surface particle's p_i B S feedback grows
    /// at the acoustic rate, ARCHITECTURE.md "The free-surface switch"). Adami's wall
    /// layers fill a particle's support, so walls do not trip it; Joubert's one-layer
    /// walls and the markers of resolved bodies leave the support truncated, so near
    /// them it trips too. Default (unset): on with `gradient_correction` when the domain's
    /// top is open (`domain.closed_top = false`, y not periodic), the domains that can
    /// hold a free surface, and off otherwise, so closed boxes keep the full correction.
    /// `true` needs `gradient_correction`.
    #[serde(default)]
    pub free_surface: Option<bool>,
    /// Robinson's variable smoothing length (eqs. 10–12, 19, after Price 2012): every
    /// fluid particle takes h_i = h (V_i/δ³)^(1/3), V_i = m_i/ρ_i, so that among grains,
    /// where the superficial density is ε ρ_f, it keeps about the same number of
    /// neighbours as in clear fluid (with a fixed h it has ε of them). Continuity and the
    /// standard pressure term carry the grad-h factor Ω_i of eq. (11) and the pressure
    /// term takes each side's own kernel (eq. 12); the corrected forms (eqs. 12–13 of
    /// Joubert) take ∇W(h_i), with B_i built from the same kernel; the viscous terms take
    /// the mean of ∇W(h_i) and ∇W(h_j). Walls and markers keep h (their volume is δ³ by
    /// construction). The boundary pass, the grains' porosity and sampling keep h too:
    /// they are interpolations at the coupling length. `fluid.max_smoothing_ratio`
    /// bounds h_i. Not built together with the corrected Laplacian, the mass
    /// correction, particle shifting, δ-SPH or Joubert's walls (each assumes one h; the
    /// scene is refused). Default false: it costs a pass per step and a wider grid.
    #[serde(default)]
    pub variable_smoothing_length: bool,
}

fn default_viscosity() -> ViscosityModel {
    ViscosityModel::Laminar
}

impl Default for EffectsSpec {
    fn default() -> Self {
        Self {
            viscosity: default_viscosity(),
            artificial_viscosity: 0.0,
            gradient_correction: false,
            laplacian_correction: false,
            mass_correction: 0.0,
            particle_shifting: 0.0,
            density_diffusion: 0.0,
            density_diffusion_form: DensityDiffusionForm::default(),
            free_surface: None,
            variable_smoothing_length: false,
        }
    }
}

/// `[dem]`: the DEM engine and its contact parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemSpec {
    /// Engine name from the registry (`couplet plan` lists them). Default "rapier".
    #[serde(default = "default_engine")]
    pub engine: String,
    /// Largest DEM step, s. Default 1e-3: rapier resolves contacts as velocity
    /// constraints and is stable far above the fluid step; smaller windows are
    /// substepped down to it anyway.
    #[serde(default = "default_dem_dt")]
    pub max_dt: f64,
    /// `[dem.soft_sphere]`: contact law and material of the `soft-sphere` engine;
    /// required by that engine and refused with any other.
    #[serde(default)]
    pub soft_sphere: Option<SoftSphereSpec>,
}

/// Normal contact law of the `soft-sphere` engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ContactLaw {
    /// Linear spring–dashpot, Robinson eq. (21): `F_n = k δ + β δ̇`, with β from the
    /// bodies' restitution. Needs `stiffness`.
    Linear,
    /// Hertz–Mindlin, DEMocritus eqs. (18)–(31): `F_n = k_n δ^{3/2} + c_n δ̇`,
    /// `k_n = 4/3 E* √R*`, with a tangential spring and Coulomb limit. Needs
    /// `youngs_modulus`.
    HertzMindlin,
}

/// `[dem.soft_sphere]`: one material for every sphere of the scene (friction and
/// restitution stay per body).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftSphereSpec {
    /// `"linear"` (Robinson eq. 21) or `"hertz-mindlin"` (DEMocritus eqs. 18–31).
    pub contact: ContactLaw,
    /// Linear law only: normal spring stiffness k, N/m (Robinson Table 1 uses 1e-4 for
    /// 0.1 mm grains, chosen soft so that the fluid, not the contacts, sets the step).
    pub stiffness: Option<f64>,
    /// Hertz–Mindlin only: Young's modulus E of the spheres (and of the rigid domain
    /// walls' partner), Pa.
    pub youngs_modulus: Option<f64>,
    /// Poisson's ratio ν. Default 0.3, typical of glass, quartz and steel (0.2–0.3): it
    /// sets the tangential stiffness `k_t = k_n / (2 (1 + ν))` (DEMocritus eq. 31) and,
    /// for Hertz–Mindlin, `E* = E / (2 (1 − ν²))`.
    #[serde(default = "default_poisson")]
    pub poisson_ratio: f64,
    /// DEM steps per contact duration: Δt = t_c / this. Default 50 (Robinson §3.2).
    #[serde(default = "default_steps_per_contact")]
    pub steps_per_contact: f64,
    /// Hertz–Mindlin only: the fastest impact the step must resolve, m/s (the Hertz
    /// contact is shorter the faster the impact, `t_c ∝ v^{-1/5}`). Default: the speed
    /// of a fall through the domain height under gravity, `√(2 |g| H)`, or 1 m/s
    /// without gravity; a faster body at run time shortens the step further.
    pub impact_speed: Option<f64>,
    /// The lubrication force between spheres of DEMocritus eq. (34),
    /// `F = 3π μ_f d² (v_j − v_i) / (8 (|r_ij| − d))`, for pairs closer than the fluid's
    /// kernel support radius (DEMocritus §2.3), with μ_f = ρ ν of `[fluid]`. Default off.
    #[serde(default)]
    pub lubrication: bool,
    /// Smallest gap the lubrication force sees, as a fraction of the pair's diameter:
    /// closer (or touching) pairs feel the force at this gap. Default 0.01: the squeeze
    /// film stops being a continuum at the surface roughness, commonly put at 1 % of d
    /// (DEMocritus gives no value; its force diverges at contact).
    #[serde(default = "default_lubrication_min_gap")]
    pub lubrication_min_gap: f64,
}

fn default_lubrication_min_gap() -> f64 {
    0.01
}

fn default_poisson() -> f64 {
    0.3
}
fn default_steps_per_contact() -> f64 {
    50.0
}

fn default_engine() -> String {
    "rapier".into()
}
fn default_dem_dt() -> f64 {
    1e-3
}

impl Default for DemSpec {
    fn default() -> Self {
        Self {
            engine: default_engine(),
            max_dt: default_dem_dt(),
            soft_sphere: None,
        }
    }
}

/// Body shape, in body coordinates (origin at the centre of mass of the shape as
/// given; vertices are recentred on their centroid).
#[derive(Debug, Clone, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum Shape {
    /// `shape.sphere.radius`, m.
    Sphere { radius: f64 },
    /// `shape.box.half_extents`, m.
    Box { half_extents: [f64; 3] },
    /// Cylinder along the body y axis: `radius`, `half_height`, m.
    Cylinder { radius: f64, half_height: f64 },
    /// Convex polyhedron: the convex hull of `vertices`, m.
    Convex { vertices: Vec<[f64; 3]> },
    /// Right regular prism along the body y axis (`shape.prism.sides`, `radius`,
    /// `half_height`): `sides` ≥ 3 rectangular faces whose edges lie on a circle of
    /// `radius` (m), so that with 12 sides it is Joubert's polyhedral "cylinder"
    /// (§3.2, Fig. 7b). Face normals point at angles 2πk/sides from body +x in the x–z
    /// plane: faces normal to ±x, and to ±z when `sides` is a multiple of 4.
    Prism {
        sides: u32,
        radius: f64,
        half_height: f64,
    },
    /// Joubert's ring (§4.2, Table 3, Fig. 17c; `shape.ring.sides`, `inner_radius`,
    /// `outer_radius`, `half_height`, m): a non-convex compound of `sides` ≥ 3 identical
    /// trapezoidal prisms around the body y axis, whose corners lie on circles of
    /// `inner_radius` and `outer_radius` at angles 2π(k + ½)/sides from body +x, like
    /// [`Shape::Prism`]'s. Joubert's ring is 12 prisms, 0.725 and 1.45 mm, height 1.75 mm.
    Ring {
        sides: u32,
        inner_radius: f64,
        outer_radius: f64,
        half_height: f64,
    },
    /// Joubert's cross (§4.2, Table 3, Fig. 17d; `shape.cross.base`, `width`, `height`,
    /// m): five identical cuboids of `base` along body x, `height` along y and `width`
    /// along z, laid as a plus sign in the y–z plane (a centre cuboid, two beside it in
    /// ±z, two above and below it in ±y) and extruded along x. Joubert's cuboids are
    /// b = 2.25, w = 0.75, h = 1 mm. Table 3 gives only these three lengths; the layout
    /// is the one that reproduces Table 4: volume 5 b w h (m_s/m_ref = 1.031), projection
    /// along y of b × 3w = 2.25 mm square (A_p/A_ref = 1.031) and width b (l_c/D = 0.900).
    Cross { base: f64, width: f64, height: f64 },
    /// Non-convex compound of convex parts, each the hull of its vertices, m.
    Compound { parts: Vec<Vec<[f64; 3]>> },
}

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    /// Never moves.
    Fixed,
    /// Moves with its initial velocities, whatever acts on it.
    Kinematic,
    /// Moves under gravity, contacts and fluid loads.
    Dynamic,
}

impl Motion {
    pub fn as_u32(self) -> u32 {
        match self {
            Self::Fixed => 0,
            Self::Kinematic => 1,
            Self::Dynamic => 2,
        }
    }
}

/// How a body meets the fluid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CouplingMode {
    /// Fully resolved: surface markers at the fluid spacing (Joubert §2.6).
    Resolved,
    /// Unresolved grain, smaller than the fluid spacing (Robinson §3.3): the fluid's
    /// force on it is sampled at its centre (interpolated velocity, pressure and viscous
    /// force, and the drag law of `coupling.drag`) at the porosity of Robinson eq. (9);
    /// the fluid's density is superficial (ε ρ_f, eqs. 10–15), and with
    /// `coupling.two_way` the fluid receives the opposite force. Spheres only.
    Unresolved,
    /// The fluid does not see the body.
    None,
}

/// `[[bodies]]`: one rigid body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    pub shape: Shape,
    /// Solid density, kg/m³; mass and inertia follow from it and the shape.
    pub density: f64,
    /// Initial centre of mass, m.
    pub position: [f64; 3],
    /// Initial rotation as a scaled axis (axis × angle in rad). Default none.
    #[serde(default)]
    pub rotation: [f64; 3],
    /// Initial velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Initial angular velocity, rad/s.
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    /// Default dynamic.
    #[serde(default = "default_motion")]
    pub motion: Motion,
    /// Default resolved.
    #[serde(default = "default_coupling")]
    pub coupling: CouplingMode,
    /// Coulomb friction coefficient of contacts. Default 0.5 (rapier's default).
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Coefficient of restitution of contacts. Default 0 (rapier's default).
    #[serde(default)]
    pub restitution: f64,
    /// Bodies that share a translation group move as one rigid body that does not rotate:
    /// each takes the group's acceleration, the sum of its members' forces (contacts,
    /// fluid, weight) over the sum of their masses. Members are not paired with each
    /// other, since their contact forces would cancel in that sum (a block of 15 300
    /// grains in one group steps in a quarter of the time). Dynamic spheres of the
    /// `soft-sphere` engine only. Default none.
    #[serde(default)]
    pub translation_group: Option<String>,
}

fn default_motion() -> Motion {
    Motion::Dynamic
}
fn default_coupling() -> CouplingMode {
    CouplingMode::Resolved
}
fn default_friction() -> f64 {
    0.5
}

/// Coupling scheme (preCICE vocabulary).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CouplingScheme {
    /// Fluid then DEM in each window, loads held constant over the DEM window. Where
    /// the loads are complete at the window's start (unresolved grains alone, see
    /// [`Scene::loads_known_at_window_start`]) the fluid sends them before it advances
    /// and the DEM steps beside it: the same numbers, in less time.
    SerialExplicit,
}

/// `[coupling]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    /// Default serial-explicit.
    #[serde(default = "default_scheme")]
    pub scheme: CouplingScheme,
    /// Fluid steps per coupling window. Default 1: each fluid step sees the bodies
    /// where they are; raise it to trade accuracy of the body motion inside the
    /// window for fewer exchanges. Unresolved grains bound the window further (a
    /// twentieth of their drag relaxation time, Robinson eq. 36, and where they move
    /// freely the time sound takes to cross h, h/c_s): `couplet plan` names the limit
    /// that binds.
    #[serde(default = "default_window_substeps")]
    pub window_substeps: u32,
    /// Drag law on unresolved grains (`coupling = "unresolved"`): `"stokes"` (Robinson
    /// eq. 28), `"coulson-richardson"` (eq. 29), `"di-felice"` (eqs. 30–33),
    /// `"ergun-wen-yu"` (DEMocritus eqs. 36–37, Gidaspow's switch at ε = 0.8, which
    /// jumps) or `"ergun-wen-yu-blend"` (the same, blended smoothly by Huilin &
    /// Gidaspow 2003). Default `"di-felice"`: Robinson's law for every case past a lone
    /// grain in creeping flow, valid from the Stokes to the Newton regime and in packed
    /// beds.
    #[serde(default = "default_drag")]
    pub drag: DragLawName,
    /// Unresolved grains push back on the fluid (Robinson eqs. 26–27): each grain's force
    /// is spread over the fluid particles within its support, weighted so that the
    /// fluid receives exactly minus what the grains receive. Default `true`: momentum is
    /// then conserved between the phases; `false` is one-way coupling (the grains feel
    /// the fluid, the fluid does not feel them), the approximation of a dilute
    /// suspension that Robinson §5.1 compares against.
    #[serde(default = "default_two_way")]
    pub two_way: bool,
    /// How the fluid's pressure acts between the fluid and unresolved grains:
    /// `"robinson"` (Robinson eqs. 12, 23–27 as written: the fluid's pressure term on its
    /// superficial density, each grain's resolved force `V ρθ̄` sampled from the fluid's
    /// rates and spread back with the drag) or `"energy-pair"` (the pressure terms that
    /// conserve energy for the EOS on ρ/ε, eq. 15: the fluid's pair term on P ε plus
    /// (P/ρ) ∇ε, ∇ε summed from the grains beside eq. 9, and on each grain exactly the
    /// opposite of that ∇ε term, `−V_j Σ_a V_a P_a ∇_j W_ja`; only the drag is spread).
    /// Both are −∇P/ρ_f on the fluid and −V ∇P on a grain in the continuum; they differ
    /// where the porosity varies within a support (a block's faces). The pair needs
    /// `effects.gradient_correction = false` (a warning says so). With `two_way = false`
    /// the fluid keeps its ∇ε term (part of its own pressure force) and only the drag is
    /// not spread. Default `"robinson"`: the paper as written. See ARCHITECTURE.md,
    /// "Among grains the pressure terms can be the energy-conserving pair".
    #[serde(default)]
    pub porosity_pressure: PorosityPressure,
}

/// `coupling.porosity_pressure`: see [`CouplingSpec::porosity_pressure`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PorosityPressure {
    #[default]
    Robinson,
    EnergyPair,
}

fn default_two_way() -> bool {
    true
}

/// `coupling.drag`: the drag law of unresolved grains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DragLawName {
    Stokes,
    CoulsonRichardson,
    DiFelice,
    ErgunWenYu,
    ErgunWenYuBlend,
}

fn default_drag() -> DragLawName {
    DragLawName::DiFelice
}

fn default_scheme() -> CouplingScheme {
    CouplingScheme::SerialExplicit
}
fn default_window_substeps() -> u32 {
    1
}

impl Default for CouplingSpec {
    fn default() -> Self {
        Self {
            scheme: default_scheme(),
            window_substeps: default_window_substeps(),
            drag: default_drag(),
            two_way: default_two_way(),
            porosity_pressure: PorosityPressure::default(),
        }
    }
}

/// `[output]`: which files a run writes beside `run.mcap` (MCAP is always written; see
/// the README's "Recordings" section for every file and its layout).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write ParaView files at every particle snapshot: `vtk/fluid_NNNNNN.vtp` (the fluid
    /// particles with velocity, pressure and density), `vtk/bodies_NNNNNN.vtp` (every
    /// body's surface at its pose) and the collections `fluid.pvd` and `bodies.pvd`.
    /// Default false: a fluid frame costs about 55 bytes per particle (the MCAP holds the
    /// same data compressed), 55 MB per snapshot of a million particles; switch it on
    /// with `--set output.vtk=true` where ParaView is the viewer.
    #[serde(default)]
    pub vtk: bool,
    /// Write `bodies.csv`: one row per body per recorded body time (the times of
    /// `/bodies/states`), with pose, velocities and fluid load. Default true: about 400
    /// bytes per body and record, small beside the particle snapshots of a resolved run;
    /// switch it off for scenes of many grains, or thin it with
    /// `time.body_output_interval`.
    #[serde(default = "default_true")]
    pub body_csv: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            vtk: false,
            body_csv: default_true(),
        }
    }
}

/// Returns `text` with the field at dotted `path` (e.g. `fluid.spacing`, `time.end`)
/// set to `value`, a TOML value (`0.02`, `"quintic"`, `true`): the command line's
/// `--set` overrides. Intermediate tables must exist; comments are not kept. The result
/// is the scene the servers load, written next to the recording.
pub fn override_field(
    text: &str,
    file: &Path,
    path: &str,
    value: &str,
) -> Result<String, SceneError> {
    let parse_err = |e: toml::de::Error, text: &str| {
        let (line, column) = e.span().map_or((0, 0), |s| line_col(text, s.start));
        SceneError::Parse {
            file: file.to_owned(),
            line,
            column,
            message: e.message().to_owned(),
        }
    };
    let invalid = |why: &str| SceneError::Invalid {
        file: file.to_owned(),
        field: path.to_owned(),
        value: value.to_owned(),
        why: why.to_owned(),
    };
    let table: toml::Table = toml::from_str(text).map_err(|e| parse_err(e, text))?;
    let wrapped = format!("v = {value}");
    let parsed: toml::Table =
        toml::from_str(&wrapped).map_err(|_| invalid("is not a TOML value"))?;
    let new = parsed
        .get("v")
        .cloned()
        .ok_or_else(|| invalid("is not a TOML value"))?;
    // Walk the path: a name enters a table, a number an array (`bodies.0.position`).
    let keys: Vec<&str> = path.split('.').collect();
    if keys.iter().any(|k| k.is_empty()) {
        return Err(invalid(
            "needs a dotted path such as fluid.spacing or bodies.0.position",
        ));
    }
    let mut node = toml::Value::Table(table);
    let mut cur = &mut node;
    for (i, k) in keys.iter().enumerate() {
        let last = i + 1 == keys.len();
        cur = match cur {
            toml::Value::Table(t) if last => {
                t.insert((*k).to_owned(), new);
                break;
            }
            // A table the file leaves out (all defaults) is created: the parse that follows
            // still rejects a misspelt name as an unknown field.
            toml::Value::Table(t) => {
                if keys[i + 1].parse::<usize>().is_err() {
                    t.entry((*k).to_owned())
                        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                } else {
                    t.get_mut(*k)
                        .ok_or_else(|| invalid(&format!("the scene has no `{k}` on that path")))?
                }
            }
            toml::Value::Array(a) => {
                let idx: usize = k
                    .parse()
                    .map_err(|_| invalid(&format!("`{k}` must be an index into an array")))?;
                let len = a.len();
                let slot = a.get_mut(idx).ok_or_else(|| {
                    invalid(&format!("index {idx} is past the array's {len} entries"))
                })?;
                if last {
                    *slot = new;
                    break;
                }
                slot
            }
            _ => return Err(invalid(&format!("`{k}` is not inside a table or array"))),
        };
    }
    match node {
        toml::Value::Table(t) => toml::to_string(&t).map_err(|e| invalid(&e.to_string())),
        _ => Err(invalid("the scene is not a table")),
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

impl Scene {
    /// Reads, parses and checks a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            file: path.to_owned(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// [`Scene::load`], with [`crate::payload::scene_digest`] of the text read: what a
    /// server says in its hello, so that the orchestrator knows it runs the same scene.
    pub fn load_with_digest(path: &Path) -> Result<(Self, u32), SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            file: path.to_owned(),
            source,
        })?;
        Ok((
            Self::parse(&text, path)?,
            crate::payload::scene_digest(&text),
        ))
    }

    /// Parses and checks scene text; `file` is only used in error messages.
    pub fn parse(text: &str, file: &Path) -> Result<Self, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((0, 0), |s| line_col(text, s.start));
            SceneError::Parse {
                file: file.to_owned(),
                line,
                column,
                message: e.message().to_owned(),
            }
        })?;
        let mut scene = scene;
        scene.expand_grain_lattices(file)?;
        scene.check(file)?;
        Ok(scene)
    }

    /// Appends each `[[grain_lattices]]` block's grains to `bodies`.
    fn expand_grain_lattices(&mut self, file: &Path) -> Result<(), SceneError> {
        for (l, g) in self.grain_lattices.iter().enumerate() {
            let bad = |field: &str, value: String, why: &str| SceneError::Invalid {
                file: file.to_owned(),
                field: format!("grain_lattices[{l}].{field}"),
                value,
                why: why.to_owned(),
            };
            if !(g.porosity > 0.0 && g.porosity < 1.0) {
                return Err(bad(
                    "porosity",
                    g.porosity.to_string(),
                    "must lie strictly between 0 and 1 (it sets the spacing (V/(1 − ε))^(1/3))",
                ));
            }
            if !(g.radius.is_finite() && g.radius > 0.0) {
                return Err(bad(
                    "radius",
                    g.radius.to_string(),
                    "must be a positive finite number",
                ));
            }
            if let Some(p) = &g.perturbation {
                for (field, v) in [("amplitude", p.amplitude), ("wavelength", p.wavelength)] {
                    if !(v.is_finite() && v >= 0.0) || (field == "wavelength" && v == 0.0) {
                        return Err(bad(
                            &format!("perturbation.{field}"),
                            v.to_string(),
                            "must be a finite number, ≥ 0 (amplitude) or > 0 (wavelength)",
                        ));
                    }
                }
            }
            let centres = g.centres();
            if centres.is_empty() {
                return Err(bad(
                    "max",
                    format!("{:?}", g.max),
                    &format!(
                        "the block from min {:?} holds no lattice cell of Δr = {:.6e} m",
                        g.min,
                        g.spacing()
                    ),
                ));
            }
            for (i, c) in centres.into_iter().enumerate() {
                self.bodies.push(BodySpec {
                    name: format!("{}[{i}]", g.name),
                    shape: Shape::Sphere { radius: g.radius },
                    density: g.density,
                    position: c,
                    rotation: [0.0; 3],
                    velocity: [0.0; 3],
                    angular_velocity: [0.0; 3],
                    motion: Motion::Dynamic,
                    coupling: CouplingMode::Unresolved,
                    friction: g.friction,
                    restitution: g.restitution,
                    translation_group: g.rigid.then(|| g.name.clone()),
                });
            }
        }
        Ok(())
    }

    /// Bodies that move (dynamic or kinematic).
    pub fn has_moving_bodies(&self) -> bool {
        self.bodies.iter().any(|b| b.motion != Motion::Fixed)
    }

    /// A fixed box in a scene with fluid is a solid obstacle that the fluid server fills
    /// with wall particles, like the domain walls (the SPHERIC dam-break box): it needs
    /// no markers and no DEM server of its own. Loads on it are not reported.
    pub fn is_fluid_obstacle(&self, body: &BodySpec) -> bool {
        self.fluid.is_some()
            && body.motion == Motion::Fixed
            && matches!(body.shape, Shape::Box { .. })
    }

    /// Whether a DEM server runs: some body is more than a fluid obstacle. A scene
    /// without moving bodies (a tank, the SPHERIC dam break) starts none.
    pub fn needs_dem(&self) -> bool {
        self.bodies.iter().any(|b| !self.is_fluid_obstacle(b))
    }

    /// Whether the fluid and the DEM exchange markers and loads every window.
    pub fn is_marker_coupled(&self, body: &BodySpec) -> bool {
        self.fluid.is_some()
            && body.coupling == CouplingMode::Resolved
            && !self.is_fluid_obstacle(body)
    }

    /// Whether any body exchanges markers and loads with the fluid.
    pub fn has_resolved_bodies(&self) -> bool {
        self.bodies.iter().any(|b| self.is_marker_coupled(b))
    }

    /// Whether the fluid samples its force on `body` at the body's centre (an
    /// unresolved grain, Robinson §3.3).
    pub fn is_grain(&self, body: &BodySpec) -> bool {
        self.fluid.is_some() && body.coupling == CouplingMode::Unresolved
    }

    /// Whether the gradient correction's free-surface switch is on: `effects.free_surface`
    /// when given, else on with the correction when the domain's top is open (see
    /// [`EffectsSpec::free_surface`]).
    pub fn free_surface_switch(&self) -> bool {
        self.effects.gradient_correction
            && (self.effects.free_surface).unwrap_or(self.domain.open_top())
    }

    /// Indices of the unresolved grains, in body order.
    pub fn grains(&self) -> Vec<usize> {
        (0..self.bodies.len())
            .filter(|i| self.is_grain(&self.bodies[*i]))
            .collect()
    }

    /// Whether the fluid sends loads every window: to resolved bodies or to grains.
    pub fn exchanges_loads(&self) -> bool {
        self.has_resolved_bodies() || self.bodies.iter().any(|b| self.is_grain(b))
    }

    /// Whether the window's loads are complete at its start, before the fluid advances:
    /// grains alone (Robinson's force at their window-start states, held over the
    /// window), without the `energy-pair` pressure force, which is summed over the
    /// window's fluid stages, and without resolved bodies, whose loads are reduced over
    /// them. The fluid server then sends them first and the DEM steps while the fluid
    /// does (ARCHITECTURE.md, "One coupling window").
    pub fn loads_known_at_window_start(&self) -> bool {
        // The only scheme; an implicit one would iterate the window on both sides.
        let CouplingScheme::SerialExplicit = self.coupling.scheme;
        self.exchanges_loads()
            && !self.has_resolved_bodies()
            && self.coupling.porosity_pressure != PorosityPressure::EnergyPair
    }

    /// Combinations that run but are known to be inaccurate, each a sentence for the
    /// user; `couplet run` and `couplet plan` print them.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.gravity.excess_weight_ramp >= self.time.end {
            w.push(format!(
                "gravity.excess_weight_ramp = {} s is not shorter than the run ({} s): the \
                 bodies the fluid sees never carry their full weight",
                self.gravity.excess_weight_ramp, self.time.end
            ));
        }
        if self.bodies.iter().any(|b| self.is_grain(b)) {
            if !self.effects.variable_smoothing_length {
                w.push(
                    "unresolved grains with a fixed smoothing length: where the porosity is ε a \
                     fluid particle has about ε times its neighbours (Robinson's variable h, \
                     eq. 19: effects.variable_smoothing_length = true)"
                        .into(),
                );
            }
            if self.effects.variable_smoothing_length
                && self.fluid.as_ref().is_some_and(|f| f.support < 3.0)
            {
                w.push(
                    "variable h with a support under 3 spacings: the grad-h factor Ω of \
                     Robinson eq. (11) carries the kernel sum's lattice error, 1 − Ω = 3.2 % at \
                     2.4δ and 5.2 % at 2δ (Wendland C2; 0.25 % at 3δ), and scales every \
                     pressure term by 1/Ω (`couplet plan` prints the scene's)"
                        .into(),
                );
            }
            if !self.coupling.two_way {
                w.push(
                    "coupling.two_way = false: the grains feel the fluid, the fluid does not \
                     feel them, and momentum is not conserved between the phases"
                        .into(),
                );
            }
            if self.coupling.porosity_pressure == PorosityPressure::EnergyPair
                && self.effects.gradient_correction
            {
                w.push(
                    "coupling.porosity_pressure = \"energy-pair\" with \
                     effects.gradient_correction: the corrected difference form of the \
                     pressure term conserves neither momentum nor energy, so the pair is not \
                     energy-conserving; at a block's faces its fluid grew a mode ×e per \
                     0.75 ms (ARCHITECTURE.md); switch the correction off"
                        .into(),
                );
            }
            if self.coupling.porosity_pressure == PorosityPressure::EnergyPair
                && self
                    .fluid
                    .as_ref()
                    .is_some_and(|f| f.background_pressure > 0.0)
            {
                w.push(
                    "coupling.porosity_pressure = \"energy-pair\" with \
                     fluid.background_pressure: the pair's grain forces feel the pressure's \
                     level, and 200 Pa slowed the constant-porosity block's quick by 25 % \
                     (ARCHITECTURE.md, \"The fluid's lattice must not be the grains'\")"
                        .into(),
                );
            }
        }
        if self.domain.wall_model == WallModel::Joubert && self.may_hold_a_free_surface() {
            w.push(
                "domain.wall_model = \"joubert\" with a free surface (an open top, or fluid \
                 blocks that leave part of the domain empty): every such run tried has blown \
                 up, the hydrostatic tank's quick at 0.03–0.06 s open or closed, the dam \
                 break's at 0.01 s, with or without δ-SPH (2026-12-04). Beside a one-layer wall \
                 the support is truncated, so the free-surface switch takes the standard \
                 pressure term there, and that term needs the full wall layers of \
                 \"adami\" (ARCHITECTURE.md, \"The free-surface switch\"); use \"adami\""
                    .into(),
            );
        }
        let (dsph, alpha) = (
            self.effects.density_diffusion,
            self.effects.artificial_viscosity,
        );
        if self.domain.wall_model == WallModel::Joubert
            && !JOUBERT_WALL_DAMPING
                .iter()
                .any(|&(d, a)| dsph >= d && alpha >= a)
        {
            w.push(format!(
                "domain.wall_model = \"joubert\" with effects.density_diffusion = {dsph} and \
                 effects.artificial_viscosity = {alpha}: a mode grows at the one-layer walls from \
                 round-off, an eigenmode of the corrected operators where the one layer truncates \
                 the support (+319 1/s in the closed hydrostatic tank's quick linearised about \
                 rest; run without α it grew at 305 1/s and blew up at 0.05 s, with δ-SPH 0.2 at \
                 98 1/s and 0.113 s). Measured to hold it: δ-SPH and α of at least {}",
                JOUBERT_WALL_DAMPING
                    .iter()
                    .map(|(d, a)| format!("{d} and {a}"))
                    .collect::<Vec<_>>()
                    .join(", or ")
                    + " (ARCHITECTURE.md, \"Joubert's one-layer walls grow a mode\")"
            ));
        }
        let weighs = self.gravity.on_fluid && self.gravity.vector.iter().any(|g| *g != 0.0);
        if weighs && self.has_resolved_bodies() && !self.effects.gradient_correction {
            w.push(
                "resolved bodies in a fluid that carries gravity, without effects.gradient_correction: \
                 the uncorrected pressure on one layer of markers is not hydrostatic, and their \
                 buoyancy is 13–58 % off (tests/tests/validation/buoyancy.rs); switch the correction on, or \
                 set gravity.on_fluid = false for Joubert eq. (28)"
                    .into(),
            );
        }
        w
    }

    /// Whether the fluid can have a free surface: the domain's top is open
    /// ([`DomainSpec::open_top`]), or its fluid blocks, clipped to the domain, fill less
    /// than all of it (overlapping blocks count twice, so a domain they leave partly empty
    /// can pass for full).
    pub fn may_hold_a_free_surface(&self) -> bool {
        let Some(f) = &self.fluid else {
            return false;
        };
        let d = &self.domain;
        let volume = |min: [f64; 3], max: [f64; 3]| -> f64 {
            (0..3)
                .map(|k| (max[k].min(d.max[k]) - min[k].max(d.min[k])).max(0.0))
                .product()
        };
        let filled: f64 = f.blocks.iter().map(|b| volume(b.min, b.max)).sum();
        d.open_top() || filled < volume(d.min, d.max) * (1.0 - 1e-9)
    }

    /// `effects.variable_smoothing_length` and `fluid.max_smoothing_ratio`: the ratio is
    /// set only with variable h and is a finite number ≥ 1; variable h is refused with
    /// the stages built for one h.
    fn check_variable_h(&self, f: &FluidSpec, file: &Path) -> Result<(), SceneError> {
        let bad = |field: &str, value: String, why: String| {
            Err(SceneError::Invalid {
                file: file.to_owned(),
                field: field.into(),
                value,
                why,
            })
        };
        let e = &self.effects;
        if !e.variable_smoothing_length {
            return match f.max_smoothing_ratio {
                Some(r) => bad(
                    "fluid.max_smoothing_ratio",
                    r.to_string(),
                    "bounds the variable smoothing length: needs effects.variable_smoothing_length = true".into(),
                ),
                None => Ok(()),
            };
        }
        if let Some(r) = f.max_smoothing_ratio
            && !(r.is_finite() && r >= 1.0)
        {
            return bad(
                "fluid.max_smoothing_ratio",
                r.to_string(),
                "must be a finite ratio ≥ 1 (the largest h over the scene's h)".into(),
            );
        }
        let one_h = [
            ("effects.laplacian_correction", e.laplacian_correction),
            ("effects.mass_correction", e.mass_correction != 0.0),
            ("effects.particle_shifting", e.particle_shifting != 0.0),
            ("effects.density_diffusion", e.density_diffusion != 0.0),
            (
                "domain.wall_model",
                self.domain.wall_model == WallModel::Joubert,
            ),
        ];
        match one_h.iter().find(|(_, on)| *on) {
            Some((field, _)) => bad(
                "effects.variable_smoothing_length",
                "true".into(),
                format!(
                    "is built for the standard and the gradient-corrected scheme with Adami's walls; \
                     {field} assumes one smoothing length: switch one of them off"
                ),
            ),
            None => Ok(()),
        }
    }

    /// `[dem.soft_sphere]` is present exactly when the engine is `soft-sphere`, names
    /// the parameters its contact law needs and none it ignores.
    fn check_soft_sphere(&self, file: &Path) -> Result<(), SceneError> {
        let bad = |field: &str, value: String, why: &str| {
            Err(SceneError::Invalid {
                file: file.to_owned(),
                field: field.into(),
                value,
                why: why.to_owned(),
            })
        };
        let soft = self.dem.engine == "soft-sphere";
        let Some(s) = &self.dem.soft_sphere else {
            if soft {
                return bad(
                    "dem.soft_sphere",
                    "missing".into(),
                    "the soft-sphere engine needs its contact law: [dem.soft_sphere] contact = \"linear\" with stiffness, or \"hertz-mindlin\" with youngs_modulus",
                );
            }
            return Ok(());
        };
        if !soft {
            return bad(
                "dem.soft_sphere",
                "present".into(),
                &format!(
                    "is read only by dem.engine = \"soft-sphere\"; this scene's engine is \"{}\"",
                    self.dem.engine
                ),
            );
        }
        let (needed, needed_name, unused, unused_name) = match s.contact {
            ContactLaw::Linear => (s.stiffness, "stiffness", s.youngs_modulus, "youngs_modulus"),
            ContactLaw::HertzMindlin => {
                (s.youngs_modulus, "youngs_modulus", s.stiffness, "stiffness")
            }
        };
        let law = match s.contact {
            ContactLaw::Linear => "linear",
            ContactLaw::HertzMindlin => "hertz-mindlin",
        };
        match needed {
            None => {
                return bad(
                    &format!("dem.soft_sphere.{needed_name}"),
                    "missing".into(),
                    &format!("contact = \"{law}\" needs it"),
                );
            }
            Some(v) if !(v.is_finite() && v > 0.0) => {
                return bad(
                    &format!("dem.soft_sphere.{needed_name}"),
                    v.to_string(),
                    "must be a positive finite number",
                );
            }
            _ => {}
        }
        if let Some(v) = unused {
            return bad(
                &format!("dem.soft_sphere.{unused_name}"),
                v.to_string(),
                &format!("is not a parameter of contact = \"{law}\""),
            );
        }
        if !(s.poisson_ratio > -1.0 && s.poisson_ratio < 0.5) {
            return bad(
                "dem.soft_sphere.poisson_ratio",
                s.poisson_ratio.to_string(),
                "must lie in (−1, 0.5) (a stable isotropic solid)",
            );
        }
        if !(s.steps_per_contact.is_finite() && s.steps_per_contact >= 10.0) {
            return bad(
                "dem.soft_sphere.steps_per_contact",
                s.steps_per_contact.to_string(),
                "must be at least 10: fewer steps per contact do not resolve the collision (Robinson §3.2 uses 50)",
            );
        }
        if s.lubrication && self.fluid.is_none() {
            return bad(
                "dem.soft_sphere.lubrication",
                "true".into(),
                "needs [fluid]: its viscosity ρν and kernel support radius (the force's cut-off, DEMocritus §2.3)",
            );
        }
        if !(s.lubrication_min_gap > 0.0 && s.lubrication_min_gap < 1.0) {
            return bad(
                "dem.soft_sphere.lubrication_min_gap",
                s.lubrication_min_gap.to_string(),
                "must lie in (0, 1) (a fraction of the pair's diameter)",
            );
        }
        if let Some(v) = s.impact_speed {
            if s.contact != ContactLaw::HertzMindlin {
                return bad(
                    "dem.soft_sphere.impact_speed",
                    v.to_string(),
                    "only the Hertz contact duration depends on the impact speed; the linear one does not",
                );
            }
            if !(v.is_finite() && v > 0.0) {
                return bad(
                    "dem.soft_sphere.impact_speed",
                    v.to_string(),
                    "must be a positive finite speed",
                );
            }
        }
        Ok(())
    }

    fn check(&self, file: &Path) -> Result<(), SceneError> {
        let bad = |field: String, value: String, why: &str| {
            Err(SceneError::Invalid {
                file: file.to_owned(),
                field,
                value,
                why: why.to_owned(),
            })
        };
        let pos = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                bad(
                    field.into(),
                    v.to_string(),
                    "must be a positive finite number",
                )
            }
        };
        pos("time.end", self.time.end)?;
        pos("time.output_interval", self.time.output_interval)?;
        if let Some(i) = self.time.body_output_interval {
            pos("time.body_output_interval", i)?;
        }
        if !(self.time.cfl > 0.0 && self.time.cfl <= 1.0) {
            return bad(
                "time.cfl".into(),
                self.time.cfl.to_string(),
                "must lie in (0, 1] (Joubert eq. 24)",
            );
        }
        if let Some(w) = self.time.max_window {
            pos("time.max_window", w)?;
        }
        pos("dem.max_dt", self.dem.max_dt)?;
        self.check_soft_sphere(file)?;
        for (i, b) in self.bodies.iter().enumerate() {
            if b.coupling != CouplingMode::Unresolved {
                continue;
            }
            let why = if self.fluid.is_none() {
                "an unresolved grain needs a [fluid] to be coupled to"
            } else if !matches!(b.shape, Shape::Sphere { .. }) {
                "unresolved grains are spheres (shape.sphere): the drag laws are for spheres"
            } else if b.motion != Motion::Dynamic {
                "unresolved grains are dynamic: a fixed or kinematic grain would take a force it ignores"
            } else {
                continue;
            };
            return bad(
                format!("bodies[{i}].coupling"),
                "\"unresolved\"".into(),
                why,
            );
        }
        if self.coupling.window_substeps == 0 {
            return bad(
                "coupling.window_substeps".into(),
                "0".into(),
                "must be at least 1",
            );
        }
        for k in 0..3 {
            if !(self.domain.min[k] < self.domain.max[k]) {
                return bad(
                    format!("domain.max[{k}]"),
                    self.domain.max[k].to_string(),
                    "must exceed domain.min",
                );
            }
        }
        let d = &self.domain;
        if d.periodic[1] && d.closed_top {
            return bad(
                "domain.closed_top".into(),
                "true".into(),
                "contradicts a periodic y axis (domain.periodic[1]): a periodic axis has no walls",
            );
        }
        // rapier does not wrap a body across a periodic face; a resolved body that spans
        // the periodic axis from face to face is its own periodic image (the DEM server
        // checks the span, where the shapes' geometry is known). The soft-sphere engine
        // wraps its spheres, so there only resolved bodies (whose markers the fluid would
        // have to wrap) must span.
        let wraps = self.dem.engine == "soft-sphere";
        if d.periodic.iter().any(|p| *p)
            && self
                .bodies
                .iter()
                .any(|b| !self.is_marker_coupled(b) && !wraps)
        {
            return bad(
                "domain.periodic".into(),
                format!("{:?}", d.periodic),
                "with dem.engine = \"rapier\", periodic axes take only resolved bodies that span them from face to face (rapier does not wrap a body across a periodic face; the soft-sphere engine does)",
            );
        }
        if d.lid_velocity.iter().any(|v| !v.is_finite()) || d.lid_velocity[1] != 0.0 {
            return bad(
                "domain.lid_velocity".into(),
                format!("{:?}", d.lid_velocity),
                "must be finite and tangential to the +y wall (y component 0)",
            );
        }
        if d.lid_velocity != [0.0; 3] && !(d.closed_top && d.walls == WallKind::NoSlip) {
            return bad(
                "domain.lid_velocity".into(),
                format!("{:?}", d.lid_velocity),
                "needs a +y wall (domain.closed_top = true) that is no-slip (domain.walls)",
            );
        }
        if d.wall_model == WallModel::Joubert {
            if !self.effects.gradient_correction {
                return bad(
                    "domain.wall_model".into(),
                    "joubert".into(),
                    "one-layer walls truncate the kernel: needs effects.gradient_correction = true (Joubert §2.5)",
                );
            }
            if self.bodies.iter().any(|b| self.is_fluid_obstacle(b)) {
                return bad(
                    "domain.wall_model".into(),
                    "joubert".into(),
                    "not with fixed box obstacles yet (their wall particles have no normals): use \"adami\"",
                );
            }
        }
        for k in (0..3).filter(|k| d.symmetry[*k]) {
            let why = if d.periodic[k] {
                "an axis cannot be both periodic and bounded by symmetry planes"
            } else if k == 1 && d.lid_velocity != [0.0; 3] {
                "the +y face carries the lid velocity: it cannot be a symmetry plane"
            } else {
                continue;
            };
            return bad(format!("domain.symmetry[{k}]"), "true".into(), why);
        }
        if self.gravity.vector.iter().any(|g| !g.is_finite()) {
            return bad(
                "gravity.vector".into(),
                format!("{:?}", self.gravity.vector),
                "must be finite",
            );
        }
        let ramp = self.gravity.excess_weight_ramp;
        if !(ramp.is_finite() && ramp >= 0.0) {
            return bad(
                "gravity.excess_weight_ramp".into(),
                format!("{ramp}"),
                "must be a finite duration ≥ 0 s (0: the full weight from the start)",
            );
        }
        if let Some(f) = &self.fluid {
            pos("fluid.density", f.density)?;
            pos("fluid.sound_speed", f.sound_speed)?;
            pos("fluid.spacing", f.spacing)?;
            pos("fluid.gamma", f.gamma)?;
            if !(f.background_pressure >= 0.0 && f.background_pressure.is_finite()) {
                return bad(
                    "fluid.background_pressure".into(),
                    f.background_pressure.to_string(),
                    "must be a finite number ≥ 0",
                );
            }
            if f.background_pressure > 0.0 && d.open_top() {
                return bad(
                    "fluid.background_pressure".into(),
                    f.background_pressure.to_string(),
                    "needs a closed domain (domain.closed_top = true, or a periodic y): \
                     at a free surface the pressure is 0, and a background pressure \
                     there would push the surface particles out",
                );
            }
            if !(f.kinematic_viscosity >= 0.0 && f.kinematic_viscosity.is_finite()) {
                return bad(
                    "fluid.kinematic_viscosity".into(),
                    f.kinematic_viscosity.to_string(),
                    "must be ≥ 0",
                );
            }
            if !(f.support >= 1.5 && f.support <= 6.0) {
                return bad(
                    "fluid.support".into(),
                    f.support.to_string(),
                    "must lie in [1.5, 6] spacings",
                );
            }
            for k in (0..3).filter(|k| d.periodic[*k]) {
                let cells = (d.max[k] - d.min[k]) / f.spacing;
                if (cells - cells.round()).abs() > 1e-6 * cells {
                    return bad(
                        format!("domain.periodic[{k}]"),
                        format!("period {} m, spacing {} m", d.max[k] - d.min[k], f.spacing),
                        "a period must be a whole number of fluid spacings (the lattice would leave a seam)",
                    );
                }
            }
            if d.periodic[1] && self.gravity.on_fluid && self.gravity.vector[1] != 0.0 {
                return bad(
                    "domain.periodic[1]".into(),
                    "true".into(),
                    "gravity along y on the fluid needs a floor (the initial hydrostatic state is built on it)",
                );
            }
            if let Some(InitialFlow::TaylorGreen {
                velocity,
                wavelength,
            }) = f.initial_flow
            {
                let whole = |k: usize| {
                    let n = (d.max[k] - d.min[k]) / wavelength;
                    d.periodic[k] && n >= 1.0 - 1e-9 && (n - n.round()).abs() < 1e-6 * n
                };
                if !(velocity.is_finite() && wavelength > 0.0 && whole(0) && whole(1)) {
                    return bad(
                        "fluid.initial_flow".into(),
                        format!("{:?}", f.initial_flow),
                        "Taylor–Green needs a finite velocity, a positive wavelength, and periodic x and y spanning whole wavelengths",
                    );
                }
                if self.gravity.on_fluid && self.gravity.vector.iter().any(|g| *g != 0.0) {
                    return bad(
                        "fluid.initial_flow".into(),
                        "taylor-green".into(),
                        "is a solution without body force: set gravity.vector = [0, 0, 0] or gravity.on_fluid = false",
                    );
                }
            }
            if f.blocks.is_empty() {
                return bad(
                    "fluid.blocks".into(),
                    "[]".into(),
                    "needs at least one block",
                );
            }
            for (i, b) in f.blocks.iter().enumerate() {
                for k in 0..3 {
                    if !(b.min[k] < b.max[k])
                        || b.min[k] < self.domain.min[k]
                        || b.max[k] > self.domain.max[k]
                    {
                        return bad(
                            format!("fluid.blocks[{i}]"),
                            format!("min {:?} max {:?}", b.min, b.max),
                            "must be a non-empty box inside the domain",
                        );
                    }
                }
            }
        }
        if self.effects.artificial_viscosity < 0.0 {
            return bad(
                "effects.artificial_viscosity".into(),
                self.effects.artificial_viscosity.to_string(),
                "must be ≥ 0",
            );
        }
        let delta = self.effects.density_diffusion;
        if !(0.0..=1.0).contains(&delta) {
            return bad(
                "effects.density_diffusion".into(),
                delta.to_string(),
                "must be 0 (off) or within (0, 1] (Antuono et al. 2010 use 0.1)",
            );
        }
        if self.effects.laplacian_correction && self.effects.viscosity != ViscosityModel::Laminar {
            return bad(
                "effects.laplacian_correction".into(),
                "true".into(),
                "corrects the laminar viscous term: needs effects.viscosity = \"laminar\"",
            );
        }
        let gamma_mc = self.effects.mass_correction;
        if gamma_mc != 0.0 && !(gamma_mc >= 1.0 && gamma_mc.is_finite()) {
            return bad(
                "effects.mass_correction".into(),
                gamma_mc.to_string(),
                "must be 0 (off) or a finite Γ ≥ 1 (Joubert §2.3.2)",
            );
        }
        if self.effects.free_surface == Some(true) && !self.effects.gradient_correction {
            return bad(
                "effects.free_surface".into(),
                "true".into(),
                "switches the gradient correction's difference forms off at a free surface: needs effects.gradient_correction = true",
            );
        }
        if gamma_mc != 0.0 && !self.effects.gradient_correction {
            return bad(
                "effects.mass_correction".into(),
                gamma_mc.to_string(),
                "corrects Joubert eq. (12)'s corrected continuity: needs effects.gradient_correction = true",
            );
        }
        if let Some(f) = &self.fluid {
            self.check_variable_h(f, file)?;
        }
        let beta = self.effects.particle_shifting;
        if beta != 0.0 && !(0.001..=0.1).contains(&beta) {
            return bad(
                "effects.particle_shifting".into(),
                beta.to_string(),
                "must be 0 (off) or within Joubert's 0.001 ≤ β ≤ 0.1 (§2.3.3)",
            );
        }
        for (i, b) in self.bodies.iter().enumerate() {
            if b.translation_group.is_some()
                && (self.dem.engine != "soft-sphere"
                    || b.motion != Motion::Dynamic
                    || !matches!(b.shape, Shape::Sphere { .. }))
            {
                return bad(
                    format!("bodies[{i}].translation_group"),
                    format!("{:?}", b.translation_group),
                    "takes dynamic spheres on dem.engine = \"soft-sphere\" only",
                );
            }
            pos(&format!("bodies[{i}].density"), b.density)?;
            let ok = match &b.shape {
                Shape::Sphere { radius } => *radius > 0.0,
                Shape::Box { half_extents } => half_extents.iter().all(|h| *h > 0.0),
                Shape::Cylinder {
                    radius,
                    half_height,
                } => *radius > 0.0 && *half_height > 0.0,
                Shape::Convex { vertices } => vertices.len() >= 4,
                Shape::Prism {
                    sides,
                    radius,
                    half_height,
                } => *sides >= 3 && *radius > 0.0 && *half_height > 0.0,
                Shape::Ring {
                    sides,
                    inner_radius,
                    outer_radius,
                    half_height,
                } => {
                    *sides >= 3
                        && *inner_radius > 0.0
                        && outer_radius > inner_radius
                        && *half_height > 0.0
                }
                Shape::Cross {
                    base,
                    width,
                    height,
                } => *base > 0.0 && *width > 0.0 && *height > 0.0,
                Shape::Compound { parts } => {
                    !parts.is_empty() && parts.iter().all(|p| p.len() >= 4)
                }
            };
            if !ok {
                return bad(
                    format!("bodies[{i}].shape"),
                    format!("{:?}", b.shape),
                    "dimensions must be positive; a hull needs at least 4 vertices, a prism or a ring 3 sides, a ring an outer radius above its inner one",
                );
            }
            for k in 0..3 {
                if b.position[k] <= self.domain.min[k] || b.position[k] >= self.domain.max[k] {
                    return bad(
                        format!("bodies[{i}].position"),
                        format!("{:?}", b.position),
                        "must lie inside the domain",
                    );
                }
            }
            if !(0.0..=1.0).contains(&b.restitution) {
                return bad(
                    format!("bodies[{i}].restitution"),
                    b.restitution.to_string(),
                    "must lie in [0, 1]",
                );
            }
            if b.friction < 0.0 {
                return bad(
                    format!("bodies[{i}].friction"),
                    b.friction.to_string(),
                    "must be ≥ 0",
                );
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[meta]
name = "t"
[time]
end = 0.1
output_interval = 0.01
[domain]
min = [0, 0, 0]
max = [1, 1, 1]
[fluid]
density = 1000.0
kinematic_viscosity = 1e-6
sound_speed = 20.0
spacing = 0.05
blocks = [{ min = [0, 0, 0], max = [1, 0.5, 1] }]
"#;

    /// `fluid.background_pressure`: finite and ≥ 0, and refused with an open top (a free
    /// surface needs P = 0); a closed or a periodic-y domain takes it; the default is 0.
    #[test]
    fn background_pressure_needs_a_closed_domain() {
        let parse = |domain: &str, fluid: &str| {
            let text = MINIMAL
                .replace("max = [1, 1, 1]\n", &format!("max = [1, 1, 1]\n{domain}\n"))
                .replace("spacing = 0.05\n", &format!("spacing = 0.05\n{fluid}\n"));
            Scene::parse(&text, Path::new("t.toml"))
        };
        let field = |r: Result<Scene, SceneError>| match r {
            Err(SceneError::Invalid { field, .. }) => field,
            other => panic!("expected an invalid field, got {other:?}"),
        };
        assert_eq!(
            parse("", "").unwrap().fluid.unwrap().background_pressure,
            0.0
        );
        let closed = parse("closed_top = true", "background_pressure = 200.0").unwrap();
        assert_eq!(closed.fluid.unwrap().background_pressure, 200.0);
        assert_eq!(
            field(parse("", "background_pressure = 200.0")),
            "fluid.background_pressure"
        );
        assert_eq!(
            field(parse("closed_top = true", "background_pressure = -1.0")),
            "fluid.background_pressure"
        );
        let tg = "[gravity]\nvector = [0.0, 0.0, 0.0]";
        let periodic = MINIMAL
            .replace(
                "max = [1, 1, 1]\n",
                "max = [1, 1, 1]\nperiodic = [true, true, true]\n",
            )
            .replace("max = [1, 0.5, 1]", "max = [1, 1, 1]")
            .replace(
                "spacing = 0.05\n",
                "spacing = 0.05\nbackground_pressure = 50.0\n",
            );
        assert!(Scene::parse(&format!("{periodic}\n{tg}"), Path::new("t.toml")).is_ok());
    }

    /// Variable h: the ratio needs it and is ≥ 1; the one-h stages refuse it; the
    /// default ratio is RCP's ε^(−1/3).
    #[test]
    fn variable_smoothing_length_is_checked() {
        let parse = |fluid: &str, effects: &str| {
            let text = MINIMAL.replace("spacing = 0.05\n", &format!("spacing = 0.05\n{fluid}\n"));
            Scene::parse(
                &format!("{text}[effects]\n{effects}\n"),
                Path::new("t.toml"),
            )
        };
        let field = |r: Result<Scene, SceneError>| match r {
            Err(SceneError::Invalid { field, .. }) => field,
            other => panic!("expected an invalid field, got {other:?}"),
        };
        let on = "variable_smoothing_length = true";
        let s = parse("", on).unwrap();
        let f = s.fluid.as_ref().unwrap();
        assert_eq!(f.max_smoothing_ratio(), DEFAULT_MAX_SMOOTHING_RATIO);
        // ε^(−1/3) = 1.4 at ε = 0.364 (random close packing ≈ 0.36).
        assert!((1.4f64.powi(-3) - 0.364).abs() < 1e-3);
        assert_eq!(
            parse("max_smoothing_ratio = 1.2", on)
                .unwrap()
                .fluid
                .unwrap()
                .max_smoothing_ratio(),
            1.2
        );
        assert_eq!(
            field(parse("max_smoothing_ratio = 1.2", "")),
            "fluid.max_smoothing_ratio"
        );
        assert_eq!(
            field(parse("max_smoothing_ratio = 0.9", on)),
            "fluid.max_smoothing_ratio"
        );
        for one_h in [
            "laplacian_correction = true",
            "gradient_correction = true\nmass_correction = 2.0",
            "particle_shifting = 0.01",
            "density_diffusion = 0.1",
        ] {
            assert_eq!(
                field(parse("", &format!("{on}\n{one_h}"))),
                "effects.variable_smoothing_length",
                "{one_h}"
            );
        }
        assert!(parse("", &format!("{on}\ngradient_correction = true")).is_ok());
    }

    /// The ramp of `gravity.excess_weight_ramp` is r(x) = 10x³ − 15x⁴ + 6x⁵: r(½) = ½,
    /// r(¼) = 0.103515625 (exact in binary), 1 outside and without a ramp; a negative
    /// or infinite ramp is refused, one as long as the run is warned of.
    #[test]
    fn excess_weight_ramps_by_the_quintic_and_is_checked() {
        let g = GravitySpec {
            excess_weight_ramp: 0.004,
            ..GravitySpec::default()
        };
        assert_eq!(g.excess_weight_fraction(0.0), 0.0);
        assert!((g.excess_weight_fraction(0.001) - 0.103515625).abs() < 1e-15);
        assert!((g.excess_weight_fraction(0.002) - 0.5).abs() < 1e-15);
        assert_eq!(g.excess_weight_fraction(0.004), 1.0);
        assert_eq!(g.excess_weight_fraction(1.0), 1.0);
        assert_eq!(GravitySpec::default().excess_weight_fraction(0.0), 1.0);
        let with = |v: &str| {
            Scene::parse(
                &format!("{MINIMAL}\n[gravity]\nexcess_weight_ramp = {v}"),
                Path::new("t.toml"),
            )
        };
        for v in ["-1e-3", "inf"] {
            match with(v) {
                Err(SceneError::Invalid { field, .. }) => {
                    assert_eq!(field, "gravity.excess_weight_ramp", "{v}")
                }
                other => panic!("{v}: {other:?}"),
            }
        }
        let s = with("1e-3").unwrap();
        assert!(
            s.warnings()
                .iter()
                .all(|w| !w.contains("excess_weight_ramp"))
        );
        let long = format!("{}", s.time.end);
        let s = with(&long).unwrap();
        assert!(
            s.warnings()
                .iter()
                .any(|w| w.contains("excess_weight_ramp"))
        );
    }

    #[test]
    fn minimal_scene_parses_with_documented_defaults() {
        let s = Scene::parse(MINIMAL, Path::new("t.toml")).unwrap();
        let f = s.fluid.unwrap();
        assert_eq!(f.kernel, KernelKind::WendlandC2);
        // support 3 spacings with Wendland (radius 2h): h = 1.5 δ.
        assert!((f.smoothing_length() - 0.075).abs() < 1e-12);
        assert_eq!(s.gravity.vector, [0.0, -9.81, 0.0]);
    }

    /// The uncorrected scheme with a resolved body in a fluid that carries gravity is
    /// warned of (tests/tests/validation/buoyancy.rs measures why); the corrected scheme, or gravity
    /// on the solid only (Joubert eq. 28), or a body the fluid does not see, are not.
    #[test]
    fn uncorrected_hydrostatic_buoyancy_is_warned_of() {
        let body = "[[bodies]]\nname = \"b\"\nshape.sphere.radius = 0.1\ndensity = 1200.0\nposition = [0.5, 0.25, 0.5]\n";
        let warned = |extra: &str| {
            let text = format!("{MINIMAL}{extra}\n{body}");
            Scene::parse(&text, Path::new("t.toml"))
                .unwrap()
                .warnings()
                .len()
        };
        assert_eq!(warned(""), 1);
        assert_eq!(warned("[effects]\ngradient_correction = true"), 0);
        assert_eq!(warned("[gravity]\non_fluid = false"), 0);
        let unseen = format!("{MINIMAL}\n{body}coupling = \"none\"\n");
        assert!(
            Scene::parse(&unseen, Path::new("t.toml"))
                .unwrap()
                .warnings()
                .is_empty()
        );
    }

    /// Joubert's one-layer walls with a free surface are warned of: an open top, or a
    /// closed box the blocks fill only in part; a closed box filled to the lid (as the
    /// closed tank's Joubert-walled validation) is not.
    #[test]
    fn joubert_walls_with_a_free_surface_are_warned_of() {
        let warned = |domain: &str, top: &str| {
            let text = MINIMAL
                .replace(
                    "max = [1, 1, 1]\n",
                    &format!("max = [1, 1, 1]\nwall_model = \"joubert\"\n{domain}\n"),
                )
                .replace("max = [1, 0.5, 1]", &format!("max = [1, {top}, 1]"))
                + "[effects]\ngradient_correction = true\n";
            (Scene::parse(&text, Path::new("t.toml")).unwrap().warnings())
                .iter()
                .any(|w| w.contains("joubert") && w.contains("free surface"))
        };
        assert!(warned("", "1"), "open top");
        assert!(warned("closed_top = true", "0.5"), "closed, half filled");
        assert!(
            !warned("closed_top = true", "1"),
            "closed, filled to the lid"
        );
        // A Joubert-walled scene is warned of the wall mode unless its δ-SPH and α reach
        // one measured pair of JOUBERT_WALL_DAMPING.
        let mode = |effects: &str| {
            let text = MINIMAL
                .replace(
                    "max = [1, 1, 1]\n",
                    "max = [1, 1, 1]\nwall_model = \"joubert\"\nclosed_top = true\n",
                )
                .replace("max = [1, 0.5, 1]", "max = [1, 1, 1]")
                + "[effects]\ngradient_correction = true\n"
                + effects;
            (Scene::parse(&text, Path::new("t.toml")).unwrap().warnings())
                .iter()
                .any(|w| w.contains("joubert") && w.contains("eigenmode"))
        };
        assert!(mode(""), "no δ-SPH, no α");
        assert!(mode("density_diffusion = 0.2"), "δ-SPH 0.2 alone");
        assert!(mode("artificial_viscosity = 0.5"), "α 0.5 alone");
        assert!(
            mode("density_diffusion = 0.1\nartificial_viscosity = 0.2"),
            "δ-SPH 0.1, α 0.2"
        );
        assert!(
            !mode("density_diffusion = 0.2\nartificial_viscosity = 0.2"),
            "δ-SPH 0.2, α 0.2"
        );
        assert!(
            !mode("density_diffusion = 0.1\nartificial_viscosity = 0.5"),
            "δ-SPH 0.1, α 0.5"
        );
    }

    /// `[output]` defaults to no VTK and a body CSV; `--set output.vtk=true` creates the
    /// table the file leaves out, and a misspelt field under it is refused by name.
    #[test]
    fn output_section_defaults_and_overrides() {
        let s = Scene::parse(MINIMAL, Path::new("t.toml")).unwrap();
        assert!(!s.output.vtk && s.output.body_csv);
        let on = override_field(MINIMAL, Path::new("t.toml"), "output.vtk", "true").unwrap();
        let s = Scene::parse(&on, Path::new("t.toml")).unwrap();
        assert!(s.output.vtk && s.output.body_csv);
        let off = override_field(&on, Path::new("t.toml"), "output.body_csv", "false").unwrap();
        assert!(
            !Scene::parse(&off, Path::new("t.toml"))
                .unwrap()
                .output
                .body_csv
        );
        let typo = override_field(MINIMAL, Path::new("t.toml"), "output.vkt", "true").unwrap();
        match Scene::parse(&typo, Path::new("t.toml")) {
            Err(SceneError::Parse { message, .. }) => assert!(message.contains("vkt"), "{message}"),
            other => panic!("expected a parse error naming `vkt`, got {other:?}"),
        }
    }

    #[test]
    fn unknown_field_is_rejected_with_line() {
        let text = MINIMAL.replace("sound_speed = 20.0", "sound_speed = 20.0\nsoundspeed = 3");
        let e = Scene::parse(&text, Path::new("x.toml")).unwrap_err();
        match e {
            SceneError::Parse { line, message, .. } => {
                assert_eq!(line, 14, "{message}"); // line 14 of MINIMAL after the insertion
                assert!(message.contains("soundspeed"), "{message}");
            }
            other => panic!("{other}"),
        }
    }

    /// `[grain_lattices.perturbation]` moves each grain straight down by Robinson eq.
    /// (39), A (1 − cos kx)(1 − cos kz) (to 1e-15 m), never more than 4A, deepest at the
    /// cell centres nearest x = z = λ/2; a negative amplitude or a zero wavelength is
    /// refused.
    #[test]
    fn grain_lattice_perturbation_is_robinson_eq_39() {
        let text = |pert: &str| {
            format!(
                "{MINIMAL}[dem]\nengine = \"soft-sphere\"\n[dem.soft_sphere]\ncontact = \"linear\"\nstiffness = 1.0\n\
                 [[grain_lattices]]\nname = \"block\"\nmin = [0.0, 0.5, 0.0]\nmax = [0.8, 0.7, 0.8]\n\
                 radius = 0.05\ndensity = 2500.0\nporosity = 0.8\n{pert}\n"
            )
        };
        let plain = Scene::parse(&text(""), Path::new("t.toml")).unwrap();
        let (a, lambda) = (0.0125, 0.8);
        let s = Scene::parse(
            &text(&format!(
                "perturbation = {{ amplitude = {a}, wavelength = {lambda} }}"
            )),
            Path::new("t.toml"),
        )
        .unwrap();
        assert_eq!(s.bodies.len(), plain.bodies.len());
        let k = 2.0 * std::f64::consts::PI / lambda;
        for (b, p) in s.bodies.iter().zip(&plain.bodies) {
            let [x, y, z] = p.position;
            let expected = a * (1.0 - (k * x).cos()) * (1.0 - (k * z).cos());
            assert_eq!((b.position[0], b.position[2]), (x, z));
            assert!((y - b.position[1] - expected).abs() < 1e-15, "{x} {z}");
            assert!(expected >= 0.0 && expected <= 4.0 * a + 1e-15);
        }
        let deepest = (s.bodies.iter().zip(&plain.bodies))
            .map(|(b, p)| p.position[1] - b.position[1])
            .fold(0.0, f64::max);
        // The centres nearest the cell's middle, x = z = λ/2 = 0.4, are at 2.5 Δr = 0.3446
        // (Δr = 0.13783), the deepest grains.
        let c = 2.5 * s.grain_lattices[0].spacing();
        let near = a * (1.0 - (k * c).cos()).powi(2);
        assert!((deepest - near).abs() < 1e-4 * a, "{deepest} vs {near}");
        for bad in [
            "amplitude = -0.01, wavelength = 0.8",
            "amplitude = 0.01, wavelength = 0.0",
        ] {
            let e = Scene::parse(
                &text(&format!("perturbation = {{ {bad} }}")),
                Path::new("t.toml"),
            )
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
            assert!(e.contains("grain_lattices[0].perturbation"), "{bad}: {e}");
        }
    }

    /// `[[grain_lattices]]` expands into bodies on the lattice of Robinson §4: spacing
    /// Δr = (V/(1 − ε))^(1/3) (for r = 0.05 and ε = 0.8: 0.13783 m), the grains that fit
    /// the block, named `NAME[i]`, unresolved, in a translation group when rigid; a
    /// porosity outside (0, 1) and a translation group on rapier are refused.
    #[test]
    fn grain_lattices_expand_into_grains() {
        let lattice = |extra: &str| {
            format!(
                "{MINIMAL}[dem]\nengine = \"soft-sphere\"\n[dem.soft_sphere]\ncontact = \"linear\"\nstiffness = 1.0\n\
                 [[grain_lattices]]\nname = \"block\"\nmin = [0.1, 0.5, 0.1]\nmax = [0.9, 0.9, 0.9]\n\
                 radius = 0.05\ndensity = 2500.0\n{extra}\n"
            )
        };
        let s = Scene::parse(
            &lattice("porosity = 0.8\nrigid = true"),
            Path::new("t.toml"),
        )
        .unwrap();
        let dr = s.grain_lattices[0].spacing();
        let v = 4.0 / 3.0 * std::f64::consts::PI * 0.05f64.powi(3);
        assert!((dr - (v / 0.2f64).cbrt()).abs() < 1e-15 && (dr - 0.13783).abs() < 1e-5);
        // 0.8 / Δr = 5.8 cells across, 0.4 / Δr = 2.9 up: 5 × 2 × 5.
        assert_eq!(s.bodies.len(), 50);
        let b = &s.bodies[7];
        assert_eq!(b.name, "block[7]");
        assert_eq!(b.coupling, CouplingMode::Unresolved);
        assert_eq!(b.translation_group.as_deref(), Some("block"));
        assert!(
            (b.position[0] - (0.1 + 2.5 * dr)).abs() < 1e-12,
            "{:?}",
            b.position
        );
        assert!(
            (b.position[2] - (0.1 + 0.5 * dr)).abs() < 1e-12,
            "{:?}",
            b.position
        );
        let e = Scene::parse(&lattice("porosity = 1.0"), Path::new("t.toml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("grain_lattices[0].porosity"), "{e}");
        let e = Scene::parse(
            &lattice("porosity = 0.8\nrigid = true")
                .replace("\"soft-sphere\"", "\"rapier\"")
                .replace(
                    "[dem.soft_sphere]\ncontact = \"linear\"\nstiffness = 1.0\n",
                    "",
                ),
            Path::new("t.toml"),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(e.contains("translation_group"), "{e}");
    }

    /// The fluid sends the loads before it advances only where they cannot change over
    /// the window: the RTI's grains (Robinson's force at t_n), not the constant-porosity
    /// block's (`energy-pair`: a pressure force summed over the window's stages) nor a
    /// resolved body's (markers' tractions reduced over the window), nor a scene with
    /// nothing to load.
    #[test]
    fn loads_precede_the_advance_only_where_the_window_cannot_change_them() {
        let shipped = |name: &str| {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../scenes")
                .join(name);
            Scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        assert!(shipped("rayleigh-taylor.toml").loads_known_at_window_start());
        assert!(shipped("single-particle-sedimentation.toml").loads_known_at_window_start());
        let cpb = shipped("constant-porosity-block.toml");
        assert!(cpb.exchanges_loads() && !cpb.loads_known_at_window_start());
        let sphere = shipped("settling-sphere.toml");
        assert!(sphere.exchanges_loads() && !sphere.loads_known_at_window_start());
        assert!(!shipped("lid-driven-cavity.toml").loads_known_at_window_start());
    }

    /// Unresolved grains: spheres, dynamic, in a scene with a fluid; the drag law
    /// defaults to Di Felice, the coupling to two-way; porosity 1 and one-way coupling
    /// are warned of.
    #[test]
    fn unresolved_grains_are_checked() {
        let grain = |shape: &str, extra: &str| {
            format!(
                "[[bodies]]\nname = \"g\"\n{shape}\ndensity = 2500.0\nposition = [0.5, 0.25, 0.5]\ncoupling = \"unresolved\"\n{extra}\n"
            )
        };
        let err = |text: String| {
            Scene::parse(&text, Path::new("t.toml"))
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        let s = Scene::parse(
            &format!("{MINIMAL}{}", grain("shape.sphere.radius = 0.01", "")),
            Path::new("t.toml"),
        )
        .unwrap();
        assert_eq!(s.coupling.drag, DragLawName::DiFelice);
        assert_eq!(s.grains(), vec![0]);
        assert!(s.exchanges_loads() && !s.has_resolved_bodies());
        assert!(s.loads_known_at_window_start());
        assert!(s.coupling.two_way, "two-way by default");
        assert!(s.warnings().iter().any(|w| w.contains("variable h")));
        assert!(!s.warnings().iter().any(|w| w.contains("two_way")));
        let one_way = Scene::parse(
            &format!("{MINIMAL}{}", grain("shape.sphere.radius = 0.01", ""))
                .replace("[fluid]", "[coupling]\ntwo_way = false\n\n[fluid]"),
            Path::new("t.toml"),
        )
        .unwrap();
        assert!(!one_way.coupling.two_way);
        assert_eq!(s.coupling.porosity_pressure, PorosityPressure::Robinson);
        let pair = |effects: &str| {
            Scene::parse(
                &format!("{MINIMAL}{}", grain("shape.sphere.radius = 0.01", "")).replace(
                    "[fluid]",
                    &format!("[coupling]\nporosity_pressure = \"energy-pair\"\n{effects}\n[fluid]"),
                ),
                Path::new("t.toml"),
            )
            .unwrap()
        };
        let plain = pair("");
        assert_eq!(
            plain.coupling.porosity_pressure,
            PorosityPressure::EnergyPair
        );
        assert!(!plain.warnings().iter().any(|w| w.contains("energy-pair")));
        let corrected = pair("[effects]\ngradient_correction = true\n");
        assert!(
            (corrected.warnings().iter()).any(|w| w.contains("energy-pair")),
            "{:?}",
            corrected.warnings()
        );
        let closed = |text: String| {
            text.replace("max = [1, 1, 1]\n", "max = [1, 1, 1]\nclosed_top = true\n")
                .replace(
                    "spacing = 0.05\n",
                    "spacing = 0.05\nbackground_pressure = 200.0\n",
                )
        };
        let level = Scene::parse(
            &closed(
                format!("{MINIMAL}{}", grain("shape.sphere.radius = 0.01", "")).replace(
                    "[fluid]",
                    "[coupling]\nporosity_pressure = \"energy-pair\"\n[fluid]",
                ),
            ),
            Path::new("t.toml"),
        )
        .unwrap();
        assert!(
            (level.warnings().iter()).any(|w| w.contains("background_pressure")),
            "{:?}",
            level.warnings()
        );
        assert!(
            one_way
                .warnings()
                .iter()
                .any(|w| w.contains("two_way = false"))
        );
        let e = err(format!(
            "{MINIMAL}{}",
            grain("shape.box.half_extents = [0.01, 0.01, 0.01]", "")
        ));
        assert!(
            e.contains("bodies[0].coupling") && e.contains("spheres"),
            "{e}"
        );
        let e = err(format!(
            "{MINIMAL}{}",
            grain("shape.sphere.radius = 0.01", "motion = \"fixed\"")
        ));
        assert!(e.contains("dynamic"), "{e}");
        let dry = MINIMAL[..MINIMAL.find("[fluid]").unwrap()].to_owned();
        let e = err(format!("{dry}{}", grain("shape.sphere.radius = 0.01", "")));
        assert!(e.contains("needs a [fluid]"), "{e}");
    }

    #[test]
    fn invalid_value_names_field() {
        let text = MINIMAL.replace("spacing = 0.05", "spacing = -0.05");
        let e = Scene::parse(&text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("fluid.spacing") && e.contains("-0.05"), "{e}");
    }

    #[test]
    fn overrides_replace_a_field_and_are_checked() {
        let text = override_field(MINIMAL, Path::new("t.toml"), "fluid.spacing", "0.1").unwrap();
        let s = Scene::parse(&text, Path::new("t.toml")).unwrap();
        assert_eq!(s.fluid.unwrap().spacing, 0.1);
        let text = override_field(MINIMAL, Path::new("t.toml"), "time.end", "2").unwrap();
        assert!(
            matches!(Scene::parse(&text, Path::new("t.toml")).unwrap().time.end, e if e == 2.0)
        );
        // A table the file leaves out is created; a misspelt one is refused by the parse.
        let text = override_field(
            MINIMAL,
            Path::new("t.toml"),
            "effects.particle_shifting",
            "0.05",
        )
        .unwrap();
        assert_eq!(
            Scene::parse(&text, Path::new("t.toml"))
                .unwrap()
                .effects
                .particle_shifting,
            0.05
        );
        let text = override_field(MINIMAL, Path::new("t.toml"), "nope.x", "1").unwrap();
        let e = Scene::parse(&text, Path::new("t.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope"), "{e}");
        let e = override_field(MINIMAL, Path::new("t.toml"), "bodies.0.density", "1")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bodies.0.density") && e.contains("no `bodies`"),
            "{e}"
        );
        let text = override_field(
            MINIMAL,
            Path::new("t.toml"),
            "fluid.blocks.0.max",
            "[1, 0.25, 1]",
        )
        .unwrap();
        assert_eq!(
            Scene::parse(&text, Path::new("t.toml"))
                .unwrap()
                .fluid
                .unwrap()
                .blocks[0]
                .max,
            [1.0, 0.25, 1.0]
        );
        assert!(override_field(MINIMAL, Path::new("t.toml"), "fluid.blocks.3.max", "1").is_err());
        // An override is checked like the file: a typo is rejected when parsed.
        let text = override_field(MINIMAL, Path::new("t.toml"), "fluid.spacingg", "1").unwrap();
        assert!(Scene::parse(&text, Path::new("t.toml")).is_err());
    }

    #[test]
    fn body_shapes_parse() {
        let text = format!(
            "{MINIMAL}\n[[bodies]]\nname = \"s\"\nshape.sphere.radius = 0.1\ndensity = 1200.0\nposition = [0.5, 0.7, 0.5]\n\
             [[bodies]]\nname = \"b\"\nshape.box.half_extents = [0.1, 0.1, 0.1]\ndensity = 500.0\nposition = [0.2, 0.7, 0.2]\nmotion = \"fixed\"\n"
        );
        let s = Scene::parse(&text, Path::new("x.toml")).unwrap();
        assert!(matches!(s.bodies[0].shape, Shape::Sphere { radius } if radius == 0.1));
        assert_eq!(s.bodies[1].motion, Motion::Fixed);
        assert!(s.has_moving_bodies());
    }

    /// Periodic axes, the lid and the Taylor–Green initial flow are refused, each naming
    /// its field, when they contradict the rest of the scene; valid ones parse.
    #[test]
    fn periodic_lid_and_initial_flow_are_checked() {
        let with = |domain: &str, extra: &str| {
            let text =
                MINIMAL.replace("max = [1, 1, 1]\n", &format!("max = [1, 1, 1]\n{domain}\n"));
            Scene::parse(&format!("{text}\n{extra}"), Path::new("t.toml"))
        };
        let field = |r: Result<Scene, SceneError>| match r {
            Err(SceneError::Invalid { field, .. }) => field,
            other => panic!("expected an invalid field, got {other:?}"),
        };
        let ok = with("periodic = [true, false, true]", "").unwrap();
        assert_eq!(ok.domain.periodic, [true, false, true]);
        assert_eq!(
            field(with(
                "periodic = [false, true, false]\nclosed_top = true",
                ""
            )),
            "domain.closed_top"
        );
        // Spacing 0.05 does not tile a period of 1.03.
        let seam = MINIMAL.replace(
            "max = [1, 1, 1]\n",
            "max = [1.03, 1, 1]\nperiodic = [true, false, false]\n",
        );
        assert_eq!(
            field(Scene::parse(&seam, Path::new("t.toml"))),
            "domain.periodic[0]"
        );
        assert_eq!(
            field(with("lid_velocity = [1.0, 0.0, 0.0]", "")),
            "domain.lid_velocity"
        );
        assert_eq!(
            field(with(
                "closed_top = true\nlid_velocity = [1.0, 0.5, 0.0]",
                ""
            )),
            "domain.lid_velocity"
        );
        assert!(with("closed_top = true\nlid_velocity = [1.0, 0.0, 0.0]", "").is_ok());
        let tg = "[fluid.initial_flow]\nkind = \"taylor-green\"\nvelocity = 1.0\nwavelength = 0.5\n[gravity]\nvector = [0.0, 0.0, 0.0]";
        let s = with("periodic = [true, true, false]", tg).unwrap();
        assert_eq!(
            s.fluid.unwrap().initial_flow,
            Some(InitialFlow::TaylorGreen {
                velocity: 1.0,
                wavelength: 0.5
            })
        );
        assert_eq!(
            field(with("periodic = [true, false, false]", tg)),
            "fluid.initial_flow"
        );
    }

    /// The free-surface switch follows the domain's top unless the scene says, and is
    /// refused without the correction it switches off.
    #[test]
    fn free_surface_switch_follows_the_open_top() {
        let parse = |extra: &str| {
            let text = format!("{MINIMAL}\n{extra}");
            Scene::parse(&text, Path::new("t.toml"))
        };
        let open = parse("[effects]\ngradient_correction = true").unwrap();
        assert!(!open.domain.closed_top && open.free_surface_switch());
        let closed = override_field(
            &format!("{MINIMAL}\n[effects]\ngradient_correction = true"),
            Path::new("t.toml"),
            "domain.closed_top",
            "true",
        )
        .unwrap();
        let closed = Scene::parse(&closed, Path::new("t.toml")).unwrap();
        assert!(!closed.free_surface_switch());
        let off = parse("[effects]\ngradient_correction = true\nfree_surface = false").unwrap();
        assert!(!off.free_surface_switch());
        assert!(!parse("").unwrap().free_surface_switch());
        match parse("[effects]\nfree_surface = true") {
            Err(SceneError::Invalid { field, .. }) => assert_eq!(field, "effects.free_surface"),
            other => panic!("expected effects.free_surface refused, got {other:?}"),
        }
    }

    /// The mass correction's Γ is refused below Joubert's 1 and without the gradient
    /// correction it builds on, naming the field; a valid one parses.
    #[test]
    fn mass_correction_is_checked() {
        let with = |effects: &str| {
            let mut text = MINIMAL.to_string();
            for kv in effects.split('\n') {
                let (k, v) = kv.split_once(" = ").unwrap();
                text =
                    override_field(&text, Path::new("t.toml"), &format!("effects.{k}"), v).unwrap();
            }
            Scene::parse(&text, Path::new("t.toml"))
        };
        let field = |r: Result<Scene, SceneError>| match r {
            Err(SceneError::Invalid { field, .. }) => field,
            other => panic!("expected an invalid field, got {other:?}"),
        };
        let ok = with("gradient_correction = true\nmass_correction = 2").unwrap();
        assert_eq!(ok.effects.mass_correction, 2.0);
        assert_eq!(
            field(with("gradient_correction = true\nmass_correction = 0.5")),
            "effects.mass_correction"
        );
        assert_eq!(
            field(with("mass_correction = 2")),
            "effects.mass_correction"
        );
    }

    /// Joubert's one-layer walls are refused without the gradient correction they rely
    /// on, and symmetry planes without those walls, on a periodic axis or on the lid,
    /// each naming its field; a valid combination parses.
    #[test]
    fn wall_model_and_symmetry_planes_are_checked() {
        let with = |domain: &str, effects: &str| {
            let text =
                MINIMAL.replace("max = [1, 1, 1]\n", &format!("max = [1, 1, 1]\n{domain}\n"));
            Scene::parse(
                &format!("{text}\n[effects]\n{effects}"),
                Path::new("t.toml"),
            )
        };
        let field = |r: Result<Scene, SceneError>| match r {
            Err(SceneError::Invalid { field, .. }) => field,
            other => panic!("expected an invalid field, got {other:?}"),
        };
        let joubert = "wall_model = \"joubert\"";
        let gc = "gradient_correction = true";
        let ok = with(&format!("{joubert}\nsymmetry = [false, false, true]"), gc).unwrap();
        assert_eq!(ok.domain.wall_model, WallModel::Joubert);
        assert_eq!(ok.domain.symmetry, [false, false, true]);
        assert_eq!(field(with(joubert, "")), "domain.wall_model");
        // Adami's walls take symmetry planes too (the fluid's velocity mirrored, ARCHITECTURE.md).
        let adami = with("symmetry = [true, false, false]", "").unwrap();
        assert_eq!(adami.domain.wall_model, WallModel::Adami);
        assert_eq!(adami.domain.symmetry, [true, false, false]);
        assert_eq!(
            field(with(
                "periodic = [true, false, false]\nsymmetry = [true, false, false]",
                ""
            )),
            "domain.symmetry[0]"
        );
        assert_eq!(
            field(with(
                &format!(
                    "{joubert}\nperiodic = [true, false, false]\nsymmetry = [true, false, false]"
                ),
                gc
            )),
            "domain.symmetry[0]"
        );
        assert_eq!(
            field(with(
                &format!(
                    "{joubert}\nclosed_top = true\nlid_velocity = [1.0, 0.0, 0.0]\nsymmetry = [false, true, false]"
                ),
                gc
            )),
            "domain.symmetry[1]"
        );
        // Resolved bodies take eq. (25) at their markers; fixed box obstacles are refused.
        let sphere = include_str!("../../scenes/settling-sphere.toml")
            .replace("[domain]\n", "[domain]\nwall_model = \"joubert\"\n");
        let s = Scene::parse(&sphere, Path::new("sphere.toml")).unwrap();
        assert!(s.has_resolved_bodies());
        let dam = include_str!("../../scenes/spheric2-dam-break.toml")
            .replace("[domain]\n", "[domain]\nwall_model = \"joubert\"\n")
            .replace("[effects]\n", "[effects]\ngradient_correction = true\n");
        assert_eq!(
            field(Scene::parse(&dam, Path::new("dam.toml"))),
            "domain.wall_model"
        );
    }
}
