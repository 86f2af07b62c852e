//! Time-domain simulator against independent references (closed forms, JKR limits, balance laws).

use djkr::adhesion::{ConstantW, GentSchultz, Law};
use djkr::dynamics::catalogue::stage;
use djkr::dynamics::{EventKind, Recorder, RunResult};
use djkr::jkr;
use djkr::material::Material;
use djkr::scenario::*;

const M: Material = Material::PAPER;

fn scene() -> Scenario {
    Scenario {
        rig: Rig {
            material: M,
            law: Law::Constant(ConstantW { w0: M.w0 }),
            sphere: Sphere {
                mass: 1e-3,
                gravity: 0.0,
            },
            holder: Holder::Spring { stiffness: 10.0 },
            damping: None,
            base: None,
            formation: ContactFormation::JumpIn,
        },
        initial: Initial::Preload(0.01),
        stages: vec![],
        solver: Solver {
            rtol: 1e-9,
            atol: 1e-10,
            ..Solver::default()
        },
        output: Output::default(),
        source_text: String::new(),
        source_name: "<test>".into(),
        overrides: Vec::new(),
    }
}

fn run(s: &Scenario) -> (RunResult, Recorder) {
    let mut rec = Recorder::default();
    let r = s.simulate(&mut rec).unwrap_or_else(|e| panic!("{e}"));
    (r, rec)
}

fn first(r: &RunResult, k: EventKind) -> Option<djkr::dynamics::Event> {
    r.events.iter().find(|e| e.kind == k).copied()
}

/// Free flight of the sphere on its spring, the spring end moving at constant speed V from rest
/// in equilibrium: x(t) = x0 + V t − (V/ω) sin ωt.
#[test]
fn free_flight_matches_ramp_oscillator() {
    let mut s = scene();
    s.rig.sphere.gravity = 9.81;
    let g0 = 5e-3;
    s.initial = Initial::Gap(g0);
    let v = 2e-3;
    s.solver.rtol = 1e-10;
    s.stages = vec![stage(StageKind::Approach, v, Until::Duration(0.5), None)];
    let (r, rec) = run(&s);
    assert!(first(&r, EventKind::Impact).is_none());
    let w = (10.0f64 / 1e-3).sqrt();
    let mut worst = 0.0f64;
    for smp in &rec.samples {
        let t = smp.t;
        let x = -g0 + v * t - v / w * (w * t).sin();
        worst = worst.max((smp.x_s - x).abs());
    }
    // Global error ≈ (steps) × rtol × |x| (|x| ~ 5 mm): ~4e-10 m at rtol 1e-10.
    assert!(worst < 1e-9, "worst error {worst:e} m");
    assert!(rec.samples.len() > 10);
}

#[test]
#[ignore]
fn probe_free_flight_order() {
    for (m, rtol) in [(Method::Dop853, 1e-10), (Method::Dop853, 1e-12)] {
        let mut s = scene();
        s.rig.law = gs();
        s.solver.method = m;
        s.solver.rtol = rtol;
        s.rig.sphere.gravity = 9.81;
        let g0 = 5e-3;
        s.initial = Initial::Gap(g0);
        let v = 2e-3;
        s.stages = vec![stage(StageKind::Approach, v, Until::Duration(0.5), None)];
        let (r, rec) = run(&s);
        let w = (10.0f64 / 1e-3).sqrt();
        let mut worst = 0.0f64;
        for smp in &rec.samples {
            let t = smp.t;
            let x = -g0 + v * t - v / w * (w * t).sin();
            worst = worst.max((smp.x_s - x).abs());
        }
        println!(
            "rtol {rtol:e}: steps {} rej {} worst {worst:e}",
            r.stats.steps, r.stats.rejected
        );
    }
}

