//! Analytic and semi-analytic reference values for two validation cases of Robinson,
//! Luding & Ramaioli, "Fluid-particle flow modelling and validation using two-way-coupled
//! mesoscale SPH-DEM": the settling speed of a constant porosity block (CPB, §6, eq. 35,
//! Table 1) and the growth rate of the particle-driven Rayleigh–Taylor instability (RTI,
//! §7, eqs. 37–38). Plain functions of f64 in SI units, no dependencies.
//!
//! Findings against the paper (details at each function):
//!
//! * Eq. (35) prints the voidage power as ε^(1+ξ), but Table 1's velocities and Re at
//!   ε = 0.6 are reproduced only by ε^ξ (drag = the grain's buoyant weight in clear
//!   fluid). ε^(1+ξ) is what the paper's own two-way model (eqs. 5 and 23) predicts for a
//!   block in a closed column. [`cpb_terminal_velocity`] implements the Table 1 form;
//!   [`cpb_terminal_velocity_mixture_buoyancy`] the printed one.
//! * Eq. (35) prints 0.392 for the Re² coefficient; Dallavalle's eq. (31) gives
//!   0.63² = 0.3969 (the other two, 6.048 = 2·0.63·4.8 and 23.04 = 4.8², are exact). The
//!   exact value is used. It matters for one printed digit only: water's Re at ε = 1 is
//!   0.85496 with 0.3969 (prints 0.85, as Table 1 does) and 0.8551 with 0.392 (0.86).
//! * Table 1 prints Ar = 18.57 for water; its stated inputs give 18.5772, which rounds
//!   to 18.58 (truncated in print, or marginally different water properties).
//! * Eq. (37) prints `α_c q_d + α_f q_c`; Chandrasekhar's form is `α_f q_d + α_d q_f`
//!   (see [`rti_growth_rate`]).

/// Close packing porosity ε_min of Krieger's model as Robinson uses it, §7 below eq. (38).
pub const KRIEGER_POROSITY_MIN: f64 = 0.37;

/// Dallavalle's coefficients, Robinson eq. (31): `C_d = (A + B/√Re)²`.
const DALLAVALLE_A: f64 = 0.63;
const DALLAVALLE_B: f64 = 4.8;

/// Range of Di Felice's exponent over all Re, Robinson eq. (33): 3.7 − 0.65 ≤ ξ ≤ 3.7.
const XI_MIN: f64 = 3.7 - 0.65;
const XI_MAX: f64 = 3.7;

/// Di Felice's voidage exponent ξ(Re_p), the ξ of `f(ε) = ε^-ξ` in Robinson eq. (32),
/// defined by Robinson eq. (33): `ξ = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re)²/2)`.
///
/// It lies in [3.05, 3.7] and tends to 3.7 as Re → 0 (so `re = 0` gives 3.7) and as
/// Re → ∞. Negative or NaN `re` gives NaN.
pub fn di_felice_xi(re: f64) -> f64 {
    // Robinson eq. (33)
    3.7 - 0.65 * (-0.5 * (1.5 - re.log10()).powi(2)).exp()
}

/// Archimedes number `Ar = d³ ρ (ρ_p − ρ) g / μ²` of a grain of diameter `d` (m) and
/// density `rho_p` in a fluid of density `rho_f` (kg/m³) and dynamic viscosity `mu`
/// (Pa·s) under gravity `g` (m/s²), as defined below Robinson eq. (35).
pub fn archimedes(d: f64, rho_f: f64, rho_p: f64, mu: f64, g: f64) -> f64 {
    // Robinson eq. (35), definition of Ar
    d.powi(3) * rho_f * (rho_p - rho_f) * g / (mu * mu)
}

/// Terminal (settling) velocity |u_t| in m/s of a grain at porosity `porosity` with the
/// Dallavalle / Di Felice drag, Robinson eqs. (30)–(33), as Robinson eq. (35) and Table 1
/// compute it: `Re = ρ |u_t| d/μ` is the root of
///
/// `0.63² Re² + 6.048 Re^1.5 + 23.04 Re − (4/3) Ar ε^ξ(Re) = 0`
///
/// (drag on the grain = its buoyant weight in clear fluid). Eq. (35) prints the power as
/// ε^(1+ξ) and the first coefficient as 0.392; see the comment in the body and
/// [`cpb_terminal_velocity_mixture_buoyancy`] for the printed power.
///
/// |u_t| is a superficial velocity (Re is built from `u_s = ε (u_f − v_p)`, Robinson
/// §3.4). For a block settling in a column closed at the bottom the volume flux through a
/// horizontal plane vanishes, `(1 − ε) v_p + ε u_f = 0`, so `u_s = −v_p`: |u_t| is also
/// the block's settling speed in the lab frame.
///
/// Refuses porosity outside (0, 1], non-positive or non-finite `d`, `rho_f`, `rho_p`,
/// `mu`, `g`, and `rho_p ≤ rho_f` (the grain would not sink).
pub fn cpb_terminal_velocity(
    porosity: f64,
    d: f64,
    rho_f: f64,
    rho_p: f64,
    mu: f64,
    g: f64,
) -> Result<f64, String> {
    // Force balance on one grain in the block (Robinson eqs. 30–33), with
    // u_s = ε (u_f − v_p) and Re = ρ |u_s| d/μ:
    //   drag  f_d = (1/8) C_d ε^-ξ π d² ρ u_s² = (π/8)(μ²/ρ) ε^-ξ (C_d Re²),
    //   C_d Re² = (0.63 Re + 4.8 √Re)² = 0.3969 Re² + 6.048 Re^1.5 + 23.04 Re.
    // (a) Drag = buoyant weight in clear fluid, (π/6) d³ (ρ_p − ρ) g:
    //   C_d Re² = (4/3) Ar ε^ξ.
    // (b) The paper's two-way model: the grain also feels −V ∇P (eq. 23) and the fluid
    //   feels −n f (eq. 5). At steady state in the block the fluid balance gives the
    //   suspension's hydrostatic gradient, −dP/dz = ((1 − ε) ρ_p + ε ρ) g, so the drag
    //   only carries the weight in excess of the suspension's buoyancy,
    //   f_d = V (ρ_p − ρ_susp) g = ε V (ρ_p − ρ) g, and C_d Re² = (4/3) Ar ε^(1+ξ).
    //   That is Robinson eq. (35) as printed, and it is the form under which Di Felice's
    //   ξ ≈ 3.7 reproduces Richardson–Zaki (u ∝ ε^(1+ξ) ≈ ε^4.7 at low Re, ε^((1+ξ)/2) ≈
    //   ε^2.35 at high Re).
    // Table 1's ranges are reproduced only by (a): at ε = 0.6, (a) gives water
    // 1.338e-3 m/s (Re 0.150), glycerol 1.287e-4 (0.00166), air 0.1021 (0.650) against
    // the printed 1.3e-3 (0.15), 1.3e-4 (0.002), 0.102 (0.65); (b) gives 8.13e-4 (0.091),
    // 7.74e-5 (0.0010), 6.23e-2 (0.396). (b)'s slip speed u_s/ε is close to (a) at low Re
    // but not for air (0.1038, Re_slip 0.661), so Table 1 is (a), not (b) quoted as slip.
    // At ε = 1 the two coincide.
    solve_terminal_velocity(porosity, d, rho_f, rho_p, mu, g, 0.0)
}

