//! Wall and marker pressure of Adami, Hu & Adams (2012), eq. (27): the uncorrected
//! analogue of Joubert eq. (25),
//!
//! `p_w = [Σ_f p_f W_wf + (g − a_w)·Σ_f ρ_f r_wf W_wf] / Σ_f W_wf`
//!
//! over fluid neighbours f, g the gravity on the fluid (zero when
//! `gravity.on_fluid = false`). a_w = 0: walls are fixed, and in this version markers
//! are treated as moving walls without acceleration (the DEM does not send body
//! accelerations yet). ρ_w from the inverted Tait equation (among unresolved grains times
//! the wall's porosity, with its mass: [`crate::porosity::boundary_state_wgsl`]); no fluid
//! neighbour: p = 0, ρ = ρ0. W is [`SphConstants::wall_kernel`]: the scene's kernel, or
//! with variable h that of the largest h. WGSL: `shaders/adami2012_boundary_pressure.wgsl`.
//!
//! A resolved body's fill point (a marker of area 0 behind the surface; couplet_dem's
//! `fill_points`) extrapolates from the fluid in front of its nearest surface only,
//! `(x_f − x_w)·n_w > 0`: a wall particle sees the fluid across the face it stands behind,
//! and inside a body thinner than two supports a fill point would otherwise mix in the
//! pressure of the body's far side. Taking both sides, the 12-face cylinder of
//! `couplet validate settling-cylinder --quick` (r = 1.25δ, support 3δ) pushed its wake
//! fluid away from the body (its fill, averaging the high front pressure, stood above
//! the wake's), and the wake decompressed and blew up at 0.13 s.
//!
//! With [`SphConstants::wall_velocity_extrapolation`] the same loop gives each wall
//! particle its velocity in the viscous sums, `2 v_w − Σ_f v_f W_wf / Σ_f W_wf`
//! (Adami, Hu & Adams 2012, §2.3; `v_w` without fluid neighbours), in the buffer at
//! `particle_binding::WALL_VEL`. The layers of a symmetry plane
//! ([`SphConstants::adami_symmetry`]) take the fluid's `Σ_f v_f W_wf / Σ_f W_wf` mirrored
//! across the plane instead (its normal component reversed): a mirror image of the
//! fluid, so that a flow along the plane feels no shear from it and one towards it
//! meets its own reflection. Leaving them out of the viscous sums altogether, as a
//! free-slip wall is, does that for the Morris term but not for the corrected
//! Laplacian (Joubert eq. 13), whose first-order sum Σ V s e runs over every viscous
//! neighbour: the floor's drag on the bottom row beside such a plane came out 12 %
//! below mid-way between two (`adami_symmetry_planes_exert_no_shear`).

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::fluid_rows::row_fluid_read_wgsl;
use crate::gpu::Gpu;
use crate::kernel::kernel_library;
use crate::marker_update::MARKER_UPDATE_WGSL;
use crate::neighbour_grid::GRID_COMMON_WGSL;
use crate::particles::{Kind, ParticleSet, dot, sub};
use crate::porosity::boundary_state_wgsl;
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, library,
    particle_binding as pb,
};
use crate::tait_eos::TAIT_EOS_WGSL;

pub const BOUNDARY_PRESSURE_WGSL: &str =
    include_str!("../shaders/adami2012_boundary_pressure.wgsl");

/// `store_wall_velocity`: writes the no-slip wall velocity, bound only when it is used.
const STORE_WALL_VELOCITY_WGSL: &str =
    "@group(0) @binding(11) var<storage, read_write> wall_vel: array<vec4<f32>>;
fn store_wall_velocity(i: u32, v: vec3<f32>) {
    wall_vel[i] = vec4<f32>(v, 0.0);
}
";
/// Without a viscous no-slip wall nothing is stored (and no buffer exists).
const NO_WALL_VELOCITY_WGSL: &str = "fn store_wall_velocity(i: u32, v: vec3<f32>) {}
";

/// `fill_side(i)`: the outward normal of a fill point's nearest surface and 1, or 0 for
/// every other boundary particle (needs the markers, group 2).
const FILL_SIDE_WGSL: &str = "@group(2) @binding(0) var<storage, read> markers_in: array<Marker>;
fn fill_side(i: u32) -> vec4<f32> {
    if !is_marker(id[i]) {
        return vec4<f32>(0.0);
    }
    let m = markers_in[marker_index(id[i])];
    return select(vec4<f32>(0.0), vec4<f32>(m.normal.xyz, 1.0), m.pos_area.w == 0.0);
}
";
/// Without markers no particle is a fill point.
const NO_FILL_SIDE_WGSL: &str = "fn fill_side(i: u32) -> vec4<f32> { return vec4<f32>(0.0); }
";

