//! The fused pair loop of a fluid particle: continuity ([`crate::continuity`]) and
//! momentum ([`crate::momentum`]) in one pass over the neighbour cells, a team of
//! `SphConstants::dense_lanes` threads per particle (one on a CPU adapter and from
//! 524 288 particles on, `neighbour_grid::dense_team_lanes`), no atomics. WGSL: `shaders/fluid_rates.wgsl`. Switched-off effects are
//! compiled out (constants generated from the scene), so they cost nothing.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::continuity::{CONTINUITY_WGSL, continuity_among_grains_cpu};
use crate::gpu::Gpu;
use crate::joubert2020_gradients::gradients_among_grains_cpu;
use crate::kernel::kernel_library;
use crate::momentum::{MOMENTUM_WGSL, momentum_cpu};
use crate::neighbour_grid::{GRID_COMMON_WGSL, dense_team_wgsl};
use crate::particles::{Kind, ParticleSet};
use crate::porosity::{porosity_pair_wgsl, porosity_wgsl};
use crate::robinson_variable_h::smoothing_wgsl;
use crate::sph_kernel::{Access, PARAMS, PARTICLES, SphKernel, particle_binding as pb};

pub const FLUID_RATES_WGSL: &str = include_str!("../shaders/fluid_rates.wgsl");

const BINDINGS: &[(u32, Access)] = &[
    (pb::POS, Access::Read),
    (pb::VEL, Access::Read),
    (pb::RHO, Access::Read),
    (pb::PRESS, Access::Read),
    (pb::ID, Access::Read),
    (pb::DRHO, Access::ReadWrite),
    (pb::DVEL, Access::ReadWrite),
];
/// `grad_rho(i)`, `grad_p(i)`: ⟨∇ρ⟩ᶜ_i and ⟨∇p⟩ᶜ_i from the gradient pass, bound only
/// with density diffusion or the mass correction (each read only where the scene has
/// it: GradientFields::layout_wgsl gives the slots).
const GRADS_WGSL: &str = "@group(0) @binding(10) var<storage, read> grads: array<vec4<f32>>;
fn grad_rho(i: u32) -> vec3<f32> {
    return grads[GRAD_STRIDE * i + GRAD_SLOT_RHO].xyz;
}
fn grad_p(i: u32) -> vec3<f32> {
    return grads[GRAD_STRIDE * i + GRAD_SLOT_P].xyz;
}
";
/// Without either no gradient buffer is bound (the terms are compiled out).
const NO_GRADS_WGSL: &str = "fn grad_rho(i: u32) -> vec3<f32> {
    return vec3<f32>(0.0);
}
fn grad_p(i: u32) -> vec3<f32> {
    return vec3<f32>(0.0);
}
";

/// `b_matrix(i)`: B_i from the gradient pass's buffer, bound only with the correction on.
const B_MATRIX_WGSL: &str = "@group(0) @binding(9) var<storage, read> bmat: array<vec4<f32>>;
fn b_matrix(i: u32) -> mat3x3<f32> {
    return mat3x3<f32>(bmat[3u * i].xyz, bmat[3u * i + 1u].xyz, bmat[3u * i + 2u].xyz);
}
// The gradient pass's free-surface flag (joubert2020_gradients.rs, FREE_SURFACE_DET).
fn near_free_surface(i: u32) -> bool {
    return bmat[3u * i].w > 0.5;
}
";
/// Without the correction no B buffer exists; the identity keeps the shader's one
/// code path valid (the corrected branch is compiled out by `GRADIENT_CORRECTION`).
const NO_B_MATRIX_WGSL: &str = "fn b_matrix(i: u32) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
}
fn near_free_surface(i: u32) -> bool {
    return false;
}
";

/// `b_hat(i)`: B̂_i of the corrected Laplacian from the gradient pass (symmetric).
const B_HAT_WGSL: &str = "@group(0) @binding(12) var<storage, read> bhat: array<vec4<f32>>;
fn b_hat(i: u32) -> mat3x3<f32> {
    let d = bhat[2u * i];
    let o = bhat[2u * i + 1u];
    return mat3x3<f32>(vec3<f32>(d.x, o.x, o.y), vec3<f32>(o.x, d.y, o.z), vec3<f32>(o.y, o.z, d.z));
}
";
/// Without the corrected Laplacian no B̂ exists (its branch is compiled out).
const NO_B_HAT_WGSL: &str = "fn b_hat(i: u32) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
}
";

/// `wall_velocity(j)`: a wall's velocity in the viscous sums, from the boundary pass.
const WALL_VELOCITY_WGSL: &str =
    "@group(0) @binding(11) var<storage, read> wall_vel: array<vec4<f32>>;
fn wall_velocity(j: u32) -> vec3<f32> {
    return wall_vel[j].xyz;
}
";
/// Without it a wall enters with its own velocity.
const OWN_WALL_VELOCITY_WGSL: &str = "fn wall_velocity(j: u32) -> vec3<f32> {
    return vel[j].xyz;
}
";

