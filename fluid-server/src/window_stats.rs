//! The fluid's telemetry at the end of each window ([`WindowStats`]): kinetic energy,
//! largest speed and largest density error, for the orchestrator's per-window frames
//! (`WatchRun`) and the recording's `/run/windows`.
//! WGSL: `shaders/window_stats.wgsl` (`window_stats`): one vec4 per workgroup, reduced
//! in workgroup memory; [`WindowStats::from_partials`] finishes the sum in f64.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::particles::ParticleSet;
use crate::porosity::porosity_wgsl;
use crate::shaders::{WORKGROUP_SIZE, workgroups};
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, param_binding as qb, particle_binding as pb,
};

pub const WINDOW_STATS_WGSL: &str = include_str!("../shaders/window_stats.wgsl");

/// The fluid particles' state summed up.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WindowStats {
    /// Σ ½ m |u|² over the fluid particles, J.
    pub kinetic_energy: f64,
    /// Largest |u|, m/s.
    pub max_speed: f64,
    /// Largest |ρ/(ε ρ0) − 1| (ε the grains' porosity, 1 without grains).
    pub max_density_error: f64,
}

impl WindowStats {
    /// Finishes the GPU's per-workgroup partials `(Σ ½ m u², max u², max error, 0)`.
    pub fn from_partials(partials: &[[f32; 4]]) -> Self {
        let mut s = Self::default();
        let mut max_u2 = 0.0f64;
        for p in partials {
            s.kinetic_energy += f64::from(p[0]);
            max_u2 = max_u2.max(f64::from(p[1]));
            s.max_density_error = s.max_density_error.max(f64::from(p[2]));
        }
        s.max_speed = max_u2.sqrt();
        s
    }

    /// CPU twin in f64: the same sums over the fluid particles of `set`, whose
    /// porosity is `porosity[k]` (1 without grains).
    pub fn of_particles(set: &ParticleSet, rho0: f64, porosity: impl Fn(usize) -> f64) -> Self {
        let mut s = Self::default();
        let mut max_u2 = 0.0f64;
        for k in 0..set.len() {
            if (set.id[k] as usize) >= set.kinds.n_fluid {
                continue;
            }
            let u2: f64 = set.vel[k].iter().map(|x| x * x).sum();
            s.kinetic_energy += 0.5 * set.mass[k] * u2;
            max_u2 = max_u2.max(u2);
            s.max_density_error = s
                .max_density_error
                .max((set.rho[k] / (rho0 * porosity(k)) - 1.0).abs());
        }
        s.max_speed = max_u2.sqrt();
        s
    }
}

/// Workgroups, and so partials, the kernel writes for `n` particles.
pub fn partial_count(n: u32) -> usize {
    let [x, y, _] = workgroups(n);
    (x * y) as usize
}

/// Bytes of the partials buffer for `n` particles (at least one entry: bindings need a
/// non-empty buffer).
pub fn partials_bytes(n: u32) -> u64 {
    partial_count(n).max(1) as u64 * 16
}

pub fn kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    const _: () = assert!(
        WORKGROUP_SIZE.is_power_of_two(),
        "the halving tree needs it"
    );
    let consts = c.wgsl();
    let (porosity, binding) = porosity_wgsl(c);
    let mut particles = vec![
        (pb::POS, Access::Read),
        (pb::VEL, Access::Read),
        (pb::RHO, Access::Read),
        (pb::ID, Access::Read),
    ];
    particles.extend(binding);
    SphKernel::new(
        gpu,
        "sph: window_stats",
        &[&consts, STEP_PARAMS_WGSL, porosity, WINDOW_STATS_WGSL],
        "window_stats",
        &[
            (PARTICLES, &particles),
            (
                PARAMS,
                &[
                    (qb::PARAMS, Access::Uniform),
                    (qb::PARTIALS, Access::ReadWrite),
                ],
            ),
        ],
        None,
    )
}