/// The boundary pass; `fill_side`: bind the markers and extrapolate fill points from one
/// side (a scene with resolved bodies, once they exist).
pub fn kernel(
    gpu: &Gpu,
    c: &SphConstants,
    grid_layout: &wgpu::BindGroupLayout,
    fill_side: bool,
) -> SphKernel {
    let consts = c.wgsl();
    let (state, mut particles) = boundary_state_wgsl(c);
    particles.extend([
        (pb::VEL, Access::Read),
        (pb::RHO, Access::ReadWrite),
        (pb::PRESS, Access::ReadWrite),
        (pb::ID, Access::Read),
        (pb::ROW_FLUID, Access::Read),
    ]);
    let rows = row_fluid_read_wgsl();
    let store = if c.wall_velocity_extrapolation {
        particles.push((pb::WALL_VEL, Access::ReadWrite));
        STORE_WALL_VELOCITY_WGSL
    } else {
        NO_WALL_VELOCITY_WGSL
    };
    let (marker_lib, side, bodies): (&str, &str, &[(u32, Access)]) = if fill_side {
        (
            library(MARKER_UPDATE_WGSL),
            FILL_SIDE_WGSL,
            &[(bb::MARKERS_IN, Access::Read)],
        )
    } else {
        ("", NO_FILL_SIDE_WGSL, &[])
    };
    let mut groups: Vec<(u32, &[(u32, Access)])> =
        vec![(PARTICLES, &particles), (PARAMS, &[(0, Access::Uniform)])];
    if fill_side {
        groups.push((BODIES, bodies));
    }
    SphKernel::new(
        gpu,
        "sph: adami2012_boundary_pressure",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            &rows,
            kernel_library(),
            library(TAIT_EOS_WGSL),
            marker_lib,
            &state,
            store,
            side,
            BOUNDARY_PRESSURE_WGSL,
        ],
        "adami2012_boundary_pressure",
        &groups,
        Some(grid_layout),
    )
}

/// CPU twin: (p, ρ) of every wall or marker entry; `None` for fluid entries.
pub fn boundary_pressure_cpu(c: &SphConstants, set: &ParticleSet) -> Vec<Option<(f64, f64)>> {
    boundary_pressure_with_fill_cpu(c, set, |_| None)
}

/// [`boundary_pressure_cpu`] where `fill_side(i)` gives entry i's nearest-surface normal
/// when it is a fill point (one-sided, as `fill_side` in the WGSL).
pub fn boundary_pressure_with_fill_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    fill_side: impl Fn(usize) -> Option<[f64; 3]>,
) -> Vec<Option<(f64, f64)>> {
    (0..set.len())
        .map(|i| {
            if set.kinds.kind(set.id[i]) == Kind::Fluid {
                return None;
            }
            // No fluid neighbour: p = 0, and ρ(0) = ρ0.
            let p = extrapolate_from_cpu(c, set, i, [0.0; 3], fill_side(i)).map_or(0.0, |(p, _)| p);
            Some((p, c.density(p)))
        })
        .collect()
}

/// Adami et al.'s extrapolation to entry `i`, whose surface accelerates at `a_w`, from
/// its fluid neighbours: the pressure of eq. (27) and the Shepard average of the fluid
/// velocity; `None` without fluid neighbours. Also the fallback of Joubert's boundary
/// values.
pub fn extrapolate_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    a_w: [f64; 3],
) -> Option<(f64, [f64; 3])> {
    extrapolate_from_cpu(c, set, i, a_w, None)
}

/// [`extrapolate_cpu`] over the fluid in front of `side` only, `(x_f − x_i)·side > 0`,
/// when given (a fill point's nearest-surface normal).
pub fn extrapolate_from_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    a_w: [f64; 3],
    side: Option<[f64; 3]>,
) -> Option<(f64, [f64; 3])> {
    let (mut sum_pw, mut sum_rrw, mut sum_vw, mut sum_w) = (0.0, [0.0; 3], [0.0; 3], 0.0);
    let k = c.wall_kernel();
    for j in set.neighbours(i, k.radius(), c.period) {
        if set.kinds.kind(set.id[j]) != Kind::Fluid {
            continue;
        }
        let r_wf = c.pair_vec(set.pos[i], set.pos[j]);
        if side.is_some_and(|n| dot(r_wf, n) >= 0.0) {
            continue;
        }
        let w = k.w(dot(r_wf, r_wf).sqrt());
        sum_pw += set.press[j] * w;
        for k in 0..3 {
            sum_rrw[k] += set.rho[j] * r_wf[k] * w;
            sum_vw[k] += set.vel[j][k] * w;
        }
        sum_w += w;
    }
    (sum_w > 0.0).then(|| {
        (
            (sum_pw + dot(sub(c.gravity_fluid, a_w), sum_rrw)) / sum_w,
            sum_vw.map(|v| v / sum_w),
        )
    })
}

/// CPU twin of the no-slip wall velocity: `2 v_w − Σ_f v_f W_wf / Σ_f W_wf` for wall
/// entry `w` (its own velocity without fluid neighbours); on a symmetry plane's layers
/// the fluid's average mirrored across the plane.
pub fn wall_velocity_cpu(c: &SphConstants, set: &ParticleSet, w: usize) -> [f64; 3] {
    let mirror = c.symmetry_mirror(set.pos[w]);
    match extrapolate_cpu(c, set, w, [0.0; 3]) {
        Some((_, v)) if mirror.iter().any(|m| *m) => {
            std::array::from_fn(|k| if mirror[k] { -v[k] } else { v[k] })
        }
        Some((_, v)) => std::array::from_fn(|k| 2.0 * set.vel[w][k] - v[k]),
        None => set.vel[w],
    }
}