/// Elastic JKR (constant w) unloaded through a soft spring: load control. The most tensile force
/// is the load-controlled pull-off force −3/2 πRw0, and detachment follows right after.
#[test]
fn soft_spring_pull_off_is_load_controlled() {
    let mut s = scene();
    s.stages = vec![stage(StageKind::Unload, 1e-3, Until::PullOff, None)];
    let (r, _) = run(&s);
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    println!("{:?} {:?}", r.pull_off, r.stats);
    assert!(r.detached);
    assert!(
        (r.pull_off.force / f0 - 1.0).abs() < 1e-7,
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
    let mut s = scene();
    s.rig.holder = Holder::Rigid;
    s.stages = vec![stage(StageKind::Unload, 1e-4, Until::PullOff, None)];
    let (r, _) = run(&s);
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    assert!(
        (r.pull_off.force / f0 - 1.0).abs() < 1e-7,
        "{} vs {f0}",
        r.pull_off.force
    );
    let loss = first(&r, EventKind::ContactLoss).expect("contact loss");
    let a_dc = jkr::displacement_controlled_pull_off_radius(&M, M.w0);
    let f_dc = jkr::displacement_controlled_pull_off_force(&M, M.w0);
    println!(
        "{:?} a {} vs {a_dc}, F {} vs {f_dc}",
        r.stats, loss.state.a, loss.state.force
    );
    assert!((loss.state.a / a_dc - 1.0).abs() < 1e-4);
    assert!((loss.state.force / f_dc - 1.0).abs() < 1e-4);
    assert!(r.detached);
}

/// The impact time of the ramp-driven oscillator, located by the driver, against the closed form
/// root of x(t) = 0 (bisection on the closed form), and its convergence with the tolerances.
#[test]
fn impact_time_converges_to_closed_form() {
    let g0 = 2e-5;
    let v = 2e-3;
    let w = (10.0f64 / 1e-3).sqrt();
    let x = |t: f64| -g0 + v * t - v / w * (w * t).sin();
    // First root: scan, then bisect.
    let mut t = 0.0;
    while x(t) < 0.0 {
        t += 1e-4;
    }
    let (mut lo, mut hi): (f64, f64) = (t - 1e-4, t);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if x(m) < 0.0 {
            lo = m
        } else {
            hi = m
        }
    }
    let t_ref = 0.5 * (lo + hi);
    let mut errs = vec![];
    for (rtol, etol) in [(1e-6, 1e-8), (1e-8, 1e-10), (1e-10, 1e-13)] {
        let mut s = scene();
        s.initial = Initial::Gap(g0);
        s.solver.rtol = rtol;
        s.solver.event_tol = etol;
        s.stages = vec![stage(StageKind::Approach, v, Until::Duration(0.1), None)];
        let (r, _) = run(&s);
        let imp = first(&r, EventKind::Impact).expect("impact");
        errs.push((imp.time - t_ref).abs());
    }
    println!("t_ref {t_ref}, errors {errs:?}");
    assert!(errs[2] < 1e-11, "{errs:?}");
    assert!(errs[2] < errs[0]);
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
        let mut s = scene();
        s.rig.law = gs();
        s.rig.holder = Holder::Rigid;
        s.stages = vec![stage(StageKind::Unload, v, Until::PullOff, None)];
        let (r, _) = run(&s);
        assert!(r.detached);
        amps.push(r.pull_off.force / f0);
        println!(
            "v {v:e}: amplification {} {:?}",
            r.pull_off.force / f0,
            r.stats
        );
    }
    assert!(
        amps[0] > amps[1] && amps[1] > amps[2] && amps[2] > 1.0,
        "{amps:?}"
    );
    assert!(amps[2] - 1.0 < 0.02, "{amps:?}");
}

/// The paper's material on a 3 g sphere, 200 N/m spring, light damping, 300 Hz shaker.
fn vibrating(xb: f64) -> Scenario {
    let mut s = scene();
    s.rig.law = gs();
    s.rig.sphere = Sphere {
        mass: 3e-3,
        gravity: 9.81,
    };
    s.rig.holder = Holder::Spring { stiffness: 200.0 };
    s.rig.damping = Some(Damping {
        c: 0.02,
        on: DampingOn::Sphere,
    });
    s.rig.base = Some(BaseMotion {
        amplitude: xb,
        frequency: 300.0,
    });
    s.initial = Initial::Preload(0.02);
    s.stages = vec![stage(
        StageKind::Hold,
        0.0,
        Until::Duration(0.05),
        Some(true),
    )];
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
        });
        let d = n as f64 / f;
        s.stages = vec![stage(StageKind::Hold, 0.0, Until::Duration(d), Some(true))];
        let after = n as f64 * (2.0 * std::f64::consts::PI / (2.0 * std::f64::consts::PI * f)) > d;
        any_after |= after;
        let r = s.simulate(&mut djkr::dynamics::NoObserver).unwrap();
        assert_eq!(
            r.cycles.len(),
            n,
            "{f} Hz, {n} periods (boundary after the stage end by rounding: {after})"
        );
        assert!(first(&r, EventKind::DurationElapsed).is_some());
    }
    assert!(
        any_after,
        "no case exercises a boundary after the stage end"
    );
}

