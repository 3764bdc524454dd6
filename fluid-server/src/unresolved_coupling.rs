//! The fluid's force on unresolved grains (issue 5; Robinson §3.3), a team of threads per
//! grain: Shepard-corrected interpolation of the fluid velocity (Robinson eq. 8) and of
//! the resolved force `V (−∇P + ∇·τ)` (eqs. 23–25) from the fluid particles within the
//! support, then the drag of the scene's law on the slip at the grain's porosity
//! ([`crate::drag`]). WGSL: `shaders/unresolved_coupling.wgsl`; this file holds its
//! CPU twin.
//!
//! θ_b, particle b's SPH acceleration without gravity and without the grains' reaction,
//! is `dvel − g_fluid − reaction` as the last rate evaluation left it: the force is
//! sampled at a window boundary, after a step. With gravity on the fluid the
//! hydrostatic part of θ is −g, so `V ρ θ̄` carries the buoyancy −ρ V g.
//!
//! Two-way coupling (`coupling.two_way`, Robinson eqs. 26–27): after the sampling,
//! `spread_grain_reaction` (`shaders/grain_reaction.wgsl`) gives each fluid particle a
//! within a grain's support the acceleration −f_j W_aj/(S_j ρ_a), with S_j the grain's
//! Shepard sum, so that Σ_a m a_a = −Σ_j f_j; `add_grain_reaction` adds it to du/dt in
//! every rate evaluation of the window. The sums are 64-bit fixed point, exact and
//! independent of thread order; [`reaction_unit`] sets their unit. CPU twin:
//! [`grain_reaction_cpu`].
//!
//! With `coupling.porosity_pressure = "energy-pair"` the pressure is exchanged as the
//! energy-conserving pair instead (ARCHITECTURE.md): the fluid's rates hold
//! (P_a/ρ_a) ∇ε_a ([`crate::porosity`], `fluid_rates.wgsl`), `sample_grains` leaves
//! V ρθ̄ out (so only the drag is spread back), and `grain_pressure_force`
//! (`shaders/grain_pressure.wgsl`, twin [`grain_pressure_force_cpu`]) sums each grain's
//! exact opposite after every rate evaluation of the window, which
//! [`GrainCoupling::add_pressure_forces`] adds to the loads sent after it.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::drag::{DRAG_WGSL, DragInput, DragLaw, drag_force, law_constants_wgsl};
use crate::error::FluidError;
use crate::gpu::{Gpu, GpuError};
use crate::kernel::KERNEL_WGSL;
use crate::neighbour_grid::{GRID_COMMON_WGSL, team_threads};
use crate::particles::{Kind, ParticleSet};
use crate::porosity::{GrainPorosity, PorosityField, Solid, solid_fraction_kernel};
use crate::solver::{Op, SphData, missing};
use crate::sph_kernel::{Access, BODIES, PARAMS, PARTICLES, SphKernel, particle_binding as pb};
use crate::timing::{self, StageTimer};
use couplet_protocol::{BodyLoad, BodyState, Scene, Shape};
use wgpu::util::DeviceExt;

pub const UNRESOLVED_COUPLING_WGSL: &str = include_str!("../shaders/unresolved_coupling.wgsl");
pub const GRAIN_REACTION_WGSL: &str = include_str!("../shaders/grain_reaction.wgsl");
pub const GRAIN_REACTION_READ_WGSL: &str = include_str!("../shaders/grain_reaction_read.wgsl");
pub const GRAIN_REACTION_ADD_WGSL: &str = include_str!("../shaders/grain_reaction_add.wgsl");
pub const GRAIN_PRESSURE_WGSL: &str = include_str!("../shaders/grain_pressure.wgsl");
/// One-way: no reaction buffer, nothing to subtract from θ.
const NO_GRAIN_REACTION_WGSL: &str = "fn grain_reaction(i: u32) -> vec3<f32> {
    return vec3<f32>(0.0);
}
";

/// The bound of [`reaction_unit`] in counts, 2^33: the WGSL is exact below 2^38, and
/// the bound assumes the intrinsic density ρ/ε ≥ ρ_min, so among grains the superficial
/// ρ may sit ε below it; 2^5 of headroom covers ε down to 1/32, far below a packed
/// bed's. Resolution: 2^-33 of the bound.
const REACTION_COUNTS: f64 = 8_589_934_592.0;

