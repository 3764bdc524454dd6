//! Unresolved grains (issue 5): Robinson's single-particle sedimentation, constant-
//! porosity block and Rayleigh–Taylor column, and DEMocritus's sedimentation regimes.

use super::*;
use couplet_fluid::porosity::{PorosityField, Solid};

/// DEMocritus §4.2's Newton-regime setup (μ = 0.01 Pa·s), and the same grain where
/// μ puts it in the Allen (μ = 1, Re ≈ 170) and Stokes (μ = 100, Re ≈ 0.1) regimes of
/// DEMocritus eq. (46); each run ends before the grain, released 3.5 m up, nears the
/// floor.
pub(super) const REGIMES: &[Variant] = &[
    ("Newton", &["time.end=1.5"]),
    ("Allen", &["fluid.kinematic_viscosity=1e-3", "time.end=1.5"]),
    (
        "Stokes",
        &[
            "fluid.kinematic_viscosity=0.1",
            "time.end=0.2",
            "time.output_interval=0.01",
        ],
    ),
];

/// DEMocritus eq. (46): the terminal velocity of a sphere in the Stokes (Re < 2), Allen
/// (2 < Re < 500) and Newton (Re > 500) regimes, taking the branch whose own Re lies in
/// its range; returns (velocity, regime name). The Newton branch is printed as
/// `{4/(3 × 0.44) (ρs − ρf) g / ρf}^{1/2} d`, which is not a velocity (m^{3/2}/s); the
/// force balance with C_D = 0.44 puts d under the root, `√(4 (ρs − ρf) g d / (3 × 0.44
/// ρf))`, and that is what reproduces DEMocritus's own Re = 2.3e4 at d = 0.1 m.
pub(super) fn democritus_terminal_velocity(
    d: f64,
    rho_s: f64,
    rho_f: f64,
    mu: f64,
    g: f64,
) -> (f64, &'static str) {
    let dr = rho_s - rho_f;
    let stokes = d * d * dr * g / (18.0 * mu);
    let allen = (4.0 / 225.0 * dr * dr * g * g / (rho_f * mu)).cbrt() * d;
    let newton = (4.0 / (3.0 * 0.44) * dr * g * d / rho_f).sqrt();
    let re = |v: f64| rho_f * v * d / mu;
    if re(stokes) < 2.0 {
        (stokes, "Stokes")
    } else if re(allen) < 500.0 {
        (allen, "Allen")
    } else {
        (newton, "Newton")
    }
}