/// Over every cycle, exactly (to integration accuracy): momentum balance
/// ⟨F⟩ − m g − ⟨F_spring⟩ = −(m Δv + c Δx)/T, and energy balance
/// ΔE = W_base + W_holder − D_damping − D_adhesion. In periodic steady state Δv = Δx = 0, so the
/// first is ⟨F⟩ = m g − k(⟨x_s⟩ − x_k).
#[test]
fn cycle_balances_hold() {
    let s = vibrating(2e-6);
    let (r, rec) = run(&s);
    assert!(r.cycles.len() >= 14, "{}", r.cycles.len());
    assert_eq!(rec.cycles.len(), r.cycles.len());
    let at = |t: f64| {
        rec.samples
            .iter()
            .find(|x| x.t == t)
            .copied()
            .expect("sample at cycle boundary")
    };
    let (m, g, c) = (3e-3, 9.81, 0.02);
    let mut worst_mom = 0.0f64;
    let mut worst_en = 0.0f64;
    for cy in &r.cycles {
        let (s0, s1) = (at(cy.t_start), at(cy.t_end));
        let tt = cy.t_end - cy.t_start;
        let lhs = cy.force_mean - m * g - cy.spring_mean;
        let rhs = -(m * (s1.v_s - s0.v_s) + c * (s1.x_s - s0.x_s)) / tt;
        worst_mom = worst_mom.max((lhs - rhs).abs() / cy.force_sin.hypot(cy.force_cos));
        let de = cy.energy_end - cy.energy_start;
        let budget =
            cy.work_base + cy.work_holder - cy.dissipation_damping - cy.dissipation_adhesion;
        worst_en = worst_en.max((de - budget).abs() / cy.work_base.abs());
    }
    let last = r.cycles.last().unwrap();
    let ss =
        (last.force_mean - (m * g + last.spring_mean)).abs() / last.force_sin.hypot(last.force_cos);
    println!(
        "momentum {worst_mom:e}, energy {worst_en:e}, steady-state residual {ss:e}, {:?}",
        r.stats
    );
    assert!(worst_mom < 1e-7);
    assert!(worst_en < 1e-6);
    assert!(last.dissipation_adhesion > 0.0 && last.dissipation_damping > 0.0);
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
    let (r, _) = run(&s);
    let last = r.cycles.last().unwrap();
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

/// DP8, Dopri5 and the implicit method agree on a vibrating scene as rtol → 0.
#[test]
fn methods_agree_under_vibration() {
    let mut res = vec![];
    for method in [Method::Implicit, Method::Dopri5, Method::Dp8] {
        let mut s = vibrating(2e-6);
        s.solver.method = method;
        s.solver.rtol = 1e-10;
        s.stages = vec![stage(
            StageKind::Hold,
            0.0,
            Until::Duration(0.02),
            Some(true),
        )];
        let (r, _) = run(&s);
        let c = *r.cycles.last().unwrap();
        println!(
            "{method:?}: <F> {:e} delta_s {:e} a_s {:e} {:?} {}",
            c.force_mean, c.delta_sin, c.a_sin, r.stats, r.method
        );
        res.push(c);
    }
    for b in &res[1..] {
        let a = res[0];
        assert!((a.force_mean - b.force_mean).abs() < 1e-7 * a.force_sin.abs());
        assert!((a.delta_sin / b.delta_sin - 1.0).abs() < 1e-7);
        assert!((a.a_sin / b.a_sin - 1.0).abs() < 1e-5);
    }
}

/// DP8, Dopri5 and the implicit method agree on a Gent–Schultz rigid-link unload, and each
/// converges as rtol → 0.
#[test]
fn methods_agree_on_gs_unload() {
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    let mut amp = vec![];
    for method in [Method::Implicit, Method::Dopri5, Method::Dp8] {
        let mut row = vec![];
        for rtol in [1e-6, 1e-8, 1e-10] {
            let mut s = scene();
            s.rig.law = gs();
            s.rig.holder = Holder::Rigid;
            s.solver.method = method;
            s.solver.rtol = rtol;
            s.stages = vec![stage(StageKind::Unload, 1e-7, Until::PullOff, None)];
            let (r, _) = run(&s);
            row.push(r.pull_off.force / f0);
        }
        println!("{method:?}: {row:?}");
        assert!(
            (row[2] - row[1]).abs() <= (row[1] - row[0]).abs() + 1e-12,
            "{row:?}"
        );
        amp.push(row[2]);
    }
    assert!((amp[1] - amp[0]).abs() < 1e-8, "{amp:?}");
    assert!((amp[2] - amp[0]).abs() < 1e-8, "{amp:?}");
}

/// An explicitly requested explicit method on a rate-independent law fails with an error that
/// names the time, the state and the remedy; and `auto` on a GS scene with impacts runs DP8.
#[test]
fn explicit_errors_and_auto() {
    let mut s = scene();
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
    println!("{}", r.method);
    assert!(r.method.starts_with("dp8"), "{}", r.method);
}

/// Probe of `ode_solvers` Dop853 alone on y'' = −y over [0, 10] with h_max = 0.5: error vs rtol.
#[test]
#[ignore]
fn probe_ode_solvers_dop853() {
    use ode_solvers::{dop_shared::OutputType, Dop853, Dopri5, System, Vector2};
    struct Osc;
    impl System<f64, Vector2<f64>> for Osc {
        fn system(&self, _t: f64, y: &Vector2<f64>, dy: &mut Vector2<f64>) {
            dy[0] = y[1];
            dy[1] = -y[0];
        }
    }
    for rtol in [1e-6, 1e-9, 1e-12] {
        let y0 = Vector2::new(1.0, 0.0);
        let mut s = Dop853::from_param(
            Osc,
            0.0,
            10.0,
            0.5,
            y0,
            rtol,
            rtol,
            0.9,
            0.0,
            0.333,
            6.0,
            0.5,
            0.0,
            100000,
            1000,
            OutputType::Sparse,
        );
        s.integrate().unwrap();
        let (x, y) = s.results().get();
        let e853 = (y.last().unwrap()[0] - 10f64.cos()).abs();
        let n853 = x.len();
        let mut s = Dopri5::from_param(
            Osc,
            0.0,
            10.0,
            0.5,
            y0,
            rtol,
            rtol,
            0.9,
            0.04,
            0.2,
            10.0,
            0.5,
            0.0,
            100000,
            1000,
            OutputType::Sparse,
        );
        s.integrate().unwrap();
        let (x, y) = s.results().get();
        println!(
            "rtol {rtol:e}: dop853 err {e853:e} ({n853} pts), dopri5 err {:e} ({} pts)",
            (y.last().unwrap()[0] - 10f64.cos()).abs(),
            x.len()
        );
    }
}

#[test]
#[ignore]
fn probe_paper_protocol() {
    for m in [Method::Auto, Method::Implicit] {
        let mut s = djkr::dynamics::catalogue::paper_protocol(5e-6);
        s.solver.method = m;
        let (r, _) = run(&s);
        println!("{:?} {} {:?}", r.pull_off, r.detached, r.stats);
        for e in &r.events {
            if e.kind != EventKind::Impact && e.kind != EventKind::ContactLoss {
                println!("  {:?} t {:e} F {:e}", e.kind, e.time, e.state.force);
            }
        }
        println!(
            "  {} cycles, {} events; {}",
            r.cycles.len(),
            r.events.len(),
            r.method
        );
    }
}

#[test]
#[ignore]
fn probe_protocol_convergence() {
    for m in [Method::Implicit, Method::Dopri5] {
        for rtol in [1e-7, 1e-8, 1e-9, 1e-10] {
            let mut s = djkr::dynamics::catalogue::paper_protocol(1e-3);
            s.solver.method = m;
            s.solver.rtol = rtol;
            match s.simulate(&mut djkr::dynamics::NoObserver) {
                Ok(r) => {
                    let last = r.cycles.last().unwrap();
                    let c5 = r.cycles.iter().find(|c| c.t_end >= 5.0).unwrap();
                    let loss = r
                        .events
                        .iter()
                        .find(|e| e.kind == EventKind::ContactLoss && e.time > 1.0)
                        .map(|e| e.time);
                    println!(
                        "   cycle at {:.6}: <F> {:.10e} delta_s {:.8e}; first loss {loss:?}",
                        c5.t_end, c5.force_mean, c5.delta_sin
                    );
                    println!("{m:?} {rtol:e}: pull-off {:.6e} at {:.6}, detach t {:.6}, last-cycle <F> {:.6e}, steps {} ; {}", r.pull_off.force, r.pull_off.time, first(&r, EventKind::PullOff).map(|e| e.time).unwrap_or(-1.0), last.force_mean, r.stats.steps, r.method.len());
                }
                Err(e) => println!("{m:?} {rtol:e}: {e}"),
            }
        }
    }
}

/// m = 0 (quasi-static balance through the spring): elastic JKR unloaded through a soft spring
/// reaches exactly the load-controlled pull-off force; through a stiff one it follows the curve
/// past the minimum to the displacement-controlled point.
#[test]
fn massless_sphere_quasi_static_pull_off() {
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    for (k, dc) in [(10.0, false), (1e7, true)] {
        let mut s = scene();
        s.rig.sphere.mass = 0.0;
        s.rig.holder = Holder::Spring { stiffness: k };
        s.stages = vec![stage(StageKind::Unload, 1e-4, Until::PullOff, None)];
        let (r, _) = run(&s);
        assert!(r.detached);
        assert!(
            (r.pull_off.force / f0 - 1.0).abs() < 1e-7,
            "k {k}: {}",
            r.pull_off.force
        );
        let loss = first(&r, EventKind::ContactLoss).unwrap();
        let f_dc = jkr::displacement_controlled_pull_off_force(&M, M.w0);
        println!(
            "k {k}: loss at F = {} (dc {f_dc}), a = {}",
            loss.state.force, loss.state.a
        );
        if dc {
            assert!((loss.state.force / f_dc - 1.0).abs() < 1e-3);
        } else {
            // Load control: the contact is lost at the force minimum itself.
            assert!((loss.state.force / f0 - 1.0).abs() < 1e-3);
        }
    }
}

/// Gent–Schultz contact formed from a small seed at impact heals at a finite (large) rate
/// towards the JKR radius, through the compressive-edge state that the explicit form cannot
/// pass; the energy balance holds with contact damping too.
#[test]
fn seeded_impact_heals_and_contact_damping_balances_energy() {
    let mut s = scene();
    s.rig.law = gs();
    s.rig.formation = ContactFormation::Seed(1e-6);
    s.rig.damping = Some(Damping {
        c: 0.05,
        on: DampingOn::Contact,
    });
    s.rig.base = Some(BaseMotion {
        amplitude: 1e-6,
        frequency: 200.0,
    });
    s.initial = Initial::Gap(5e-6);
    s.stages = vec![
        stage(StageKind::Approach, 1e-3, Until::Preload(0.01), Some(false)),
        stage(StageKind::Hold, 0.0, Until::Duration(0.05), Some(true)),
    ];
    s.solver.max_steps = 100_000;
    let mut rr = Recorder::default();
    let res = s.simulate(&mut rr);
    for e in rr.events.iter().take(10) {
        println!(
            "{:?} t {:e} a {:e} delta {:e} F {:e} adot {:e}",
            e.kind, e.time, e.state.a, e.state.delta, e.state.force, e.state.a_dot
        );
    }
    let (r, rec) = (res.unwrap_or_else(|e| panic!("{e}")), rr);
    assert!(r.method.contains("implicit"));
    let imp = first(&r, EventKind::Impact).expect("impact");
    assert!((imp.state.a - 1e-6).abs() < 1e-12);
    assert!(first(&r, EventKind::PreloadReached).is_some());
    let a_max_rate = rec.samples.iter().map(|x| x.a_dot).fold(0.0, f64::max);
    println!("max healing rate {a_max_rate:e} m/s, {:?}", r.stats);
    assert!(a_max_rate > 1e-2 && a_max_rate.is_finite());
    let a_eq = jkr::equilibrium_radius_for_force(&M, 0.01, M.w0).unwrap();
    let at_preload = first(&r, EventKind::PreloadReached).unwrap().state.a;
    // Healing lags behind the quasi-static radius (w < w0 while healing): a smaller radius.
    assert!(
        at_preload < a_eq && at_preload > 0.5 * a_eq,
        "{at_preload} vs {a_eq}"
    );
    for cy in &r.cycles {
        let de = cy.energy_end - cy.energy_start;
        let budget =
            cy.work_base + cy.work_holder - cy.dissipation_damping - cy.dissipation_adhesion;
        assert!(
            (de - budget).abs() < 1e-6 * cy.work_base.abs().max(cy.dissipation_damping),
            "{de} vs {budget}"
        );
    }
}

/// Errors name the stage, the time and the state.
#[test]
fn errors_are_explicit() {
    let mut s = scene();
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
    let mut s = scene();
    s.rig.holder = Holder::None;
    s.stages = vec![stage(StageKind::Hold, 0.0, Until::Duration(0.01), None)];
    let e = s
        .simulate(&mut Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("weight"), "{e}");
}

#[test]
#[ignore]
fn probe_vibration_cost() {
    for m in [Method::Implicit, Method::Auto] {
        let mut s = djkr::dynamics::catalogue::vibrating_hold(5e-6, 400.0, 1.0);
        s.solver.method = m;
        let r = s.simulate(&mut djkr::dynamics::NoObserver).unwrap();
        println!("{m:?}: {:?}", r.stats);
    }
}

/// Observed orders of a fixed-step stepper on the free ramp-driven oscillator (closed form
/// x(t) = x0 + V t − (V/ω) sin ωt, the sphere starting at rest a gap x0 < 0 away, spring end
/// moving at V = 2 mm/s): the errors at t = 0.1 s with `n`, 2n and 4n steps of `steps` and the
/// two log₂ ratios. `steps(model, drive, y0, h, n)` returns the state after n steps of h.
fn ramp_oscillator_orders(
    x0: f64,
    n: usize,
    steps: impl Fn(
        &djkr::dynamics::model::Model,
        &djkr::dynamics::model::Drive,
        djkr::dynamics::state::State,
        f64,
        usize,
    ) -> djkr::dynamics::state::State,
) -> (f64, f64) {
    use djkr::dynamics::model::{resolve, Drive, NQ};
    use djkr::dynamics::state::State;
    let mut s = scene();
    s.initial = Initial::Gap(-x0);
    let model = resolve(&s.rig, s.run_scales()).unwrap();
    let v = 2e-3;
    let w = (10.0f64 / 1e-3).sqrt();
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
        let x = x0 + v * t_end - v / w * (w * t_end).sin();
        (y.x - x).abs()
    };
    let (e1, e2, e3) = (err(n), err(2 * n), err(4 * n));
    let (p1, p2) = ((e1 / e2).log2(), (e2 / e3).log2());
    println!("errors {e1:e} {e2:e} {e3:e}; observed orders {p1:.2} {p2:.2}");
    (p1, p2)
}

