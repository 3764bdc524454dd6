//! The per-step gradient pass: the kernel-gradient correction matrix of Joubert eq. (10),
//! the corrected gradients of velocity and pressure (eqs. 7, 9–10) and the shift
//! direction of particle shifting (eq. 17). It runs once per step after the grid sort,
//! only when a scene's effect reads it ([`SphConstants::gradient_pass`]: the gradient
//! and Laplacian corrections, the mass correction, particle shifting, δ-SPH).
//!
//! For a fluid particle i, over its support (every kind of neighbour, `V_j = m/ρ_j`):
//!
//! - `M_i = −Σ_j V_j ∇W_ij ⊗ r_ij`, so that the SPH gradient of a linear field is
//!   `⟨∇f⟩_i = M_i ∇f` (Joubert eq. 9; the paper writes the transpose, B⁻¹ of eq. 10,
//!   with the other contraction convention). A full support gives `M ≈ I`.
//! - `B_i = M_i⁻¹` when `det M_i ≥` [`B_DET_MIN`]; otherwise `B_i = I` and the particle
//!   is counted (see [`B_DET_MIN`]): the count is reported per window, never hidden.
//! - `⟨∇f⟩ᶜ_i = B_i Σ_j V_j (f_j − f_i) ∇W_ij` for `f = u_x, u_y, u_z, p, ρ/ε` (ρ/ε: the
//!   renormalised density gradient of δ-SPH, Antuono et al. 2010, of the intrinsic
//!   density among unresolved grains, ε = 1 elsewhere; [`crate::continuity`]).
//! - `s_i = r̄_i² Σ_j (m_j/m_0) e_ij / r_ij²` with `r̄_i` the mean neighbour distance
//!   and `m_0 = ρ0 δ³` the lattice mass: eq. (17) without its factor `β ‖u‖max Δt`,
//!   which [`crate::particle_shifting`] applies. Joubert's sum counts every neighbour
//!   as one particle; here each counts as the lattice particles it stands for, as every
//!   other sum weighs it by its volume. Fluid, wall and fill particles weigh m_0 (eq. 17
//!   as printed); a surface marker weighs ρ0 ΔS δ (`marker_mass`), so markers packed
//!   closer than δ do not crowd the fluid off a surface. Counted whole, the 24 markers
//!   0.375 δ apart in the hole of Joubert's ring at δ = 1 mm drove the fluid particle
//!   there out against its flow while continuity compressed it, and the ring blew up
//!   (ARCHITECTURE.md, "Particle shifting counts a marker as the patch it stands for").
//! - the largest fluid speed of the step, `‖u‖max` of eq. (17).
//!
//! WGSL: `shaders/joubert2020_gradients.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::kernel::{SmoothingKernel, kernel_library};
use crate::neighbour_grid::{GRID_COMMON_WGSL, dense_team_wgsl};
use crate::particles::{Kind, ParticleSet, dot};
use crate::porosity::porosity_wgsl;
use crate::robinson_variable_h::{kernel_at, smoothing_wgsl};
use crate::sph_kernel::{
    Access, PARAMS, PARTICLES, SphKernel, param_binding as qb, particle_binding as pb,
};

pub const GRADIENTS_WGSL: &str = include_str!("../shaders/joubert2020_gradients.wgsl");

/// Smallest determinant of the truncation matrix `M_i` that is inverted. A particle with
/// a full support has `det M ≈ 1`; one at a flat free surface or wall without boundary
/// particles ≈ 0.5, at a free-surface corner ≈ 0.1–0.2. Below 0.05 the support holds
/// only a few particles on one side (an isolated droplet or a splash), where the
/// inverse amplifies round-off and noise by more than 20×: such a particle keeps the
/// uncorrected gradient (B = I), and the solver reports how many did per window.
pub const B_DET_MIN: f64 = 0.05;

