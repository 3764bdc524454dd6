//! MCAP recording of a run, in Foxglove's well-known schemas where one fits so that a
//! recording opens in Foxglove with no plugin.
//!
//! | topic | schema | when |
//! |---|---|---|
//! | `/fluid/particles` | `foxglove.PointCloud` (protobuf): float32 `x y z pressure vx vy vz density`, stride 32 B, frame `world` | every particle snapshot (output interval, and the last window) |
//! | `/bodies/scene` | `foxglove.SceneUpdate` (protobuf): one entity per body, id and frame `body/<i>` (i = scene index), `frame_locked`, its real shape in its body frame: `SpherePrimitive`, `CubePrimitive`, `CylinderPrimitive` (turned so that Foxglove's z axis is the body's y), or a `TriangleListPrimitive` of the faces of its convex parts (prism, ring, cross, convex, compound); metadata `name` | once, at t = 0; entities never expire |
//! | `/tf` | `foxglove.FrameTransforms` (protobuf): parent `world`, child `body/<i>`, the body's centre of mass and orientation | at t = 0 from the scene, then every recorded body time |
//! | `/bodies/poses` | `foxglove.PosesInFrame` (protobuf), one pose per body, frame `world`, the order of `/bodies/states` | every recorded body time |
//! | `/bodies/states` | `couplet.BodyStates` (JSON): `time` (s), `bodies[]`: `body`, `name`, `position` (m), `orientation` `[x,y,z,w]`, `velocity` (m/s), `angular_velocity` (rad/s), `mass` (kg) | every recorded body time |
//! | `/bodies/loads` | `couplet.BodyLoads` (JSON): `time` (s, the window's start), `loads[]`: `body`, fluid `force` (N), `moment` about the centre of mass (N·m) | every recorded body time of a scene whose fluid sends loads |
//! | `/run/windows` | `couplet.Window` (JSON): `step`, `time` (window start, s), `window` (s), `fluid` and `dem` (null for a side that does not run): `substeps`, `compute_us`, `wait_us`, `exchange_us`, `near_singular`, `reflected`, `shift_limited`, and the fluid's `kinetic_energy` (J), `max_speed` (m/s), `max_density_error` at the window's end | every window |
//!
//! "Every recorded body time" is every window's end, or `time.body_output_interval`'s
//! thinning of it. The JSON channels are Foxglove's time series: its Plot panel reads
//! `/bodies/loads.loads[0].force[1]`; their schemas (`jsonschema` encoding, draft
//! 2020-12) type every field, arrays with their `items` and lengths.
//!
//! Log time = simulation time in ns (the recording starts at t = 0). Frame `world`,
//! SI units. The scene file is attached (`scene.toml`) and the run described in the
//! `couplet` metadata record. Chunks of 1 MiB, zstd-compressed, with message and chunk
//! indexes and a summary (statistics, schemas, channels) when the file is closed. The
//! writer is closed on every exit path, so a recording stays readable when a server dies;
//! a run killed outright leaves a file without its summary, which [`read_recording`]
//! still reads up to its last complete chunk.

use crate::vtk::{BodyMotion, polyhedra_mesh};
use couplet_dem::BodyGeometry;
use couplet_dem::DemError;
use couplet_protocol::{BodyLoad, BodyState, ParticleRecord, SideReport};
use foxglove::messages::packed_element_field::NumericType;
use foxglove::messages::{
    Color, CubePrimitive, CylinderPrimitive, FrameTransform, FrameTransforms, KeyValuePair,
    PackedElementField, Point3, PointCloud, Pose, PosesInFrame, Quaternion, SceneEntity,
    SceneUpdate, SpherePrimitive, Timestamp, TriangleListPrimitive, Vector3,
};
use foxglove::{Channel, Context, McapWriteOptions, McapWriterHandle, RawChannel, Schema};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub const TOPIC_PARTICLES: &str = "/fluid/particles";
pub const TOPIC_SCENE: &str = "/bodies/scene";
pub const TOPIC_TF: &str = "/tf";
pub const TOPIC_POSES: &str = "/bodies/poses";
pub const TOPIC_STATES: &str = "/bodies/states";
pub const TOPIC_LOADS: &str = "/bodies/loads";
pub const TOPIC_WINDOWS: &str = "/run/windows";
/// The frame every body's entity and transform hang from.
pub const WORLD_FRAME: &str = "world";

