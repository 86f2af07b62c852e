//! Memory independent of run length: `djkr run` of a scene ten times longer (ten times the
//! samples, streamed to disk) peaks at no more than 1.5× the memory of the short one. Both runs
//! are past the writer's in-memory threshold (`output::SPILL_ROWS` samples), so the short one
//! already holds its largest buffer: what is compared is whether anything else grows with the
//! run. Peak RSS is the kernel's own accounting of each child (`wait4`'s `ru_maxrss`).

#![cfg(target_os = "linux")]

use std::path::Path;
use std::process::Command;

use djkr::output::SPILL_ROWS;

/// The heavy rig of the paper protocol: a quiet hold of `t` s then a vibrating hold of `t` s
/// (300 Hz, 10 µm, envelope following on), sampled at 12 kHz.
fn scene(t: f64) -> String {
    format!(
        r#"version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 0.240
[adhesion]
law = "gent-schultz"
v0 = 4.45e-5
n = 0.531
[sphere]
mass = 0.25
[spring]
stiffness = 2000.0
[damping]
c = 10.0
[base]
amplitude = 10e-6
frequency = 300.0
[initial]
preload = 0.05
[[stage]]
kind = "hold"
duration = {t}
vibration = false
[[stage]]
kind = "hold"
duration = {t}
vibration = true
[output]
sample_rate = 12000
"#
    )
}

/// Run `djkr run FILE --out DIR`; its peak resident memory (bytes) and the samples it wrote.
// The child is reaped by `wait4` below (which also gives its peak memory), not by `wait()`.
#[allow(clippy::zombie_processes)]
fn peak_rss(file: &Path, out: &Path) -> (u64, u64) {
    // Reaped by `wait4` below, which also gives its resource usage.
    #[allow(clippy::zombie_processes)]
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(["run", "--json", "--out"])
        .arg(out)
        .arg(file)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: plain libc call on our own child, with valid pointers to locals.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4 failed");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "djkr run failed: status {status}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    // ru_maxrss is in kilobytes on Linux.
    (
        usage.ru_maxrss as u64 * 1024,
        summary["samples"].as_u64().unwrap(),
    )
}

#[test]
fn a_ten_times_longer_run_takes_at_most_one_and_a_half_times_the_memory() {
    let dir = tempfile::tempdir().unwrap();
    let mut results = Vec::new();
    for (name, t) in [("short", 12.0), ("long", 120.0)] {
        let file = dir.path().join(format!("{name}.toml"));
        std::fs::write(&file, scene(t)).unwrap();
        let out = dir.path().join(name);
        results.push(peak_rss(&file, &out));
        // Free the disk for the next run (these files are this test's own).
        std::fs::remove_dir_all(&out).unwrap();
    }
    let [(short_rss, short_n), (long_rss, long_n)] = [results[0], results[1]];
    assert!(short_n > SPILL_ROWS as u64, "short run: {short_n} samples");
    // Ten times the simulated time; envelope following skips relatively more periods of the
    // long vibrating hold, so about eight times the samples.
    assert!(long_n > 7 * short_n, "{long_n} vs {short_n} samples");
    let ratio = long_rss as f64 / short_rss as f64;
    eprintln!(
        "peak RSS: {:.1} MB for {short_n} samples, {:.1} MB for {long_n} (ratio {ratio:.2})",
        short_rss as f64 / 1e6,
        long_rss as f64 / 1e6
    );
    assert!(ratio <= 1.5, "peak RSS ratio {ratio:.2}");
    // And bounded in absolute terms: the issue's budget for the full-length protocol.
    assert!(long_rss < 64 << 20, "{long_rss} bytes");
}
