//! Drag laws of unresolved coupling (`drag.rs`) against the reference tables in
//! `../shared/validation/` (copied here: CI clones only this repository), and the WGSL
//! `drag_force` against its CPU twin.

use couplet_fluid::drag::{
    DragInput, DragLaw, coulson_richardson_cd, dallavalle_cd, di_felice_chi, drag_force,
    drag_table_gpu, huilin_gidaspow_weight, momentum_exchange, schiller_naumann_cd,
};
use couplet_fluid::gpu::shared_test_gpu;
use std::f64::consts::PI;

/// `sphere_drag_correlations.csv`: Re, Stokes, Schiller–Naumann, Dallavalle, Coulson–
/// Richardson form, Di Felice χ.
const SPHERE_CD: [[f64; 6]; 10] = [
    [0.01, 2400.0, 2415.2161, 2364.8769, 2491.4415, 3.6985781],
    [0.1, 240.0, 247.40121, 249.92236, 241.33566, 3.671441],
    [0.2, 120.0, 125.95772, 129.12064, 122.53959, 3.6420699],
    [1.0, 24.0, 27.6, 29.4849, 27.292822, 3.4889759],
    [10.0, 2.4, 4.1510659, 4.6134455, 4.1728666, 3.126377],
    [100.0, 0.24, 1.0917311, 1.2321, 1.0412933, 3.126377],
    [200.0, 0.12, 0.80561469, 0.93975818, 0.77135579, 3.2283921],
    [500.0, 0.048, 0.5626653, 0.71345478, 0.56551611, 3.3832199],
    [1000.0, 0.024, 0.44, 0.61119455, 0.47607156, 3.4889759],
    [10000.0, 0.0024, 0.44, 0.459684, 0.37392716, 3.671441],
];

/// `porous_drag_beta_examples.csv` (water ρ = 1000, μ = 1e-3, d = 1 mm, |u − v| = 0.01
/// m/s): ε, β Ergun, β Wen–Yu, β Gidaspow switch, β Di Felice equivalent.
const POROUS_BETA: [[f64; 5]; 9] = [
    [0.4, 145500.0, 170058.74, 145500.0, 131751.36],
    [0.5, 83750.0, 82090.98, 83750.0, 67740.545],
    [0.6, 47000.0, 42195.084, 47000.0, 37119.237],
    [0.7, 24535.714, 21831.007, 24535.714, 20443.127],
    [0.79, 12048.418, 11440.274, 12048.418, 11308.733],
    [0.8, 11000.0, 10573.32, 10573.32, 10513.316],
    [0.81, 10010.185, 9751.4391, 9751.4391, 9752.9353],
    [0.9, 3416.6667, 3994.7909, 3994.7909, 4205.6363],
    [0.99, 190.15152, 318.80508, 318.80508, 352.44828],
];

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn water(eps: f64, speed: f64) -> DragInput {
    DragInput {
        porosity: eps,
        diameter: 1e-3,
        density: 1000.0,
        viscosity: 1e-3,
        slip: [0.0, -speed, 0.0],
    }
}

/// The coefficients against the table to its 8 digits (rel 1e-6); and each law's force
/// on a lone grain (ε = 1) is `C_D ½ ρ u² π d²/4` with its C_D.
#[test]
fn drag_coefficients_match_the_reference_table() {
    for [re, stokes, sn, dv, cr, chi] in SPHERE_CD {
        assert!(rel(schiller_naumann_cd(re), sn) < 1e-6, "SN at Re {re}");
        assert!(rel(dallavalle_cd(re), dv) < 1e-6, "Dallavalle at Re {re}");
        assert!(rel(coulson_richardson_cd(re), cr) < 1e-6, "C–R at Re {re}");
        assert!(rel(di_felice_chi(re), chi) < 1e-6, "χ at Re {re}");
        // A lone grain at this Re: u = Re μ / (ρ d).
        let u = re * 1e-3 / (1000.0 * 1e-3);
        let cd_of = |law| {
            let f = drag_force(law, &water(1.0, u));
            -f[1] / (0.5 * 1000.0 * u * u * PI * 1e-6 / 4.0)
        };
        assert!(
            rel(cd_of(DragLaw::Stokes), stokes) < 1e-6,
            "Stokes at Re {re}"
        );
        assert!(
            rel(cd_of(DragLaw::CoulsonRichardson), cr) < 1e-6,
            "C–R force at Re {re}"
        );
        // Di Felice at ε = 1: the voidage factor is 1, so Dallavalle's C_D.
        assert!(
            rel(cd_of(DragLaw::DiFelice), dv) < 1e-6,
            "Di Felice force at Re {re}"
        );
        if re < 1000.0 {
            // Wen–Yu at ε = 1 is Schiller–Naumann's drag on a lone sphere.
            assert!(
                rel(cd_of(DragLaw::ErgunWenYu), sn) < 1e-6,
                "Wen–Yu at Re {re}"
            );
        }
    }
}