/// Uncompressed size at which a chunk is closed, compressed and indexed. mcap's default,
/// written out: a killed run loses at most the chunk it was filling, and Foxglove seeks
/// by chunk.
const CHUNK_SIZE: u64 = 1024 * 1024;

/// Errors writing a run's outputs (MCAP, VTK, CSV); each names the file.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("recording {path}: {detail}")]
    Mcap { path: PathBuf, detail: String },
    #[error("{path}: {what}: {source}")]
    Io {
        path: PathBuf,
        what: &'static str,
        source: std::io::Error,
    },
    #[error("{path}: {count} {what} exceed the Int32 indices of a VTK file")]
    TooLarge {
        path: PathBuf,
        what: &'static str,
        count: usize,
    },
    #[error("bodies[{index}] ({name}): its shape cannot be drawn: {source}")]
    Shape {
        index: usize,
        name: String,
        source: DemError,
    },
}

/// A scene body as the outputs draw it.
#[derive(Debug, Clone)]
pub struct SceneBody {
    pub name: String,
    /// Body-frame shape, origin at the centre of mass.
    pub geometry: BodyGeometry,
    /// Where the scene puts it at t = 0.
    pub start: BodyMotion,
}

/// The frame of scene body `index` in `/tf` and `/bodies/scene`.
pub fn body_frame(index: usize) -> String {
    format!("body/{index}")
}

pub struct Recorder {
    path: PathBuf,
    /// Scene body names, scene order (for `/bodies/states`).
    names: Vec<String>,
    // Keeps the channels' context alive for the writer's lifetime.
    _ctx: Arc<Context>,
    writer: Option<McapWriterHandle<BufWriter<File>>>,
    /// Logged once at creation; held so that its channel lives as long as the writer.
    scene: Option<Channel<SceneUpdate>>,
    particles: Channel<PointCloud>,
    poses: Channel<PosesInFrame>,
    transforms: Channel<FrameTransforms>,
    states: Arc<RawChannel>,
    loads: Arc<RawChannel>,
    windows: Arc<RawChannel>,
}

fn json_schema(schema: &Value) -> Schema {
    let name = schema["title"].as_str().unwrap_or_default().to_owned();
    Schema::new(name, "jsonschema", schema.to_string().into_bytes())
}

/// JSON Schema of an array of `n` numbers.
fn numbers(n: usize, description: &str) -> Value {
    json!({"type": "array", "items": {"type": "number"}, "minItems": n, "maxItems": n, "description": description})
}

fn object(title: Option<&str>, description: &str, properties: Value) -> Value {
    let required: Vec<String> = properties
        .as_object()
        .map(|p| p.keys().cloned().collect())
        .unwrap_or_default();
    let mut o = json!({"type": "object", "description": description, "properties": properties, "required": required});
    if let Some(t) = title {
        o["$schema"] = json!("https://json-schema.org/draft/2020-12/schema");
        o["title"] = json!(t);
    }
    o
}

/// `couplet.BodyStates`: what [`Recorder::bodies`] writes.
pub fn body_states_schema() -> Value {
    let body = object(
        None,
        "one body",
        json!({
            "body": {"type": "integer", "minimum": 0, "description": "index in the scene's [[bodies]]"},
            "name": {"type": "string"},
            "position": numbers(3, "centre of mass, m"),
            "orientation": numbers(4, "unit quaternion [x, y, z, w], body to world"),
            "velocity": numbers(3, "of the centre of mass, m/s"),
            "angular_velocity": numbers(3, "rad/s, world frame"),
            "mass": {"type": "number", "description": "kg"},
        }),
    );
    object(
        Some("couplet.BodyStates"),
        "body states at one time",
        json!({"time": {"type": "number", "description": "s"}, "bodies": {"type": "array", "items": body}}),
    )
}

