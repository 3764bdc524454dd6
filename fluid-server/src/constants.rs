//! The scene-fixed numbers of the SPH scheme ([`SphConstants`]) and the per-window
//! uniform ([`StepParams`]): written once here, generated into WGSL, so the Rust twins
//! and the kernels cannot drift apart (STYLE.md, "one source of truth").

use crate::error::FluidError;
use crate::gpu::Gpu;
use crate::kernel::SmoothingKernel;
use crate::neighbour_grid::{GRID_REACH_CPU, TEAM_LANES_GPU, grid_reach_wgsl, team_lanes_wgsl};
use couplet_protocol::{
    DensityDiffusionForm, KernelKind, PorosityPressure, Scene, ViscosityModel, WallKind, WallModel,
};

/// Scene-fixed parameters of the standard WCSPH scheme, in SI units (`f64`; the WGSL
/// constants are the same numbers rounded to `f32`).
#[derive(Debug, Clone, PartialEq)]
pub struct SphConstants {
    pub kernel: SmoothingKernel,
    /// Initial particle spacing δ, m.
    pub spacing: f64,
    /// Reference density ρ0, kg/m³.
    pub rho0: f64,
    /// Numerical speed of sound c_s, m/s.
    pub sound_speed: f64,
    /// Tait exponent γ.
    pub gamma: f64,
    /// Background pressure P_b, Pa (`fluid.background_pressure`): the EOS's pressure at
    /// ρ0, added to Joubert eq. (4).
    pub background_pressure: f64,
    /// Kinematic viscosity ν, m²/s.
    pub nu: f64,
    /// Lattice mass m = ρ0 δ³, kg: every wall and marker particle's, and a fluid
    /// particle's where the porosity is 1 (particles carry their own, `ParticleSet::mass`,
    /// `pos.w` on the GPU).
    pub mass: f64,
    /// Gravity acting on the fluid, m/s² (zero when `gravity.on_fluid = false`). The
    /// kernels read it from [`StepParams::gravity`], so that it can change during a run
    /// ([`crate::solver::FluidSolver::set_gravity`]).
    pub gravity_fluid: [f64; 3],
    /// `gravity.on_fluid`: a change of gravity during the run reaches the fluid.
    pub gravity_on_fluid: bool,
    /// Morris (1997) laminar viscosity stage on.
    pub laminar: bool,
    /// Monaghan (1992) artificial viscosity α (0: stage off).
    pub alpha: f64,
    /// Walls take part in the viscous sums: Adami no-slip walls (free-slip ones do not
    /// enter them), and every one-layer Joubert boundary particle (no-slip ones with
    /// their own velocity, symmetry ones with the fluid's by eq. 27).
    pub no_slip_walls: bool,
    /// Axes whose faces are symmetry planes of Adami's walls (`domain.symmetry` with
    /// `wall_model = "adami"`): their wall particles enter the viscous sums with the
    /// fluid's velocity mirrored across the plane, except those also behind a no-slip
    /// face (an edge between a wall and a symmetry plane belongs to the wall, as with
    /// Joubert's walls). See [`Self::symmetry_mirror`]. All false with Joubert's walls,
    /// whose symmetry planes take eq. (27) instead.
    pub adami_symmetry: [bool; 3],
    /// The neighbour grid's reach R (`GRID_REACH` in WGSL): cells of at least
    /// [`Self::grid_radius`]/R, pair loops over (2R + 1)² rows. [`GRID_REACH_CPU`]
    /// from the scene; the solver sets the device's with [`Self::for_adapter`]. A pair kernel
    /// must be built with the reach of the grid it is bound to, or it misses neighbours:
    /// kernels built outside the solver take `FluidSolver::constants`.
    pub grid_reach: u32,
    /// Lanes per item of the team passes (`TEAM_LANES` in WGSL, `neighbour_grid::
    /// TEAM_LANES_GPU`): [`TEAM_LANES_GPU`] from the scene; the solver sets the device's
    /// (`Gpu::team_lanes`) with [`Self::for_adapter`]. A team pass must be dispatched with
    /// `team_threads(n, team_lanes)` of the constants it was compiled with.
    pub team_lanes: u32,
    /// Lanes per fluid particle of the dense team passes (`DENSE_LANES` in WGSL, the
    /// fused rates): 1 from the scene; the solver sets the device's for its particle
    /// count (`Gpu::dense_lanes`). A dense pass must be dispatched with
    /// `team_threads(n, dense_lanes)` of the constants it was compiled with.
    pub dense_lanes: u32,
    /// No-slip walls enter the viscous sums with the velocity 2 v_w − ṽ_w (Adami, Hu &
    /// Adams 2012, §2.3): ṽ_w the Shepard interpolation of the fluid's velocity at the
    /// wall particle, v_w the wall's own (0, or the lid's). The fluid then sees the
    /// no-slip condition on the wall face rather than on the first wall layer half a
    /// spacing behind it (measured: a start-up Poiseuille profile 17 % off with walls
    /// at their own velocity). On whenever no-slip Adami walls meet a viscous term
    /// (Joubert's one-layer walls sit on the face: no extrapolation).
    pub wall_velocity_extrapolation: bool,
    /// The faces fluid must stay inside, per axis `[low, high]`, relative to the solver
    /// origin (the domain centre, where the GPU's positions are measured from): a wall
    /// face's plane, or ∓∞ on a periodic axis and above an open top. The
    /// non-penetration pass mirrors fluid back across them (see
    /// [`crate::body_non_penetration`]).
    pub wall_faces: [[f64; 2]; 3],
    /// The period per axis, m (the domain's extent on a periodic axis, 0 elsewhere), for
    /// the CPU twins' nearest images ([`Self::pair_vec`]); the kernels take theirs from
    /// the grid (`grid_common.wgsl`'s `pair_vec`).
    pub period: [f64; 3],
    /// `domain.wall_model = "joubert"`: one layer of boundary particles on the faces,
    /// their pressure from the Neumann condition of Joubert eq. (25) and, on symmetry
    /// planes, their velocity from eq. (27) ([`crate::joubert2020_boundary_values`]).
    pub joubert_walls: bool,
    /// Kernel-gradient correction (Joubert eq. 10) on: the gradient pass runs and the
    /// pressure term takes the corrected difference form (eq. 13), and so does the
    /// continuity term (eq. 12) unless [`Self::corrected_continuity`] says otherwise.
    pub gradient_correction: bool,
    /// Continuity in Joubert's corrected difference form (eq. 12): with the gradient
    /// correction, except among unresolved grains. There the density is superficial
    /// and jumps with the porosity at a block's faces, and only the standard form
    /// `Σ m_j u_ij·∇W_ij` (Robinson eq. 10 at fixed h) is the exact time derivative of
    /// the summation density, so that the fluid's volume stays tied to where its
    /// particles are. Measured (CPB quick, 2026-11-24): with the corrected form the
    /// closed column's pressure rose 190 Pa in 19 ms, as if the grains' swept volume
    /// compressed the fluid instead of displacing it; the return flow through the block
    /// was 40 % of continuity's and the block fell 16 % fast. With the standard form the
    /// floor pressure only takes up the block's weight (+11 Pa).
    pub corrected_continuity: bool,
    /// The gradient correction's free-surface switch (`effects.free_surface`,
    /// [`couplet_protocol::Scene::free_surface_switch`]): a particle whose truncation
    /// matrix has det M < [`crate::joubert2020_gradients::free_surface_det`] takes the
    /// standard continuity and pressure terms instead of the corrected ones.
    pub free_surface: bool,
    /// The fraction of a complete support's det M below which the switch takes a
    /// particle: [`crate::joubert2020_gradients::FREE_SURFACE_FRACTION`], not a scene
    /// field (a field here so that the linearised rates can be read at others, as
    /// `fluid-server/tests/linear_acoustics.rs` reads 0.75).
    pub free_surface_fraction: f64,
    /// Corrected Laplacian (Joubert eqs. 11, 13) in the viscous term: the gradient pass
    /// solves B̂_i, the rates use it (only with laminar viscosity).
    pub laplacian_correction: bool,
    /// Mass correction smoothing factor Γ of Joubert eq. (14); 0: off. Needs the
    /// gradient correction; the gradient pass then also solves B̂_i (eq. 15's stencil).
    pub mass_correction: f64,
    /// Particle shifting decrowding factor β (Joubert eq. 17); 0: off.
    pub shifting_beta: f64,
    /// δ-SPH density diffusion coefficient δ (Antuono et al. 2010); 0: off.
    pub density_diffusion: f64,
    /// Which δ-SPH term (`effects.density_diffusion_form`): Antuono's renormalised
    /// gradients, or Fourtakas et al. 2019's hydrostatic difference.
    pub density_diffusion_form: DensityDiffusionForm,
    /// The scene has unresolved grains: their sampling reads du/dt after a sort, so
    /// the grid permutes `dvel` with the particles.
    pub grains: bool,
    /// Unresolved grains push back on the fluid (`coupling.two_way`, Robinson eqs.
    /// 26–27): the reaction buffer and its kernels exist.
    pub grain_reaction: bool,
    /// `coupling.porosity_pressure = "energy-pair"` among unresolved grains: the fluid's
    /// pressure term takes P ε and adds (P/ρ) ∇ε (the gradient summed beside the solid
    /// fraction), each grain gets the exact opposite of that term, and only the drag is
    /// spread back ([`crate::porosity`], [`crate::unresolved_coupling`]).
    pub porosity_pair: bool,
    /// `effects.variable_smoothing_length`: `Some(largest h / h)` (Robinson eq. 19,
    /// `fluid.max_smoothing_ratio`), `None` for one h. See [`crate::robinson_variable_h`].
    pub variable_h: Option<f64>,
}