/// Terminal velocity |u_t| in m/s from Robinson eq. (35) exactly as printed, voidage power
/// ε^(1+ξ): `0.63² Re² + 6.048 Re^1.5 + 23.04 Re − (4/3) Ar ε^(1+ξ(Re)) = 0`.
///
/// This is the drag balancing the grain's weight in excess of the suspension's buoyancy,
/// which is what the paper's own two-way model (Robinson eqs. 5 and 23) predicts for a
/// block settling in a closed column (derivation in [`cpb_terminal_velocity`]); Table 1
/// was not computed with it. Equal to [`cpb_terminal_velocity`] at ε = 1. Same
/// refusals.
pub fn cpb_terminal_velocity_mixture_buoyancy(
    porosity: f64,
    d: f64,
    rho_f: f64,
    rho_p: f64,
    mu: f64,
    g: f64,
) -> Result<f64, String> {
    // Robinson eq. (35) as printed
    solve_terminal_velocity(porosity, d, rho_f, rho_p, mu, g, 1.0)
}

/// Robinson eq. (35) for a rigid block whose grains see porosities ε_a of their own
/// (Robinson eq. 9 at each grain: the kernel smooths the porosity across the block's
/// faces, Robinson §6). With the fluid's momentum as in eq. (5), `−dP/dz = ρ g +
/// n_a f_a/ε_a`, and one superficial slip at every height (the flux through a level of
/// a column closed below is zero, so `ε_a (u_f − v_p) = −v_p` everywhere), the block's
/// balance `Σ_a (f_a − V dP/dz|_a) = N ρ_p V g` becomes `Σ_a f_a/ε_a = N V (ρ_p − ρ) g`
/// with Di Felice's `f_a ∝ ε_a^-ξ C_d Re²`: `C_d Re² = (4/3) Ar / ⟨ε_a^-(1+ξ)⟩`. Equal
/// to [`cpb_terminal_velocity_mixture_buoyancy`] when every ε_a is the same; faster
/// where the faces' grains see more fluid. Same refusals, and an empty list is refused.
pub fn cpb_terminal_velocity_of_porosities(
    porosities: &[f64],
    d: f64,
    rho_f: f64,
    rho_p: f64,
    mu: f64,
    g: f64,
) -> Result<f64, String> {
    if porosities.is_empty() {
        return Err("no grains".into());
    }
    if let Some(e) = porosities.iter().find(|e| !(**e > 0.0 && **e <= 1.0)) {
        return Err(format!("porosity must lie in (0, 1], got {e}"));
    }
    let n = porosities.len() as f64;
    let factor = |xi: f64| n / porosities.iter().map(|e| e.powf(-1.0 - xi)).sum::<f64>();
    solve_for(factor, d, rho_f, rho_p, mu, g)
}

/// Solves `C_d Re² = (4/3) Ar ε^(extra + ξ(Re))` for Re and returns `Re μ/(ρ d)`.
fn solve_terminal_velocity(
    porosity: f64,
    d: f64,
    rho_f: f64,
    rho_p: f64,
    mu: f64,
    g: f64,
    extra: f64,
) -> Result<f64, String> {
    if !(porosity > 0.0 && porosity <= 1.0) {
        return Err(format!("porosity must lie in (0, 1], got {porosity}"));
    }
    solve_for(|xi| porosity.powf(extra + xi), d, rho_f, rho_p, mu, g)
}