/// `couplet.BodyLoads`: what [`Recorder::loads`] writes.
pub fn body_loads_schema() -> Value {
    let load = object(
        None,
        "the fluid's load on one body",
        json!({
            "body": {"type": "integer", "minimum": 0, "description": "index in the scene's [[bodies]]"},
            "force": numbers(3, "N"),
            "moment": numbers(3, "about the centre of mass, N·m"),
        }),
    );
    object(
        Some("couplet.BodyLoads"),
        "fluid loads held over one window",
        json!({"time": {"type": "number", "description": "the window's start, s"}, "loads": {"type": "array", "items": load}}),
    )
}

/// `couplet.Window`: what [`Recorder::window`] writes.
pub fn window_schema() -> Value {
    let mut side = object(
        None,
        "one side's report; null when that side does not run",
        json!({
            "substeps": {"type": "integer", "minimum": 0},
            "compute_us": {"type": "number"},
            "wait_us": {"type": "number"},
            "exchange_us": {"type": "number"},
            "near_singular": {"type": "integer", "minimum": 0, "description": "fluid particle-steps that kept the uncorrected gradient (Joubert eq. 10)"},
            "reflected": {"type": "integer", "minimum": 0, "description": "fluid particle-steps that ended behind a resolved body's surface or a wall face and were mirrored back"},
            "shift_limited": {"type": "integer", "minimum": 0, "description": "fluid particle-steps whose shift (Joubert eq. 17) was cut short δ/2 in front of a resolved body's surface"},
            "kinetic_energy": {"type": "number", "minimum": 0, "description": "fluid at the window's end: Σ ½ m |u|², J (0 for the DEM)"},
            "max_speed": {"type": "number", "minimum": 0, "description": "fluid at the window's end: largest particle speed, m/s (0 for the DEM)"},
            "max_density_error": {"type": "number", "minimum": 0, "description": "fluid at the window's end: largest |ρ/(ε ρ0) − 1| (0 for the DEM)"},
        }),
    );
    side["type"] = json!(["object", "null"]);
    object(
        Some("couplet.Window"),
        "one coupling window",
        json!({
            "step": {"type": "integer", "minimum": 0},
            "time": {"type": "number", "description": "the window's start, s"},
            "window": {"type": "number", "description": "its length, s"},
            "wall_s": {"type": "number", "minimum": 0, "description": "wall time of the run from its launch to this window's end, over every sitting of a resumed run, s"},
            "fluid": side.clone(),
            "dem": side,
        }),
    )
}

/// `/bodies/states`: `{"bodies": [...], "time": t}`. Serialised from borrowed fields
/// rather than through `serde_json::Value`, which allocated a map and its keys per body:
/// a record of 15 300 grains (all its channels and CSV rows) took 92–94 ms with the
/// trees and 54–55 ms without, two runs each of `couplet run scenes/rayleigh-taylor.toml
/// --windows 8 --set time.body_output_interval=1e-6` on this repository's two-core
/// machine (its `then recording`); most of the rest is zstd. The fields are in the
/// order `Value`'s sorted maps wrote them, so the bytes are the same.
#[derive(serde::Serialize)]
struct StatesRecord<'a> {
    bodies: Vec<StateRecord<'a>>,
    time: f64,
}

#[derive(serde::Serialize)]
struct StateRecord<'a> {
    angular_velocity: [f64; 3],
    body: u32,
    mass: f64,
    name: &'a str,
    orientation: [f64; 4],
    position: [f64; 3],
    velocity: [f64; 3],
}

fn states_record<'a>(time: f64, states: &[BodyState], names: &'a [String]) -> StatesRecord<'a> {
    StatesRecord {
        bodies: (states.iter())
            .map(|s| StateRecord {
                angular_velocity: s.angular_velocity,
                body: s.body,
                mass: s.mass,
                name: names.get(s.body as usize).map_or("", String::as_str),
                orientation: s.orientation,
                position: s.position,
                velocity: s.linear_velocity,
            })
            .collect(),
        time,
    }
}

