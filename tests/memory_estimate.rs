//! The up-front memory estimate of a run kept in memory (`djkr::memory`, issue 24 defect 1):
//! its bytes per sample are measured here, and a run whose known samples exceed
//! `solver.max_memory` is refused at once as bad input naming the keys that drive it.
//!
//! The measurement counts every byte the heap holds: this test binary's global allocator adds
//! each allocation's size to a counter and takes it away on free, and keeps the counter's peak.
//! A reallocation is counted as a new block allocated before the old one is freed (the copy a
//! `realloc` that cannot grow in place makes), so the peak is the most the run can hold at any
//! instant, never less.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use djkr::api;
use djkr::error::Error as ApiError;
use djkr::memory::{Estimate, SAMPLE_BYTES};
use djkr::scenario::parse::ScenarioSource;

/// The system allocator with a count of the bytes live and their peak.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
/// Taken by every test of this binary: the allocator's count is global, so a test that runs
/// beside the measurement would add its allocations to the measured peak.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

fn grow(n: usize) {
    let now = LIVE.fetch_add(n, Ordering::SeqCst) + n;
    PEAK.fetch_max(now, Ordering::SeqCst);
}

// SAFETY: every call is forwarded to the system allocator unchanged; only counters are added.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // The new block counted while the old one is still live.
        grow(new_size);
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            LIVE.fetch_sub(new_size, Ordering::SeqCst);
        } else {
            LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// The light rig of `tests/sweep/tiny.toml` held still (no vibration, so the solver takes few
/// steps and the samples dominate) for `t` s in two stages, sampled at `rate`.
fn scene(t: f64, rate: f64) -> String {
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
mass = 3e-3
gravity = 9.81
[spring]
stiffness = 200.0
[damping]
c = 0.05
[initial]
preload = 0.02
[[stage]]
kind = "hold"
duration = {a}
[[stage]]
kind = "hold"
duration = {b}
[output]
sample_rate = {rate}
"#,
        a = t / 2.0,
        b = t / 2.0
    )
}

fn scenario(text: &str, sets: &[&str]) -> djkr::scenario::Scenario {
    ScenarioSource::parse(text, "<test>", None)
        .unwrap()
        .scenario(&djkr::scenario::overrides::Override::parse_all(sets).unwrap())
        .unwrap()
}

/// Peak heap bytes during `api::run` of the scene with `samples_wanted` samples, less what was
/// live before, and the samples taken.
fn peak_bytes(samples_wanted: usize) -> (f64, usize) {
    // 1 s at `samples_wanted - 1` samples a second: that many samples with the one at t = 0.
    let scn = scenario(&scene(1.0, (samples_wanted - 1) as f64), &[]);
    let before = LIVE.load(Ordering::SeqCst);
    PEAK.store(before, Ordering::SeqCst);
    let rec = api::run(&scn, None).unwrap();
    let peak = PEAK.load(Ordering::SeqCst);
    let samples = rec.series.rows();
    drop(rec);
    ((peak - before) as f64, samples)
}

/// Peak heap bytes per sample during `api::run`: the peak of a run of `n` samples less that of
/// the same run with 2 samples (what the run holds whatever its length: model, events, summary),
/// divided by the difference in samples.
fn bytes_per_sample(n: usize) -> (f64, usize) {
    let (fixed, few) = peak_bytes(2);
    let (peak, samples) = peak_bytes(n);
    ((peak - fixed) / (samples - few) as f64, samples)
}

/// `SAMPLE_BYTES` bounds the measured peak per sample and is not a loose guess: across a
/// doubling of the columns' capacity (2¹⁷ samples fill it exactly, 2¹⁷ + 1 doubles it) the
/// measured peak stays at or below it and comes within 5 % of it.
#[test]
fn sample_bytes_is_the_measured_peak_per_sample() {
    let _serial = serial();
    let mut worst: f64 = 0.0;
    for n in [1 << 17, (1 << 17) + 1, 150_000, 200_000, (1 << 18) + 1] {
        let (per, samples) = bytes_per_sample(n);
        // The estimate counts these samples, or one more: the last sample time, summed in
        // floating point, may fall a rounding past the end.
        let est = Estimate::of(&scenario(&scene(1.0, (n - 1) as f64), &[])).unwrap();
        assert_eq!(est.samples, n as f64);
        assert!(
            samples == n || samples + 1 == n,
            "{samples} samples, {n} estimated"
        );
        eprintln!("{n} samples: {per:.1} bytes a sample at the peak");
        assert!(
            per <= SAMPLE_BYTES,
            "{n} samples: {per:.1} bytes a sample at the peak, more than SAMPLE_BYTES = {SAMPLE_BYTES}"
        );
        worst = worst.max(per);
    }
    assert!(
        worst >= 0.95 * SAMPLE_BYTES,
        "the worst measured peak, {worst:.1} bytes a sample, is far below SAMPLE_BYTES = {SAMPLE_BYTES}"
    );
}

/// The reproducer of issue 24 (1000 s at 10⁷ samples/s, 10¹⁰ samples) is refused at once as
/// bad input naming both keys, the estimate in bytes and in words, and the way out.
#[test]
fn a_run_too_large_for_memory_is_refused_before_it_starts() {
    let _serial = serial();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/sweep/tiny.toml"
    ))
    .unwrap();
    let scn = scenario(&text, &["stage[0].duration=1e3", "output.sample_rate=1e7"]);
    let t0 = Instant::now();
    let e = api::run(&scn, None).unwrap_err();
    assert!(t0.elapsed().as_secs_f64() < 1.0, "took {:?}", t0.elapsed());
    assert!(matches!(e, ApiError::Memory(_)), "{e:?}");
    assert!(e.is_input());
    let m = e.to_string();
    for needle in [
        "stage[0].duration = 1000 s",
        "output.sample_rate = 10000000 1/s",
        "1.000e10 samples",
        "bytes",
        "TiB",
        "solver.max_memory = 2147483648 bytes (2.0 GiB)",
        "raise solver.max_memory",
        "lower output.sample_rate",
    ] {
        assert!(m.contains(needle), "{needle:?} not in: {m}");
    }
    // The stage ending at pull-off (max_duration 10 s) adds nothing.
    let est = Estimate::of(&scn).unwrap();
    assert_eq!(est.samples, 1e10 + 1.0);
    assert_eq!(est.bytes, (1e10 + 1.0) * SAMPLE_BYTES);
}

/// The budget is `solver.max_memory`: the same run fits when it is raised, and a run just
/// above a lowered budget is refused while one just below it runs.
#[test]
fn the_budget_is_solver_max_memory() {
    let _serial = serial();
    let text = scene(1.0, 9999.0); // 10 000 samples
    let need = 10_000.0 * SAMPLE_BYTES;
    let below = format!("solver.max_memory={}", (need as u64).max(1 << 20));
    assert!(api::run(&scenario(&text, &[&below]), None).is_ok());
    // 1 MiB (the least max_memory) holds 4854 samples at 216 bytes.
    let big = scene(1.0, 1e4);
    let e = api::run(&scenario(&big, &["solver.max_memory=1048576"]), None).unwrap_err();
    assert!(e.is_input(), "{e}");
    assert!(e.to_string().contains("1.0 MiB"), "{e}");
    assert!(
        e.to_string()
            .contains("stage[0].duration = 0.5 s + stage[1].duration = 0.5 s"),
        "{e}"
    );
    // A rate of 0 (every step) is not estimated up front.
    let every_step = scenario(&big, &["output.sample_rate=0"]);
    assert!(Estimate::of(&every_step).is_none());
}
