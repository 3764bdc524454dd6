//! The `main` of the standalone server binaries (`couplet-fluid-server`,
//! `couplet-dem-server`): `RUN_ID SCENE.toml [--detached] [--checkpoints DIR]
//! [--restore DIR]`, the arguments of `couplet fluid-server` and `couplet dem-server`,
//! parsed by hand so that the server crates need no argument parser.

use crate::Scene;
use crate::state::StateDirs;
use crate::transport::Orchestrator;
use std::fmt::Display;
use std::path::Path;
use std::process::ExitCode;

/// Runs the server `role` ("fluid-server" or "dem-server") of the process's arguments
/// with `serve`: exit code 2 with the usage for bad arguments, 1 with the error when the
/// scene cannot be read or `serve` fails.
pub fn server_main<E: Display>(
    role: &str,
    serve: impl FnOnce(&str, &Scene, &Orchestrator, u32, &StateDirs) -> Result<(), E>,
) -> ExitCode {
    // Parent first: it is the orchestrator only while this process has not been reparented.
    let parent = Orchestrator::parent();
    let usage = format!(
        "usage: couplet-{role} RUN_ID SCENE.toml [--detached] [--checkpoints DIR] [--restore DIR]   \
         (--detached: started apart from its orchestrator, `couplet run --external`)"
    );
    let args: Vec<String> = std::env::args().collect();
    let [_, run_id, scene, rest @ ..] = args.as_slice() else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let (orchestrator, rest) = match rest {
        [flag, rest @ ..] if flag == "--detached" => (Orchestrator::detached(run_id), rest),
        _ => (parent, rest),
    };
    let dirs = match StateDirs::from_args(rest) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("{role}: {e}\n{usage}");
            return ExitCode::from(2);
        }
    };
    let result = Scene::load_with_digest(Path::new(scene))
        .map_err(|e| e.to_string())
        .and_then(|(s, digest)| {
            serve(run_id, &s, &orchestrator, digest, &dirs).map_err(|e| e.to_string())
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{role}: {e}");
            ExitCode::FAILURE
        }
    }
}
