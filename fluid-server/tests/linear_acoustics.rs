//! The fluid's rates linearised about rest (`couplet_fluid::linear_acoustics`): which
//! wall models let the spatial operators grow a mode by themselves. CPU only (the f64
//! twins), no GPU.
//!
//! Growth is read by `RestState::growth_rate`, a power iteration on RK4 steps of
//! x' = J x. The energy of small motions E = Σ m (c² ρ'²/ρ0² + |u|²)/2 is conserved
//! exactly when W J is skew-symmetric (W the energy's weights); neither wall model's J
//! is (`examples/wall_mode` with `results/2026-12-07-cpu-wall-mode/modes.py` measure
//! |WJ + (WJ)ᵀ| / |WJ|), but Adami's walls are neutral (every eigenvalue imaginary)
//! where Joubert's one layer grows.

mod common;

use couplet_fluid::FluidError;
use couplet_fluid::linear_acoustics::RestState;
use couplet_protocol::Scene;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// The hydrostatic tank's CI quick (δ = 0.02 m, support 2δ, c = 17.5 m/s), closed and
/// cut to 6 × 10 × 6 fluid particles, without gravity, viscosity or α (α's default is
/// 0; the rates are then linear at rest); `domain` and `effects` add lines to those tables.
fn closed_box(domain: &str, effects: &str) -> Scene {
    box_scene([0.12, 0.2, 0.12], domain, effects)
}

/// [`closed_box`] of `size` m, filled; `effects` may end with further tables.
fn box_scene(size: [f64; 3], domain: &str, effects: &str) -> Scene {
    let text = format!(
        r#"
[meta]
name = "linear-acoustics"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = {size:?}
walls = "no-slip"
closed_top = true
{domain}
[fluid]
density = 1000.0
kinematic_viscosity = 0.0
sound_speed = 17.5
spacing = 0.02
kernel = "wendland-c2"
support = 2.0
blocks = [{{ min = [0.0, 0.0, 0.0], max = {size:?} }}]
[gravity]
vector = [0.0, 0.0, 0.0]
[effects]
viscosity = "none"
{effects}
"#
    );
    Scene::parse(&text, Path::new("linear-acoustics.toml")).unwrap()
}

/// A seeded random state (ρ' scaled to ρ0/c per unit of u, so both halves weigh alike).
fn random_state(rest: &RestState, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rho_per_u = rest.c.rho0 / rest.c.sound_speed;
    (0..rest.len())
        .map(|k| {
            let v: f64 = rng.random_range(-1.0..1.0);
            if k % 4 == 0 { v * rho_per_u } else { v }
        })
        .collect()
}

/// The fastest growth of small motions (`RestState::growth_rate`): 60 RK4 steps of 1 ms
/// (ωΔt ≤ 0.98 for these boxes' fastest ω, up to 980 rad/s, inside RK4's limit) from a
/// seeded random state. Where every eigenvalue is imaginary it reads within a few 1/s of
/// 0: E's norm, which the iteration rescales, swings as the neutral modes beat (W J is
/// not skew), so the second half's mean log growth carries a fraction of a swing over
/// 30 ms.
const NEUTRAL: f64 = 5.0;
fn growth(rest: &RestState) -> f64 {
    rest.growth_rate(&random_state(rest, 11), 1e-3, 60)
}

/// Adami's walls (two layers at support 2δ, so every fluid particle's support is
/// complete) grow no mode, standard or corrected: the whole J (`examples/wall_mode`,
/// 6 × 10 × 6 box, 2026-12-07, after the fix below) has no eigenvalue with Re λ above
/// 3e-4 1/s against |Im λ| up to 927 rad/s (round-off of the central difference: all
/// neutral). Its W J is not skew, 0.36 (0.45 in the outer layer's rows, 2e-11 inside):
/// the energy E is not what Adami's walls conserve, some other quadratic form is.
/// Measured here: growth rates of −0.77 and −1.05 1/s; asserted
/// under `NEUTRAL`, where Joubert's walls below read hundreds.
#[test]
fn adami_walls_grow_no_mode() {
    for effects in ["", "gradient_correction = true"] {
        let rest = RestState::new(&closed_box("", effects)).unwrap();
        let g = growth(&rest);
        println!("Adami's walls, `{effects}`: growth rate {g:.4} 1/s");
        assert!(
            g < NEUTRAL,
            "Adami's walls, `{effects}`: growth rate {g} 1/s"
        );
    }
}

