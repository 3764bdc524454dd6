//! A run's outputs read back (issue 6, "Recordings and outputs"): `run.mcap` with the
//! `mcap` crate, the VTK files with an XML parser, `bodies.csv` as text.
//!
//! The run: a 12 × 8 × 6 cm box, water to 8 cm at δ = 1 cm (576 fluid particles), with
//! three resolved bodies of different shapes — a sphere, a cylinder (Foxglove's cylinder
//! axis is z, couplet's y) and Joubert's cross (a compound: a triangle list) — stopped
//! after 12 windows (`--windows 12`), snapshots every 4 ms (about every third window),
//! VTK on (`--set output.vtk=true`). The sizes only need to run in seconds on lavapipe:
//! nothing physical is judged here. Every expected count comes from the documented rules
//! (`record.rs`, `outputs.rs`, `vtk.rs` module docs) applied to the windows the recording
//! says were run; every expected number from another channel or file of the same run, or
//! from the scene.

use couplet_orchestrator::outputs::BODY_CSV_HEADER;
use couplet_orchestrator::record::{body_loads_schema, body_states_schema, window_schema};
use couplet_tests::couplet_run;
use foxglove::Decode;
use foxglove::messages::{FrameTransforms, PointCloud, SceneUpdate};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const CLI: &str = env!("CARGO_BIN_EXE_couplet-cli");
const WINDOWS: usize = 12;
const OUTPUT_INTERVAL: f64 = 4e-3;

const SCENE: &str = r#"
[meta]
name = "recordings"
[time]
end = 1.0
output_interval = 4e-3
[fluid]
density = 1000.0
kinematic_viscosity = 1e-4
sound_speed = 2.0
spacing = 0.01
[[fluid.blocks]]
min = [0.0, 0.0, 0.0]
max = [0.12, 0.08, 0.06]
[domain]
min = [0.0, 0.0, 0.0]
max = [0.12, 0.1, 0.06]
[gravity]
on_fluid = false
[[bodies]]
name = "ball"
shape.sphere.radius = 0.02
density = 1200.0
position = [0.025, 0.04, 0.03]
[[bodies]]
name = "can"
shape.cylinder = { radius = 0.012, half_height = 0.015 }
density = 1200.0
position = [0.06, 0.04, 0.03]
rotation = [0.0, 0.0, 0.3]
[[bodies]]
name = "cross"
shape.cross = { base = 0.02, width = 0.008, height = 0.008 }
density = 1200.0
position = [0.095, 0.04, 0.03]
"#;
const SPHERE_RADIUS: f64 = 0.02;
const CYLINDER: (f64, f64) = (0.012, 0.015);
/// Cross b, w, h (Joubert's layout: volume 5 b w h).
const CROSS: (f64, f64, f64) = (0.02, 0.008, 0.008);

/// Every channel the README documents, with its schema encoding and name.
const CHANNELS: [(&str, &str, &str); 7] = [
    ("/fluid/particles", "protobuf", "foxglove.PointCloud"),
    ("/bodies/scene", "protobuf", "foxglove.SceneUpdate"),
    ("/tf", "protobuf", "foxglove.FrameTransforms"),
    ("/bodies/poses", "protobuf", "foxglove.PosesInFrame"),
    ("/bodies/states", "jsonschema", "couplet.BodyStates"),
    ("/bodies/loads", "jsonschema", "couplet.BodyLoads"),
    ("/run/windows", "jsonschema", "couplet.Window"),
];

/// The JSON Schema keywords the recorder's schemas may use: [`validate`] implements each
/// one, so none is silently ignored.
const KEYWORDS: [&str; 10] = [
    "$schema",
    "title",
    "description",
    "type",
    "properties",
    "required",
    "items",
    "minItems",
    "maxItems",
    "minimum",
];

fn check_keywords(schema: &Value, at: &str) {
    let o = schema
        .as_object()
        .unwrap_or_else(|| panic!("{at}: not a schema object"));
    for (k, v) in o {
        assert!(KEYWORDS.contains(&k.as_str()), "{at}: keyword {k}");
        match k.as_str() {
            "properties" => {
                for (name, sub) in v.as_object().expect("properties is an object") {
                    check_keywords(sub, &format!("{at}.{name}"));
                }
            }
            "items" => check_keywords(v, &format!("{at}[]")),
            _ => {}
        }
    }
}