pub fn kernel(gpu: &Gpu, c: &SphConstants, grid_layout: &wgpu::BindGroupLayout) -> SphKernel {
    let consts = c.wgsl();
    let grads = c.rates_read_gradients();
    // The B matrix and the gradient buffer are bound only when their effect is on.
    let mut bindings = BINDINGS.to_vec();
    if c.uses_b_matrix() {
        bindings.push((pb::BMAT, Access::Read));
    }
    if grads {
        bindings.push((pb::GRADS, Access::Read));
    }
    let wall_velocity = if c.wall_velocity_extrapolation {
        bindings.push((pb::WALL_VEL, Access::Read));
        WALL_VELOCITY_WGSL
    } else {
        OWN_WALL_VELOCITY_WGSL
    };
    let b = if c.uses_b_matrix() {
        B_MATRIX_WGSL
    } else {
        NO_B_MATRIX_WGSL
    };
    let b_hat = if c.uses_b_hat() {
        bindings.push((pb::BHAT, Access::Read));
        B_HAT_WGSL
    } else {
        NO_B_HAT_WGSL
    };
    let g = if grads {
        format!(
            "{}{GRADS_WGSL}",
            crate::joubert2020_gradients::GradientFields::of(c).layout_wgsl()
        )
    } else {
        NO_GRADS_WGSL.to_owned()
    };
    let (smoothing, smoothing_binding) = smoothing_wgsl(c);
    bindings.extend(smoothing_binding);
    let (porosity, porosity_binding) = porosity_wgsl(c);
    bindings.extend(porosity_binding);
    let (pair, pair_bindings) = porosity_pair_wgsl(c);
    bindings.extend(pair_bindings);
    let team = dense_team_wgsl(c.dense_lanes);
    SphKernel::new(
        gpu,
        "sph: fluid_rates",
        &[
            &consts,
            STEP_PARAMS_WGSL,
            GRID_COMMON_WGSL,
            kernel_library(),
            CONTINUITY_WGSL,
            MOMENTUM_WGSL,
            b,
            b_hat,
            &g,
            wall_velocity,
            smoothing,
            porosity,
            pair,
            &team,
            FLUID_RATES_WGSL,
        ],
        "fluid_rates",
        &[(PARTICLES, &bindings), (PARAMS, &[(0, Access::Uniform)])],
        Some(grid_layout),
    )
}

/// CPU twin: (dρ/dt, du/dt) of every fluid entry; `None` for other particles. `dt` is
/// the step the rates are taken for (it enters the mass correction only).
pub fn fluid_rates_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    dt: f64,
) -> Vec<Option<(f64, [f64; 3])>> {
    fluid_rates_among_grains_cpu(c, set, dt, None)
}

/// ε and ∇ε at every entry of a set (`PorosityField::porosity` and `::gradient`).
pub struct PorosityAt<'a> {
    pub porosity: &'a [f64],
    pub gradient: &'a [[f64; 3]],
}

/// CPU twin among unresolved grains: as [`fluid_rates_cpu`], and with
/// `coupling.porosity_pressure = "energy-pair"` ([`SphConstants::porosity_pair`]) the
/// pressure sums take P ε (they are the sums of a set whose pressures are P ε) and each
/// fluid entry gains (P/ρ) ∇ε, from `porosity` (required then). δ-SPH diffuses the
/// intrinsic density ρ/ε with `porosity`'s ε (1 without it).
pub fn fluid_rates_among_grains_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    dt: f64,
    porosity: Option<PorosityAt>,
) -> Vec<Option<(f64, [f64; 3])>> {
    let eps = porosity.as_ref().map(|e| e.porosity);
    let grads = if c.rates_read_gradients() {
        gradients_among_grains_cpu(c, set, eps)
    } else {
        Vec::new()
    };
    let pair = porosity.filter(|_| c.porosity_pair).map(|e| {
        let mut scaled = set.clone();
        for (p, eps) in scaled.press.iter_mut().zip(e.porosity) {
            *p *= eps;
        }
        (scaled, e.gradient)
    });
    assert!(
        pair.is_some() || !c.porosity_pair,
        "energy-pair rates need the porosity"
    );
    (0..set.len())
        .map(|i| {
            (set.kinds.kind(set.id[i]) == Kind::Fluid).then(|| {
                let acc = match &pair {
                    Some((scaled, grad)) => {
                        let a = momentum_cpu(c, scaled, i);
                        let s = set.press[i] / set.rho[i];
                        std::array::from_fn(|k| a[k] + s * grad[i][k])
                    }
                    None => momentum_cpu(c, set, i),
                };
                (continuity_among_grains_cpu(c, set, i, &grads, dt, eps), acc)
            })
        })
        .collect()
}