/// Solves `C_d Re² = (4/3) Ar factor(ξ(Re))` for Re and returns `Re μ/(ρ d)`; `factor`
/// must not increase with ξ (a porosity power, ε ≤ 1).
fn solve_for(
    factor: impl Fn(f64) -> f64,
    d: f64,
    rho_f: f64,
    rho_p: f64,
    mu: f64,
    g: f64,
) -> Result<f64, String> {
    check_positive("grain diameter d", d)?;
    check_positive("fluid density rho_f", rho_f)?;
    check_positive("grain density rho_p", rho_p)?;
    check_positive("fluid viscosity mu", mu)?;
    check_positive("gravity g", g)?;
    if rho_p <= rho_f {
        return Err(format!(
            "grain density rho_p = {rho_p} must exceed fluid density rho_f = {rho_f} \
             for the grain to settle"
        ));
    }
    let ar = archimedes(d, rho_f, rho_p, mu, g);
    let rhs = |re: f64| 4.0 / 3.0 * ar * factor(di_felice_xi(re));
    let residual = |re: f64| dallavalle_cd_re2(re) - rhs(re);
    // ξ ∈ [3.05, 3.7] and ε ≤ 1, so the right-hand side lies between its values at
    // ξ = 3.7 and ξ = 3.05. Inverting the monotone left-hand side at those two values
    // brackets the root: residual(lo) ≤ 0 ≤ residual(hi).
    let mut lo = invert_dallavalle(4.0 / 3.0 * ar * factor(XI_MAX));
    let mut hi = invert_dallavalle(4.0 / 3.0 * ar * factor(XI_MIN));
    if !(lo.is_finite() && hi.is_finite() && hi > 0.0) {
        return Err(format!(
            "terminal Reynolds number out of floating-point range (Ar = {ar:e}, \
             porosity factor = {})",
            factor(XI_MAX)
        ));
    }
    // Bisection: ξ(Re) is continuous, so the bracket always holds a root.
    for _ in 0..400 {
        if hi - lo <= 1e-14 * hi {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if residual(mid) <= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let re = 0.5 * (lo + hi);
    // Robinson below eq. (35): Re_p = ρ |u_t| d/μ
    Ok(re * mu / (rho_f * d))
}

/// `C_d Re²` for Dallavalle's C_d, Robinson eq. (31): `(0.63 Re + 4.8 √Re)²`, the first
/// three terms of Robinson eq. (35).
fn dallavalle_cd_re2(re: f64) -> f64 {
    (DALLAVALLE_A * re + DALLAVALLE_B * re.sqrt()).powi(2)
}

/// The Re ≥ 0 with `dallavalle_cd_re2(Re) = y` (y ≥ 0): `√Re = s` solves
/// `0.63 s² + 4.8 s − √y = 0`, taken in the cancellation-free form
/// `s = 2√y / (4.8 + √(4.8² + 4·0.63·√y))`.
fn invert_dallavalle(y: f64) -> f64 {
    let r = y.sqrt();
    let s =
        2.0 * r / (DALLAVALLE_B + (DALLAVALLE_B * DALLAVALLE_B + 4.0 * DALLAVALLE_A * r).sqrt());
    s * s
}

/// Krieger's effective viscosity of a hard-sphere suspension at porosity ε, Robinson
/// eq. (38): `μ_d = μ_f ((ε − ε_min)/(1 − ε_min))^(−2.5 (1 − ε_min))`, with `ε_min` the
/// porosity at maximum packing ([`KRIEGER_POROSITY_MIN`] = 0.37 in the paper). This is
/// Krieger–Dougherty `(1 − φ/φ_m)^(−2.5 φ_m)` with solid fraction φ = 1 − ε.
///
/// Valid for `porosity_min < porosity ≤ 1` (gives `mu_f` at ε = 1); at or below
/// `porosity_min` the suspension is jammed and this returns +∞.
pub fn krieger_viscosity(mu_f: f64, porosity: f64, porosity_min: f64) -> f64 {
    if porosity <= porosity_min {
        return f64::INFINITY;
    }
    // Robinson eq. (38)
    mu_f * ((porosity - porosity_min) / (1.0 - porosity_min)).powf(-2.5 * (1.0 - porosity_min))
}

/// Growth rate n (1/s) of a normal-mode disturbance of wave number `k` (1/m) on the
/// interface between a heavy viscous fluid (density `rho_d`, kinematic viscosity `nu_d`)
/// lying above a light one (`rho_f`, `nu_f`) under gravity `g`, zero surface tension:
/// the positive real root of the dispersion relation, Robinson eq. (37) (Chandrasekhar
/// 1961, §94), with `α = ρ/(ρ_f + ρ_d)` and `q² = k² + n/ν`:
///
/// ```text
/// −[g k/n² (α_f − α_d) + 1] (α_f q_d + α_d q_f − k) − 4 k α_f α_d
///   + 4 k²/n (α_f ν_f − α_d ν_d) [α_d q_f − α_f q_d + k (α_f − α_d)]
///   + 4 k³/n² (α_f ν_f − α_d ν_d)² (q_f − k)(q_d − k) = 0.
/// ```
///
/// It lies in (0, n_inviscid] with `n_inviscid² = g k (ρ_d − ρ_f)/(ρ_d + ρ_f)`, tends to it
/// as ν → 0 and to the Stokes-flow rate `g (ρ_d − ρ_f)/(2 k (μ_f + μ_d))` as ν → ∞.
///
/// Refuses `rho_d ≤ rho_f` (the interface is stable: no growing mode) and non-positive or
/// non-finite inputs.
pub fn rti_growth_rate(
    k: f64,
    rho_f: f64,
    nu_f: f64,
    rho_d: f64,
    nu_d: f64,
    g: f64,
) -> Result<f64, String> {
    check_positive("wave number k", k)?;
    check_positive("light (lower) fluid density rho_f", rho_f)?;
    check_positive("light (lower) fluid kinematic viscosity nu_f", nu_f)?;
    check_positive("heavy (upper) fluid density rho_d", rho_d)?;
    check_positive("heavy (upper) fluid kinematic viscosity nu_d", nu_d)?;
    check_positive("gravity g", g)?;
    if rho_d <= rho_f {
        return Err(format!(
            "upper density rho_d = {rho_d} must exceed lower density rho_f = {rho_f}: \
             otherwise the interface is stable and has no growing mode"
        ));
    }
    // Robinson eq. (37) prints the factor of the first term as `α_c q_d + α_f q_c − k`,
    // which names no fluid "c". Chandrasekhar's (1961, §94) relation for fluid 1 below
    // and fluid 2 above has `α_1 q_2 + α_2 q_1 − k`, i.e. `α_f q_d + α_d q_f − k` here
    // (each α paired with the *other* fluid's q), the form implemented. Checks: (i) as
    // ν → 0 every q → ∞ and the relation reduces to g k (α_f − α_d)/n² + 1 = 0, the
    // inviscid n² = g k (ρ_d − ρ_f)/(ρ_d + ρ_f); (ii) as ν → ∞ (q − k ≈ n/(2kν)) it
    // reduces exactly to the Stokes-flow rate n = g (ρ_d − ρ_f)/(2 k (μ_f + μ_d)).
    // Reading the misprint as `α_d q_d + α_f q_f` instead passes (i) but breaks (ii)
    // (it would weight 1/μ by α², not the sum of the two viscosities). The other terms
    // of eq. (37) match Chandrasekhar's with 1 → f, 2 → d.
    let a_f = rho_f / (rho_f + rho_d);
    let a_d = rho_d / (rho_f + rho_d);
    let n_inviscid = (g * k * (a_d - a_f)).sqrt();
    let residual = |n: f64| rti_residual(n, k, a_f, nu_f, a_d, nu_d, g);
    // residual(0) = g k (α_d − α_f)(α_f e_d + α_d e_f) > 0 with e = 1/(2 k ν) (see
    // rti_residual), and residual → −∞ as n → ∞. At n_inviscid it is ≤ 0 whenever viscosity only slows the
    // instability (Chandrasekhar §94; found so over 2·10⁴ random cases spanning 14
    // decades of ν); should it ever be positive, the bracket is widened upward.
    let mut lo = 0.0;
    let mut hi = n_inviscid;
    let mut widen = 0;
    while residual(hi) > 0.0 {
        lo = hi;
        hi *= 2.0;
        widen += 1;
        if widen > 100 || !hi.is_finite() {
            return Err(format!(
                "no root of the dispersion relation found below {hi:e} 1/s \
                 (k = {k}, nu_f = {nu_f}, nu_d = {nu_d})"
            ));
        }
    }
    // Bisection on [lo, hi]: residual(lo) > 0 ≥ residual(hi).
    for _ in 0..400 {
        if hi - lo <= 1e-14 * hi {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if residual(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// n times the left side of Robinson eq. (37), free of poles and cancellation at small n:
/// with `q − k = (n/ν)/(q + k)` write `q − k = n e`, `e = 1/(ν (q + k))`; since
/// `α_f + α_d = 1`, `α_f q_d + α_d q_f − k = n (α_f e_d + α_d e_f)` and
/// `α_d q_f − α_f q_d + k (α_f − α_d) = n (α_d e_f − α_f e_d)`, so n·(eq. 37) reads
///
/// `−[g k (α_f − α_d) + n²](α_f e_d + α_d e_f) − 4 k α_f α_d n
///  + 4 k² Δ n (α_d e_f − α_f e_d) + 4 k³ Δ² n e_f e_d`, `Δ = α_f ν_f − α_d ν_d`,
///
/// finite at n = 0 and positive there when α_d > α_f.
fn rti_residual(n: f64, k: f64, a_f: f64, nu_f: f64, a_d: f64, nu_d: f64, g: f64) -> f64 {
    let q_f = (k * k + n / nu_f).sqrt();
    let q_d = (k * k + n / nu_d).sqrt();
    let e_f = 1.0 / (nu_f * (q_f + k));
    let e_d = 1.0 / (nu_d * (q_d + k));
    let delta = a_f * nu_f - a_d * nu_d;
    // Robinson eq. (37), first factor corrected to Chandrasekhar's α_f q_d + α_d q_f − k
    -(g * k * (a_f - a_d) + n * n) * (a_f * e_d + a_d * e_f) - 4.0 * k * a_f * a_d * n
        + 4.0 * k * k * delta * n * (a_d * e_f - a_f * e_d)
        + 4.0 * k.powi(3) * delta * delta * n * e_f * e_d
}

fn check_positive(name: &str, value: f64) -> Result<(), String> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be positive and finite, got {value}"))
    }
}

/// A lone Stokes grain's excess over Robinson eq. (34) from the flow its coupling makes
/// at the grain, in a continuum ([`grain_own_flow`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnFlow {
    /// The fluid velocity at the grain (weighted over its support), along the grain's
    /// motion, over v_t, at the end.
    pub fluid_velocity: f64,
    /// The grain's velocity less eq. (34)'s, over v_t, at the end.
    pub grain_excess: f64,
}

/// The flow a lone grain's coupling makes in the fluid at the grain, and the excess it
/// gives the grain's settling over Robinson eq. (34), in a continuum. The grain is
/// released from rest at t = 0 under Stokes drag `b (v − u)`, `b = 3π μ d`, and samples
/// the fluid velocity `u` with the kernel (eq. 8; `w` is the kernel, `radius` its
/// support, with h_c the fluid's h). A force density `F(t) W(x)` acts on the fluid:
///
/// - two-way: the grain's drag, spread back by eqs. (26)–(27). The resolved part of its
///   force, the buoyancy −ρVg, is spread back too, and it restores exactly the weight
///   the superficial fluid lacks where the grain's volume lowers its porosity (eq. 9).
/// - one-way: nothing is spread back, so that missing weight is not restored: the fluid
///   around the grain is lighter than the pressure that carries it, `F = −ρ V g`
///   (against the motion) from t = 0, and it rises. Robinson §5.1 calls the porosity's
///   effect on one grain "negligible"; at h/d = 3 it is as large as the two-way drag's.
///
/// The fluid is incompressible, unbounded and at rest at t = 0, and responds linearly
/// (unsteady Stokes): in Fourier space the force's solenoidal part, 2/3 of it along F
/// once averaged over directions, diffuses as `exp(−ν k² τ)`, so
///
/// `u(t) = 2/(3ρ) ∫₀ᵗ F(s) G(t − s) ds`, `G(τ) = 1/(2π²) ∫ k² Ŵ(k)² exp(−ν k² τ) dk`,
///
/// with `Ŵ` the kernel's Fourier transform (`G(0) = ∫ W² dV`). The grain follows
/// `m dv/dt = (ρ_p − ρ) V g − b (v − u)`, so its excess e = v − v₃₄ relaxes towards u
/// over t_d = m/b. Left out: the acoustic part of the response (a weakly compressible
/// fluid's), the grain's own porosity in the drag (eq. 28's ε, the same both ways), and
/// the walls. Two-way minus one-way is then what the coupling itself does. Early on
/// `u ≈ 2/(3ρ) G(0) ∫F dt`, which scales as (d/h)³ (the grain's mass over the fluid's
/// in its support); after the diffusion time R²/ν it tends to the steady regularised
/// Stokeslet.
///
/// Quadrature: the kernel on 400 radii, `Ŵ` on 600 wave numbers to 60/R, the time on
/// 400 steps (the relaxation exact over each, the force at each step's middle). Checked
/// against closed forms for a Gaussian kernel and at early times for Wendland C2 (tests
/// below).
#[allow(clippy::too_many_arguments)]
pub fn grain_own_flow(
    w: impl Fn(f64) -> f64,
    radius: f64,
    d: f64,
    rho_f: f64,
    rho_p: f64,
    nu: f64,
    g: f64,
    t_end: f64,
    two_way: bool,
) -> Result<OwnFlow, String> {
    for (name, v) in [
        ("support radius", radius),
        ("diameter", d),
        ("rho_f", rho_f),
        ("rho_p", rho_p),
        ("nu", nu),
        ("gravity", g),
        ("end time", t_end),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("grain_own_flow: {name} = {v} must be > 0"));
        }
    }
    if rho_p <= rho_f {
        return Err(format!(
            "grain_own_flow: the grain ({rho_p} kg/m³) must be denser than the fluid ({rho_f})"
        ));
    }
    const NR: usize = 400;
    const NK: usize = 600;
    const NT: usize = 400;
    let pi = std::f64::consts::PI;
    let (dr, dk) = (radius / NR as f64, 60.0 / radius / NK as f64);
    let ks: Vec<f64> = (0..NK).map(|i| (i as f64 + 0.5) * dk).collect();
    // Ŵ(k) = 4π/k ∫ r W(r) sin(k r) dr, then k² Ŵ² dk / (2π²), the weights of G.
    let weights: Vec<f64> = (ks.iter())
        .map(|&k| {
            let wk = (0..NR)
                .map(|j| (j as f64 + 0.5) * dr)
                .map(|r| r * w(r) * (k * r).sin())
                .sum::<f64>()
                * dr
                * 4.0
                * pi
                / k;
            k * k * wk * wk * dk / (2.0 * pi * pi)
        })
        .collect();
    let dt = t_end / NT as f64;
    // G at (m + ½) dt: the lag from the middle of step i to the end of step n is
    // (n − i + ½) dt.
    let green: Vec<f64> = (0..NT)
        .map(|m| {
            let tau = (m as f64 + 0.5) * dt;
            (ks.iter().zip(&weights))
                .map(|(k, wt)| wt * (-nu * k * k * tau).exp())
                .sum()
        })
        .collect();
    let volume = pi * d * d * d / 6.0;
    let b = 3.0 * pi * rho_f * nu * d;
    let (v_t, t_d) = ((rho_p - rho_f) * volume * g / b, rho_p * volume / b);
    let relax = (-dt / t_d).exp();
    let (mut excess, mut u) = (0.0, 0.0);
    let mut force = Vec::with_capacity(NT);
    for n in 0..NT {
        // The force over step n, at its middle, from the state at its start.
        let mid = (n as f64 + 0.5) * dt;
        force.push(if two_way {
            b * (v_t * (1.0 - (-mid / t_d).exp()) + excess - u)
        } else {
            -rho_f * volume * g
        });
        excess = excess * relax + u * (1.0 - relax);
        u = 2.0 / (3.0 * rho_f)
            * (force.iter().enumerate())
                .map(|(i, f)| f * green[n - i])
                .sum::<f64>()
            * dt;
    }
    Ok(OwnFlow {
        fluid_velocity: u / v_t,
        grain_excess: excess / v_t,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const D: f64 = 1.0e-4;
    const RHO_P: f64 = 2500.0;
    const G: f64 = 9.81;
    // Robinson Table 1: (ρ, μ) of the three model fluids.
    const WATER: (f64, f64) = (1000.0, 8.9e-4);
    const GLYCEROL: (f64, f64) = (1150.0, 8.9e-3);
    const AIR: (f64, f64) = (1.1839, 1.86e-5);

    fn ut(porosity: f64, fluid: (f64, f64)) -> f64 {
        cpb_terminal_velocity(porosity, D, fluid.0, RHO_P, fluid.1, G).unwrap()
    }

    fn re(u: f64, fluid: (f64, f64)) -> f64 {
        fluid.0 * u * D / fluid.1
    }

    fn assert_close(what: &str, got: f64, want: f64, tol: f64) {
        assert!(
            (got - want).abs() <= tol,
            "{what}: got {got:e}, want {want:e} ± {tol:e}"
        );
    }

    #[test]
    fn xi_limits_and_minimum() {
        // Robinson eq. (33): ξ → 3.7 away from Re = 10^1.5, minimum 3.05 at Re = 10^1.5.
        assert_close("ξ(0)", di_felice_xi(0.0), 3.7, 0.0);
        assert_close("ξ(1e-8)", di_felice_xi(1e-8), 3.7, 1e-12);
        assert_close("ξ(10^1.5)", di_felice_xi(10f64.powf(1.5)), 3.05, 1e-12);
        // ξ(1) = 3.7 − 0.65 e^(−1.125)
        assert_close(
            "ξ(1)",
            di_felice_xi(1.0),
            3.7 - 0.65 * (-1.125f64).exp(),
            1e-15,
        );
    }

    #[test]
    fn archimedes_matches_table_1() {
        // Robinson Table 1: Ar = 83.89 (air), 18.57 (water), 0.192 (water–glycerol).
        let ar = |f: (f64, f64)| archimedes(D, f.0, RHO_P, f.1, G);
        assert_close("Ar air", ar(AIR), 83.89, 0.005);
        assert_close("Ar glycerol", ar(GLYCEROL), 0.192, 0.0005);
        // The stated inputs give 18.5772, which rounds to 18.58: the printed 18.57 is
        // truncated (or the authors' water properties differed in the 4th digit). Assert
        // the exact value and that it is within one unit of the last printed digit.
        assert_close(
            "Ar water",
            ar(WATER),
            1e-12 * 1000.0 * 1500.0 * 9.81 / 7.921e-7,
            1e-12,
        );
        assert_close("Ar water digits", ar(WATER), 18.5772, 0.0001);
        assert_close("Ar water vs Table 1", ar(WATER), 18.57, 0.01);
    }

    #[test]
    fn terminal_velocity_matches_table_1() {
        // Robinson Table 1: |u_t| and Re_p at ε = 1.0 … 0.6, tolerance half a unit of the
        // last printed digit.
        // Water: 7.6e-3 … 1.3e-3 m/s, Re 0.85 … 0.15.
        assert_close("water u ε=1", ut(1.0, WATER), 7.6e-3, 0.05e-3);
        assert_close("water u ε=0.6", ut(0.6, WATER), 1.3e-3, 0.05e-3);
        // Re(ε=1) = 0.85496, 4e-5 inside the rounding boundary; eq. (35)'s printed 0.392
        // in place of 0.63² would give 0.8551, which prints as 0.86.
        assert_close("water Re ε=1", re(ut(1.0, WATER), WATER), 0.85, 0.005);
        assert_close(
            "water Re ε=1 digits",
            re(ut(1.0, WATER), WATER),
            0.85496,
            1e-5,
        );
        assert_close("water Re ε=0.6", re(ut(0.6, WATER), WATER), 0.15, 0.005);
        // Water + 10 % glycerol: 8.4e-4 … 1.3e-4 m/s, Re 0.011 … 0.002.
        assert_close("glycerol u ε=1", ut(1.0, GLYCEROL), 8.4e-4, 0.05e-4);
        assert_close("glycerol u ε=0.6", ut(0.6, GLYCEROL), 1.3e-4, 0.05e-4);
        assert_close(
            "glycerol Re ε=1",
            re(ut(1.0, GLYCEROL), GLYCEROL),
            0.011,
            0.0005,
        );
        assert_close(
            "glycerol Re ε=0.6",
            re(ut(0.6, GLYCEROL), GLYCEROL),
            0.002,
            0.0005,
        );
        // Air: 0.5 … 0.102 m/s, Re 3.19 … 0.65.
        assert_close("air u ε=1", ut(1.0, AIR), 0.5, 0.05);
        assert_close("air u ε=0.6", ut(0.6, AIR), 0.102, 0.0005);
        assert_close("air Re ε=1", re(ut(1.0, AIR), AIR), 3.19, 0.005);
        assert_close("air Re ε=0.6", re(ut(0.6, AIR), AIR), 0.65, 0.005);
    }

    #[test]
    fn terminal_velocity_solves_its_equation() {
        // The returned Re satisfies C_d Re² = (4/3) Ar ε^ξ(Re) to ~1e-12 relative.
        for fluid in [WATER, GLYCEROL, AIR] {
            let ar = archimedes(D, fluid.0, RHO_P, fluid.1, G);
            for eps in [1.0, 0.9, 0.8, 0.7, 0.6, 0.45] {
                let r = re(ut(eps, fluid), fluid);
                let lhs = dallavalle_cd_re2(r);
                let rhs = 4.0 / 3.0 * ar * eps.powf(di_felice_xi(r));
                assert!((lhs - rhs).abs() <= 1e-12 * rhs, "ε={eps}: {lhs} vs {rhs}");
            }
        }
    }

    /// The block of grains with porosities of their own: with every ε_a equal it is
    /// eq. (35) as printed (to the bisection's 1e-14); in creeping flow (ξ = 3.7) the
    /// speed is linear in 1/⟨ε_a^-4.7⟩, so half the grains at 0.6 and half at 0.8 settle
    /// at 2 / (0.6^-4.7 + 0.8^-4.7) of the ε = 1 speed; and bad lists are refused.
    #[test]
    fn block_of_own_porosities_reduces_to_eq35_and_weights_by_eps_power() {
        for f in [WATER, GLYCEROL, AIR] {
            let uniform =
                cpb_terminal_velocity_mixture_buoyancy(0.7, D, f.0, RHO_P, f.1, G).unwrap();
            let own =
                cpb_terminal_velocity_of_porosities(&[0.7; 5], D, f.0, RHO_P, f.1, G).unwrap();
            assert_close("uniform ε = 0.7", own, uniform, 1e-12 * uniform);
        }
        let viscous = (1150.0, 1.0);
        let one =
            cpb_terminal_velocity_of_porosities(&[1.0], D, viscous.0, RHO_P, viscous.1, G).unwrap();
        let mixed =
            cpb_terminal_velocity_of_porosities(&[0.6, 0.8], D, viscous.0, RHO_P, viscous.1, G)
                .unwrap();
        let want = 2.0 / (0.6f64.powf(-4.7) + 0.8f64.powf(-4.7));
        assert_close("creeping mixed", mixed / one, want, 1e-3 * want);
        assert!(cpb_terminal_velocity_of_porosities(&[], D, 1000.0, RHO_P, 8.9e-4, G).is_err());
        assert!(
            cpb_terminal_velocity_of_porosities(&[0.8, 1.2], D, 1000.0, RHO_P, 8.9e-4, G).is_err()
        );
    }

    #[test]
    fn printed_eq35_power_does_not_reproduce_table_1() {
        // Robinson eq. (35) as printed (ε^(1+ξ)) equals the Table 1 form at ε = 1 …
        let printed = |eps: f64, f: (f64, f64)| {
            cpb_terminal_velocity_mixture_buoyancy(eps, D, f.0, RHO_P, f.1, G).unwrap()
        };
        for f in [WATER, GLYCEROL, AIR] {
            assert_close("ε=1", printed(1.0, f), ut(1.0, f), 1e-15);
        }
        // … but at ε = 0.6 gives water 8.13e-4 m/s, far from Table 1's 1.3e-3.
        assert_close(
            "water ε=0.6 printed",
            printed(0.6, WATER),
            8.13e-4,
            0.005e-4,
        );
        // In creeping flow (μ = 1 Pa·s: Re ~ 1e-6, ξ = 3.7 to 1e-12, the 6.048 Re^1.5 term
        // a 3e-4 correction) the speed is linear in the right-hand side, so
        // v(ε)/v(1) = ε^(1+ξ) = ε^4.7 (Richardson–Zaki's n ≈ 4.7) for the printed form,
        // against ε^ξ = ε^3.7 for the Table 1 form.
        let viscous = (1150.0, 1.0);
        let ratio = printed(0.6, viscous) / printed(1.0, viscous);
        assert_close(
            "creeping ratio, printed",
            ratio,
            0.6f64.powf(4.7),
            1e-3 * ratio,
        );
        let ratio = ut(0.6, viscous) / ut(1.0, viscous);
        assert_close(
            "creeping ratio, Table 1",
            ratio,
            0.6f64.powf(3.7),
            1e-3 * ratio,
        );
    }

    #[test]
    fn stokes_limit_of_dallavalle() {
        // As Re → 0, C_d Re² → 23.04 Re (eq. 31), so at ε = 1, Re → (4/3) Ar / 23.04,
        // while Stokes (eq. 28/34) gives u = (ρ_p − ρ) g d²/(18 μ), i.e. Re = Ar/18.
        // Ratio: 18 · 4/3 / 23.04 = 24/23.04 = 1.041666…: Dallavalle's drag is 0.96 of
        // Stokes' at vanishing Re. The next term, 6.048 Re^1.5, shifts the ratio by
        // ≈ −(6.048/23.04) √Re ≈ −2.4e-7 at μ = 1000 Pa·s (Re ≈ 8.5e-13).
        let (rho, mu) = (1000.0, 1000.0);
        let u = cpb_terminal_velocity(1.0, D, rho, RHO_P, mu, G).unwrap();
        let stokes = (RHO_P - rho) * G * D * D / (18.0 * mu);
        assert_close("u/u_Stokes", u / stokes, 24.0 / 23.04, 1e-6);
        // At μ = 10 Pa·s (Re = 8.5e-9) that first correction, 2.4e-5, is resolved.
        let mu = 10.0;
        let u = cpb_terminal_velocity(1.0, D, rho, RHO_P, mu, G).unwrap();
        let stokes = (RHO_P - rho) * G * D * D / (18.0 * mu);
        let re0 = archimedes(D, rho, RHO_P, mu, G) / 17.28;
        let first_order = 24.0 / 23.04 * (1.0 - 6.048 / 23.04 * re0.sqrt());
        assert_close("u/u_Stokes, μ = 10", u / stokes, first_order, 1e-8);
        // Water itself (Re 0.86) is already 9 % below that limit.
        let ratio = ut(1.0, WATER) / ((RHO_P - 1000.0) * G * D * D / (18.0 * 8.9e-4));
        assert!(ratio < 0.95 && ratio > 0.8, "{ratio}");
    }

    #[test]
    fn terminal_velocity_refusals() {
        let f = |eps, d, rf, rp, mu, g| cpb_terminal_velocity(eps, d, rf, rp, mu, g);
        for (args, word) in [
            ((0.0, D, 1000.0, RHO_P, 1e-3, G), "porosity"),
            ((1.1, D, 1000.0, RHO_P, 1e-3, G), "porosity"),
            ((f64::NAN, D, 1000.0, RHO_P, 1e-3, G), "porosity"),
            ((0.8, 0.0, 1000.0, RHO_P, 1e-3, G), "diameter"),
            ((0.8, D, -1.0, RHO_P, 1e-3, G), "rho_f"),
            ((0.8, D, 1000.0, 0.0, 1e-3, G), "rho_p"),
            ((0.8, D, 1000.0, RHO_P, 0.0, G), "mu"),
            ((0.8, D, 1000.0, RHO_P, 1e-3, -9.81), "gravity"),
            ((0.8, D, 1000.0, 900.0, 1e-3, G), "exceed"),
            ((0.8, D, 1000.0, 1000.0, 1e-3, G), "exceed"),
        ] {
            let (e, d, rf, rp, mu, g) = args;
            let err = f(e, d, rf, rp, mu, g).unwrap_err();
            assert!(err.contains(word), "{args:?}: {err}");
        }
    }

    #[test]
    fn krieger_values() {
        // Robinson eq. (38): μ_d/μ_f = ((ε − 0.37)/0.63)^(−1.575).
        assert_close(
            "ε=1",
            krieger_viscosity(2.0, 1.0, KRIEGER_POROSITY_MIN),
            2.0,
            1e-15,
        );
        let r = krieger_viscosity(1.0, 0.8, KRIEGER_POROSITY_MIN);
        assert_close("ε=0.8", r, (0.43f64 / 0.63).powf(-1.575), 1e-14);
        assert_close("ε=0.8 digits", r, 1.8249, 1e-4);
        // Dilute limit: Einstein's 1 + 2.5 φ.
        let phi = 1e-6;
        let r = krieger_viscosity(1.0, 1.0 - phi, KRIEGER_POROSITY_MIN);
        assert_close("Einstein", r, 1.0 + 2.5 * phi, 1e-11);
        assert_eq!(
            krieger_viscosity(1.0, 0.37, KRIEGER_POROSITY_MIN),
            f64::INFINITY
        );
    }

    #[test]
    fn rti_inviscid_limit() {
        // ν → 0: n² = g k (ρ_d − ρ_f)/(ρ_d + ρ_f). The viscous correction is of relative
        // order √(k² ν / n) (boundary layers of thickness √(ν/n) against the wavelength;
        // numerically −2 α_f α_d √(k² ν / n) for equal ν); with ν = 1e-12 m²/s and
        // k ≤ 1 1/m it is below 1e-6.
        for (k, rf, rd) in [
            (1.0, 1000.0, 1420.0),
            (1.0, 1.0, 3.0),
            (0.1, 1000.0, 1001.0),
        ] {
            let inviscid = (G * k * (rd - rf) / (rd + rf)).sqrt();
            let dev = |nu: f64| rti_growth_rate(k, rf, nu, rd, nu, G).unwrap() / inviscid - 1.0;
            assert_close("n/n_inviscid − 1", dev(1e-12), 0.0, 1e-6);
            // and the deviation is negative and shrinks as √ν.
            assert!(dev(1e-12) < 0.0);
            assert_close("√ν scaling", dev(1e-14) / dev(1e-12), 0.1, 1e-4);
        }
    }

    #[test]
    fn rti_viscosity_slows_growth_monotonically() {
        let (k, rf, rd) = (2000.0, 1150.0, 1420.0);
        let inviscid = (G * k * (rd - rf) / (rd + rf)).sqrt();
        let mut last = inviscid;
        for i in 0..=40 {
            let nu = 1e-10 * 10f64.powf(i as f64 * 0.2);
            let n = rti_growth_rate(k, rf, nu, rd, 2.0 * nu, G).unwrap();
            assert!(n > 0.0 && n < last, "ν = {nu:e}: n = {n} not below {last}");
            last = n;
        }
    }

    #[test]
    fn rti_stokes_limit() {
        // Chandrasekhar §94, ν → ∞ (creeping flow): n = g (ρ_d − ρ_f)/(2 k (μ_f + μ_d)),
        // exact to first order in n/(k²ν); here n/(k²ν) ~ 1e-6. Unequal viscosities test
        // the α_f q_d + α_d q_f pairing of the first term (see rti_growth_rate).
        for (k, rf, nf, rd, nd) in [
            (10.0, 1000.0, 10.0, 1500.0, 30.0),
            (100.0, 1.0, 1.0, 2.0, 0.1),
            (2221.0, 1150.0, 1.0, 1420.0, 1.0),
        ] {
            let n = rti_growth_rate(k, rf, nf, rd, nd, G).unwrap();
            let stokes = G * (rd - rf) / (2.0 * k * (rf * nf + rd * nd));
            assert_close("n/n_Stokes", n / stokes, 1.0, 1e-4);
        }
    }

    #[test]
    fn rti_root_is_a_unique_positive_root() {
        // The returned n zeroes eq. (37) (times n², to remove the poles) and eq. (37)
        // changes sign nowhere else on (0, 10 n_inviscid].
        let (k, rf, nf, rd, nd) = (2221.0, 1150.0, 7.7e-6, 1420.0, 1.2e-5);
        let a_f = rf / (rf + rd);
        let a_d = rd / (rf + rd);
        let n = rti_growth_rate(k, rf, nf, rd, nd, G).unwrap();
        let h = |x: f64| rti_residual(x, k, a_f, nf, a_d, nd, G);
        // Scale of the residual's terms at the root.
        let scale = G * k * (a_d - a_f) * (a_f / (nd * 2.0 * k) + a_d / (nf * 2.0 * k));
        assert!(h(n).abs() <= 1e-10 * scale, "residual {} vs {scale}", h(n));
        let inviscid = (G * k * (a_d - a_f)).sqrt();
        let mut changes = 0;
        let mut prev = h(1e-9 * inviscid);
        for i in 1..=20000 {
            let x = 10.0 * inviscid * i as f64 / 20000.0;
            let cur = h(x);
            if (cur > 0.0) != (prev > 0.0) {
                changes += 1;
                assert!((x - n).abs() <= 10.0 * inviscid / 20000.0, "root near {x}");
            }
            prev = cur;
        }
        assert_eq!(changes, 1);
    }

    #[test]
    fn rti_paper_case_water_glycerol() {
        // Robinson §7: water–glycerol, ρ_d = ε ρ_f + (1 − ε) ρ_p, μ_d from Krieger
        // (eq. 38), k_x = k_y = 2π/w with w = 4e-3 m, so |k| = √2 · 2π/w. The paper
        // bounds the growth by ε = 0.8 (upper) and ε = 0.93 (lower).
        let (rho_f, mu_f) = GLYCEROL;
        let k = 2f64.sqrt() * 2.0 * std::f64::consts::PI / 4e-3;
        let rate = |eps: f64| {
            let rho_d = eps * rho_f + (1.0 - eps) * RHO_P;
            let mu_d = krieger_viscosity(mu_f, eps, KRIEGER_POROSITY_MIN);
            let n = rti_growth_rate(k, rho_f, mu_f / rho_f, rho_d, mu_d / rho_d, G).unwrap();
            eprintln!(
                "RTI water-glycerol ε = {eps}: ρ_d = {rho_d} kg/m³, μ_d = {mu_d:.4e} Pa·s, \
                 k = {k:.2} 1/m, n = {n:.4} 1/s (inviscid {:.4} 1/s)",
                (G * k * (rho_d - rho_f) / (rho_d + rho_f)).sqrt()
            );
            n
        };
        let (n08, n093) = (rate(0.8), rate(0.93));
        assert!(n093 > 0.0 && n08 > n093, "n(0.8) = {n08}, n(0.93) = {n093}");
    }

    #[test]
    fn rti_refusals() {
        let f = rti_growth_rate;
        for (args, word) in [
            ((0.0, 1000.0, 1e-6, 1500.0, 1e-6, G), "wave number"),
            ((1.0, 0.0, 1e-6, 1500.0, 1e-6, G), "rho_f"),
            ((1.0, 1000.0, 0.0, 1500.0, 1e-6, G), "nu_f"),
            ((1.0, 1000.0, 1e-6, f64::INFINITY, 1e-6, G), "rho_d"),
            ((1.0, 1000.0, 1e-6, 1500.0, -1e-6, G), "nu_d"),
            ((1.0, 1000.0, 1e-6, 1500.0, 1e-6, 0.0), "gravity"),
            ((1.0, 1500.0, 1e-6, 1000.0, 1e-6, G), "stable"),
            ((1.0, 1000.0, 1e-6, 1000.0, 1e-6, G), "stable"),
        ] {
            let (k, rf, nf, rd, nd, g) = args;
            let err = f(k, rf, nf, rd, nd, g).unwrap_err();
            assert!(err.contains(word), "{args:?}: {err}");
        }
    }

    /// Wendland C2 of support R: `W = 21/(2π R³) (1 − q)⁴ (1 + 4q)`, q = r/R.
    fn wendland(radius: f64) -> impl Fn(f64) -> f64 {
        move |r: f64| {
            let q = (r / radius).min(1.0);
            21.0 / (2.0 * PI * radius.powi(3)) * (1.0 - q).powi(4) * (1.0 + 4.0 * q)
        }
    }

    /// ∫W² dV of Wendland C2 of support R: 441/(117 π R³) (the integral
    /// ∫q²(1−q)⁸(1+4q)² dq = 1/117 by Beta functions).
    fn wendland_w2(radius: f64) -> f64 {
        441.0 / (117.0 * PI * radius.powi(3))
    }

    /// Long before the diffusion time R²/ν the fluid's response is inviscid: u = 2/(3ρ)
    /// ∫W² dV ∫F dt ([`wendland_w2`]), with ∫F dt = b v_t (t − t_d (1 − e^(−t/t_d)))
    /// while u ≪ v_t.
    #[test]
    fn own_flow_is_inviscid_early() {
        let (r, d, rho, rho_p, nu, t) = (0.02, 1e-4, 1000.0, 2500.0, 8.9e-7, 7.8e-3);
        let got = grain_own_flow(wendland(r), r, d, rho, rho_p, nu, G, t, true).unwrap();
        let b = 3.0 * PI * rho * nu * d;
        let t_d = rho_p * PI * d.powi(3) / 6.0 / b;
        let impulse_over_vt = b * (t - t_d * (1.0 - (-t / t_d).exp()));
        let want = 2.0 / (3.0 * rho) * wendland_w2(r) * impulse_over_vt;
        assert_close(
            "two-way, early",
            got.fluid_velocity,
            want,
            1e-3 * want.abs(),
        );
        // The grain lags the fluid by about t_d.
        assert!(got.grain_excess > 0.0 && got.grain_excess < got.fluid_velocity);
    }

    /// One-way, the lighter fluid around the grain rises under the constant −ρVg: early
    /// on u = −2/(3ρ) ∫W² dV ρ V g t (the same closed form), and the grain, dragged by
    /// it, falls slower than eq. (34).
    #[test]
    fn one_way_fluid_rises_where_the_grain_lightens_it() {
        let (r, d, rho, rho_p, nu, t) = (0.02, 1e-4, 1000.0, 2500.0, 8.9e-7, 7.8e-3);
        let got = grain_own_flow(wendland(r), r, d, rho, rho_p, nu, G, t, false).unwrap();
        let volume = PI * d.powi(3) / 6.0;
        let v_t = (rho_p - rho) * volume * G / (3.0 * PI * rho * nu * d);
        let want = -2.0 / (3.0 * rho) * wendland_w2(r) * rho * volume * G * t / v_t;
        assert_close(
            "one-way, early",
            got.fluid_velocity,
            want,
            1e-3 * want.abs(),
        );
        assert!(got.grain_excess < 0.0 && got.grain_excess > got.fluid_velocity);
    }

    /// A Gaussian kernel of width σ has `G(τ) = (4π (σ² + ν τ))^(−3/2)`, so under the
    /// drag F ≈ (ρ_p − ρ) V g (1 − e^(−t/t_d)) (t_d ≪ t, u ≪ v_t)
    /// `u(t) = 2/(3ρ) F [2/ν (4π)^(−3/2) (1/σ − (σ² + ν t)^(−1/2)) − t_d G(t)]`; as
    /// t → ∞ it tends to the regularised Stokeslet `F/(6π μ) · 1/(σ √π)`.
    #[test]
    fn own_flow_matches_a_gaussian_kernel_closed_form() {
        let (sigma, d, rho, rho_p, nu, t) = (1e-3, 1e-4, 1000.0, 2500.0, 1e-5, 1.0);
        let gauss =
            |r: f64| (2.0 * PI * sigma * sigma).powf(-1.5) * (-r * r / (2.0 * sigma * sigma)).exp();
        let got = grain_own_flow(gauss, 6.0 * sigma, d, rho, rho_p, nu, G, t, true).unwrap();
        let b = 3.0 * PI * rho * nu * d;
        let t_d = rho_p * PI * d.powi(3) / 6.0 / b;
        let a = sigma * sigma + nu * t;
        let integral = 2.0 / nu * (4.0 * PI).powf(-1.5) * (1.0 / sigma - a.powf(-0.5));
        let want = 2.0 / (3.0 * rho) * b * (integral - t_d * (4.0 * PI * a).powf(-1.5));
        let steady = d / (2.0 * sigma * PI.sqrt());
        assert_close("gaussian", got.fluid_velocity, want, 1e-3 * want.abs());
        // Still short of the steady regularised Stokeslet.
        assert!(want < steady, "{want} against the steady {steady}");
    }

    #[test]
    fn own_flow_refusals() {
        let w = wendland(1e-3);
        assert!(
            grain_own_flow(&w, 1e-3, 1e-4, 1000.0, 900.0, 1e-6, G, 1.0, true)
                .unwrap_err()
                .contains("denser")
        );
        assert!(
            grain_own_flow(&w, 1e-3, 1e-4, 1000.0, 2500.0, 0.0, G, 1.0, false)
                .unwrap_err()
                .contains("nu")
        );
    }
}
