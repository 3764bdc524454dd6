//! Body markers from the DEM's coupling points (Joubert §2.6).
//!
//! Points arrive once per window in DEM order (contiguous per body) and are uploaded
//! as they are into `markers_in` (positions made relative to the solver origin). One
//! pass over all particles writes position and velocity into the marker particles by
//! `id − marker_base` (the grid permutes particles, so they are found by id). Inside the
//! window a marker moves with its own velocity, `x = x_n + v τ`; the body's rotation
//! inside a window is neglected (an error of order ω Δt_w in the marker velocity
//! direction). WGSL: `shaders/marker_update.wgsl` (`marker_update`, `advance_clock`).

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, particle_binding as pb,
};
use couplet_protocol::CouplingPoint;

pub const MARKER_UPDATE_WGSL: &str = include_str!("../shaders/marker_update.wgsl");

/// GPU mirror of `Marker` in marker_update.wgsl (the layout of `CouplingPoint`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuMarker {
    /// Position relative to the origin, m; w = area ΔS, m².
    pub pos_area: [f32; 4],
    /// Velocity, m/s; w = body index (bits of a u32).
    pub vel_body: [f32; 4],
    /// Outward unit normal; w unused.
    pub normal: [f32; 4],
}

/// GPU mirror of `Body` in marker_update.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuBody {
    /// Centre of mass relative to the origin, m.
    pub cg: [f32; 4],
    /// Velocity of the centre of mass, m/s.
    pub vel: [f32; 4],
}

/// GPU mirror of `Clock` in marker_update.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Clock {
    /// Time since the window start, s.
    pub tau: f32,
    pub substep: u32,
    pub _pad: [u32; 2],
}

const _: () = {
    assert!(std::mem::size_of::<GpuMarker>() == std::mem::size_of::<CouplingPoint>());
    assert!(std::mem::size_of::<GpuBody>() == 32);
    assert!(std::mem::size_of::<Clock>() == 16);
};

impl GpuMarker {
    /// The GPU form of a coupling point, its position made relative to `origin` (in f64
    /// before rounding, so that no digits are lost far from the world origin).
    pub fn from_point(p: &CouplingPoint, origin: [f64; 3]) -> Self {
        let rel = |k: usize| (f64::from(p.position[k]) - origin[k]) as f32;
        GpuMarker {
            pos_area: [rel(0), rel(1), rel(2), p.measure],
            vel_body: [
                p.velocity[0],
                p.velocity[1],
                p.velocity[2],
                f32::from_bits(p.body),
            ],
            normal: [p.normal[0], p.normal[1], p.normal[2], 0.0],
        }
    }
}

pub fn marker_update_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: marker_update",
        &[&consts, STEP_PARAMS_WGSL, MARKER_UPDATE_WGSL],
        "marker_update",
        &[
            (
                PARTICLES,
                &[
                    (pb::POS, Access::ReadWrite),
                    (pb::VEL, Access::ReadWrite),
                    (pb::ID, Access::Read),
                ],
            ),
            (
                BODIES,
                &[
                    (bb::MARKERS_IN, Access::Read),
                    (bb::CLOCK, Access::ReadWrite),
                ],
            ),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        None,
    )
}

pub fn advance_clock_kernel(gpu: &Gpu, c: &SphConstants) -> SphKernel {
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: advance_clock",
        &[&consts, STEP_PARAMS_WGSL, MARKER_UPDATE_WGSL],
        "advance_clock",
        &[
            (BODIES, &[(bb::CLOCK, Access::ReadWrite)]),
            (PARAMS, &[(0, Access::Uniform)]),
        ],
        None,
    )
}

/// CPU twin: position and velocity of marker `k` at time τ into the window.
pub fn marker_at(p: &CouplingPoint, tau: f64) -> ([f64; 3], [f64; 3]) {
    let v = p.velocity.map(f64::from);
    (
        std::array::from_fn(|k| f64::from(p.position[k]) + tau * v[k]),
        v,
    )
}