/// Three face coordinates as WGSL f32 literals, ±∞ as ±1e30 (WGSL has no infinity, and
/// a constant expression that overflows f32 is a shader compile error).
fn wgsl_faces(v: [f64; 3]) -> String {
    v.map(|x| format!("{:e}", x.clamp(-1e30, 1e30))).join(", ")
}

/// `η² = 0.01 h²` in the Morris (1997) and Monaghan (1992) denominators `r² + η²`: keeps
/// them finite for coincident particles (Monaghan 1992, eq. 4.2).
pub const VISCOUS_ETA2_H2: f64 = 0.01;

/// Lower bound of `1 + γ p/(ρ0 c²)` when the Tait equation is inverted for a wall
/// density: a wall whose extrapolated pressure is below the EOS's −ρ0c²/γ (possible
/// only for a nearly empty support) gets a tiny positive density instead of NaN.
pub const MIN_TAIT_BASE: f64 = 1e-3;

/// Below this |e| = |ρ − ρ0|/ρ0 the GPU evaluates the Tait pressure as the series
/// Σ C(γ, k) e^k instead of `pow(ρ/ρ0, γ) − 1`. Near ρ0 the difference of the power and
/// 1 cancels: on NVIDIA (pow as exp2(γ log2 x), division to 2.5 ulp, as Vulkan allows)
/// it left pressure errors of a few 1e-6 B, 13 Pa at c = 200 m/s, against 0.5 ulp of
/// ρ on lavapipe (measured 2026-11-26, `neumann_marker_pressure_includes_the_body_acceleration`).
/// At |e| < 1/8 twelve terms leave a remainder below |C(γ, 13)| 8⁻¹² ≈ 1e-11 of e for
/// γ ≤ 7 (none for an integer γ ≤ 12); beyond it the power no longer cancels.
pub const TAIT_SERIES_LIMIT: f64 = 0.125;
/// Terms of that series.
pub const TAIT_SERIES_TERMS: usize = 12;

