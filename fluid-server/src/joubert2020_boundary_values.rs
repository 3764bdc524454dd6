//! Joubert's one-layer boundaries (§2.5–2.6, `domain.wall_model = "joubert"`): the
//! pressure of every boundary particle — domain wall or body marker — from the Neumann
//! condition of Joubert eq. (25), and on symmetry planes the velocity from eq. (27)
//! with a zero normal derivative. No ghost or mirrored particles: the corrected
//! gradient over the particle's fluid neighbours is contracted with the surface normal.
//!
//! For boundary particle w and its fluid neighbours f (`V_f = m/ρ_f`):
//!
//! - `M_w = −Σ_f V_f ∇W_wf ⊗ r_wf` and `B_w = M_w⁻¹`: the one-sided truncation matrix
//!   (Joubert eq. 10 over the fluid only, so that `Σ_f V_f (f_f − f_w) B_w ∇W_wf` is
//!   exact for a linear field whatever `f_w` is);
//! - `p_w = (n̂·B_w Σ_f V_f p_f/ρ_f ∇W_wf − n̂·g + n̂·a_w − n̂·⟨∇·τ/ρ⟩_w) /
//!   n̂·B_w Σ_f V_f/ρ_f ∇W_wf` (eq. 25), the momentum equation contracted with the
//!   normal; the normal's sign cancels. `a_w` is the surface's acceleration: 0 for
//!   domain walls (fixed, or sliding at a constant lid velocity), the rigid-body
//!   acceleration of the point for a marker ([`crate::marker_update::point_acceleration`]).
//!   Normal and acceleration come per boundary particle in a [`BoundaryFrame`]. The
//!   viscous term `n̂·ν∇²u` is left out: at a flat no-slip
//!   wall it equals `−ν ∇_t·(∂u_t/∂n)`, zero for a fully developed channel flow and for
//!   fluid at rest, and at a symmetry plane it vanishes with the odd normal velocity;
//!   it is not zero next to the corners of a driven cavity. Computing it needs the
//!   corrected Laplacian at the wall, a one-sided second-order fit not built yet.
//! - no-slip particles (and markers) keep their own velocity (a Dirichlet condition, Joubert's "one
//!   layer of boundary particles with fixed properties"); symmetry particles take
//!   `u_w = n̂·B_w Σ_f V_f u_f ∇W_wf / n̂·B_w Σ_f V_f ∇W_wf` (eq. 27, `∂u/∂n = 0`) with
//!   the components along their normal's axes set to zero (no flow through the plane).
//! - `ρ_w` from the inverted Tait equation (eq. 4).
//!
//! Guard: where `M_w` is near-singular — a support holding few fluid particles, or only
//! a sheet of them — the inverse would amplify noise, so the particle takes Adami, Hu &
//! Adams's (2012) uncorrected extrapolation (eq. 27 there; velocity: the Shepard
//! average) and is counted; the count reaches the run's near-singular total. A
//! particle without any fluid neighbour (a wall above a free surface) takes `p = 0`,
//! `ρ = ρ0` and, on a symmetry plane, zero velocity; no fluid particle sees it, so it
//! is not counted.
//! WGSL: `shaders/joubert2020_boundary_values.wgsl`.

use crate::adami2012_boundary_pressure::extrapolate_cpu;
use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::fluid_rows::row_fluid_read_wgsl;
use crate::gpu::Gpu;
use crate::joubert2020_gradients::{B_DET_MIN, Mat3, determinant, inverse, mat_vec};
use crate::kernel::kernel_library;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, dot};
use crate::porosity::boundary_state_wgsl;
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, library, param_binding as qb, particle_binding as pb,
};
use crate::tait_eos::TAIT_EOS_WGSL;
use couplet_protocol::Scene;

pub const BOUNDARY_VALUES_WGSL: &str = include_str!("../shaders/joubert2020_boundary_values.wgsl");

