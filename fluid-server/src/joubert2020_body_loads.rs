//! Fluid force and moment on resolved bodies, Joubert eqs. (31)–(32):
//!
//! `t_i = (−p_i n_i + μ (∇u + ∇uᵀ)_i · n_i) ΔS_i`, `∇u_i = Σ_f V_f (u_f − u_i) ⊗ B_i ∇W_if`
//!
//! over fluid neighbours f (V_f = m/ρ_f, μ = ρ0 ν), and `M_i = (r_i − r_cg) × t_i`.
//! With `effects.gradient_correction` the velocity gradient is Joubert's corrected one,
//! `B_i = M_i⁻¹` over the marker's fluid neighbours only (eq. 10, one-sided, as for
//! Joubert's walls): exact for a linear field at the surface, where the uncorrected sum
//! sees about half a support and gives about half the shear. A near-singular `M_i`
//! (the guard of [`crate::joubert2020_boundary_values`]) keeps `B_i = I` and is counted
//! with the run's near-singular particles. Without the correction `B_i = I`. The marker
//! pressure p_i is the boundary pressure ([`crate::adami2012_boundary_pressure`], or
//! eq. 25 with Joubert walls, [`crate::joubert2020_boundary_values`]).
//! Loads are evaluated at both derivative evaluations of every step (at fⁿ and f*,
//! weight 1/(2 · substeps) each), i.e. with the predictor–corrector's own trapezoidal
//! weights, and summed per marker (Kahan) into `marker_load[2k..2k+2]` (marker order =
//! DEM order), so the window average is ready at the end. [`crate::body_load_reduce`]
//! then reduces each body's contiguous range.
//! WGSL: `shaders/joubert2020_body_loads.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::joubert2020_boundary_values::well_posed;
use crate::joubert2020_gradients::{B_DET_MIN, Mat3, inverse};
use crate::kernel::kernel_library;
use crate::marker_update::MARKER_UPDATE_WGSL;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, sub};
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, library, param_binding as qb,
    particle_binding as pb,
};

pub const BODY_LOADS_WGSL: &str = include_str!("../shaders/joubert2020_body_loads.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    // The fallback count needs the gradient pass's diagnostics, bound only with it.
    let guard = format!(
        "const B_DET_MIN: f32 = {B_DET_MIN:e};\n{}",
        if c.gradient_correction {
            "@group(3) @binding(4) var<storage, read_write> diag: array<atomic<u32>, 4>;\n\
             fn count_one_sided_fallback() { atomicAdd(&diag[2], 1u); }\n"
        } else {
            "fn count_one_sided_fallback() {}\n"
        }
    );
    let params: &[(u32, Access)] = if c.gradient_correction {
        &[(qb::PARAMS, Access::Uniform), (qb::DIAG, Access::ReadWrite)]
    } else {
        &[(qb::PARAMS, Access::Uniform)]
    };
    SphKernel::new(
        gpu,
        "sph: joubert2020_marker_loads",
        &[
            &consts,
            &guard,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            kernel_library(),
            library(MARKER_UPDATE_WGSL),
            BODY_LOADS_WGSL,
        ],
        "marker_loads",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::Read),
                    (pb::VEL, Access::Read),
                    (pb::RHO, Access::Read),
                    (pb::PRESS, Access::Read),
                    (pb::ID, Access::Read),
                ],
            ),
            (
                BODIES,
                &[
                    (bb::MARKERS_IN, Access::Read),
                    (bb::BODIES, Access::Read),
                    (bb::CLOCK, Access::Read),
                    (bb::MARKER_LOAD, Access::ReadWrite),
                    (bb::MARKER_LOAD_C, Access::ReadWrite),
                ],
            ),
            (PARAMS, params),
        ],
        Some(grid_layout),
    )
}

/// What the CPU twin needs of a marker besides the particle arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerGeometry {
    pub normal: [f64; 3],
    pub area: f64,
    /// Centre of mass of the owning body at the time of the evaluation.
    pub cg: [f64; 3],
}

/// The CPU twin's load of one marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerLoad {
    pub traction: [f64; 3],
    pub moment: [f64; 3],
    /// The gradient correction was on and the one-sided M near-singular: B = I.
    pub fallback: bool,
}

/// CPU twin: traction t_i and moment M_i of the marker at entry `i`.
pub fn marker_load_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    m: &MarkerGeometry,
) -> MarkerLoad {
    if m.area == 0.0 {
        // A fill point: no surface, no load, no one-sided B (as the WGSL).
        return MarkerLoad {
            traction: [0.0; 3],
            moment: [0.0; 3],
            fallback: false,
        };
    }
    let n = m.normal;
    let mut t = n.map(|x| -set.press[i] * x);
    let mut fallback = false;
    if c.nu > 0.0 {
        // d[a][c] = Σ V du_a ∇W_c; m_i the one-sided M (Joubert eq. 10, fluid only).
        let mut d: Mat3 = [[0.0; 3]; 3];
        let mut m_i: Mat3 = [[0.0; 3]; 3];
        for j in set.neighbours(i, c.support_radius(), c.period) {
            if set.kinds.kind(set.id[j]) != Kind::Fluid {
                continue;
            }
            let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
            let g = c.kernel.grad(r_ij);
            let v = set.mass[j] / set.rho[j];
            let du = sub(set.vel[j], set.vel[i]);
            for a in 0..3 {
                for b in 0..3 {
                    d[a][b] += v * du[a] * g[b];
                    m_i[a][b] -= v * g[a] * r_ij[b];
                }
            }
        }
        // grad_u[a][b] = ∂u_a/∂x_b = Σ_c d[a][c] B[b][c].
        let mut grad_u = d;
        if c.gradient_correction {
            if well_posed(&m_i) {
                let b = inverse(&m_i);
                grad_u = std::array::from_fn(|a| {
                    std::array::from_fn(|bb| (0..3).map(|k| d[a][k] * b[bb][k]).sum())
                });
            } else {
                fallback = true;
            }
        }
        let mu = c.rho0 * c.nu;
        for a in 0..3 {
            let sym_n: f64 = (0..3).map(|b| (grad_u[a][b] + grad_u[b][a]) * n[b]).sum();
            t[a] += mu * sym_n;
        }
    }
    let t = t.map(|x| x * m.area);
    let arm = sub(set.pos[i], m.cg);
    let moment = [
        arm[1] * t[2] - arm[2] * t[1],
        arm[2] * t[0] - arm[0] * t[2],
        arm[0] * t[1] - arm[1] * t[0],
    ];
    MarkerLoad {
        traction: t,
        moment,
        fallback,
    }
}
