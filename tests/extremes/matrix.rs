//! The extremes matrix, shared by `tests/it/extremes.rs` (the reduced matrix, in the default
//! suite) and `examples/study_extremes.rs` (the full matrix, which writes `docs/extremes.md`).
//!
//! Every case finishes with physically valid output (finite numbers, a ≥ 0, F equal to the JKR
//! force of the reported a and δ) or a clear error (`SimError` / `ParamError` with a message);
//! none panics or hangs. Each case runs on its own thread under `catch_unwind`, with a step
//! budget and a wall-clock budget (`solver.max_steps`, `solver.max_wall_s`); the harness waits
//! at most budget + margin for it (a hang is reported with the case name, not waited on) and
//! checks the measured wall time is below that.
#![allow(dead_code)]

use crate::catalogue::{self, stage, vibrating_hold};
use djkr::scenario::*;
use djkr_core::adhesion::{ConstantW, GentSchultz, Law};
use djkr_core::dynamics::protocol::*;
use djkr_core::dynamics::Method;
use djkr_core::dynamics::{CycleRecord, Event, Observer, RunResult, Sample};
use djkr_core::imposed_area;
use djkr_core::material::Material;
use djkr_core::rig::{ContactFormation, Damping, DampingOn, Holder};
use std::f64::consts::PI;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc;
use std::time::{Duration, Instant};

pub const M: Material = Material::PAPER;

/// Scale of forces: |F0| = 3/2 π R w0 (N).
pub fn force_scale() -> f64 {
    M.static_pull_off_force().abs()
}

pub fn gs(n: f64) -> Law {
    Law::GentSchultz(GentSchultz {
        w0: M.w0,
        v0: GentSchultz::PAPER.v0,
        n,
    })
}

pub fn constant() -> Law {
    Law::Constant(ConstantW { w0: M.w0 })
}

/// What a case runs.
#[derive(Clone)]
pub enum Work {
    /// A time-domain scene.
    Time(Box<Scenario>),
    /// An imposed-area pull-off at (law, f, a_A).
    PullOff { law: Law, freq: f64, a_amp: f64 },
    /// One imposed-area cycle at (law, f, a_m, a_A).
    Cycle {
        law: Law,
        freq: f64,
        a_mean: f64,
        a_amp: f64,
    },
}

/// Whether a clear error is an acceptable outcome of the case.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Expect {
    /// Must run to completion with valid output.
    Ok,
    /// Must end with a clear error (an impossible setup).
    Error,
    /// Valid output or a clear error.
    Either,
}

#[derive(Clone)]
pub struct Case {
    name: String,
    method: &'static str,
    work: Work,
    expect: Expect,
    budget_s: f64,
}

/// How a case ended.
#[derive(Debug)]
pub enum Outcome {
    /// Valid output; key numbers.
    Ok(String),
    /// A clear error; its message.
    ClearError(String),
    /// A panic, hang, invalid output or an error without a message.
    Fail(String),
}

/// Checks every sample as the run produces it.
#[derive(Default)]
pub struct Checker {
    samples: u64,
    min_a: f64,
    bad: Option<String>,
}

pub fn sample_problem(s: &Sample) -> Option<String> {
    let fields = [
        ("t", s.t),
        ("x_s", s.x_s),
        ("v_s", s.v_s),
        ("x_b", s.x_b),
        ("x_k", s.x_k),
        ("delta", s.delta),
        ("a", s.a),
        ("a_dot", s.a_dot),
        ("force", s.force),
        ("g", s.g),
        ("w", s.w),
    ];
    if let Some((k, v)) = fields.iter().find(|(_, v)| !v.is_finite()) {
        return Some(format!("non-finite {k} = {v} at t = {:e}", s.t));
    }
    if s.a < 0.0 {
        return Some(format!("a = {:e} < 0 at t = {:e}", s.a, s.t));
    }
    // Independent check of eq. (32): F = (K a/2)(3δ − a²/R) in contact, 0 out of contact.
    let f_jkr = if s.a > 0.0 {
        0.5 * M.k * s.a * (3.0 * s.delta - s.a * s.a / M.r)
    } else {
        0.0
    };
    let tol = 1e-9 * (f_jkr.abs() + force_scale());
    if (s.force - f_jkr).abs() > tol {
        return Some(format!(
            "force {:e} N differs from the JKR force {:e} N of a = {:e}, delta = {:e} at t = {:e}",
            s.force, f_jkr, s.a, s.delta, s.t
        ));
    }
    None
}