/// With the free-surface switch (`effects.free_surface`), a particle whose truncation
/// matrix has `det M_i` below this fraction of a complete support's
/// ([`lattice_det`]) is near the fluid's edge and takes the standard, symmetric
/// continuity and pressure terms rather than Joubert's corrected difference forms
/// (eqs. 12–13). On the open tank's lattice (Wendland C2, support 3δ) the surface row
/// has det M = 0.28–0.58 (edges and corners lowest), the second row 0.83–0.91 and the
/// third 1.0017, the interior's value: the switch takes the two rows whose support
/// reaches past the surface. Adami's wall layers complete a support, so walls alone do
/// not trip it. Measured on that tank at δ = 0.02 m: switching at det < 0.75 (the
/// surface row only) left the second row, where the two forms met, to grow to 0.5 m/s
/// in 0.2 s; at this fraction the tank stayed at rest (|u| ≤ 0.011 m/s over 0.3 s,
/// decaying). The linearised rates agree (`linear_acoustics`, an open 6 × 10 × 6 box at
/// 3δ): 29 1/s of growth at 0.75, none at 0.95. The fraction, not an absolute det, because a complete support's det is
/// the kernel's discretisation: 0.9487 at support 2δ, where an absolute 0.95 took the
/// whole fluid.
pub const FREE_SURFACE_FRACTION: f64 = 0.95;

/// `det M` of a particle whose support is complete, on the scene's lattice of spacing
/// δ (all neighbours at rest density): the reference of the free-surface zone.
pub fn lattice_det(c: &SphConstants) -> f64 {
    let d = c.spacing;
    let reach = (c.support_radius() / d).ceil() as i64;
    let v = d * d * d;
    let mut m = [[0.0; 3]; 3];
    for i in -reach..=reach {
        for j in -reach..=reach {
            for k in -reach..=reach {
                let r = [i as f64 * d, j as f64 * d, k as f64 * d];
                if (i, j, k) == (0, 0, 0) || dot(r, r) >= c.support_radius().powi(2) {
                    continue;
                }
                // r_ij = x_i − x_j with x_i at the origin.
                add_to_truncation(&mut m, &c.kernel, v, r.map(|x| -x));
            }
        }
    }
    determinant(&m)
}

/// The det M below which the free-surface switch takes a particle:
/// `c.free_surface_fraction` ([`FREE_SURFACE_FRACTION`] from a scene) × [`lattice_det`].
pub fn free_surface_det(c: &SphConstants) -> f64 {
    c.free_surface_fraction * lattice_det(c)
}

/// Smallest pivot of the corrected Laplacian's 6 × 6 system, relative to its largest
/// entry, below which B̂_i = I and the particle is counted with the near-singular ones.
/// A full support gives pivots of about 1/5 of the largest entry; 1e-3 leaves room for
/// the thinnest wall-side supports while refusing the 1000× amplification of a
/// nearly empty one.
pub const LAP_PIVOT_MIN: f64 = 1e-3;

/// `store_bhat(i, diagonal, off_diagonal)`: bound only with the corrected Laplacian.
const STORE_BHAT_WGSL: &str =
    "@group(0) @binding(12) var<storage, read_write> bhat: array<vec4<f32>>;
fn store_bhat(i: u32, d: vec4<f32>, o: vec4<f32>) {
    bhat[2u * i] = d;
    bhat[2u * i + 1u] = o;
}
";
const NO_BHAT_WGSL: &str = "fn store_bhat(i: u32, d: vec4<f32>, o: vec4<f32>) {}
";

/// Which of the pass's fields a scene reads, so that the pass sums, stores and allocates
/// only those (WGSL constants `GRAD_U`, `GRAD_P`, `GRAD_RHO`, `SHIFT_SUMS`, `STORE_B`):
/// ⟨∇u⟩ᶜ and s_i by particle shifting (the Taylor terms and the shift direction of eqs.
/// 17–19), ⟨∇p⟩ᶜ by particle shifting and the mass correction (eqs. 15–16), ⟨∇ρ⟩ᶜ by
/// Antuono's δ-SPH, and B_i with its free-surface flag by the rates' corrected forms
/// (the gradient correction or the corrected Laplacian; the fallback count is always
/// kept). With the gradient correction alone the pass is M and B only, the pair loop's
/// loads pos, ρ (and porosity among grains) without vel and p. The gradient buffer holds
/// [`GradientFields::stride`] vec4 a particle, the fields read in the order ∇u_x, ∇u_y,
/// ∇u_z, ∇p, s, ∇ρ ([`GradientFields::layout_wgsl`]); at 96 B a particle for all six, it
/// was allocated whole until 2026-12-05 (ARCHITECTURE.md, "GPU memory per particle").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GradientFields {
    pub grad_u: bool,
    pub grad_p: bool,
    pub grad_rho: bool,
    pub shift: bool,
    pub store_b: bool,
}

impl GradientFields {
    pub fn of(c: &SphConstants) -> Self {
        let shifting = c.shifting_beta > 0.0;
        GradientFields {
            grad_u: shifting,
            grad_p: shifting || c.mass_correction > 0.0,
            grad_rho: c.antuono_diffusion(),
            shift: shifting,
            store_b: c.uses_b_matrix(),
        }
    }

