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
    let ok = Command::new("python3")
        .args(["-m", "venv"])
        .arg(&dir)
        .status()
        .is_ok_and(|s| s.success())
        && Command::new(&py)
            .args(["-m", "pip", "install", "--quiet"])
            .args(packages)
            .status()
            .is_ok_and(|s| s.success());
    (ok && runs(&py, &check)).then_some(py)
}