impl Observer for Checker {
    fn sample(&mut self, s: &Sample) -> bool {
        if self.samples == 0 {
            self.min_a = f64::INFINITY;
        }
        self.samples += 1;
        self.min_a = self.min_a.min(s.a);
        if self.bad.is_none() {
            self.bad = sample_problem(s);
        }
        true
    }
    fn event(&mut self, e: &Event) {
        if self.bad.is_none() {
            self.bad = sample_problem(&e.state).map(|p| format!("event {:?}: {p}", e.kind));
        }
    }
    fn cycle(&mut self, c: &CycleRecord) {
        let v = [
            c.force_mean,
            c.force_sin,
            c.force_cos,
            c.delta_mean,
            c.delta_sin,
            c.delta_cos,
            c.a_mean,
            c.a_sin,
            c.a_cos,
            c.energy_start,
            c.energy_end,
        ];
        if self.bad.is_none() && (v.iter().any(|x| !x.is_finite()) || c.a_mean < 0.0) {
            self.bad = Some(format!("cycle {} has invalid means {v:?}", c.index));
        }
    }
}

pub fn run_time(s: &Scenario) -> Outcome {
    let mut chk = Checker::default();
    match s.simulate(&mut chk) {
        Ok(r) => {
            if let Some(p) = chk.bad {
                return Outcome::Fail(format!("invalid output: {p}"));
            }
            if let Some(p) = sample_problem(&r.final_state) {
                return Outcome::Fail(format!("invalid final state: {p}"));
            }
            // The amplification is defined for a tensile pull-off force only (a compressive or
            // zero one has none: NaN, never a negative ratio).
            if !r.pull_off.force.is_finite()
                || r.pull_off.amplification.is_finite() != r.pull_off.is_tensile()
            {
                return Outcome::Fail(format!("invalid pull-off summary {:?}", r.pull_off));
            }
            Outcome::Ok(summarise(&r, &chk))
        }
        Err(e) => {
            let msg = e.to_string();
            if msg.trim().is_empty() {
                Outcome::Fail("error without a message".into())
            } else {
                Outcome::ClearError(msg)
            }
        }
    }
}

pub fn summarise(r: &RunResult, chk: &Checker) -> String {
    let count = |k: djkr_core::dynamics::EventKind| r.events.iter().filter(|e| e.kind == k).count();
    use djkr_core::dynamics::EventKind as K;
    // Numbers that do not depend on the output cadence (explicit methods report samples at
    // their macro-step ends only): the final state, event counts, the last cycle's mean force.
    let f = &r.final_state;
    let mut s = format!(
        "{} rhs; final a {:.4} mm, F {:.4} mN; min sampled a {:.3} mm",
        r.stats.rhs_evals,
        f.a * 1e3,
        f.force * 1e3,
        chk.min_a * 1e3
    );
    let (loss, imp) = (count(K::ContactLoss), count(K::Impact));
    if loss + imp > 0 {
        s += &format!("; {loss} losses, {imp} impacts");
    }
    if r.detached {
        s += &format!("; pull-off {:.4} mN", r.pull_off.force * 1e3);
    } else if let Some(c) = r.last_cycle.as_ref() {
        s += &format!("; last-cycle ⟨F⟩ {:.4} mN", c.force_mean * 1e3);
    }
    if let Some(i) = r.method.find(" steps implicit") {
        let n = r.method[..i].rsplit(' ').next().unwrap_or("");
        s += &format!("; {n} steps implicit");
    }
    s
}