    /// First vec4 slot of ∇u_x, ∇p, s and ∇ρ in a particle's stretch of the gradient
    /// buffer, and the stretch's length: the fields read, in that order (a field not read
    /// takes no slot, and its start is where the next one's is).
    fn slots(&self) -> ([u32; 4], u32) {
        let mut next = 0;
        let mut take = |on: bool, len: u32| {
            let at = next;
            next += if on { len } else { 0 };
            at
        };
        let at = [
            take(self.grad_u, 3),
            take(self.grad_p, 1),
            take(self.shift, 1),
            take(self.grad_rho, 1),
        ];
        (at, next)
    }

    /// vec4 slots a particle takes in the gradient buffer (0 to 6).
    pub fn stride(&self) -> u32 {
        self.slots().1
    }

    /// Bytes a particle takes in the gradient buffer (16 a slot).
    pub fn slot_bytes(&self) -> u64 {
        16 * u64::from(self.stride())
    }

    /// Bytes a particle takes in B's buffer: its three vec4 columns where the rates read
    /// B, else none.
    pub fn b_bytes(&self) -> u64 {
        if self.store_b { 48 } else { 0 }
    }

    /// The slot of field `k` of [`crate::solver::GradientReadback::fields`] (0–2 ∇u,
    /// 3 ∇p, 4 s, 5 ∇ρ) in a particle's stretch, `None` when the scene does not read it.
    pub fn slot_of(&self, k: usize) -> Option<u32> {
        let ([u, p, s, rho], _) = self.slots();
        match k {
            0..=2 => self.grad_u.then_some(u + k as u32),
            3 => self.grad_p.then_some(p),
            4 => self.shift.then_some(s),
            5 => self.grad_rho.then_some(rho),
            _ => None,
        }
    }

    /// The WGSL constants of the flags and the layout, for the pass and its readers.
    pub fn layout_wgsl(&self) -> String {
        let ([u, p, s, rho], stride) = self.slots();
        format!(
            "const GRAD_U: bool = {};\nconst GRAD_P: bool = {};\nconst GRAD_RHO: bool = {};\n\
             const SHIFT_SUMS: bool = {};\nconst STORE_B: bool = {};\n\
             const GRAD_STRIDE: u32 = {stride}u;\nconst GRAD_SLOT_U: u32 = {u}u;\n\
             const GRAD_SLOT_P: u32 = {p}u;\nconst GRAD_SLOT_S: u32 = {s}u;\n\
             const GRAD_SLOT_RHO: u32 = {rho}u;\n",
            self.grad_u, self.grad_p, self.grad_rho, self.shift, self.store_b
        )
    }
}

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    let guard = format!(
        "const B_DET_MIN: f32 = {B_DET_MIN:e};\nconst LAP_PIVOT_MIN: f32 = {LAP_PIVOT_MIN:e};\nconst FREE_SURFACE_DET: f32 = {:e};\n{}",
        free_surface_det(c),
        GradientFields::of(c).layout_wgsl()
    );
    let mut particles = vec![
        (pb::POS, Access::Read),
        (pb::VEL, Access::Read),
        (pb::RHO, Access::Read),
        (pb::PRESS, Access::Read),
        (pb::ID, Access::Read),
        (pb::BMAT, Access::ReadWrite),
        (pb::GRADS, Access::ReadWrite),
    ];
    let store = if c.uses_b_hat() {
        particles.push((pb::BHAT, Access::ReadWrite));
        STORE_BHAT_WGSL
    } else {
        NO_BHAT_WGSL
    };
    let (smoothing, smoothing_binding) = smoothing_wgsl(c);
    particles.extend(smoothing_binding);
    let (porosity, porosity_binding) = porosity_wgsl(c);
    particles.extend(porosity_binding);
    SphKernel::new(
        gpu,
        "sph: joubert2020_gradients",
        &[
            &consts,
            &guard,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            kernel_library(),
            store,
            smoothing,
            porosity,
            &dense_team_wgsl(c.dense_lanes),
            GRADIENTS_WGSL,
        ],
        "gradients",
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

/// 3×3 matrix, row-major: `m[row][col]`.
pub type Mat3 = [[f64; 3]; 3];

/// The gradient pass's results for one fluid particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gradients {
    /// `B_i` (identity when near-singular).
    pub b: Mat3,
    /// `det M_i < B_DET_MIN`.
    pub singular: bool,
    /// `grad_u[a]` = corrected gradient of `u_a`.
    pub grad_u: [[f64; 3]; 3],
    /// Corrected pressure gradient, Pa/m.
    pub grad_p: [f64; 3],
    /// `s_i = r̄_i² Σ e_ij / r_ij²` (dimensionless).
    pub shift: [f64; 3],
    /// Corrected gradient of the intrinsic density ρ/ε (ρ without grains), kg/m⁴: δ-SPH's.
    pub grad_rho: [f64; 3],
}

