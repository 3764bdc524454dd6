//! Diagnostic: a scene's fluid advanced in process, window by window, printing every
//! fifth window's kinetic energy, largest speed, near-singular count, the fluid
//! particles of lowest and highest density with where they are, and the fastest one:
//! where an instability starts, long before the blow-up check stops the run.
//!
//! `cargo run --release -p couplet-fluid --example window_trace -- SCENE [PATH=VALUE…]
//! [window=S] [end=S] [every=N] [slabs=K]` (N: print every Nth window, default 5; K > 0 also
//! prints the fluid's mean vertical velocity in K equal slabs of the domain's height, bottom
//! first), e.g. the open tank that showed the corrected scheme's
//! free-surface blow-up: `… scenes/hydrostatic-tank.toml effects.gradient_correction=true
//! effects.free_surface=false fluid.spacing=0.02 window=0.001 end=0.05`.
use couplet_fluid::FluidSolver;
use couplet_fluid::gpu::Gpu;
use couplet_protocol::Scene;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1).map(Path::new) else {
        eprintln!("usage: window_trace SCENE [PATH=VALUE…] [window=S] [end=S] [every=N]");
        std::process::exit(2);
    };
    let mut text = std::fs::read_to_string(path).unwrap();
    let mut window: f64 = 1e-3;
    let mut end: f64 = 0.1;
    let mut every: usize = 5;
    let mut slabs: usize = 0;
    for kv in &args[2..] {
        let (k, v) = kv.split_once('=').unwrap();
        match k {
            "window" => window = v.parse().unwrap(),
            "end" => end = v.parse().unwrap(),
            "every" => every = v.parse().unwrap(),
            "slabs" => slabs = v.parse().unwrap(),
            _ => text = couplet_protocol::scene::override_field(&text, path, k, v).unwrap(),
        }
    }
    let scene = Scene::parse(&text, path).unwrap();
    let gpu = Gpu::new().unwrap();
    let mut s = FluidSolver::new(&gpu, &scene).unwrap();
    let n = (end / window).round() as usize;
    for w in 0..n {
        let r = s.advance(&gpu, window, None);
        let set = s.particles(&gpu).unwrap();
        let nf = set.kinds.n_fluid;
        let fluid: Vec<usize> = (0..set.len())
            .filter(|&k| (set.id[k] as usize) < nf)
            .collect();
        let lo = *fluid
            .iter()
            .min_by(|a, b| set.rho[**a].total_cmp(&set.rho[**b]))
            .unwrap();
        let hi = *fluid
            .iter()
            .max_by(|a, b| set.rho[**a].total_cmp(&set.rho[**b]))
            .unwrap();
        let fast = *fluid
            .iter()
            .max_by(|a, b| {
                let sp = |k: usize| set.vel[k].iter().map(|v| v * v).sum::<f64>();
                sp(**a).total_cmp(&sp(**b))
            })
            .unwrap();
        let st = s.stats();
        if w % every == 0 || r.is_err() {
            println!(
                "t={:.4} KE={:.3e} umax={:.3} ns={} lo ρ={:.1} at {:?} id {} | hi ρ={:.1} at {:?} | fastest id {} at {:?} u {:?}",
                s.time(),
                st.kinetic_energy,
                st.max_speed,
                s.near_singular(),
                set.rho[lo],
                set.pos[lo].map(|x| (x * 1000.0).round() / 1000.0),
                set.id[lo],
                set.rho[hi],
                set.pos[hi].map(|x| (x * 1000.0).round() / 1000.0),
                set.id[fast],
                set.pos[fast].map(|x| (x * 1000.0).round() / 1000.0),
                set.vel[fast].map(|x| (x * 1000.0).round() / 1000.0)
            );
        }
        if slabs > 0 && (w % every == 0 || r.is_err()) {
            let (y0, y1) = (scene.domain.min[1], scene.domain.max[1]);
            let mut sum = vec![(0.0f64, 0usize); slabs];
            for &k in &fluid {
                let b = ((set.pos[k][1] - y0) / (y1 - y0) * slabs as f64).floor();
                let b = (b.max(0.0) as usize).min(slabs - 1);
                sum[b].0 += set.vel[k][1];
                sum[b].1 += 1;
            }
            let means: Vec<String> = sum
                .iter()
                .map(|(s, n)| format!("{:+.3e}", s / (*n).max(1) as f64))
                .collect();
            println!("  slab mean u_y (m/s, bottom first): {}", means.join(" "));
        }
        if let Err(e) = r {
            println!("{e}");
            break;
        }
    }
}
