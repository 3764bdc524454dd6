//! The `couplet` CLI built inside the test package, so that the cross-process tests can
//! start it (`CARGO_BIN_EXE_couplet-cli`) and it can start itself as the servers.

fn main() -> std::process::ExitCode {
    couplet_orchestrator::cli::main()
}
