//! Two processes exchange every payload type through iceoryx2; a peer with another
//! protocol version is refused; messages with NaN or an out-of-range body index are
//! rejected with an error naming them.
//!
//! The second process is this test binary started again with `COUPLET_TEST_PEER` set:
//! it then runs [`peer_process`] and exits (the trick keeps the peer's code next to the
//! checks). Each test uses its own run id, so its services are its own.

use couplet_protocol::transport::Endpoint;
use couplet_protocol::*;
use std::process::{Command as Proc, Stdio};
use std::time::{Duration, Instant};

const N_POINTS: usize = 1000;
const N_BODIES: usize = 3;

fn point(i: usize) -> CouplingPoint {
    let f = i as f32;
    CouplingPoint {
        position: [f, f * 0.5, -f],
        measure: 1e-6 * (1.0 + f),
        velocity: [0.1 * f, 0.0, 1.0],
        body: (i % N_BODIES) as u32,
        normal: [0.0, 1.0, 0.0],
        _pad: 0,
    }
}
fn state(i: usize) -> BodyState {
    BodyState {
        position: [i as f64, 2.0, 3.0],
        body: i as u32,
        motion: 2,
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 1.5,
        volume: 1e-3,
        ..Default::default()
    }
}
fn load(i: usize) -> BodyLoad {
    BodyLoad {
        force: [i as f64, -1.0, 0.5],
        body: i as u32,
        _pad: 0,
        moment: [0.0, 0.25, i as f64],
    }
}
fn particle(i: usize) -> ParticleRecord {
    ParticleRecord {
        position: [i as f32; 3],
        pressure: 10.0 * i as f32,
        velocity: [1.0, 2.0, 3.0],
        density: 1000.0,
    }
}

/// Starts this test binary as the peer in `mode`.
fn spawn_peer(run_id: &str, mode: &str) -> std::process::Child {
    let exe = std::env::current_exe().unwrap();
    Proc::new(exe)
        .args(["--exact", "peer_process", "--nocapture", "--test-threads=1"])
        .env("COUPLET_TEST_PEER", format!("{run_id}:{mode}"))
        .stdin(Stdio::null())
        .spawn()
        .unwrap()
}

fn run_id(tag: &str) -> String {
    format!(
        "test-{tag}-{}-{}",
        std::process::id(),
        monotonic_ns() % 1_000_000_000
    )
}

/// Polls `f` until it yields or 30 s pass.
fn within<T>(mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(t) = f() {
            return t;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "timed out waiting for the peer"
        );
        std::thread::sleep(Duration::from_micros(200));
    }
}

/// The peer's side. Only acts when started by a test below; a plain `cargo test` run
/// sees it return at once.
#[test]
fn peer_process() {
    let Ok(spec) = std::env::var("COUPLET_TEST_PEER") else {
        return;
    };
    let (run, mode) = spec.split_once(':').unwrap();
    let ep = Endpoint::new(run).unwrap();
    let points = ep
        .slice_sender::<CouplingPoint>(ServiceLeaf::Points, N_POINTS)
        .unwrap();
    let bodies = ep
        .slice_sender::<BodyState>(ServiceLeaf::Bodies, N_BODIES)
        .unwrap();
    let loads = ep
        .slice_sender::<BodyLoad>(ServiceLeaf::Loads, N_BODIES)
        .unwrap();
    let particles = ep
        .slice_sender::<ParticleRecord>(ServiceLeaf::Particles, 16)
        .unwrap();
    let hello = ep.value_sender::<Hello>(ServiceLeaf::Hello).unwrap();
    let report = ep.value_sender::<SideReport>(ServiceLeaf::Report).unwrap();
    let commands = ep.value_receiver::<Command>(ServiceLeaf::Command).unwrap();
    let back = ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads).unwrap();
    let version = if mode == "old-version" {
        PROTOCOL_VERSION + 1
    } else {
        PROTOCOL_VERSION
    };
    hello
        .send(Hello {
            protocol_version: version,
            role: Role::Dem as u32,
            pid: std::process::id(),
            dt_limit: 1e-3,
            count: N_BODIES as u64,
            ..Default::default()
        })
        .unwrap();
    // Wait for the go (the parent's subscribers exist by then).
    let go = within(|| commands.try_next().unwrap());
    assert_eq!(go.kind(), Some(CommandKind::Advance));
    assert_eq!((go.body, go.values), (3, [1.0, -2.0, 0.5, 0.0, 0.0, 7.0]));
    let h = |n: usize| WindowHeader::new(go.step, go.time, go.window, n);
    match mode {
        "all" => {
            let p: Vec<_> = (0..N_POINTS).map(point).collect();
            points.send(h(p.len()), &p).unwrap();
            let s: Vec<_> = (0..N_BODIES).map(state).collect();
            bodies.send(h(s.len()), &s).unwrap();
            let l: Vec<_> = (0..N_BODIES).map(load).collect();
            loads.send(h(l.len()), &l).unwrap();
            let r: Vec<_> = (0..16).map(particle).collect();
            particles.send(h(r.len()), &r).unwrap();
            report
                .send(SideReport {
                    protocol_version: PROTOCOL_VERSION,
                    role: Role::Dem as u32,
                    step: go.step,
                    substeps: 7,
                    ..Default::default()
                })
                .unwrap();
            // And the parent's loads coming back.
            let got = within(|| {
                back.try_step(go.step + 1)
                    .unwrap()
                    .map(|s| s.payload().to_vec())
            });
            let want: Vec<_> = (0..N_BODIES).map(|i| load(10 + i)).collect();
            if got != want {
                std::process::exit(3);
            }
        }
        "nan" => {
            let mut p: Vec<_> = (0..N_POINTS).map(point).collect();
            p[17].velocity[1] = f32::NAN;
            points.send(h(p.len()), &p).unwrap();
            let mut l: Vec<_> = (0..N_BODIES).map(load).collect();
            l[1].body = 99;
            loads.send(h(l.len()), &l).unwrap();
        }
        _ => {}
    }
    // Keep the samples alive until the parent has read them.
    std::thread::sleep(Duration::from_millis(500));
    std::process::exit(0);
}

