//! Diagnostic: the fluid of a run's snapshots, to see where and when a flow that should
//! be steady starts to grow (it found the constant-porosity block's lower-face
//! instability, ARCHITECTURE.md). One line per snapshot: the fluid's mean velocity, its
//! largest speed and the height where it is, the density and pressure ranges, and the
//! mean pressure of the lowest and highest layer `--layer M` thick (default: the scene's
//! spacing; a closed column's floor and lid, whose drift is the column's level). With
//! `--at MS` also, at the snapshot nearest that time, the fluid in horizontal layers
//! `--layer M` thick (default: the scene's spacing): count, mean and spread of the
//! vertical velocity, mean horizontal speed, density and pressure per layer; and with
//! `--particles Y` every particle of the layer at height Y, sorted across; with `--csv`
//! every particle of that snapshot as CSV, in id order.
//!
//! `cargo run --release -p couplet-orchestrator --example fluid_layers -- OUT/run.mcap
//! [--at MS [--layer M] [--particles Y] [--csv]]`
use couplet_orchestrator::record::{Particle, particle_speed as speed, read_recording};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: fluid_layers RUN.mcap [--at MS [--layer M] [--particles Y] [--csv]]");
        std::process::exit(2);
    };
    let option = |name: &str| -> Option<f64> {
        let i = args.iter().position(|a| a == name)?;
        let v = args.get(i + 1).unwrap_or_else(|| {
            eprintln!("{name} needs a value");
            std::process::exit(2)
        });
        Some(v.parse().unwrap_or_else(|e| {
            eprintln!("{name} {v}: {e}");
            std::process::exit(2)
        }))
    };
    let rec = read_recording(std::path::Path::new(path)).unwrap_or_else(|e| {
        eprintln!("{path}: {e}");
        std::process::exit(1)
    });
    if rec.snapshots.is_empty() {
        eprintln!("{path}: no fluid snapshots");
        std::process::exit(1);
    }
    let spacing = || {
        let scene = std::path::Path::new(path).with_file_name("scene.toml");
        let text = std::fs::read_to_string(&scene).ok()?;
        let v: toml::Value = toml::from_str(&text).ok()?;
        v.get("fluid")?.get("spacing")?.as_float()
    };
    let layer = option("--layer").or_else(spacing);
    for (t, ps) in &rec.snapshots {
        let n = ps.len() as f64;
        let mean: [f64; 3] =
            std::array::from_fn(|k| ps.iter().map(|p| f64::from(p[4 + k])).sum::<f64>() / n);
        let fastest = (ps.iter())
            .max_by(|a, b| speed(a).total_cmp(&speed(b)))
            .unwrap();
        let range = |k: usize| {
            (ps.iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(f64::from(p[k])), hi.max(f64::from(p[k])))
            })
        };
        let ((rho_lo, rho_hi), (p_lo, p_hi)) = (range(7), range(3));
        // The column's pressure level: the mean pressure of the lowest and the highest
        // layer of fluid (a closed column's floor and lid).
        let ends = layer.map_or(String::new(), |dy| {
            let (y_lo, y_hi) = range(1);
            let mean_p = |keep: &dyn Fn(f64) -> bool| {
                let l: Vec<f64> = (ps.iter())
                    .filter(|p| keep(f64::from(p[1])))
                    .map(|p| f64::from(p[3]))
                    .collect();
                l.iter().sum::<f64>() / l.len() as f64
            };
            format!(
                ", p lowest layer {:.1} Pa, highest {:.1} Pa",
                mean_p(&|y| y < y_lo + dy),
                mean_p(&|y| y > y_hi - dy)
            )
        });
        println!(
            "t {t:.4e} s: mean u ({:+.2e}, {:+.2e}, {:+.2e}) m/s, largest speed {:.3e} m/s at y {:.4e} m, ρ {rho_lo:.2}–{rho_hi:.2}, p {p_lo:.1}–{p_hi:.1} Pa{ends}",
            mean[0],
            mean[1],
            mean[2],
            speed(fastest),
            fastest[1]
        );
    }
    let Some(at) = option("--at") else {
        return;
    };
    let (t, ps) = (rec.snapshots.iter())
        .min_by(|a, b| (a.0 - 1e-3 * at).abs().total_cmp(&(b.0 - 1e-3 * at).abs()))
        .unwrap();
    let dy = layer.unwrap_or_else(|| {
        eprintln!("no scene.toml beside the recording: give --layer M");
        std::process::exit(2)
    });
    println!("\nlayers {dy:.4e} m thick at t {t:.4e} s:");
    let mut layers: std::collections::BTreeMap<i64, Vec<&Particle>> = Default::default();
    for p in ps {
        layers
            .entry((f64::from(p[1]) / dy).floor() as i64)
            .or_default()
            .push(p);
    }
    for (k, l) in &layers {
        let n = l.len() as f64;
        let avg = |f: &dyn Fn(&Particle) -> f64| l.iter().map(|p| f(p)).sum::<f64>() / n;
        let vy = avg(&|p| f64::from(p[5]));
        let sd = avg(&|p| (f64::from(p[5]) - vy).powi(2)).sqrt();
        println!(
            "  y {:.4e}: {n} particles, u_y {vy:+.2e} ± {sd:.2e}, |u_xz| {:.2e} m/s, ρ {:.2}, p {:.1} Pa",
            (*k as f64 + 0.5) * dy,
            avg(&|p| f64::from(p[4]).hypot(f64::from(p[6]))),
            avg(&|p| f64::from(p[7])),
            avg(&|p| f64::from(p[3])),
        );
    }
    if args.iter().any(|a| a == "--csv") {
        // Every particle of the snapshot, in id order, for analysis elsewhere.
        println!("\nx,y,z,p,vx,vy,vz,rho");
        for p in ps {
            let f: Vec<String> = p.iter().map(|v| format!("{v:e}")).collect();
            println!("{}", f.join(","));
        }
    }
    if let Some(y) = option("--particles") {
        let mut l: Vec<&Particle> = (ps.iter())
            .filter(|p| (f64::from(p[1]) - y).abs() < 0.5 * dy)
            .collect();
        l.sort_by(|a, b| (a[0], a[2]).partial_cmp(&(b[0], b[2])).unwrap());
        println!("\nthe layer at y {y:.4e} m:");
        for p in l {
            println!(
                "  x {:.4e} z {:.4e} y {:.5e}: u ({:+.2e}, {:+.2e}, {:+.2e}) m/s, p {:.1} Pa, ρ {:.2}",
                p[0], p[2], p[1], p[4], p[5], p[6], p[3], p[7]
            );
        }
    }
}