/// [`SphConstants::wall_faces`] of `d`: its half extents about its centre, ∓∞ where
/// no wall stands (a periodic axis; +y without `closed_top`).
fn wall_faces(d: &couplet_protocol::scene::Domain) -> [[f64; 2]; 3] {
    std::array::from_fn(|k| {
        let half = 0.5 * (d.max[k] - d.min[k]);
        let top_open = k == 1 && !d.closed_top;
        match (d.periodic[k], top_open) {
            (true, _) => [f64::NEG_INFINITY, f64::INFINITY],
            (false, true) => [-half, f64::INFINITY],
            (false, false) => [-half, half],
        }
    })
}

impl SphConstants {
    pub fn from_scene(scene: &Scene) -> Result<Self, FluidError> {
        let f = scene.fluid.as_ref().ok_or(FluidError::NoFluid)?;
        let kernel = SmoothingKernel::new(f.kernel, f.smoothing_length());
        let g = if scene.gravity.on_fluid {
            scene.gravity.vector
        } else {
            [0.0; 3]
        };
        let joubert_walls = scene.domain.wall_model == WallModel::Joubert;
        Ok(Self {
            kernel,
            spacing: f.spacing,
            rho0: f.density,
            sound_speed: f.sound_speed,
            gamma: f.gamma,
            background_pressure: f.background_pressure,
            nu: f.kinematic_viscosity,
            mass: f.density * f.spacing.powi(3),
            gravity_fluid: g,
            gravity_on_fluid: scene.gravity.on_fluid,
            laminar: scene.effects.viscosity == ViscosityModel::Laminar
                && f.kinematic_viscosity > 0.0,
            alpha: scene.effects.artificial_viscosity,
            no_slip_walls: scene.domain.walls == WallKind::NoSlip || joubert_walls,
            adami_symmetry: std::array::from_fn(|k| {
                !joubert_walls && !scene.domain.periodic[k] && scene.domain.symmetry[k]
            }),
            grid_reach: GRID_REACH_CPU,
            team_lanes: TEAM_LANES_GPU,
            dense_lanes: 1,
            wall_velocity_extrapolation: scene.domain.walls == WallKind::NoSlip
                && !joubert_walls
                && ((scene.effects.viscosity == ViscosityModel::Laminar
                    && f.kinematic_viscosity > 0.0)
                    || scene.effects.artificial_viscosity > 0.0),
            wall_faces: wall_faces(&scene.domain),
            period: std::array::from_fn(|k| {
                let d = &scene.domain;
                if d.periodic[k] {
                    d.max[k] - d.min[k]
                } else {
                    0.0
                }
            }),
            joubert_walls,
            gradient_correction: scene.effects.gradient_correction,
            corrected_continuity: scene.effects.gradient_correction && scene.grains().is_empty(),
            free_surface: scene.free_surface_switch(),
            free_surface_fraction: crate::joubert2020_gradients::FREE_SURFACE_FRACTION,
            laplacian_correction: scene.effects.laplacian_correction
                && scene.effects.viscosity == ViscosityModel::Laminar
                && f.kinematic_viscosity > 0.0,
            mass_correction: scene.effects.mass_correction,
            shifting_beta: scene.effects.particle_shifting,
            density_diffusion: scene.effects.density_diffusion,
            density_diffusion_form: scene.effects.density_diffusion_form,
            grains: !scene.grains().is_empty(),
            grain_reaction: scene.coupling.two_way && !scene.grains().is_empty(),
            porosity_pair: scene.coupling.porosity_pressure == PorosityPressure::EnergyPair
                && !scene.grains().is_empty(),
            variable_h: scene
                .effects
                .variable_smoothing_length
                .then(|| f.max_smoothing_ratio()),
        })
    }

