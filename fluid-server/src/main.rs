//! Standalone fluid server: `couplet-fluid-server RUN_ID SCENE.toml [--checkpoints DIR] [--restore DIR]` (the orchestrator
//! normally starts `couplet fluid-server`, the same code in its own binary).

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let [_, run_id, scene, rest @ ..] = args.as_slice() else {
        eprintln!(
            "usage: couplet-fluid-server RUN_ID SCENE.toml [--checkpoints DIR] [--restore DIR]"
        );
        return ExitCode::from(2);
    };
    let dirs = match couplet_protocol::state::StateDirs::from_args(rest) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("fluid-server: {e}");
            return ExitCode::from(2);
        }
    };
    let result = couplet_protocol::Scene::load(&PathBuf::from(scene))
        .map_err(|e| e.to_string())
        .and_then(|s| couplet_fluid::server::serve(run_id, &s, &dirs).map_err(|e| e.to_string()));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fluid-server: {e}");
            ExitCode::FAILURE
        }
    }
}
