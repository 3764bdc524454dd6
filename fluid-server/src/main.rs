//! Standalone fluid server: `couplet-fluid-server RUN_ID SCENE.toml [--detached]
//! [--checkpoints DIR] [--restore DIR]` (the orchestrator normally starts `couplet
//! fluid-server`, the same code in its own binary).

use couplet_protocol::state::StateDirs;
use couplet_protocol::transport::Orchestrator;
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: couplet-fluid-server RUN_ID SCENE.toml [--detached] [--checkpoints DIR] [--restore DIR]   (--detached: started apart from its orchestrator, `couplet run --external`)";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    // Parent first: it is the orchestrator only while this process has not been reparented.
    let parent = Orchestrator::parent();
    let [_, run_id, scene, rest @ ..] = args.as_slice() else {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    };
    let (orchestrator, rest) = match rest {
        [flag, rest @ ..] if flag == "--detached" => (Orchestrator::detached(run_id), rest),
        _ => (parent, rest),
    };
    let dirs = match StateDirs::from_args(rest) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("fluid-server: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let result = couplet_protocol::Scene::load_with_digest(&PathBuf::from(scene))
        .map_err(|e| e.to_string())
        .and_then(|(s, digest)| {
            couplet_fluid::server::serve(run_id, &s, &orchestrator, digest, &dirs)
                .map_err(|e| e.to_string())
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fluid-server: {e}");
            ExitCode::FAILURE
        }
    }
}
