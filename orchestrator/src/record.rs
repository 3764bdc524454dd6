//! MCAP recording of a run, in Foxglove's well-known schemas where one fits so that a
//! recording opens in Foxglove with no plugin.
//!
//! | topic | schema | when |
//! |---|---|---|
//! | `/fluid/particles` | `foxglove.PointCloud` (protobuf): float32 `x y z pressure vx vy vz density`, stride 32 B | every output interval |
//! | `/bodies/poses` | `foxglove.PosesInFrame` (protobuf), one pose per body, scene order | every window |
//! | `/bodies/states` | `couplet.BodyStates` (JSON): per body position, orientation `[x,y,z,w]`, velocity, angular velocity, mass | every window |
//! | `/bodies/loads` | `couplet.BodyLoads` (JSON): per coupled body index, fluid force (N) and moment about the COM (N·m) | every window with resolved bodies |
//! | `/run/windows` | `couplet.Window` (JSON): step, time, substeps, compute and exchange µs per side, fluid particle-steps with a near-singular truncation matrix | every window |
//!
//! Log time = simulation time in ns (the recording starts at t = 0). Frame `world`,
//! SI units. The scene file is attached (`scene.toml`) and the run described in the
//! `couplet` metadata record. The writer is closed on every exit path, so a recording
//! stays readable when a server dies.

use couplet_protocol::{BodyLoad, BodyState, ParticleRecord, SideReport};
use foxglove::messages::packed_element_field::NumericType;
use foxglove::messages::{
    PackedElementField, PointCloud, Pose, PosesInFrame, Quaternion, Timestamp, Vector3,
};
use foxglove::{Channel, Context, McapWriterHandle, RawChannel, Schema};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub const TOPIC_PARTICLES: &str = "/fluid/particles";
pub const TOPIC_POSES: &str = "/bodies/poses";
pub const TOPIC_STATES: &str = "/bodies/states";
pub const TOPIC_LOADS: &str = "/bodies/loads";
pub const TOPIC_WINDOWS: &str = "/run/windows";

#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("recording {path}: {detail}")]
    Mcap { path: PathBuf, detail: String },
}

pub struct Recorder {
    path: PathBuf,
    // Keeps the channels' context alive for the writer's lifetime.
    _ctx: Arc<Context>,
    writer: Option<McapWriterHandle<BufWriter<File>>>,
    particles: Channel<PointCloud>,
    poses: Channel<PosesInFrame>,
    states: Arc<RawChannel>,
    loads: Arc<RawChannel>,
    windows: Arc<RawChannel>,
}

fn json_schema(name: &str, schema: &str) -> Schema {
    Schema::new(name, "jsonschema", schema.as_bytes().to_vec())
}