    /// Tait stiffness B = ρ0 c²/γ, Pa (Joubert eq. 4).
    pub fn tait_b(&self) -> f64 {
        self.rho0 * self.sound_speed * self.sound_speed / self.gamma
    }

    /// Joubert eq. (4), plus the background pressure.
    pub fn pressure(&self, rho: f64) -> f64 {
        self.tait_b() * ((rho / self.rho0).powf(self.gamma) - 1.0) + self.background_pressure
    }

    /// The binomial coefficients C(γ, k), k = 1 … [`TAIT_SERIES_TERMS`], of
    /// (1 + e)^γ − 1 = Σ C(γ, k) e^k: the GPU's Tait pressure for |e| below
    /// [`TAIT_SERIES_LIMIT`] (`tait_eos.wgsl`).
    pub fn tait_series(&self) -> [f64; TAIT_SERIES_TERMS] {
        let mut c = [0.0; TAIT_SERIES_TERMS];
        let mut ck = 1.0;
        for (k, slot) in c.iter_mut().enumerate() {
            ck *= (self.gamma - k as f64) / (k as f64 + 1.0);
            *slot = ck;
        }
        c
    }

    /// Joubert eq. (4) inverted (wall and marker densities, the initial state).
    pub fn density(&self, p: f64) -> f64 {
        self.rho0
            * (1.0 + (p - self.background_pressure) / self.tait_b())
                .max(MIN_TAIT_BASE)
                .powf(1.0 / self.gamma)
    }

