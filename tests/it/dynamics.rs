//! Time-domain simulator against independent references (closed forms, JKR limits, balance laws,
//! fixed-step orders, agreement between methods), on the scenes of `crate::catalogue`. The
//! tolerances are the values measured by `examples/study_checks.rs` (`docs/studies/checks.md`)
//! with a margin.

use crate::catalogue;
use crate::catalogue::stage;
use djkr::scenario::*;
use djkr_core::adhesion::{ConstantW, GentSchultz, Law};
use djkr_core::dynamics::protocol::*;
use djkr_core::dynamics::Method;
use djkr_core::dynamics::{EventKind, Recorder, RunResult};
use djkr_core::jkr;
use djkr_core::material::Material;
use djkr_core::rig::{BaseMotion, ContactFormation, Damping, DampingOn, Holder};

const M: Material = Material::PAPER;

fn run(s: &Scenario) -> (RunResult, Recorder) {
    let mut rec = Recorder::default();
    let r = s.simulate(&mut rec).unwrap_or_else(|e| panic!("{e}"));
    (r, rec)
}

fn first(r: &RunResult, k: EventKind) -> Option<djkr_core::dynamics::Event> {
    r.events.iter().find(|e| e.kind == k).copied()
}

/// Free flight of the sphere on its spring, the spring end moving at constant speed V from rest
/// in equilibrium: x(t) = x0 + V t − (V/ω) sin ωt (`catalogue::RampOscillator`).
#[test]
fn free_flight_matches_ramp_oscillator() {
    let (mut s, osc) = catalogue::free_flight(5e-3, 2e-3, 0.5);
    s.solver.rtol = 1e-10;
    let (r, rec) = run(&s);
    assert!(first(&r, EventKind::Impact).is_none());
    let worst = rec
        .samples
        .iter()
        .map(|smp| (smp.x_s - osc.position(smp.t)).abs())
        .fold(0.0, f64::max);
    // Measured 3.4e-10 m (global error ≈ steps × rtol × |x|, |x| ~ 5 mm).
    assert!(worst < 1e-9, "worst error {worst:e} m");
    assert!(rec.samples.len() > 10);
}

/// Elastic JKR (constant w) unloaded through a soft spring: load control. The most tensile force
/// is the load-controlled pull-off force −3/2 πRw0, and detachment follows right after.
#[test]
fn soft_spring_pull_off_is_load_controlled() {
    let (r, _) = run(&catalogue::load_controlled_unload());
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    assert!(r.detached);
    // Measured 1.6e-15.
    assert!(
        (r.pull_off.force / f0 - 1.0).abs() < 1e-12,
        "{} vs {f0}",
        r.pull_off.force
    );
    let po = first(&r, EventKind::PullOff).expect("pull-off event");
    // Past the minimum the contact runs away: a few contact periods, well under 10 ms.
    assert!(
        po.time > r.pull_off.time && po.time - r.pull_off.time < 1e-2,
        "{} {}",
        po.time,
        r.pull_off.time
    );
}

/// Through a rigid link (displacement control) the contact follows the JKR curve past the
/// force minimum and jumps off where dδ/da = 0: a³ = πwR²/(6K), F = −5/6 πRw.
#[test]
fn rigid_link_pull_off_is_displacement_controlled() {
    let (r, _) = run(&catalogue::displacement_controlled_unload());
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    // Measured 4.4e-16.
    assert!(
        (r.pull_off.force / f0 - 1.0).abs() < 1e-12,
        "{} vs {f0}",
        r.pull_off.force
    );
    let loss = first(&r, EventKind::ContactLoss).expect("contact loss");
    let a_dc = jkr::displacement_controlled_pull_off_radius(&M, M.w0);
    let f_dc = jkr::displacement_controlled_pull_off_force(&M, M.w0);
    // Measured 7.5e-6 and 9.1e-6: the loss is declared where the collapse outruns the time
    // resolution, just past the turning point.
    assert!((loss.state.a / a_dc - 1.0).abs() < 3e-5, "{}", loss.state.a);
    assert!(
        (loss.state.force / f_dc - 1.0).abs() < 3e-5,
        "{}",
        loss.state.force
    );
    assert!(r.detached);
}

