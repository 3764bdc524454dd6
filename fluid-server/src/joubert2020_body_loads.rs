//! Fluid force and moment on resolved bodies, Joubert eqs. (31)–(32), with uncorrected
//! gradients for now (the B-matrix correction will multiply ∇W here):
//!
//! `t_i = (−p_i n_i + μ (∇u + ∇uᵀ)_i · n_i) ΔS_i`, `∇u_i = Σ_f V_f (u_f − u_i) ⊗ ∇W_if`
//!
//! over fluid neighbours f (V_f = m/ρ_f, μ = ρ0 ν), and `M_i = (r_i − r_cg) × t_i`. The
//! marker pressure p_i is the boundary pressure ([`crate::adami2012_boundary_pressure`]).
//! Loads are evaluated at both derivative evaluations of every step (at fⁿ and f*,
//! weight 1/(2 · substeps) each), i.e. with the predictor–corrector's own trapezoidal
//! weights, and summed per marker (Kahan) into `marker_load[2k..2k+2]` (marker order =
//! DEM order), so the window average is ready at the end. [`crate::body_load_reduce`]
//! then reduces each body's contiguous range.
//! WGSL: `shaders/joubert2020_body_loads.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::kernel::kernel_library;
use crate::marker_update::MARKER_UPDATE_WGSL;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, dot, sub};
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, library,
    particle_binding as pb,
};

pub const BODY_LOADS_WGSL: &str = include_str!("../shaders/joubert2020_body_loads.wgsl");

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: joubert2020_marker_loads",
        &[
            &consts,
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
            (PARAMS, &[(0, Access::Uniform)]),
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

/// CPU twin: (traction t_i, moment M_i) of the marker at entry `i`.
pub fn marker_load_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    m: &MarkerGeometry,
) -> ([f64; 3], [f64; 3]) {
    let n = m.normal;
    let mut t = n.map(|x| -set.press[i] * x);
    if c.nu > 0.0 {
        // grad_u[a][b] = ∂u_a/∂x_b.
        let mut grad_u = [[0.0; 3]; 3];
        for j in set.neighbours(i, c.support_radius()) {
            if set.kinds.kind(set.id[j]) != Kind::Fluid {
                continue;
            }
            let g = c.kernel.grad(sub(set.pos[i], set.pos[j]));
            let v = c.mass / set.rho[j];
            let du = sub(set.vel[j], set.vel[i]);
            for a in 0..3 {
                for b in 0..3 {
                    grad_u[a][b] += v * du[a] * g[b];
                }
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
    let _ = dot;
    (t, moment)
}
