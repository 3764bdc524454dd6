//! Cross-process integration and validation tests; shared helpers for them.

use std::path::PathBuf;

/// The repository root (the scenes live in `scenes/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A shipped scene by name.
pub fn scene(name: &str) -> PathBuf {
    repo_root().join("scenes").join(format!("{name}.toml"))
}
