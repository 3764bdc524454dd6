//! Standalone DEM server: `couplet-dem-server RUN_ID SCENE.toml [--detached]` (the orchestrator
//! normally starts `couplet dem-server`, the same code in its own binary).

use couplet_protocol::transport::Orchestrator;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    // Parent first: it is the orchestrator only while this process has not been reparented.
    let parent = Orchestrator::parent();
    let (run_id, scene, orchestrator) = match args.as_slice() {
        [_, run_id, scene] => (run_id, scene, parent),
        [_, run_id, scene, flag] if flag == "--detached" => {
            (run_id, scene, Orchestrator::detached(run_id))
        }
        _ => {
            eprintln!(
                "usage: couplet-dem-server RUN_ID SCENE.toml [--detached]   (--detached: started apart from its orchestrator, `couplet run --external`)"
            );
            return ExitCode::from(2);
        }
    };
    let result = couplet_protocol::Scene::load_with_digest(&PathBuf::from(scene))
        .map_err(|e| e.to_string())
        .and_then(|(s, digest)| {
            couplet_dem::server::serve(run_id, &s, &orchestrator, digest).map_err(|e| e.to_string())
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dem-server: {e}");
            ExitCode::FAILURE
        }
    }
}