/// The impact time of the ramp-driven oscillator, located by the driver, against the closed form
/// root of x(t) = 0 (bisection on the closed form), and its convergence with the tolerances.
#[test]
fn impact_time_converges_to_closed_form() {
    let (s0, osc) = catalogue::free_flight(2e-5, 2e-3, 0.1);
    let t_ref = osc.impact_time();
    let mut errs = vec![];
    for (rtol, etol) in [(1e-6, 1e-8), (1e-8, 1e-10), (1e-10, 1e-13)] {
        let mut s = s0.clone();
        s.solver.rtol = rtol;
        s.solver.event_tol = etol;
        let (r, _) = run(&s);
        let imp = first(&r, EventKind::Impact).expect("impact");
        errs.push((imp.time - t_ref).abs());
    }
    // Measured 8.1e-9, 9.8e-11, 8.0e-12 s.
    assert!(
        errs[2] < 3e-11 && errs[1] < 3e-10 && errs[0] < 3e-8,
        "{errs:?}"
    );
    assert!(errs[2] < errs[1] && errs[1] < errs[0], "{errs:?}");
}

fn gs() -> Law {
    Law::GentSchultz(GentSchultz::PAPER)
}

/// Gent–Schultz law through a rigid link, quasi-static unload: the most tensile force exceeds the
/// static −3/2 πRw0 (rate effect) and tends to it as the unload speed → 0.
#[test]
fn gs_rigid_unload_rate_effect_vanishes_slowly() {
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    let mut amps = vec![];
    for v in [1e-7, 1e-9, 1e-11] {
        let (r, _) = run(&catalogue::gs_rigid_unload(v));
        assert!(r.detached);
        amps.push(r.pull_off.force / f0);
    }
    assert!(
        amps[0] > amps[1] && amps[1] > amps[2] && amps[2] > 1.0,
        "{amps:?}"
    );
    assert!(amps[2] - 1.0 < 0.02, "{amps:?}");
}

/// The catalogue's light rig shaken at 300 Hz with amplitude `xb` for 0.05 s, at rtol 1e-9.
fn vibrating(xb: f64) -> Scenario {
    let mut s = catalogue::vibrating_hold(xb, 300.0, 0.05);
    s.solver.rtol = 1e-9;
    s
}

/// A hold of exactly N base periods records N cycles, also where rounding puts the N-th period
/// boundary (t_on + N·2π/ω) a few ulps after the stage end (t0 + N/f): 333.3 Hz for N = 1, 2, 5
/// and 123.4 Hz for N = 3 are such cases (checked in the test itself).
#[test]
fn stage_of_whole_periods_records_every_cycle() {
    let mut any_after = false;
    for (f, n) in [(333.3, 1), (333.3, 2), (333.3, 5), (123.4, 3), (300.0, 4)] {
        let mut s = vibrating(1e-6);
        s.rig.base = Some(BaseMotion {
            amplitude: 1e-6,
            frequency: f,
            phase: 0.0,
        });
        let d = n as f64 / f;
        s.stages = vec![stage(StageKind::Hold, 0.0, Until::Duration(d), Some(true))];
        let after = n as f64 * (2.0 * std::f64::consts::PI / (2.0 * std::f64::consts::PI * f)) > d;
        any_after |= after;
        let r = s.simulate(&mut djkr_core::dynamics::NoObserver).unwrap();
        assert_eq!(
            r.cycle_count, n as u64,
            "{f} Hz, {n} periods (boundary after the stage end by rounding: {after})"
        );
        assert!(first(&r, EventKind::DurationElapsed).is_some());
    }
    assert!(
        any_after,
        "no case exercises a boundary after the stage end"
    );
}