/// Structural JSON Schema validation of `v` (the keywords of [`KEYWORDS`]); stricter than
/// JSON Schema in one way: a message may carry no property its schema does not declare.
fn validate(schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    let types: Vec<&str> = match &schema["type"] {
        Value::String(t) => vec![t.as_str()],
        Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    let fits = |t: &str| match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "number" => v.is_number(),
        "integer" => v.is_i64() || v.is_u64(),
        "string" => v.is_string(),
        "null" => v.is_null(),
        "boolean" => v.is_boolean(),
        _ => false,
    };
    if !types.is_empty() && !types.iter().any(|t| fits(t)) {
        return Err(format!("{at}: {v} is not {types:?}"));
    }
    if let (Some(min), Some(x)) = (schema["minimum"].as_f64(), v.as_f64())
        && x < min
    {
        return Err(format!("{at}: {x} < minimum {min}"));
    }
    if let Some(o) = v.as_object() {
        for r in schema["required"].as_array().into_iter().flatten() {
            let r = r.as_str().unwrap_or_default();
            if !o.contains_key(r) {
                return Err(format!("{at}: required {r} missing"));
            }
        }
        for (k, x) in o {
            let sub = schema["properties"]
                .get(k)
                .ok_or_else(|| format!("{at}: undeclared property {k}"))?;
            validate(sub, x, &format!("{at}.{k}"))?;
        }
    }
    if let Some(a) = v.as_array() {
        if let Some(n) = schema["minItems"].as_u64()
            && (a.len() as u64) < n
        {
            return Err(format!("{at}: {} items < minItems {n}", a.len()));
        }
        if let Some(n) = schema["maxItems"].as_u64()
            && (a.len() as u64) > n
        {
            return Err(format!("{at}: {} items > maxItems {n}", a.len()));
        }
        if schema.get("items").is_some() {
            for (i, x) in a.iter().enumerate() {
                validate(&schema["items"], x, &format!("{at}[{i}]"))?;
            }
        }
    }
    Ok(())
}

/// Volume enclosed by a triangle list (divergence theorem), m³.
fn enclosed_volume(points: &[[f64; 3]], indices: &[u32]) -> f64 {
    indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| points[t[k] as usize]);
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum()
}

/// One `<DataArray>` decoded: base64 of a UInt64 byte count and the values.
fn data_array(node: roxmltree::Node) -> Vec<u8> {
    use base64::Engine;
    assert_eq!(node.attribute("format"), Some("binary"));
    let text: String = node
        .text()
        .unwrap_or_default()
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect();
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(text)
        .expect("base64");
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    assert_eq!(n, bytes.len() - 8, "header byte count");
    bytes[8..].to_vec()
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}
fn f64s(b: &[u8]) -> Vec<f64> {
    b.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}
