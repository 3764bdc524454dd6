//! Smoothing kernels: Wendland C2 (Wendland 1995) and the quintic spline of Joubert
//! eq. (6) (Morris, Fox & Zhu 1997), with their gradients. The WGSL side is
//! `shaders/kernel.wgsl`; [`SmoothingKernel`] is its CPU `f64` twin and the one place the
//! normalisation constants live (they are generated into WGSL by
//! [`crate::constants::SphConstants::wgsl`]).
//!
//! Both kernels are written as `W(r) = σ f(q)`, `q = r/h`, and the gradient as
//! `∇_i W(r_i − r_j) = F(r) r_ij` with `F(r) = W'(r)/r`: the pair kernels multiply
//! `F` by `r_ij` and never normalise `r_ij` themselves.

use couplet_protocol::KernelKind;
use std::f64::consts::PI;

/// Wendland C2 in 3D: `σ = 21/(16 π h³)` for `W = σ (1 − q/2)⁴ (2q + 1)`, `q ∈ [0, 2]`
/// (Dehnen & Aly 2012, Table 1, rescaled to support 2h).
pub const WENDLAND_C2_SIGMA_H3: f64 = 21.0 / (16.0 * PI);

/// Quintic spline in 3D: `σ = 1/(120 π h³)`, the exact normalisation of
/// `(3−q)⁵ − 6(2−q)⁵ + 15(1−q)⁵` (`∫ W dV = 4π σ h³ (3⁸ − 6·2⁸ + 15)/168 = 120 π σ h³`).
///
/// Joubert (2020) quotes `σ = 3/(359 π h³)` after Liu & Liu's book; that constant is
/// 0.28 % too large (`∫ W dV = 360/359`), so it would break the normalisation test at
/// 1e-3. [`JOUBERT_QUINTIC_SIGMA_H3`] keeps the quoted value for that comparison.
pub const QUINTIC_SIGMA_H3: f64 = 1.0 / (120.0 * PI);

/// The quintic normalisation as printed in Joubert (2020) below eq. (6).
pub const JOUBERT_QUINTIC_SIGMA_H3: f64 = 3.0 / (359.0 * PI);

/// A kernel with its smoothing length; CPU twin of `shaders/kernel.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothingKernel {
    pub kind: KernelKind,
    /// Smoothing length h, m.
    pub h: f64,
    /// Normalisation σ, 1/m³.
    pub sigma: f64,
}

impl SmoothingKernel {
    pub fn new(kind: KernelKind, h: f64) -> Self {
        let sigma_h3 = match kind {
            KernelKind::WendlandC2 => WENDLAND_C2_SIGMA_H3,
            KernelKind::Quintic => QUINTIC_SIGMA_H3,
        };
        Self {
            kind,
            h,
            sigma: sigma_h3 / (h * h * h),
        }
    }

    /// Support radius, m: 2h (Wendland C2) or 3h (quintic).
    pub fn radius(&self) -> f64 {
        self.kind.radius_in_h() * self.h
    }

    /// W(r), 1/m³.
    pub fn w(&self, r: f64) -> f64 {
        let q = r / self.h;
        match self.kind {
            KernelKind::WendlandC2 => {
                let t = (1.0 - 0.5 * q).max(0.0);
                self.sigma * t.powi(4) * (2.0 * q + 1.0)
            }
            // Joubert eq. (6), with Morris's alternating signs.
            KernelKind::Quintic => {
                let a = (3.0 - q).max(0.0);
                let b = (2.0 - q).max(0.0);
                let c = (1.0 - q).max(0.0);
                self.sigma * (a.powi(5) - 6.0 * b.powi(5) + 15.0 * c.powi(5))
            }
        }
    }

    /// dW/dr, 1/m⁴.
    pub fn dw_dr(&self, r: f64) -> f64 {
        let q = r / self.h;
        match self.kind {
            // d/dq[(1 − q/2)⁴ (2q + 1)] = −5 q (1 − q/2)³
            KernelKind::WendlandC2 => {
                let t = (1.0 - 0.5 * q).max(0.0);
                self.sigma / self.h * (-5.0 * q * t.powi(3))
            }
            KernelKind::Quintic => {
                let a = (3.0 - q).max(0.0);
                let b = (2.0 - q).max(0.0);
                let c = (1.0 - q).max(0.0);
                self.sigma / self.h * (-5.0 * a.powi(4) + 30.0 * b.powi(4) - 75.0 * c.powi(4))
            }
        }
    }

    /// F(r) = W'(r)/r, so that ∇_i W_ij = F(r_ij) r_ij; finite at r = 0.
    pub fn grad_factor(&self, r: f64) -> f64 {
        match self.kind {
            KernelKind::WendlandC2 => {
                let t = (1.0 - 0.5 * r / self.h).max(0.0);
                -5.0 * self.sigma / (self.h * self.h) * t.powi(3)
            }
            KernelKind::Quintic => {
                let q = r / self.h;
                if q <= 1.0 {
                    // The q ≤ 1 bracket of dw_dr divided by q, expanded exactly (no
                    // cancellation near q = 0; same form as kernel.wgsl).
                    self.sigma / (self.h * self.h) * ((-50.0 * q + 120.0) * q * q - 120.0)
                } else {
                    self.dw_dr(r) / r
                }
            }
        }
    }

    /// ∇_i W(r_i − r_j) for `r_ij = r_i − r_j`, 1/m⁴.
    pub fn grad(&self, r_ij: [f64; 3]) -> [f64; 3] {
        let r = norm(r_ij);
        let f = self.grad_factor(r);
        [f * r_ij[0], f * r_ij[1], f * r_ij[2]]
    }
}

pub(crate) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `shaders/kernel.wgsl`: the library part (`kernel_w`, `kernel_grad_factor`) that pair
/// kernels include.
pub const KERNEL_WGSL: &str = include_str!("../shaders/kernel.wgsl");

/// The library part of [`KERNEL_WGSL`].
pub fn kernel_library() -> &'static str {
    crate::sph_kernel::library(KERNEL_WGSL)
}

/// Compiles `kernel_eval` (W and F for a list of distances; the kernel's twin test).
/// Group 0: binding 0 = distances (`f32`), binding 1 = output (`vec2<f32>`: W, F).
pub fn eval_kernel(
    gpu: &crate::gpu::Gpu,
    c: &crate::constants::SphConstants,
) -> crate::sph_kernel::SphKernel {
    use crate::sph_kernel::{Access, PARTICLES, SphKernel};
    let consts = c.wgsl();
    SphKernel::new(
        gpu,
        "sph: kernel_eval",
        &[&consts, KERNEL_WGSL],
        "kernel_eval",
        &[(PARTICLES, &[(0, Access::Read), (1, Access::ReadWrite)])],
        None,
    )
}
