//! Diagnostic: the Jacobian J of a scene's fluid rates at rest with its resolved bodies
//! held fixed at their initial poses (`couplet_fluid::linear_acoustics::RestState::with_bodies`),
//! written out whole as `examples/wall_mode` writes a scene without bodies (same format,
//! read by `results/2026-12-07-cpu-wall-mode/modes.py`): whether a body's one layer of
//! markers grows a mode as Joubert's one-layer walls do.
//!
//! `cargo run --release -p couplet-orchestrator --example body_mode -- SCENE OUT [PATH=VALUE…]`
//!
//! The bodies' coupling points are the DEM's (`couplet_dem::MarkerSet`: surface markers
//! at the fluid spacing, and under Adami's wall model the fill behind them), at each
//! body's scene position and rotation. The scene must be small, without gravity on the
//! fluid, and α = 0 (the module's doc).
use couplet_dem::MarkerSet;
use couplet_fluid::linear_acoustics::RestState;
use couplet_orchestrator::run::resolve_scene;
use couplet_protocol::BodyState;
use couplet_protocol::vec3::quat_from_scaled_axis;
use std::path::Path;

fn fail(e: &dyn std::fmt::Display) -> ! {
    eprintln!("body_mode: {e}");
    std::process::exit(2);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(path), Some(out)) = (args.get(1).map(Path::new), args.get(2)) else {
        eprintln!("usage: body_mode SCENE OUT [PATH=VALUE…]");
        std::process::exit(2);
    };
    let overrides: Vec<(String, String)> = (args[3..].iter())
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) => (k.to_owned(), v.to_owned()),
            None => fail(&format!("{kv}: an override is PATH=VALUE")),
        })
        .collect();
    let (scene, _) = resolve_scene(path, &overrides).unwrap_or_else(|e| fail(&e));
    let markers = MarkerSet::from_scene(&scene).unwrap_or_else(|e| fail(&e));
    let states: Vec<BodyState> = (scene.bodies.iter().enumerate())
        .map(|(k, b)| BodyState {
            position: b.position,
            body: k as u32,
            orientation: quat_from_scaled_axis(b.rotation),
            ..Default::default()
        })
        .collect();
    let mut points = Vec::new();
    markers.world_points(&states, &mut points);
    let rest = RestState::with_bodies(&scene, &points).unwrap_or_else(|e| fail(&e));
    let n = rest.len();
    eprintln!(
        "{} fluid, {} wall particles, {} markers ({} fill): J is {n} × {n}",
        n / 4,
        rest.n_wall(),
        rest.n_markers(),
        points.iter().filter(|p| p.measure == 0.0).count()
    );
    let started = std::time::Instant::now();
    rest.write_jacobian(Path::new(out), |done, n| {
        eprintln!(
            "{done} of {n} columns, {:.0} s",
            started.elapsed().as_secs_f64()
        )
    })
    .unwrap_or_else(|e| fail(&e));
}