pub fn mat_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| dot(m[r], v))
}

pub fn determinant(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// `m⁻¹` by the adjugate (`det` must be non-zero).
pub fn inverse(m: &Mat3) -> Mat3 {
    let d = determinant(m);
    let c =
        |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    [
        [c(1, 1, 2, 2) / d, -c(0, 1, 2, 2) / d, c(0, 1, 1, 2) / d],
        [-c(1, 0, 2, 2) / d, c(0, 0, 2, 2) / d, -c(0, 0, 1, 2) / d],
        [c(1, 0, 2, 1) / d, -c(0, 0, 2, 1) / d, c(0, 0, 1, 1) / d],
    ]
}

/// Particle `i`'s truncation matrix read the two ways the CPU twins use it, from one
/// pass over its neighbours.
#[derive(Debug, Clone, Copy)]
pub struct Truncation {
    /// `B_i = M_i⁻¹`, or I where `M_i` is near-singular.
    pub b: Mat3,
    /// `M_i` was near-singular (`det < B_DET_MIN`): `b` is I.
    pub singular: bool,
    /// In the free-surface zone: the switch is on and `det M_i <` [`free_surface_det`]
    /// (the gradient pass's flag).
    pub near_free_surface: bool,
}

/// CPU twin of the gradient pass's `B_i`, fallback and free-surface flag.
pub fn truncation_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> Truncation {
    let mut m = [[0.0; 3]; 3];
    let k = kernel_at(c, set, i);
    for j in set.neighbours(i, k.radius(), c.period) {
        add_to_truncation(
            &mut m,
            &k,
            set.mass[j] / set.rho[j],
            c.pair_vec(set.pos[i], set.pos[j]),
        );
    }
    let det = determinant(&m);
    let singular = det < B_DET_MIN;
    Truncation {
        b: if singular {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        } else {
            inverse(&m)
        },
        singular,
        near_free_surface: c.free_surface && det < free_surface_det(c),
    }
}

/// The truncation matrix `M_i = −Σ_j V_j ∇W_ij ⊗ r_ij` and `B_i` (see the module doc).
pub fn b_matrix_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> (Mat3, bool) {
    let t = truncation_cpu(c, set, i);
    (t.b, t.singular)
}

/// Adds neighbour j's term `−V_j ∇W_ij ⊗ r_ij` to `M_i` (Joubert eq. 10).
fn add_to_truncation(m: &mut Mat3, k: &SmoothingKernel, v_j: f64, r_ij: [f64; 3]) {
    let g = k.grad(r_ij);
    for (a, row) in m.iter_mut().enumerate() {
        for (b, x) in row.iter_mut().enumerate() {
            *x -= v_j * g[a] * r_ij[b];
        }
    }
}

/// CPU twin of the gradient pass for every entry (`None` for non-fluid entries).
pub fn gradients_cpu(c: &SphConstants, set: &ParticleSet) -> Vec<Option<Gradients>> {
    gradients_among_grains_cpu(c, set, None)
}

/// [`gradients_cpu`] among unresolved grains: `grad_rho` is the gradient of the
/// intrinsic density ρ/ε, with `porosity` ε at every entry of `set` (`None`: 1).
pub fn gradients_among_grains_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    porosity: Option<&[f64]>,
) -> Vec<Option<Gradients>> {
    let intrinsic = |k: usize| set.rho[k] / porosity.map_or(1.0, |e| e[k]);
    (0..set.len())
        .map(|i| {
            if set.kinds.kind(set.id[i]) != Kind::Fluid {
                return None;
            }
            let (b, singular) = b_matrix_cpu(c, set, i);
            let mut raw = [[0.0; 3]; 5];
            let (mut r_sum, mut count, mut s) = (0.0, 0.0, [0.0; 3]);
            let k_i = kernel_at(c, set, i);
            for j in set.neighbours(i, k_i.radius(), c.period) {
                let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
                let r2 = dot(r_ij, r_ij);
                let g = k_i.grad(r_ij);
                let v = set.mass[j] / set.rho[j];
                let df = [
                    set.vel[j][0] - set.vel[i][0],
                    set.vel[j][1] - set.vel[i][1],
                    set.vel[j][2] - set.vel[i][2],
                    set.press[j] - set.press[i],
                    intrinsic(j) - intrinsic(i),
                ];
                for (f, acc) in raw.iter_mut().enumerate() {
                    for k in 0..3 {
                        acc[k] += v * df[f] * g[k];
                    }
                }
                let r = r2.sqrt();
                r_sum += r;
                count += 1.0;
                // Each neighbour counts as the lattice particles it stands for: among
                // grains a lattice particle's mass is ε m0.
                let w = set.mass[j] / (c.mass * porosity.map_or(1.0, |e| e[j]));
                for k in 0..3 {
                    s[k] += w * r_ij[k] / (r2 * r);
                }
            }
            let r_mean = if count > 0.0 { r_sum / count } else { 0.0 };
            Some(Gradients {
                b,
                singular,
                grad_u: [
                    mat_vec(&b, raw[0]),
                    mat_vec(&b, raw[1]),
                    mat_vec(&b, raw[2]),
                ],
                grad_p: mat_vec(&b, raw[3]),
                shift: s.map(|x| r_mean * r_mean * x),
                grad_rho: mat_vec(&b, raw[4]),
            })
        })
        .collect()
}