/// `/bodies/loads`: `{"loads": [{"body", "force", "moment"}...], "time": t}`, as
/// [`StatesRecord`].
#[derive(serde::Serialize)]
struct LoadsRecord {
    loads: Vec<LoadRecord>,
    time: f64,
}

#[derive(serde::Serialize)]
struct LoadRecord {
    body: u32,
    force: [f64; 3],
    moment: [f64; 3],
}

fn loads_record(time: f64, loads: &[BodyLoad]) -> LoadsRecord {
    LoadsRecord {
        loads: (loads.iter())
            .map(|l| LoadRecord {
                body: l.body,
                force: l.force,
                moment: l.moment,
            })
            .collect(),
        time,
    }
}

fn stamp(t: f64) -> Timestamp {
    let ns = (t * 1e9).round().max(0.0) as u64;
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

fn ns(t: f64) -> u64 {
    (t * 1e9).round().max(0.0) as u64
}

fn vector3(v: [f64; 3]) -> Vector3 {
    Vector3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

fn quaternion(q: [f64; 4]) -> Quaternion {
    Quaternion {
        x: q[0],
        y: q[1],
        z: q[2],
        w: q[3],
    }
}

/// Colours of the bodies, by scene index (Okabe & Ito's palette, told apart with every
/// kind of colour vision).
const PALETTE: [[f64; 3]; 7] = [
    [0.902, 0.624, 0.0],
    [0.337, 0.706, 0.914],
    [0.0, 0.620, 0.451],
    [0.941, 0.894, 0.259],
    [0.0, 0.447, 0.698],
    [0.835, 0.369, 0.0],
    [0.800, 0.475, 0.655],
];

/// The rotation −π/2 about x: it turns Foxglove's cylinder axis (z) onto couplet's (y).
const Z_TO_Y: [f64; 4] = [
    -std::f64::consts::FRAC_1_SQRT_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
];

/// The `/bodies/scene` entity of scene body `index`: its shape in its own frame.
pub fn scene_entity(index: usize, body: &SceneBody) -> SceneEntity {
    let [r, g, b] = PALETTE[index % PALETTE.len()];
    let color = Some(Color { r, g, b, a: 1.0 });
    let at_origin = Some(identity_pose());
    let mut e = SceneEntity {
        timestamp: Some(stamp(0.0)),
        frame_id: body_frame(index),
        id: body_frame(index),
        // None: the entity stays until replaced; the transforms move it.
        lifetime: None,
        frame_locked: true,
        metadata: vec![KeyValuePair {
            key: "name".into(),
            value: body.name.clone(),
        }],
        ..Default::default()
    };
    match &body.geometry {
        BodyGeometry::Sphere { radius } => e.spheres.push(SpherePrimitive {
            pose: at_origin,
            size: Some(vector3([2.0 * radius; 3])),
            color,
        }),
        BodyGeometry::Box { half_extents } => e.cubes.push(CubePrimitive {
            pose: at_origin,
            size: Some(vector3(half_extents.map(|h| 2.0 * h))),
            color,
        }),
        BodyGeometry::Cylinder {
            radius,
            half_height,
        } => e.cylinders.push(CylinderPrimitive {
            pose: Some(Pose {
                position: Some(vector3([0.0; 3])),
                orientation: Some(quaternion(Z_TO_Y)),
            }),
            size: Some(vector3([2.0 * radius, 2.0 * radius, 2.0 * half_height])),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color,
        }),
        BodyGeometry::Polyhedra(parts) => {
            let mesh = polyhedra_mesh(parts);
            e.triangles.push(TriangleListPrimitive {
                pose: at_origin,
                points: mesh
                    .points
                    .iter()
                    .map(|p| Point3 {
                        x: p[0],
                        y: p[1],
                        z: p[2],
                    })
                    .collect(),
                color,
                colors: Vec::new(),
                indices: mesh.triangles.iter().flatten().copied().collect(),
            })
        }
    }
    e
}

impl Recorder {
    /// Creates `path` (replacing an earlier recording there: re-running into the same
    /// output folder is the usual way to redo a run), attaches `scene_text`, and writes
    /// the bodies' shapes and their start poses at t = 0.
    pub fn create(
        path: &Path,
        scene_name: &str,
        scene_text: &str,
        bodies: &[SceneBody],
    ) -> Result<Self, RecordError> {
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
        // Set explicitly rather than left to the defaults: the recording must be chunked,
        // compressed and indexed whatever mcap's defaults become. zstd is what every MCAP
        // reader decodes (Foxglove, the mcap CLI and crate), and it halves a small run
        // (`tests/tests/recordings.rs`: 91.5 kB of records in 46.7 kB). Compression threads stay
        // mcap's default (one per physical core): the run records after both servers
        // have reported, while they wait for the next window, so the workers use cores
        // that would otherwise idle.
        let options = McapWriteOptions::new()
            .compression(Some(foxglove::McapCompression::Zstd))
            .chunk_size(Some(CHUNK_SIZE))
            .use_chunks(true)
            .emit_message_indexes(true)
            .emit_chunk_indexes(true)
            .emit_statistics(true)
            .emit_summary_offsets(true);
        let writer = ctx
            .mcap_writer_with_options(options)
            .create_new_buffered_file(path)
            .map_err(err)?;
        let raw = |topic: &str, schema: Value| {
            ctx.channel_builder(topic)
                .message_encoding("json")
                .schema(json_schema(&schema))
                .build_raw()
                .map_err(err)
        };
        let states = raw(TOPIC_STATES, body_states_schema())?;
        let loads = raw(TOPIC_LOADS, body_loads_schema())?;
        let windows = raw(TOPIC_WINDOWS, window_schema())?;
        let particles = ctx.channel_builder(TOPIC_PARTICLES).build::<PointCloud>();
        let poses = ctx.channel_builder(TOPIC_POSES).build::<PosesInFrame>();
        let transforms = ctx.channel_builder(TOPIC_TF).build::<FrameTransforms>();
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
        let scene =
            (!bodies.is_empty()).then(|| ctx.channel_builder(TOPIC_SCENE).build::<SceneUpdate>());
        let rec = Self {
            path: path.to_owned(),
            names: bodies.iter().map(|b| b.name.clone()).collect(),
            _ctx: ctx,
            writer: Some(writer),
            scene,
            particles,
            poses,
            transforms,
            states,
            loads,
            windows,
        };
        if let Some(scene) = &rec.scene {
            scene.log_with_time(
                &SceneUpdate {
                    deletions: Vec::new(),
                    entities: bodies
                        .iter()
                        .enumerate()
                        .map(|(i, b)| scene_entity(i, b))
                        .collect(),
                },
                0,
            );
            rec.log_transforms(0.0, bodies.iter().enumerate().map(|(i, b)| (i, &b.start)));
        }
        Ok(rec)
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
            frame_id: WORLD_FRAME.into(),
            pose: Some(identity_pose()),
            point_stride: core::mem::size_of::<ParticleRecord>() as u32,
            fields,
            data: data.into(),
        };
        self.particles.log_with_time(&msg, ns(time));
    }

    fn log_transforms<'a>(&self, time: f64, bodies: impl Iterator<Item = (usize, &'a BodyMotion)>) {
        let transforms = bodies
            .map(|(i, b)| FrameTransform {
                timestamp: Some(stamp(time)),
                parent_frame_id: WORLD_FRAME.into(),
                child_frame_id: body_frame(i),
                translation: Some(vector3(b.position)),
                rotation: Some(quaternion(b.orientation)),
            })
            .collect();
        self.transforms
            .log_with_time(&FrameTransforms { transforms }, ns(time));
    }

    /// `/tf`, `/bodies/poses` and `/bodies/states` at `time`.
    pub fn bodies(&self, time: f64, states: &[BodyState]) {
        let motion: Vec<(usize, BodyMotion)> = states
            .iter()
            .map(|s| (s.body as usize, motion_of(s)))
            .collect();
        self.log_transforms(time, motion.iter().map(|(i, m)| (*i, m)));
        let poses = states
            .iter()
            .map(|s| Pose {
                position: Some(vector3(s.position)),
                orientation: Some(quaternion(s.orientation)),
            })
            .collect();
        self.poses.log_with_time(
            &PosesInFrame {
                timestamp: Some(stamp(time)),
                frame_id: WORLD_FRAME.into(),
                poses,
            },
            ns(time),
        );
        self.log_json(
            &self.states,
            time,
            &states_record(time, states, &self.names),
        );
    }

    pub fn loads(&self, time: f64, loads: &[BodyLoad]) {
        self.log_json(&self.loads, time, &loads_record(time, loads));
    }

    pub fn window(
        &self,
        step: u64,
        time: f64,
        window: f64,
        wall_s: f64,
        fluid: Option<&SideReport>,
        dem: Option<&SideReport>,
    ) {
        let side = |r: Option<&SideReport>| {
            r.map(|r| {
                json!({
                    "substeps": r.substeps, "compute_us": r.compute_us, "wait_us": r.wait_us,
                    "exchange_us": r.exchange_us, "near_singular": r.near_singular, "reflected": r.reflected,
                    "shift_limited": r.shift_limited,
                    "kinetic_energy": r.kinetic_energy, "max_speed": r.max_speed,
                    "max_density_error": r.max_density_error,
                })
            })
        };
        self.log_json(
            &self.windows,
            time,
            &json!({ "step": step, "time": time, "window": window, "wall_s": wall_s, "fluid": side(fluid), "dem": side(dem) }),
        );
    }

    fn log_json(&self, channel: &RawChannel, time: f64, value: &impl serde::Serialize) {
        let bytes = serde_json::to_vec(value).expect("a record of numbers and strings serialises");
        channel.log_with_meta(
            &bytes,
            foxglove::PartialMetadata {
                log_time: Some(ns(time)),
            },
        );
    }

    /// Writes out what is recorded so far (the open chunk ends): a process killed
    /// after this leaves a file that reads to here (not closed, so without its summary).
    pub fn flush(&self) -> Result<(), RecordError> {
        match &self.writer {
            Some(w) => w.flush().map_err(|e| RecordError::Mcap {
                path: self.path.clone(),
                detail: e.to_string(),
            }),
            None => Ok(()),
        }
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

/// A body state's pose and velocities.
pub fn motion_of(s: &BodyState) -> BodyMotion {
    BodyMotion {
        position: s.position,
        orientation: s.orientation,
        velocity: s.linear_velocity,
        angular_velocity: s.angular_velocity,
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

/// A snapshot particle's speed |(vx, vy, vz)|, m/s.
pub fn particle_speed(p: &Particle) -> f64 {
    f64::from(p[4])
        .hypot(f64::from(p[5]))
        .hypot(f64::from(p[6]))
}

/// A `/run/windows` message, decoded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowRecord {
    pub step: u64,
    /// The window's start, s.
    pub time: f64,
    /// Its length, s.
    pub window: f64,
    /// Wall time of the run to the window's end over all its sittings, s (NaN in
    /// recordings made before 2026-11-30).
    pub wall_s: f64,
}

/// Windows `from_step..to_step` (start times `from_time`, `to_time`, s) that no sitting of
/// a resumed run recorded. A sitting killed outright (SIGKILL, the machine going down)
/// loses what its recorder had not yet written; a checkpoint taken later than that, where
/// the next sitting starts, leaves the windows between in neither recording. Since
/// 2026-12-06 a checkpoint first writes out the recording
/// ([`crate::run::CoupledRun::checkpoint`]), so only older runs have them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    pub from_step: u64,
    pub to_step: u64,
    pub from_time: f64,
    pub to_time: f64,
}

/// What a recording holds, decoded.
#[derive(Debug, Default)]
pub struct Recording {
    pub snapshots: Vec<(f64, Vec<Particle>)>,
    pub bodies: Vec<BodySample>,
    pub loads: Vec<LoadSample>,
    pub windows: usize,
    /// The first and the last window recorded.
    pub first_window: Option<WindowRecord>,
    pub last_window: Option<WindowRecord>,
    /// Windows of a run over several sittings that none recorded
    /// ([`crate::resume::read_chain`]); none in one file.
    pub gaps: Vec<Gap>,
    /// The fluid's `reflected` summed over the windows: particle-steps mirrored back
    /// out of a body or across a wall face (couplet_fluid::body_non_penetration), and
    /// the start of the first window that had any, s.
    pub reflected: u64,
    pub first_reflected: Option<f64>,
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
    read_recording_before(path, None)
}

/// [`read_recording`] of the windows before window `stop` only (all with `None`): a
/// window's records precede its `/run/windows` message (`CoupledRun::advance`), so
/// reading ends with the message of window `stop − 1`. A run resumed from a checkpoint
/// at window `stop` recorded the rest again (`crate::resume`).
pub fn read_recording_before(path: &Path, stop: Option<u64>) -> Result<Recording, String> {
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
            "/run/windows" => {
                let v: serde_json::Value =
                    serde_json::from_slice(&m.data).map_err(|e| e.to_string())?;
                let step = v["step"]
                    .as_u64()
                    .ok_or_else(|| format!("{}: a window without its step", path.display()))?;
                rec.windows += 1;
                let reflected = v["fluid"]["reflected"].as_u64().unwrap_or(0);
                if reflected > 0 {
                    rec.reflected += reflected;
                    rec.first_reflected
                        .get_or_insert(v["time"].as_f64().unwrap_or(f64::NAN));
                }
                let w = WindowRecord {
                    step,
                    time: v["time"].as_f64().unwrap_or(f64::NAN),
                    window: v["window"].as_f64().unwrap_or(f64::NAN),
                    wall_s: v["wall_s"].as_f64().unwrap_or(f64::NAN),
                };
                rec.first_window.get_or_insert(w);
                rec.last_window = Some(w);
                if stop.is_some_and(|s| step + 1 >= s) {
                    break;
                }
            }
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

    /// `/bodies/states` and `/bodies/loads` written from borrowed structs have the bytes
    /// that the `serde_json::Value` trees they replaced wrote (reference: those trees,
    /// built here as the recorder built them before 2026-11-30), so recordings from
    /// before and after read alike; awkward values included (a name to escape, −0.0,
    /// a subnormal, a body without a scene name).
    #[test]
    fn body_records_keep_the_bytes_of_the_value_trees() {
        let names = vec!["a \"quoted\" grain".to_string(), "b".to_string()];
        let states = [
            BodyState {
                body: 0,
                position: [1.5e-3, -0.0, 3.0],
                orientation: [0.0, 0.0, 0.0, 1.0],
                linear_velocity: [1e-310, 2.0, -3.25],
                angular_velocity: [0.1, 0.2, 0.3],
                mass: 6.545e-7,
                ..Default::default()
            },
            BodyState {
                body: 7,
                mass: 1.0,
                ..Default::default()
            },
        ];
        let old_states: Vec<Value> = states
            .iter()
            .map(|s| {
                let name = names.get(s.body as usize).map_or("", String::as_str);
                json!({
                    "body": s.body, "name": name, "position": s.position, "orientation": s.orientation,
                    "velocity": s.linear_velocity, "angular_velocity": s.angular_velocity, "mass": s.mass,
                })
            })
            .collect();
        let old = json!({ "time": 0.125, "bodies": old_states }).to_string();
        let new = serde_json::to_string(&states_record(0.125, &states, &names)).unwrap();
        assert_eq!(new, old);

        let loads = [
            BodyLoad {
                body: 3,
                force: [1e-9, -2.5, 1e300],
                moment: [0.0, -0.0, 7.0],
                ..Default::default()
            },
            BodyLoad::default(),
        ];
        let old_loads: Vec<Value> = loads
            .iter()
            .map(|l| json!({ "body": l.body, "force": l.force, "moment": l.moment }))
            .collect();
        let old = json!({ "time": 2e-3, "loads": old_loads }).to_string();
        let new = serde_json::to_string(&loads_record(2e-3, &loads)).unwrap();
        assert_eq!(new, old);
    }

    /// A recording of `n` snapshots of 1000 particles at t = k ms, closed.
    fn write(path: &Path, n: usize) {
        let mut rec = Recorder::create(path, "test", "name = \"test\"\n", &[]).unwrap();
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

    fn body(geometry: BodyGeometry) -> SceneBody {
        SceneBody {
            name: "b".into(),
            geometry,
            start: BodyMotion {
                position: [0.0; 3],
                orientation: [0.0, 0.0, 0.0, 1.0],
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
            },
        }
    }

    /// Each analytic shape becomes Foxglove's primitive of its full size (diameter, edge,
    /// height), in the body's own frame; the cylinder's primitive is turned so that its
    /// axis (Foxglove's z) lies along the body's y, couplet's cylinder axis.
    #[test]
    fn analytic_shapes_become_primitives_of_their_size() {
        let e = scene_entity(
            3,
            &body(BodyGeometry::Box {
                half_extents: [0.1, 0.2, 0.3],
            }),
        );
        assert_eq!((e.frame_id.as_str(), e.id.as_str()), ("body/3", "body/3"));
        let size = e.cubes[0].size.unwrap();
        assert_eq!((size.x, size.y, size.z), (0.2, 0.4, 0.6));
        let e = scene_entity(
            0,
            &body(BodyGeometry::Cylinder {
                radius: 0.1,
                half_height: 0.5,
            }),
        );
        let c = e.cylinders[0];
        let size = c.size.unwrap();
        assert_eq!((size.x, size.y, size.z), (0.2, 0.2, 1.0));
        let q = c.pose.unwrap().orientation.unwrap();
        let axis = couplet_protocol::vec3::rotate([q.x, q.y, q.z, q.w], [0.0, 0.0, 1.0]);
        assert!(axis[0].abs() < 1e-15 && (axis[1] - 1.0).abs() < 1e-15 && axis[2].abs() < 1e-15);
        let e = scene_entity(0, &body(BodyGeometry::Sphere { radius: 0.25 }));
        assert_eq!(e.spheres[0].size.unwrap().y, 0.5);
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

    /// The fluid's `reflected` of each window (the non-penetration pass's count) is
    /// summed over the recording, and the first window with any is kept. Hand-set counts.
    #[test]
    fn a_recording_sums_the_fluid_mirrored_back_over_its_windows() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.mcap");
        let mut rec = Recorder::create(&path, "test", "name = \"test\"\n", &[]).unwrap();
        for (step, reflected) in [0, 0, 3, 0, 2].into_iter().enumerate() {
            let fluid = SideReport {
                reflected,
                ..Default::default()
            };
            let t = 0.5 * step as f64;
            rec.window(step as u64, t, 0.5, 0.0, Some(&fluid), None);
        }
        rec.close().unwrap();
        let r = read_recording(&path).unwrap();
        assert_eq!((r.reflected, r.first_reflected), (5, Some(1.0)));
    }

    /// Regression (2026-12-06): a process killed outright (SIGKILL; the lavapipe RTI's
    /// machine restarting) loses what its recorder holds in memory, the open chunk, which
    /// may span thousands of windows; a checkpoint taken meanwhile then starts the next
    /// sitting after the recording's end. `flush` writes it out: what was recorded
    /// before it survives the process, what came after does not.
    #[test]
    fn a_flushed_recording_survives_its_process_killed_to_the_flush() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.mcap");
        let rec = Recorder::create(&path, "test", "name = \"test\"\n", &[]).unwrap();
        let window = |step: u64| rec.window(step, step as f64, 1.0, 0.0, None, None);
        (0..10).for_each(window);
        rec.flush().unwrap();
        (10..15).for_each(window);
        // As SIGKILL: no close, no drop; the writer's memory is never written.
        std::mem::forget(rec);
        let r = read_recording(&path).unwrap();
        assert!(!r.has_summary);
        let steps = (
            r.first_window.map(|w| w.step),
            r.last_window.map(|w| w.step),
        );
        assert_eq!((r.windows, steps), (10, (Some(0), Some(9))));
    }
}
