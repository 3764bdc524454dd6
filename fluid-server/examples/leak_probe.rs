//! Diagnostic: how the fluid server's resident memory grows as one group of GPU stages is
//! dispatched over and over, to tell a leak in our code from one in the Vulkan driver.
//!
//! `cargo run --release -p couplet-fluid --example leak_probe -- MODE [PATH=VALUE…]`
//! on `scenes/hydrostatic-tank.toml` at δ = 0.02 m (overrides apply on top), with
//! `ROUNDS` (default 6) rounds of `CALLS` (default 200) dispatches, printing the growth
//! of VmRSS after each round. MODE is one of:
//!
//! - `advance`: whole steps through [`FluidSolver::advance`];
//! - `boundary`: the boundary pass alone (`Op::BoundaryPressure`);
//! - `rates`: `Op::FluidRates` alone;
//! - `eos`, `sort`, `predict`, `correct`: that stage alone;
//! - `empty`: a submission with no stage (the cost of the call itself).
//!
//! Found with it (2026-11-25, Debian bookworm's Mesa 22.3.6 lavapipe): `advance` grows
//! about 6.7 MB/s; `boundary` alone leaks about 280 kB per dispatch, linearly, while
//! `rates`, `eos` and `sort` stay flat. Mesa 25.0.7's lavapipe (bookworm-backports), run
//! through `VK_ICD_FILENAMES`, stays flat in every mode: the leak is the driver's.
use couplet_fluid::gpu::Gpu;
use couplet_fluid::{FluidSolver, Op};
use couplet_protocol::Scene;
use std::path::Path;

/// This process's resident set, kB.
fn rss_kb() -> i64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmRSS in /proc/self/status")
}

fn env_count(name: &str, default: usize) -> usize {
    std::env::var(name).map_or(default, |v| {
        v.parse()
            .unwrap_or_else(|_| panic!("{name}={v} is not a count"))
    })
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("advance", String::as_str);
    let ops: &[Op] = match mode {
        "advance" => &[],
        "boundary" => &[Op::BoundaryPressure],
        "rates" => &[Op::FluidRates],
        "eos" => &[Op::TaitEos],
        "sort" => &[Op::Sort],
        "predict" => &[Op::Predict],
        "correct" => &[Op::Correct],
        "empty" => &[],
        other => {
            eprintln!(
                "unknown mode {other}: advance, boundary, rates, eos, sort, predict, correct or empty"
            );
            std::process::exit(2);
        }
    };
    let path = Path::new("scenes/hydrostatic-tank.toml");
    let mut text = std::fs::read_to_string(path).expect("run from the repository root");
    text = couplet_protocol::scene::override_field(&text, path, "fluid.spacing", "0.02").unwrap();
    for kv in args.iter().skip(2) {
        let (k, v) = kv.split_once('=').expect("overrides are PATH=VALUE");
        text = couplet_protocol::scene::override_field(&text, path, k, v).unwrap();
    }
    let scene = Scene::parse(&text, path).unwrap();
    let gpu = Gpu::new().unwrap();
    let mut solver = FluidSolver::new(&gpu, &scene).unwrap();
    let (rounds, calls) = (env_count("ROUNDS", 6), env_count("CALLS", 200));
    let start = rss_kb();
    for round in 1..=rounds {
        for _ in 0..calls {
            if mode == "advance" {
                solver.advance(&gpu, solver.limits().dt, None).unwrap();
            } else {
                solver.run_ops(&gpu, ops, 1e-5, 1.0).unwrap();
            }
        }
        println!(
            "{mode}: after {} calls RSS {:+} kB",
            round * calls,
            rss_kb() - start
        );
    }
}
