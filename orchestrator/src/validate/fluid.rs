//! The fluid-only cases of the corrected scheme (issue 3): the hydrostatic tank, the
//! dam break against Martin & Moyce (1952), the lid-driven cavity against Ghia, Ghia &
//! Shin (1982), Poiseuille and Couette start-up against Morris, Fox & Zhu (1997), and the
//! Taylor–Green vortex.

use super::*;

/// Hydrostatic tank: the pressure of particles farther than the support from the walls
/// and the free surface, averaged over the last 0.1 s (longer than the column's acoustic
/// period 4H/c, which WCSPH leaves weakly damped), against ρ0 g (H − y), H the mean
/// height of the top row plus δ/2; 2 % of ρ0 g H for the standard scheme (issue 2), 1 %
/// with the gradient correction or δ-SPH (issue 3). The fluid mass is the count
/// times the constant particle mass: conserved exactly.
pub(super) fn hydrostatic(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let (rho0, g) = (f.density, -scene.gravity.vector[1]);
    // Issue 2 holds the standard scheme to 2 %; issue 3 the corrected scheme and δ-SPH to 1 %.
    let e = &scene.effects;
    let tolerance = if e.gradient_correction || e.density_diffusion > 0.0 {
        0.01
    } else {
        0.02
    };
    let (dx, support) = (f.spacing, f.support_radius());
    let n0 = rec
        .snapshots
        .first()
        .ok_or("no particle snapshots")?
        .1
        .len();
    let kept = rec.snapshots.iter().all(|(_, s)| s.len() == n0);
    report.judge(
        "fluid particles (mass / m)",
        format!("{n0} throughout: {kept}"),
        format!("{n0}"),
        "exact".into(),
        Some(kept),
    );
    let finite = rec
        .snapshots
        .iter()
        .all(|(_, s)| s.iter().all(|p| p.iter().all(|v| v.is_finite())));
    report.judge(
        "all values finite",
        finite.to_string(),
        "true".into(),
        "exact".into(),
        Some(finite),
    );
    // A column at rest has no mean vertical velocity; a steady drift (the column settling
    // into its floor) shows here long before it shows in the pressure.
    let drift: Vec<(f64, f64)> = (rec.snapshots.iter())
        .map(|(t, s)| {
            (
                *t,
                s.iter().map(|p| f64::from(p[5])).sum::<f64>() / s.len() as f64,
            )
        })
        .collect();
    let t_end = drift.last().map_or(0.0, |d| d.0);
    let late: Vec<f64> = (drift.iter())
        .filter(|d| d.0 >= 0.5 * t_end)
        .map(|d| d.1)
        .collect();
    if !late.is_empty() {
        report.judge(
            "mean vertical fluid velocity over all particles, averaged over the second half",
            format!("{:.3e} m/s", late.iter().sum::<f64>() / late.len() as f64),
            "0 (at rest)".into(),
            "reported".into(),
            None,
        );
    }
    report.series.push(Series {
        name: "mean-vertical-velocity".into(),
        x_label: "t (s)".into(),
        y_label: "mean fluid u_y over all particles (m/s)".into(),
        points: drift,
        reference: Vec::new(),
    });
    let mean = time_average(rec, 0.1)?;
    let top = mean
        .iter()
        .map(|p| f64::from(p[1]))
        .fold(f64::MIN, f64::max);
    let row: Vec<f64> = mean
        .iter()
        .map(|p| f64::from(p[1]))
        .filter(|y| *y > top - 0.5 * dx)
        .collect();
    let surface = row.iter().sum::<f64>() / row.len() as f64 + 0.5 * dx;
    let (lo, hi) = (scene.domain.min, scene.domain.max);
    let p_bottom = rho0 * g * (surface - lo[1]);
    let (mut worst, mut n, mut profile) = (0.0f64, 0, Vec::new());
    for p in &mean {
        let x = [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
        let inside = (0..3).all(|k| x[k] > lo[k] + support && (k == 1 || x[k] < hi[k] - support));
        if inside && x[1] < surface - support {
            let want = rho0 * g * (surface - x[1]);
            worst = worst.max((f64::from(p[3]) - want).abs() / p_bottom);
            n += 1;
            profile.push((surface - x[1], f64::from(p[3])));
        }
    }
    if n == 0 {
        return Err("no particle farther than the support from walls and surface".into());
    }
    report.judge(
        format!("largest deviation of p̄ from ρ0 g (H − y), over ρ0 g H ({n} interior particles, last 0.1 s)"),
        pct(worst),
        "0 (hydrostatics)".into(),
        pct(tolerance),
        Some(worst < tolerance),
    );
    report.headline = Some(("hydrostatic pressure error / ρ0 g H".into(), worst));
    profile.sort_by(|a, b| a.0.total_cmp(&b.0));
    let depth_max = profile.last().map_or(0.0, |p| p.0);
    report.series.push(Series {
        name: "pressure-vs-depth".into(),
        x_label: "depth H − y (m)".into(),
        y_label: "time-averaged pressure (Pa)".into(),
        points: profile,
        reference: (0..=10)
            .map(|k| depth_max * f64::from(k) / 10.0)
            .map(|d| (d, rho0 * g * d))
            .collect(),
    });
    Ok(())
}

/// Martin & Moyce (1952), fig. 3, n² = 2 (column height 2a): (T, Z) for the two column
/// widths, `../shared/validation/martin_moyce1952_surge_front.csv`.
pub(super) const MARTIN_MOYCE: [(f64, f64); 17] = [
    (0.849, 1.245),
    (1.212, 1.443),
    (1.602, 1.884),
    (2.283, 2.689),
    (2.950, 3.728),
    (3.598, 4.528),
    (3.905, 4.999),
    (4.592, 5.841),
    (4.961, 6.271),
    (5.316, 6.717),
    (0.832, 1.217),
    (1.219, 1.474),
    (1.997, 2.292),
    (2.547, 2.995),
    (3.345, 4.134),
    (4.034, 4.944),
    (4.418, 5.881),
];

/// The release delays the dam-break report tries, ΔT = 0, 0.005, …, 0.6 (T units; 0.6 is
/// 33 ms at a = 2.25 in).
pub(super) const DAM_BREAK_DELAY_STEP: f64 = 0.005;
pub(super) const DAM_BREAK_MAX_DELAY_STEPS: u32 = 120;

/// The largest relative deviation of the simulated front `front` (T, Z) from Martin &
/// Moyce's points, each compared at T − `delay` (the measurements' clock started `delay`
/// early: 0 for the plain comparison), linear between snapshots; points whose T − delay
/// falls outside the run are skipped. Returns (deviation, T, Z_sim, Z_MM) of the worst.
pub(super) fn surge_front_deviation(
    front: &[(f64, f64)],
    delay: f64,
) -> Result<(f64, f64, f64, f64), String> {
    let (t_min, t_max) = match (front.first(), front.last()) {
        (Some(a), Some(b)) => (a.0, b.0),
        _ => return Err("no front".into()),
    };
    let mut worst: Option<(f64, f64, f64, f64)> = None;
    for &(tm, zm) in &MARTIN_MOYCE {
        let t = tm - delay;
        if t > t_max || (delay > 0.0 && t < t_min) {
            continue;
        }
        let i = front
            .iter()
            .position(|p| p.0 >= t)
            .ok_or("front series ends early")?;
        let z = if i == 0 {
            front[0].1
        } else {
            let (a0, a1) = (front[i - 1], front[i]);
            a0.1 + (a1.1 - a0.1) * (t - a0.0) / (a1.0 - a0.0)
        };
        let dev = (z - zm).abs() / zm;
        if worst.is_none_or(|w| dev > w.0) {
            worst = Some((dev, tm, z, zm));
        }
    }
    worst.ok_or_else(|| "no Martin & Moyce point inside the run".into())
}

/// Dam break: the surge front x_f(t) is the largest x of fluid particles within 2δ of the
/// floor, ignoring the 0.5 % farthest (single particles thrown ahead); Z = (x_f − x_0)/a
/// with x_0 the wall behind the column, T = t √(2g/a). Every Martin & Moyce point inside
/// the run's T range is compared with the simulated Z at that T (linear in between
/// snapshots): the largest deviation relative to the measured Z, 5 % (issue 3). Reported
/// beside it: the same with the measurements' clock shifted by the best-fitting release
/// delay ΔT, and the front speed over T ≥ 2 against the measured one. Measured
/// (2026-11-25, `--quick --spacing D`): the plain deviation grows with refinement, 9.7 %
/// (a/5, front behind), 16.2 % (a/10), 23.6 % (a/20), 24.5 % (a/30; all three ahead,
/// worst at T = 1.21), while the front speed converges to the measured one (−15.2,
/// +3.7, +1.3, −0.6 %) and with ΔT = 0.21, 0.275 and 0.295 (11–16 ms at a = 2.25 in)
/// the deviation is 3.5, 4.0 and 3.8 %: the simulated front leads by a near-constant
/// ΔZ, as a measured column released late would. The full case (a/50, side walls, 20
/// layers deep; 2026-12-01 on lavapipe, `results/2026-12-01-lavapipe/`): 21.9 % plain
/// (worst at T = 1.21, Z = 1.759 against 1.443), 4.24 % with ΔT = 0.275 (14.8 ms),
/// front speed +3.0 %.
pub(super) fn dam_break(scene: &Scene, rec: &Recording, report: &mut Report) -> Result<(), String> {
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let block = f.blocks.first().ok_or("the scene has no fluid block")?;
    let (x0, a) = (block.min[0], block.max[0] - block.min[0]);
    let g = -scene.gravity.vector[1];
    let floor = scene.domain.min[1];
    let scale = (2.0 * g / a).sqrt();
    let mut front = Vec::new();
    for (t, s) in &rec.snapshots {
        let mut xs: Vec<f64> = s
            .iter()
            .filter(|p| f64::from(p[1]) - floor < 2.0 * f.spacing)
            .map(|p| f64::from(p[0]))
            .collect();
        if xs.is_empty() {
            continue;
        }
        xs.sort_by(f64::total_cmp);
        let k = ((xs.len() as f64) * 0.995) as usize;
        let xf = xs[k.min(xs.len() - 1)] + 0.5 * f.spacing;
        front.push((t * scale, (xf - x0) / a));
    }
    if front.len() < 3 {
        return Err(format!("only {} particle snapshots", front.len()));
    }
    let t_max = front.last().map_or(0.0, |p| p.0);
    let (dev, tm, z, zm) = surge_front_deviation(&front, 0.0)?;
    report.headline = Some(("surge-front deviation from Martin & Moyce".into(), dev));
    report.judge(
        format!("surge front: largest deviation of Z from Z_MM, relative, for T ≤ {t_max:.2} (worst at T = {tm:.2}: Z = {z:.3})"),
        pct(dev),
        format!("Martin & Moyce 1952 (Z = {zm:.3} there)"),
        "< 5 %".into(),
        Some(dev < 0.05),
    );
    // Two readings that a late release of the measured column does not change (the
    // simulated front leads from the first points on, by about the same ΔZ throughout):
    // the same comparison with the measurements' clock started late by the ΔT that fits
    // best, and the front's speed once it runs (T ≥ 2).
    let (shift, shifted) = (0..=DAM_BREAK_MAX_DELAY_STEPS)
        .map(|k| f64::from(k) * DAM_BREAK_DELAY_STEP)
        .filter_map(|d| surge_front_deviation(&front, d).ok().map(|w| (d, w.0)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or("no delay leaves a comparison")?;
    report.judge(
        format!(
            "surge front with the measured clock started late by the best-fitting ΔT = {shift:.3} (t = {:.1} ms at a = 2.25 in): largest deviation",
            1e3 * shift / (2.0 * g / 0.05715).sqrt()
        ),
        pct(shifted),
        "Martin & Moyce 1952, Z(T − ΔT)".into(),
        "reported".into(),
        None,
    );
    let running = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
        pts.iter()
            .copied()
            .filter(|(t, _)| (2.0..=t_max).contains(t))
            .collect()
    };
    if let (Some(sim), Some(mm)) = (
        least_squares_slope(&running(&front)),
        least_squares_slope(&running(&MARTIN_MOYCE)),
    ) {
        report.judge(
            format!("surge-front speed dZ/dT, least squares over 2 ≤ T ≤ {t_max:.2}"),
            format!("{sim:.3} ({:+.1} %)", 100.0 * (sim - mm) / mm),
            format!("{mm:.3} (Martin & Moyce, both widths)"),
            "reported".into(),
            None,
        );
    }
    report.series.push(Series {
        name: "surge-front".into(),
        x_label: "T = t √(2g/a)".into(),
        y_label: "Z = x/a".into(),
        points: front,
        reference: MARTIN_MOYCE
            .iter()
            .filter(|(t, _)| *t <= t_max)
            .copied()
            .collect(),
    });
    Ok(())
}

/// Ghia, Ghia & Shin (1982), Re = 100, `../shared/validation/ghia1982_re100.csv`:
/// (y, u) on the vertical centreline x = L/2 (their Table I) and (x, v) on the
/// horizontal centreline y = H/2 (Table II), in units of L and U; the wall points
/// (where the values are the boundary conditions) are left out.
pub(super) const GHIA_U: [(f64, f64); 15] = [
    (0.9766, 0.84123),
    (0.9688, 0.78871),
    (0.9609, 0.73722),
    (0.9531, 0.68717),
    (0.8516, 0.23151),
    (0.7344, 0.00332),
    (0.6172, -0.13641),
    (0.5000, -0.20581),
    (0.4531, -0.21090),
    (0.2813, -0.15662),
    (0.1719, -0.10150),
    (0.1016, -0.06434),
    (0.0703, -0.04775),
    (0.0625, -0.04192),
    (0.0547, -0.03717),
];
pub(super) const GHIA_V: [(f64, f64); 15] = [
    (0.9688, -0.05906),
    (0.9609, -0.07391),
    (0.9531, -0.08864),
    (0.9453, -0.10313),
    (0.9063, -0.16914),
    (0.8594, -0.22445),
    (0.8047, -0.24533),
    (0.5000, 0.05454),
    (0.2344, 0.17527),
    (0.2266, 0.17507),
    (0.1563, 0.16077),
    (0.0938, 0.12317),
    (0.0781, 0.10890),
    (0.0703, 0.10091),
    (0.0625, 0.09233),
];

/// Joubert §3.1's differences from Ghia at δ = L/100: maximum and mean, u then v, as
/// fractions of U.
pub(super) const JOUBERT_CAVITY: [[f64; 2]; 2] = [[0.0129, 0.0111], [0.0048, 0.0036]];

/// Bounds for coarser runs (δ > L/100), [largest, mean] × [u, v] / U: the quick case
/// (δ = L/10, Adami walls, Joubert's corrected scheme) measured 15.46 / 7.96 % largest
/// and 4.85 / 3.60 % mean on 2026-11-22; the bounds leave about 25 % above that, a
/// regression guard for the reduced version, not an accuracy claim.
pub(super) const COARSE_CAVITY: [[f64; 2]; 2] = [[0.20, 0.10], [0.06, 0.05]];

/// Velocity component `k` at (x, y) from every particle within `r` in the xy-plane (all
/// z: the flow is z-invariant): the value of the weighted least-squares plane
/// `a + b (x' − x) + c (y' − y)` through them (Wendland C2 weight). Unlike a Shepard
/// average it is exact for a linear field, so a probe next to the lid, whose support is
/// one-sided, is not biased towards the slower fluid below it. That matters at coarse
/// resolution: Ghia's top point lies 0.0234 L below the lid, inside the last fluid row's
/// spacing at δ = L/10, where the support (0.3 L) is mostly beyond the lid; at δ = L/100
/// the two probes differ by 4e-5 U there. `None` when the points do not span the plane
/// (fewer than three, or collinear).
pub(super) fn probe_xy(snap: &[Particle], x: f64, y: f64, r: f64, k: usize) -> Option<f64> {
    // Normal equations of the weighted fit in (1, dx, dy), lengths in units of r.
    let (mut m, mut rhs) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
    for p in snap {
        let (dx, dy) = ((f64::from(p[0]) - x) / r, (f64::from(p[1]) - y) / r);
        let d = dx.hypot(dy);
        if d < 1.0 {
            let w = (1.0 - d).powi(4) * (1.0 + 4.0 * d);
            let basis = [1.0, dx, dy];
            for a in 0..3 {
                for b in 0..3 {
                    m[a][b] += w * basis[a] * basis[b];
                }
                rhs[a] += w * basis[a] * f64::from(p[4 + k]);
            }
        }
    }
    // The constant term; m[0][0] = Σw is the largest entry (|dx|, |dy| < 1), the scale
    // solve3 measures singularity by.
    solve3(m, rhs).map(|c| c[0])
}

/// Lid-driven cavity (Joubert §3.1): u on x = L/2 and v on y = H/2 at Ghia's points,
/// each probed with a support-radius least-squares plane ([`probe_xy`]) in every snapshot of the last
/// 20 % of the run and averaged over them; the largest and the mean difference from
/// Ghia et al. (1982) as fractions of U. Judged against Joubert's own figures (max
/// 1.29 % / 1.11 %, mean 0.48 % / 0.36 % for u / v) when δ ≤ L/100, his resolution;
/// reported otherwise. Steadiness: how much the profiles change between the two halves
/// of that span (reported).
pub(super) fn lid_driven_cavity(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let lid = scene.domain.lid_velocity;
    let u_lid = lid[0].hypot(lid[2]);
    if !(u_lid > 0.0) {
        return Err("the scene has no moving lid (domain.lid_velocity)".into());
    }
    let (x0, y0) = (scene.domain.min[0], scene.domain.min[1]);
    let l = scene.domain.max[0] - x0;
    let h = scene.domain.max[1] - y0;
    let (t_end, _) = rec.snapshots.last().ok_or("no particle snapshots")?;
    let span = 0.2 * t_end;
    let tail: Vec<&(f64, Vec<Particle>)> = rec
        .snapshots
        .iter()
        .filter(|(t, _)| *t >= t_end - span - 1e-9)
        .collect();
    if tail.len() < 2 {
        return Err(format!(
            "only {} snapshots in the last 20 % of the run",
            tail.len()
        ));
    }
    let r = f.support_radius();
    // Mean over `snaps` of the profile at Ghia's points: u(y) at x = L/2, v(x) at y = H/2.
    let profile = |snaps: &[&(f64, Vec<Particle>)], v_line: bool| -> Result<Vec<f64>, String> {
        let points: &[(f64, f64)] = if v_line { &GHIA_V } else { &GHIA_U };
        points
            .iter()
            .map(|&(c, _)| {
                let (x, y) = if v_line {
                    (x0 + c * l, y0 + 0.5 * h)
                } else {
                    (x0 + 0.5 * l, y0 + c * h)
                };
                let k = usize::from(v_line);
                let mut sum = 0.0;
                for (_, s) in snaps {
                    sum += probe_xy(s, x, y, r, k)
                        .ok_or(format!("too few fluid particles within the support of ({x:.4}, {y:.4}) to fit a plane"))?;
                }
                Ok(sum / snaps.len() as f64 / u_lid)
            })
            .collect()
    };
    let half = tail.len() / 2;
    let mut worst = 0.0f64;
    for (v_line, name, coord) in [
        (false, "u(y) on x = L/2", "y/H"),
        (true, "v(x) on y = H/2", "x/L"),
    ] {
        let points: &[(f64, f64)] = if v_line { &GHIA_V } else { &GHIA_U };
        let got = profile(&tail, v_line)?;
        let first = profile(&tail[..half], v_line)?;
        let second = profile(&tail[half..], v_line)?;
        let diffs: Vec<f64> = got
            .iter()
            .zip(points)
            .map(|(g, (_, want))| (g - want).abs())
            .collect();
        let max = diffs.iter().copied().fold(0.0, f64::max);
        let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
        let drift = first
            .iter()
            .zip(&second)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        worst = worst.max(max);
        let i = usize::from(v_line);
        let judged = f.spacing <= l / 100.0 * (1.0 + 1e-9);
        let at = diffs
            .iter()
            .position(|d| *d == max)
            .map_or(0.0, |k| points[k].0);
        let rows = [
            (
                format!(
                    "{name}: largest difference / U at Ghia's {} points (worst at {coord} = {at})",
                    points.len()
                ),
                max,
                "largest",
                0,
            ),
            (
                format!("{name}: mean absolute difference / U"),
                mean,
                "mean",
                1,
            ),
        ];
        for (quantity, value, what, k) in rows {
            let paper = JOUBERT_CAVITY[k][i];
            let (bound, tolerance) = if judged {
                (paper, format!("≤ {}", pct(paper)))
            } else {
                let coarse = COARSE_CAVITY[k][i];
                (
                    coarse,
                    format!("≤ {} (δ > L/100: coarse bound)", pct(coarse)),
                )
            };
            report.judge(
                quantity,
                pct(value),
                format!(
                    "Ghia et al. 1982 (Joubert §3.1's {what} difference at δ = L/100: {})",
                    pct(paper)
                ),
                tolerance,
                Some(value <= bound),
            );
        }
        report.judge(
            format!(
                "{name}: largest change between the halves of the last {span:.1} s (steadiness)"
            ),
            pct(drift),
            "steady state: 0".into(),
            "reported".into(),
            None,
        );
        report.series.push(Series {
            name: if v_line {
                "v-horizontal-centreline".into()
            } else {
                "u-vertical-centreline".into()
            },
            x_label: coord.into(),
            y_label: if v_line { "v/U".into() } else { "u/U".into() },
            points: points.iter().map(|p| p.0).zip(got).collect(),
            reference: points.to_vec(),
        });
    }
    report.headline = Some(("largest centreline difference from Ghia / U".into(), worst));
    Ok(())
}

/// Start-up flow between plates at y = 0 and y = `l` (Morris, Fox & Zhu 1997, the
/// series of `../shared/validation/morris1997_*_startup.csv`): fluid at rest at t = 0,
/// driven by a body force `f` along x (plane Poiseuille) and by the top plate sliding
/// at `v0` (plane Couette). The problem is linear, so the two solutions add:
///
///   u = F y (L − y)/(2ν) − Σ_{n≥0} 4 F L²/(ν π³ (2n+1)³) sin((2n+1) π y/L) e^{−(2n+1)² π² ν t/L²}
///     + V0 y/L + Σ_{n≥1} 2 V0/(n π) (−1)ⁿ sin(n π y/L) e^{−n² π² ν t/L²}.
///
/// Terms are summed until the exponential falls below 1e-18 (t > 0); u(y, 0) = 0
/// below the plate.
pub fn morris_channel_velocity(y: f64, t: f64, l: f64, nu: f64, f: f64, v0: f64) -> f64 {
    use std::f64::consts::PI;
    if t <= 0.0 {
        return if y >= l { v0 } else { 0.0 };
    }
    let a = PI * PI * nu * t / (l * l);
    let mut u = f * y * (l - y) / (2.0 * nu) + v0 * y / l;
    for n in 1..100_000u32 {
        let k = f64::from(n);
        let decay = (-k * k * a).exp();
        if decay < 1e-18 {
            break;
        }
        let s = (k * PI * y / l).sin() * decay;
        if n % 2 == 1 {
            // Poiseuille: odd wavenumbers k = 2m + 1.
            u -= 4.0 * f * l * l / (nu * PI.powi(3) * k.powi(3)) * s;
        }
        let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
        u += 2.0 * v0 / (k * PI) * sign * s;
    }
    u
}

/// Plane Poiseuille and Couette start-up (issue 3, case 2): at every snapshot after
/// t = 0 the relative L2 error of the fluid's u_x against [`morris_channel_velocity`]
/// at each particle's height, √(Σ (u − u_a)² / Σ u_a²). Start-up (t < ½ L²/ν) is held
/// to 2 %, the steady state (the last snapshot, t ≥ L²/ν) to 1 %; Morris et al.'s
/// snapshot times 0.0225, 0.045 and 0.1125 s are listed. The cross-stream velocity is
/// reported as a fraction of the steady maximum.
pub(super) fn channel_flow(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let fl = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let d = &scene.domain;
    let (y0, l, nu) = (d.min[1], d.max[1] - d.min[1], fl.kinematic_viscosity);
    let f = if scene.gravity.on_fluid {
        scene.gravity.vector[0]
    } else {
        0.0
    };
    let v0 = d.lid_velocity[0];
    let u_ref = (f * l * l / (8.0 * nu)).abs().max(v0.abs());
    if u_ref == 0.0 || nu <= 0.0 {
        return Err("neither a body force along x nor a lid velocity drives the flow".into());
    }
    let errors: Vec<(f64, f64, f64)> = rec
        .snapshots
        .iter()
        .filter(|(t, _)| *t > 0.0)
        .map(|(t, s)| {
            let (mut num, mut den, mut cross) = (0.0, 0.0, 0.0f64);
            for p in s {
                let ua = morris_channel_velocity(f64::from(p[1]) - y0, *t, l, nu, f, v0);
                num += (f64::from(p[4]) - ua).powi(2);
                den += ua * ua;
                cross = cross.max(f64::from(p[5]).abs().max(f64::from(p[6]).abs()));
            }
            (*t, (num / den).sqrt(), cross / u_ref)
        })
        .collect();
    let &(t_end, steady, _) = errors.last().ok_or("no snapshot after t = 0")?;
    let t_diff = l * l / nu;
    let finite = errors.iter().all(|e| e.1.is_finite());
    report.judge(
        "all values finite",
        finite.to_string(),
        "true".into(),
        "exact".into(),
        Some(finite),
    );
    for t_m in [0.0225, 0.045, 0.1125] {
        if let Some(e) = errors.iter().find(|e| (e.0 - t_m).abs() < 1e-3 * t_diff) {
            report.judge(
                format!("L2 error of u at t = {:.4} s", e.0),
                pct(e.1),
                "Morris et al. (1997) series".into(),
                "reported (start-up bound below)".into(),
                None,
            );
        }
    }
    let startup = errors
        .iter()
        .filter(|e| e.0 < 0.5 * t_diff)
        .map(|e| e.1)
        .fold(f64::NAN, f64::max);
    report.judge(
        format!(
            "largest L2 error of u during start-up (t < {:.3} s = ½ L²/ν)",
            0.5 * t_diff
        ),
        pct(startup),
        "Morris et al. (1997) series".into(),
        "< 2 %".into(),
        Some(startup < 0.02),
    );
    report.judge(
        format!("L2 error of u at the steady state (t = {t_end:.4} s)"),
        pct(steady),
        "Morris et al. (1997) series".into(),
        "< 1 %".into(),
        Some(t_end >= t_diff && steady < 0.01),
    );
    let cross = errors.iter().map(|e| e.2).fold(0.0, f64::max);
    report.judge(
        "largest cross-stream |v|, |w| over the run",
        format!("{} of u_max", pct(cross)),
        "0".into(),
        "reported".into(),
        None,
    );
    report.headline = Some(("steady-state L2 error of u".into(), steady));
    let (_, last) = rec.snapshots.last().expect("checked above");
    let mut profile: Vec<(f64, f64)> = last
        .iter()
        .map(|p| (f64::from(p[1]) - y0, f64::from(p[4])))
        .collect();
    profile.sort_by(|a, b| a.0.total_cmp(&b.0));
    report.series.push(Series {
        name: "velocity-profile".into(),
        x_label: "y (m)".into(),
        y_label: format!("u_x at t = {t_end:.4} s (m/s)"),
        points: profile,
        reference: (0..=20)
            .map(|k| l * f64::from(k) / 20.0)
            .map(|y| (y, morris_channel_velocity(y, t_end, l, nu, f, v0)))
            .collect(),
    });
    report.series.push(Series {
        name: "l2-error".into(),
        x_label: "t (s)".into(),
        y_label: "relative L2 error of u_x".into(),
        points: errors.iter().map(|e| (e.0, e.1)).collect(),
        reference: Vec::new(),
    });
    Ok(())
}

/// Taylor–Green vortex (issue 3, case 3): the kinetic energy E(t) = Σ ½ m |u|² of every
/// snapshot (m = ρ0 δ³, the same for all particles) decays as e^{2bt} with
/// b = −8π²ν/L² (`fluid.initial_flow`). The rate is the least-squares slope of ln E
/// against t over the snapshots after the first 5 % of the run (the start-up acoustic
/// adjustment of the lattice), held to 2 % of 2b.
pub(super) fn taylor_green(
    scene: &Scene,
    rec: &Recording,
    report: &mut Report,
) -> Result<(), String> {
    let f = scene.fluid.as_ref().ok_or("the scene has no fluid")?;
    let Some(couplet_protocol::InitialFlow::TaylorGreen {
        velocity: u0,
        wavelength,
    }) = f.initial_flow
    else {
        return Err("the scene has no Taylor–Green initial flow".into());
    };
    let b = -8.0 * std::f64::consts::PI.powi(2) * f.kinematic_viscosity / (wavelength * wavelength);
    let mass = f.density * f.spacing.powi(3);
    let energy: Vec<(f64, f64)> = rec
        .snapshots
        .iter()
        .map(|(t, s)| {
            let e: f64 = s
                .iter()
                .map(|p| 0.5 * mass * (p[4..7].iter().map(|v| f64::from(*v).powi(2)).sum::<f64>()))
                .sum();
            (*t, e)
        })
        .collect();
    let t_end = energy.last().ok_or("no particle snapshots")?.0;
    let fit: Vec<(f64, f64)> = energy
        .iter()
        .filter(|(t, e)| *t >= 0.05 * t_end && *e > 0.0)
        .copied()
        .collect();
    if fit.len() < 3 {
        return Err(format!("only {} snapshots to fit the decay", fit.len()));
    }
    let rate = exponential_rate(&fit).ok_or("the decay's snapshots share one time")?;
    let error = (rate - 2.0 * b).abs() / (2.0 * b).abs();
    let finite = energy.iter().all(|(_, e)| e.is_finite());
    report.judge(
        "all values finite",
        finite.to_string(),
        "true".into(),
        "exact".into(),
        Some(finite),
    );
    report.judge(
        format!(
            "kinetic-energy decay rate d ln E/dt over t ∈ [{:.3}, {t_end:.3}] s",
            0.05 * t_end
        ),
        format!("{rate:.4} 1/s"),
        format!("{:.4} 1/s (2b = −16π²ν/L²)", 2.0 * b),
        "± 2 %".into(),
        Some(error < 0.02),
    );
    report.judge(
        "decay-rate error",
        pct(error),
        "0".into(),
        "reported".into(),
        None,
    );
    let (t0, e_first) = energy[0];
    let e_analytic = 0.25 * f.density * u0 * u0 * (2.0 * b * t0).exp();
    report.judge(
        format!("kinetic energy per unit volume at the first snapshot (t = {t0:.3} s)"),
        format!("{:.4} J/m³", e_first / scene_volume(scene)),
        format!("{e_analytic:.4} J/m³ (ρ U²/4 e^(2bt))"),
        "reported".into(),
        None,
    );
    report.headline = Some(("decay-rate error".into(), error));
    report.series.push(Series {
        name: "kinetic-energy".into(),
        x_label: "t (s)".into(),
        y_label: "E(t) / E(first snapshot)".into(),
        points: energy.iter().map(|(t, e)| (*t, e / e_first)).collect(),
        reference: energy
            .iter()
            .map(|(t, _)| (*t, (2.0 * b * (t - t0)).exp()))
            .collect(),
    });
    Ok(())
}
