//! Strong vibration: the base phase, the regression points of the strong-vibration issue, and
//! (opt-in) a scan over base amplitudes.

use crate::catalogue;
use djkr_core::dynamics::protocol::{Stage, StageKind, Until};
use djkr_core::dynamics::{EventKind, Recorder};
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
    let (ca, cb) = (&ra.cycles, &rb.cycles);
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

use crate::catalogue::Bundled;
use djkr::scenario::Scenario;
use djkr_core::dynamics::{CycleRecord, EnvelopeMode, RunResult};

/// A bundled paper protocol with the base amplitude `xb` (m), the unload's time limit raised
/// to 400 s, no time series, envelope following as given.
fn protocol(b: Bundled, xb: f64, envelope: EnvelopeMode) -> Scenario {
    let mut s = b.scenario().unwrap_or_else(|e| panic!("{e}"));
    if let Some(base) = s.rig.base.as_mut() {
        base.amplitude = xb;
    }
    s.stages[3].max_duration = 400.0;
    s.output.sample_rate = 0.0;
    s.solver.envelope = envelope;
    s
}

fn run_with_cycles(s: &Scenario) -> (RunResult, Vec<CycleRecord>) {
    let mut rec = Recorder::default();
    let r = s
        .simulate(&mut rec)
        .unwrap_or_else(|e| panic!("{}: {e}", s.source_name));
    (r, rec.cycles)
}

/// The strong-vibration issue's failing points (200 and 300 Hz protocols, X_b = 100 µm, rtol
/// 1e-8, `auto`): the step size underflowed at t ≈ 120 s in deep healing. They run to pull-off
/// with direct integration, and envelope following agrees with it. (The cause was a contact
/// collapse predicted while the contact peeled and kept after it began to heal.)
#[test]
fn deep_healing_points_run_to_pull_off() {
    for b in [Bundled::PaperProtocol200, Bundled::PaperProtocol300] {
        let direct = protocol(b, 100e-6, EnvelopeMode::Off);
        let r = direct
            .simulate(&mut djkr_core::dynamics::NoObserver)
            .unwrap_or_else(|e| panic!("{}: {e}", b.path()));
        assert!(r.detached, "{}", b.path());
        assert!(
            r.pull_off.amplification > 20.0 && r.pull_off.amplification < 30.0,
            "{}: {}",
            b.path(),
            r.pull_off.amplification
        );
        let env = protocol(b, 100e-6, EnvelopeMode::Auto)
            .simulate(&mut djkr_core::dynamics::NoObserver)
            .unwrap_or_else(|e| panic!("{}: {e}", b.path()));
        let rel = (env.pull_off.force / r.pull_off.force - 1.0).abs();
        assert!(rel < 1e-4, "{}: envelope vs direct {rel:e}", b.path());
    }
}

/// The gentle rig (3 g, 200 N/m, c = 0.5 N s/m on the sphere, 20 mN preload), 3 s of
/// 400 Hz / 10 µm vibration, then unloading at 100 µm/s: failed with a step-size underflow in
/// deep healing at rtol 1e-8 (ran at 1e-10); now runs to pull-off at both.
#[test]
fn gentle_rig_unload_runs_at_both_tolerances() {
    for rtol in [1e-8, 1e-10] {
        let mut s = catalogue::vibrating_hold(10e-6, 400.0, 3.0);
        s.rig.damping = Some(djkr_core::rig::Damping {
            c: 0.5,
            on: djkr_core::rig::DampingOn::Sphere,
        });
        s.stages.push(catalogue::stage(
            StageKind::Unload,
            100e-6,
            Until::PullOff,
            None,
        ));
        s.solver.rtol = rtol;
        s.solver.envelope = EnvelopeMode::Off;
        let r = s
            .simulate(&mut djkr_core::dynamics::NoObserver)
            .unwrap_or_else(|e| panic!("rtol {rtol:e}: {e}"));
        assert!(r.detached, "rtol {rtol:e}");
        assert!(
            r.pull_off.amplification > 1.0,
            "{}",
            r.pull_off.amplification
        );
    }
}