/// The speed at which the drag law balances the submerged weight of a grain at porosity
/// `porosity` in fluid at rest, by bisection on `couplet_fluid::drag::drag_force` to
/// 1e-12.
pub(super) fn drag_law_terminal_velocity(
    law: couplet_fluid::drag::DragLaw,
    porosity: f64,
    d: f64,
    rho_s: f64,
    rho_f: f64,
    mu: f64,
    g: f64,
) -> f64 {
    let weight = (rho_s - rho_f) * std::f64::consts::PI * d.powi(3) / 6.0 * g;
    let drag = |v: f64| {
        couplet_fluid::drag::drag_force(
            law,
            &couplet_fluid::drag::DragInput {
                porosity,
                diameter: d,
                density: rho_f,
                viscosity: mu,
                slip: [0.0, v, 0.0],
            },
        )[1]
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    while drag(hi) < weight {
        hi *= 2.0;
    }
    while hi - lo > 1e-12 * hi {
        let mid = 0.5 * (lo + hi);
        if drag(mid) < weight {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// DEMocritus §4.2: the grain's terminal velocity — the mean downward velocity over the
/// last tenth of the run, which must have levelled off (change over that tenth < 0.5 %)
/// — against the speed where the scene's drag law balances the submerged weight at the
/// porosity the lone grain sees (judged < 2 %: what the coupling adds, fluid sampling
/// and the held window force) and against DEMocritus eq. (46) (judged within the law's
/// own gap to eq. 46 plus 2 %: Dallavalle's C_D differs from eq. 46's regime laws, by
/// 0.3 % at Re 2.3e4, 12 % in the Allen regime).
///
/// The porosity a lone grain sees is Robinson eq. (9) at its centre with itself its only
/// neighbour, ε0 = 1 − W(0) V. Eq. (46) is a grain in unbounded fluid, ε = 1, so ε0 is
/// judged ≥ 0.98: DEMocritus's own porosity (his eq. 43, the grain's volume over a
/// sphere of radius h) gives 0.984 for this grain at h = 2 dx. At the scene's first
/// support, 2δ (h = d), ε0 was 0.781, the law's drag 1.5–1.9 times ε = 1's, and the
/// grain fell 22–52 % slower than eq. (46) (2026-11-29).
pub(super) fn sedimentation_regimes(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let (i, body, radius) = first_grain(scene)?;
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let (d, g, mu) = (
        2.0 * radius,
        gravity_magnitude(scene),
        f.density * f.kinematic_viscosity,
    );
    let s = track(rec, i);
    let last = s.last().ok_or("no grain states recorded")?.time;
    let tail: Vec<f64> = (s.iter())
        .filter(|p| p.time >= 0.9 * last)
        .map(|p| -p.velocity[1])
        .collect();
    if tail.len() < 4 {
        return Err(format!("only {} states in the last tenth", tail.len()));
    }
    let terminal = tail.iter().sum::<f64>() / tail.len() as f64;
    let change = (tail[tail.len() - 1] - tail[0]).abs() / terminal;
    report.judge(
        "levelled off: velocity change over the last tenth",
        pct(change),
        "0".into(),
        "< 0.5 %".into(),
        Some(change < 0.005),
    );
    // Robinson eq. (9) at the grain, the grain its only neighbour, by the fluid server's
    // own field (the sum it gives the drag each window).
    let grain = Solid {
        position: body.position,
        volume: std::f64::consts::PI * d.powi(3) / 6.0,
    };
    let eps0 = porosity_field(scene)?.porosity(&[grain.position], &[grain])[0];
    report.judge(
        "porosity the lone grain sees (Robinson eq. 9 at its centre, itself its only neighbour)",
        format!("{eps0:.4}"),
        "1 (unbounded fluid, eq. 46; DEMocritus eq. 43 at h = 2 dx: 0.984)".into(),
        "≥ 0.98".into(),
        Some(eps0 >= 0.98),
    );
    let law = couplet_fluid::drag::DragLaw::from(scene.coupling.drag);
    let balance = drag_law_terminal_velocity(law, eps0, d, body.density, f.density, mu, g);
    let e_law = (terminal - balance).abs() / balance;
    report.headline = Some((
        "terminal velocity against the drag law's balance".into(),
        e_law,
    ));
    report.judge(
        format!(
            "terminal velocity (Re = {:.3e})",
            f.density * terminal * d / mu
        ),
        format!("{terminal:.5e} m/s"),
        format!("{balance:.5e} m/s ({law:?} balance of the submerged weight at ε0)"),
        "< 2 %".into(),
        Some(e_law < 0.02),
    );
    let (v46, regime) = democritus_terminal_velocity(d, body.density, f.density, mu, g);
    let gap = (balance - v46).abs() / v46;
    let e46 = (terminal - v46).abs() / v46;
    report.judge(
        "terminal velocity against DEMocritus eq. (46)",
        format!("{terminal:.5e} m/s ({})", pct(e46)),
        format!(
            "{v46:.5e} m/s ({regime} regime; the law's balance is {} from it)",
            pct(gap)
        ),
        format!("< {}", pct(gap + 0.02)),
        Some(e46 < gap + 0.02),
    );
    if let Some((t, snap)) = rec.snapshots.last() {
        report.series.push(fluid_velocity_profile(scene, *t, snap));
    }
    report.series.push(Series::downward_velocity(
        "grain-velocity",
        &s,
        vec![(0.0, v46), (last, v46)],
    ));
    Ok(())
}

/// Robinson §6 (Fig. 9): the block at ε = 0.6 … 0.9 in water and water–glycerol (Table 1),
/// h = 2d in Robinson's h = 1.5 δ (eq. 19). The lattice spacing Δr = (V/(1 − ε))^(1/3)
/// changes with ε, so each column is a whole number of lattice spacings across (the
/// lattice tiles the period) and a whole number of fluid spacings δ, with δ within 3 %
/// of 1.3782e-4 m (h/d 2.00–2.09), and 43 δ high. The two counts differ: where they
/// are equal (ε = 0.8 with δ = Δr, as until 2026-11-28) every fluid row sits at one
/// phase of the grain lattice, the porosity's lattice ripple (±2.8e-4 at h = 1.5 Δr)
/// moves the whole column's pressure as the fluid flows through the block, and the
/// quick's fluid grew (ARCHITECTURE.md, "The fluid's lattice must not be the grains'").
/// The block fills the column's upper half, y = H/2–H, as Robinson's (§4): 27, 24, 20,
/// 17 layers (until 2026-12-05 y = 3.0–5.4 mm, 21, 19, 17, 13 layers, where the
/// porosity's smoothing across the faces made the block up to 7.5 % fast at ε = 0.6;
/// ARCHITECTURE.md, "The block fills the column's upper half"). Full: about 4 mm across
/// (29, 29, 31, 29 fluid spacings; 37, 33, 30, 23 lattice spacings), Robinson's domain.
/// The test `cpb_variants_tile_their_periods` checks every number against these rules.
pub(super) const CPB_VARIANTS: &[Variant] = &[
    (
        "water, ε = 0.6",
        &[
            "fluid.spacing=1.3956716917e-04",
            "domain.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "fluid.blocks.0.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "grain_lattices.0.min=[0.0, 3.0006941372e-03, 0.0]",
            "grain_lattices.0.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "grain_lattices.0.porosity=0.6",
        ],
    ),
    (
        "water, ε = 0.7",
        &[
            "fluid.spacing=1.3700667644e-04",
            "domain.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "fluid.blocks.0.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "grain_lattices.0.min=[0.0, 2.9456435434e-03, 0.0]",
            "grain_lattices.0.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "grain_lattices.0.porosity=0.7",
        ],
    ),
    (
        "water, ε = 0.8",
        &[
            "fluid.spacing=1.3337745811e-04",
            "domain.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "fluid.blocks.0.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "grain_lattices.0.min=[0.0, 2.8676153493e-03, 0.0]",
            "grain_lattices.0.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "grain_lattices.0.porosity=0.8",
        ],
    ),
    (
        "water, ε = 0.9",
        &[
            "fluid.spacing=1.3771969288e-04",
            "domain.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "fluid.blocks.0.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "grain_lattices.0.min=[0.0, 2.9609733970e-03, 0.0]",
            "grain_lattices.0.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "grain_lattices.0.porosity=0.9",
        ],
    ),
    (
        "water-glycerol, ε = 0.6",
        &[
            "fluid.spacing=1.3956716917e-04",
            "domain.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "fluid.blocks.0.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "grain_lattices.0.min=[0.0, 3.0006941372e-03, 0.0]",
            "grain_lattices.0.max=[4.0474479060e-03, 6.0013882744e-03, 4.0474479060e-03]",
            "grain_lattices.0.porosity=0.6",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.7",
        &[
            "fluid.spacing=1.3700667644e-04",
            "domain.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "fluid.blocks.0.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "grain_lattices.0.min=[0.0, 2.9456435434e-03, 0.0]",
            "grain_lattices.0.max=[3.9731936168e-03, 5.8912870869e-03, 3.9731936168e-03]",
            "grain_lattices.0.porosity=0.7",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.8",
        &[
            "fluid.spacing=1.3337745811e-04",
            "domain.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "fluid.blocks.0.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "grain_lattices.0.min=[0.0, 2.8676153493e-03, 0.0]",
            "grain_lattices.0.max=[4.1347012014e-03, 5.7352306987e-03, 4.1347012014e-03]",
            "grain_lattices.0.porosity=0.8",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.9",
        &[
            "fluid.spacing=1.3771969288e-04",
            "domain.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "fluid.blocks.0.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "grain_lattices.0.min=[0.0, 2.9609733970e-03, 0.0]",
            "grain_lattices.0.max=[3.9938710937e-03, 5.9219467940e-03, 3.9938710937e-03]",
            "grain_lattices.0.porosity=0.9",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
];

/// The quick version's columns: 8–11 fluid spacings across (the shortest period the
/// neighbour grid takes is 7.5 δ at support 3 δ): 10, 9, 10, 8 lattice spacings. At
/// ε = 0.8 the column is 10 lattice spacings and 11 fluid spacings across (h/d = 1.88,
/// 47 δ high): with so few spacings no other count keeps h/d within 3 % of 2 without
/// the fluid's lattice being the grains'.
pub(super) const CPB_QUICK_VARIANTS: &[Variant] = &[
    (
        "water, ε = 0.6",
        &[
            "fluid.spacing=1.3673810493e-04",
            "domain.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "fluid.blocks.0.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "grain_lattices.0.min=[0.0, 2.9398692560e-03, 0.0]",
            "grain_lattices.0.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "grain_lattices.0.porosity=0.6",
        ],
    ),
    (
        "water, ε = 0.7",
        &[
            "fluid.spacing=1.3544978239e-04",
            "domain.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "fluid.blocks.0.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "grain_lattices.0.min=[0.0, 2.9121703214e-03, 0.0]",
            "grain_lattices.0.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "grain_lattices.0.porosity=0.7",
        ],
    ),
    (
        "water, ε = 0.8",
        &[
            "fluid.spacing=1.2529397580e-04",
            "domain.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "fluid.blocks.0.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "grain_lattices.0.min=[0.0, 2.9444084313e-03, 0.0]",
            "grain_lattices.0.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "grain_lattices.0.porosity=0.8",
        ],
    ),
    (
        "water, ε = 0.9",
        &[
            "fluid.spacing=1.3891725543e-04",
            "domain.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "fluid.blocks.0.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "grain_lattices.0.min=[0.0, 2.9867209918e-03, 0.0]",
            "grain_lattices.0.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "grain_lattices.0.porosity=0.9",
        ],
    ),
    (
        "water-glycerol, ε = 0.6",
        &[
            "fluid.spacing=1.3673810493e-04",
            "domain.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "fluid.blocks.0.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "grain_lattices.0.min=[0.0, 2.9398692560e-03, 0.0]",
            "grain_lattices.0.max=[1.0939048394e-03, 5.8797385120e-03, 1.0939048394e-03]",
            "grain_lattices.0.porosity=0.6",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.7",
        &[
            "fluid.spacing=1.3544978239e-04",
            "domain.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "fluid.blocks.0.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "grain_lattices.0.min=[0.0, 2.9121703214e-03, 0.0]",
            "grain_lattices.0.max=[1.0835982591e-03, 5.8243406428e-03, 1.0835982591e-03]",
            "grain_lattices.0.porosity=0.7",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.8",
        &[
            "fluid.spacing=1.2529397580e-04",
            "domain.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "fluid.blocks.0.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "grain_lattices.0.min=[0.0, 2.9444084313e-03, 0.0]",
            "grain_lattices.0.max=[1.3782337338e-03, 5.8888168626e-03, 1.3782337338e-03]",
            "grain_lattices.0.porosity=0.8",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
    (
        "water-glycerol, ε = 0.9",
        &[
            "fluid.spacing=1.3891725543e-04",
            "domain.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "fluid.blocks.0.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "grain_lattices.0.min=[0.0, 2.9867209918e-03, 0.0]",
            "grain_lattices.0.max=[1.3891725543e-03, 5.9734419836e-03, 1.3891725543e-03]",
            "grain_lattices.0.porosity=0.9",
            "fluid.density=1150.0",
            "fluid.kinematic_viscosity=7.7391e-6",
        ],
    ),
];

/// Robinson §7's runs: water–glycerol with and without artificial viscosity (Fig. 14,
/// both between the bounds in the paper) and water without it (Fig. 13; with it the
/// paper's water growth falls below both bounds), to 0.15 s in water (n ≈ 25.5–43.2 1/s
/// at the scene's λ = 4.13 mm; water–glycerol 9.31–18.81 1/s). Water at α = 0 runs with
/// δ-SPH 0.1 on ρ/ε: without it the quick's column blew up at α = 0 from its faces and
/// odd-even rows in the block (`RTI_QUICK_VARIANTS`), which δ-SPH holds, as it does the
/// constant-porosity block's. Water–glycerol at α = 0 is Robinson's scheme as he ran it:
/// the 1.1 mm column so run (windows of t_d/20 = 7.8 μs) stayed quiet to 60 ms, its
/// fluid's largest speed 0.86–1.33 mm/s over 6–60 ms where water's faces grew ×2 a
/// millisecond from 20 ms (results/2026-12-05-lavapipe-rti-window/wg-a0).
pub(super) const RTI_VARIANTS: &[Variant] = &[
    ("water-glycerol, α = 0.1", &[]),
    (
        "water-glycerol, α = 0",
        &["effects.artificial_viscosity=0.0"],
    ),
    (
        "water, α = 0, δ-SPH 0.1",
        &[
            "effects.artificial_viscosity=0.0",
            "effects.density_diffusion=0.1",
            "fluid.density=1000.0",
            "fluid.kinematic_viscosity=8.9e-7",
            "time.end=0.15",
        ],
    ),
];

/// The RTI's quick column: 16 lattice spacings Δr = 0.13782337 mm across (2.2051739740e-3
/// m), the disturbance's wavelength the new width, with 18 fluid spacings across it and
/// 48 δ high (5.88 mm; the full column is 43 of its δ, 5.74 mm). Not 16 fluid spacings:
/// with the fluid's lattice on the grains' the porosity's lattice ripple moves every fluid
/// row alike (ARCHITECTURE.md, "The fluid's lattice must not be the grains'"). Not
/// narrower: until 2026-12-05 it was 8 lattice and 9 fluid spacings (1.1 mm), where the
/// interface, the porosity smoothed over a support of 3δ = 0.37 mm, spans a third of the
/// wavelength (k L = 3.0 at √2 k), and the lowest layer's mode burst to about 0.1 mm and
/// levelled off instead of growing as e^(n t) (ARCHITECTURE.md, "The narrow RTI quick is no
/// proxy"); at 2.2 mm (k L = 1.5) it grew through the bounds' rates to the end.
pub(super) const RTI_QUICK: &[&str] = &[
    "fluid.spacing=1.2250966522e-04",
    "domain.max=[2.2051739740e-03, 5.8804639306e-03, 2.2051739740e-03]",
    "fluid.blocks.0.max=[2.2051739740e-03, 5.8804639306e-03, 2.2051739740e-03]",
    "grain_lattices.0.max=[2.2051739740e-03, 5.4e-3, 2.2051739740e-03]",
    "grain_lattices.0.perturbation.wavelength=2.2051739740e-03",
    "time.output_interval=0.005",
    "time.body_output_interval=1e-3",
];

/// The quick version runs water only (see `quick_why`), to 0.06 s: from rest the depth
/// grows as about cosh(n t), 2.9–10-fold by then at the bounds' n = 28–50 1/s. It runs
/// Robinson's water case, Fig. 13, without artificial viscosity, and holds the block's
/// faces with δ-SPH 0.1 on ρ/ε instead (the "alternative method of reducing the velocity
/// fluctuations near high porosity gradients" Robinson's §7 calls for). At α = 0 without
/// δ-SPH the 1.1 mm column of before blew up at t = 17.8 ms and the 2.2 mm one at
/// 16.7 ms, a sound wave through the block fed by windows of 20 fluid steps; with windows
/// of at most h/c_s (`grain_sound_crossing`, 2026-12-05) the 2.2 mm column ran to
/// 37.3 ms, and then blew up from its upper face, the fluid under the lid and odd-even
/// rows in the block, all growing from 20 ms (ARCHITECTURE.md, "A window longer than the
/// sound's crossing of h"). With δ-SPH it ran quiet to 0.06 s (2026-12-05) but for a jet
/// of the fluid beside the spike's axis at 55 ms, which the scene's particle shifting
/// (since 2026-12-07) removes: 35.685 1/s to 0.06 s, and to 0.075 s without a jet
/// (ARCHITECTURE.md, "The RTI's jet"). With δ-SPH
/// and α = 0.1 (`--set effects.artificial_viscosity=0.1`) the growth falls below both
/// bounds, 18.062 1/s, as Robinson's water growth with α = 0.1 did (2026-12-06). The
/// scene's α = 0.1 without δ-SPH (`--set effects.artificial_viscosity=0.1 --set
/// effects.density_diffusion=0.0`) grew as slowly until its fluid turned noisy at 35 ms,
/// and its fit read the burst after: 38.904 1/s
/// (results/2026-12-06-lavapipe-rti-alpha/comparison.md).
pub(super) const RTI_QUICK_VARIANTS: &[Variant] = &[(
    "water, α = 0, δ-SPH 0.1",
    &[
        "effects.artificial_viscosity=0.0",
        "effects.density_diffusion=0.1",
        "fluid.density=1000.0",
        "fluid.kinematic_viscosity=8.9e-7",
        "time.end=0.06",
    ],
)];

/// The three fluids of Robinson Table 1, each two-way (the scene's default) and one-way
/// (Robinson §5.1 and Fig. 4 compare the two in each), as overrides of the water scene:
/// ν = μ/ρ, and the run to five relaxation times t_d (water 1.56e-3 s, water–glycerol
/// 1.56e-4 s) or, in air (t_d = 7.47e-2 s), to 0.025 s, before the grain (released
/// 4.75 mm above the floor, falling at nearly g) lands.
pub(super) const SPS_FLUIDS: &[Variant] = &[
    ("water", &[]),
    ("water, one-way", &[SPS_ONE_WAY]),
    ("air", SPS_AIR),
    (
        "air, one-way",
        &[SPS_AIR[0], SPS_AIR[1], SPS_AIR[2], SPS_AIR[3], SPS_ONE_WAY],
    ),
    ("water-glycerol", SPS_GLYCEROL),
    (
        "water-glycerol, one-way",
        &[
            SPS_GLYCEROL[0],
            SPS_GLYCEROL[1],
            SPS_GLYCEROL[2],
            SPS_GLYCEROL[3],
            SPS_ONE_WAY,
        ],
    ),
];

/// CI's: the three fluids two-way and water one-way, the four runs CI made before the
/// one-way air and water–glycerol joined the full case (they add two runs to CI's
/// budget and no code path the water one-way run does not take).
pub(super) const SPS_QUICK_FLUIDS: &[Variant] =
    &[SPS_FLUIDS[0], SPS_FLUIDS[1], SPS_FLUIDS[2], SPS_FLUIDS[4]];

pub(super) const SPS_ONE_WAY: &str = "coupling.two_way=false";
pub(super) const SPS_AIR: &[&str] = &[
    "fluid.density=1.1839",
    "fluid.kinematic_viscosity=1.5711e-5",
    "time.end=0.025",
    "time.output_interval=0.0025",
];
pub(super) const SPS_GLYCEROL: &[&str] = &[
    "fluid.density=1150.0",
    "fluid.kinematic_viscosity=7.7391e-6",
    "time.end=7.8e-4",
    "time.output_interval=7.8e-5",
];

/// Robinson §4–5 (SPS): the first unresolved grain's downward velocity against Robinson
/// eq. (34), `v(t) = (ρ_p − ρ) V g / b (1 − exp(−b t / m))`, `b = 3π μ d`, `m = ρ_p V`
/// (Stokes drag, no added mass, released from rest at t = 0). Judged: the largest
/// difference after one relaxation time `t_d = m / b` (or after a quarter of the run
/// when it is shorter than t_d, as in air), as a fraction of `v_t`, below Robinson's
/// 2 %; the difference at the end is reported.
pub(super) fn single_particle_sedimentation(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let (i, body, radius) = first_grain(scene)?;
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let (d, g) = (2.0 * radius, gravity_magnitude(scene));
    let volume = std::f64::consts::PI * d.powi(3) / 6.0;
    let mass = body.density * volume;
    let b = 3.0 * std::f64::consts::PI * f.density * f.kinematic_viscosity * d;
    let (v_t, t_d) = ((body.density - f.density) * volume * g / b, mass / b);
    // Robinson eq. (34).
    let stokes = |t: f64| v_t * (1.0 - (-t / t_d).exp());
    let s = track(rec, i);
    if s.len() < 20 {
        return Err(format!("only {} grain states recorded", s.len()));
    }
    let last_time = s.last().map_or(0.0, |p| p.time);
    let t_judge = t_d.min(0.25 * last_time);
    // The signed deviation from eq. (34) over v_t after t_judge: its largest size is judged,
    // its mean and spread are Robinson Fig. 5's measure.
    let after: Vec<(f64, f64)> = (s.iter())
        .filter(|p| p.time >= t_judge)
        .map(|p| (p.time, (-p.velocity[1] - stokes(p.time)) / v_t))
        .collect();
    let (t_worst, worst) = after
        .iter()
        .map(|&(t, e)| (t, e.abs()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or("the run ends before one relaxation time")?;
    // No `|` in the row: it is a markdown table cell.
    report.headline = Some((
        "max deviation from eq. (34) over v_t after t_d".into(),
        worst,
    ));
    report.judge(
        format!("max deviation from eq. (34) over v_t for t ≥ {t_judge:.3e} s (t_d = {t_d:.3e} s)"),
        format!("{} (at t = {t_worst:.3e} s)", pct(worst)),
        format!("v_t = {v_t:.4e} m/s (Robinson eq. 34)"),
        "< 2 % (Robinson §5.1)".into(),
        Some(worst < 0.02),
    );
    // Robinson Fig. 5's measure: the mean deviation over the same stretch, with one standard
    // deviation of the fluctuation about it (he finds the mean within about 1 %, the
    // fluctuation under 1 % for h/d ≥ 2 and 3 % at h/d = 1.5).
    let n = after.len() as f64;
    let mean = after.iter().map(|a| a.1).sum::<f64>() / n;
    let sd = (after.iter().map(|a| (a.1 - mean).powi(2)).sum::<f64>() / n).sqrt();
    report.judge(
        format!("mean deviation from eq. (34) over v_t for t ≥ {t_judge:.3e} s, ± one standard deviation"),
        format!("{:+.2} % ± {:.2} %", 100.0 * mean, 100.0 * sd),
        "Robinson Fig. 5: mean within about 1 %, ± < 1 % for h/d ≥ 2".into(),
        "reported".into(),
        None,
    );
    let last = s.last().expect("checked above");
    report.judge(
        "velocity at the end",
        format!("{:.4e} m/s", -last.velocity[1]),
        format!(
            "{:.4e} m/s (eq. 34 at t = {:.3e} s)",
            stokes(last.time),
            last.time
        ),
        "reported".into(),
        None,
    );
    // For `sps_two_way_against_one_way`: the excess at the end, and the part of it that
    // the coupling's own flow at the grain makes, in a continuum.
    let two_way = scene.coupling.two_way;
    let kernel = couplet_fluid::kernel::SmoothingKernel::new(f.kernel, f.smoothing_length());
    let own = crate::robinson_reference::grain_own_flow(
        |r| kernel.w(r),
        kernel.radius(),
        d,
        f.density,
        body.density,
        f.kinematic_viscosity,
        g,
        last.time,
        two_way,
    )?;
    report.values.extend([
        ("two_way", f64::from(u8::from(two_way))),
        ("nu", f.kinematic_viscosity),
        ("end_excess", (-last.velocity[1] - stokes(last.time)) / v_t),
        ("own_flow_excess", own.grain_excess),
    ]);
    report.series.push(Series::downward_velocity(
        "grain-velocity",
        &s,
        (0..=20)
            .map(|k| last.time * f64::from(k) / 20.0)
            .map(|t| (t, stokes(t)))
            .collect(),
    ));
    Ok(())
}

/// SPS across variants: for each fluid run both ways, the two-way grain's velocity at
/// the end less the one-way grain's, over v_t: what the coupling itself does to a lone
/// grain, the rest of the two runs' error being shared. Beside it, the continuum
/// estimate of the same difference (`robinson_reference::grain_own_flow`): the two-way
/// grain's drag spread back on the fluid in its support, less the one-way fluid's rise
/// where the grain's volume lightens it. Reported, not judged: Robinson §5.1 finds the two
/// "identical" at h/d = 6, and both parts scale as (d/h)³ (ARCHITECTURE.md, "A lone
/// grain's coupling moves the fluid in its support").
pub(super) fn sps_two_way_against_one_way(
    parts: &[Report],
    report: &mut Report,
) -> Result<(), String> {
    let get = |r: &Report, k: &str| {
        r.value(k)
            .ok_or_else(|| format!("{}: no `{k}` in the analysis", r.case))
    };
    let label = |r: &Report| {
        let c = r.case.as_str();
        c.find('(')
            .and_then(|i| c.rfind(')').map(|j| c[i + 1..j].to_owned()))
            .unwrap_or_else(|| c.to_owned())
    };
    for two in parts.iter().filter(|r| r.value("two_way") == Some(1.0)) {
        let nu = get(two, "nu")?;
        let Some(one) =
            (parts.iter()).find(|r| r.value("two_way") == Some(0.0) && r.value("nu") == Some(nu))
        else {
            continue;
        };
        let diff = get(two, "end_excess")? - get(one, "end_excess")?;
        let (drag, rise) = (get(two, "own_flow_excess")?, get(one, "own_flow_excess")?);
        report.judge(
            format!(
                "{}: two-way minus one-way, velocity at the end over v_t",
                label(two)
            ),
            format!("{:+.2} %", 100.0 * diff),
            format!(
                "{:+.2} % (continuum estimate: two-way, the drag spread back, {:+.2} %; one-way, the lightened fluid's rise, {:+.2} %)",
                100.0 * (drag - rise),
                100.0 * drag,
                100.0 * rise
            ),
            "reported".into(),
            None,
        );
    }
    Ok(())
}

/// Robinson §6 (CPB): the rigid block's settling speed, its fall over the second half of
/// the run over that time (every grain of a translation group moves alike),
/// against Robinson eq. (35) as printed (`cpb_terminal_velocity_mixture_buoyancy`: the
/// drag carries the grain's weight in excess of the suspension's buoyancy, which is what
/// the model of eqs. 5 and 23 predicts), within Robinson's 5 % (§6.2). Eq. (35) in the
/// form that reproduces Robinson's Table 1 (drag = the grain's buoyant weight in clear
/// fluid) is reported beside it, as is the change of the velocity across the judged
/// stretch (a plateau changes little).
pub(super) fn constant_porosity_block(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    use crate::robinson_reference::{
        cpb_terminal_velocity, cpb_terminal_velocity_mixture_buoyancy,
    };
    let lattice = scene
        .grain_lattices
        .first()
        .ok_or("the scene has no [[grain_lattices]] block")?;
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let first = (scene.bodies.iter())
        .position(|b| b.translation_group.as_deref() == Some(lattice.name.as_str()))
        .ok_or("the block's grains are not a translation group (grain_lattices.rigid)")?;
    let (eps, d, g) = (
        lattice.porosity,
        2.0 * lattice.radius,
        gravity_magnitude(scene),
    );
    let mu = f.density * f.kinematic_viscosity;
    let printed =
        cpb_terminal_velocity_mixture_buoyancy(eps, d, f.density, lattice.density, mu, g)?;
    let table = cpb_terminal_velocity(eps, d, f.density, lattice.density, mu, g)?;
    // Robinson Fig. 9's scale: one grain's terminal velocity, eq. (35) at ε = 1.
    let single = cpb_terminal_velocity(1.0, d, f.density, lattice.density, mu, g)?;
    let s = track(rec, first);
    if s.len() < 10 {
        return Err(format!("only {} states of the block recorded", s.len()));
    }
    let finite = (s.iter()).all(|b| b.position.iter().chain(&b.velocity).all(|v| v.is_finite()));
    report.judge(
        "block state finite",
        finite.to_string(),
        "true".into(),
        "exact".into(),
        Some(finite),
    );
    let t_end = s.last().map_or(0.0, |b| b.time);
    let judged: Vec<&BodySample> = (s.iter()).filter(|b| b.time >= 0.5 * t_end).collect();
    let n = judged.len();
    if n < 5 {
        return Err(format!(
            "only {n} states of the block in the judged second half (t ≥ {:.3e} s)",
            0.5 * t_end
        ));
    }
    // The settling speed is the block's fall across the judged stretch over its duration,
    // the exact time average of its velocity whatever the record interval. A mean of the
    // records weights the stretch's ends by a full interval and would alias any motion
    // whose period is near a multiple of the interval; in the water ε = 0.9 quick runs,
    // whose block speed oscillates by a few per cent with a period of about 31 ms, the
    // two differed by less than 0.1 % (results/2026-12-01-lavapipe-cpb/comparison.md).
    // The records' mean is reported beside it.
    let fall_rate =
        |a: &BodySample, b: &BodySample| (a.position[1] - b.position[1]) / (b.time - a.time);
    let settled = fall_rate(judged[0], judged[n - 1]);
    let records = judged.iter().map(|b| -b.velocity[1]).sum::<f64>() / n as f64;
    // The fall rate over the stretch's last quarter against its first quarter's.
    let q = (n / 4).max(1);
    let change =
        (fall_rate(judged[n - 1 - q], judged[n - 1]) - fall_rate(judged[0], judged[q])) / settled;
    let error = (settled - printed).abs() / printed;
    report.headline = Some(("settling speed vs eq. (35)".into(), error));
    report.values.extend([
        ("porosity", eps),
        ("speed", settled),
        ("eq35", printed),
        ("single", single),
    ]);
    report.judge(
        format!(
            "block settling speed, its fall over t = {:.3e}–{:.3e} s over the time (ε = {eps})",
            judged[0].time,
            judged[n - 1].time
        ),
        format!("{settled:.4e} m/s ({} off)", pct(error)),
        format!("{printed:.4e} m/s (Robinson eq. 35 as printed, ε^(1+ξ))"),
        "< 5 % (Robinson §6.2)".into(),
        Some(error < 0.05),
    );
    report.judge(
        "against eq. (35) in Table 1's form (ε^ξ, the buoyant weight in clear fluid)",
        format!(
            "{settled:.4e} m/s ({:+.1} %)",
            100.0 * (settled / table - 1.0)
        ),
        format!("{table:.4e} m/s"),
        "reported".into(),
        None,
    );
    // Eq. (35) with each grain's own porosity (Robinson eq. 9 at the grain, by the fluid
    // server's field at the start; the block moves rigidly): the faces' grains see more
    // fluid, and the block falls faster than eq. (35) at ε by what the model itself
    // predicts (Robinson §6's explanation of his blocks' few per cent).
    {
        let volume = std::f64::consts::PI * d.powi(3) / 6.0;
        let grains: Vec<Solid> = (scene.bodies.iter())
            .filter(|b| b.translation_group.as_deref() == Some(lattice.name.as_str()))
            .map(|b| Solid {
                position: b.position,
                volume,
            })
            .collect();
        let points: Vec<[f64; 3]> = grains.iter().map(|g| g.position).collect();
        let own = porosity_field(scene)?.porosity(&points, &grains);
        let mean = own.iter().sum::<f64>() / own.len() as f64;
        let v_own = crate::robinson_reference::cpb_terminal_velocity_of_porosities(
            &own,
            d,
            f.density,
            lattice.density,
            mu,
            g,
        )?;
        report.values.push(("eq35_own", v_own));
        report.judge(
            format!(
                "against eq. (35) over the grains' own porosities (Robinson eq. 9 at each; mean {mean:.4}, {:.4}–{:.4})",
                own.iter().copied().fold(f64::INFINITY, f64::min),
                own.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            ),
            format!(
                "{settled:.4e} m/s ({:+.2} %)",
                100.0 * (settled / v_own - 1.0)
            ),
            format!("{v_own:.4e} m/s ({:+.2} % off eq. 35 at ε)", 100.0 * (v_own / printed - 1.0)),
            "reported".into(),
            None,
        );
    }
    report.judge(
        format!(
            "mean of the block's {n} recorded velocities over the same stretch (every {:.1e} s)",
            (judged[n - 1].time - judged[0].time) / (n - 1) as f64
        ),
        format!(
            "{records:.4e} m/s ({:+.2} % off the fall's)",
            100.0 * (records / settled - 1.0)
        ),
        format!("{settled:.4e} m/s (the fall over the time)"),
        "reported".into(),
        None,
    );
    // Robinson's error bars (Figs. 8–9): one standard deviation of the block's speed
    // over his 0.34 s; here over the judged stretch's records. A ring of amplitude A
    // gives A/√2.
    let spread = ((judged.iter())
        .map(|b| (-b.velocity[1] - records).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    report.judge(
        "standard deviation of those velocities (Robinson Figs. 8–9's error bars)",
        format!(
            "{spread:.4e} m/s ({:.2} % of eq. 35)",
            100.0 * spread / printed
        ),
        "one standard deviation over 0.34 s in Robinson".into(),
        "reported".into(),
        None,
    );
    report.judge(
        "change of the settling speed across the judged stretch (the fall rate over its last quarter against its first)",
        pct(change.abs()),
        "0 (a plateau)".into(),
        "reported".into(),
        None,
    );
    // What the block exchanges with the fluid over the judged stretch: the fluid's force
    // on all its grains over their weight (1 at a steady fall), and the fluid's mean
    // vertical velocity inside the block at the last snapshot against continuity's
    // return flow, ε u_f + (1 − ε) v = 0 (Robinson eq. 4 with a closed floor).
    let members: Vec<usize> = (0..scene.bodies.len())
        .filter(|&i| scene.bodies[i].translation_group.as_deref() == Some(lattice.name.as_str()))
        .collect();
    let grain_mass = lattice.density * 4.0 / 3.0 * std::f64::consts::PI * lattice.radius.powi(3);
    let weight = members.len() as f64 * grain_mass * g;
    let mut by_time: std::collections::BTreeMap<u64, f64> = Default::default();
    for l in rec.loads.iter().filter(|l| l.time >= 0.5 * t_end) {
        if scene.bodies[l.body].translation_group.is_some() {
            *by_time.entry(l.time.to_bits()).or_default() += l.force[1];
        }
    }
    if !by_time.is_empty() {
        let mean_force = by_time.values().sum::<f64>() / by_time.len() as f64;
        report.judge(
            "fluid force on the block over its weight (mean, judged stretch)",
            format!("{:.4}", mean_force / weight),
            "1 at a steady fall".into(),
            "reported".into(),
            None,
        );
    }
    // The return flow, averaged over every snapshot of the judged stretch: one snapshot
    // carries the column's acoustic breathing (±1 mm/s at c = 10 m/s), larger than the
    // flow through the block.
    // The block's extent at the recorded body time nearest a snapshot: a snapshot's
    // time is in whole nanoseconds, the body states' in full f64.
    let body_times: Vec<f64> = s.iter().map(|b| b.time).collect();
    let block_at = |t: f64| {
        let nearest = (body_times.iter())
            .copied()
            .min_by(|a, b| (a - t).abs().total_cmp(&(b - t).abs()))
            .unwrap_or(f64::NAN);
        (rec.bodies.iter())
            .filter(|b| b.time == nearest)
            .filter(|b| scene.bodies[b.body].translation_group.is_some())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
                (a.min(s.position[1]), b.max(s.position[1]))
            })
    };
    // Below the block, more than a kernel support under its lowest grain, the fluid is
    // clear and the floor is closed: its mean velocity is 0 (a drift of the column there
    // adds straight to the block's lab-frame speed).
    let support = f.support * f.spacing;
    let (mut inside, mut below, mut snapshots) = ((0.0, 0usize), (0.0, 0usize), 0usize);
    let (mut inside_series, mut below_series) = (Vec::new(), Vec::new());
    // The fluid's largest speed in each snapshot (see the row below).
    let mut fastest: Vec<(f64, f64)> = Vec::new();
    // A snapshot's time is in whole nanoseconds (its MCAP log time): one stamped up to
    // 1 ns past the last body state still belongs to the run.
    let within = |t: f64| t <= t_end + 1e-9;
    for (t, snap) in rec.snapshots.iter().filter(|(t, _)| within(*t)) {
        let (bottom, top) = block_at(*t);
        if !bottom.is_finite() {
            continue;
        }
        let quarter = 0.25 * (top - bottom);
        let (mut i, mut b) = ((0.0, 0usize), (0.0, 0usize));
        for p in snap {
            let (y, v) = (f64::from(p[1]), f64::from(p[5]));
            if y - bottom > quarter && top - y > quarter {
                i = (i.0 + v, i.1 + 1);
            } else if y < bottom - support {
                b = (b.0 + v, b.1 + 1);
            }
        }
        if i.1 > 0 && b.1 > 0 {
            inside_series.push((*t, i.0 / i.1 as f64));
            below_series.push((*t, b.0 / b.1 as f64));
        }
        let top_speed = (snap.iter())
            .map(crate::record::particle_speed)
            .fold(0.0, f64::max);
        fastest.push((*t, top_speed));
        if *t >= 0.5 * t_end {
            inside = (inside.0 + i.0, inside.1 + i.1);
            below = (below.0 + b.0, below.1 + b.1);
            snapshots += 1;
        }
    }
    for (name, points) in [
        ("fluid-velocity-in-block", inside_series),
        ("fluid-velocity-below-block", below_series),
    ] {
        report.series.push(Series {
            name: name.into(),
            x_label: "t (s)".into(),
            y_label: "mean fluid u_y (m/s)".into(),
            points,
            reference: Vec::new(),
        });
    }
    let rows = [
        (
            "in the block's middle half",
            inside,
            (1.0 - eps) / eps * settled,
            "−(1 − ε)/ε × v_block",
        ),
        (
            "below the block (clear fluid, a support away)",
            below,
            0.0,
            "closed floor",
        ),
    ];
    for (place, (sum, count), reference, why) in rows {
        if count > 0 {
            report.judge(
                format!(
                    "fluid velocity {place}, mean over {snapshots} snapshots of the judged stretch"
                ),
                format!("{:.4e} m/s ({count} particle samples)", sum / count as f64),
                format!("{reference:.4e} m/s ({why})"),
                "reported".into(),
                None,
            );
        }
    }
    // A steady fall holds the flow steady. With Robinson's pressure terms the fluid layer
    // at the block's lower face instead grew a mode of its own, e-folding every 1.5–2 ms
    // in water and slower in water–glycerol (ARCHITECTURE.md, "Among grains the pressure
    // terms can be the energy-conserving pair"; the scene's energy-pair cured it), and a
    // plateau measured over such a mode is not Robinson's: the fluid's largest speed over
    // the last quarter of the judged stretch's snapshots against the first quarter's must
    // stay within a factor of 2 (the column's breathing moves it by tens of per cent).
    let judged_fastest: Vec<(f64, f64)> = (fastest.iter())
        .copied()
        .filter(|p| p.0 >= 0.5 * t_end)
        .collect();
    if judged_fastest.len() >= 2 {
        let q = (judged_fastest.len() / 4).max(1);
        let top = |v: &[(f64, f64)]| v.iter().map(|p| p.1).fold(0.0, f64::max);
        let n = judged_fastest.len();
        let (first, last) = (top(&judged_fastest[..q]), top(&judged_fastest[n - q..]));
        let growth = last / first;
        report.judge(
            "growth of the fluid's largest speed across the judged stretch (its last quarter's over its first's)",
            format!("{growth:.3} ({first:.3e} → {last:.3e} m/s; block {settled:.3e} m/s)"),
            "1 (a steady flow)".into(),
            "≤ 2".into(),
            Some(growth <= 2.0),
        );
        // Creeping flow through and around the block is driven by the block alone, so
        // no fluid moves much faster than it; a mode that has grown and saturated before
        // the judged stretch (so that the growth row passes) does, by tens to hundreds of
        // times (water–glycerol ε = 0.6 to 30 ms: 79; water ε = 0.7: 300–900).
        let fastest_judged = top(&judged_fastest);
        report.judge(
            "the fluid's largest speed over the judged stretch, over the block's settling speed",
            format!("{:.3} ({fastest_judged:.3e} m/s)", fastest_judged / settled),
            "of order 1 (a creeping flow driven by the block)".into(),
            "≤ 10".into(),
            Some(fastest_judged <= 10.0 * settled),
        );
        report.series.push(Series {
            name: "fluid-largest-speed".into(),
            x_label: "t (s)".into(),
            y_label: "largest fluid speed (m/s)".into(),
            points: fastest,
            reference: Vec::new(),
        });
    }
    if let Some((t, snap)) = rec.snapshots.iter().rev().find(|(t, _)| within(*t)) {
        report.series.push(fluid_velocity_profile(scene, *t, snap));
    }
    report.series.push(Series::downward_velocity(
        "block-velocity",
        &s,
        vec![(0.0, printed), (t_end, printed)],
    ));
    // How far the block's lowest layer is from the closed floor: the distance a slowing
    // near the floor would follow, and the height any stretch's settling speed can be
    // read from as the drop in it over the time (`results/…/compare.py --falls`).
    let lowest = (scene.bodies.iter().enumerate())
        .filter(|(_, b)| b.translation_group.as_deref() == Some(lattice.name.as_str()))
        .min_by(|a, b| a.1.position[1].total_cmp(&b.1.position[1]))
        .map_or(first, |(i, _)| i);
    report.series.push(Series {
        name: "block-height".into(),
        x_label: "t (s)".into(),
        y_label: "lowest grain centre above the floor (m)".into(),
        points: (track(rec, lowest).iter())
            .map(|b| (b.time, b.position[1] - scene.domain.min[1]))
            .collect(),
        reference: Vec::new(),
    });
    Ok(())
}

/// Robinson §7 (RTI): the lowest grain's depth below the settling block's undisturbed
/// lower face, `a(t) = y_face − v₃₅ t − y_low(t)` (`y_face` the bottom layer's centre
/// before eq. 39's disturbance, v₃₅ the block's settling speed of eq. 35 as printed, the
/// form the CPB case meets), grows as e^(n t) once the disturbance has set the fluid
/// moving. The growth rate n is the least-squares slope of ln a from the first sample
/// with a ≥ 2 a(0) until the lowest grain has come half way to the floor (the two-fluid
/// model assumes an unbounded domain; Robinson sees wall effects take over near the
/// floor). From rest a grows like a(0) cosh(n t), whose log-slope is 0.87 n at
/// a = 2 a(0) and tends to n, so the fit reads a few per cent low. It is judged between
/// the two-fluid model's rates, Robinson eq. (37) with Krieger's μ_d (eq. 38) at
/// ε = 0.93 (lower bound, the porosity his front reached) and at the block's ε (upper),
/// for eq. (39)'s wave number |k| = √2 · 2π/λ (k_x = k_z = 2π/λ). Reported beside it,
/// not judged: the same fit of the lowest layer's two modes (`lowest_layer_modes`), a
/// reading of the interface that one grain's jumps do not move (in the quick, 2026-12-05,
/// the lowest grain's depth stalled and jumped by tens of µm while the layer's modes
/// grew and levelled off).
pub(super) fn rayleigh_taylor(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    use crate::robinson_reference::{
        KRIEGER_POROSITY_MIN, cpb_terminal_velocity_mixture_buoyancy, krieger_viscosity,
        rti_growth_rate,
    };
    let lattice =
        (scene.grain_lattices.first()).ok_or("the scene has no [[grain_lattices]] block")?;
    let p = (lattice.perturbation)
        .ok_or("the grain lattice has no perturbation (Robinson eq. 39) to grow")?;
    if lattice.rigid {
        return Err("the grain lattice is rigid: the instability needs free grains".into());
    }
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let (eps, d, g) = (
        lattice.porosity,
        2.0 * lattice.radius,
        gravity_magnitude(scene),
    );
    let mu = f.density * f.kinematic_viscosity;
    let v35 = cpb_terminal_velocity_mixture_buoyancy(eps, d, f.density, lattice.density, mu, g)?;
    // The suspension above at porosity e with dynamic viscosity mu_d.
    let rate_with = |e: f64, k: f64, mu_d: f64| {
        let rho_d = e * f.density + (1.0 - e) * lattice.density;
        rti_growth_rate(k, f.density, f.kinematic_viscosity, rho_d, mu_d / rho_d, g)
    };
    let rate = |e: f64, k: f64| rate_with(e, k, krieger_viscosity(mu, e, KRIEGER_POROSITY_MIN));
    let k = 2.0 * std::f64::consts::PI / p.wavelength;
    // The judged mode cos kx cos kz's wave number.
    let sk = 2f64.sqrt() * k;
    let (upper, lower) = (rate(eps, sk)?, rate(0.93, sk)?);
    // The lowest grain at every recorded time.
    let prefix = format!("{}[", lattice.name);
    let member: Vec<bool> = (scene.bodies.iter())
        .map(|b| b.name.starts_with(&prefix))
        .collect();
    let mut lowest: std::collections::BTreeMap<u64, (f64, f64)> = Default::default();
    for b in rec
        .bodies
        .iter()
        .filter(|b| member.get(b.body) == Some(&true))
    {
        let e = lowest
            .entry(b.time.to_bits())
            .or_insert((b.time, f64::INFINITY));
        e.1 = e.1.min(b.position[1]);
    }
    let track: Vec<(f64, f64)> = lowest.into_values().collect();
    if track.len() < 10 {
        return Err(format!(
            "only {} states of the grains recorded",
            track.len()
        ));
    }
    let finite = track.iter().all(|(_, y)| y.is_finite());
    report.judge(
        "grain states finite",
        finite.to_string(),
        "true".into(),
        "exact".into(),
        Some(finite),
    );
    let face = lattice.min[1] + 0.5 * lattice.spacing();
    let depth: Vec<(f64, f64)> = track
        .iter()
        .map(|&(t, y)| (t, face - v35 * t - y))
        .collect();
    let (a0, y0, floor) = (depth[0].1, track[0].1, scene.domain.min[1]);
    if a0 <= 0.0 {
        return Err(format!(
            "the lowest grain starts {a0:e} m below the face: no disturbance"
        ));
    }
    let stop = (track.iter())
        .position(|&(_, y)| y < floor + 0.5 * (y0 - floor))
        .unwrap_or(track.len());
    let start = depth[..stop].iter().position(|&(_, a)| a >= 2.0 * a0);
    let stretch = start.map_or(&depth[..0], |i| &depth[i..stop]);
    report.judge(
        "disturbance (lowest grain's depth below the settling face) at the start",
        format!("{a0:.4e} m"),
        format!(
            "{:.4e} m (4A, eq. 39, at the cell centre)",
            4.0 * p.amplitude
        ),
        "reported".into(),
        None,
    );
    report.judge(
        "bounds of the growth rate, two-fluid model (Robinson eqs. 37–38)",
        format!("{lower:.3} 1/s (ε = 0.93) … {upper:.3} 1/s (ε = {eps})"),
        format!("wave number √2 · 2π/λ = {sk:.1} 1/m"),
        "reported".into(),
        None,
    );
    // The bounds take the suspension's viscosity from Krieger's eq. (38), 1.83 μ_f at
    // ε = 0.8. The unresolved model has no mechanism for it: its suspension is the
    // fluid with grains held by drag. Its fluid's viscous term (Morris's, μ = ρν with ρ
    // the superficial density ε ρ_f) is the kinematic ν everywhere, so fluid and grains
    // summed feel ε μ_f ∇²u, where eq. (5) with τ = μ_f ∇u would have μ_f: the bounds
    // again at both. In water–glycerol, where viscosity counts, the full column's upper
    // bound moves from 18.813 to 22.891 and 24.110 1/s; in the water quick from 50.279
    // to 54.031 and 55.073.
    let at = |mu_d: &dyn Fn(f64) -> f64| -> Result<String, String> {
        Ok(format!(
            "{:.3} 1/s (ε = 0.93) … {:.3} 1/s (ε = {eps})",
            rate_with(0.93, sk, mu_d(0.93))?,
            rate_with(eps, sk, mu_d(eps))?
        ))
    };
    report.judge(
        "bounds with the suspension at the fluid's viscosity and at ε times it (eq. 37 without eq. 38, which the unresolved model has no mechanism for; not judged)",
        format!(
            "{} at μ_d = μ_f; {} at μ_d = ε μ_f",
            at(&|_| mu)?,
            at(&|e| e * mu)?
        ),
        format!(
            "μ_f = {mu:.4e} Pa·s; ε μ_f is what the model's viscous term (ν everywhere) gives fluid and grains together"
        ),
        "reported".into(),
        None,
    );
    if stretch.len() < 5 {
        report.judge(
            "growth of the disturbance",
            format!(
                "{} samples from a = 2 a(0) to half way to the floor; a reached {:.2} a(0) by t = {:.3e} s",
                stretch.len(),
                depth[..stop].iter().map(|p| p.1).fold(f64::MIN, f64::max) / a0,
                depth[stop.max(1) - 1].0
            ),
            "at least 5 samples to fit e^(n t)".into(),
            "exact".into(),
            Some(false),
        );
    } else {
        let n = exponential_rate(stretch).ok_or("the stretch's depths are not all positive")?;
        let inside = lower <= n && n <= upper;
        let off = if inside {
            0.0
        } else {
            (n - n.clamp(lower, upper)).abs() / n.clamp(lower, upper)
        };
        report.headline = Some(("growth rate outside Robinson's bounds".into(), off));
        report
            .values
            .extend([("growth", n), ("lower", lower), ("upper", upper)]);
        report.judge(
            format!(
                "growth rate of the lowest grain's depth, fit over {}",
                fit_stretch(stretch, a0)
            ),
            format!("{n:.3} 1/s"),
            format!("{lower:.3} … {upper:.3} 1/s"),
            "between the bounds (Robinson §7)".into(),
            Some(inside),
        );
        // Whether the stretch is one exponential, as Robinson's Fig. 13–14 read: the
        // rates of its two halves (sharing the middle sample), reported, not judged. The
        // water quick at α = 0.1 without δ-SPH grew 12–20 1/s a 10 ms until its fluid
        // turned noisy at 35 ms, then 51 and 31, and its fit over 42–60 ms read the burst
        // as 38.904 1/s, between the bounds (results/2026-12-06-lavapipe-rti-alpha).
        let mid = stretch.len() / 2;
        let halves = [&stretch[..=mid], &stretch[mid..]].map(|h| {
            exponential_rate(h).map(|n| {
                format!(
                    "{n:.3} 1/s over t = {:.3e}–{:.3e} s",
                    h[0].0,
                    h[h.len() - 1].0
                )
            })
        });
        if let [Some(first), Some(second)] = halves {
            report.judge(
                "the lowest grain's growth rate over each half of the fitted stretch (not judged: one exponential reads the same in both)",
                format!("{first}; {second}"),
                format!("{n:.3} 1/s over the whole"),
                "reported".into(),
                None,
            );
        }
    }
    // Robinson's Figs. 13–14 set the lowest grain's trajectory beside the bounds'
    // curves a(0) e^(n t) and call it between them; a start from rest lags both curves
    // at first, so a grain whose own rate ends above the upper one can lie between the
    // curves over most of the stretch (ARCHITECTURE.md has the runs that showed it). The
    // chronological runs of the records to half way to the floor against the curves,
    // reported, not judged.
    let t_start = depth[0].0;
    let curve = |n: f64, t: f64| a0 * (n * (t - t_start)).exp();
    let mut runs: Vec<(&str, f64, f64, usize)> = Vec::new();
    for &(t, a) in depth.get(1..stop).unwrap_or_default() {
        let class = if a < curve(lower, t) {
            "below the lower"
        } else if a > curve(upper, t) {
            "above the upper"
        } else {
            "between"
        };
        match runs.last_mut() {
            Some(r) if r.0 == class => (r.2, r.3) = (t, r.3 + 1),
            _ => runs.push((class, t, t, 1)),
        }
    }
    if !runs.is_empty() {
        let text: Vec<String> = (runs.iter())
            .map(|(c, a, b, n)| format!("{c} at t = {a:.3e}–{b:.3e} s ({n} records)"))
            .collect();
        report.judge(
            "the lowest grain's depth against the bounds' curves a(0) e^(n t), to half way to the floor (Robinson's Figs. 13–14 compare these; not judged)",
            text.join("; "),
            format!("n = {lower:.3} … {upper:.3} 1/s from a(0) = {a0:.4e} m at t = {t_start:.3e} s"),
            "reported".into(),
            None,
        );
    }
    report.judge(
        "the single-axis modes of eq. (39), wave number 2π/λ (not judged)",
        format!("{:.3} … {:.3} 1/s", rate(0.93, k)?, rate(eps, k)?),
        format!("ε = 0.93 … ε = {eps}"),
        "reported".into(),
        None,
    );
    // The same growth read from the whole lowest layer instead of one grain.
    let t_stop = track.get(stop).map_or(f64::INFINITY, |p| p.0);
    let modes = lowest_layer_modes(scene, lattice, k, rec);
    if modes.len() >= 2 {
        for (name, pick, wave) in [
            ("cos kx cos kz", 2, "√2 · 2π/λ, the judged bounds'"),
            ("cos kx + cos kz", 1, "2π/λ, the single-axis rates'"),
        ] {
            let amp: Vec<(f64, f64)> = (modes.iter()).map(|m| (m.0, m.1[pick])).collect();
            let b0 = amp[0].1;
            let grow: Vec<(f64, f64)> = (amp.iter().copied())
                .skip_while(|&(_, b)| b < 2.0 * b0)
                .take_while(|&(t, _)| t < t_stop)
                .collect();
            let last = amp[amp.len() - 1];
            let measured = match exponential_rate(&grow) {
                Some(n) if grow.len() >= 5 && b0 > 0.0 => {
                    format!("{n:.3} 1/s over {}", fit_stretch(&grow, b0))
                }
                _ => format!(
                    "did not double and keep growing for 5 samples: {:.3e} m at the start, {:.3e} m at t = {:.3e} s",
                    b0, last.1, last.0
                ),
            };
            report.judge(
                format!(
                    "growth rate of the lowest layer's mode {name} (least squares of its grains' heights; wave number {wave}; not judged)"
                ),
                measured,
                format!("{:.4e} m at the start (A, eq. 39)", p.amplitude),
                "reported".into(),
                None,
            );
        }
        report.series.push(Series {
            name: "lowest-layer-mode-vs-upper-bound".into(),
            x_label: "t (s)".into(),
            y_label: "amplitude of the lowest layer's mode cos kx cos kz (m)".into(),
            points: modes.iter().map(|m| (m.0, m.1[2])).collect(),
            reference: (modes.iter())
                .map(|m| (m.0, modes[0].1[2] * (upper * (m.0 - modes[0].0)).exp()))
                .collect(),
        });
    }
    // The fluid's largest speed in each snapshot, and where: reported, not judged (the
    // instability moves the fluid as it should), so that a report says whether the
    // fluid stayed quiet while the grains were read. The water quick at α = 0 without
    // δ-SPH grew modes at the block's faces, under the lid and in odd-even rows of the
    // block from 20 ms and blew up at 37 ms (ARCHITECTURE.md, "A window longer than the
    // sound's crossing of h"); a full run's recording stays on the GPU machine.
    let fastest: Vec<(f64, f64, f64)> = (rec.snapshots.iter())
        .filter(|(t, _)| *t <= track[track.len() - 1].0 + 1e-9)
        .map(|(t, snap)| {
            (snap.iter()).fold((*t, 0.0, f64::NAN), |m, p| {
                let v = crate::record::particle_speed(p);
                if v > m.1 { (*t, v, f64::from(p[1])) } else { m }
            })
        })
        .collect();
    let (t0, t1) = match stretch {
        [first, .., last] if stretch.len() >= 5 => (first.0, last.0),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    let in_stretch: Vec<&(f64, f64, f64)> = (fastest.iter())
        .filter(|f| f.0 >= t0 - 1e-9 && f.0 <= t1 + 1e-9)
        .collect();
    if let (Some(first), Some(top)) = (
        in_stretch.first(),
        in_stretch.iter().max_by(|a, b| a.1.total_cmp(&b.1)),
    ) {
        report.judge(
            format!(
                "the fluid's largest speed over the {} snapshots {} (not judged)",
                in_stretch.len(),
                if t0.is_finite() { "of the fitted stretch" } else { "recorded" }
            ),
            format!(
                "{:.3e} m/s at t = {:.3e} s, y = {:.3e} m (at t = {:.3e} s: {:.3e} m/s, y = {:.3e} m)",
                top.1, top.0, top.2, first.0, first.1, first.2
            ),
            format!("{v35:.3e} m/s (the block's settling speed, eq. 35)"),
            "reported".into(),
            None,
        );
        report.series.push(Series {
            name: "fluid-largest-speed".into(),
            x_label: "t (s)".into(),
            y_label: "largest fluid speed (m/s)".into(),
            points: fastest.iter().map(|f| (f.0, f.1)).collect(),
            reference: Vec::new(),
        });
    }
    for (name, bound) in [("upper", upper), ("lower", lower)] {
        report.series.push(Series {
            name: format!("lowest-grain-depth-vs-{name}-bound"),
            x_label: "t (s)".into(),
            y_label: "depth below the settling face (m)".into(),
            points: depth.clone(),
            reference: depth.iter().map(|&(t, _)| (t, curve(bound, t))).collect(),
        });
    }
    Ok(())
}

/// The lowest lattice layer's heights at each recorded time, fitted by least squares as
/// y = c₀ + c₁ (cos kx + cos kz) + c₂ cos kx cos kz over its grains' present positions:
/// (t, [c₀, c₁, −c₂]). Robinson eq. (39) starts the layer at c₁ = A, −c₂ = A; the mode
/// cos kx cos kz has wave number √2 k, the one the judged bounds are for, and
/// cos kx + cos kz the single-axis k. Times with fewer than 4 of the layer's grains
/// recorded, or a singular fit, are left out.
pub(super) fn lowest_layer_modes(
    scene: &Scene,
    lattice: &couplet_protocol::scene::GrainLattice,
    k: f64,
    rec: &Recording,
) -> Vec<(f64, [f64; 3])> {
    let n = lattice.counts();
    let prefix = format!("{}[", lattice.name);
    // Grain i of the lattice is in layer (i / n_x) mod n_y (`GrainLattice::centres`).
    let lowest: Vec<bool> = (scene.bodies.iter())
        .map(|b| {
            (b.name.strip_prefix(&prefix))
                .and_then(|r| r.strip_suffix(']'))
                .and_then(|i| i.parse::<usize>().ok())
                .is_some_and(|i| n[0] > 0 && n[1] > 0 && (i / n[0]).is_multiple_of(n[1]))
        })
        .collect();
    // At each record time: the time, the normal equations' matrix and right side of the
    // least squares, and the grains summed.
    type Sums = (f64, [[f64; 3]; 3], [f64; 3], usize);
    let mut at: std::collections::BTreeMap<u64, Sums> = Default::default();
    for b in (rec.bodies.iter()).filter(|b| lowest.get(b.body) == Some(&true)) {
        let (cx, cz) = ((k * b.position[0]).cos(), (k * b.position[2]).cos());
        let f = [1.0, cx + cz, cx * cz];
        let e = (at.entry(b.time.to_bits())).or_insert((b.time, [[0.0; 3]; 3], [0.0; 3], 0));
        for r in 0..3 {
            for c in 0..3 {
                e.1[r][c] += f[r] * f[c];
            }
            e.2[r] += f[r] * b.position[1];
        }
        e.3 += 1;
    }
    (at.into_values())
        .filter(|e| e.3 >= 4)
        .filter_map(|(t, m, v, _)| solve3(m, v).map(|c| (t, [c[0], c[1], -c[2]])))
        .collect()
}

/// "t = t₀–t₁ s (N samples, a from a₀/a(0) to a₁/a(0) a(0))" of a fitted stretch.
fn fit_stretch(stretch: &[(f64, f64)], a0: f64) -> String {
    let (first, last) = (stretch[0], stretch[stretch.len() - 1]);
    format!(
        "t = {:.3e}–{:.3e} s ({} samples, a from {:.2} to {:.2} a(0))",
        first.0,
        last.0,
        stretch.len(),
        first.1 / a0,
        last.1 / a0
    )
}

/// Robinson Fig. 9 across the CPB's variants: per fluid, the settling speed over one
/// grain's terminal velocity u_t (eq. 35 at ε = 1) against ε, with eq. (35) as
/// reference markers, and the largest error across ε. The variants' own rows judge each
/// point; this gathers them.
pub(super) fn cpb_porosity_series(parts: &[Report], report: &mut Report) -> Result<(), String> {
    let get = |r: &Report, k: &str| {
        r.value(k)
            .ok_or_else(|| format!("{}: no `{k}` in the analysis", r.case))
    };
    // "constant-porosity-block (water, ε = 0.8)" → "water"
    let fluid = |r: &Report| {
        r.case
            .split_once('(')
            .and_then(|(_, l)| l.split(',').next())
            .unwrap_or(&r.case)
            .to_owned()
    };
    let mut fluids: Vec<String> = parts.iter().map(fluid).collect();
    fluids.dedup();
    for name in fluids {
        let (mut points, mut reference, mut worst) = (Vec::new(), Vec::new(), (0.0_f64, 0.0));
        for r in parts.iter().filter(|r| fluid(r) == name) {
            let (eps, u_t) = (get(r, "porosity")?, get(r, "single")?);
            let (v, v35) = (get(r, "speed")?, get(r, "eq35")?);
            points.push((eps, v / u_t));
            reference.push((eps, v35 / u_t));
            let e = (v - v35).abs() / v35;
            if e >= worst.0 {
                worst = (e, eps);
            }
        }
        report.judge(
            format!("{name}: largest settling-speed error across ε (Fig. 9)"),
            format!("{} at ε = {}", pct(worst.0), worst.1),
            "Robinson eq. (35)".into(),
            "reported (each ε judged above)".into(),
            None,
        );
        report.series.push(Series {
            name: format!("settling-speed-over-ut-{}", slug(&name)),
            x_label: "block porosity ε".into(),
            y_label: "settling speed / u_t (one grain)".into(),
            points,
            reference,
        });
    }
    Ok(())
}

/// The fluid's mean vertical velocity by height in one snapshot (20 bins over the
/// domain): a column at rest or carrying a return flow shows it at a glance.
pub(super) fn fluid_velocity_profile(
    scene: &Scene,
    t: f64,
    snap: &[crate::record::Particle],
) -> Series {
    let (y0, y1) = (scene.domain.min[1], scene.domain.max[1]);
    let mut bins = vec![(0.0, 0usize); 20];
    for p in snap {
        let k = (((f64::from(p[1]) - y0) / (y1 - y0) * 20.0).floor().max(0.0) as usize).min(19);
        bins[k].0 += f64::from(p[5]);
        bins[k].1 += 1;
    }
    Series {
        name: "fluid-velocity-profile".into(),
        x_label: "y (m)".into(),
        y_label: format!("mean fluid u_y at t = {t:.3e} s (m/s)"),
        points: (bins.iter().enumerate())
            .filter(|(_, b)| b.1 > 0)
            .map(|(k, b)| (y0 + (k as f64 + 0.5) / 20.0 * (y1 - y0), b.0 / b.1 as f64))
            .collect(),
        reference: Vec::new(),
    }
}

/// |g| of the scene's gravity vector, m/s².
/// The fluid server's porosity field of the scene (Robinson eq. 9: its kernel, its
/// coupling length, the domain's periods).
fn porosity_field(scene: &Scene) -> Result<PorosityField, String> {
    let consts =
        couplet_fluid::constants::SphConstants::from_scene(scene).map_err(|e| e.to_string())?;
    Ok(PorosityField::of_scene(&consts, scene))
}

pub(super) fn gravity_magnitude(scene: &Scene) -> f64 {
    scene
        .gravity
        .vector
        .iter()
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
}

/// The scene's first unresolved grain (body index, spec, radius): the lone grain of the
/// single-grain cases.
fn first_grain(scene: &Scene) -> Result<(usize, &couplet_protocol::BodySpec, f64), String> {
    let i = *scene
        .grains()
        .first()
        .ok_or("the scene has no unresolved grain")?;
    let body = &scene.bodies[i];
    match body.shape {
        couplet_protocol::Shape::Sphere { radius } => Ok((i, body, radius)),
        _ => Err("the grain is not a sphere".into()),
    }
}