/// Over every cycle, to integration accuracy (`catalogue::cycle_balances`): momentum balance
/// ⟨F⟩ − m g − ⟨F_holder⟩ = −(m Δv + c Δx)/T, and energy balance
/// ΔE = W_base + W_holder − D_damping − D_adhesion + the contact-energy steps at impacts and
/// losses, on every scene of `catalogue::cycle_balance_scenes` at its own tolerances. Each bound
/// is the worst residual measured by `examples/study_checks.rs` (`docs/studies/checks.md`) with a
/// margin of 3–10×: at rtol 1e-8 the explicit DP8 integrates the energy quadratures to ~1e-8 of
/// the run's energy scale, the implicit method (seeded contact) to ~1e-7; momentum holds to
/// rounding.
#[test]
fn cycle_balances_hold() {
    // (scene, bound on the worst momentum residual, on the worst energy residual); measured
    // values in the comments.
    let bounds = [
        ("light rig, 300 Hz, X_b 2 µm", 1e-13, 2e-8), // 1.1e-15, 4.0e-9
        ("resonance-400hz hold", 5e-13, 3e-8),        // 4.6e-14, 6.0e-9
        ("seeded impact, contact damping", 5e-11, 1e-7), // 4.9e-12, 3.2e-8
        // Energy 2.0e-9 since auto hands the deep-healing steps after each jump-in to the
        // implicit method (1.2e-11 when DP8 took them all, with 30 % more steps).
        ("impacts, jump-in", 5e-13, 1e-8),    // 2.6e-14, 2.0e-9
        ("impacts, seed 10 µm", 5e-13, 3e-7), // 1.8e-14, 8.9e-8
        ("light protocol, unload 1 mm/s", 5e-12, 3e-8), // 2.4e-13, 8.4e-9
    ];
    let scenes = catalogue::cycle_balance_scenes().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scenes.len(), bounds.len());
    for (name, s) in &scenes {
        let &(_, mom, en) = bounds
            .iter()
            .find(|b| b.0 == *name)
            .unwrap_or_else(|| panic!("no bound for {name}"));
        let (r, rec) = run(s);
        let b = catalogue::cycle_balances(&s.rig, &rec.cycles, &rec.samples, &rec.events);
        let w = catalogue::summarise_balances(&b);
        assert!(w.cycles >= 10, "{name}: {} cycles", w.cycles);
        let m = w.momentum.expect("every balance scene has inertia");
        assert!(m < mom, "{name}: momentum residual {m:e} (bound {mom:e})");
        assert!(
            w.energy < en,
            "{name}: energy residual {:e} (bound {en:e})",
            w.energy
        );
        if name.starts_with("impacts") {
            // Contact lost and regained every cycle: the jump terms are exercised.
            let impacts = r
                .events
                .iter()
                .filter(|e| e.kind == EventKind::Impact)
                .count();
            assert!(impacts + 2 >= rec.cycles.len(), "{name}: {impacts} impacts");
        }
    }
}

/// The contact energy of the JKR jump-in state is −0.6 π w0 a_J² (from U(a_J, 0) =
/// (3K/20) a_J⁵/R² with a_J³ = 8πw0R²/(3K)).
#[test]
fn jump_in_contact_energy_closed_form() {
    let a_j = jkr::jump_in_radius(&M, M.w0);
    let e = catalogue::contact_energy(&M, a_j, 0.0);
    let expected = -0.6 * std::f64::consts::PI * M.w0 * a_j * a_j;
    assert!((e / expected - 1.0).abs() < 1e-12, "{e} vs {expected}");
}

/// In periodic steady state (heavier damping so the transient dies within the run) the
/// cycle-averaged contact force equals m g − k(⟨x_s⟩ − x_k).
#[test]
fn steady_state_force_balance() {
    let mut s = vibrating(2e-6);
    s.rig.damping = Some(Damping {
        c: 0.5,
        on: DampingOn::Sphere,
    });
    s.stages = vec![stage(
        StageKind::Hold,
        0.0,
        Until::Duration(0.15),
        Some(true),
    )];
    let (r, rec) = run(&s);
    let last = rec.cycles.last().unwrap();
    let k = 200.0;
    let balance = 3e-3 * 9.81 - k * (last.x_s_mean - last.x_k_mean);
    let amp = last.force_sin.hypot(last.force_cos);
    println!(
        "<F> {} balance {} amplitude {amp} {:?}",
        last.force_mean, balance, r.stats
    );
    assert!((last.force_mean - balance).abs() < 1e-5 * amp);
}

/// A large-amplitude shaker that breaks and re-makes the contact every cycle: no NaN, a ≥ 0,
/// finite forces, and the events alternate.
#[test]
fn repeated_impacts_stay_finite() {
    let cases = [
        (
            Law::Constant(ConstantW { w0: M.w0 }),
            ContactFormation::JumpIn,
            20e-6,
        ),
        (
            Law::Constant(ConstantW { w0: M.w0 }),
            ContactFormation::Seed(1e-5),
            20e-6,
        ),
        (gs(), ContactFormation::Seed(1e-5), 150e-6),
        (gs(), ContactFormation::JumpIn, 150e-6),
    ];
    for (law, formation, xb) in cases {
        let mut s = vibrating(xb);
        s.rig.law = law.clone();
        s.rig.formation = formation;
        s.initial = Initial::Preload(0.005);
        s.stages = vec![stage(
            StageKind::Hold,
            0.0,
            Until::Duration(0.03),
            Some(true),
        )];
        let (r, rec) = run(&s);
        let losses = r
            .events
            .iter()
            .filter(|e| e.kind == EventKind::ContactLoss)
            .count();
        let impacts = r
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Impact)
            .count();
        println!(
            "{formation:?}: {losses} losses, {impacts} impacts, {:?}",
            r.stats
        );
        if matches!(law, Law::Constant(_)) {
            assert!(losses >= 3 && impacts >= 3, "{losses} {impacts}");
        }
        for smp in &rec.samples {
            assert!(
                smp.a >= 0.0 && smp.a.is_finite() && smp.force.is_finite() && smp.x_s.is_finite()
            );
        }
    }
}

