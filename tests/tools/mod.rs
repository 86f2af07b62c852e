//! What the tests that check djkr with outside tools (h5py reading the HDF5 files, the `python/`
//! package's pytest suite, a Slurm cluster) may use, and when they may install it.
//!
//! A user's `cargo test` never changes their machine: without `DJKR_TEST_INSTALL=1` these tests
//! use what is present (a system `python3` that imports what they need, a venv an earlier opted-in
//! run left under the target directory, Slurm's commands on `PATH`) and otherwise skip, printing
//! one line that says what was skipped and how to run it. With `DJKR_TEST_INSTALL=1` (which
//! `.ci/run` exports) they install what is missing — Debian packages with apt-get as root, Python
//! packages from the package index into a venv under the target directory — and a tool that
//! still cannot be had fails the test instead of skipping it.

// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The environment variable that allows the tests to install what they need.
pub const INSTALL_VAR: &str = "DJKR_TEST_INSTALL";

/// True when the tests may install what they need (`DJKR_TEST_INSTALL=1`).
pub fn may_install() -> bool {
    std::env::var_os(INSTALL_VAR).is_some_and(|v| v == "1")
}

/// Say on the terminal, past the test harness's output capture (which would show it only for a
/// failing test), that `what` was skipped and why. One line.
pub fn skipped(what: &str, why: &str) {
    use std::os::fd::FromRawFd;
    // SAFETY: fd 2 is the process's standard error, open for the whole test run; ManuallyDrop
    // keeps it from being closed here.
    let mut stderr = std::mem::ManuallyDrop::new(unsafe { std::fs::File::from_raw_fd(2) });
    let _ = writeln!(
        stderr,
        "SKIPPED {what}: {why} (run with {INSTALL_VAR}=1 to install it; see docs/guide/unattended.md)"
    );
}

/// Skip `what` for `why`, or fail when installing was allowed (then the tool should have been
/// there: CI must not pass without the check).
pub fn skip_or_fail(what: &str, why: &str) {
    assert!(
        !may_install(),
        "{what}: {why}, although {INSTALL_VAR}=1 allowed installing it"
    );
    skipped(what, why);
}