/// Guard thresholds, relative (see the module doc): `tr M/3 ≥ B_DET_MIN` (at least
/// 5 % of a full support's first moment), `det M ≥ B_DET_MIN (tr M/3)³` (not a sheet),
/// and `|n̂·B Σ V ∇W| δ ≥ B_DET_MIN` (eq. 25's denominator clear of zero). A particle
/// on a flat face has `M ≈ I/2`; at an edge `≈ I/4`, at a corner `≈ I/8`, all well-posed.
pub(crate) fn well_posed(m: &Mat3) -> bool {
    let scale = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    scale >= B_DET_MIN && determinant(m) >= B_DET_MIN * scale.powi(3)
}

/// What eq. (25) needs of boundary particle `id − n_fluid` besides the fluid (domain
/// walls first, then markers; WGSL `BoundaryFrame`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BoundaryFrame {
    /// xyz the unit normal (its sign cancels in eqs. 25 and 27); w = 1 on a symmetry
    /// plane (the particle takes eq. 27's velocity), else 0 (it keeps its own).
    pub normal: [f32; 4],
    /// xyz the acceleration of the surface at the particle, m/s²; w unused.
    pub acc: [f32; 4],
}

impl BoundaryFrame {
    /// A marker's frame: its outward normal and the point's acceleration.
    pub fn marker(normal: [f32; 3], acc: [f64; 3]) -> Self {
        BoundaryFrame {
            normal: [normal[0], normal[1], normal[2], 0.0],
            acc: [acc[0] as f32, acc[1] as f32, acc[2] as f32, 0.0],
        }
    }
}

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    let guard = format!("const B_DET_MIN: f32 = {B_DET_MIN:e};\n");
    let (state, mut particles) = boundary_state_wgsl(c);
    particles.extend([
        (pb::VEL, Access::ReadWrite),
        (pb::RHO, Access::ReadWrite),
        (pb::PRESS, Access::ReadWrite),
        (pb::ID, Access::Read),
        (pb::BOUNDARY_FRAME, Access::Read),
        (pb::ROW_FLUID, Access::Read),
    ]);
    let rows = row_fluid_read_wgsl();
    SphKernel::new(
        gpu,
        "sph: joubert2020_boundary_values",
        &[
            &consts,
            &guard,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            &rows,
            kernel_library(),
            library(TAIT_EOS_WGSL),
            &state,
            BOUNDARY_VALUES_WGSL,
        ],
        "joubert2020_boundary_values",
        &[
            (PARTICLES, &particles),
            (
                PARAMS,
                &[(qb::PARAMS, Access::Uniform), (qb::DIAG, Access::ReadWrite)],
            ),
        ],
        Some(grid_layout),
    )
}

/// Frames of every wall particle of a fresh `set` built for `scene` with
/// `wall_model = "joubert"`, indexed by `id − n_fluid`: the unit normal into the fluid
/// (the normalised sum of the normals of the faces the particle lies on), marked
/// symmetric when every one of those faces is a symmetry plane (`domain.symmetry`, or
/// every face with `walls = "free-slip"`), and zero acceleration.
pub fn wall_frames(scene: &Scene, set: &ParticleSet) -> Vec<BoundaryFrame> {
    let d = &scene.domain;
    let tol = 0.25 * scene.fluid.as_ref().map_or(0.0, |f| f.spacing);
    let index = set.index_of_id();
    let base = set.kinds.n_fluid;
    (base..base + set.kinds.n_wall)
        .map(|w| {
            let p = set.pos[index[w]];
            let mut n = [0.0f64; 3];
            let mut all_symmetric = true;
            for k in (0..3).filter(|k| !d.periodic[*k]) {
                for (face, inward) in [(d.min[k], 1.0), (d.max[k], -1.0)] {
                    if (p[k] - face).abs() < tol {
                        n[k] += inward;
                        all_symmetric &= d.is_symmetry_axis(k);
                    }
                }
            }
            let len = dot(n, n).sqrt();
            // Every Joubert wall particle lies on a face by construction
            // (particles.rs); a zero normal would make eq. (25) fall back, counted.
            let n = if len > 0.0 { n.map(|x| x / len) } else { n };
            let symmetric = len > 0.0 && all_symmetric;
            BoundaryFrame {
                normal: [
                    n[0] as f32,
                    n[1] as f32,
                    n[2] as f32,
                    f32::from(u8::from(symmetric)),
                ],
                acc: [0.0; 4],
            }
        })
        .collect()
}