fn i32s(b: &[u8]) -> Vec<i32> {
    b.chunks_exact(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn type_size(t: &str) -> usize {
    match t {
        "Float32" | "Int32" => 4,
        "Float64" | "Int64" | "UInt64" => 8,
        other => panic!("unexpected DataArray type {other}"),
    }
}

/// A parsed `.vtp`: its piece's counts and every named array (decoded bytes, type,
/// components), keyed `Section/Name` (`Points` for the points).
struct Vtp {
    points: usize,
    verts: usize,
    polys: usize,
    time: f64,
    arrays: BTreeMap<String, (Vec<u8>, String, usize)>,
}

fn read_vtp(path: &Path) -> Vtp {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let root = doc.root_element();
    assert_eq!(root.attribute("type"), Some("PolyData"));
    assert_eq!(root.attribute("header_type"), Some("UInt64"));
    let piece = root
        .descendants()
        .find(|n| n.has_tag_name("Piece"))
        .unwrap();
    let count = |a: &str| piece.attribute(a).unwrap().parse::<usize>().unwrap();
    let mut arrays = BTreeMap::new();
    let mut time = f64::NAN;
    for a in root.descendants().filter(|n| n.has_tag_name("DataArray")) {
        let section = a.parent_element().unwrap().tag_name().name().to_owned();
        let name = a.attribute("Name").unwrap_or("").to_owned();
        let ty = a.attribute("type").unwrap().to_owned();
        let bytes = data_array(a);
        if section == "FieldData" && name == "TimeValue" {
            time = f64s(&bytes)[0];
            continue;
        }
        let comps = a
            .attribute("NumberOfComponents")
            .map_or(1, |c| c.parse().unwrap());
        assert_eq!(bytes.len() % (type_size(&ty) * comps), 0, "{path:?} {name}");
        let key = if section == "Points" {
            "Points".to_owned()
        } else {
            format!("{section}/{name}")
        };
        arrays.insert(key, (bytes, ty, comps));
    }
    Vtp {
        points: count("NumberOfPoints"),
        verts: count("NumberOfVerts"),
        polys: count("NumberOfPolys"),
        time,
        arrays,
    }
}

impl Vtp {
    fn tuples(&self, key: &str) -> usize {
        let (b, ty, comps) = &self.arrays[key];
        b.len() / (type_size(ty) * comps)
    }
}

/// The `timestep`s and files of a `.pvd`.
fn read_pvd(path: &Path) -> Vec<(f64, String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    assert_eq!(doc.root_element().attribute("type"), Some("Collection"));
    doc.descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            (
                n.attribute("timestep").unwrap().parse().unwrap(),
                n.attribute("file").unwrap().to_owned(),
            )
        })
        .collect()
}

fn arr(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Two shortest-round-trip decimals of one f64 (the CSV's `{:e}`, serde_json's ryu) read
/// back within a few ulps: serde_json's default float parser is not correctly rounded.
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs())
}

