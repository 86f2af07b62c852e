//! Restarting from an explicit state (`Initial::State`, what shooting and frequency sweeps use)
//! continues the same trajectory: a run split at a base-period boundary and resumed from its end
//! state matches one unbroken run.

use crate::catalogue;
use djkr_core::dynamics::protocol::{Initial, Until};
use djkr_core::dynamics::Recorder;

#[test]
fn split_run_matches_unbroken_run() {
    let freq = 300.0;
    let period = 1.0 / freq;
    // 40 + 40 periods vs 80 periods, 5 µm base amplitude, GS law, contact never lost.
    let whole = catalogue::vibrating_hold(5e-6, freq, 80.0 * period);
    let mut rec_whole = Recorder::default();
    let r_whole = whole.simulate(&mut rec_whole).unwrap();

    let first = catalogue::vibrating_hold(5e-6, freq, 40.0 * period);
    let mut rec1 = Recorder::default();
    let r1 = first.simulate(&mut rec1).unwrap();
    let f = r1.final_state;
    assert!(f.a > 0.0);
    let mut second = catalogue::vibrating_hold(5e-6, freq, 40.0 * period);
    second.initial = Initial::State {
        x_s: f.x_s,
        v_s: f.v_s,
        a: f.a,
        a_dot: f.a_dot,
        x_k: f.x_k,
    };
    second.stages[0].until = Until::Duration(40.0 * period);
    let mut rec2 = Recorder::default();
    let r2 = second.simulate(&mut rec2).unwrap();

    // Cycle records 40..80 of the unbroken run against 0..40 of the resumed one.
    assert_eq!(rec_whole.cycles.len(), 80);
    assert_eq!(rec2.cycles.len(), 40);
    let fscale = rec_whole
        .cycles
        .iter()
        .map(|c| c.force_sin.hypot(c.force_cos))
        .fold(0.0, f64::max);
    let dscale = rec_whole
        .cycles
        .iter()
        .map(|c| c.delta_sin.hypot(c.delta_cos))
        .fold(0.0, f64::max);
    // The resumed run chooses its own steps, so the two differ by the integration error: measured
    // (`docs/studies/checks.md`) 1.0e-9 of the largest |F1| in ⟨F⟩ and 9.2e-11 in ⟨a⟩.
    for (cw, c2) in rec_whole.cycles[40..].iter().zip(&rec2.cycles) {
        assert!(
            (cw.force_mean - c2.force_mean).abs() < 1e-8 * fscale,
            "{cw:?}\n{c2:?}"
        );
        assert!((cw.delta_sin - c2.delta_sin).abs() < 1e-6 * dscale);
        assert!((cw.delta_cos - c2.delta_cos).abs() < 1e-6 * dscale);
        assert!((cw.a_mean - c2.a_mean).abs() < 1e-9 * cw.a_mean);
    }
    let (a, b) = (r_whole.final_state, r2.final_state);
    assert!((a.a - b.a).abs() < 1e-6 * a.a, "{a:?}\n{b:?}");
    assert!((a.x_s - b.x_s).abs() < 1e-6 * dscale.max(1e-9));
    assert!((r2.final_state.t - 40.0 * period).abs() < 1e-12);
}

#[test]
fn invalid_explicit_state_is_an_error_not_a_panic() {
    let mut s = catalogue::vibrating_hold(5e-6, 300.0, 0.01);
    s.initial = Initial::State {
        x_s: 0.0,
        v_s: f64::NAN,
        a: 1e-3,
        a_dot: 0.0,
        x_k: 0.0,
    };
    let e = s.simulate(&mut Recorder::default()).unwrap_err();
    assert!(e.to_string().contains("initial state"), "{e}");
}
