//! Body markers from the DEM's coupling points (Joubert §2.6).
//!
//! Points arrive once per window in DEM order (contiguous per body) and are uploaded
//! as they are into `markers_in` (positions made relative to the solver origin). One
//! pass over all particles writes position and velocity into the marker particles by
//! `id − marker_base` (the grid permutes particles, so they are found by id). Inside the
//! window a marker moves with its own velocity, `x = x_n + v τ`; the body's rotation
//! inside a window is neglected (an error of order ω Δt_w in the marker velocity
//! direction). WGSL: `shaders/marker_update.wgsl` (`marker_update`, `advance_clock`).
//!
//! The acceleration of each surface point, which Joubert eq. (25) needs for the marker
//! pressure, is the time derivative of eq. (33): `a + α × r + ω × (ω × r)`
//! ([`point_acceleration`]). The DEM sends velocities only; [`AccelerationEstimate`]
//! takes `a` and `α` as the change of the body's velocities over the previous window,
//! the mean acceleration the DEM integrated there — lagged by one window, the same lag
//! as the explicit scheme's loads.

use crate::constants::{STEP_PARAMS_WGSL, SphConstants};
use crate::gpu::Gpu;
use crate::sph_kernel::{
    Access, BODIES, PARAMS, PARTICLES, SphKernel, body_binding as bb, particle_binding as pb,
};
use couplet_protocol::vec3::cross;
use couplet_protocol::{BodyState, CouplingPoint};

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

/// The mass a coupling point of `measure` ΔS carries in the fluid's sums (`pos.w`): the
/// slab of fluid it stands for, ρ0 ΔS δ, so that markers packed closer than δ (a face
/// under δ²/2 is one marker) do not make a denser wall; a fill point (ΔS = 0) is a
/// lattice point, ρ0 δ³. ARCHITECTURE.md, "A marker weighs as the fluid slab it stands
/// for".
pub fn marker_mass(c: &SphConstants, measure: f32) -> f64 {
    let d = c.spacing;
    let volume = if measure > 0.0 {
        f64::from(measure) * d
    } else {
        d * d * d
    };
    c.rho0 * volume
}

/// CPU twin: position and velocity of marker `k` at time τ into the window.
pub fn marker_at(p: &CouplingPoint, tau: f64) -> ([f64; 3], [f64; 3]) {
    let v = p.velocity.map(f64::from);
    (
        std::array::from_fn(|k| f64::from(p.position[k]) + tau * v[k]),
        v,
    )
}

/// Linear and angular acceleration of one body (world frame).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyAcceleration {
    /// Of the centre of mass, m/s².
    pub linear: [f64; 3],
    /// rad/s².
    pub angular: [f64; 3],
}

/// Acceleration of the body-fixed point at `r` from the centre of mass: the time
/// derivative of Joubert eq. (33), `a + α × r + ω × (ω × r)`.
pub fn point_acceleration(acc: &BodyAcceleration, omega: [f64; 3], r: [f64; 3]) -> [f64; 3] {
    let tangential = cross(acc.angular, r);
    let centripetal = cross(omega, cross(omega, r));
    std::array::from_fn(|k| acc.linear[k] + tangential[k] + centripetal[k])
}

/// Body accelerations from the velocities of consecutive windows: at window start
/// `t_n`, `(v_n − v_m)/(t_n − t_m)` and `(ω_n − ω_m)/(t_n − t_m)` with `t_m` the
/// previous window start (zero for a body seen for the first time). Indexed like the
/// body states it was given.
#[derive(Debug, Default, Clone, serde::Serialize, serde::Deserialize)]
pub struct AccelerationEstimate {
    /// Per body index: the velocities at the last update.
    last: Vec<Option<VelocitySample>>,
}

#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
struct VelocitySample {
    t: f64,
    linear: [f64; 3],
    angular: [f64; 3],
}

impl AccelerationEstimate {
    /// The accelerations of `states` (at time `t`), in their order, and remembers them.
    /// A repeated `t` (no time passed) gives the previous estimate's inputs again: zero.
    pub fn update(&mut self, t: f64, states: &[BodyState]) -> Vec<BodyAcceleration> {
        states
            .iter()
            .map(|s| {
                let b = s.body as usize;
                if self.last.len() <= b {
                    self.last.resize(b + 1, None);
                }
                let acc = match self.last[b] {
                    Some(last) if t > last.t => BodyAcceleration {
                        linear: std::array::from_fn(|k| {
                            (s.linear_velocity[k] - last.linear[k]) / (t - last.t)
                        }),
                        angular: std::array::from_fn(|k| {
                            (s.angular_velocity[k] - last.angular[k]) / (t - last.t)
                        }),
                    },
                    _ => BodyAcceleration::default(),
                };
                self.last[b] = Some(VelocitySample {
                    t,
                    linear: s.linear_velocity,
                    angular: s.angular_velocity,
                });
                acc
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body turning at constant ω about z with α about x: the point's acceleration is
    /// a + α × r − ω² r_⊥ (r_⊥ the part of r normal to ω). Reference: hand-evaluated
    /// cross products, exact in f64.
    #[test]
    fn point_acceleration_is_rigid_body_kinematics() {
        let acc = BodyAcceleration {
            linear: [0.5, -1.0, 2.0],
            angular: [3.0, 0.0, 0.0],
        };
        let omega = [0.0, 0.0, 4.0];
        let r = [0.1, 0.2, 0.3];
        // α × r = (3,0,0) × (0.1,0.2,0.3) = (0, −0.9, 0.6); −ω² r_⊥ = −16 (0.1, 0.2, 0).
        let want = [0.5 - 1.6, -1.0 - 0.9 - 3.2, 2.0 + 0.6];
        let got = point_acceleration(&acc, omega, r);
        for k in 0..3 {
            assert!((got[k] - want[k]).abs() < 1e-12, "{got:?} vs {want:?}");
        }
    }

    /// Velocities 0, 1, 3 m/s at t = 0, 0.5, 1 s: no estimate at the first window, then
    /// 2 and 4 m/s²; a body first seen later starts at zero. Reference: the differences.
    #[test]
    fn acceleration_estimate_differences_consecutive_windows() {
        let state = |body: u32, v: f64| BodyState {
            body,
            linear_velocity: [0.0, v, 0.0],
            angular_velocity: [v, 0.0, 0.0],
            ..Default::default()
        };
        let mut e = AccelerationEstimate::default();
        assert_eq!(
            e.update(0.0, &[state(0, 0.0)])[0],
            BodyAcceleration::default()
        );
        let a = e.update(0.5, &[state(0, 1.0), state(2, 7.0)]);
        assert_eq!(a[0].linear, [0.0, 2.0, 0.0]);
        assert_eq!(a[0].angular, [2.0, 0.0, 0.0]);
        assert_eq!(a[1], BodyAcceleration::default());
        let a = e.update(1.0, &[state(0, 3.0)]);
        assert_eq!(a[0].linear, [0.0, 4.0, 0.0]);
    }
}
