//! Diagnostic: what a run's `/run/windows` says of the fluid over the whole run — the
//! particle-steps mirrored out of resolved bodies (`reflected`), those whose shift was cut
//! short in front of one (`shift_limited`) and those that kept the uncorrected gradient
//! (`near_singular`) — with the reflections binned over the windows that had any, to see
//! when a gap or a body ran under-resolved.
//!
//! `cargo run --release -p couplet-orchestrator --example window_sums -- OUT/run.mcap`
use couplet_orchestrator::record::read_recording;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: window_sums RUN.mcap");
        std::process::exit(2);
    };
    // Refuses what the validation reader refuses (not MCAP, a bad record).
    if let Err(e) = read_recording(std::path::Path::new(&path)) {
        eprintln!("{path}: {e}");
        std::process::exit(1);
    }
    let data = std::fs::read(&path).expect("readable");
    let (mut reflected, mut shift_limited, mut near_singular, mut windows) = (0u64, 0, 0, 0u64);
    let mut with_reflections: Vec<(f64, u64)> = Vec::new();
    for m in mcap::MessageStream::new(&data).expect("an MCAP file") {
        let Ok(m) = m else { break };
        if m.channel.topic != "/run/windows" {
            continue;
        }
        let v: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON windows");
        let f = &v["fluid"];
        let r = f["reflected"].as_u64().unwrap_or(0);
        windows += 1;
        reflected += r;
        near_singular += f["near_singular"].as_u64().unwrap_or(0);
        shift_limited += f["shift_limited"].as_u64().unwrap_or(0);
        if r > 0 {
            with_reflections.push((v["time"].as_f64().unwrap_or(f64::NAN), r));
        }
    }
    println!(
        "{windows} windows: {reflected} fluid particle-steps mirrored out of bodies, {shift_limited} shifts cut short in front of them, {near_singular} near-singular"
    );
    let bins = with_reflections.len().div_ceil(20).max(1);
    for chunk in with_reflections.chunks(bins) {
        let (t0, t1) = (chunk[0].0, chunk[chunk.len() - 1].0);
        let n: u64 = chunk.iter().map(|x| x.1).sum();
        println!("  windows starting at t = {t0:.4} … {t1:.4} s: {n} mirrored");
    }
}
