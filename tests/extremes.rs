//! Numerical stability at the extremes (issue 5): every case finishes with physically valid output
//! (finite numbers, a ≥ 0, F equal to the JKR force of the reported a and δ) or a clear error
//! (`SimError` / `ParamError` with a message); none panics or hangs. The harness and the cases
//! live in `tests/extremes/matrix.rs`.
//!
//! - `reduced_matrix` (default suite): method `auto` on every time-domain scene plus a few
//!   explicit-method runs, and the imposed-area cases, with short durations.
//! - The full matrix, every scene with every method (auto, implicit, dp8, dopri5, dop853) for
//!   longer and a denser imposed-area grid, is a study that asserts the same and writes
//!   `docs/extremes.md`: `cargo run --release --example study_extremes`.

#[path = "extremes/matrix.rs"]
mod matrix;

use djkr_core::adhesion::{AdhesionLaw, GentSchultz};
use djkr_core::dynamics::Sample;
use djkr_core::imposed_area;
use matrix::{constant, gs, sample_problem, M};
use std::f64::consts::PI;

#[test]
fn reduced_matrix() {
    let r = matrix::run_matrix(false);
    println!("{}\n{}", r.summary, r.table);
    assert!(
        r.failures.is_empty(),
        "failures:\n{}",
        r.failures.join("\n")
    );
}

/// A rate-independent law has no frequency: the imposed-area pull-off at 1 Hz and 10 kHz must be
/// the same (an independent check of the extreme-frequency cases).
#[test]
fn constant_law_pull_off_is_frequency_independent() {
    let p1 = imposed_area::pull_off(&M, &constant(), 2.0 * PI, 0.5e-3).unwrap();
    let p2 = imposed_area::pull_off(&M, &constant(), 2.0 * PI * 1e4, 0.5e-3).unwrap();
    assert!(
        (p1.force / p2.force - 1.0).abs() < 1e-12,
        "{} vs {}",
        p1.force,
        p2.force
    );
}

/// The checker itself catches what it must: NaN, a < 0, a force inconsistent with (a, δ).
#[test]
fn checker_catches_invalid_samples() {
    let a = 1e-3;
    let delta = 5e-6;
    let good = Sample {
        t: 0.0,
        x_s: delta,
        v_s: 0.0,
        x_b: 0.0,
        x_k: 0.0,
        delta,
        a,
        a_dot: 0.0,
        force: 0.5 * M.k * a * (3.0 * delta - a * a / M.r),
        g: M.w0,
        w: M.w0,
        stage: 0,
    };
    assert!(sample_problem(&good).is_none());
    assert!(sample_problem(&Sample { a: -1e-9, ..good }).is_some());
    assert!(sample_problem(&Sample {
        v_s: f64::NAN,
        ..good
    })
    .is_some());
    assert!(sample_problem(&Sample {
        force: good.force * 1.001,
        ..good
    })
    .is_some());
    // The law the GS cases use is the law with the given n (sanity of the builder).
    assert!((gs(1.5).work_of_adhesion(-GentSchultz::PAPER.v0) / M.w0 - 2.0).abs() < 1e-12);
}
