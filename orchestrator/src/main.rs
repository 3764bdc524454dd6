//! The `couplet` binary; the command line lives in `couplet_orchestrator::cli`.

fn main() -> std::process::ExitCode {
    couplet_orchestrator::cli::main()
}