/// Regression (linearised_adami_walls_extrapolate, 2026-12-07): `RestState` ran no
/// boundary pass at Adami's walls, so they kept the rest state's p = 0, a
/// pressure-release wall, whose W J is skew to round-off (2.2e-11, the "Adami's walls
/// conserve E" of 2026-12-07's first reading). With Adami's extrapolation the
/// floor holds the Neumann condition of a smooth pressure: ρ' = cos(π y/L_y) (the rigid
/// box's lowest acoustic mode, y from the floor's face, L_y = 0.2 m) gives the bottom
/// row du_y/dt = −(c²/ρ0) ∂ρ'/∂y = +0.753 m/s², within the discretisation error of the
/// interior rows (0.078 m/s² at most there in the whole J; measured here at the floor
/// 0.012, asserted within 0.15); with p = 0 at the walls it read −6.8.
#[test]
fn regression_linearised_adami_walls_extrapolate() {
    let rest = RestState::new(&closed_box("", "gradient_correction = true")).unwrap();
    let pos = rest.positions();
    let floor = pos.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min) - 0.5 * 0.02;
    let ly = 0.2;
    let k = std::f64::consts::PI / ly;
    let x: Vec<f64> = (pos.iter())
        .flat_map(|p| [(k * (p[1] - floor)).cos(), 0.0, 0.0, 0.0])
        .collect();
    let jx = rest.apply(&x);
    let c2 = rest.c.sound_speed.powi(2) / rest.c.rho0;
    let mut worst: f64 = 0.0;
    for (a, p) in pos.iter().enumerate().filter(|(_, p)| p[1] - floor < 0.02) {
        let want = c2 * k * (k * (p[1] - floor)).sin();
        let got = jx[4 * a + 2];
        worst = worst.max((got - want).abs());
        assert!(
            (got - want).abs() < 0.15,
            "bottom row at {p:?}: du_y/dt {got} m/s², the Neumann pressure's {want}"
        );
    }
    println!("bottom row: largest |du_y/dt − exact| {worst:.4} m/s²");
}

/// Joubert's one layer (`domain.wall_model = "joubert"`, eq. 25 at the walls, the
/// corrected scheme) grows a mode: J has real eigenvalues up to +299 1/s (177 of its
/// 1440 with Re λ > 0; `examples/wall_mode`, 2026-12-07), the mode that grows from
/// round-off in the closed tank (ARCHITECTURE.md, "Joubert's one-layer walls grow a
/// mode"). Measured here: 282.5 1/s (the power iteration's 60 ms do not separate it
/// wholly from the next modes); asserted over 150 1/s. Its |WJ + (WJ)ᵀ| / |WJ| sits at
/// the walls (in the 10 × 20 × 10 tank: 0.94 in the first fluid layer's rows, 0.19 in
/// the second's, 0.04 in the third's).
#[test]
fn joubert_one_layer_walls_grow_a_mode() {
    let rest = RestState::new(&closed_box(
        "wall_model = \"joubert\"",
        "gradient_correction = true",
    ))
    .unwrap();
    let g = growth(&rest);
    println!("Joubert's walls: growth rate {g:.1} 1/s");
    assert!(g > 150.0, "Joubert's walls: growth rate {g} 1/s");
}

/// The same two wall models on a floor and a lid alone, x and z periodic (the box's
/// 6 × 10 × 6 fluid particles span both periods): pairs across the periodic faces are
/// summed to their nearest image, as the GPU sums them. Adami's floor and lid grow no
/// mode (the whole J: Re λ at most 1.3e-4 1/s; measured here 0.97 and 0.96 1/s,
/// standard and corrected, the beat of the neutral modes; under `NEUTRAL`) and
/// Joubert's grow one (the whole J: +328.7 1/s, 22 of 1440 eigenvalues growing;
/// measured here 328.4; asserted over 150): a floor and a lid alone grow the mode, as
/// the runs of 2026-12-05 found (blown up at 0.099 s, later than the closed box's
/// 0.065 s). Before the twins took periodic images (regression
/// twins_without_periodic_images) the linearisation refused periodic axes.
#[test]
fn small_motions_across_periodic_faces() {
    let periodic = "periodic = [true, false, true]";
    for effects in ["", "gradient_correction = true"] {
        let rest = RestState::new(&closed_box(periodic, effects)).unwrap();
        let g = growth(&rest);
        println!("Adami's floor and lid, `{effects}`: growth rate {g:.4} 1/s");
        assert!(
            g < NEUTRAL,
            "Adami's floor and lid, `{effects}`: growth rate {g} 1/s"
        );
    }
    let rest = RestState::new(&closed_box(
        &format!("{periodic}\nwall_model = \"joubert\""),
        "gradient_correction = true",
    ))
    .unwrap();
    let g = growth(&rest);
    println!("Joubert's floor and lid: growth rate {g:.1} 1/s");
    assert!(g > 150.0, "Joubert's floor and lid: growth rate {g} 1/s");
}

