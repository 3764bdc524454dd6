//! The standalone binary's arguments (`couplet_protocol::standalone::server_main`, which
//! `couplet-dem-server` shares). Reference: the usage and exit codes that function
//! documents (2 for bad arguments, 1 for a run that cannot start).

use std::process::Command;

fn run(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_couplet-fluid-server"))
        .args(args)
        .output()
        .expect("the standalone fluid server starts");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn standalone_server_refuses_bad_arguments_with_its_usage() {
    let usage = "usage: couplet-fluid-server RUN_ID SCENE.toml [--detached]";
    let (code, err) = run(&[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains(usage), "{err}");
    let (code, err) = run(&["r", "scene.toml", "--bogus"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.starts_with("fluid-server: unknown argument \"--bogus\""),
        "{err}"
    );
    assert!(err.contains(usage), "{err}");
    let (code, err) = run(&["r", "/nonexistent/scene.toml"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.starts_with("fluid-server: /nonexistent/scene.toml"),
        "{err}"
    );
}