pub fn run_imposed(w: &Work) -> Outcome {
    let check_cycle = |c: &imposed_area::Cycle| -> Option<String> {
        let v = [
            c.a_mean,
            c.harmonics.delta_mean,
            c.harmonics.delta_amp,
            c.harmonics.force_mean,
            c.harmonics.force_sin,
            c.harmonics.force_cos,
            c.force_slope,
            c.contact_fraction,
        ];
        if v.iter().any(|x| !x.is_finite()) {
            return Some(format!("non-finite cycle {c:?}"));
        }
        if c.a_mean < 0.0 || !(0.0..=1.0).contains(&c.contact_fraction) {
            return Some(format!(
                "a_mean = {:e}, contact fraction {}",
                c.a_mean, c.contact_fraction
            ));
        }
        None
    };
    let res = match w {
        Work::PullOff { law, freq, a_amp } => {
            imposed_area::pull_off(&M, law, 2.0 * PI * freq, *a_amp).map(|p| {
                check_cycle(&p.cycle)
                    .or_else(|| {
                        (!(p.force.is_finite() && p.amplification.is_finite() && p.force < 0.0))
                            .then(|| format!("pull-off force {} N", p.force))
                    })
                    .map_or_else(
                        || {
                            Outcome::Ok(format!(
                                "amplification {:.4}; a_m,po {:.4} mm; contact {:.0} %",
                                p.amplification,
                                p.cycle.a_mean * 1e3,
                                p.cycle.contact_fraction * 100.0
                            ))
                        },
                        Outcome::Fail,
                    )
            })
        }
        Work::Cycle {
            law,
            freq,
            a_mean,
            a_amp,
        } => imposed_area::cycle(&M, law, 2.0 * PI * freq, *a_mean, *a_amp).map(|c| {
            check_cycle(&c).map_or_else(
                || {
                    Outcome::Ok(format!(
                        "⟨F⟩ {:.4} mN; ⟨a⟩ {:.4} mm; contact {:.0} %",
                        c.harmonics.force_mean * 1e3,
                        c.a_mean * 1e3,
                        c.contact_fraction * 100.0
                    ))
                },
                Outcome::Fail,
            )
        }),
        Work::Time(_) => unreachable!("time-domain work goes to run_time"),
    };
    match res {
        Ok(o) => o,
        Err(e) if !e.to_string().trim().is_empty() => Outcome::ClearError(e.to_string()),
        Err(_) => Outcome::Fail("error without a message".into()),
    }
}

/// Run one case on its own thread: a panic is caught, a hang is reported after budget + margin.
pub fn run_case(case: &Case) -> (Outcome, f64) {
    let (tx, rx) = mpsc::channel();
    let work = case.work.clone();
    let start = Instant::now();
    let spawned = std::thread::Builder::new()
        .name(case.name.clone())
        .spawn(move || {
            let out = catch_unwind(AssertUnwindSafe(|| match &work {
                Work::Time(s) => run_time(s),
                other => run_imposed(other),
            }));
            let out = out.unwrap_or_else(|p| {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                Outcome::Fail(format!("panic: {msg}"))
            });
            let _ = tx.send(out);
        });
    if let Err(e) = spawned {
        return (Outcome::Fail(format!("could not start thread: {e}")), 0.0);
    }
    let limit = case.budget_s * 1.5 + 2.0;
    match rx.recv_timeout(Duration::from_secs_f64(limit)) {
        Ok(o) => (o, start.elapsed().as_secs_f64()),
        Err(_) => (
            Outcome::Fail(format!("hang: no result within {limit:.1} s")),
            start.elapsed().as_secs_f64(),
        ),
    }
}