struct Parent {
    ep: Endpoint,
    commands: couplet_protocol::transport::ValueSender<Command>,
    hellos: couplet_protocol::transport::ValueReceiver<Hello>,
}

fn parent(run: &str) -> Parent {
    let ep = Endpoint::new(run).unwrap();
    let commands = ep.value_sender::<Command>(ServiceLeaf::Command).unwrap();
    let hellos = ep.value_receiver::<Hello>(ServiceLeaf::Hello).unwrap();
    Parent {
        ep,
        commands,
        hellos,
    }
}

fn go(p: &Parent) {
    p.commands
        .send(Command {
            protocol_version: PROTOCOL_VERSION,
            kind: CommandKind::Advance as u32,
            step: 5,
            time: 0.25,
            window: 1e-4,
            snapshot: 0,
            body: 3,
            values: [1.0, -2.0, 0.5, 0.0, 0.0, 7.0],
        })
        .unwrap();
}

/// Every payload type crosses intact in both directions (exact equality: zero-copy
/// samples are bytes, nothing is converted).
#[test]
fn every_payload_type_crosses_between_processes() {
    let run = run_id("all");
    let p = parent(&run);
    let points =
        p.ep.slice_receiver::<CouplingPoint>(ServiceLeaf::Points)
            .unwrap();
    let bodies =
        p.ep.slice_receiver::<BodyState>(ServiceLeaf::Bodies)
            .unwrap();
    let loads = p.ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads).unwrap();
    let particles =
        p.ep.slice_receiver::<ParticleRecord>(ServiceLeaf::Particles)
            .unwrap();
    let reports =
        p.ep.value_receiver::<SideReport>(ServiceLeaf::Report)
            .unwrap();
    let loads_back =
        p.ep.slice_sender::<BodyLoad>(ServiceLeaf::Loads, N_BODIES)
            .unwrap();
    let mut child = spawn_peer(&run, "all");

    let hello = within(|| p.hellos.try_next().unwrap());
    assert_eq!(check_hello(&hello), Ok(Role::Dem));
    go(&p);
    let got_points = within(|| points.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    assert_eq!(got_points, (0..N_POINTS).map(point).collect::<Vec<_>>());
    validate_points(&got_points, N_BODIES).unwrap();
    let got_states = within(|| bodies.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    assert_eq!(got_states, (0..N_BODIES).map(state).collect::<Vec<_>>());
    let got_loads = within(|| loads.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    assert_eq!(got_loads, (0..N_BODIES).map(load).collect::<Vec<_>>());
    let got_particles = within(|| particles.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    assert_eq!(got_particles, (0..16).map(particle).collect::<Vec<_>>());
    let r = within(|| reports.try_next().unwrap());
    assert_eq!((r.step, r.substeps), (5, 7));

    let back: Vec<_> = (0..N_BODIES).map(|i| load(10 + i)).collect();
    loads_back
        .send(WindowHeader::new(6, 0.3, 1e-4, back.len()), &back)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(
        status.success(),
        "the peer did not receive the loads intact: {status}"
    );
}

/// A peer that speaks another protocol version is refused at the handshake, and the
/// refusal names both versions.
#[test]
fn peer_with_other_protocol_version_is_refused() {
    let run = run_id("version");
    let p = parent(&run);
    let mut child = spawn_peer(&run, "old-version");
    let hello = within(|| p.hellos.try_next().unwrap());
    let err = check_hello(&hello).unwrap_err();
    assert_eq!(
        err,
        HandshakeError::Version {
            role: "dem-server",
            pid: child.id(),
            got: PROTOCOL_VERSION + 1
        }
    );
    assert!(
        err.to_string()
            .contains(&format!("version {}", PROTOCOL_VERSION + 1)),
        "{err}"
    );
    child.kill().unwrap();
    let _ = child.wait();
}

/// A point with a NaN velocity and a load with body index 99 (of 3) arrive from another
/// process and are rejected with errors naming the element and field.
#[test]
fn nan_and_out_of_range_body_are_rejected() {
    let run = run_id("nan");
    let p = parent(&run);
    let points =
        p.ep.slice_receiver::<CouplingPoint>(ServiceLeaf::Points)
            .unwrap();
    let loads = p.ep.slice_receiver::<BodyLoad>(ServiceLeaf::Loads).unwrap();
    let mut child = spawn_peer(&run, "nan");
    within(|| p.hellos.try_next().unwrap());
    go(&p);
    let pts = within(|| points.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    let e = validate_points(&pts, N_BODIES).unwrap_err();
    assert!(
        matches!(
            e,
            ValidationError::NonFinite {
                index: 17,
                field: "velocity",
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("coupling_point[17].velocity"), "{e}");
    let l = within(|| loads.try_step(5).unwrap().map(|s| s.payload().to_vec()));
    let e = validate_loads(&l, N_BODIES).unwrap_err();
    assert_eq!(
        e,
        ValidationError::BodyIndex {
            what: "body_load",
            index: 1,
            body: 99,
            bodies: N_BODIES
        }
    );
    assert!(child.wait().unwrap().success());
}