/// Grain arrays in the bodies group (2), numbered after the marker bindings.
pub mod grain_binding {
    pub const POS: u32 = 7;
    pub const VEL: u32 = 8;
    pub const POROSITY: u32 = 9;
    pub const SAMPLE: u32 = 10;
    /// Uniform vec4: x the time since the window's start, s (the solid fraction moves
    /// the grains by v τ).
    pub const TAU: u32 = 11;
    /// Per grain vec4: the window's weighted sum of the `energy-pair` pressure force.
    pub const PRESSURE: u32 = 12;
}

/// One grain as the fluid sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grain {
    /// Centre, relative to the solver origin, m.
    pub position: [f64; 3],
    pub velocity: [f64; 3],
    /// Solid volume V, m³.
    pub volume: f64,
    pub diameter: f64,
    /// Porosity ε at the grain (1 for a lone grain).
    pub porosity: f64,
}

/// What the fluid gives one grain.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GrainSample {
    /// Shepard-interpolated fluid velocity u_f (Robinson eq. 8), m/s.
    pub fluid_velocity: [f64; 3],
    /// Shepard denominator Σ V_b W: 1 inside the fluid, less near a free surface or a
    /// wall, 0 with no fluid in reach (then every force is 0).
    pub shepard: f64,
    /// `V (−∇P + ∇·τ)` at the grain, Robinson eqs. (23)–(25), N; 0 with
    /// `coupling.porosity_pressure = "energy-pair"`, whose pressure force comes from the
    /// window instead ([`grain_pressure_force_cpu`]).
    pub resolved: [f64; 3],
    /// Drag of the scene's law, N.
    pub drag: [f64; 3],
}

impl GrainSample {
    /// The fluid's whole force on the grain, Robinson eq. (23), N.
    pub fn force(&self) -> [f64; 3] {
        std::array::from_fn(|k| self.resolved[k] + self.drag[k])
    }
}