/// Envelope following against direct integration: the pull-off force within 1e-4 and the cycle
/// means of every period both integrate, up to the pull-off, within 1e-5 (of the force scale
/// 3/2 πRw0 for ⟨F⟩, of the indentation's mean or amplitude for ⟨δ⟩, of the radius for ⟨a⟩).
/// On the bundled protocols as shipped (X_b = 10 µm, where the contact radius creeps with a
/// multiplier within 0.3 % of 1, so the error share leaves moderate skips: at least 30 % of the
/// periods skipped, measured 42–59 %) and on two of them in the strong regime, where envelope
/// following must skip most periods; never more evaluations than direct integration.
#[test]
fn envelope_following_matches_direct_integration() {
    for (b, xb, min_skipped) in [
        (Bundled::PaperProtocol200, None, 0.3),
        (Bundled::PaperProtocol300, None, 0.3),
        (Bundled::PaperProtocol400, None, 0.3),
        (Bundled::PaperProtocol200, Some(60e-6), 0.8),
        (Bundled::PaperProtocol400, Some(80e-6), 0.8),
    ] {
        let xb = xb.unwrap_or_else(|| b.scenario().unwrap().rig.base.unwrap().amplitude);
        let name = format!("{} at X_b = {xb:e} m", b.path());
        let (rd, cd) = run_with_cycles(&protocol(b, xb, EnvelopeMode::Off));
        let (re, ce) = run_with_cycles(&protocol(b, xb, EnvelopeMode::Auto));
        assert!(rd.detached && re.detached, "{name}");
        let skipped = 1.0 - ce.len() as f64 / cd.len() as f64;
        assert!(skipped >= min_skipped, "{name}: skipped {skipped}");
        // Its trial periods must not cost more than the periods they skip (measured 0.60–0.79
        // at 10 µm, 0.05–0.11 in the strong regime; 1.02–1.03 at 10 µm while the corrector read
        // P(z) − z as the derivative at the new point, 1.19–1.25 when every run of attempts was
        // retried after 16 periods whether it had paid or not).
        let cost = re.stats.rhs_evals as f64 / rd.stats.rhs_evals as f64;
        println!("{name}: envelope/direct evaluations {cost:.4}, skipped {skipped:.4}");
        assert!(cost <= 1.0, "{name}: envelope/direct evaluations {cost}");
        let rel = (re.pull_off.force / rd.pull_off.force - 1.0).abs();
        assert!(rel < 1e-4, "{name}: pull-off {rel:e}");
        let f0 = 1.5 * PI * 0.051 * 0.240;
        let mut compared = 0;
        // Up to the pull-off (the most tensile cycle mean): past it the contact runs away to
        // detachment within a few periods, and every method's cycles there differ by more.
        for e in ce.iter().filter(|c| c.t_end <= rd.pull_off.time + 1e-9) {
            let Some(d) = cd.iter().find(|d| d.index == e.index && d.stage == e.stage) else {
                continue;
            };
            let da = d.delta_sin.hypot(d.delta_cos).max(d.delta_mean.abs());
            for (what, x, y, scale) in [
                ("F", e.force_mean, d.force_mean, f0),
                ("delta", e.delta_mean, d.delta_mean, da),
                ("a", e.a_mean, d.a_mean, d.a_mean),
            ] {
                assert!(
                    (x - y).abs() <= 1e-5 * scale,
                    "{name}, period {} (stage {}): <{what}> {x} vs {y}",
                    e.index,
                    e.stage
                );
            }
            compared += 1;
        }
        assert!(compared > 100, "{name}: {compared} periods compared");
    }
}

