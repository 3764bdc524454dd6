//! Standalone dem server: `couplet-dem-server RUN_ID SCENE.toml [--detached]
//! [--checkpoints DIR] [--restore DIR]` (the orchestrator normally starts `couplet
//! dem-server`, the same code in its own binary).

fn main() -> std::process::ExitCode {
    couplet_protocol::standalone::server_main("dem-server", couplet_dem::server::serve)
}