/// DP8, Dopri5 and the implicit method agree on the last cycle's means and first harmonics of
/// `vibrating_hold(2 µm, 300 Hz, 0.02 s)` at rtol 1e-10.
#[test]
fn methods_agree_under_vibration() {
    let mut res = vec![];
    for method in [Method::Implicit, Method::Dopri5, Method::Dp8] {
        let mut s = catalogue::vibrating_hold(2e-6, 300.0, 0.02);
        s.solver.method = method;
        s.solver.rtol = 1e-10;
        let (_, rec) = run(&s);
        res.push(*rec.cycles.last().unwrap());
    }
    // Measured (`docs/studies/checks.md`): Δ⟨F⟩/|F_s| 2.9e-9, δ_s 6.0e-8, a_s 1.2e-6.
    for b in &res[1..] {
        let a = res[0];
        assert!((a.force_mean - b.force_mean).abs() < 2e-8 * a.force_sin.abs());
        assert!((a.delta_sin / b.delta_sin - 1.0).abs() < 2e-7);
        assert!((a.a_sin / b.a_sin - 1.0).abs() < 5e-6);
    }
}

/// DP8, Dopri5 and the implicit method agree on the pull-off of a Gent–Schultz rigid-link
/// unload (`gs_rigid_unload(0.1 µm/s)`), and each converges as rtol → 0.
#[test]
fn methods_agree_on_gs_unload() {
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    let mut amp = vec![];
    for method in [Method::Implicit, Method::Dopri5, Method::Dp8] {
        let mut row = vec![];
        for rtol in [1e-6, 1e-8, 1e-10] {
            let mut s = catalogue::gs_rigid_unload(1e-7);
            s.solver.method = method;
            s.solver.rtol = rtol;
            let (r, _) = run(&s);
            row.push(r.pull_off.force / f0);
        }
        assert!(
            (row[2] - row[1]).abs() <= (row[1] - row[0]).abs() + 1e-12,
            "{method:?}: {row:?}"
        );
        amp.push(row[2]);
    }
    // Measured at rtol 1e-10: Dopri5 3.4e-10, DP8 8.1e-11 from the implicit method.
    assert!((amp[1] - amp[0]).abs() < 2e-9, "{amp:?}");
    assert!((amp[2] - amp[0]).abs() < 2e-9, "{amp:?}");
}

/// An explicitly requested explicit method on a rate-independent law fails with an error that
/// names the time, the state and the remedy; and `auto` on a GS scene with impacts runs DP8.
#[test]
fn explicit_errors_and_auto() {
    let mut s = catalogue::soft_spring_jkr();
    s.solver.method = Method::Dopri5;
    s.stages = vec![stage(StageKind::Hold, 0.0, Until::Duration(0.01), None)];
    let e = s
        .simulate(&mut Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t = 0") && e.contains("implicit") && e.contains("a = "),
        "{e}"
    );

    let mut s = vibrating(150e-6);
    s.rig.law = Law::GentSchultz(GentSchultz::new(M.w0, 4.45e-5, 0.531).unwrap());
    s.initial = Initial::Preload(0.005);
    s.stages = vec![stage(
        StageKind::Hold,
        0.0,
        Until::Duration(0.01),
        Some(true),
    )];
    let (r, _) = run(&s);
    assert!(r.method.starts_with("dp8"), "{}", r.method);
}

/// m = 0 (quasi-static balance through the spring): elastic JKR unloaded through a soft spring
/// reaches exactly the load-controlled pull-off force; through a stiff one it follows the curve
/// past the minimum to the displacement-controlled point.
#[test]
fn massless_sphere_quasi_static_pull_off() {
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    for (k, dc) in [(10.0, false), (1e7, true)] {
        let (r, _) = run(&catalogue::massless_unload(k));
        assert!(r.detached);
        // Measured 4.4e-16.
        assert!(
            (r.pull_off.force / f0 - 1.0).abs() < 1e-12,
            "k {k}: {}",
            r.pull_off.force
        );
        let loss = first(&r, EventKind::ContactLoss).unwrap();
        let f_dc = jkr::displacement_controlled_pull_off_force(&M, M.w0);
        if dc {
            // Measured 7.4e-4.
            assert!((loss.state.force / f_dc - 1.0).abs() < 1e-3);
        } else {
            // Load control: the contact is lost at the force minimum itself (measured 4.9e-7).
            assert!((loss.state.force / f0 - 1.0).abs() < 2e-6);
        }
    }
}