pub fn with(mut s: Scenario, method: Method, budget_s: f64) -> Scenario {
    s.solver.method = method;
    s.solver.max_wall_s = budget_s;
    s.solver.max_steps = 20_000_000;
    s
}

/// The time-domain scenes: (name, scene, expectation), `long` for the full matrix's durations.
pub fn scenes(long: bool) -> Vec<(String, Scenario, Expect)> {
    // Vibrating hold for a number of cycles at f (Hz) with base amplitude xb (m).
    let cycles = if long { 1000.0 } else { 50.0 };
    let hold = |xb: f64, f: f64| vibrating_hold(xb, f, cycles / f);
    let mut v: Vec<(String, Scenario, Expect)> = Vec::new();
    v.push((
        "GS n = 0.531, 400 Hz, X_b 2 µm (baseline)".into(),
        hold(2e-6, 400.0),
        Expect::Ok,
    ));
    // Impacts every cycle: impacts.toml's rig (m 0.25 kg, k 2000 N/m, c 10 N s/m, 300 Hz).
    let impacts = |xb: f64, law: Law, formation: ContactFormation| {
        catalogue::impacts(xb, law, formation, (if long { 60.0 } else { 10.0 }) / 300.0)
    };
    let ns: &[f64] = if long {
        &[0.05, 0.1, 0.3, 1.0, 1.2, 1.5]
    } else {
        &[0.05, 0.1, 1.0, 1.5]
    };
    for &n in ns {
        let mut s = hold(2e-6, 400.0);
        s.rig.law = gs(n);
        v.push((format!("GS n = {n}, 400 Hz, X_b 2 µm"), s, Expect::Ok));
        // The same exponent with impacts every cycle.
        if long {
            let mut s = impacts(400e-6, gs(n), ContactFormation::JumpIn);
            s.rig.law = gs(n);
            v.push((
                format!("impacts: GS n = {n}, X_b 400 µm, 300 Hz"),
                s,
                Expect::Ok,
            ));
        }
    }
    // Peak crack speeds ~1e6 v0: the paper's law with v0 shrunk by 1e6, and a large amplitude.
    let mut s = hold(20e-6, 400.0);
    s.rig.law = Law::GentSchultz(GentSchultz {
        w0: M.w0,
        v0: GentSchultz::PAPER.v0 * 1e-6,
        n: GentSchultz::PAPER.n,
    });
    v.push(("GS v0 × 1e-6 (v/v0 ≳ 1e6), X_b 20 µm".into(), s, Expect::Ok));
    v.push((
        "impacts: GS, X_b 400 µm, 300 Hz, jump-in".into(),
        impacts(400e-6, gs(0.531), ContactFormation::JumpIn),
        Expect::Ok,
    ));
    v.push((
        "impacts: GS, X_b 400 µm, 300 Hz, seed 10 µm".into(),
        impacts(400e-6, gs(0.531), ContactFormation::Seed(1e-5)),
        Expect::Ok,
    ));
    v.push((
        "impacts: constant w, X_b 40 µm, 300 Hz".into(),
        impacts(40e-6, constant(), ContactFormation::JumpIn),
        Expect::Ok,
    ));
    let mut s = hold(2e-6, 400.0);
    s.rig.damping = None;
    v.push(("c = 0".into(), s, Expect::Ok));
    let mut s = hold(2e-6, 400.0);
    s.rig.holder = Holder::None;
    s.initial = Initial::Preload(s.rig.sphere.mass * s.rig.sphere.gravity);
    v.push(("k = 0 (no holder, preload = weight)".into(), s, Expect::Ok));
    let mut s = hold(2e-6, 400.0);
    s.rig.holder = Holder::Spring { stiffness: 1e6 };
    v.push(("k = 1e6 N/m".into(), s, Expect::Ok));
    let masses: &[f64] = if long {
        &[1e-5, 1e-4, 0.1, 1.0]
    } else {
        &[1e-5, 1.0]
    };
    for &mass in masses {
        let mut s = hold(2e-6, 400.0);
        s.rig.sphere.mass = mass;
        v.push((format!("m = {mass} kg"), s, Expect::Ok));
    }
    let mut s = hold(2e-6, 400.0);
    s.rig.sphere.mass = 0.0;
    s.rig.damping = None;
    v.push(("m = 0 (quasi-static), c = 0".into(), s, Expect::Ok));
    let mut s = hold(2e-6, 400.0);
    s.rig.sphere.mass = 0.0;
    v.push(("m = 0 with damping (unsupported)".into(), s, Expect::Error));
    // Compressive edge at impact: a seed contact hit at 10 mm/s (δ ≫ a²/R just after impact).
    for (label, formation) in [
        ("seed 1 µm", ContactFormation::Seed(1e-6)),
        ("jump-in", ContactFormation::JumpIn),
    ] {
        let mut s = hold(0.0, 400.0);
        s.rig.base = None;
        s.initial = Initial::Gap(20e-6);
        s.rig.formation = formation;
        s.stages = vec![
            stage(StageKind::Approach, 10e-3, Until::Preload(0.05), None),
            stage(StageKind::Hold, 0.0, Until::Duration(0.01), None),
        ];
        v.push((
            format!("compressive edge: impact at 10 mm/s, {label}"),
            s,
            Expect::Ok,
        ));
    }
    let mut s = hold(2e-6, 400.0);
    s.rig.law = constant();
    v.push(("constant w, 400 Hz, X_b 2 µm".into(), s, Expect::Ok));
    let mut s = vibrating_hold(10e-6, 1.0, if long { 3.0 } else { 1.0 });
    s.rig.law = gs(0.531);
    v.push(("1 Hz, X_b 10 µm".into(), s, Expect::Ok));
    v.push(("10 kHz, X_b 0.2 µm".into(), hold(0.2e-6, 1e4), Expect::Ok));
    let mut s = hold(2e-6, 400.0);
    s.rig.damping = Some(Damping {
        c: 0.02,
        on: DampingOn::Contact,
    });
    v.push(("contact damping c δ̇ (eq. 3)".into(), s, Expect::Ok));
    let mut s = hold(2e-6, 400.0);
    s.rig.holder = Holder::Rigid;
    s.rig.damping = None;
    v.push(("rigid link, base 2 µm".into(), s, Expect::Ok));
    if long {
        for f in [10.0, 100.0, 1000.0] {
            v.push((format!("{f} Hz, X_b 2 µm"), hold(2e-6, f), Expect::Ok));
        }
        // Pull-off under vibration (the paper's protocol, shortened), and at 1 kHz with impacts.
        let mut s = catalogue::light_protocol(1e-3);
        s.stages[1].until = Until::Duration(0.05);
        s.stages[2].until = Until::Duration(0.1);
        v.push(("paper protocol, unload 1 mm/s".into(), s, Expect::Ok));
    }
    v
}