/// True when `python` runs `-c code` successfully.
pub fn runs(python: &Path, code: &str) -> bool {
    Command::new(python)
        .args(["-c", code])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// True when `cmd` is on `PATH`.
pub fn have(cmd: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {cmd}")])
        .stdout(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// True when this process runs as root.
pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// Cargo's scratch folder for tests, `target/tmp` (`CARGO_TARGET_TMPDIR`, which Cargo sets for
/// integration tests only; the library's unit tests find it from their executable,
/// `target/PROFILE/deps/NAME`).
pub fn target_tmp() -> PathBuf {
    match option_env!("CARGO_TARGET_TMPDIR") {
        Some(d) => PathBuf::from(d),
        None => {
            let exe = std::env::current_exe().expect("the test executable's path");
            let target = exe.ancestors().nth(3).expect("target/PROFILE/deps/NAME");
            target.join("tmp")
        }
    }
}

/// The interpreter of the venv `target/tmp/<name>` (`CARGO_TARGET_TMPDIR`) that can `import`
/// each of `imports`, or why there is none.
///
/// A venv that already has them is used as it is. Otherwise, with [`may_install`], it is created
/// and given `packages` by pip from the package index. Without it, nothing is downloaded: when
/// the system `python3` already imports everything, the venv is made on top of the system's
/// packages (`--system-site-packages`, inside the target directory only); else `Err`.
pub fn venv(name: &str, packages: &[&str], imports: &[&str]) -> Result<PathBuf, String> {
    let dir = target_tmp().join(name);
    let py = dir.join("bin/python3");
    let check = format!("import {}", imports.join(", "));
    if runs(&py, &check) {
        return Ok(py);
    }
    let make = |system_site: bool| {
        let mut c = Command::new("python3");
        c.args(["-m", "venv"]);
        if system_site {
            c.arg("--system-site-packages");
        }
        c.arg(&dir).status().is_ok_and(|s| s.success())
    };
    if !may_install() {
        if !runs(Path::new("python3"), &check) {
            return Err(format!(
                "needs a Python that imports {} (the system python3 does not, and there is no \
                 venv under target/ yet)",
                imports.join(", ")
            ));
        }
        let _ = std::fs::remove_dir_all(&dir);
        return if make(true) && runs(&py, &check) {
            Ok(py)
        } else {
            Err("python3 -m venv failed (Debian: the python3-venv package)".into())
        };
    }
    let _ = writeln!(
        std::io::stderr(),
        "{}: installing {} into {} (once)",
        imports.join(", "),
        packages.join(" "),
        dir.display()
    );
    // Debian ships `venv` (ensurepip) in a package of its own: install it (and python3 itself)
    // when the first attempt fails and we may (root with apt-get, as in CI), then try again on a
    // clean directory (the failed attempt leaves a venv without pip behind).
    // A venv made by an earlier run that lacks a package added since is completed, not remade.
    let existing = runs(&py, "import sys");
    if !existing {
        let _ = std::fs::remove_dir_all(&dir);
    }
    let made = existing || make(false) || {
        let _ = std::fs::remove_dir_all(&dir);
        apt_install(&["python3", "python3-venv"]).is_ok() && make(false)
    };
    if !made {
        return Err("python3 -m venv failed, also after installing python3-venv".into());
    }
    let ok = Command::new(&py)
        .args(["-m", "pip", "install", "--quiet"])
        .args(packages)
        .status()
        .is_ok_and(|s| s.success());
    if ok && runs(&py, &check) {
        Ok(py)
    } else {
        Err(format!("pip install {} failed", packages.join(" ")))
    }
}

/// `apt-get install -y PACKAGES`, only with [`may_install`], as root, on a machine with apt-get.
pub fn apt_install(packages: &[&str]) -> Result<(), String> {
    if !may_install() {
        return Err(format!("{INSTALL_VAR} is not 1"));
    }
    if !is_root() || !have("apt-get") {
        return Err("installing Debian packages needs root and apt-get".into());
    }
    // Tests of one binary run in parallel threads; dpkg takes one installation at a time.
    static APT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = APT.lock().unwrap_or_else(|e| e.into_inner());
    let _ = writeln!(
        std::io::stderr(),
        "installing {} with apt-get",
        packages.join(" ")
    );
    let run = |args: &[&str]| {
        Command::new("apt-get")
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(std::process::Stdio::null())
            .status()
            .map_err(|e| format!("apt-get: {e}"))
            .and_then(|s| {
                s.success()
                    .then_some(())
                    .ok_or(format!("apt-get {} failed: {s}", args.join(" ")))
            })
    };
    run(&["update", "-qq"])?;
    run(&["install", "-y", "-qq"]
        .iter()
        .copied()
        .chain(packages.iter().copied())
        .collect::<Vec<_>>())
}

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
    walk(&root.join("core/src"), &mut files);
    files.push(root.join("core/Cargo.toml"));
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
/// `c` without the variables cargo sets for the crate under test, so that a build it starts
/// (maturin) sees the environment of a plain shell.
pub fn clean(mut c: Command) -> Command {
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

/// The interpreter of the test venv `target/tmp/python-venv` with the `python/` package built
/// from this checkout and installed (rebuilt when a source of it changed since: a stamp of the
/// sources, `core/src` included), or why there is none. Installs only under [`may_install`]
/// (see [`venv`]); the notebook's packages (nbclient …) are added then too.
pub fn djkr_python() -> Result<PathBuf, String> {
    // Tests of one binary run in parallel threads: two of them installing into the venv at once
    // (a fresh CI's first build of the package) would break each other's pip.
    static SETUP: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = SETUP.lock().unwrap_or_else(|e| e.into_inner());
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let py = venv("python-venv", &PACKAGES, &IMPORTS)?;
    let bin = py.parent().expect("venv bin directory").to_path_buf();
    if may_install() && !runs(&py, "import nbclient, nbformat, ipykernel") {
        let ok = Command::new(&py)
            .args(["-m", "pip", "install", "--quiet"])
            .args(NOTEBOOK_PACKAGES)
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return Err(format!(
                "pip install {} failed",
                NOTEBOOK_PACKAGES.join(" ")
            ));
        }
    }
    let stamp_file = bin.join("../djkr-sources.stamp");
    let want = stamp(root);
    let fresh =
        std::fs::read_to_string(&stamp_file).is_ok_and(|s| s == want) && runs(&py, "import djkr");
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
        let status = pip.status().map_err(|e| format!("pip: {e}"))?;
        if !status.success() {
            return Err(format!("pip install ./python failed: {status}"));
        }
        std::fs::write(&stamp_file, &want).map_err(|e| format!("{}: {e}", stamp_file.display()))?;
        eprintln!(
            "built and installed the djkr Python package in {:.1} s",
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(py)
}

/// Wait for `child` at most `limit`, reading its stdout (when piped) and stderr meanwhile so
/// that a full pipe cannot block it; kill it when the limit passes. Returns its exit status
/// (`None`: killed at the limit), stdout and stderr.
pub fn finish_within(
    mut child: std::process::Child,
    limit: std::time::Duration,
) -> (Option<std::process::ExitStatus>, String, String) {
    use std::io::Read;
    fn drain(pipe: Option<impl Read + Send + 'static>) -> std::thread::JoinHandle<String> {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut p) = pipe {
                p.read_to_string(&mut s).ok();
            }
            s
        })
    }
    let t_out = drain(child.stdout.take());
    let t_err = drain(child.stderr.take());
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("try_wait") {
            break Some(s);
        }
        if t0.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let stdout = t_out.join().expect("stdout reader");
    let stderr = t_err.join().expect("stderr reader");
    (status, stdout, stderr)
}

/// The descriptions table of a file djkr wrote (`/descriptions/path` and `/descriptions/text`,
/// docs/guide/output.md), read here on its own as a reader of the format would.
pub struct Descriptions(Vec<(String, String)>);

impl Descriptions {
    /// Read the table of `f`.
    pub fn of(f: &hdf5_pure::File) -> Descriptions {
        let read = |name: &str| {
            f.dataset(&format!("descriptions/{name}"))
                .and_then(|d| d.read_string())
                .unwrap_or_else(|e| panic!("/descriptions/{name}: {e}"))
        };
        let (paths, texts) = (read("path"), read("text"));
        assert_eq!(paths.len(), texts.len(), "/descriptions: paths and texts");
        Descriptions(paths.into_iter().zip(texts).collect())
    }

    /// The description of `path`, if it has one.
    pub fn get(&self, path: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(p, _)| p == path)
            .map(|(_, t)| t.as_str())
    }
}