/// Gent–Schultz contact formed from a small seed at impact heals at a finite (large) rate
/// towards the JKR radius, through the compressive-edge state that the explicit form cannot pass
/// (`catalogue::seeded_impact_with_contact_damping`; its energy balance with contact damping is
/// checked in `cycle_balances_hold`).
#[test]
fn seeded_impact_heals_at_a_finite_rate() {
    let (r, rec) = run(&catalogue::seeded_impact_with_contact_damping());
    assert!(r.method.contains("implicit"));
    let imp = first(&r, EventKind::Impact).expect("impact");
    assert!((imp.state.a - 1e-6).abs() < 1e-12);
    assert!(first(&r, EventKind::PreloadReached).is_some());
    let a_max_rate = rec.samples.iter().map(|x| x.a_dot).fold(0.0, f64::max);
    assert!(a_max_rate > 1e-2 && a_max_rate.is_finite());
    let a_eq = jkr::equilibrium_radius_for_force(&M, 0.01, M.w0).unwrap();
    let at_preload = first(&r, EventKind::PreloadReached).unwrap().state.a;
    // Healing lags behind the quasi-static radius (w < w0 while healing): a smaller radius.
    assert!(
        at_preload < a_eq && at_preload > 0.5 * a_eq,
        "{at_preload} vs {a_eq}"
    );
}

/// Errors name the stage, the time and the state.
#[test]
fn errors_are_explicit() {
    let mut s = catalogue::soft_spring_jkr();
    s.stages = vec![Stage {
        max_duration: 0.01,
        ..stage(StageKind::Unload, 1e-6, Until::PullOff, None)
    }];
    let e = s
        .simulate(&mut Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stage 0") && e.contains("max_duration") && e.contains("F = "),
        "{e}"
    );
    let mut s = catalogue::soft_spring_jkr();
    s.rig.holder = Holder::None;
    s.stages = vec![stage(StageKind::Hold, 0.0, Until::Duration(0.01), None)];
    let e = s
        .simulate(&mut Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("weight"), "{e}");
}

/// Observed orders of a fixed-step stepper on the free ramp-driven oscillator (closed form
/// x(t) = x0 + V t − (V/ω) sin ωt, the sphere starting at rest a gap x0 < 0 away, spring end
/// moving at V = 2 mm/s): the errors at t = 0.1 s with `n`, 2n and 4n steps of `steps` and the
/// two log₂ ratios. `steps(model, drive, y0, h, n)` returns the state after n steps of h.
fn ramp_oscillator_orders(
    x0: f64,
    n: usize,
    steps: impl Fn(
        &djkr_core::dynamics::model::Model,
        &djkr_core::dynamics::model::Drive,
        djkr_core::dynamics::State,
        f64,
        usize,
    ) -> djkr_core::dynamics::State,
) -> (f64, f64) {
    use djkr_core::dynamics::model::{resolve, Drive, NQ};
    use djkr_core::dynamics::State;
    // Without gravity, so that the spring end starts at the sphere (the drive below).
    let mut s = catalogue::soft_spring_jkr();
    s.initial = Initial::Gap(-x0);
    let model = resolve(&s.rig, s.run_scales()).unwrap();
    let v = 2e-3;
    let osc = catalogue::RampOscillator {
        gap: -x0,
        speed: v,
        omega: (s.rig.spring_stiffness() / s.rig.sphere.mass).sqrt(),
    };
    let drive = Drive {
        xk0: x0,
        tk0: 0.0,
        xk_speed: v,
        shaker: false,
        t_on: 0.0,
    };
    let t_end = 0.1;
    let err = |n: usize| {
        let y0 = State {
            t: 0.0,
            x: x0,
            v: 0.0,
            acc: 0.0,
            a: 0.0,
            adot: 0.0,
            contact: false,
            q: [0.0; NQ],
        };
        let y = steps(&model, &drive, y0, t_end / n as f64, n);
        (y.x - osc.position(t_end)).abs()
    };
    let (e1, e2, e3) = (err(n), err(2 * n), err(4 * n));
    let (p1, p2) = ((e1 / e2).log2(), (e2 / e3).log2());
    println!("errors {e1:e} {e2:e} {e3:e}; observed orders {p1:.2} {p2:.2}");
    (p1, p2)
}

/// Fixed steps ignore the error estimate.
const NO_CONTROL: djkr_core::dynamics::Tol = djkr_core::dynamics::Tol {
    rtol: 1.0,
    atol: 1.0,
};

