//! Standalone fluid server: `couplet-fluid-server RUN_ID SCENE.toml [--detached]
//! [--checkpoints DIR] [--restore DIR]` (the orchestrator normally starts `couplet
//! fluid-server`, the same code in its own binary).

fn main() -> std::process::ExitCode {
    couplet_protocol::standalone::server_main("fluid-server", couplet_fluid::server::serve)
}
