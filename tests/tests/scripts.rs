//! The shell scripts a fresh machine runs first (`scripts/ensure-vulkan`, called by
//! `scripts/test` and `scripts/couplet`): they must find a Vulkan driver that is installed
//! whatever PATH they are started with, and must not report one missing that is there.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn ensure_vulkan() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/ensure-vulkan")
}

fn run_with_path(path: &str) -> Output {
    Command::new("bash")
        .arg(ensure_vulkan())
        .env("PATH", path)
        .output()
        .expect("bash runs scripts/ensure-vulkan")
}

fn describe(o: &Output) -> String {
    format!(
        "exit {:?}, stderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The driver this suite's GPU tests run on is there (scripts/test installed it before
/// the tests started); the script must say so without installing anything.
fn assert_found_without_installing(o: &Output, what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !err.contains("no Vulkan driver found"),
        "{what}: scripts/ensure-vulkan did not find the installed driver: {}",
        describe(o)
    );
}

/// Regression: CI of 2026-11-27 ran `.ci/run` with a PATH without /usr/sbin, where
/// `ldconfig` lives; the loader check failed, apt reinstalled nothing, and the run stopped
/// after 2 s with "installing mesa-vulkan-drivers did not provide a Vulkan driver".
#[test]
fn ensure_vulkan_finds_the_driver_without_sbin_on_path() {
    let full = run_with_path(&std::env::var("PATH").unwrap_or_default());
    assert_found_without_installing(&full, "with the test's own PATH");
    let bare = run_with_path("/usr/bin:/bin");
    assert_found_without_installing(&bare, "with PATH=/usr/bin:/bin");
}

/// Regression (same failure, other cause): `ldconfig -p | grep -q` under `set -o pipefail`
/// fails when grep stops reading before ldconfig has written everything — ldconfig dies of
/// SIGPIPE once its output passes the pipe's buffer (64 KiB on Linux). A stand-in
/// `ldconfig` that lists the real cache's libvulkan.so.1 first and then 1 MiB of other
/// libraries makes that happen every time.
#[test]
fn ensure_vulkan_reads_a_long_ldconfig_cache() {
    let real = ["/usr/sbin/ldconfig", "/sbin/ldconfig"]
        .into_iter()
        .find(|p| Path::new(p).exists())
        .expect("ldconfig in /usr/sbin or /sbin");
    let cache = Command::new(real)
        .arg("-p")
        .output()
        .expect("ldconfig -p runs");
    let cache = String::from_utf8_lossy(&cache.stdout);
    let vulkan = cache
        .lines()
        .find(|l| l.trim_start().starts_with("libvulkan.so.1 "))
        .expect("the ldconfig cache lists libvulkan.so.1 (scripts/test installs it)");

    let dir = tempfile::tempdir().expect("temporary directory");
    let filler: String = (0..16_384)
        .map(|i| {
            format!("\tlibfiller{i:05}.so.1 (libc6,x86-64) => /nonexistent/libfiller{i:05}.so.1\n")
        })
        .collect();
    assert!(filler.len() > 1 << 20, "filler of {} bytes", filler.len());
    std::fs::write(dir.path().join("cache.txt"), format!("{vulkan}\n{filler}")).unwrap();
    let fake = dir.path().join("ldconfig");
    std::fs::write(
        &fake,
        format!(
            "#!/bin/sh\ncat '{}'\n",
            dir.path().join("cache.txt").display()
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();

    let o = run_with_path(&format!("{}:/usr/bin:/bin", dir.path().display()));
    assert_found_without_installing(&o, "with an ldconfig cache of over 1 MiB");
}