    /// Some axis has a wall face ([`Self::wall_faces`]): fluid is kept inside it
    /// ([`crate::body_non_penetration`]).
    pub fn has_wall_face(&self) -> bool {
        self.wall_faces.iter().flatten().any(|f| f.is_finite())
    }

    /// The per-step gradient pass ([`crate::joubert2020_gradients`]) runs: it feeds
    /// the gradient and Laplacian corrections, particle shifting and δ-SPH.
    pub fn gradient_pass(&self) -> bool {
        self.gradient_correction
            || self.uses_b_hat()
            || self.shifting_beta > 0.0
            || self.antuono_diffusion()
    }

    /// δ-SPH with Antuono's renormalised density gradients: the gradient pass writes ∇ρ.
    pub fn antuono_diffusion(&self) -> bool {
        self.density_diffusion > 0.0 && self.density_diffusion_form == DensityDiffusionForm::Antuono
    }

    /// The rates pass reads the gradient pass's fields: ∇ρ for Antuono's δ-SPH, ∇p for
    /// the mass correction (Joubert eqs. 15–16).
    pub fn rates_read_gradients(&self) -> bool {
        self.antuono_diffusion() || self.mass_correction > 0.0
    }

    /// `a − b` as the nearest image on the periodic axes ([`Self::period`]): the CPU twin
    /// of `pair_vec` in `grid_common.wgsl`, in f64.
    pub fn pair_vec(&self, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        crate::particles::nearest_image(a, b, self.period)
    }

    /// The axes across which a wall particle at `x` (relative to the solver origin, as
    /// [`Self::wall_faces`]) mirrors the fluid's velocity: those of the symmetry planes
    /// of Adami's walls it stands behind, none if it also stands behind a no-slip face
    /// (the edge belongs to the wall) or behind no face (fixed box obstacles). CPU twin
    /// of `symmetry_mirror` in `adami2012_boundary_pressure.wgsl`.
    pub fn symmetry_mirror(&self, x: [f64; 3]) -> [bool; 3] {
        let behind: [bool; 3] =
            std::array::from_fn(|k| x[k] < self.wall_faces[k][0] || x[k] > self.wall_faces[k][1]);
        let held = (0..3).any(|k| behind[k] && !self.adami_symmetry[k]);
        std::array::from_fn(|k| !held && behind[k] && self.adami_symmetry[k])
    }

    /// The rates read B_i (the gradient correction, or the corrected Laplacian's
    /// gradient term).
    pub fn uses_b_matrix(&self) -> bool {
        self.gradient_correction || self.laplacian_correction
    }

    /// The gradient pass solves the Laplacian truncation B̂_i (Joubert eq. 11): for the
    /// corrected viscous term and for the compact pressure Laplacian of eq. (15).
    pub fn uses_b_hat(&self) -> bool {
        self.laplacian_correction || self.mass_correction > 0.0
    }

    /// Support radius, m.
    pub fn support_radius(&self) -> f64 {
        self.kernel.radius()
    }

    /// The kernel of Adami's wall extrapolation: the scene's, or with variable h that of
    /// the largest h allowed. The wall layers are as thick as the largest support
    /// ([`crate::particles::wall_layers`]); at the scene's h the outer ones would have no
    /// fluid within reach and keep p = 0, which a fluid particle with a larger h sees.
    pub fn wall_kernel(&self) -> SmoothingKernel {
        match self.variable_h {
            Some(ratio) => SmoothingKernel::new(self.kernel.kind, self.kernel.h * ratio),
            None => self.kernel,
        }
    }

    /// The neighbour grid's reach, m: the support radius, or with variable h that of
    /// the largest h allowed.
    pub fn grid_radius(&self) -> f64 {
        self.support_radius() * self.variable_h.unwrap_or(1.0)
    }

