//! The Python package (`python/`, issue 13): `pip install ./python` into a venv under the target
//! directory, then its pytest suite (`python/tests`), which compares every function with the
//! command line's output for the same input: `djkr.run`'s arrays with `run.h5` bit for bit,
//! `cycle`, `pulloff` and `validate` with `--json`, `resonance` and `sweep` with their CSV
//! tables, `set=` with `--set`, errors with the command's message, Ctrl-C, the example, the
//! docstrings against the type stub, and the example notebooks (executed with nbclient, their
//! key numbers against the command line's).
//!
//! The venv (pytest, numpy, h5py, pandas, matplotlib, maturin from the package index) is made
//! once. The package is rebuilt only when the sources it is built from changed since the last
//! install (a hash of `src/`, `python/` and the manifests, kept next to the venv): the first
//! run builds the extension in release (about 1–3 min on 2 cores, reusing this build's
//! dependencies), later runs only run pytest. The venv's packages come from the package index
//! only with `DJKR_TEST_INSTALL=1` (`.ci/run` sets it; then a venv that cannot be made fails the
//! test); without it the test uses a venv an earlier such run left, or the system `python3` when it
//! has every package, and otherwise skips with one line (module `tools`).

use crate::tools;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

#[test]
fn python_package_passes_its_pytest_suite() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let py = match tools::djkr_python() {
        Ok(py) => py,
        Err(why) => {
            tools::skip_or_fail(
                "the Python package's pytest suite (tests/cli/python.rs)",
                &why,
            );
            return;
        }
    };
    let t0 = Instant::now();
    let out = tools::clean(Command::new(&py))
        .args([
            "-m",
            "pytest",
            "-q",
            // One line per skipped test, with its reason (the notebook's without nbclient).
            "-rs",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .current_dir(root)
        .env("DJKR_BIN", env!("CARGO_BIN_EXE_djkr"))
        .output()
        .expect("pytest runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!(
        "pytest python/tests ({:.1} s):\n{text}",
        t0.elapsed().as_secs_f64()
    );
    assert!(out.status.success(), "pytest failed:\n{text}");
}
