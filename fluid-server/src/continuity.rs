//! Continuity equation, standard WCSPH form of Joubert eq. (12) without the gradient
//! correction: `dρ_i/dt = Σ_j m_j (u_i − u_j)·∇W_ij` over fluid, wall and marker
//! neighbours. WGSL: `shaders/continuity.wgsl` (the pair term); the pair loop is fused
//! with momentum in [`crate::fluid_rates`] (same neighbours, same ∇W).
//! With `effects.gradient_correction`: Joubert eq. (12) itself,
//! `dρ_i/dt = −ρ_i Σ_j V_j (u_j − u_i)·B_i ∇W_ij`, `V_j = m/ρ_j`, `B_i` from
//! [`crate::joubert2020_gradients`] — except among unresolved grains, where the
//! standard form stays (Robinson eq. 10; why: [`SphConstants::corrected_continuity`]).
//!
//! With `effects.variable_smoothing_length`, Robinson eq. (10): the standard form takes
//! particle i's own kernel and 1/Ω_i ([`crate::robinson_variable_h`]).
//!
//! With `effects.density_diffusion` = δ > 0, δ-SPH (Antuono, Colagrossi, Marrone &
//! Molteni 2010, eq. 5) adds over fluid neighbours `δ h c_s Σ_j V_j ψ_ij·∇W_ij`,
//! `ψ_ij = 2(ρ_j − ρ_i) r_ji/r_ij² − (⟨∇ρ⟩ᶜ_i + ⟨∇ρ⟩ᶜ_j)`, with the renormalised density
//! gradients of the gradient pass (h: the smoothing length of the kernel in use).
//! With `effects.density_diffusion_form = "fourtakas"` the term is Fourtakas,
//! Domínguez, Vacondio & Rogers 2019's instead (DualSPHysics `DensityDT=2`):
//! `ψ_ij = 2(ρ_j − ρ_i − ρ^H_ji) r_ji/r_ij²`, no gradients, with the hydrostatic density
//! difference `ρ^H_ji = ρ0((1 + ρ0 g·r_ji/B)^(1/γ) − 1)` of the equation of state
//! ([`fourtakas2019_hydrostatic_difference`]). Antuono's gradients make the term zero
//! on a hydrostatic field only where the support is complete; Fourtakas's is zero there
//! at a free surface too (`operators.rs`, `fourtakas_diffusion_vanishes_on_a_hydrostatic_column`).
//! Among unresolved grains it diffuses the intrinsic density ρ/ε (Robinson eq. 15's
//! argument): ρ stands for ρ/ε in ψ and in the gradients, and the term is multiplied by
//! ε_i, the rate of ρ = ε ρ_f at fixed ε. On the superficial ρ it would diffuse the
//! porosity's own step at a block's faces (ARCHITECTURE.md, "An odd-even pressure mode
//! among grains").
//!
//! With `effects.mass_correction` = Γ > 0, Joubert eq. (14) adds
//! `ρ_i Γ Δt (L15_i − L16_i)` with
//! - `L15_i = 2 Σ_j V_j (2/(ρ_i + ρ_j)) ((p_i − p_j)/r_ij − e_ij·⟨∇p⟩ᶜ_i) B̂_i:(e_ij ⊗ ∇W_ij)`
//!   (eq. 15; as printed, its `e_ij·⟨∇p⟩ᶜ_i` lacks the `1/ρ` of the first term and the
//!   two do not have the same units: we read the pair's `2/(ρ_i + ρ_j)` as multiplying
//!   the whole bracket, which keeps the term zero for a linear pressure whatever the
//!   densities, as the Taylor correction of eq. 11 intends),
//! - `L16_i = Σ_j V_j (g_j − g_i)·B_i ∇W_ij`, `g = ⟨∇p⟩ᶜ/ρ` (eq. 16),
//!
//! over every neighbour. Walls and markers have no corrected gradient of their own:
//! they enter eq. (16) with `g_j = g_i` (no contribution), eq. (15) with their pressure.
//! The gradients `⟨∇p⟩ᶜ` are the gradient pass's (start of the step, in both stages of
//! the predictor–corrector: the term is O(Δt) already, so the lag is O(Δt²)).

use crate::constants::{MIN_TAIT_BASE, SphConstants};
use crate::joubert2020_gradients::{Gradients, laplacian_b_hat_cpu, mat_vec, truncation_cpu};
use crate::particles::{Kind, ParticleSet, dot, sub};
use crate::robinson_variable_h::{kernel_at, omega_cpu, pair_neighbours};
use couplet_protocol::DensityDiffusionForm;

pub const CONTINUITY_WGSL: &str = include_str!("../shaders/continuity.wgsl");

/// CPU twin: dρ/dt of particle (entry) `i`; `grads` holds every entry's gradient-pass
/// results when density diffusion or the mass correction is on (unused otherwise);
/// `dt` is the step (mass correction only).
pub fn continuity_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    grads: &[Option<Gradients>],
    dt: f64,
) -> f64 {
    continuity_among_grains_cpu(c, set, i, grads, dt, None)
}