pub fn imposed_cases(long: bool) -> Vec<(String, Work, Expect)> {
    let mut v = Vec::new();
    let ns: &[f64] = if long {
        &[0.05, 0.1, 0.3, 0.531, 1.0, 1.5]
    } else {
        &[0.05, 0.531, 1.5]
    };
    let ratios: &[f64] = if long {
        &[1e-2, 1.0, 1e2, 1e4, 1e6]
    } else {
        &[1e-2, 1e2, 1e6]
    };
    let freqs: &[f64] = if long { &[1.0, 400.0, 1e4] } else { &[400.0] };
    for &n in ns {
        for &r in ratios {
            for &f in freqs {
                let a_amp = r * GentSchultz::PAPER.v0 / (2.0 * PI * f);
                v.push((
                    format!("pull-off n = {n}, v_max/v0 = {r:e}, {f} Hz (a_A {a_amp:.2e} m)"),
                    Work::PullOff {
                        law: gs(n),
                        freq: f,
                        a_amp,
                    },
                    Expect::Ok,
                ));
            }
        }
    }
    for (label, a_mean) in [
        ("a_A > a_m (a_m = 0.3 a_A)", 0.3e-3),
        ("a_A ≫ a_m (a_m = −0.99 a_A)", -0.99e-3),
        ("a_m = a_A (touching)", 1e-3),
    ] {
        for (ln, law) in [("GS n = 0.531", gs(0.531)), ("GS n = 1.5", gs(1.5))] {
            v.push((
                format!("cycle {label}, {ln}, 400 Hz, a_A 1 mm"),
                Work::Cycle {
                    law,
                    freq: 400.0,
                    a_mean,
                    a_amp: 1e-3,
                },
                Expect::Ok,
            ));
        }
    }
    for f in [1.0, 1e4] {
        v.push((
            format!("pull-off constant w, {f} Hz, a_A 0.5 mm"),
            Work::PullOff {
                law: constant(),
                freq: f,
                a_amp: 0.5e-3,
            },
            Expect::Ok,
        ));
    }
    v.push((
        "cycle a_m < −a_A (invalid input)".into(),
        Work::Cycle {
            law: gs(0.531),
            freq: 400.0,
            a_mean: -2e-3,
            a_amp: 1e-3,
        },
        Expect::Error,
    ));
    v
}