#[test]
fn outputs_read_back_whole() {
    let out = tempfile::tempdir().unwrap();
    let scene_path = out.path().join("recordings.toml");
    std::fs::write(&scene_path, SCENE).unwrap();
    let o = couplet_run(
        CLI,
        &scene_path,
        out.path(),
        &[
            "--windows",
            &WINDOWS.to_string(),
            "--set",
            "output.vtk=true",
        ],
    );
    assert!(o.status.success(), "the run failed");

    // ---- MCAP: summary, indexes, compression ----
    let buf = std::fs::read(out.path().join("run.mcap")).unwrap();
    let summary = mcap::Summary::read(&buf)
        .unwrap()
        .expect("a finished recording has a summary");
    assert!(!summary.chunk_indexes.is_empty());
    let (mut packed, mut unpacked) = (0, 0);
    for c in &summary.chunk_indexes {
        assert_eq!(c.compression, "zstd", "chunk at {}", c.chunk_start_offset);
        assert!(
            !c.message_index_offsets.is_empty(),
            "chunk without message indexes"
        );
        packed += c.compressed_size;
        unpacked += c.uncompressed_size;
    }
    eprintln!(
        "{} chunks, {packed} B compressed from {unpacked} B",
        summary.chunk_indexes.len()
    );
    assert!(packed < unpacked, "{packed} B not below {unpacked} B");
    let stats = summary.stats.as_ref().expect("statistics in the summary");

    // Every documented channel, no other, each with its schema.
    let topics: BTreeSet<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    let documented: BTreeSet<&str> = CHANNELS.iter().map(|c| c.0).collect();
    assert_eq!(topics, documented);
    let mut pools = BTreeMap::new();
    let mut json_schemas = BTreeMap::new();
    for c in summary.channels.values() {
        let (_, encoding, name) = CHANNELS.iter().find(|d| d.0 == c.topic).unwrap();
        let schema = c.schema.as_ref().expect("every channel has a schema");
        assert_eq!(
            (schema.encoding.as_str(), schema.name.as_str()),
            (*encoding, *name)
        );
        if *encoding == "protobuf" {
            assert_eq!(c.message_encoding, "protobuf");
            // The schema is a FileDescriptorSet that defines the named message.
            let pool = prost_reflect::DescriptorPool::decode(&schema.data[..])
                .unwrap_or_else(|e| panic!("{}: {e}", c.topic));
            let desc = pool
                .get_message_by_name(name)
                .unwrap_or_else(|| panic!("{}: no {name} in its schema", c.topic));
            pools.insert(c.topic.clone(), desc);
        } else {
            assert_eq!(c.message_encoding, "json");
            let s: Value = serde_json::from_slice(&schema.data).unwrap();
            check_keywords(&s, &c.topic);
            assert_eq!(s["title"], *name);
            json_schemas.insert(c.topic.clone(), s);
        }
    }
    // The schemas written are the ones the recorder module publishes.
    assert_eq!(json_schemas["/bodies/states"], body_states_schema());
    assert_eq!(json_schemas["/bodies/loads"], body_loads_schema());
    assert_eq!(json_schemas["/run/windows"], window_schema());

    // Every message decodes with its channel's schema and fields.
    let mut by_topic: BTreeMap<String, Vec<(u64, Vec<u8>)>> = BTreeMap::new();
    for m in mcap::MessageStream::new(&buf).unwrap() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        if let Some(desc) = pools.get(&topic) {
            let d = prost_reflect::DynamicMessage::decode(desc.clone(), &m.data[..])
                .unwrap_or_else(|e| panic!("{topic} at {} ns: {e}", m.log_time));
            assert_eq!(
                d.unknown_fields().count(),
                0,
                "{topic}: fields its schema lacks"
            );
        } else {
            let v: Value = serde_json::from_slice(&m.data).unwrap();
            validate(&json_schemas[&topic], &v, &topic).unwrap();
        }
        by_topic
            .entry(topic)
            .or_default()
            .push((m.log_time, m.data.to_vec()));
    }
    for c in summary.channels.values() {
        let counted = by_topic.get(&c.topic).map_or(0, Vec::len) as u64;
        assert_eq!(
            stats.channel_message_counts.get(&c.id).copied(),
            Some(counted),
            "{}",
            c.topic
        );
    }
    let json = |topic: &str| -> Vec<Value> {
        by_topic[topic]
            .iter()
            .map(|(_, d)| serde_json::from_slice(d).unwrap())
            .collect()
    };

    // ---- message counts against the windows run ----
    let windows = json("/run/windows");
    assert_eq!(windows.len(), WINDOWS);
    for (k, w) in windows.iter().enumerate() {
        assert_eq!(w["step"].as_u64(), Some(k as u64));
        assert!(w["fluid"].is_object() && w["dem"].is_object());
    }
    let window = windows[0]["window"].as_f64().unwrap();
    // Body states, poses and loads are recorded every window (no body_output_interval);
    // /tf once more, at t = 0 from the scene; the shapes once.
    for topic in ["/bodies/states", "/bodies/poses", "/bodies/loads"] {
        assert_eq!(by_topic[topic].len(), WINDOWS, "{topic}");
    }
    assert_eq!(by_topic["/tf"].len(), WINDOWS + 1);
    assert_eq!(by_topic["/bodies/scene"].len(), 1);
    // Snapshots: at the first window end at or after each multiple of the output
    // interval, and at the last window (run.rs, `CoupledRun::advance`).
    let mut expected_snapshots = Vec::new();
    let mut next = OUTPUT_INTERVAL;
    for k in 0..WINDOWS {
        let end = (k + 1) as f64 * window;
        if end >= next * (1.0 - 1e-9) || k + 1 == WINDOWS {
            expected_snapshots.push(end);
            while next <= end * (1.0 + 1e-9) {
                next += OUTPUT_INTERVAL;
            }
        }
    }
    eprintln!("window {window:.4e} s, snapshots at {expected_snapshots:?}");
    let snapshots: Vec<(f64, PointCloud)> = by_topic["/fluid/particles"]
        .iter()
        .map(|(t, d)| (*t as f64 * 1e-9, PointCloud::decode(&d[..]).unwrap()))
        .collect();
    assert_eq!(snapshots.len(), expected_snapshots.len());
    for ((t, pc), e) in snapshots.iter().zip(&expected_snapshots) {
        // Log times are whole ns.
        assert!((t - e).abs() < 1e-9, "snapshot at {t}, expected {e}");
        assert_eq!(pc.data.len() % 32, 0);
        assert!(pc.data.len() / 32 > 300, "{} particles", pc.data.len() / 32);
    }

    // ---- the bodies' shapes and motion ----
    let scene = SceneUpdate::decode(&by_topic["/bodies/scene"][0].1[..]).unwrap();
    assert_eq!(scene.entities.len(), 3);
    for (i, e) in scene.entities.iter().enumerate() {
        assert_eq!(e.frame_id, format!("body/{i}"));
        assert!(e.frame_locked && e.lifetime.is_none());
    }
    let sphere = &scene.entities[0].spheres[0].size.unwrap();
    assert_eq!(
        (sphere.x, sphere.y, sphere.z),
        (
            2.0 * SPHERE_RADIUS,
            2.0 * SPHERE_RADIUS,
            2.0 * SPHERE_RADIUS
        )
    );
    let cyl = &scene.entities[1].cylinders[0];
    let size = cyl.size.unwrap();
    assert_eq!((size.x, size.z), (2.0 * CYLINDER.0, 2.0 * CYLINDER.1));
    // Its pose turns Foxglove's z (the cylinder's axis) onto the body's y.
    let q = cyl.pose.unwrap().orientation.unwrap();
    let z_image = couplet_protocol::vec3::rotate([q.x, q.y, q.z, q.w], [0.0, 0.0, 1.0]);
    assert!((z_image[1] - 1.0).abs() < 1e-15, "{z_image:?}");
    // The cross's triangles enclose Joubert's 5 b w h (to round-off: the mesh is its faces).
    let tri = &scene.entities[2].triangles[0];
    let pts: Vec<[f64; 3]> = tri.points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let v = enclosed_volume(&pts, &tri.indices);
    let v_cross = 5.0 * CROSS.0 * CROSS.1 * CROSS.2;
    assert!((v / v_cross - 1.0).abs() < 1e-12, "{v} vs {v_cross}");

    let states = json("/bodies/states");
    let tf: Vec<FrameTransforms> = by_topic["/tf"]
        .iter()
        .map(|(_, d)| FrameTransforms::decode(&d[..]).unwrap())
        .collect();
    assert_eq!(by_topic["/tf"][0].0, 0);
    assert_eq!(tf[0].transforms[1].translation.unwrap().x, 0.06);
    for (s, t) in states.iter().zip(&tf[1..]) {
        let bodies = s["bodies"].as_array().unwrap();
        assert_eq!(bodies.len(), 3);
        for (b, f) in bodies.iter().zip(&t.transforms) {
            assert_eq!(f.parent_frame_id, "world");
            assert_eq!(f.child_frame_id, format!("body/{}", b["body"]));
            let p = f.translation.unwrap();
            for (x, y) in arr(&b["position"]).iter().zip([p.x, p.y, p.z]) {
                assert!(same(*x, y), "{x} vs {y}");
            }
        }
    }

    // ---- VTK: the collections list every frame; the frames parse back ----
    let fluid_pvd = read_pvd(&out.path().join("fluid.pvd"));
    let bodies_pvd = read_pvd(&out.path().join("bodies.pvd"));
    assert_eq!(fluid_pvd.len(), snapshots.len());
    assert_eq!(bodies_pvd.len(), snapshots.len());
    for (k, ((t, pc), ((tf, ff), (tb, fb)))) in snapshots
        .iter()
        .zip(fluid_pvd.iter().zip(&bodies_pvd))
        .enumerate()
    {
        assert_eq!(ff, &format!("vtk/fluid_{k:06}.vtp"));
        assert_eq!(fb, &format!("vtk/bodies_{k:06}.vtp"));
        assert!((tf - t).abs() < 1e-9 && (tb - t).abs() < 1e-9);
        let fluid = read_vtp(&out.path().join(ff));
        let n = pc.data.len() / 32;
        assert_eq!((fluid.points, fluid.verts, fluid.polys), (n, n, 0));
        assert_eq!(fluid.time, *tf);
        for (key, tuples) in [
            ("Points", n),
            ("PointData/velocity", n),
            ("PointData/pressure", n),
            ("PointData/density", n),
            ("Verts/connectivity", n),
            ("Verts/offsets", n),
        ] {
            assert_eq!(fluid.tuples(key), tuples, "{ff} {key}");
        }
        // The same particles as the MCAP snapshot, bit for bit: x y z of each record.
        let xyz = f32s(&fluid.arrays["Points"].0);
        let mcap_xyz: Vec<f32> = f32s(&pc.data)
            .chunks_exact(8)
            .flat_map(|r| [r[0], r[1], r[2]])
            .collect();
        assert_eq!(xyz, mcap_xyz);
        assert_eq!(
            i32s(&fluid.arrays["Verts/offsets"].0).last().copied(),
            Some(n as i32)
        );

        let bodies = read_vtp(&out.path().join(fb));
        assert_eq!(bodies.verts, 0);
        let cells = bodies.polys;
        assert_eq!(bodies.tuples("Points"), bodies.points);
        assert_eq!(bodies.tuples("PointData/velocity"), bodies.points);
        assert_eq!(bodies.tuples("CellData/body"), cells);
        assert_eq!(bodies.tuples("Polys/connectivity"), 3 * cells);
        assert_eq!(bodies.tuples("Polys/offsets"), cells);
        let owner = i32s(&bodies.arrays["CellData/body"].0);
        assert_eq!(
            owner.iter().copied().collect::<BTreeSet<_>>(),
            BTreeSet::from([0, 1, 2])
        );
        // The sphere's mesh is symmetric about its centre: the mean of its vertices is the
        // body's position in /bodies/states at that time, and the mean of the vertex
        // velocities v + ω × r its velocity (to round-off of 1e-12 m, m/s).
        let conn = i32s(&bodies.arrays["Polys/connectivity"].0);
        let mut sphere_vertices: Vec<usize> = conn
            .chunks_exact(3)
            .zip(&owner)
            .filter(|(_, b)| **b == 0)
            .flat_map(|(t, _)| t.iter().map(|&i| i as usize))
            .collect();
        sphere_vertices.sort_unstable();
        sphere_vertices.dedup();
        let xyz = f64s(&bodies.arrays["Points"].0);
        let vel = f64s(&bodies.arrays["PointData/velocity"].0);
        let mean = |a: &[f64], k: usize| {
            sphere_vertices.iter().map(|&i| a[3 * i + k]).sum::<f64>()
                / sphere_vertices.len() as f64
        };
        let state = states
            .iter()
            .find(|s| (s["time"].as_f64().unwrap() - t).abs() < 1e-9)
            .expect("body states at the snapshot's time");
        let ball = &state["bodies"][0];
        for k in 0..3 {
            assert!((mean(&xyz, k) - arr(&ball["position"])[k]).abs() < 1e-12);
            assert!((mean(&vel, k) - arr(&ball["velocity"])[k]).abs() < 1e-12);
        }
    }

    // ---- CSV: a row per body per /bodies/states message, the same numbers ----
    let csv = std::fs::read_to_string(out.path().join("bodies.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(BODY_CSV_HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let loads = json("/bodies/loads");
    let names = ["ball", "can", "cross"];
    let mut r = 0;
    for (s, l) in states.iter().zip(&loads) {
        for b in s["bodies"].as_array().unwrap() {
            let row = &rows[r];
            r += 1;
            let num = |i: usize| row[i].parse::<f64>().unwrap();
            let body = b["body"].as_u64().unwrap() as usize;
            assert!(same(num(0), s["time"].as_f64().unwrap()));
            assert_eq!((row[1], row[2]), (body.to_string().as_str(), names[body]));
            let expected: Vec<f64> = ["position", "orientation", "velocity", "angular_velocity"]
                .iter()
                .flat_map(|k| arr(&b[*k]))
                .collect();
            for (i, e) in expected.iter().enumerate() {
                assert!(same(num(3 + i), *e), "row {r} column {}", 3 + i);
            }
            let load = l["loads"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["body"] == b["body"])
                .expect("every body here is resolved and gets a load");
            let fm: Vec<f64> = arr(&load["force"])
                .into_iter()
                .chain(arr(&load["moment"]))
                .collect();
            for (i, e) in fm.iter().enumerate() {
                assert!(same(num(16 + i), *e), "row {r} column {}", 16 + i);
            }
        }
    }
    assert_eq!(r, rows.len());
    assert_eq!(rows.len(), 3 * WINDOWS);
}