/// [`continuity_cpu`] among unresolved grains, with `porosity` ε at every entry of `set`
/// (`None`: 1): δ-SPH diffuses the intrinsic density ρ/ε, `grads` from
/// [`crate::joubert2020_gradients::gradients_among_grains_cpu`] with the same ε.
pub fn continuity_among_grains_cpu(
    c: &SphConstants,
    set: &ParticleSet,
    i: usize,
    grads: &[Option<Gradients>],
    dt: f64,
    porosity: Option<&[f64]>,
) -> f64 {
    let eps = |k: usize| porosity.map_or(1.0, |e| e[k]);
    let t = c.uses_b_matrix().then(|| truncation_cpu(c, set, i));
    let b = t
        .filter(|t| c.corrected_continuity && !t.near_free_surface)
        .map(|t| t.b);
    let grad_rho = |k: usize| grads[k].map_or([0.0; 3], |g| g.grad_rho);
    // Mass correction (eqs. 14–16): g = ⟨∇p⟩ᶜ/ρ, B̂_i, and the sums of eqs. (15)–(16).
    let mc = t
        .filter(|_| c.mass_correction > 0.0)
        .map(|t| (t.b, laplacian_b_hat_cpu(c, set, i, &t.b, t.singular).0));
    let g_p = |k: usize| {
        grads
            .get(k)
            .copied()
            .flatten()
            .map(|g| g.grad_p.map(|x| x / set.rho[k]))
    };
    let grad_p_i = grads
        .get(i)
        .copied()
        .flatten()
        .map_or([0.0; 3], |g| g.grad_p);
    let g_i = g_p(i).unwrap_or([0.0; 3]);
    let (mut mc_a, mut mc_q, mut mc_div) = (0.0, [0.0; 3], 0.0);
    let mut d = 0.0;
    // Variable h (Robinson eq. 10): ∇W(h_i) and 1/Ω_i; with one h, c.kernel and 1.
    let k_i = kernel_at(c, set, i);
    let omega_i = omega_cpu(c, set, i);
    for j in pair_neighbours(c, set, i) {
        let grad_w = k_i.grad(c.pair_vec(set.pos[i], set.pos[j]));
        let u_ij = sub(set.vel[i], set.vel[j]);
        d += match &b {
            Some(b) => set.rho[i] * (set.mass[j] / set.rho[j]) * dot(u_ij, mat_vec(b, grad_w)),
            None => set.mass[j] * dot(u_ij, grad_w) / omega_i,
        };
        if let Some((bm, bhat)) = &mc {
            let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
            let r = dot(r_ij, r_ij).sqrt();
            let e = r_ij.map(|x| x / r);
            let v_j = set.mass[j] / set.rho[j];
            let vs = v_j * dot(e, mat_vec(bhat, grad_w));
            let w = 2.0 / (set.rho[i] + set.rho[j]);
            mc_a += vs * w * (set.press[i] - set.press[j]) / r;
            for k in 0..3 {
                mc_q[k] += vs * w * e[k];
            }
            let g_j = g_p(j).unwrap_or(g_i);
            mc_div += v_j * dot(sub(g_j, g_i), mat_vec(bm, grad_w));
        }
        if c.density_diffusion > 0.0 && set.kinds.kind(set.id[j]) == Kind::Fluid {
            let r_ij = c.pair_vec(set.pos[i], set.pos[j]);
            let (rho_f_i, rho_f_j) = (set.rho[i] / eps(i), set.rho[j] / eps(j));
            let psi: [f64; 3] = match c.density_diffusion_form {
                DensityDiffusionForm::Antuono => {
                    let f = -2.0 * (rho_f_j - rho_f_i) / dot(r_ij, r_ij);
                    let (gi, gj) = (grad_rho(i), grad_rho(j));
                    std::array::from_fn(|k| f * r_ij[k] - (gi[k] + gj[k]))
                }
                DensityDiffusionForm::Fourtakas => {
                    let rho_h = fourtakas2019_hydrostatic_difference(c, r_ij);
                    let f = -2.0 * (rho_f_j - rho_f_i - rho_h) / dot(r_ij, r_ij);
                    r_ij.map(|x| f * x)
                }
            };
            d += eps(i)
                * c.density_diffusion
                * c.kernel.h
                * c.sound_speed
                * (set.mass[j] / set.rho[j])
                * dot(psi, grad_w);
        }
    }
    if mc.is_some() {
        let l15 = 2.0 * (mc_a - dot(mc_q, grad_p_i));
        d += set.rho[i] * c.mass_correction * dt * (l15 - mc_div);
    }
    d
}

/// Fourtakas et al. 2019's hydrostatic density difference between neighbour j and
/// particle i, `r_ij` = r_i − r_j apart: ρ^H_ji = ρ0((1 + ρ0 g·r_ji/B)^(1/γ) − 1), the
/// Tait density (Joubert eq. 4 inverted) of the hydrostatic pressure step ρ0 g·r_ji, with
/// the fluid's gravity. Twin of `fourtakas2019_hydrostatic_difference` in continuity.wgsl
/// (which takes a series where f32 would lose the step's digits).
pub fn fourtakas2019_hydrostatic_difference(c: &SphConstants, r_ij: [f64; 3]) -> f64 {
    let x = -c.rho0 * dot(c.gravity_fluid, r_ij) / c.tait_b();
    c.rho0 * ((1.0 + x).max(MIN_TAIT_BASE).powf(1.0 / c.gamma) - 1.0)
}
