//! Robinson's variable smoothing length (Robinson eqs. 10–12, 19, after Price 2012),
//! `effects.variable_smoothing_length`. Among grains the fluid's density is
//! superficial, ε ρ_f, so a particle that moves into porosity ε swells to a volume
//! V = m/ρ of δ³/ε; with one h it would keep about ε of its neighbours. Each fluid
//! particle therefore takes
//!
//! - `h_i = h (V_i/δ³)^(1/3)` (eq. 19; its σ is the scene's h/δ),
//! - `Ω_i = 1 − (∂h_i/∂ρ_i) Σ_j m_j ∂W_ij(h_i)/∂h_i` (eq. 11), with `∂h/∂ρ = −h/(3ρ)`
//!   and `∂W/∂h = −(3W + r² F)/h` (`F = W'(r)/r`), itself included in the sum;
//!
//! once per step after the sort (`smoothing_lengths`, into the (h, Ω) buffer); the
//! rates ([`crate::fluid_rates`]) and the gradient pass read it. Walls and markers
//! keep (h, 1): their volume is δ³ by construction, which eq. (19) maps to h.
//! Ω_i and h_i are those of the step's start in both stages of the predictor–corrector
//! (a lag of O(Δt) in a factor of 1 + O(|δρ|/ρ)). On a uniform lattice Ω is 1 less the
//! kernel sum's lattice error ([`lattice_omega`]: 2.5e-3 at support 3δ, 5.2e-2 at 2δ),
//! which our continuity density does not cancel; the scene warns under 3δ.
//!
//! The neighbour grid is built for the largest h allowed,
//! [`SphConstants::grid_radius`]; a particle whose h would exceed it is a blow-up
//! ([`crate::blowup_check`]).
//! WGSL: `shaders/robinson_variable_h.wgsl`; the per-particle h of the other kernels:
//! [`smoothing_wgsl`].

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::kernel::{SmoothingKernel, kernel_library};
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, dot};
use crate::sph_kernel::{Access, PARAMS, PARTICLES, SphKernel, particle_binding as pb};

pub const ROBINSON_VARIABLE_H_WGSL: &str = include_str!("../shaders/robinson_variable_h.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: robinson_variable_h",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            kernel_library(),
            ROBINSON_VARIABLE_H_WGSL,
        ],
        "smoothing_lengths",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::Read),
                    (pb::RHO, Access::Read),
                    (pb::ID, Access::Read),
                    (pb::SMOOTHING, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        Some(grid_layout),
    )
}

/// `smoothing_length(i)` and `omega(i)` for a pair kernel, and the binding it needs:
/// the pass's buffer with variable h, the constants H and 1 without (nothing bound).
pub fn smoothing_wgsl(c: &SphConstants) -> (&'static str, Option<(u32, Access)>) {
    if c.variable_h.is_some() {
        (
            "@group(0) @binding(17) var<storage, read> smoothing: array<vec2<f32>>;
fn smoothing_length(i: u32) -> f32 {
    return smoothing[i].x;
}
fn omega(i: u32) -> f32 {
    return smoothing[i].y;
}
",
            Some((pb::SMOOTHING, Access::Read)),
        )
    } else {
        (
            "fn smoothing_length(i: u32) -> f32 {
    return H;
}
fn omega(i: u32) -> f32 {
    return 1.0;
}
",
            None,
        )
    }
}

/// CPU twin of h_i: eq. (19) for a fluid particle with variable h, else the scene's h.
pub fn smoothing_length_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> f64 {
    let h = c.kernel.h;
    match c.variable_h {
        Some(_) if set.kinds.kind(set.id[i]) == Kind::Fluid => {
            h * (set.mass[i] / (set.rho[i] * c.spacing.powi(3))).cbrt()
        }
        _ => h,
    }
}

/// Particle `i`'s own kernel: [`SphConstants::kernel`] at [`smoothing_length_cpu`].
pub fn kernel_at(c: &SphConstants, set: &ParticleSet, i: usize) -> SmoothingKernel {
    if c.variable_h.is_some() {
        SmoothingKernel::new(c.kernel.kind, smoothing_length_cpu(c, set, i))
    } else {
        c.kernel
    }
}

/// CPU twin of Ω_i (eq. 11): 1 for walls, markers and without variable h.
pub fn omega_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> f64 {
    if c.variable_h.is_none() || set.kinds.kind(set.id[i]) != Kind::Fluid {
        return 1.0;
    }
    let k = kernel_at(c, set, i);
    // Itself: r = 0, 3 W(0).
    let mut sum = set.mass[i] * 3.0 * k.w(0.0);
    for j in set.neighbours(i, k.radius(), c.period) {
        let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
        let r2 = dot(r_ij, r_ij);
        let r = r2.sqrt();
        sum += set.mass[j] * (3.0 * k.w(r) + r2 * k.grad_factor(r));
    }
    1.0 - sum / (3.0 * set.rho[i])
}

/// CPU twin of the pass: (h_i, Ω_i) of every entry.
pub fn smoothing_cpu(c: &SphConstants, set: &ParticleSet) -> Vec<(f64, f64)> {
    (0..set.len())
        .map(|i| (smoothing_length_cpu(c, set, i), omega_cpu(c, set, i)))
        .collect()
}

/// CPU twin of the rates' pair rule: the particles within particle `i`'s support or
/// within their own (with one h: within the support).
pub fn pair_neighbours<'a>(
    c: &'a SphConstants,
    set: &'a ParticleSet,
    i: usize,
) -> impl Iterator<Item = usize> + 'a {
    let r_i = kernel_at(c, set, i).radius();
    set.neighbours(i, c.grid_radius(), c.period)
        .filter(move |&j| {
            let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
            let r = dot(r_ij, r_ij).sqrt();
            r < r_i || r < kernel_at(c, set, j).radius()
        })
}

/// Ω of eq. (11) at a particle inside a uniform cubic lattice of spacing δ at ρ0 (the
/// same at every stretch, since eq. 19 scales h with the spacing):
/// `1 − Σ_lattice (3W + r²F) δ³/3`. It is 1 in the continuum; the lattice sum's error
/// is what the kernel's support leaves: −2.5e-3 at 3δ, −3.2e-2 at 2.4δ, −5.2e-2 at 2δ
/// (Wendland C2). With the continuity density (ρ0 on the lattice, not the kernel sum)
/// this bias scales every pressure term by 1/Ω; `couplet plan` prints it.
pub fn lattice_omega(c: &SphConstants) -> f64 {
    let k = &c.kernel;
    let d = c.spacing;
    let reach = (k.radius() / d).ceil() as i64;
    let mut sum = 0.0;
    for i in -reach..=reach {
        for j in -reach..=reach {
            for l in -reach..=reach {
                let r2 = ((i * i + j * j + l * l) as f64) * d * d;
                let r = r2.sqrt();
                if r < k.radius() {
                    sum += 3.0 * k.w(r) + r2 * k.grad_factor(r);
                }
            }
        }
    }
    1.0 - sum * d.powi(3) / 3.0
}
