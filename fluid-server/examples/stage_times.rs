//! Per-stage GPU times of the hydrostatic tank: `cargo run --release -p couplet-fluid --example stage_times [SPACING] [STEPS]`.

use couplet_fluid::FluidSolver;
use couplet_fluid::gpu::Gpu;
use couplet_fluid::timing::StageTimer;
use couplet_protocol::Scene;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let spacing: f64 = args.get(1).map_or(Ok(0.02), |s| s.parse())?;
    let steps: u32 = args.get(2).map_or(Ok(50), |s| s.parse())?;
    let support: f64 = args.get(3).map_or(Ok(3.0), |s| s.parse())?;
    let text = format!(
        r#"
[meta]
name = "tank"
[time]
end = 1.0
output_interval = 0.1
[domain]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.32, 0.2]
[fluid]
density = 1000.0
kinematic_viscosity = 1e-6
sound_speed = 20.0
spacing = {spacing}
support = {support}
blocks = [{{ min = [0.0, 0.0, 0.0], max = [0.2, 0.3, 0.2] }}]
[effects]
artificial_viscosity = 0.05
"#
    );
    let scene = Scene::parse(&text, Path::new("tank.toml"))?;
    let gpu = Gpu::new()?;
    println!("{}", gpu.describe());
    let mut solver = FluidSolver::new(&gpu, &scene)?;
    let dt = solver.limits().dt;
    let counts = solver.counts();
    println!("{counts:?}, dt = {dt:e}");
    solver.advance(&gpu, dt * 5.0, None)?;
    let mut timer = StageTimer::new(&gpu, 64);
    println!("timer mode {:?}", timer.mode());
    solver.advance(&gpu, dt * f64::from(steps), Some(&mut timer))?;
    let mut total = 0.0;
    for (label, s, n) in timer.totals_with_counts() {
        println!(
            "{label:40} {:8.3} ms/step  ({n} passes)",
            1e3 * s / f64::from(steps)
        );
        total += s;
    }
    println!("sum {:.3} ms/step", 1e3 * total / f64::from(steps));
    let t = Instant::now();
    solver.advance(&gpu, dt * f64::from(steps), None)?;
    println!(
        "untimed: {:.3} ms/step",
        1e3 * t.elapsed().as_secs_f64() / f64::from(steps)
    );
    println!(
        "neighbours/fluid particle: {:.1}",
        solver.neighbour_stats(&gpu)?
    );
    let t = Instant::now();
    for _ in 0..10 {
        solver.neighbour_stats(&gpu)?;
    }
    println!(
        "neighbour_stats (sort + count + readback): {:.3} ms",
        1e2 * t.elapsed().as_secs_f64()
    );
    Ok(())
}