/// Fixed steps ignore the error estimate.
const NO_CONTROL: djkr::dynamics::state::Tol = djkr::dynamics::state::Tol {
    rtol: 1.0,
    atol: 1.0,
};

/// Convergence order of the ESDIRK stepper with fixed steps on the free ramp-driven oscillator
/// (closed form): halving h divides the error by ≈ 2⁴.
#[test]
fn esdirk_fixed_step_order_is_four() {
    use djkr::dynamics::esdirk::step;
    let (p1, p2) = ramp_oscillator_orders(-1.0, 40, |model, drive, mut y, h, n| {
        for _ in 0..n {
            y = step(model, drive, &y, h, NO_CONTROL).unwrap().y;
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
    use djkr::dynamics::dp8::{rates_at, step};
    let (p1, p2) = ramp_oscillator_orders(-1e-3, 10, |model, drive, mut y, h, n| {
        let (mut k, mut fq) = rates_at(model, drive, &y).unwrap();
        for _ in 0..n {
            let (o, k1, fq1) = step(model, drive, &y, &k, &fq, h, NO_CONTROL).unwrap();
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
    assert_eq!(r.cycles.len(), 4);
    let t_off = r.cycles.last().unwrap().t_end;
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
    impl djkr::dynamics::Observer for StopAt {
        fn sample(&mut self, _: &djkr::dynamics::Sample) -> bool {
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
        let mut s = scene();
        s.rig.law = gs();
        s.rig.holder = Holder::Rigid;
        s.rig.formation = formation;
        s.solver.method = Method::Implicit;
        s.stages = vec![stage(StageKind::Unload, 1e-7, Until::PullOff, None)];
        let (r, _) = run(&s);
        let loss = first(&r, EventKind::ContactLoss).unwrap();
        rows.push((loss.time, loss.state.a, r.pull_off.force));
    }
    println!("{rows:?}");
    let (t0, _, f0) = rows[0];
    for &(t, _, f) in &rows[1..] {
        assert!((t - t0).abs() < 1e-6 * t0, "{rows:?}");
        assert!((f - f0).abs() < 1e-12 * f0.abs(), "{rows:?}");
    }
}

/// Work–precision study of 1 s at 400 Hz (`catalogue::vibrating_hold(5 µm, 400 Hz, 1 s)`): for
/// each method and rtol, the final-cycle ⟨F⟩, δ_A and a_m against an implicit reference at rtol
/// 1e-12. Opt-in: `cargo test --release --test dynamics work_precision -- --ignored --nocapture`.
#[test]
#[ignore]
fn work_precision_1s_400hz() {
    let outs = |r: &RunResult| {
        let c = r.cycles.last().expect("cycles");
        (c.force_mean, c.delta_sin.hypot(c.delta_cos), c.a_mean)
    };
    for xb in [5e-6, 1e-6] {
        let mut s = djkr::dynamics::catalogue::vibrating_hold(xb, 400.0, 1.0);
        s.solver.method = Method::Implicit;
        s.solver.rtol = 1e-12;
        let t = std::time::Instant::now();
        let r = s.simulate(&mut djkr::dynamics::NoObserver).unwrap();
        let (f0, d0, a0) = outs(&r);
        println!(
            "X_b {xb:e}: reference implicit 1e-12: F {f0:e} dA {d0:e} am {a0:e} {:?} {:.3} s",
            r.stats,
            t.elapsed().as_secs_f64()
        );
        for m in [
            Method::Implicit,
            Method::Dp8,
            Method::Dopri5,
            Method::Dop853,
            Method::Auto,
        ] {
            for rtol in [1e-4, 1e-6, 1e-8, 1e-10] {
                s.solver.method = m;
                s.solver.rtol = rtol;
                let t = std::time::Instant::now();
                match s.simulate(&mut djkr::dynamics::NoObserver) {
                    Ok(r) => {
                        let (f, d, a) = outs(&r);
                        println!(
                            "X_b {xb:e} {m:?} rtol {rtol:e}: errF {:.2e} errdA {:.2e} erram {:.2e} steps {} rej {} rhs {} wall {:.4} s",
                            ((f - f0) / f0).abs(),
                            ((d - d0) / d0).abs(),
                            ((a - a0) / a0).abs(),
                            r.stats.steps,
                            r.stats.rejected,
                            r.stats.rhs_evals,
                            t.elapsed().as_secs_f64()
                        );
                    }
                    Err(e) => {
                        let e = e.to_string();
                        println!(
                            "X_b {xb:e} {m:?} rtol {rtol:e}: fails: {}",
                            &e[..e.len().min(120)]
                        );
                    }
                }
            }
        }
    }
}

/// Minimum wall time over repeats of 1 s at 400 Hz per method at rtol 1e-8 (robust to load).
/// Opt-in: `cargo test --release --test dynamics probe_min_wall -- --ignored --nocapture`.
#[test]
#[ignore]
fn probe_min_wall() {
    for m in [Method::Implicit, Method::Auto] {
        let mut s = djkr::dynamics::catalogue::vibrating_hold(5e-6, 400.0, 1.0);
        s.solver.method = m;
        let mut best = f64::INFINITY;
        let mut stats = None;
        for _ in 0..15 {
            let t = std::time::Instant::now();
            let r = s.simulate(&mut djkr::dynamics::NoObserver).unwrap();
            best = best.min(t.elapsed().as_secs_f64());
            stats = Some(r.stats);
        }
        println!("{m:?}: min wall {:.2} ms {:?}", best * 1e3, stats);
    }
}

/// Method comparison per scene type (min wall over repeats; basis of the `auto` rule).
/// Opt-in: `cargo test --release --test dynamics probe_methods_by_scene -- --ignored --nocapture`.
#[test]
#[ignore]
fn probe_methods_by_scene() {
    let mut scenes: Vec<(&str, Scenario)> = vec![];
    let mut s = scene();
    s.rig.law = gs();
    s.rig.holder = Holder::Rigid;
    s.stages = vec![stage(StageKind::Unload, 1e-7, Until::PullOff, None)];
    scenes.push(("gs_rigid_unload_0.1um_s", s));
    let mut s = scene();
    s.rig.law = gs();
    s.rig.sphere.mass = 0.0;
    s.stages = vec![stage(StageKind::Unload, 1e-7, Until::PullOff, None)];
    scenes.push(("gs_massless_unload_0.1um_s", s));
    let mut s = djkr::dynamics::catalogue::vibrating_hold(2e-6, 400.0, 0.2);
    s.rig.holder = Holder::Rigid;
    scenes.push(("rigid_hold_2um_400hz_0.2s", s));
    let mut s = djkr::dynamics::catalogue::paper_protocol(1e-3);
    s.rig.base = None;
    scenes.push(("protocol_no_shaker_1mm_s", s));
    scenes.push((
        "protocol_1mm_s",
        djkr::dynamics::catalogue::paper_protocol(1e-3),
    ));
    scenes.push((
        "vibrating_hold_1um_400hz_0.2s",
        djkr::dynamics::catalogue::vibrating_hold(1e-6, 400.0, 0.2),
    ));
    scenes.push((
        "vibrating_hold_5um_400hz_0.2s",
        djkr::dynamics::catalogue::vibrating_hold(5e-6, 400.0, 0.2),
    ));
    if let Ok(s) = djkr::scenario::parse::load_scenario(std::path::Path::new(
        "scenarios/paper-protocol-300hz.toml",
    )) {
        scenes.push(("paper-protocol-300hz.toml", s));
    }
    for (name, s0) in &scenes {
        for m in [
            Method::Implicit,
            Method::Dp8,
            Method::Dopri5,
            Method::Dop853,
            Method::Auto,
        ] {
            let mut s = s0.clone();
            s.solver.method = m;
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..3 {
                let t = std::time::Instant::now();
                let r = s.simulate(&mut djkr::dynamics::NoObserver);
                best = best.min(t.elapsed().as_secs_f64());
                last = Some(r);
            }
            match last.unwrap() {
                Ok(r) => println!(
                    "{name} {m:?}: {:.2} ms steps {} rhs {} pull-off {:.6e}",
                    best * 1e3,
                    r.stats.steps,
                    r.stats.rhs_evals,
                    r.pull_off.force
                ),
                Err(e) => println!("{name} {m:?}: fails: {}", &e.to_string()[..100]),
            }
        }
    }
}

/// `auto` takes the implicit method without inertia (rigid link), for a constant w and for
/// seeded contact formation, and DP8 for a GS sphere with mass; on the rigid link it gives the
/// same GS pull-off as Dopri5 and DP8.
#[test]
fn auto_rule_by_scene() {
    let mut s = scene();
    s.rig.law = gs();
    s.rig.holder = Holder::Rigid;
    s.stages = vec![stage(StageKind::Unload, 1e-7, Until::PullOff, None)];
    s.solver.method = Method::Auto;
    let (r, _) = run(&s);
    assert!(r.method.starts_with("implicit"), "{}", r.method);
    for m in [Method::Dopri5, Method::Dp8] {
        s.solver.method = m;
        let (rd, _) = run(&s);
        let rel = (r.pull_off.force - rd.pull_off.force).abs() / rd.pull_off.force.abs();
        assert!(rel < 1e-7, "auto vs {m:?} pull-off: {rel:e}");
    }
    let mut c = s.clone();
    c.rig.law = Law::Constant(ConstantW { w0: M.w0 });
    c.solver.method = Method::Auto;
    assert!(run(&c).0.method.starts_with("implicit"));
    let mut seeded = s.clone();
    seeded.rig.formation = ContactFormation::Seed(1e-5);
    seeded.solver.method = Method::Auto;
    assert!(run(&seeded).0.method.starts_with("implicit"));

    let mut s = scene();
    s.rig.law = gs();
    s.stages = vec![stage(StageKind::Unload, 1e-4, Until::PullOff, None)];
    s.solver.method = Method::Auto;
    let (r, _) = run(&s);
    assert!(r.method.starts_with("dp8"), "{}", r.method);
    assert!(r.detached);
}