/// Convergence order of the ESDIRK stepper with fixed steps on the free ramp-driven oscillator
/// (closed form): halving h divides the error by ≈ 2⁴.
#[test]
fn esdirk_fixed_step_order_is_four() {
    use djkr_core::dynamics::kernels::esdirk_step;
    let (p1, p2) = ramp_oscillator_orders(-1.0, 40, |model, drive, mut y, h, n| {
        for _ in 0..n {
            y = esdirk_step(model, drive, &y, h, NO_CONTROL).unwrap().y;
        }
        y
    });
    assert!(
        (p2 - 4.0).abs() < 0.3 && (p1 - 4.0).abs() < 0.5,
        "{p1} {p2}"
    );
}

/// Convergence order of the DP8 stepper with fixed steps on the same oscillator: halving h
/// divides the error by ≈ 2⁸. The drive depends on time (the spring end moves), so a wrong stage
/// time (the `ode_solvers` Dop853 tableau's c₁₂ = 0) would show as order 1.
#[test]
fn dp8_fixed_step_order_is_eight() {
    use djkr_core::dynamics::kernels::{dp8_step, rates_at};
    let (p1, p2) = ramp_oscillator_orders(-1e-3, 10, |model, drive, mut y, h, n| {
        let (mut k, mut fq) = rates_at(model, drive, &y).unwrap();
        let mut o = djkr_core::dynamics::StepOut::default();
        for _ in 0..n {
            let (mut k1, mut fq1) = (k, fq);
            dp8_step(
                model, drive, &y, &k, &fq, h, NO_CONTROL, &mut o, &mut k1, &mut fq1,
            )
            .unwrap();
            (y, k, fq) = (o.y, k1, fq1);
        }
        y
    });
    assert!(
        (p2 - 8.0).abs() < 0.5 && (p1 - 8.0).abs() < 1.0,
        "{p1} {p2}"
    );
}

/// Output on a fixed grid, the shaker switching off at a period boundary (x_b continuous, no
/// more cycles), and an observer that stops the run.
#[test]
fn sampling_shaker_off_and_observer_stop() {
    let mut s = vibrating(2e-6);
    s.output.sample_rate = 10_000.0;
    s.stages = vec![
        stage(StageKind::Hold, 0.0, Until::Duration(0.0101), Some(true)),
        stage(StageKind::Hold, 0.0, Until::Duration(0.01), Some(false)),
    ];
    let (r, rec) = run(&s);
    // Samples every 0.1 ms from t = 0.
    for (i, smp) in rec.samples.iter().enumerate() {
        assert!((smp.t - i as f64 * 1e-4).abs() < 1e-12, "{i}: {}", smp.t);
    }
    assert_eq!(rec.samples.len(), 202);
    // 300 Hz: the shaker runs until the boundary after 0.0101 s, i.e. 4 whole periods (0.01333 s).
    assert_eq!(rec.cycles.len(), 4);
    assert_eq!(r.cycle_count, 4);
    assert_eq!(r.last_cycle, rec.cycles.last().copied());
    let t_off = rec.cycles.last().unwrap().t_end;
    assert!((t_off - 4.0 / 300.0).abs() < 1e-12);
    assert!(rec
        .samples
        .iter()
        .filter(|x| x.t > t_off)
        .all(|x| x.x_b == 0.0));
    let max_jump = rec
        .samples
        .windows(2)
        .map(|w| (w[1].x_b - w[0].x_b).abs())
        .fold(0.0, f64::max);
    assert!(max_jump <= 2e-6 * 2.0 * std::f64::consts::PI * 300.0 * 1e-4 * 1.01);

    struct StopAt(usize);
    impl djkr_core::dynamics::Observer for StopAt {
        fn sample(&mut self, _: &djkr_core::dynamics::Sample) -> bool {
            self.0 -= 1;
            self.0 > 0
        }
    }
    let r = s.simulate(&mut StopAt(10)).unwrap();
    assert!(r.method.contains("stopped by the observer"));
    assert!(r.final_state.t < 2e-3);
}