fn stamp(t: f64) -> Timestamp {
    let ns = (t * 1e9).round().max(0.0) as u64;
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

fn ns(t: f64) -> u64 {
    (t * 1e9).round().max(0.0) as u64
}

impl Recorder {
    /// Creates `path` (replacing an earlier recording there: re-running into the same
    /// output folder is the usual way to redo a run) and attaches `scene_text`.
    pub fn create(path: &Path, scene_name: &str, scene_text: &str) -> Result<Self, RecordError> {
        let err = |e: foxglove::FoxgloveError| RecordError::Mcap {
            path: path.to_owned(),
            detail: e.to_string(),
        };
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                return Err(RecordError::Mcap {
                    path: path.to_owned(),
                    detail: format!("cannot replace it: {e}"),
                });
            }
        }
        let ctx = Context::new();
        let writer = ctx
            .mcap_writer()
            .create_new_buffered_file(path)
            .map_err(err)?;
        let raw = |topic: &str, name: &str, schema: &str| {
            ctx.channel_builder(topic)
                .message_encoding("json")
                .schema(json_schema(name, schema))
                .build_raw()
                .map_err(err)
        };
        let states = raw(
            TOPIC_STATES,
            "couplet.BodyStates",
            r#"{"type":"object","properties":{"time":{"type":"number"},"bodies":{"type":"array","items":{"type":"object","properties":{"body":{"type":"integer"},"position":{"type":"array"},"orientation":{"type":"array"},"velocity":{"type":"array"},"angular_velocity":{"type":"array"},"mass":{"type":"number"}}}}}}"#,
        )?;
        let loads = raw(
            TOPIC_LOADS,
            "couplet.BodyLoads",
            r#"{"type":"object","properties":{"time":{"type":"number"},"loads":{"type":"array","items":{"type":"object","properties":{"body":{"type":"integer"},"force":{"type":"array"},"moment":{"type":"array"}}}}}}"#,
        )?;
        let windows = raw(
            TOPIC_WINDOWS,
            "couplet.Window",
            r#"{"type":"object","properties":{"step":{"type":"integer"},"time":{"type":"number"},"window":{"type":"number"},"fluid":{"type":"object"},"dem":{"type":"object"}}}"#,
        )?;
        let particles = ctx.channel_builder(TOPIC_PARTICLES).build::<PointCloud>();
        let poses = ctx.channel_builder(TOPIC_POSES).build::<PosesInFrame>();
        writer
            .attach(&foxglove::McapAttachment {
                log_time: 0,
                create_time: 0,
                name: "scene.toml".into(),
                media_type: "application/toml".into(),
                data: scene_text.as_bytes().into(),
            })
            .map_err(err)?;
        let mut meta = BTreeMap::new();
        meta.insert("scene".into(), scene_name.into());
        meta.insert("couplet_version".into(), env!("CARGO_PKG_VERSION").into());
        writer.write_metadata("couplet", meta).map_err(err)?;
        Ok(Self {
            path: path.to_owned(),
            _ctx: ctx,
            writer: Some(writer),
            particles,
            poses,
            states,
            loads,
            windows,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn particles(&self, time: f64, particles: &[ParticleRecord]) {
        const FIELDS: [&str; 8] = ["x", "y", "z", "pressure", "vx", "vy", "vz", "density"];
        let fields = FIELDS
            .iter()
            .enumerate()
            .map(|(i, n)| PackedElementField {
                name: (*n).into(),
                offset: 4 * i as u32,
                r#type: NumericType::Float32 as i32,
            })
            .collect();
        let data: Vec<u8> = bytemuck_cast(particles);
        let msg = PointCloud {
            timestamp: Some(stamp(time)),
            frame_id: "world".into(),
            pose: Some(identity_pose()),
            point_stride: core::mem::size_of::<ParticleRecord>() as u32,
            fields,
            data: data.into(),
        };
        self.particles.log_with_time(&msg, ns(time));
    }

    pub fn bodies(&self, time: f64, states: &[BodyState]) {
        let poses = states
            .iter()
            .map(|s| Pose {
                position: Some(Vector3 {
                    x: s.position[0],
                    y: s.position[1],
                    z: s.position[2],
                }),
                orientation: Some(Quaternion {
                    x: s.orientation[0],
                    y: s.orientation[1],
                    z: s.orientation[2],
                    w: s.orientation[3],
                }),
            })
            .collect();
        self.poses.log_with_time(
            &PosesInFrame {
                timestamp: Some(stamp(time)),
                frame_id: "world".into(),
                poses,
            },
            ns(time),
        );
        let bodies: Vec<serde_json::Value> = states
            .iter()
            .map(|s| {
                serde_json::json!({
                    "body": s.body, "position": s.position, "orientation": s.orientation,
                    "velocity": s.linear_velocity, "angular_velocity": s.angular_velocity, "mass": s.mass,
                })
            })
            .collect();
        self.log_json(
            &self.states,
            time,
            &serde_json::json!({ "time": time, "bodies": bodies }),
        );
    }

    pub fn loads(&self, time: f64, loads: &[BodyLoad]) {
        let loads: Vec<serde_json::Value> = loads
            .iter()
            .map(|l| serde_json::json!({ "body": l.body, "force": l.force, "moment": l.moment }))
            .collect();
        self.log_json(
            &self.loads,
            time,
            &serde_json::json!({ "time": time, "loads": loads }),
        );
    }

    pub fn window(
        &self,
        step: u64,
        time: f64,
        window: f64,
        fluid: Option<&SideReport>,
        dem: Option<&SideReport>,
    ) {
        let side = |r: Option<&SideReport>| {
            r.map(|r| {
                serde_json::json!({ "substeps": r.substeps, "compute_us": r.compute_us, "wait_us": r.wait_us, "exchange_us": r.exchange_us, "near_singular": r.near_singular })
            })
        };
        self.log_json(
            &self.windows,
            time,
            &serde_json::json!({ "step": step, "time": time, "window": window, "fluid": side(fluid), "dem": side(dem) }),
        );
    }

    fn log_json(&self, channel: &RawChannel, time: f64, value: &serde_json::Value) {
        channel.log_with_meta(
            value.to_string().as_bytes(),
            foxglove::PartialMetadata {
                log_time: Some(ns(time)),
            },
        );
    }

    /// Flushes and writes the summary; the file is complete and indexed afterwards.
    pub fn close(&mut self) -> Result<(), RecordError> {
        if let Some(w) = self.writer.take() {
            w.close().map_err(|e| RecordError::Mcap {
                path: self.path.clone(),
                detail: e.to_string(),
            })?;
        }
        Ok(())
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        // Every exit path closes the file: an unwinding error must not leave it unreadable.
        let _ = self.close();
    }
}

fn identity_pose() -> Pose {
    Pose {
        position: Some(Vector3 {
            x: 0.0,
            y: 0.0,
            z: 0.0,
        }),
        orientation: Some(Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }),
    }
}

fn bytemuck_cast(p: &[ParticleRecord]) -> Vec<u8> {
    let mut out = Vec::with_capacity(p.len() * 32);
    for r in p {
        for v in r
            .position
            .iter()
            .chain([r.pressure].iter())
            .chain(r.velocity.iter())
            .chain([r.density].iter())
        {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

// ---- reading a recording back (validation and tests) ----

/// One body at one time, from `/bodies/states`.
#[derive(Debug, Clone, Copy)]
pub struct BodySample {
    pub time: f64,
    pub body: usize,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
    pub velocity: [f64; 3],
}

/// One body's fluid load at one window, from `/bodies/loads`.
#[derive(Debug, Clone, Copy)]
pub struct LoadSample {
    pub time: f64,
    pub body: usize,
    /// Fluid force, N.
    pub force: [f64; 3],
    /// Fluid moment about the centre of mass, N·m.
    pub moment: [f64; 3],
}

/// A particle of a `/fluid/particles` snapshot: x y z pressure vx vy vz density.
pub type Particle = [f32; 8];

/// What a recording holds, decoded.
#[derive(Debug, Default)]
pub struct Recording {
    pub snapshots: Vec<(f64, Vec<Particle>)>,
    pub bodies: Vec<BodySample>,
    pub loads: Vec<LoadSample>,
    pub windows: usize,
    /// The file ends with a summary and footer (it was closed properly).
    pub has_summary: bool,
    /// Why reading stopped early in a file that was never closed (a run killed mid-write):
    /// the messages before the cut are kept. `None` when the file was read to its end.
    pub truncated: Option<String>,
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

/// Reads and decodes a recording. A closed file must read whole: any bad record is an error.
/// A file without its end magic (its run was killed before the recorder closed it) is read up
/// to its last complete record, and `truncated` says where and why reading stopped, so that a
/// run cut off by a time limit or a crash can still be analysed.
pub fn read_recording(path: &Path) -> Result<Recording, String> {
    use foxglove::Decode;
    let buf = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let closed = match mcap::Summary::read(&buf) {
        Ok(summary) => summary.is_some(),
        Err(mcap::McapError::BadMagic) if buf.starts_with(mcap::MAGIC) => false,
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let mut rec = Recording {
        has_summary: closed,
        ..Default::default()
    };
    let options = if closed {
        enumset::EnumSet::empty()
    } else {
        mcap::read::Options::IgnoreEndMagic.into()
    };
    for m in mcap::MessageStream::new_with_options(&buf, options)
        .map_err(|e| format!("{}: {e}", path.display()))?
    {
        let m = match m {
            Ok(m) => m,
            Err(e) if !closed => {
                rec.truncated = Some(format!(
                    "{}: not closed; read up to its last complete record ({e})",
                    path.display()
                ));
                break;
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
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
                            *v = f32::from_le_bytes([
                                c[4 * k],
                                c[4 * k + 1],
                                c[4 * k + 2],
                                c[4 * k + 3],
                            ]);
                        }
                        r
                    })
                    .collect();
                rec.snapshots.push((time, p));
            }
            "/bodies/states" => {
                let v: serde_json::Value =
                    serde_json::from_slice(&m.data).map_err(|e| e.to_string())?;
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
            "/bodies/loads" => {
                let v: serde_json::Value =
                    serde_json::from_slice(&m.data).map_err(|e| e.to_string())?;
                for l in v["loads"].as_array().into_iter().flatten() {
                    rec.loads.push(LoadSample {
                        time: v["time"].as_f64().unwrap_or(f64::NAN),
                        body: l["body"].as_u64().unwrap_or(u64::MAX) as usize,
                        force: arr(&l["force"]),
                        moment: arr(&l["moment"]),
                    });
                }
            }
            "/run/windows" => rec.windows += 1,
            _ => {}
        }
    }
    if !closed && rec.truncated.is_none() {
        rec.truncated = Some(format!(
            "{}: not closed; its records end whole",
            path.display()
        ));
    }
    Ok(rec)
}

/// The states of one body over time.
pub fn track(rec: &Recording, body: usize) -> Vec<BodySample> {
    rec.bodies
        .iter()
        .filter(|b| b.body == body)
        .copied()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A recording of `n` snapshots of 1000 particles at t = k ms, closed.
    fn write(path: &Path, n: usize) {
        let mut rec = Recorder::create(path, "test", "name = \"test\"\n").unwrap();
        for k in 0..n {
            let p: Vec<ParticleRecord> = (0..1000)
                .map(|i| ParticleRecord {
                    position: [i as f32, k as f32, 0.0],
                    pressure: 0.0,
                    velocity: [0.0; 3],
                    density: 1000.0,
                })
                .collect();
            rec.particles(k as f64 * 1e-3, &p);
        }
        rec.close().unwrap();
    }

    /// Regression (session 12): a run killed before its recorder closed the file (the RTI
    /// quick cut off at t = 42 ms by a machine restart) left an MCAP without its summary and
    /// end magic, and `read_recording` refused all of it ("Bad magic number").
    #[test]
    fn a_recording_cut_off_mid_write_reads_up_to_its_last_complete_record() {
        let dir = std::env::temp_dir().join(format!("couplet-cut-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        write(&path, 200);

        let whole = read_recording(&path).unwrap();
        assert!(whole.has_summary && whole.truncated.is_none());
        assert_eq!(whole.snapshots.len(), 200);

        // Cut the file at 60 %: inside the data section, mid-chunk.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() * 3 / 5]).unwrap();
        let cut = read_recording(&path).unwrap();
        assert!(!cut.has_summary);
        assert!(cut.truncated.as_deref().unwrap().contains("not closed"));
        // 200 snapshots of 32 kB in 6.4 MB: 60 % of the file holds about 120 of them, less
        // the chunk the cut falls in.
        let n = cut.snapshots.len();
        assert!((60..=120).contains(&n), "{n} snapshots before the cut");
        for (k, (t, p)) in cut.snapshots.iter().enumerate() {
            assert!((t - k as f64 * 1e-3).abs() < 1e-9 && p.len() == 1000);
            assert_eq!(p[999][1], k as f32);
        }

        // A file that is not an MCAP at all is still an error, not an empty recording.
        std::fs::write(&path, b"not an mcap file").unwrap();
        assert!(read_recording(&path).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