/// Opt-in (`cargo test --release --test it strong_vibration:: -- --ignored --nocapture`): the
/// paper protocols at 200, 300 and 400 Hz over base amplitudes up to 400 µm run to pull-off
/// under `auto`, with and without envelope following, and agree.
#[test]
#[ignore]
fn scan_of_base_amplitudes() {
    for b in [
        Bundled::PaperProtocol200,
        Bundled::PaperProtocol300,
        Bundled::PaperProtocol400,
    ] {
        for xb_um in [
            10.0, 20.0, 40.0, 60.0, 80.0, 100.0, 150.0, 200.0, 250.0, 300.0, 400.0,
        ] {
            let xb = xb_um * 1e-6;
            let t = std::time::Instant::now();
            let env = protocol(b, xb, EnvelopeMode::Auto)
                .simulate(&mut djkr_core::dynamics::NoObserver)
                .unwrap_or_else(|e| panic!("{} X_b {xb_um} um, envelope: {e}", b.path()));
            let t_env = t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let direct = protocol(b, xb, EnvelopeMode::Off)
                .simulate(&mut djkr_core::dynamics::NoObserver)
                .unwrap_or_else(|e| panic!("{} X_b {xb_um} um, direct: {e}", b.path()));
            let t_dir = t.elapsed().as_secs_f64();
            let rel = (env.pull_off.force / direct.pull_off.force - 1.0).abs();
            println!(
                "{} X_b {xb_um:5.0} um: A {:.5} (direct {:.5}, rel {rel:.1e}), detached {}, {t_env:.3} s vs {t_dir:.3} s",
                b.path(),
                env.pull_off.amplification,
                direct.pull_off.amplification,
                direct.detached
            );
            assert!(direct.detached && env.detached);
            // Envelope following at the default envelope_tol (1e-6) moves the pull-off force
            // by at most 1.8e-6 relative over this scan (measured 2026-11-27); 1e-5 leaves room
            // for the platform's rounding, not for a drifting envelope.
            assert!(
                rel < 1e-5,
                "{} X_b {xb_um} um: pull-off force with envelope following {} N, direct {} N \
                 (rel {rel:.1e})",
                b.path(),
                env.pull_off.force,
                direct.pull_off.force
            );
        }
    }
}

/// Twins 1e-12 apart tell the two regimes apart (`djkr run --sensitivity`): on the heavy rig
/// of the paper protocol the pull-off is deterministic (twins agree to integration accuracy,
/// below `sensitivity::SENSITIVE_SPREAD`), on the gentle rig it is chaotic (the period-1 orbit
/// is lost well before detachment: percent, `docs/studies/sensitivity.md`).
#[test]
fn twins_tell_a_deterministic_from_a_chaotic_pull_off() {
    use djkr::sensitivity;
    for (b, chaotic) in [
        (Bundled::PaperProtocol300, false),
        (Bundled::GentleUnload300, true),
    ] {
        let s = b.scenario().unwrap();
        let r = s.simulate(&mut djkr_core::dynamics::NoObserver).unwrap();
        let x = sensitivity::twins(&s, &r, 3, sensitivity::EPSILON)
            .expect("both have a base")
            .unwrap_or_else(|e| panic!("{}: {e}", b.path()));
        assert_eq!(x.runs.len(), 4);
        assert_eq!(
            x.sensitive,
            chaotic,
            "{}: spread {:e}",
            b.path(),
            x.force_spread
        );
        if chaotic {
            assert!(x.force_spread > 1e-3, "{}", x.force_spread);
            assert!(x.digits <= 3);
        } else {
            assert!(x.force_spread < 1e-7, "{}", x.force_spread);
            assert!(x.time_spread < 1e-6, "{}", x.time_spread);
        }
    }
}

