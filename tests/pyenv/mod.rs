//! Python environments for the tests that check djkr from Python (h5py reading the HDF5 files,
//! the `python/` package's pytest suite): a venv under the target directory, created once with
//! the packages the test needs from the package index, so `cargo test` needs no manual install.

use std::path::{Path, PathBuf};
use std::process::Command;

/// True under CI (`CI` set and not `false`): there, a Python that cannot be provided fails the
/// test instead of skipping the check.
pub fn in_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty() && v != "false")
}

/// True when `python` runs `-c code` successfully.
pub fn runs(python: &Path, code: &str) -> bool {
    Command::new(python)
        .args(["-c", code])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The interpreter of the venv `target/tmp/<name>` (`CARGO_TARGET_TMPDIR`), created and given
/// `packages` by pip when it cannot yet `import` each of `imports`. `None` when that fails.
pub fn venv(name: &str, packages: &[&str], imports: &[&str]) -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let py = dir.join("bin/python3");
    let check = format!("import {}", imports.join(", "));
    if runs(&py, &check) {
        return Some(py);
    }
    eprintln!(
        "{}: installing {} into {} (once)",
        imports.join(", "),
        packages.join(" "),
        dir.display()
    );
    let make = || {
        Command::new("python3")
            .args(["-m", "venv"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success())
    };
    // Debian ships `venv` (ensurepip) in a package of its own: install it (and python3 itself)
    // when the first attempt fails and we may (root with apt-get, as in CI), then try again on a
    // clean directory (the failed attempt leaves a venv without pip behind).
    let made = make() || {
        let _ = std::fs::remove_dir_all(&dir);
        apt_install(&["python3", "python3-venv"]) && make()
    };
    let ok = made
        && Command::new(&py)
            .args(["-m", "pip", "install", "--quiet"])
            .args(packages)
            .status()
            .is_ok_and(|s| s.success());
    (ok && runs(&py, &check)).then_some(py)
}

/// `apt-get install -y PACKAGES` when running as root on a machine with apt-get; true when it
/// succeeded.
fn apt_install(packages: &[&str]) -> bool {
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root || !Path::new("/usr/bin/apt-get").exists() {
        return false;
    }
    eprintln!("installing {} with apt-get", packages.join(" "));
    let _ = Command::new("apt-get")
        .args(["update", "-qq"])
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status();
    Command::new("apt-get")
        .args(["install", "-y", "-qq"])
        .args(packages)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()
        .is_ok_and(|s| s.success())
}
