//! Cross-process integration and validation tests; helpers to run the `couplet` CLI and
//! read back what it recorded.

use foxglove::messages::PointCloud;
use foxglove::Decode;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (the scenes live in `scenes/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A shipped scene by name.
pub fn scene(name: &str) -> PathBuf {
    repo_root().join("scenes").join(format!("{name}.toml"))
}

/// Runs `couplet run SCENE --out OUT EXTRA…` with the CLI binary `cli` and returns its output.
pub fn couplet_run(cli: &str, scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let o = Command::new(cli)
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("cannot start the couplet CLI");
    eprintln!("{}", String::from_utf8_lossy(&o.stdout));
    eprintln!("{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// One body at one time, from `/bodies/states`.
#[derive(Debug, Clone, Copy)]
pub struct BodySample {
    pub time: f64,
    pub body: usize,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
    pub velocity: [f64; 3],
}

/// A particle of a `/fluid/particles` snapshot: x y z pressure vx vy vz density.
pub type Particle = [f32; 8];

/// What a recording holds, decoded.
#[derive(Debug, Default)]
pub struct Recording {
    pub snapshots: Vec<(f64, Vec<Particle>)>,
    pub bodies: Vec<BodySample>,
    pub loads: usize,
    pub windows: usize,
    /// The file ends with a summary and footer (it was closed properly).
    pub has_summary: bool,
}

fn arr<const N: usize>(v: &serde_json::Value) -> [f64; N] {
    let mut out = [f64::NAN; N];
    if let Some(a) = v.as_array() {
        for (o, x) in out.iter_mut().zip(a) {
            *o = x.as_f64().unwrap_or(f64::NAN);
        }
    }
    out
}

/// Reads and decodes a recording; errors if any record is unreadable.
pub fn read_recording(path: &Path) -> Result<Recording, String> {
    let buf = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut rec = Recording {
        has_summary: mcap::Summary::read(&buf).map_err(|e| e.to_string())?.is_some(),
        ..Default::default()
    };
    for m in mcap::MessageStream::new(&buf).map_err(|e| e.to_string())? {
        let m = m.map_err(|e| format!("{}: {e}", path.display()))?;
        let time = m.log_time as f64 * 1e-9;
        match m.channel.topic.as_str() {
            "/fluid/particles" => {
                let pc = PointCloud::decode(&m.data[..]).map_err(|e| e.to_string())?;
                let p = pc
                    .data
                    .chunks_exact(32)
                    .map(|c| {
                        let mut r = [0f32; 8];
                        for (k, v) in r.iter_mut().enumerate() {
                            *v = f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]);
                        }
                        r
                    })
                    .collect();
                rec.snapshots.push((time, p));
            }
            "/bodies/states" => {
                let v: serde_json::Value = serde_json::from_slice(&m.data).map_err(|e| e.to_string())?;
                for b in v["bodies"].as_array().into_iter().flatten() {
                    rec.bodies.push(BodySample {
                        time: v["time"].as_f64().unwrap_or(f64::NAN),
                        body: b["body"].as_u64().unwrap_or(u64::MAX) as usize,
                        position: arr(&b["position"]),
                        orientation: arr(&b["orientation"]),
                        velocity: arr(&b["velocity"]),
                    });
                }
            }
            "/bodies/loads" => rec.loads += 1,
            "/run/windows" => rec.windows += 1,
            _ => {}
        }
    }
    Ok(rec)
}

/// The states of one body over time.
pub fn track(rec: &Recording, body: usize) -> Vec<BodySample> {
    rec.bodies.iter().filter(|b| b.body == body).copied().collect()
}

/// Terminal settling velocity of a sphere from the force balance of Joubert eq. (37)
/// with the drag correlation of eq. (38), by fixed-point iteration on Re.
pub fn joubert_terminal_velocity(radius: f64, rho_s: f64, rho_f: f64, nu: f64, g: f64) -> f64 {
    let d = 2.0 * radius;
    let cd = |re: f64| {
        24.0 / re + 2.6 * (re / 5.0) / (1.0 + (re / 5.0).powf(1.52))
            + 0.411 * (re / 2.63e5).powf(-7.94) / (1.0 + (re / 2.63e5).powf(-8.0))
            + 0.25 * (re / 1e6) / (1.0 + re / 1e6)
    };
    // Eq. (37): (ρs − ρf) V g = ½ C_D ρf U² A with V = πd³/6, A = πd²/4.
    let mut u = (rho_s - rho_f) * g * d * d / (18.0 * rho_f * nu); // Stokes start
    for _ in 0..200 {
        let re = u * d / nu;
        u = (4.0 * (rho_s - rho_f) * g * d / (3.0 * cd(re) * rho_f)).sqrt();
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stokes regime check of the correlation solver: at Re ≪ 1 eq. (38) reduces to
    /// 24/Re (plus ≈ 0.5 Re^... small terms), so U → Stokes' (ρs−ρf) g d²/(18 μ).
    #[test]
    fn terminal_velocity_tends_to_stokes() {
        let (r, rs, rf, nu, g) = (1e-5, 1250.0, 1000.0, 1e-4, 9.81);
        let stokes = (rs - rf) * g * (2.0 * r) * (2.0 * r) / (18.0 * rf * nu);
        let u = joubert_terminal_velocity(r, rs, rf, nu, g);
        assert!((u / stokes - 1.0).abs() < 1e-3, "{u} vs {stokes}");
    }
}
