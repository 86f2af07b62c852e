//! The Python package (`python/`, issue 13): `pip install ./python` into a venv under the target
//! directory, then its pytest suite (`python/tests`), which compares every function with the
//! command line's output for the same input: `djkr.run`'s arrays with `run.h5` bit for bit,
//! `cycle`, `pulloff` and `validate` with `--json`, `resonance` and `sweep` with their CSV
//! tables, `set=` with `--set`, errors with the command's message, Ctrl-C, the example, the
//! docstrings against the type stub, and the example notebook (executed with nbclient, its key
//! numbers against the command line's).
//!
//! The venv (pytest, numpy, h5py, pandas, matplotlib, maturin from the package index) is made
//! once. The package is rebuilt only when the sources it is built from changed since the last
//! install (a hash of `src/`, `python/` and the manifests, kept next to the venv): the first
//! run builds the extension in release (about 1–3 min on 2 cores, reusing this build's
//! dependencies), later runs only run pytest. The venv's packages come from the package index
//! only with `DJKR_TEST_INSTALL=1` (`.ci/run` sets it; then a venv that cannot be made fails the
//! test); without it the test uses a venv an earlier such run left, or the system `python3` when it
//! has every package, and otherwise skips with one line (module `tools`).

mod tools;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const PACKAGES: [&str; 6] = [
    "maturin>=1.5,<2",
    "numpy",
    "pytest",
    "h5py",
    "pandas",
    "matplotlib",
];
const IMPORTS: [&str; 6] = ["maturin", "numpy", "pytest", "h5py", "pandas", "matplotlib"];
/// What `python/tests/test_notebook.py` executes the example notebook with: installed into the
/// venv only with `DJKR_TEST_INSTALL=1`; without them that one test skips.
const NOTEBOOK_PACKAGES: [&str; 3] = ["nbclient", "nbformat", "ipykernel"];

/// Files whose change means the installed package is stale.
fn sources(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                if p.file_name()
                    .is_some_and(|n| n == "tests" || n == "__pycache__")
                {
                    continue;
                }
                walk(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let mut files = vec![
        root.join("Cargo.toml"),
        root.join("Cargo.lock"),
        root.join("python/Cargo.toml"),
        root.join("python/pyproject.toml"),
    ];
    walk(&root.join("src"), &mut files);
    walk(&root.join("python/src"), &mut files);
    walk(&root.join("python/djkr"), &mut files);
    files.sort();
    files
}

/// FNV-1a over the files' paths and contents.
fn stamp(root: &Path) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for f in sources(root) {
        eat(f
            .strip_prefix(root)
            .unwrap_or(&f)
            .to_string_lossy()
            .as_bytes());
        eat(&std::fs::read(&f).unwrap_or_default());
    }
    format!("{h:016x}\n")
}

/// A command without the variables cargo sets for this test binary (they describe the `djkr`
/// package, not the nested build of the extension).
fn clean(mut c: Command) -> Command {
    for (k, _) in std::env::vars_os() {
        let k = k.to_string_lossy();
        let per_crate = [
            "CARGO_PKG_",
            "CARGO_MANIFEST_",
            "CARGO_CRATE_",
            "CARGO_BIN_",
            "CARGO_TARGET_TMPDIR",
            "CARGO_PRIMARY_PACKAGE",
            "CARGO_RUSTC_CURRENT_DIR",
        ];
        if per_crate.iter().any(|p| k.starts_with(p)) {
            c.env_remove(k.as_ref());
        }
    }
    c
}

#[test]
fn python_package_passes_its_pytest_suite() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let py = match tools::venv("python-venv", &PACKAGES, &IMPORTS) {
        Ok(py) => py,
        Err(why) => {
            tools::skip_or_fail("the Python package's pytest suite (tests/python.rs)", &why);
            return;
        }
    };
    let bin = py.parent().expect("venv bin directory").to_path_buf();
    if tools::may_install() && !tools::runs(&py, "import nbclient, nbformat, ipykernel") {
        let ok = Command::new(&py)
            .args(["-m", "pip", "install", "--quiet"])
            .args(NOTEBOOK_PACKAGES)
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "pip install {} failed", NOTEBOOK_PACKAGES.join(" "));
    }
    let stamp_file = bin.join("../djkr-sources.stamp");
    let want = stamp(root);
    let fresh = std::fs::read_to_string(&stamp_file).is_ok_and(|s| s == want)
        && tools::runs(&py, "import djkr");
    if !fresh {
        let _ = std::fs::remove_file(&stamp_file);
        let t0 = Instant::now();
        // maturin (in the venv, on PATH) builds in this workspace's target directory; no build
        // isolation, so nothing is downloaded per build.
        let path = std::env::join_paths(std::iter::once(bin.clone()).chain(std::env::split_paths(
            &std::env::var_os("PATH").unwrap_or_default(),
        )))
        .expect("PATH");
        let mut pip = clean(Command::new(&py));
        pip.args(["-m", "pip", "install", "--quiet", "--no-build-isolation"])
            .args(["--no-deps", "--force-reinstall"])
            .arg(root.join("python"))
            .env("PATH", path);
        let status = pip.status().expect("pip runs");
        assert!(status.success(), "pip install ./python failed: {status}");
        std::fs::write(&stamp_file, &want).expect("stamp written");
        eprintln!(
            "built and installed the djkr Python package in {:.1} s",
            t0.elapsed().as_secs_f64()
        );
    }
    let t0 = Instant::now();
    let out = clean(Command::new(&py))
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