    /// These constants with the grid reach of `gpu` (`Gpu::grid_reach`: its adapter's, or
    /// `COUPLET_GRID_REACH`'s) and its team lanes (`Gpu::team_lanes`).
    pub fn for_adapter(mut self, gpu: &Gpu) -> SphConstants {
        self.grid_reach = gpu.grid_reach();
        self.team_lanes = gpu.team_lanes;
        self
    }

    /// The WGSL constant block every SPH module starts with (after the prelude).
    pub fn wgsl(&self) -> String {
        let k = &self.kernel;
        let r = k.radius();
        format!(
            "// ---- SPH constants (generated by constants.rs from the scene) ----\n\
             const KERNEL_QUINTIC: bool = {quintic};\n\
             const H: f32 = {h:e};\n\
             const INV_H: f32 = {inv_h:e};\n\
             const SIGMA: f32 = {sigma:e};\n\
             const SUPPORT_RADIUS2: f32 = {r2:e};\n\
             const SPACING: f32 = {dx:e};\n\
             const RHO0: f32 = {rho0:e};\n\
             const LATTICE_MASS: f32 = {lattice_mass:e};\n\
             const SOUND_SPEED: f32 = {c:e};\n\
             const GAMMA: f32 = {gamma:e};\n\
             const TAIT_B: f32 = {b:e};\n\
             const BACKGROUND_PRESSURE: f32 = {p_b:e};\n\
             const MIN_TAIT_BASE: f32 = {min_base:e};\n\
             const TAIT_SERIES_LIMIT: f32 = {series_limit:e};\n\
             const TAIT_SERIES_TERMS: i32 = {series_n};\n\
             const TAIT_SERIES: array<f32, {series_n}> = array<f32, {series_n}>({series});\n\
             const NU: f32 = {nu:e};\n\
             const LAMINAR_VISCOSITY: bool = {laminar};\n\
             const ARTIFICIAL_VISCOSITY: bool = {av};\n\
             const ALPHA: f32 = {alpha:e};\n\
             const NO_SLIP_WALLS: bool = {no_slip};\n\
             const ADAMI_SYMMETRY: vec3<bool> = vec3<bool>({adami_symmetry});\n\
             {grid_reach}\
             {team_lanes}\
             const VISCOUS_ETA2: f32 = {eta2:e};\n\
             const GRADIENT_CORRECTION: bool = {correction};\n\
             const CORRECTED_CONTINUITY: bool = {corrected_continuity};\n\
             const FREE_SURFACE_SWITCH: bool = {free_surface};\n\
             const LAPLACIAN_CORRECTION: bool = {laplacian};\n\
             const MASS_CORRECTION: bool = {mass_correction};\n\
             const B_HAT_SOLVE: bool = {b_hat};\n\
             const MASS_CORRECTION_GAMMA: f32 = {gamma_mc:e};\n\
             const SHIFTING_BETA: f32 = {beta:e};\n\
             const DENSITY_DIFFUSION: bool = {diffusion};\n\
             const DIFFUSION_DELTA: f32 = {delta:e};\n\
             const DIFFUSION_FOURTAKAS: bool = {fourtakas};\n\
             const VARIABLE_H: bool = {variable_h};\n\
             const POROSITY_PAIR: bool = {porosity_pair};\n\
             const MAX_H: f32 = {max_h:e};\n\
             const WALL_LO: vec3<f32> = vec3<f32>({wall_lo});\n\
             const WALL_HI: vec3<f32> = vec3<f32>({wall_hi});\n\
             // ---- end of SPH constants ----\n",
            quintic = k.kind == KernelKind::Quintic,
            h = k.h,
            inv_h = 1.0 / k.h,
            sigma = k.sigma,
            r2 = r * r,
            dx = self.spacing,
            rho0 = self.rho0,
            lattice_mass = self.mass,
            c = self.sound_speed,
            gamma = self.gamma,
            b = self.tait_b(),
            p_b = self.background_pressure,
            min_base = MIN_TAIT_BASE,
            series_limit = TAIT_SERIES_LIMIT,
            series_n = TAIT_SERIES_TERMS,
            series = self
                .tait_series()
                .iter()
                .map(|c| format!("{c:e}"))
                .collect::<Vec<_>>()
                .join(", "),
            nu = self.nu,
            laminar = self.laminar,
            av = self.alpha > 0.0,
            alpha = self.alpha,
            no_slip = self.no_slip_walls,
            adami_symmetry = self.adami_symmetry.map(|b| b.to_string()).join(", "),
            grid_reach = grid_reach_wgsl(self.grid_reach),
            team_lanes = team_lanes_wgsl(self.team_lanes),
            eta2 = VISCOUS_ETA2_H2 * k.h * k.h,
            correction = self.gradient_correction,
            corrected_continuity = self.corrected_continuity,
            free_surface = self.free_surface,
            laplacian = self.laplacian_correction,
            mass_correction = self.mass_correction > 0.0,
            b_hat = self.uses_b_hat(),
            gamma_mc = self.mass_correction,
            beta = self.shifting_beta,
            diffusion = self.density_diffusion > 0.0,
            delta = self.density_diffusion,
            fourtakas = self.density_diffusion_form == DensityDiffusionForm::Fourtakas,
            variable_h = self.variable_h.is_some(),
            porosity_pair = self.porosity_pair,
            max_h = k.h * self.variable_h.unwrap_or(1.0),
            wall_lo = wgsl_faces(self.wall_faces.map(|f| f[0])),
            wall_hi = wgsl_faces(self.wall_faces.map(|f| f[1])),
        )
    }
}