/// The free-surface switch (`effects.free_surface`, ARCHITECTURE.md, "The free-surface
/// switch") in the linearised rates: the box open at the top (fluid 0.2 m deep in a
/// 0.3 m domain, no gravity, so that rest at p = 0 is steady under the free surface),
/// corrected. Without the switch Joubert's difference forms at the surface grow a mode
/// at the acoustic rate: at support 2δ the whole J (`examples/wall_mode`, 2026-12-07)
/// has 112 of its 1440 eigenvalues growing, the fastest at +817 1/s with 99 % of its
/// energy in the outer layer (at 3δ +746 1/s), where the open tank's runs blew up with
/// the kinetic energy ×1000 every 5 ms (about 690 1/s an amplitude). With it the
/// fastest is +1.21 ± 436i 1/s (3δ: +0.62 ± 411i), a column mode that gains 1.7 % a
/// cycle, which α damps. Measured here at 2δ: 0.50 and 811 1/s; asserted under
/// `NEUTRAL` and over 150. And the switch's fraction (`FREE_SURFACE_FRACTION`, 0.95 of
/// a complete support's det M): at 3δ it takes the two rows under the surface (det
/// 0.28–0.58 and 0.83–0.91) and reads 0.24 1/s; at 0.75 it takes the surface row alone
/// and the second row grows, 29.1 1/s (0.85, part of that row: 10.2), as the open
/// tank's run at 0.75 did (0.5 m/s in 0.2 s); asserted under `NEUTRAL` and over 15.
#[test]
fn the_free_surface_switch_removes_the_surface_mode() {
    let open = |support: f64, effects: &str| {
        let mut s = closed_box("", &format!("gradient_correction = true\n{effects}"));
        s.domain.closed_top = false;
        s.domain.max[1] = 0.3;
        s.fluid.as_mut().unwrap().support = support;
        RestState::new(&s).unwrap()
    };
    let on = growth(&open(2.0, ""));
    let off = growth(&open(2.0, "free_surface = false"));
    println!("open box, support 2δ: growth rate {on:.3} 1/s with the switch, {off:.1} 1/s without");
    assert!(on < NEUTRAL, "with the switch: growth rate {on} 1/s");
    assert!(off > 150.0, "without the switch: growth rate {off} 1/s");
    let mut rest = open(3.0, "");
    let two_rows = growth(&rest);
    rest.c.free_surface_fraction = 0.75;
    let one_row = growth(&rest);
    println!(
        "open box, support 3δ: growth rate {two_rows:.3} 1/s at the fraction 0.95, {one_row:.2} 1/s at 0.75"
    );
    assert!(
        two_rows < NEUTRAL,
        "fraction 0.95: growth rate {two_rows} 1/s"
    );
    assert!(one_row > 15.0, "fraction 0.75: growth rate {one_row} 1/s");
}

/// A resolved body's one layer of markers grows a mode beside it, under Adami's wall
/// model too (`RestState::with_bodies`): a fixed sphere r = 2.5δ at the centre of a
/// closed 0.2 m box (δ = 0.02 m, support 2δ, corrected; 864 fluid particles), its 82
/// surface markers without fill (the DEM gives a sphere this small none at support 2δ:
/// no lattice point lies δ to 1.5δ deep). With the DEM's markers the whole J
/// (`examples/body_mode`, 2026-12-07) has 332 of its 3456 eigenvalues growing, the
/// fastest real at +164 1/s with 87 % of its energy in the fluid 1–2δ off the surface;
/// the same box without the sphere grows nothing. At support 3δ, with 13 fill points,
/// +127 1/s. Here with 82 Fibonacci markers (`common::sphere_markers`): measured
/// 126.9 1/s; asserted over 60, so that a change that stops it is seen.
#[test]
fn a_resolved_body_grows_a_mode_beside_its_markers() {
    let centre = [0.1, 0.1, 0.1];
    let s = box_scene(
        [0.2; 3],
        "",
        &format!(
            "gradient_correction = true\n[[bodies]]\nname = \"ball\"\n\
             shape = {{ sphere = {{ radius = 0.05 }} }}\ndensity = 1250.0\n\
             position = {centre:?}\nmotion = \"fixed\"\ncoupling = \"resolved\""
        ),
    );
    let points = common::sphere_markers(centre, 0.05, 82);
    let rest = RestState::with_bodies(&s, &points).unwrap();
    assert_eq!(rest.n_markers(), 82);
    let g = growth(&rest);
    println!("a sphere r = 2.5δ in Adami's box: growth rate {g:.1} 1/s");
    assert!(g > 60.0, "growth rate {g} 1/s");
}

/// Rest is steady only without gravity on the fluid, and α makes the rates non-linear
/// at rest: each is refused with what to change.
#[test]
fn rest_state_refuses_gravity_and_alpha() {
    let mut s = closed_box("", "");
    s.gravity.vector = [0.0, -9.81, 0.0];
    match RestState::new(&s) {
        Err(FluidError::LinearAcoustics(m)) => assert!(m.contains("gravity.vector"), "{m}"),
        other => panic!("gravity: {:?}", other.err()),
    }
    match RestState::new(&closed_box("", "artificial_viscosity = 0.2")) {
        Err(FluidError::LinearAcoustics(m)) => assert!(m.contains("artificial_viscosity"), "{m}"),
        other => panic!("α: {:?}", other.err()),
    }
}