/// One boundary particle's values from the CPU twin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundaryValues {
    pub press: f64,
    pub rho: f64,
    /// The velocity the particle holds afterwards (its own on no-slip faces).
    pub vel: [f64; 3],
    /// The one-sided M was near-singular: Adami's extrapolation was used.
    pub fallback: bool,
}

/// CPU twin: the values of every wall and marker entry of `set` (`None` for fluid),
/// with `frames` indexed by `id − n_fluid` ([`wall_frames`], then the markers').
pub fn boundary_values_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    frames: &[BoundaryFrame],
) -> Vec<Option<BoundaryValues>> {
    (0..set.len())
        .map(|i| {
            (set.kinds.kind(set.id[i]) != Kind::Fluid).then(|| {
                let f = frames[set.id[i] as usize - set.kinds.n_fluid];
                let n = [f.normal[0], f.normal[1], f.normal[2]].map(f64::from);
                let a = [f.acc[0], f.acc[1], f.acc[2]].map(f64::from);
                one_boundary(c, set, i, n, a, f.normal[3] > 0.5)
            })
        })
        .collect()
}

fn one_boundary(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    n: [f64; 3],
    a_w: [f64; 3],
    symmetry: bool,
) -> BoundaryValues {
    let mut m: Mat3 = [[0.0; 3]; 3];
    let (mut s, mut s_rho, mut sp) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    let mut su = [[0.0; 3]; 3];
    for j in set.neighbours(i, c.support_radius(), c.period) {
        if set.kinds.kind(set.id[j]) != Kind::Fluid {
            continue;
        }
        let r_wf = c.pair_vec(set.pos[i], set.pos[j]);
        let r = dot(r_wf, r_wf).sqrt();
        let v = set.mass[j] / set.rho[j];
        let vgw = r_wf.map(|x| v * c.kernel.grad_factor(r) * x);
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] -= vgw[a] * r_wf[b];
            }
            s[a] += vgw[a];
            s_rho[a] += vgw[a] / set.rho[j];
            sp[a] += set.press[j] / set.rho[j] * vgw[a];
            for (k, su_k) in su.iter_mut().enumerate() {
                su_k[a] += set.vel[j][k] * vgw[a];
            }
        }
    }
    let own = set.vel[i];
    let Some(adami) = extrapolate_cpu(c, set, i, a_w) else {
        return BoundaryValues {
            press: 0.0,
            rho: c.rho0,
            vel: if symmetry { [0.0; 3] } else { own },
            fallback: false,
        };
    };
    let mut solved = None;
    if well_posed(&m) {
        let b = inverse(&m);
        let n_s = dot(n, mat_vec(&b, s));
        if n_s.abs() * c.spacing >= B_DET_MIN {
            // Joubert eq. (25), viscous term left out (module doc).
            let p = (dot(n, mat_vec(&b, sp)) - dot(n, c.gravity_fluid) + dot(n, a_w))
                / dot(n, mat_vec(&b, s_rho));
            // Joubert eq. (27) with ∂u/∂n = 0.
            let u = su.map(|su_k| dot(n, mat_vec(&b, su_k)) / n_s);
            solved = Some((p, u));
        }
    }
    let fallback = solved.is_none();
    let (press, u) = solved.unwrap_or(adami);
    let vel = if symmetry {
        std::array::from_fn(|k| if n[k] != 0.0 { 0.0 } else { u[k] })
    } else {
        own
    };
    BoundaryValues {
        press,
        rho: c.density(press),
        vel,
        fallback,
    }
}
