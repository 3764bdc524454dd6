//! Momentum equation of standard WCSPH (the uncorrected analogue of Joubert eq. 13):
//!
//! `du_i/dt = −Σ_j m_j (p_i/ρ_i² + p_j/ρ_j²) ∇W_ij`
//! `        + Σ_j m_j (μ_i + μ_j) r_ij·∇W_ij / (ρ_i ρ_j (r_ij² + 0.01 h²)) (u_i − u_j)` (Morris, Fox & Zhu 1997, eq. 8; μ = ρν; only with `effects.viscosity = "laminar"`)
//! `        − Σ_j m_j Π_ij ∇W_ij` (Monaghan 1992, α = `effects.artificial_viscosity`, only if > 0)
//! `        + g` (only with `gravity.on_fluid`).
//!
//! With `effects.gradient_correction` the pressure part is Joubert eq. (13)'s
//! `−(1/ρ_i) Σ_j V_j (p_j − p_i) B_i ∇W_ij` (`V_j = m/ρ_j`); the viscous terms stay Morris's.
//!
//! With `effects.variable_smoothing_length` the standard pressure part is Robinson eq.
//! (12), `−Σ_j m_j (p_i/(Ω_i ρ_i²) ∇W(h_i) + p_j/(Ω_j ρ_j²) ∇W(h_j))`, the corrected one
//! takes `∇W(h_i)`, and the viscous terms the mean `(∇W(h_i) + ∇W(h_j))/2`
//! ([`crate::robinson_variable_h`]).
//!
//! Free-slip walls do not enter the viscous sums; no-slip walls enter them with the
//! velocity 2 v_w − ṽ_w of Adami et al. (2012) (see
//! [`crate::adami2012_boundary_pressure`]); markers (body surfaces) always enter them
//! with the body's velocity.
//! WGSL: `shaders/momentum.wgsl` (pair terms); the pair loop is [`crate::fluid_rates`].

use crate::adami2012_boundary_pressure::wall_velocity_cpu;
use crate::constants::SphConstants;
use crate::joubert2020_gradients::{laplacian_b_hat_cpu, mat_vec, truncation_cpu};
use crate::particles::{Kind, ParticleSet, dot, sub};
use crate::robinson_variable_h::{kernel_at, omega_cpu, pair_neighbours};

pub const MOMENTUM_WGSL: &str = include_str!("../shaders/momentum.wgsl");

/// CPU twin: du/dt of particle (entry) `i`.
pub fn momentum_cpu(c: &SphConstants, set: &ParticleSet, i: usize) -> [f64; 3] {
    let mut acc = [0.0; 3];
    let (rho_i, p_i) = (set.rho[i], set.press[i]);
    let eta2 = crate::constants::VISCOUS_ETA2_H2 * c.kernel.h * c.kernel.h;
    let t = c.uses_b_matrix().then(|| truncation_cpu(c, set, i));
    let b = t
        .filter(|t| c.gradient_correction && !t.near_free_surface)
        .map(|t| t.b);
    // Corrected Laplacian (Joubert eq. 13): A = Σ V s (u_i − u_j)/r, Q = Σ V s e,
    // D[k][b] = Σ V (u_j − u_i)_k ∇W_b, term 2ν (A − D Bᵀ Q) (see fluid_rates.wgsl).
    let lap = t
        .filter(|_| c.laplacian_correction)
        .map(|t| (t.b, laplacian_b_hat_cpu(c, set, i, &t.b, t.singular).0));
    let (mut lap_a, mut lap_q, mut lap_d) = ([0.0; 3], [0.0; 3], [[0.0; 3]; 3]);
    // Variable h (Robinson eq. 12): each side's own kernel and Ω; the viscous terms take
    // the mean gradient. With one h all three gradients are c.kernel's and Ω = 1.
    let k_i = kernel_at(c, set, i);
    let q_i = p_i / omega_cpu(c, set, i);
    for j in pair_neighbours(c, set, i) {
        let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
        let r2 = dot(r_ij, r_ij);
        let g = k_i.grad(r_ij);
        let g_j = kernel_at(c, set, j).grad(r_ij);
        let g_visc: [f64; 3] = std::array::from_fn(|k| 0.5 * (g[k] + g_j[k]));
        let (rho_j, p_j) = (set.rho[j], set.press[j]);
        let q_j = p_j / omega_cpu(c, set, j);
        let u_ij = sub(set.vel[i], set.vel[j]);
        let mut add: [f64; 3] = match &b {
            Some(b) => mat_vec(b, g).map(|x| -set.mass[j] / (rho_i * rho_j) * (p_j - p_i) * x),
            None => std::array::from_fn(|k| {
                -set.mass[j] * (q_i / (rho_i * rho_i) * g[k] + q_j / (rho_j * rho_j) * g_j[k])
            }),
        };
        let wall = set.kinds.kind(set.id[j]) == Kind::Wall;
        let viscous = c.no_slip_walls || !wall;
        let u_visc = if wall && c.wall_velocity_extrapolation {
            sub(set.vel[i], wall_velocity_cpu(c, set, j))
        } else {
            u_ij
        };
        if let (Some((_, bhat)), true) = (&lap, viscous) {
            let r = r2.sqrt();
            let e = r_ij.map(|x| x / r);
            let v_j = set.mass[j] / rho_j;
            let vs = v_j * dot(e, mat_vec(bhat, g));
            for k in 0..3 {
                lap_a[k] += vs / r * u_visc[k];
                lap_q[k] += vs * e[k];
                for b2 in 0..3 {
                    lap_d[k][b2] -= v_j * u_visc[k] * g[b2];
                }
            }
        } else if c.laminar && viscous {
            // Morris, Fox & Zhu (1997) eq. (8).
            let f = set.mass[j] * c.nu * (rho_i + rho_j) * dot(r_ij, g_visc)
                / (rho_i * rho_j * (r2 + eta2));
            for k in 0..3 {
                add[k] += f * u_visc[k];
            }
        }
        if c.alpha > 0.0 && viscous {
            let vr = dot(u_visc, r_ij);
            if vr < 0.0 {
                // Monaghan (1992) eqs. (4.1)–(4.2), β = 0.
                let mu_ij = c.kernel.h * vr / (r2 + eta2);
                let pi_ij = -c.alpha * c.sound_speed * mu_ij / (0.5 * (rho_i + rho_j));
                for k in 0..3 {
                    add[k] += -set.mass[j] * pi_ij * g_visc[k];
                }
            }
        }
        for k in 0..3 {
            acc[k] += add[k];
        }
    }
    if let Some((bm, _)) = &lap {
        // Bᵀ Q, then D (Bᵀ Q).
        let btq: [f64; 3] = std::array::from_fn(|b2| (0..3).map(|a| bm[a][b2] * lap_q[a]).sum());
        for k in 0..3 {
            acc[k] += 2.0 * c.nu * (lap_a[k] - dot(lap_d[k], btq));
        }
    }
    let g = c.gravity_fluid;
    [acc[0] + g[0], acc[1] + g[1], acc[2] + g[2]]
}
