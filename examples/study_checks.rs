//! The simulator against independent references, measured: the numbers behind README's "Checked
//! against independent references" table, which `tests/it/dynamics.rs` and `tests/it/restart.rs`
//! assert (with a margin) on the same catalogue scenes.
//!
//!   cargo run --release --example study_checks
//!
//! Writes `docs/studies/checks.md`. About 10 s on 2 cores.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::{cycle_balances, summarise_balances};
use common::{sci, Args, Table};
use djkr::scenario::Scenario;
use djkr_core::dynamics::protocol::{Initial, Until};
use djkr_core::dynamics::Method;
use djkr_core::dynamics::{EventKind, Recorder, RunResult};
use djkr_core::jkr;
use djkr_core::material::Material;
use std::fmt::Write as _;

const M: Material = Material::PAPER;

fn run(s: &Scenario) -> (RunResult, Recorder) {
    let mut rec = Recorder::default();
    match s.simulate(&mut rec) {
        Ok(r) => (r, rec),
        Err(e) => {
            eprintln!("{}: {e}", s.source_name);
            std::process::exit(1)
        }
    }
}

fn first(r: &RunResult, k: EventKind) -> Option<djkr_core::dynamics::Event> {
    r.events.iter().find(|e| e.kind == k).copied()
}

fn main() {
    let args = Args::parse(
        "study_checks",
        "docs/studies",
        "The simulator against independent references: balances, JKR limits, closed forms, \
         agreement between methods. Writes checks.md.",
    );
    let mut doc = args.header("Time-domain simulator: checks against independent references");
    doc += "Each section names the catalogue scene (`tests/catalogue/mod.rs`) and the test that asserts \
            the claim with a margin over the value measured here.\n\n";

    // ---------------------------------------------------------------------------------------
    doc += "## Per-cycle balances\n\n";
    doc += "Momentum: eq. (30) averaged over a base period, ⟨F⟩ − m g − ⟨F_holder⟩ = −(m Δv + c Δx_s)/T, \
            residual relative to the run's largest first harmonic |F1|. Energy: ΔE = W_base + W_holder − D_damping − \
            D_adhesion + Σ E_jump, where E_jump is the step of the contact energy at an impact (a jump-in \
            releases 0.6 π w0 a_J²) or a contact loss (the contact's final collapse, faster than any \
            step, takes the elastic energy still in it), residual relative to the run's largest per-cycle work or dissipation term (not each cycle's own: in a cycle with little net work, such as a ringing dwell, the integration error is set by the scale of the motion). Both from the \
            quadrature states carried with the solution (`catalogue::cycle_balances`). Worst over every \
            cycle of the scene; asserted by `cycle_balances_hold` in `tests/it/dynamics.rs`.\n\n";
    let scenes = catalogue::cycle_balance_scenes().unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    let mut t = Table::new(&[
        "scene",
        "rtol",
        "method",
        "cycles",
        "impacts",
        "worst momentum",
        "worst energy",
    ]);
    let mut worst_all = (0.0f64, 0.0f64);
    for (name, s0) in &scenes {
        for rtol in [s0.solver.rtol, 1e-10] {
            let mut s = s0.clone();
            s.solver.rtol = rtol;
            let (r, rec) = run(&s);
            let b = summarise_balances(&cycle_balances(
                &s.rig,
                &rec.cycles,
                &rec.samples,
                &rec.events,
            ));
            if rtol == s0.solver.rtol {
                worst_all.0 = worst_all.0.max(b.momentum.unwrap_or(0.0));
                worst_all.1 = worst_all.1.max(b.energy);
            }
            let impacts = r
                .events
                .iter()
                .filter(|e| e.kind == EventKind::Impact)
                .count();
            let method: String = r
                .method
                .split(['(', ':', ';'])
                .next()
                .unwrap_or("")
                .trim()
                .into();
            t.row([
                name.to_string(),
                sci(rtol),
                method,
                rec.cycles.len().to_string(),
                impacts.to_string(),
                b.momentum.map_or("n/a".into(), sci),
                sci(b.energy),
            ]);
        }
    }
    doc += &t.markdown();
    let _ = writeln!(
        doc,
        "\nAt each scene's own tolerance (rtol 1e-8 or 1e-9): momentum balance within {}, energy \
         balance within {}.\n",
        sci(worst_all.0),
        sci(worst_all.1)
    );

    // ---------------------------------------------------------------------------------------
    doc += "## Elastic JKR limits (constant w0)\n\n";
    let mut t = Table::new(&["scene", "quantity", "simulated / closed form − 1", "test"]);
    let f0 = jkr::load_controlled_pull_off_force(&M, M.w0);
    let (r, _) = run(&catalogue::load_controlled_unload());
    t.row([
        "`load_controlled_unload` (1 g on 10 N/m)",
        "most tensile force vs −3/2 πRw0",
        &sci(r.pull_off.force / f0 - 1.0),
        "`soft_spring_pull_off_is_load_controlled`",
    ]);
    let (r, _) = run(&catalogue::displacement_controlled_unload());
    let a_dc = jkr::displacement_controlled_pull_off_radius(&M, M.w0);
    let f_dc = jkr::displacement_controlled_pull_off_force(&M, M.w0);
    let loss = first(&r, EventKind::ContactLoss).expect("contact loss");
    t.row([
        "`displacement_controlled_unload` (rigid link)".to_string(),
        "most tensile force vs −3/2 πRw0".into(),
        sci(r.pull_off.force / f0 - 1.0),
        "`rigid_link_pull_off_is_displacement_controlled`".into(),
    ]);
    t.row([
        "".to_string(),
        "radius at contact loss vs a³ = πwR²/(6K)".into(),
        sci(loss.state.a / a_dc - 1.0),
        "".into(),
    ]);
    t.row([
        "".to_string(),
        "force at contact loss vs −5/6 πRw".into(),
        sci(loss.state.force / f_dc - 1.0),
        "".into(),
    ]);
    for k in [10.0, 1e7] {
        let (r, _) = run(&catalogue::massless_unload(k));
        let loss = first(&r, EventKind::ContactLoss).expect("contact loss");
        let (what, reference) = if k < 1e3 {
            ("force at contact loss vs −3/2 πRw0", f0)
        } else {
            ("force at contact loss vs −5/6 πRw", f_dc)
        };
        t.row([
            format!("`massless_unload({k:e} N/m)`"),
            "most tensile force vs −3/2 πRw0".into(),
            sci(r.pull_off.force / f0 - 1.0),
            "`massless_sphere_quasi_static_pull_off`".into(),
        ]);
        t.row([
            "".to_string(),
            what.into(),
            sci(loss.state.force / reference - 1.0),
            "".into(),
        ]);
    }
    doc += &t.markdown();

    // ---------------------------------------------------------------------------------------
    doc += "\n## Free flight and impact against the closed form\n\n";
    let (mut s, osc) = catalogue::free_flight(5e-3, 2e-3, 0.5);
    s.solver.rtol = 1e-10;
    let (_, rec) = run(&s);
    let worst = rec
        .samples
        .iter()
        .map(|x| (x.x_s - osc.position(x.t)).abs())
        .fold(0.0, f64::max);
    let _ = writeln!(
        doc,
        "`free_flight(5 mm, 2 mm/s, 0.5 s)` at rtol 1e-10: worst position error {} m over {} \
         samples (`free_flight_matches_ramp_oscillator`).\n",
        sci(worst),
        rec.samples.len()
    );
    let mut t = Table::new(&["rtol", "event_tol (s)", "impact time error (s)", "steps"]);
    let (s0, osc) = catalogue::free_flight(2e-5, 2e-3, 0.1);
    let t_ref = osc.impact_time();
    for (rtol, etol) in [(1e-6, 1e-8), (1e-8, 1e-10), (1e-10, 1e-13)] {
        let mut s = s0.clone();
        s.solver.rtol = rtol;
        s.solver.event_tol = etol;
        let (r, _) = run(&s);
        let imp = first(&r, EventKind::Impact).expect("impact");
        t.row([
            sci(rtol),
            sci(etol),
            sci((imp.time - t_ref).abs()),
            r.stats.steps.to_string(),
        ]);
    }
    let _ = writeln!(
        doc,
        "`free_flight(20 µm, 2 mm/s, 0.1 s)`: impact at {t_ref:.9} s by the closed form \
         (`impact_time_converges_to_closed_form`).\n"
    );
    doc += &t.markdown();

    // ---------------------------------------------------------------------------------------
    doc += "\n## Gent–Schultz rate effect vanishes as the unload slows\n\n";
    let mut t = Table::new(&[
        "unload speed (m/s)",
        "amplification F_po / (−3/2 πRw0)",
        "steps",
    ]);
    for v in [1e-7, 1e-9, 1e-11] {
        let (r, _) = run(&catalogue::gs_rigid_unload(v));
        t.row([
            sci(v),
            format!("{:.4}", r.pull_off.force / f0),
            r.stats.steps.to_string(),
        ]);
    }
    doc += "`gs_rigid_unload(v)`: tends to the static 1 (`gs_rigid_unload_rate_effect_vanishes_slowly`).\n\n";
    doc += &t.markdown();

    // ---------------------------------------------------------------------------------------
    doc += "\n## The contact-loss radius\n\n";
    doc += "Contact loss is declared at a_floor = min(10⁻³ a_J, seed/10); the seed only sets \
            a_floor here (no impact happens). `gs_rigid_unload(0.1 µm/s)`, implicit method \
            (`contact_loss_radius_has_negligible_effect`):\n\n";
    let mut t = Table::new(&[
        "formation",
        "a_floor (m)",
        "loss time (s)",
        "Δ loss time (s)",
        "Δ pull-off force (rel.)",
    ]);
    let a_j = jkr::jump_in_radius(&M, M.w0);
    let mut base: Option<(f64, f64)> = None;
    for (label, formation, floor) in [
        (
            "jump-in",
            djkr_core::rig::ContactFormation::JumpIn,
            1e-3 * a_j,
        ),
        (
            "seed 1 µm",
            djkr_core::rig::ContactFormation::Seed(1e-6),
            1e-7,
        ),
        (
            "seed 10 nm",
            djkr_core::rig::ContactFormation::Seed(1e-8),
            1e-9,
        ),
    ] {
        let mut s = catalogue::gs_rigid_unload(1e-7);
        s.rig.formation = formation;
        s.solver.method = Method::Implicit;
        let (r, _) = run(&s);
        let loss = first(&r, EventKind::ContactLoss).expect("contact loss");
        let (t0, f0) = *base.get_or_insert((loss.time, r.pull_off.force));
        t.row([
            label.to_string(),
            sci(floor),
            format!("{:.6}", loss.time),
            sci(loss.time - t0),
            sci((r.pull_off.force - f0) / f0.abs()),
        ]);
    }
    doc += &t.markdown();

    // ---------------------------------------------------------------------------------------
    doc += "\n## Agreement between methods\n\n";
    let methods = [Method::Implicit, Method::Dp8, Method::Dopri5];
    let mut cyc = Vec::new();
    for m in methods {
        let mut s = catalogue::vibrating_hold(2e-6, 300.0, 0.02);
        s.solver.method = m;
        s.solver.rtol = 1e-10;
        let (_, rec) = run(&s);
        cyc.push(*rec.cycles.last().expect("cycles"));
    }
    let mut t = Table::new(&[
        "method vs implicit",
        "Δ⟨F⟩ / |F_sin|",
        "δ_sin ratio − 1",
        "a_sin ratio − 1",
    ]);
    for (m, c) in methods.iter().zip(&cyc).skip(1) {
        let a = cyc[0];
        t.row([
            format!("{m}"),
            sci((a.force_mean - c.force_mean).abs() / a.force_sin.abs()),
            sci((c.delta_sin / a.delta_sin - 1.0).abs()),
            sci((c.a_sin / a.a_sin - 1.0).abs()),
        ]);
    }
    doc += "Last cycle of `vibrating_hold(2 µm, 300 Hz, 0.02 s)` at rtol 1e-10 \
            (`methods_agree_under_vibration`):\n\n";
    doc += &t.markdown();
    let mut t = Table::new(&[
        "method",
        "rtol 1e-6",
        "rtol 1e-8",
        "rtol 1e-10",
        "vs implicit at 1e-10",
    ]);
    let mut at10 = Vec::new();
    for m in methods {
        let mut row = vec![format!("{m}")];
        let mut last = 0.0;
        for rtol in [1e-6, 1e-8, 1e-10] {
            let mut s = catalogue::gs_rigid_unload(1e-7);
            s.solver.method = m;
            s.solver.rtol = rtol;
            let (r, _) = run(&s);
            last = r.pull_off.force / f0;
            row.push(format!("{last:.12}"));
        }
        at10.push(last);
        row.push(sci((last - at10[0]).abs()));
        t.row(row);
    }
    doc += "\nPull-off amplification of `gs_rigid_unload(0.1 µm/s)` (`methods_agree_on_gs_unload`):\n\n";
    doc += &t.markdown();

    // ---------------------------------------------------------------------------------------
    doc += "\n## Restart from an explicit state\n\n";
    let period = 1.0 / 300.0;
    let (_, whole) = run(&catalogue::vibrating_hold(5e-6, 300.0, 80.0 * period));
    let (r1, _) = run(&catalogue::vibrating_hold(5e-6, 300.0, 40.0 * period));
    let f = r1.final_state;
    let mut second = catalogue::vibrating_hold(5e-6, 300.0, 40.0 * period);
    second.initial = Initial::State {
        x_s: f.x_s,
        v_s: f.v_s,
        a: f.a,
        a_dot: f.a_dot,
        x_k: f.x_k,
    };
    second.stages[0].until = Until::Duration(40.0 * period);
    let (_, rec2) = run(&second);
    let fscale = whole
        .cycles
        .iter()
        .map(|c| c.force_sin.hypot(c.force_cos))
        .fold(0.0, f64::max);
    let worst = whole.cycles[40..]
        .iter()
        .zip(&rec2.cycles)
        .map(|(a, b)| (a.force_mean - b.force_mean).abs() / fscale)
        .fold(0.0, f64::max);
    let worst_a = whole.cycles[40..]
        .iter()
        .zip(&rec2.cycles)
        .map(|(a, b)| ((a.a_mean - b.a_mean) / a.a_mean).abs())
        .fold(0.0, f64::max);
    let _ = writeln!(
        doc,
        "`vibrating_hold(5 µm, 300 Hz)`: 40 + 40 periods resumed from the end state against 80 \
         unbroken periods (`split_run_matches_unbroken_run` in `tests/it/restart.rs`): cycle means \
         differ by at most {} of the largest |F1| in ⟨F⟩ and {} relative in ⟨a⟩.",
        sci(worst),
        sci(worst_a)
    );

    print!("{doc}");
    args.write("checks.md", &doc);
}