/// Compiles `sample_grains` for the scene's constants, drag law and viscosity.
pub fn kernel(
    gpu: &Gpu,
    c: &SphConstants,
    law: DragLaw,
    grid_layout: &wgpu::BindGroupLayout,
) -> SphKernel {
    let consts = c.wgsl();
    let coupling = format!(
        "{}const DRAG_LAW: u32 = {}u;\nconst FLUID_MU: f32 = {:e};\n",
        law_constants_wgsl(),
        law.code(),
        c.rho0 * c.nu
    );
    let mut particles = vec![
        (pb::POS, Access::Read),
        (pb::VEL, Access::Read),
        (pb::RHO, Access::Read),
        (pb::ID, Access::Read),
        (pb::DVEL, Access::Read),
    ];
    let reaction = if c.grain_reaction {
        particles.extend([
            (pb::REACTION_LO, Access::Read),
            (pb::REACTION_HI, Access::Read),
        ]);
        GRAIN_REACTION_READ_WGSL
    } else {
        NO_GRAIN_REACTION_WGSL
    };
    SphKernel::new(
        gpu,
        "sph: sample_grains",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            KERNEL_WGSL,
            &coupling,
            DRAG_WGSL,
            reaction,
            UNRESOLVED_COUPLING_WGSL,
        ],
        "sample_grains",
        &[
            (PARTICLES, &particles),
            (
                BODIES,
                &[
                    (grain_binding::POS, Access::Read),
                    (grain_binding::VEL, Access::Read),
                    (grain_binding::POROSITY, Access::Read),
                    (grain_binding::SAMPLE, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// Compiles `spread_grain_reaction` (Robinson eqs. 26–27, at a window's start).
pub fn spread_kernel(
    gpu: &Gpu,
    c: &SphConstants,
    grid_layout: &wgpu::BindGroupLayout,
) -> SphKernel {
    SphKernel::new(
        gpu,
        "sph: spread_grain_reaction",
        &[
            &c.wgsl(),
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            KERNEL_WGSL,
            GRAIN_REACTION_WGSL,
        ],
        "spread_grain_reaction",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::Read),
                    (pb::RHO, Access::Read),
                    (pb::ID, Access::Read),
                    (pb::REACTION_LO, Access::ReadWrite),
                    (pb::REACTION_HI, Access::ReadWrite),
                ],
            ),
            (
                BODIES,
                &[
                    (grain_binding::POS, Access::Read),
                    (grain_binding::SAMPLE, Access::Read),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// Compiles `add_grain_reaction` (after each `fluid_rates`).
pub fn add_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    SphKernel::new(
        gpu,
        "sph: add_grain_reaction",
        &[
            &c.wgsl(),
            STEP_PARAMS_WGSL,
            GRAIN_REACTION_READ_WGSL,
            GRAIN_REACTION_ADD_WGSL,
        ],
        "add_grain_reaction",
        &[
            (
                PARTICLES,
                &[
                    (pb::ID, Access::Read),
                    (pb::DVEL, Access::ReadWrite),
                    (pb::REACTION_LO, Access::Read),
                    (pb::REACTION_HI, Access::Read),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        None,
    )
}

/// Compiles `grain_pressure_force` (`coupling.porosity_pressure = "energy-pair"`, after
/// each `fluid_rates`).
pub fn pressure_kernel(
    gpu: &Gpu,
    c: &SphConstants,
    grid_layout: &wgpu::BindGroupLayout,
) -> SphKernel {
    SphKernel::new(
        gpu,
        "sph: grain_pressure_force",
        &[
            &c.wgsl(),
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            KERNEL_WGSL,
            GRAIN_PRESSURE_WGSL,
        ],
        "grain_pressure_force",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::Read),
                    (pb::RHO, Access::Read),
                    (pb::PRESS, Access::Read),
                    (pb::ID, Access::Read),
                ],
            ),
            (
                BODIES,
                &[
                    (grain_binding::POS, Access::Read),
                    (grain_binding::VEL, Access::Read),
                    (grain_binding::TAU, Access::Uniform),
                    (grain_binding::PRESSURE, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// CPU twin of one `grain_pressure_force` (load weight 1, grains where `grains` has
/// them): f_j = −V_j Σ_a (m_a/ρ_a) P_a ∇_j W_ja over the fluid entries of `set`, all
/// pairs (to the nearest image on a periodic axis, as the GPU). Opposite, summed over j, to Σ_a m_a (P_a/ρ_a) ∇ε_a with ∇ε from
/// [`crate::porosity::PorosityField::gradient`].
pub fn grain_pressure_force_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    grains: &[Grain],
) -> Vec<[f64; 3]> {
    let r2max = c.support_radius().powi(2);
    (grains.iter())
        .map(|g| {
            let mut sum = [0.0; 3];
            for a in (0..set.len()).filter(|a| set.kinds.kind(set.id[*a]) == Kind::Fluid) {
                let r = c.pair_vec(g.position, set.pos[a]);
                let r2 = r.iter().map(|x| x * x).sum::<f64>();
                if r2 >= r2max {
                    continue;
                }
                let f = set.mass[a] / set.rho[a] * set.press[a] * c.kernel.grad_factor(r2.sqrt());
                for k in 0..3 {
                    sum[k] += f * r[k];
                }
            }
            sum.map(|x| -g.volume * x)
        })
        .collect()
}

/// The fixed-point unit of the window's reaction sums, m/s² per count: no fluid
/// particle's sum can exceed `W(0) Σ_j |f_j|∞ / (S_j ρ_min)` per component, with ρ_min the
/// lowest intrinsic density the blow-up check lets through; that bound is
/// [`REACTION_COUNTS`]. A window without force gets unit 1 (every count is then 0).
pub fn reaction_unit(c: &SphConstants, samples: &[GrainSample]) -> f64 {
    let rho_min = c.rho0 * (1.0 - crate::blowup_check::BLOWUP_DENSITY_DEVIATION);
    let bound: f64 = (samples.iter())
        .filter(|s| s.shepard > 0.0)
        .map(|s| s.force().iter().fold(0.0f64, |m, f| m.max(f.abs())) / s.shepard)
        .sum::<f64>()
        * c.kernel.w(0.0)
        / rho_min;
    if bound > 0.0 && bound.is_finite() {
        // The unit is an f32 on the GPU: never below the smallest normal one (a larger
        // unit only coarsens forces some 10^-38 m/s² small).
        (bound / REACTION_COUNTS).max(f64::from(f32::MIN_POSITIVE))
    } else {
        1.0
    }
}

/// CPU twin of `spread_grain_reaction` + `grain_reaction_read`: the grains' reaction on
/// every entry of `set` as an acceleration (zero for non-fluid entries), Robinson eqs.
/// (26)–(27), exact sums over all pairs (to the nearest image on a periodic axis);
/// `samples` as [`sample_grains_cpu`] gives them.
pub fn grain_reaction_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    grains: &[Grain],
    samples: &[GrainSample],
) -> Vec<[f64; 3]> {
    let r2max = c.support_radius().powi(2);
    let mut acc = vec![[0.0; 3]; set.len()];
    for (g, s) in grains.iter().zip(samples) {
        if s.shepard == 0.0 {
            continue;
        }
        let f = s.force();
        for a in (0..set.len()).filter(|a| set.kinds.kind(set.id[*a]) == Kind::Fluid) {
            let r = c.pair_vec(g.position, set.pos[a]);
            let r2: f64 = r.iter().map(|x| x * x).sum();
            if r2 >= r2max {
                continue;
            }
            let w = c.kernel.w(r2.sqrt());
            for k in 0..3 {
                acc[a][k] -= w / (s.shepard * set.rho[a]) * f[k];
            }
        }
    }
    acc
}

/// The grains' reaction buffers (64-bit fixed point, two words per component).
pub struct ReactionBuffers {
    pub lo: wgpu::Buffer,
    pub hi: wgpu::Buffer,
}

/// The grains as the buffers hold them: (position, V), (velocity, d) and ε.
#[allow(clippy::type_complexity)]
fn pack(grains: &[Grain]) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<f32>) {
    let f = |x: f64| x as f32;
    let pos = (grains.iter())
        .map(|g| g.position.map(f))
        .zip(grains)
        .map(|(p, g)| [p[0], p[1], p[2], f(g.volume)])
        .collect();
    let vel = (grains.iter())
        .map(|g| {
            [
                f(g.velocity[0]),
                f(g.velocity[1]),
                f(g.velocity[2]),
                f(g.diameter),
            ]
        })
        .collect();
    let eps = grains.iter().map(|g| f(g.porosity)).collect();
    (pos, vel, eps)
}

/// The grain buffers of group 2.
pub struct GrainBuffers {
    pub pos: wgpu::Buffer,
    pub vel: wgpu::Buffer,
    pub porosity: wgpu::Buffer,
    pub sample: wgpu::Buffer,
    pub tau: wgpu::Buffer,
    /// τ of each step of one submission, one vec4 a slot
    /// (`gpu::MAX_STEPS_PER_SUBMIT`): `queue.write_buffer` lands before a submission's
    /// commands, so a submission of several steps writes each step's τ to its own slot
    /// and copies it into `tau` in the command stream, before the step's passes.
    pub tau_slots: wgpu::Buffer,
    /// The `energy-pair` pressure force's window sum, one vec4 per grain (exact size:
    /// its length is the grain count the kernel sees).
    pub pressure: wgpu::Buffer,
    pub count: u32,
}

impl GrainBuffers {
    /// Uploads `grains` (positions already relative to the solver origin).
    pub fn new(gpu: &Gpu, grains: &[Grain]) -> GrainBuffers {
        let init = |label: &str, bytes: &[u8], extra: wgpu::BufferUsages| {
            let mut contents = bytes.to_vec();
            contents.resize(contents.len().max(16), 0);
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &contents,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
                })
        };
        let (pos, vel, eps) = pack(grains);
        let zeros = vec![0u8; 48 * grains.len()];
        GrainBuffers {
            pos: init(
                "grain pos",
                bytemuck::cast_slice(&pos),
                wgpu::BufferUsages::empty(),
            ),
            vel: init(
                "grain vel",
                bytemuck::cast_slice(&vel),
                wgpu::BufferUsages::empty(),
            ),
            // The porosity array's length is the grain count the kernel sees: exact size.
            porosity: gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("grain porosity"),
                    contents: bytemuck::cast_slice(&eps),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                }),
            sample: init("grain sample", &zeros, wgpu::BufferUsages::COPY_SRC),
            tau: gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("grain tau"),
                    contents: &[0u8; 16],
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                }),
            tau_slots: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("grain tau slots"),
                size: 16 * u64::from(crate::gpu::MAX_STEPS_PER_SUBMIT),
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            pressure: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("grain pressure force"),
                size: 16 * grains.len().max(1) as u64,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            count: grains.len() as u32,
        }
    }

    /// The buffer bound at `binding` of group 2.
    pub fn binding(&self, binding: u32) -> Option<&wgpu::Buffer> {
        match binding {
            grain_binding::POS => Some(&self.pos),
            grain_binding::VEL => Some(&self.vel),
            grain_binding::POROSITY => Some(&self.porosity),
            grain_binding::SAMPLE => Some(&self.sample),
            grain_binding::TAU => Some(&self.tau),
            grain_binding::PRESSURE => Some(&self.pressure),
            _ => None,
        }
    }

    /// Replaces the grains' data (the same count as at creation).
    pub fn write(&self, gpu: &Gpu, grains: &[Grain]) {
        assert_eq!(grains.len(), self.count as usize, "grain count is fixed");
        let (pos, vel, eps) = pack(grains);
        gpu.queue
            .write_buffer(&self.pos, 0, bytemuck::cast_slice(&pos));
        gpu.queue
            .write_buffer(&self.vel, 0, bytemuck::cast_slice(&vel));
        gpu.queue
            .write_buffer(&self.porosity, 0, bytemuck::cast_slice(&eps));
    }

    /// Reads the `energy-pair` pressure forces' window sums back, in grain order, N.
    pub fn read_pressure(&self, gpu: &Gpu) -> Result<Vec<[f64; 3]>, GpuError> {
        let s: Vec<[f32; 4]> = gpu.read_buffer(&self.pressure, 0, u64::from(self.count))?;
        Ok(s.iter()
            .map(|a| [0, 1, 2].map(|k| f64::from(a[k])))
            .collect())
    }

    /// Reads the samples back, in grain order.
    pub fn read(&self, gpu: &Gpu) -> Result<Vec<GrainSample>, GpuError> {
        let s: Vec<[f32; 4]> = gpu.read_buffer(&self.sample, 0, 3 * u64::from(self.count))?;
        let v = |a: [f32; 4]| [0, 1, 2].map(|k| f64::from(a[k]));
        Ok((0..self.count as usize)
            .map(|g| GrainSample {
                fluid_velocity: v(s[3 * g]),
                shepard: f64::from(s[3 * g][3]),
                resolved: v(s[3 * g + 1]),
                drag: v(s[3 * g + 2]),
            })
            .collect())
    }
}

/// CPU twin of `sample_grains`: the same sums over every fluid particle of `set` (all
/// pairs, to the nearest image on a periodic axis), with `dvel` the particles' rates (`SphData::read_rates`, same
/// order as `set`).
pub fn sample_grains_cpu(
    c: &SphConstants,
    law: DragLaw,
    set: &ParticleSet,
    dvel: &[[f64; 3]],
    grains: &[Grain],
) -> Vec<GrainSample> {
    let r2max = c.support_radius().powi(2);
    let g_fluid = c.gravity_fluid;
    grains
        .iter()
        .map(|g| {
            let (mut s, mut u, mut t) = (0.0, [0.0; 3], [0.0; 3]);
            for b in (0..set.len()).filter(|b| set.kinds.kind(set.id[*b]) == Kind::Fluid) {
                let r = c.pair_vec(g.position, set.pos[b]);
                let r2 = r.iter().map(|x| x * x).sum::<f64>();
                if r2 >= r2max {
                    continue;
                }
                let w = c.kernel.w(r2.sqrt());
                let vw = set.mass[b] / set.rho[b] * w;
                s += vw;
                for k in 0..3 {
                    u[k] += vw * set.vel[b][k];
                    // Robinson eq. (24).
                    t[k] += set.mass[b] * w * (dvel[b][k] - g_fluid[k]);
                }
            }
            if s == 0.0 {
                return GrainSample::default();
            }
            let u_f = u.map(|x| x / s);
            let drag = drag_force(
                law,
                &DragInput {
                    porosity: g.porosity,
                    diameter: g.diameter,
                    density: c.rho0,
                    viscosity: c.rho0 * c.nu,
                    slip: std::array::from_fn(|k| u_f[k] - g.velocity[k]),
                },
            );
            GrainSample {
                fluid_velocity: u_f,
                shepard: s,
                resolved: if c.porosity_pair {
                    [0.0; 3]
                } else {
                    t.map(|x| g.volume * x / s)
                },
                drag,
            }
        })
        .collect()
}

/// The grains of a scene as the fluid server couples them each window: their body
/// indices and diameters, the compiled kernel and its buffers.
pub struct GrainCoupling {
    kernel: SphKernel,
    /// `grain_solid_fraction` (Robinson eq. 9 at the fluid particles).
    solid: SphKernel,
    /// Robinson eq. (9) at the grains, on the CPU, from neighbour lists kept across
    /// windows (behind a lock: [`GrainCoupling::sample`] takes `&self`).
    porosity: std::sync::Mutex<GrainPorosity>,
    /// `spread_grain_reaction`, with `coupling.two_way`.
    spread: Option<SphKernel>,
    /// `grain_pressure_force`, with `coupling.porosity_pressure = "energy-pair"`.
    pressure: Option<SphKernel>,
    buffers: GrainBuffers,
    bodies: Vec<u32>,
    diameters: Vec<f64>,
    /// The lanes per grain the team passes above were compiled with
    /// (`SphConstants::team_lanes`), which their dispatches must match.
    team_lanes: u32,
}

impl GrainCoupling {
    /// `None` when the scene has no unresolved grain.
    pub fn new(
        gpu: &Gpu,
        c: &SphConstants,
        scene: &Scene,
        grid_layout: &wgpu::BindGroupLayout,
    ) -> Option<GrainCoupling> {
        let bodies = scene.grains();
        if bodies.is_empty() {
            return None;
        }
        let diameters: Vec<f64> = (bodies.iter())
            .map(|&i| match scene.bodies[i].shape {
                Shape::Sphere { radius } => 2.0 * radius,
                // Scene::check refuses non-spherical grains.
                _ => unreachable!("grain {i} is not a sphere"),
            })
            .collect();
        let grains: Vec<Grain> = (diameters.iter())
            .map(|d| Grain {
                position: [0.0; 3],
                velocity: [0.0; 3],
                volume: 0.0,
                diameter: *d,
                porosity: 1.0,
            })
            .collect();
        Some(GrainCoupling {
            kernel: kernel(gpu, c, scene.coupling.drag.into(), grid_layout),
            solid: solid_fraction_kernel(gpu, c, grid_layout),
            porosity: std::sync::Mutex::new(GrainPorosity::new(PorosityField::of_scene(c, scene))),
            spread: c.grain_reaction.then(|| spread_kernel(gpu, c, grid_layout)),
            pressure: c
                .porosity_pair
                .then(|| pressure_kernel(gpu, c, grid_layout)),
            buffers: GrainBuffers::new(gpu, &grains),
            bodies: bodies.into_iter().map(|i| i as u32).collect(),
            diameters,
            team_lanes: c.team_lanes,
        })
    }

    /// The fluid's force on every grain at the bodies' `states` (world frame; `origin`
    /// is the solver's), as one load per grain, zero moment (a sphere's drag has none at
    /// its centre), and the samples they came from. The particles are sorted first, so
    /// that the grid is exact. The porosity of Robinson eq. (9) is set at the grains (on
    /// the CPU, for their drag) and at the fluid particles (on the GPU, for the EOS of
    /// the window, Robinson eq. 15, whose pressures are recomputed at once). With a
    /// `timer` (`couplet bench`) each of its GPU stages is timed, the timer finished
    /// before the submission; its `collect` is the caller's.
    pub fn sample(
        &self,
        gpu: &Gpu,
        data: &SphData,
        origin: [f64; 3],
        states: &[BodyState],
        mut timer: Option<&mut StageTimer>,
    ) -> Result<(Vec<BodyLoad>, Vec<GrainSample>), FluidError> {
        let solids: Vec<Solid> = (self.bodies.iter())
            .map(|&b| Solid {
                position: states[b as usize].position,
                volume: states[b as usize].volume,
            })
            .collect();
        let porosity = (self.porosity.lock())
            .unwrap_or_else(|e| e.into_inner())
            .porosity(&solids);
        if let Some((i, &e)) = (porosity.iter().enumerate()).find(|(_, e)| !(**e > 0.0)) {
            return Err(FluidError::Porosity {
                at: format!(
                    "grain body {} at {:?} m",
                    self.bodies[i], solids[i].position
                ),
                porosity: e,
            });
        }
        let grains: Vec<Grain> = (self.bodies.iter().zip(&self.diameters).zip(&porosity))
            .map(|((&b, &d), &e)| {
                let s = &states[b as usize];
                Grain {
                    position: std::array::from_fn(|k| s.position[k] - origin[k]),
                    velocity: s.linear_velocity,
                    volume: s.volume,
                    diameter: d,
                    porosity: e,
                }
            })
            .collect();
        self.buffers.write(gpu, &grains);
        let bound = self
            .kernel
            .bind(
                gpu,
                |g, b| match g {
                    PARTICLES => match b {
                        pb::POS => Some(&data.pos),
                        pb::VEL => Some(&data.vel),
                        pb::RHO => Some(&data.rho),
                        pb::ID => Some(&data.id),
                        pb::DVEL => Some(&data.dvel),
                        pb::REACTION_LO => data.reaction.as_ref().map(|r| &r.lo),
                        pb::REACTION_HI => data.reaction.as_ref().map(|r| &r.hi),
                        _ => None,
                    },
                    BODIES => self.buffers.binding(b),
                    PARAMS => Some(&data.params),
                    _ => None,
                },
                Some(data.grid.bind_group()),
            )
            .ok_or_else(|| missing("sample_grains"))?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        data.queue_op(gpu, &mut encoder, timer.as_deref_mut(), Op::Sort);
        {
            let mut pass = timing::begin_pass(
                timer.as_deref_mut(),
                gpu,
                &mut encoder,
                "sph: sample_grains",
            );
            bound.dispatch(&mut pass, team_threads(self.buffers.count, self.team_lanes));
        }
        self.queue_solid_fraction(gpu, &mut encoder, timer.as_deref_mut(), data, 0.0, 0)?;
        // The window's pressures at the new porosity (Robinson eq. 15).
        data.queue_op(gpu, &mut encoder, timer.as_deref_mut(), Op::TaitEos);
        // energy-pair: the window's pressure force starts from 0.
        encoder.clear_buffer(&self.buffers.pressure, 0, None);
        if let Some(t) = timer {
            t.finish(gpu, &mut encoder);
        }
        gpu.queue.submit([encoder.finish()]);
        let samples = self.buffers.read(gpu)?;
        let loads = (self.bodies.iter().zip(&samples))
            .map(|(&body, s)| BodyLoad {
                force: s.force(),
                body,
                _pad: 0,
                moment: [0.0; 3],
            })
            .collect();
        Ok((loads, samples))
    }

    /// Records the fluid's porosity (Robinson eq. 9) with the grains moved by v τ from
    /// the window's start, after a sort: at sampling (τ = 0) and after every later step's
    /// sort (the window's first step keeps sampling's: `FluidSolver::start_sorted`),
    /// so that the porosity follows the grains instead of jumping once a window (each
    /// jump is a pressure pulse through the EOS on ρ/ε). `tau` goes to the GPU in `slot`
    /// of the τ slots (`GrainBuffers::tau_slots`), the step's place in the encoder's
    /// submission: each step of one submission needs its own.
    pub fn queue_solid_fraction(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut StageTimer>,
        data: &SphData,
        tau: f64,
        slot: u32,
    ) -> Result<(), FluidError> {
        let solid_buffer = (data.solid.as_ref()).ok_or_else(|| missing("the solid fraction"))?;
        let solid = self
            .solid
            .bind(
                gpu,
                |g, b| match g {
                    PARTICLES => match b {
                        pb::POS => Some(&data.pos),
                        pb::ID => Some(&data.id),
                        pb::SOLID => Some(solid_buffer),
                        pb::SOLID_GRAD => data.solid_grad.as_ref(),
                        _ => None,
                    },
                    BODIES => self.buffers.binding(b),
                    PARAMS => Some(&data.params),
                    _ => None,
                },
                Some(data.grid.bind_group()),
            )
            .ok_or_else(|| missing("grain_solid_fraction"))?;
        let at = 16 * u64::from(slot);
        gpu.queue.write_buffer(
            &self.buffers.tau_slots,
            at,
            bytemuck::cast_slice(&[tau as f32, 0.0, 0.0, 0.0]),
        );
        encoder.copy_buffer_to_buffer(&self.buffers.tau_slots, at, &self.buffers.tau, 0, 16);
        encoder.clear_buffer(solid_buffer, 0, None);
        if let Some(g) = &data.solid_grad {
            encoder.clear_buffer(g, 0, None);
        }
        let mut pass = timing::begin_pass(timer, gpu, encoder, "sph: grain_solid_fraction");
        solid.dispatch(&mut pass, team_threads(self.buffers.count, self.team_lanes));
        Ok(())
    }

    /// Adds this stage's `energy-pair` pressure force, times `params.load_weight`, to
    /// the window's sums (after a `fluid_rates`, in the same encoder as the step's
    /// [`GrainCoupling::queue_solid_fraction`], whose τ it shares). Nothing otherwise.
    pub fn queue_pressure_force(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut StageTimer>,
        data: &SphData,
    ) -> Result<(), FluidError> {
        let Some(kernel) = &self.pressure else {
            return Ok(());
        };
        let bound = kernel
            .bind(
                gpu,
                |g, b| match g {
                    PARTICLES => match b {
                        pb::POS => Some(&data.pos),
                        pb::RHO => Some(&data.rho),
                        pb::PRESS => Some(&data.press),
                        pb::ID => Some(&data.id),
                        _ => None,
                    },
                    BODIES => self.buffers.binding(b),
                    PARAMS => Some(&data.params),
                    _ => None,
                },
                Some(data.grid.bind_group()),
            )
            .ok_or_else(|| missing("grain_pressure_force"))?;
        let mut pass = timing::begin_pass(timer, gpu, encoder, "sph: grain_pressure_force");
        bound.dispatch(&mut pass, team_threads(self.buffers.count, self.team_lanes));
        Ok(())
    }

    /// `loads` (one per grain, as [`GrainCoupling::sample`] gave them) with the window's
    /// `energy-pair` pressure force added: its weighted sum over the window's stages,
    /// which is the window's average (the weights sum to 1). Unchanged otherwise.
    pub fn add_pressure_forces(&self, gpu: &Gpu, loads: &mut [BodyLoad]) -> Result<(), FluidError> {
        if self.pressure.is_none() {
            return Ok(());
        }
        for (l, f) in loads.iter_mut().zip(self.buffers.read_pressure(gpu)?) {
            for k in 0..3 {
                l.force[k] += f[k];
            }
        }
        Ok(())
    }

    /// One `grain_pressure_force` at the present state, with the load weight and τ as
    /// last written (`FluidSolver::run_ops` sets the weight), read back (tests: the
    /// pass against its CPU twin).
    pub fn pressure_forces_now(
        &self,
        gpu: &Gpu,
        data: &SphData,
    ) -> Result<Vec<[f64; 3]>, FluidError> {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&self.buffers.pressure, 0, None);
        self.queue_pressure_force(gpu, &mut encoder, None, data)?;
        gpu.queue.submit([encoder.finish()]);
        Ok(self.buffers.read_pressure(gpu)?)
    }

    /// Replaces the fluid's reaction with that of the last [`GrainCoupling::sample`]
    /// (Robinson eqs. 26–27), in counts of `params.reaction_unit`, which the caller has
    /// set to [`reaction_unit`] of those samples. Nothing without `coupling.two_way`.
    /// A `timer` times the pass and is finished before the submission, as in
    /// [`GrainCoupling::sample`].
    pub fn spread(
        &self,
        gpu: &Gpu,
        data: &SphData,
        mut timer: Option<&mut StageTimer>,
    ) -> Result<(), FluidError> {
        let (Some(spread), Some(reaction)) = (&self.spread, &data.reaction) else {
            return Ok(());
        };
        let bound = spread
            .bind(
                gpu,
                |g, b| match g {
                    PARTICLES => match b {
                        pb::POS => Some(&data.pos),
                        pb::RHO => Some(&data.rho),
                        pb::ID => Some(&data.id),
                        pb::REACTION_LO => Some(&reaction.lo),
                        pb::REACTION_HI => Some(&reaction.hi),
                        _ => None,
                    },
                    BODIES => self.buffers.binding(b),
                    PARAMS => Some(&data.params),
                    _ => None,
                },
                Some(data.grid.bind_group()),
            )
            .ok_or_else(|| missing("spread_grain_reaction"))?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&reaction.lo, 0, None);
        encoder.clear_buffer(&reaction.hi, 0, None);
        {
            let mut pass = timing::begin_pass(
                timer.as_deref_mut(),
                gpu,
                &mut encoder,
                "sph: spread_grain_reaction",
            );
            bound.dispatch(&mut pass, team_threads(self.buffers.count, self.team_lanes));
        }
        if let Some(t) = timer {
            t.finish(gpu, &mut encoder);
        }
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    }
}
