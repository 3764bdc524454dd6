//! The fluid's time-step limits (Joubert eq. 24), fixed at the start of a run.

use crate::error::FluidError;
use crate::kernel::SmoothingKernel;
use couplet_protocol::{Scene, WallModel};

/// Joubert §2.1: c_s is at least ten times the fastest expected flow, so the expected
/// maximum speed in eq. (24) is taken as c_s/10.
pub const EXPECTED_MACH: f64 = 0.1;

/// Morris, Fox & Zhu (1997) eq. (23): Δt ≤ 0.125 h²/ν for their viscous term.
pub const MORRIS_VISCOUS_FACTOR: f64 = 0.125;

/// Time-step limits of the fluid, s.
///
/// Joubert eq. (24): Δt = s · min(δ_min/(c_s + u_max), δ_min²/ν) with s = `time.cfl` and
/// u_max = c_s/10 (Joubert §2.1). The paper evaluates the limit once, from the expected
/// maximum speed, and keeps Δt fixed for the whole run; so does couplet. The viscous
/// limit is the smaller of eq. (24)'s `s δ_min²/ν` and Morris's `0.125 h²/ν` (the latter
/// binds for the quintic kernel at h = δ, where 0.125 h²/ν < 0.2 δ²/ν).
///
/// δ_min is eq. (24)'s smallest particle spacing: δ, except with Joubert's one-layer walls
/// (`domain.wall_model = "joubert"`), whose layer sits δ/2 from the first fluid row.
/// Measured: with δ there instead, a closed tank at rest under gravity blows up at
/// t = 0.08 s and a driven cavity at 0.07 s (δ = L/20); with δ/2 both run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FluidLimits {
    /// Eq. (24)'s smallest particle spacing, m.
    pub delta_min: f64,
    /// s · δ_min/(c_s + u_max).
    pub dt_acoustic: f64,
    /// min(s δ_min²/ν, 0.125 h²/ν); infinite for an inviscid fluid.
    pub dt_viscous: f64,
    /// min of the two: the fluid step.
    pub dt: f64,
}

impl FluidLimits {
    pub fn from_scene(scene: &Scene) -> Result<Self, FluidError> {
        let f = scene.fluid.as_ref().ok_or(FluidError::NoFluid)?;
        let s = scene.time.cfl;
        let delta = if scene.domain.wall_model == WallModel::Joubert {
            0.5 * f.spacing
        } else {
            f.spacing
        };
        let c = f.sound_speed;
        let u_max = EXPECTED_MACH * c;
        // Joubert eq. (24), acoustic part.
        let dt_acoustic = s * delta / (c + u_max);
        let nu = f.kinematic_viscosity;
        let h = SmoothingKernel::new(f.kernel, f.smoothing_length()).h;
        let dt_viscous = if nu > 0.0 {
            // Joubert eq. (24), viscous part, and Morris (1997) eq. (23).
            (s * delta * delta / nu).min(MORRIS_VISCOUS_FACTOR * h * h / nu)
        } else {
            f64::INFINITY
        };
        Ok(Self {
            delta_min: delta,
            dt_acoustic,
            dt_viscous,
            dt: dt_acoustic.min(dt_viscous),
        })
    }
}