// ---------------------------------------------------------------- generated chapters of the docs

/// The command that regenerates the generated chapters.
pub const BLESS: &str = "DJKR_BLESS=1 cargo test --release docs_reference";

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One line on the terminal, past the test harness's output capture.
pub fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

pub fn bless() -> bool {
    std::env::var_os("DJKR_BLESS").is_some_and(|v| v == "1")
}

/// Compare `generated` with the committed file `rel` (or write it under `DJKR_BLESS=1`).
pub fn check(rel: &str, generated: &str) {
    let path = root().join(rel);
    if bless() {
        std::fs::write(&path, generated).unwrap_or_else(|e| panic!("{rel}: {e}"));
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed == generated {
        return;
    }
    let (n, old, new) = committed
        .lines()
        .map(Some)
        .chain(std::iter::repeat(None))
        .zip(generated.lines().map(Some).chain(std::iter::repeat(None)))
        .enumerate()
        .find(|(_, (a, b))| a != b)
        .map(|(n, (a, b))| {
            (
                n + 1,
                a.unwrap_or("<end of file>"),
                b.unwrap_or("<end of file>"),
            )
        })
        .unwrap_or((0, "", ""));
    panic!(
        "{rel} is out of date with the code (line {n}):\n  committed: {old}\n  generated: {new}\n\
         Regenerate the generated chapters with `{BLESS}` and commit them."
    );
}

/// Replace the text between the `BEGIN GENERATED: name` and `END GENERATED` markers of `doc`.
pub fn splice(doc: &str, name: &str, generated: &str) -> String {
    let begin = format!("<!-- BEGIN GENERATED: {name} ");
    let start = doc
        .find(&begin)
        .unwrap_or_else(|| panic!("no `{begin}...-->` marker"));
    let after = start + doc[start..].find("-->").expect("marker closes") + 3;
    let end = after
        + doc[after..]
            .find("<!-- END GENERATED -->")
            .expect("END GENERATED marker");
    // Blank lines off, leading spaces kept (a region inside a list item is indented).
    format!(
        "{}\n{}\n{}",
        &doc[..after],
        generated.trim_matches('\n'),
        &doc[end..]
    )
}