pub fn matrix(long: bool) -> Vec<Case> {
    let budget = if long { 60.0 } else { 6.0 };
    let mut cases = Vec::new();
    let methods: &[(&str, Method)] = &[
        ("auto", Method::Auto),
        ("implicit", Method::Implicit),
        ("dp8", Method::Dp8),
        ("dopri5", Method::Dopri5),
        ("dop853", Method::Dop853),
    ];
    for (name, scene, expect) in scenes(long) {
        for &(mname, method) in methods {
            // An explicit method may refuse a scene (G ≤ 0, rate-independent law): a clear error.
            let expect = match (expect, method) {
                (Expect::Ok, Method::Dp8 | Method::Dopri5 | Method::Dop853) => Expect::Either,
                (e, _) => e,
            };
            cases.push(Case {
                name: name.clone(),
                method: mname,
                work: Work::Time(Box::new(with(scene.clone(), method, budget))),
                expect,
                budget_s: budget,
            });
        }
    }
    for (name, work, expect) in imposed_cases(long) {
        cases.push(Case {
            name,
            method: "imposed-area",
            work,
            expect,
            budget_s: budget,
        });
    }
    cases
}

pub fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// What a run of the matrix found.
pub struct Report {
    /// One line per failed case (panic, hang, invalid output, unexpected outcome, over budget).
    pub failures: Vec<String>,
    /// Number of cases.
    pub cases: usize,
    /// Wall time of the whole matrix (s).
    pub wall_s: f64,
    /// Markdown: one row per time-domain scene with each method's outcome, then a line for the
    /// imposed-area cases.
    pub summary: String,
    /// Markdown: every case.
    pub table: String,
}