/// CPU twin of the corrected Laplacian's truncation (Joubert eq. 11; the sums are in
/// the WGSL header): the symmetric B̂_i with B̂ : Ĉ_i = −I on symmetric Hessians, from
/// `b` = B_i. `(I, true)` when B_i fell back (`b_singular`) or a pivot is below
/// [`LAP_PIVOT_MIN`] of the largest entry.
pub fn laplacian_b_hat_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    b: &Mat3,
    b_singular: bool,
) -> (Mat3, bool) {
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if b_singular {
        return (identity, true);
    }
    let pairs = |e: [f64; 3]| {
        [
            e[0] * e[0],
            e[1] * e[1],
            e[2] * e[2],
            e[0] * e[1],
            e[0] * e[2],
            e[1] * e[2],
        ]
    };
    let (mut c1, mut p, mut r_) = ([[0.0; 6]; 6], [[0.0; 3]; 6], [[0.0; 3]; 6]);
    for j in set.neighbours(i, c.support_radius(), c.period) {
        let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
        let r = dot(r_ij, r_ij).sqrt();
        let e = r_ij.map(|x| x / r);
        // ∇W = F r_ij: F = (∇W)_k / r_k on any non-zero component.
        let g = c.kernel.grad(r_ij);
        let f = dot(g, r_ij) / (r * r);
        let vf = set.mass[j] / set.rho[j] * f;
        let q = pairs(e);
        for a in 0..6 {
            for b2 in 0..6 {
                c1[a][b2] += vf * r * r * q[a] * q[b2];
            }
            for k in 0..3 {
                p[a][k] += vf * r * r * r * q[a] * e[k];
                r_[a][k] += vf * r * q[a] * e[k];
            }
        }
    }
    let mut a = [[0.0; 6]; 6];
    for row in 0..6 {
        let bp = mat_vec(b, p[row]);
        for col in 0..6 {
            let mult = if col < 3 { 1.0 } else { 2.0 };
            a[row][col] = mult * (c1[row][col] + dot(r_[col], bp));
        }
    }
    let mut x = [-1.0, -1.0, -1.0, 0.0, 0.0, 0.0];
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..6 {
        let piv = (col..6)
            .max_by(|&r1, &r2| a[r1][col].abs().total_cmp(&a[r2][col].abs()))
            .expect("non-empty");
        if !(a[piv][col].abs() > LAP_PIVOT_MIN * scale) {
            return (identity, true);
        }
        a.swap(col, piv);
        x.swap(col, piv);
        for row in col + 1..6 {
            let f = a[row][col] / a[col][col];
            for k in col..6 {
                a[row][k] -= f * a[col][k];
            }
            x[row] -= f * x[col];
        }
    }
    for row in (0..6).rev() {
        let tail: f64 = (row + 1..6).map(|k| a[row][k] * x[k]).sum();
        x[row] = (x[row] - tail) / a[row][row];
    }
    (
        [[x[0], x[3], x[4]], [x[3], x[1], x[5]], [x[4], x[5], x[2]]],
        false,
    )
}