/// Per-window uniform of every SPH kernel (group 3, binding 0). Particle kinds are id
/// ranges: `[0, n_fluid)` fluid, `[n_fluid, n_fluid + n_wall)` wall, then markers.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct StepParams {
    pub n_total: u32,
    pub n_fluid: u32,
    pub n_wall: u32,
    pub n_markers: u32,
    /// Substep Δt, s.
    pub dt: f32,
    /// Weight of one load evaluation in the window average: 1/(2 · substeps) (two
    /// evaluations per predictor–corrector step).
    pub load_weight: f32,
    /// Bodies with markers (contiguous marker ranges).
    pub n_load_bodies: u32,
    /// Acceleration of one count of the fixed-point grain reaction, m/s²
    /// ([`crate::unresolved_coupling`]); chosen per window so that no sum overflows.
    pub reaction_unit: f32,
    /// Gravity on the fluid, m/s² (xyz): [`SphConstants::gravity_fluid`], a uniform
    /// rather than a WGSL constant so that a live run can change it. w is 1, a factor the
    /// shader compiler cannot see (`opaque_one()`): multiplied into the integrator's
    /// compensated sums, it keeps them from being simplified away as (a + b) − a = b.
    pub gravity: [f32; 4],
}

/// WGSL mirror of [`StepParams`]; keep in the same order (size checked below and by
/// wgpu's minimum binding size at bind time).
pub const STEP_PARAMS_WGSL: &str = "struct StepParams {
    n_total: u32,
    n_fluid: u32,
    n_wall: u32,
    n_markers: u32,
    dt: f32,
    load_weight: f32,
    n_load_bodies: u32,
    reaction_unit: f32,
    gravity: vec4<f32>,
}
@group(3) @binding(0) var<uniform> params: StepParams;
fn is_fluid(id: u32) -> bool { return id < params.n_fluid; }
fn is_wall(id: u32) -> bool { return id >= params.n_fluid && id < params.n_fluid + params.n_wall; }
fn is_marker(id: u32) -> bool { return id >= params.n_fluid + params.n_wall; }
fn marker_index(id: u32) -> u32 { return id - params.n_fluid - params.n_wall; }
// 1 at run time, unknown to the compiler (StepParams::gravity_of).
fn opaque_one() -> f32 { return params.gravity.w; }
";

const _: () = assert!(core::mem::size_of::<StepParams>() == 48);

impl StepParams {
    /// The gravity field in the uniform's layout (w: the opaque 1).
    pub fn gravity_of(g: [f64; 3]) -> [f32; 4] {
        [g[0] as f32, g[1] as f32, g[2] as f32, 1.0]
    }

    pub fn marker_base(&self) -> u32 {
        self.n_fluid + self.n_wall
    }
}
