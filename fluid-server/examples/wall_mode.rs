//! Diagnostic: the Jacobian J of a scene's fluid rates at rest
//! ([`couplet_fluid::linear_acoustics`]), written out whole so that its eigenvalues say
//! whether the scheme's spatial operators grow a mode by themselves (ARCHITECTURE.md,
//! "Joubert's one-layer walls grow a mode").
//!
//! `cargo run --release -p couplet-fluid --example wall_mode -- SCENE OUT [PATH=VALUE…]`
//!
//! The scene must be a small box (closed, or periodic) without gravity on the fluid,
//! and α = 0 keeps the rates linear (the module's doc), e.g. the quick closed tank of
//! 6 × 10 × 6 fluid particles: `scenes/hydrostatic-tank.toml fluid.spacing=0.02 fluid.support=2.0
//! fluid.sound_speed=17.5 effects.artificial_viscosity=0.0 fluid.kinematic_viscosity=0.0
//! domain.closed_top=true "domain.max=[0.12,0.2,0.12]" "fluid.blocks.0.max=[0.12,0.2,0.12]"
//! "gravity.vector=[0.0,0.0,0.0]" effects.gradient_correction=true
//! 'domain.wall_model="joubert"'` (7 s).
//!
//! OUT receives a little-endian u64 n (4 a fluid particle: ρ', u_x, u_y, u_z), then J as
//! n × n little-endian f64, row-major; OUT.txt each fluid particle's position and its
//! four energy weights (`RestState::energy_weights`), in the state's order. With numpy:
//! `n = int(np.fromfile(OUT, '<u8', 1)[0]); J = np.fromfile(OUT, '<f8', offset=8).reshape(n, n)`.
use couplet_fluid::linear_acoustics::RestState;
use couplet_protocol::Scene;
use std::path::Path;

fn fail(e: &dyn std::fmt::Display) -> ! {
    eprintln!("wall_mode: {e}");
    std::process::exit(2);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(path), Some(out)) = (args.get(1).map(Path::new), args.get(2)) else {
        eprintln!("usage: wall_mode SCENE OUT [PATH=VALUE…]");
        std::process::exit(2);
    };
    let mut text = std::fs::read_to_string(path).unwrap();
    for kv in &args[3..] {
        let (k, v) = kv.split_once('=').expect("an override PATH=VALUE");
        text =
            couplet_protocol::scene::override_field(&text, path, k, v).unwrap_or_else(|e| fail(&e));
    }
    let scene = Scene::parse(&text, path).unwrap_or_else(|e| fail(&e));
    let rest = RestState::new(&scene).unwrap_or_else(|e| fail(&e));
    let n = rest.len();
    eprintln!(
        "{} fluid, {} wall particles: J is {n} × {n}",
        n / 4,
        rest.n_wall()
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
