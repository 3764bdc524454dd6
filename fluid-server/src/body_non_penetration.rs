//! Fluid kept out of resolved bodies. Once per step, after the last position change
//! (the corrector's Joubert eq. 23 and the shift of eq. 17), a fluid particle behind
//! the tangent plane of its nearest surface marker within δ — `d = (x_i − x_m)·n_m < 0`,
//! the inside test the carve-out at the markers' arrival uses — is mirrored back
//! across that plane, `x_i ← x_i − 2 d n_m`, and the inward part of its velocity
//! relative to the marker, `(u_i − u_m)·n_m < 0`, is removed (no energy is added).
//!
//! Why: with the difference form of the pressure gradient (Joubert eq. 13) a pair
//! pushes particle i from a boundary particle j only when p_j > p_i, and the boundary
//! pressure (Adami's extrapolation, or eq. 25) follows the fluid's, so nothing but the
//! compression of i's neighbours stops a particle crossing a boundary a spacing thin.
//! Where two bodies close a gap below δ (the kissing phase of `couplet validate dkt`
//! at r = 2δ), fluid squeezed from the gap slipped between the markers into a body and
//! the run blew up (t = 0.30 s). The correction is not in Joubert; it is counted
//! (`SideReport::reflected`, `/run/windows`, the run summary), so a run that relies on
//! it says so: many reflections mean the gap or the body is under-resolved.
//!
//! The same pass then keeps fluid inside the domain's wall faces
//! ([`SphConstants::wall_faces`]): a particle beyond one is mirrored back across it and
//! loses its velocity into the wall. Why: a body resting on a wall presses the fluid
//! between them through the wall, where nothing pushes it back. The settling-sphere
//! quick (r = 1.25δ) with the mass correction Γ = 2 landed at 0.36 s, one fluid
//! particle under it went through the floor (1 mm below it by 0.41 s), and its density
//! went to NaN at 0.417 s.
//!
//! A scene without resolved bodies runs the wall part alone ([`wall_kernel`]), where it
//! has a wall face. Why: fluid crosses a wall there too once the flow beside it is
//! disturbed (the water–glycerol RTI at α = 0, 2026-12-06: two fluid particles above
//! the lid at 110 ms, after its upper face had turned noisy), and nothing reported it;
//! a particle among the wall layers takes their pressure at a fraction of a spacing.
//! Now it is mirrored back and counted like the rest.
//! WGSL: `shaders/body_non_penetration.wgsl`.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::marker_update::MARKER_UPDATE_WGSL;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, dot, sub};
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, library, param_binding as qb,
    particle_binding as pb,
};

pub const BODY_NON_PENETRATION_WGSL: &str = include_str!("../shaders/body_non_penetration.wgsl");

const PARTICLE_BINDINGS: &[(u32, Access)] = &[
    (pb::POS, Access::ReadWrite),
    (pb::VEL, Access::ReadWrite),
    (pb::ID, Access::Read),
];
const PARAM_BINDINGS: &[(u32, Access)] = &[
    (qb::PARAMS, Access::Uniform),
    (qb::STATUS, Access::ReadWrite),
];

fn build(
    gpu: &Gpu,
    c: &SphConstants,
    label: &'static str,
    entry: &str,
    groups: &[(u32, &[(u32, Access)])],
    grid_layout: Option<&wgpu::BindGroupLayout>,
) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        label,
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            library(MARKER_UPDATE_WGSL),
            BODY_NON_PENETRATION_WGSL,
        ],
        entry,
        groups,
        grid_layout,
    )
}

/// The pass with resolved bodies: their surfaces, then the wall faces.
pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    build(
        gpu,
        c,
        "sph: body_non_penetration",
        "body_non_penetration",
        &[
            (PARTICLES, PARTICLE_BINDINGS),
            (BODIES, &[(bb::MARKERS_IN, Access::Read)]),
            (PARAMS, PARAM_BINDINGS),
        ],
        Some(grid_layout),
    )
}

/// The pass without resolved bodies: the wall faces alone (no markers, no grid).
pub fn wall_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    build(
        gpu,
        c,
        "sph: wall_non_penetration",
        "wall_non_penetration",
        &[(PARTICLES, PARTICLE_BINDINGS), (PARAMS, PARAM_BINDINGS)],
        None,
    )
}

/// What the CPU twin needs of a marker besides the particle arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub normal: [f64; 3],
    /// ΔS, m²; 0 for a fill point (not the surface).
    pub area: f64,
}

/// CPU twin: applies the correction to every fluid particle of `set` (entries in any
/// order, positions relative to the solver origin as [`SphConstants::wall_faces`] are;
/// `markers[k]` describes the marker of id `marker_base + k`), the body surfaces first,
/// then the wall faces, and returns how many particles it moved. A marker across a
/// periodic face is seen as its nearest image, as the kernel sees it.
pub fn non_penetration_cpu(
    c: &SphConstants,
    set: &mut ParticleSet,
    markers: &[SurfacePoint],
) -> u32 {
    let surface = surface_markers(set, markers);
    let mut moved = 0;
    for i in 0..set.len() {
        if set.kinds.kind(set.id[i]) != Kind::Fluid {
            continue;
        }
        let mut this_moved = false;
        if let Some((j, r, n)) = nearest_surface_marker_cpu(c, set, markers, &surface, i) {
            let d = dot(r, n);
            if d < 0.0 {
                set.pos[i] = std::array::from_fn(|k| set.pos[i][k] - 2.0 * d * n[k]);
                let inward = dot(sub(set.vel[i], set.vel[j]), n).min(0.0);
                set.vel[i] = std::array::from_fn(|k| set.vel[i][k] - inward * n[k]);
                this_moved = true;
            }
        }
        for (k, [lo, hi]) in c.wall_faces.into_iter().enumerate() {
            if set.pos[i][k] < lo {
                set.pos[i][k] = 2.0 * lo - set.pos[i][k];
                set.vel[i][k] = set.vel[i][k].max(0.0);
                this_moved = true;
            } else if set.pos[i][k] > hi {
                set.pos[i][k] = 2.0 * hi - set.pos[i][k];
                set.vel[i][k] = set.vel[i][k].min(0.0);
                this_moved = true;
            }
        }
        moved += u32::from(this_moved);
    }
    moved
}

/// The entries of `set` that are surface markers (area > 0; fill points are not the
/// surface), for [`nearest_surface_marker_cpu`].
pub fn surface_markers(set: &ParticleSet, markers: &[SurfacePoint]) -> Vec<usize> {
    let base = set.kinds.marker_base();
    (0..set.len())
        .filter(|&j| {
            set.kinds.kind(set.id[j]) == Kind::Marker
                && markers[set.id[j] as usize - base].area > 0.0
        })
        .collect()
}

/// CPU twin of `nearest_surface_marker` (body_non_penetration.wgsl): of `surface`
/// ([`surface_markers`]), the marker nearest to entry `i` within δ, the first in set
/// order on a tie, as its entry, `r = x_i − x_m` (the nearest image) and its outward
/// normal.
pub fn nearest_surface_marker_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    markers: &[SurfacePoint],
    surface: &[usize],
    i: usize,
) -> Option<(usize, [f64; 3], [f64; 3])> {
    let base = set.kinds.marker_base();
    surface
        .iter()
        .map(|&j| (j, c.pair_vec(set.pos[i], set.pos[j])))
        .filter(|(_, r)| dot(*r, *r) < c.spacing * c.spacing)
        .min_by(|a, b| dot(a.1, a.1).total_cmp(&dot(b.1, b.1)))
        .map(|(j, r)| (j, r, markers[set.id[j] as usize - base].normal))
}