/// Run the matrix (`long`: the full one) and report.
pub fn run_matrix(long: bool) -> Report {
    let cases = matrix(long);
    let mut failures = Vec::new();
    let mut table = String::from(
        "| case | method | outcome | key numbers / message | wall (s) |\n|---|---|---|---|---|\n",
    );
    let t0 = Instant::now();
    let mut done: Vec<(String, &str, &str, String, f64)> = Vec::new();
    for case in &cases {
        let (out, wall) = run_case(case);
        let (word, text) = match &out {
            Outcome::Ok(t) => ("ok", t.clone()),
            Outcome::ClearError(m) => ("clear error", m.clone()),
            Outcome::Fail(m) => ("FAIL", m.clone()),
        };
        done.push((case.name.clone(), case.method, word, text.clone(), wall));
        let short: String = text.chars().take(220).collect();
        table += &format!(
            "| {} | {} | {} | {} | {:.3} |\n",
            cell(&case.name),
            case.method,
            word,
            cell(&short),
            wall
        );
        let verdict = match (&out, case.expect) {
            (Outcome::Fail(m), _) => Some(m.clone()),
            (Outcome::ClearError(m), Expect::Ok) => Some(format!("expected valid output: {m}")),
            (Outcome::Ok(t), Expect::Error) => Some(format!("expected a clear error, got {t}")),
            _ => None,
        };
        if wall > case.budget_s * 1.5 + 1.0 {
            failures.push(format!(
                "{} [{}]: wall {wall:.2} s exceeds budget {} s + margin",
                case.name, case.method, case.budget_s
            ));
        }
        if let Some(v) = verdict {
            failures.push(format!("{} [{}]: {v}", case.name, case.method));
        }
    }
    Report {
        failures,
        cases: cases.len(),
        wall_s: t0.elapsed().as_secs_f64(),
        summary: summary(&done),
        table,
    }
}

/// The short reason of a clear error.
pub fn reason(msg: &str) -> &'static str {
    if msg.contains("G <= 0") {
        "G ≤ 0"
    } else if msg.contains("stiffness") {
        "stiffness"
    } else if msg.contains("rate-independent") {
        "rate-indep. law"
    } else if msg.contains("wall-clock budget") {
        "wall budget"
    } else if msg.contains("step budget") {
        "step budget"
    } else if msg.contains("damping is not supported") {
        "unsupported setup"
    } else if msg.contains("must") {
        "invalid input"
    } else {
        "other"
    }
}

/// One row per time-domain scene with the outcome of each method, and a line for the
/// imposed-area cases: the condensed table of the README.
pub fn summary(done: &[(String, &str, &str, String, f64)]) -> String {
    let mut out = String::from(
        "| scene | auto | implicit | dp8 | dopri5 | dop853 | auto: key numbers |\n|---|---|---|---|---|---|---|\n",
    );
    let mut names: Vec<&str> = Vec::new();
    for d in done.iter().filter(|d| d.1 != "imposed-area") {
        if !names.contains(&d.0.as_str()) {
            names.push(&d.0);
        }
    }
    for name in names {
        let cell_of = |m: &str| {
            done.iter()
                .find(|d| d.0 == name && d.1 == m)
                .map_or("—".to_string(), |d| match d.2 {
                    "ok" => format!("ok {:.3} s", d.4),
                    "clear error" => format!("error: {}", reason(&d.3)),
                    _ => "**FAIL**".to_string(),
                })
        };
        let key = done
            .iter()
            .find(|d| d.0 == name && d.1 == "auto")
            .map_or(String::new(), |d| {
                if d.2 == "ok" {
                    d.3.clone()
                } else {
                    d.3.chars().take(100).collect()
                }
            });
        out += &format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            cell(name),
            cell_of("auto"),
            cell_of("implicit"),
            cell_of("dp8"),
            cell_of("dopri5"),
            cell_of("dop853"),
            cell(&key)
        );
    }
    let ia: Vec<_> = done.iter().filter(|d| d.1 == "imposed-area").collect();
    let count = |w: &str| ia.iter().filter(|d| d.2 == w).count();
    let wall = ia.iter().map(|d| d.4).fold(0.0, f64::max);
    out += &format!(
        "\nImposed-area cases: {} — {} ok, {} clear errors ({}), {} failures; slowest {:.3} s.\n",
        ia.len(),
        count("ok"),
        count("clear error"),
        ia.iter()
            .filter(|d| d.2 == "clear error")
            .map(|d| cell(&d.0))
            .collect::<Vec<_>>()
            .join("; "),
        count("FAIL"),
        wall
    );
    out
}
