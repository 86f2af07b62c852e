//! Strong vibration: the base phase, the regression points of the strong-vibration issue, and
//! (opt-in) a scan over base amplitudes.

use djkr::dynamics::{catalogue, EventKind, Recorder};
use djkr::scenario::{Stage, StageKind, Until};
use std::f64::consts::PI;

fn hold(duration: f64, vibration: bool) -> Stage {
    catalogue::stage(
        StageKind::Hold,
        0.0,
        Until::Duration(duration),
        Some(vibration),
    )
}

/// A base phase φ starts the shaker φ/ω after its stage begins, at phase 0 of its own motion:
/// the run equals one whose shaker-off stage is φ/ω longer (and the vibrating one φ/ω shorter),
/// and x_b is continuous (0 at the start of the motion).
#[test]
fn base_phase_delays_the_shaker_start() {
    let f = 400.0;
    let phi = 2.0;
    let delay = phi / (2.0 * PI * f);
    let mut a = catalogue::vibrating_hold(5e-6, f, 0.0);
    a.stages = vec![hold(0.01, false), hold(0.05, true)];
    if let Some(b) = a.rig.base.as_mut() {
        b.phase = phi;
    }
    let mut b = catalogue::vibrating_hold(5e-6, f, 0.0);
    b.stages = vec![hold(0.01 + delay, false), hold(0.05 - delay, true)];
    let (mut ra, mut rb) = (Recorder::default(), Recorder::default());
    let sa = a.simulate(&mut ra).unwrap();
    let sb = b.simulate(&mut rb).unwrap();
    let (ca, cb) = (&sa.cycles, &sb.cycles);
    assert_eq!(ca.len(), cb.len());
    assert!(
        (ca[0].t_start - (0.01 + delay)).abs() < 1e-12,
        "{}",
        ca[0].t_start
    );
    for (x, y) in ca.iter().zip(cb) {
        assert!((x.t_start - y.t_start).abs() < 1e-12);
        let scale = x.force_sin.hypot(x.force_cos).max(x.force_mean.abs());
        assert!(
            (x.force_mean - y.force_mean).abs() < 1e-7 * scale,
            "{} vs {}",
            x.force_mean,
            y.force_mean
        );
    }
    let (fa, fb) = (sa.final_state, sb.final_state);
    assert!((fa.a / fb.a - 1.0).abs() < 1e-8, "{} vs {}", fa.a, fb.a);
    // x_b is 0 up to the start of the motion, then X_b sin(ω (t − t_on)).
    let t_on = ca[0].t_start;
    for s in &ra.samples {
        if s.t <= t_on {
            assert!(s.x_b.abs() < 1e-18, "{s:?}");
        } else {
            let want = 5e-6 * (2.0 * PI * f * (s.t - t_on)).sin();
            assert!((s.x_b - want).abs() < 1e-15, "{s:?}");
        }
    }
    assert!(sa.events.iter().all(|e| e.kind != EventKind::ContactLoss));
}