/// β of Ergun, Wen–Yu, Gidaspow's switch and Di Felice's law (as n_p |f| / |u − v|)
/// against the table (rel 1e-6); the switch jumps at ε = 0.8 and the Huilin–Gidaspow
/// blend does not (its two sides within 1e-6 of each other across 0.8 ± 1e-9, and
/// within 1 % of Ergun at ε = 0.7 and Wen–Yu at 0.9, where its weight is 0.01 and 0.99).
#[test]
fn momentum_exchange_matches_the_reference_table() {
    for [eps, ergun, wen_yu, switch, di_felice] in POROUS_BETA {
        let i = water(eps, 0.01);
        let beta = |law| momentum_exchange(law, &i);
        assert!(
            rel(beta(DragLaw::ErgunWenYu), switch) < 1e-6,
            "switch at ε {eps}"
        );
        assert!(
            rel(beta(DragLaw::DiFelice), di_felice) < 1e-6,
            "Di Felice at ε {eps}"
        );
        let w = huilin_gidaspow_weight(eps);
        let blend = (1.0 - w) * ergun + w * wen_yu;
        assert!(
            rel(beta(DragLaw::ErgunWenYuBlend), blend) < 1e-6,
            "blend at ε {eps}"
        );
    }
    let b = |eps| momentum_exchange(DragLaw::ErgunWenYu, &water(eps, 0.01));
    assert!(
        rel(b(0.8 - 1e-9), b(0.8 + 1e-9)) > 0.03,
        "the switch should jump"
    );
    let s = |eps| momentum_exchange(DragLaw::ErgunWenYuBlend, &water(eps, 0.01));
    assert!(rel(s(0.8 - 1e-9), s(0.8 + 1e-9)) < 1e-6, "the blend jumps");
    assert!(rel(s(0.7), 24535.714) < 0.01 && rel(s(0.9), 3994.7909) < 0.01);
}

/// A Stokes grain settles at `v_t = (ρ_p − ρ_f) g d²/(18 μ)`: the law's force balances
/// the submerged weight there (`stokes_settling_examples.csv`, glass and steel in water
/// and glycerol, rel 1e-6 on the table's 5 digits → 1e-4).
#[test]
fn stokes_law_balances_the_submerged_weight_at_the_tabulated_terminal_velocity() {
    for (rho_p, rho_f, mu, d, v_t) in [
        (2500.0, 1000.0, 0.001, 0.0001, 0.008175),
        (2500.0, 1260.0, 1.41, 0.002, 0.0019171631),
        (7800.0, 1260.0, 1.41, 0.002, 0.010111489),
        (500.0, 1000.0, 0.001, 0.0001, -0.002725),
    ] {
        let i = DragInput {
            porosity: 1.0,
            diameter: d,
            density: rho_f,
            viscosity: mu,
            slip: [0.0, v_t, 0.0], // fluid at rest, grain moving down at v_t
        };
        let f = drag_force(DragLaw::Stokes, &i)[1];
        let weight = (rho_p - rho_f) * PI * d * d * d / 6.0 * 9.81;
        assert!(
            rel(f, weight) < 1e-4,
            "ρp {rho_p} d {d}: drag {f} vs {weight}"
        );
    }
}

/// `drag_force` in WGSL (f32) against the CPU twin: every law at ε from 0.35 to 1,
/// Re from 1e-3 to 1e5, slip along and across the axes, and zero slip. Tolerance rel
/// 5e-5 of the force (f32 `pow` on exponents like 3.45 and −2.65).
#[test]
fn drag_wgsl_matches_cpu_twin() {
    let mut cases = Vec::new();
    for law in DragLaw::ALL {
        for eps in [0.35, 0.5, 0.7, 0.79, 0.8, 0.81, 0.9, 1.0] {
            for re in [1e-3, 0.1, 1.0, 30.0, 800.0, 2000.0, 1e5] {
                let speed = re * 1e-3 / (1000.0 * 1e-3);
                for dir in [[0.0, -1.0, 0.0], [0.6, 0.0, 0.8], [-0.48, 0.6, 0.64]] {
                    let mut i = water(eps, 0.0);
                    i.slip = dir.map(|c: f64| c * speed);
                    cases.push((law, i));
                }
            }
        }
        cases.push((law, water(0.6, 0.0)));
    }
    let gpu = shared_test_gpu().unwrap();
    let out = drag_table_gpu(&gpu, &cases).unwrap();
    let mut worst: f64 = 0.0;
    for ((law, i), g) in cases.iter().zip(&out) {
        let c = drag_force(*law, i);
        let mag = c.iter().map(|x| x * x).sum::<f64>().sqrt();
        let diff = (0..3)
            .map(|k| (g[k] as f64 - c[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        if mag == 0.0 {
            assert_eq!(*g, [0.0; 3], "{law:?}: zero slip gave {g:?}");
            continue;
        }
        let e = diff / mag;
        worst = worst.max(e);
        assert!(
            e < 5e-5,
            "{law:?} ε {} slip {:?}: gpu {g:?} cpu {c:?}",
            i.porosity,
            i.slip
        );
    }
    println!(
        "drag.wgsl vs CPU twin: {} cases, worst rel {worst:.2e}",
        cases.len()
    );
}