/// A hold under a steady shaker settles onto its periodic orbit (the sphere rings down and the
/// contact radius ratchets for ~100 periods), after which every boundary of the stage is the
/// orbit's fixed point: envelope following finds it by shooting and jumps to the stage's end.
/// On the light rig with c = 0.5 N s/m on the sphere (the compiled peer's benchmark scene,
/// 1 s at 400 Hz / 10 µm, and 3 s at 300 Hz / 20 µm, the vibration of
/// `scenarios/gentle-unload-300hz.toml`): one such jump over most of the stage, and the final
/// state within the envelope's tolerance (1e-6 of X_b, ω X_b and a) of direct integration of
/// every period.
#[test]
fn a_hold_at_its_periodic_steady_state_jumps_to_its_end() {
    for (xb, f, duration) in [(10e-6, 400.0, 1.0), (20e-6, 300.0, 3.0)] {
        let run = |envelope| {
            let mut s = catalogue::vibrating_hold(xb, f, duration);
            s.rig.damping = Some(djkr_core::rig::Damping {
                c: 0.5,
                on: djkr_core::rig::DampingOn::Sphere,
            });
            s.output.sample_rate = 0.0;
            s.solver.envelope = envelope;
            s.simulate(&mut djkr_core::dynamics::NoObserver)
                .unwrap_or_else(|e| panic!("{f} Hz: {e}"))
        };
        let (direct, env) = (run(EnvelopeMode::Off), run(EnvelopeMode::Auto));
        let periods = (duration * f).round() as u64;
        assert_eq!(env.envelope.steady_jumps, 1, "{f} Hz: {:?}", env.envelope);
        assert!(
            env.envelope.periods_skipped > periods / 2,
            "{f} Hz: {:?}",
            env.envelope
        );
        let (d, e) = (direct.final_state, env.final_state);
        assert!((d.t - duration).abs() < 1e-12 && (e.t - duration).abs() < 1e-12);
        let w = 2.0 * PI * f;
        for (what, x, y, scale) in [
            ("x_s", e.x_s, d.x_s, xb),
            ("v_s", e.v_s, d.v_s, w * xb),
            ("a", e.a, d.a, d.a),
        ] {
            println!("{f} Hz {what}: {:.1e}", (x - y).abs() / scale);
            assert!((x - y).abs() <= 1e-6 * scale, "{f} Hz {what}: {x} vs {y}");
        }
    }
}

/// Step control under a steady shaker follows the last base period (core/src/dynamics/control.rs):
/// on the compiled peer's benchmark scene (1 s at 400 Hz, X_b = 10 µm, rtol 1e-7, every period
/// integrated) the elementary controller alone had 24 % of its attempts rejected (1 735 of
/// 7 388: four overshoots per period in the healing stretch after each turning point, and the
/// turning point itself), 90 491 evaluations. With the last period as a guide at most 10 % are
/// rejected, with fewer evaluations, and a(1 s) stays within 1e-7 of a converged run.
#[test]
fn a_steady_shaker_is_not_overshot_at_the_same_place_every_period() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/scenes/vib400.toml");
    let mut s = djkr::scenario::parse::load_scenario(&file).unwrap();
    s.solver.envelope = EnvelopeMode::Off;
    let mut reference = s.clone();
    s.solver.rtol = 1e-7;
    reference.solver.rtol = 1e-11;
    let r = s.simulate(&mut djkr_core::dynamics::NoObserver).unwrap();
    let refr = reference
        .simulate(&mut djkr_core::dynamics::NoObserver)
        .unwrap();
    let attempts = r.stats.steps + r.stats.rejected;
    let share = r.stats.rejected as f64 / attempts as f64;
    assert!(
        share <= 0.10,
        "{} of {attempts} attempts rejected",
        r.stats.rejected
    );
    assert!(
        r.stats.rhs_evals < 90_491,
        "{} evaluations",
        r.stats.rhs_evals
    );
    let rel = (r.final_state.a - refr.final_state.a).abs() / refr.final_state.a;
    assert!(rel < 1e-7, "a(1 s) {rel:e} from the rtol 1e-11 run");
}