/// Effect of the contact-loss radius a_floor = min(1e-3 a_J, seed/10) on a GS rigid-link
/// pull-off (the seed only sets a_floor here: no impact happens): the loss time moves by far
/// less than the time resolution of the unload.
#[test]
fn contact_loss_radius_has_negligible_effect() {
    let mut rows = vec![];
    for formation in [
        ContactFormation::JumpIn,
        ContactFormation::Seed(1e-6),
        ContactFormation::Seed(1e-8),
    ] {
        let mut s = catalogue::gs_rigid_unload(1e-7);
        s.rig.formation = formation;
        s.solver.method = Method::Implicit;
        let (r, _) = run(&s);
        let loss = first(&r, EventKind::ContactLoss).unwrap();
        rows.push((loss.time, loss.state.a, r.pull_off.force));
    }
    let (t0, _, f0) = rows[0];
    for &(t, _, f) in &rows[1..] {
        assert!((t - t0).abs() < 1e-6 * t0, "{rows:?}");
        assert!((f - f0).abs() < 1e-12 * f0.abs(), "{rows:?}");
    }
}

/// `auto` takes the implicit method without inertia (rigid link), for a constant w and for
/// seeded contact formation, and DP8 for a GS sphere with mass (the rule of
/// `dynamics::methods::auto_method`; its basis is measured in `docs/studies/methods.md`). That
/// the methods agree on these scenes is `methods_agree_on_gs_unload`.
#[test]
fn auto_rule_by_scene() {
    let s = catalogue::gs_rigid_unload(1e-7);
    assert_eq!(s.solver.method, Method::Auto);
    let (r, _) = run(&s);
    assert!(r.method.starts_with("implicit"), "{}", r.method);
    assert!(r.detached);
    let mut c = s.clone();
    c.rig.law = Law::Constant(ConstantW { w0: M.w0 });
    assert!(run(&c).0.method.starts_with("implicit"));
    let mut seeded = s.clone();
    seeded.rig.formation = ContactFormation::Seed(1e-5);
    assert!(run(&seeded).0.method.starts_with("implicit"));
    let mut massless = catalogue::gs_massless_unload(1e-7);
    massless.stages[0].speed = 1e-4;
    assert!(run(&massless).0.method.starts_with("implicit"));

    let (r, _) = run(&catalogue::gs_soft_spring_unload(1e-4));
    assert!(r.method.starts_with("dp8"), "{}", r.method);
    assert!(r.detached);
}

/// A bundled scenario file, with `solver.method` set as `--set solver.method=NAME` sets it.
fn bundled_with_method(file: &str, name: &str) -> Result<Scenario, String> {
    use djkr::scenario::overrides::Override;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(file);
    let set = Override::parse(&format!("solver.method={name}")).map_err(|e| e.to_string())?;
    djkr::scenario::parse::load_scenario_with(&path, &[set]).map_err(|e| e.to_string())
}

/// What each registry entry provides, listed: the stepper it builds on a Gent–Schultz scene
/// with inertia (the resonance scene) and on a rate-independent one (quasi-static JKR), with the
/// method named in reports and the capabilities the simulator reads. A new method adds its row
/// here; a changed capability fails this list.
#[test]
fn registry_lists_what_each_method_provides() {
    use djkr_core::dynamics::methods::{self, METHODS};
    use djkr_core::dynamics::{Capabilities, Reach};
    const IMPLICIT: Capabilities = Capabilities {
        algebraic_radius: true,
        turning_points: false,
        period_memory: false,
        reach: Reach::Full,
    };
    const DP8: Capabilities = Capabilities {
        algebraic_radius: false,
        turning_points: true,
        period_memory: true,
        reach: Reach::HalfForSamples,
    };
    const MACRO: Capabilities = Capabilities {
        algebraic_radius: false,
        turning_points: false,
        period_memory: false,
        reach: Reach::Half,
    };
    // (name; on the GS scene with inertia: reported as, capabilities; on the constant-w scene).
    let expected = [
        ("auto", ("dp8", DP8), ("implicit", IMPLICIT)),
        ("dp8", ("dp8", DP8), ("dp8", DP8)),
        ("dopri5", ("dopri5", MACRO), ("dopri5", MACRO)),
        ("dop853", ("dop853", MACRO), ("dop853", MACRO)),
        ("implicit", ("implicit", IMPLICIT), ("implicit", IMPLICIT)),
    ];
    let gs = bundled_with_method("resonance-400hz.toml", "auto").unwrap();
    let constant = bundled_with_method("quasi-static-jkr.toml", "auto").unwrap();
    let names: Vec<&str> = METHODS.iter().map(|e| e.name).collect();
    assert_eq!(
        names,
        expected.map(|e| e.0),
        "the registry's names, in order"
    );
    assert_eq!(methods::method_names(), names);
    for (entry, (name, on_gs, on_constant)) in METHODS.iter().zip(expected) {
        for (rig, (reported, caps)) in [(&gs.rig, on_gs), (&constant.rig, on_constant)] {
            let stepper = (entry.build)(rig);
            assert_eq!(stepper.short_name(), reported, "{name}");
            assert_eq!(stepper.capabilities(), caps, "{name}: {}", stepper.name());
            // What a report names is itself a method of the registry.
            assert!(names.contains(&stepper.short_name()), "{name}");
            // A fresh stepper is the same method.
            let fresh = stepper.fresh();
            assert_eq!((fresh.short_name(), fresh.capabilities()), (reported, caps));
        }
    }
    // The constants code names are registry methods, and names and methods map both ways.
    for m in [
        Method::Auto,
        Method::Dp8,
        Method::Dopri5,
        Method::Dop853,
        Method::Implicit,
    ] {
        let name = methods::method_name(m);
        assert_eq!(methods::method_from_name(name), Some(m));
        assert_eq!(m.to_string(), name);
    }
    assert_eq!(methods::methods().count(), METHODS.len());
    assert_eq!(methods::method_from_name("rk4"), None);
}

