//! Time-domain simulator against independent references (closed forms, JKR limits, balance laws).

use djkr::adhesion::{ConstantW, GentSchultz, Law};
use djkr::dynamics::{simulate, EventKind, Recorder, RunResult};
use djkr::jkr;
use djkr::material::Material;
use djkr::scenario::*;
use std::f64::consts::PI;

const M: Material = Material::PAPER;

fn scene() -> Scenario {
    Scenario {
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
    }
}

fn stage(kind: StageKind, speed: f64, until: Until, vibration: Option<bool>) -> Stage {
    Stage {
        kind,
        speed,
        until,
        vibration,
        max_duration: 1e7,
    }
}

fn run(s: &Scenario) -> (RunResult, Recorder) {
    let mut rec = Recorder::default();
    let r = simulate(s, &mut rec).unwrap_or_else(|e| panic!("{e}"));
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
    s.sphere.gravity = 9.81;
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
    for rtol in [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11] {
        let mut s = scene();
        s.solver.rtol = rtol;
        s.sphere.gravity = 9.81;
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
    s.holder = Holder::Rigid;
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