/// The scenario parser accepts exactly the registry's names for `solver.method` (and maps each
/// to its method); any other name is refused with the registry's list, in its order.
#[test]
fn parser_accepts_the_registry_names_for_solver_method() {
    use djkr_core::dynamics::methods::{method_from_name, method_names};
    for name in method_names() {
        let s = bundled_with_method("resonance-400hz.toml", name)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(Some(s.solver.method), method_from_name(name), "{name}");
    }
    let listed = method_names()
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(", ");
    for bogus in ["rk4", "DP8", "Implicit"] {
        let e = bundled_with_method("resonance-400hz.toml", bogus).unwrap_err();
        assert!(e.contains("solver.method"), "{bogus}: {e}");
        assert!(
            e.contains(&format!("must be one of {listed}")),
            "{bogus}: {e}"
        );
    }
}

/// The capabilities say what the steppers do. `algebraic_radius`: exactly the methods that
/// declare it run a rate-independent law; the others are refused when the file is read and,
/// set on the parsed scenario, when the run starts.
/// `turning_points`: over one period of the vibrating resonance scene, stepped at 1/64 of the
/// period, only a method that declares it reports a turning point of the contact line (and DP8,
/// which does, reports the two per period).
#[test]
fn capabilities_match_what_the_steppers_do() {
    use djkr_core::dynamics::methods::{method_names, METHODS};
    use djkr_core::dynamics::StepOut;
    use djkr_core::dynamics::{model, protocol};
    let constant = bundled_with_method("quasi-static-jkr.toml", "auto").unwrap();
    for name in method_names() {
        let method = djkr_core::dynamics::methods::method_from_name(name).unwrap();
        let algebraic = djkr_core::dynamics::methods::build(method, &constant.rig)
            .capabilities()
            .algebraic_radius;
        let read = bundled_with_method("quasi-static-jkr.toml", name);
        assert_eq!(read.is_ok(), algebraic, "{name}: {:?}", read.err());
        let mut s = constant.clone();
        s.solver.method = method;
        let r = s.simulate(&mut djkr_core::dynamics::NoObserver);
        assert_eq!(r.is_ok(), algebraic, "{name}: {:?}", r.err());
    }
    let s = bundled_with_method("resonance-400hz.toml", "auto").unwrap();
    let m = model::resolve(&s.rig, s.run_scales()).unwrap();
    let (y0, mut drive) = protocol::initial_state(&s.rig, &s.initial, &m).unwrap();
    drive.shaker = true;
    drive.t_on = y0.t;
    let period = 2.0 * std::f64::consts::PI / m.omega;
    let tol = djkr_core::dynamics::Tol {
        rtol: 1e-8,
        atol: 1e-10,
    };
    for entry in METHODS {
        let mut stepper = (entry.build)(&s.rig);
        let declared = stepper.capabilities().turning_points;
        let (mut y, mut turns, mut predicted) = (y0, 0, 0);
        let mut out = StepOut::default();
        let mut evals = 0;
        for _ in 0..64 {
            stepper
                .attempt(&m, &drive, &y, period / 64.0, tol, &mut evals, &mut out)
                .unwrap_or_else(|e| panic!("{}: {e:?}", entry.name));
            turns += out.kink.is_some() as usize;
            predicted += out.kink_ahead.is_some() as usize;
            y = out.y;
        }
        if declared {
            assert!((2..=3).contains(&turns), "{}: {turns} turns", entry.name);
            assert!(predicted > 0, "{}", entry.name);
        } else {
            assert_eq!((turns, predicted), (0, 0), "{}", entry.name);
        }
    }
}
