//! How reproducible is pull-off under vibration? The light-rig protocol (`catalogue::
//! light_protocol`) unloaded at 1 mm/s, by several methods and tolerances: the cycle means
//! converge, the detachment does not. Also the protocol at the paper's 5 µm/s, and the
//! per-cycle means of `scenarios/impacts.toml` at rtol 1e-8 against 1e-12.
//!
//!   cargo run --release --example study_pull_off            # about 1 min
//!   cargo run --release --example study_pull_off -- --full  # adds rtol 1e-11
//!
//! Writes `docs/studies/pull-off-sensitivity.md`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::Bundled;
use common::{sci, Args, Table};
use djkr::accuracy::{self, method_name};
use djkr_core::dynamics::Method;
use djkr_core::dynamics::{EventKind, RunResult};
use std::fmt::Write as _;

fn detach_time(r: &RunResult) -> Option<f64> {
    r.events
        .iter()
        .find(|e| e.kind == EventKind::PullOff)
        .map(|e| e.time)
}

fn main() {
    let args = Args::parse(
        "study_pull_off",
        "docs/studies",
        "Reproducibility of pull-off under vibration, by method and tolerance. Writes \
         pull-off-sensitivity.md.",
    );
    let mut doc = args.header("Pull-off under vibration: what converges and what does not");

    doc += "## The light-rig protocol unloaded at 1 mm/s\n\n";
    doc += "`catalogue::light_protocol(1e-3)`: 3 g sphere, 200 N/m, 300 Hz, X_b = 10 µm; approach \
            to 50 mN, dwell, shaker on, dwell, unload at 1 mm/s to pull-off. The cycle ending \
            nearest t = 5 s, well before detachment, against the pull-off itself.\n\n";
    let mut rtols = vec![1e-7, 1e-8, 1e-9, 1e-10];
    if args.full {
        rtols.push(1e-11);
    }
    let mut t = Table::new(&[
        "method",
        "rtol",
        "⟨F⟩ of the cycle at 5 s (N)",
        "δ_sin there (m)",
        "pull-off force (N)",
        "at t (s)",
        "detached at (s)",
        "steps",
    ]);
    let mut at5 = Vec::new();
    let mut forces = Vec::new();
    for m in [Method::Implicit, Method::Dp8, Method::Dopri5] {
        for &rtol in &rtols {
            eprintln!("{} {rtol:e}", method_name(m));
            let mut s = catalogue::light_protocol(1e-3);
            s.solver.method = m;
            s.solver.rtol = rtol;
            match common::with_cycles(&s) {
                Ok((r, cycles)) => {
                    let c5 = cycles.iter().find(|c| c.t_end >= 5.0);
                    if let Some(c) = c5 {
                        at5.push(c.force_mean);
                    }
                    forces.push(r.pull_off.force);
                    t.row([
                        method_name(m).to_string(),
                        sci(rtol),
                        c5.map_or("—".into(), |c| format!("{:.10e}", c.force_mean)),
                        c5.map_or("—".into(), |c| format!("{:.8e}", c.delta_sin)),
                        format!("{:.4}", r.pull_off.force),
                        format!("{:.4}", r.pull_off.time),
                        detach_time(&r).map_or("—".into(), |x| format!("{x:.4}")),
                        r.stats.steps.to_string(),
                    ]);
                }
                Err(e) => t.row([
                    method_name(m).to_string(),
                    sci(rtol),
                    format!(
                        "fails: {}",
                        e.to_string().chars().take(80).collect::<String>()
                    ),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
        }
    }
    doc += &t.markdown();
    let spread = |v: &[f64]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        (lo, hi)
    };
    let (lo5, hi5) = spread(&at5);
    let (lof, hif) = spread(&forces);
    let _ = writeln!(
        doc,
        "\nAcross all runs: the cycle mean at 5 s spans {} relative; the pull-off force spans \
         {lof:.3} … {hif:.3} N.\n",
        sci((hi5 - lo5) / hi5.abs())
    );

    doc += "## The light-rig protocol at the paper's 5 µm/s\n\n";
    let mut t = Table::new(&[
        "method",
        "pull-off force (N)",
        "amplification",
        "at t (s)",
        "detached",
        "cycles",
        "steps",
        "ran",
    ]);
    for m in [Method::Auto, Method::Implicit] {
        eprintln!("5 µm/s {}", method_name(m));
        let mut s = catalogue::light_protocol(5e-6);
        s.solver.method = m;
        match common::with_cycles(&s) {
            Ok((r, cycles)) => t.row([
                method_name(m).to_string(),
                format!("{:.5}", r.pull_off.force),
                format!("{:.3}", r.pull_off.amplification),
                format!("{:.3}", r.pull_off.time),
                detach_time(&r).map_or("no".into(), |x| format!("at {x:.3} s")),
                cycles.len().to_string(),
                r.stats.steps.to_string(),
                r.method
                    .split(['(', ':', ';'])
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string(),
            ]),
            Err(e) => t.row([
                method_name(m).to_string(),
                format!(
                    "fails: {}",
                    e.to_string().chars().take(200).collect::<String>()
                ),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
            ]),
        }
    }
    doc += &t.markdown();

    doc += "\n## The 300 Hz protocol: with and without its detachment\n\n";
    doc += "`scenarios/paper-protocol-300hz.toml` as shipped, and with the unload stopped after \
            15 s, before pull-off: the pull-off-relevant error of `djkr::accuracy` (pull-off force \
            and the last cycle's ⟨F⟩, ⟨δ⟩, δ_A) against the implicit method at rtol 1e-12, and \
            the pull-off force's own error.\n\n";
    match Bundled::PaperProtocol300.scenario() {
        Ok(full) => {
            let mut stopped = full.clone();
            if let Some(last) = stopped.stages.last_mut() {
                last.until = djkr_core::dynamics::protocol::Until::Duration(15.0);
            }
            let cfg = accuracy::StudyConfig::default();
            let mut t = Table::new(&[
                "scene",
                "method",
                "rtol",
                "pull-off-relevant error",
                "pull-off force error",
                "reference uncertainty",
            ]);
            for (name, s0) in [("as shipped", &full), ("unload stopped at 15 s", &stopped)] {
                eprintln!("protocol {name}: reference");
                let reference = match accuracy::reference(s0, &cfg) {
                    Ok(r) => r,
                    Err(e) => {
                        t.row([
                            name.to_string(),
                            format!("no reference: {e}"),
                            String::new(),
                            String::new(),
                            String::new(),
                            String::new(),
                        ]);
                        continue;
                    }
                };
                let sc = accuracy::scales(s0);
                for m in [Method::Dp8, Method::Implicit] {
                    for rtol in [1e-8, 1e-10] {
                        let mut s = s0.clone();
                        s.solver.method = m;
                        s.solver.rtol = rtol;
                        s.solver.atol = 0.01 * rtol;
                        let cell = match accuracy::simulate_key_outputs(&s) {
                            Ok((_, k)) => {
                                let e = accuracy::compare(&k, &reference.outputs, &sc);
                                (sci(e.pull_off_relevant), sci(e.pull_off_force))
                            }
                            Err(e) => (
                                format!(
                                    "fails: {}",
                                    e.to_string().chars().take(80).collect::<String>()
                                ),
                                String::new(),
                            ),
                        };
                        t.row([
                            name.to_string(),
                            method_name(m).to_string(),
                            sci(rtol),
                            cell.0,
                            cell.1,
                            sci(reference.check_errors.pull_off_relevant),
                        ]);
                    }
                }
            }
            doc += &t.markdown();
        }
        Err(e) => {
            let _ = writeln!(doc, "cannot load: {e}");
        }
    }

    doc += "\n## `scenarios/impacts.toml`: cycle means at rtol 1e-8 against 1e-12 (implicit)\n\n";
    doc += "Contact lost and regained every cycle. ⟨x_b⟩ vanishes over a whole period, so \
            ⟨δ⟩ − ⟨x_s⟩ must vanish in both runs.\n\n";
    match Bundled::Impacts.scenario() {
        Ok(base) => {
            let run = |rtol: f64| {
                let mut s = base.clone();
                s.solver.method = Method::Implicit;
                s.solver.rtol = rtol;
                s.solver.atol = 0.01 * rtol;
                common::with_cycles(&s).map(|(_, c)| c)
            };
            match (run(1e-8), run(1e-12)) {
                (Ok(a), Ok(r)) => {
                    let mut t = Table::new(&[
                        "cycle",
                        "Δ⟨δ⟩ (m)",
                        "Δ⟨x_s⟩ (m)",
                        "Δ⟨F⟩ (N)",
                        "⟨δ⟩ − ⟨x_s⟩ at 1e-8 (m)",
                        "at 1e-12 (m)",
                    ]);
                    let n = r.len().min(a.len());
                    let mut worst = (0.0f64, 0usize);
                    for (i, (c, d)) in a.iter().zip(&r).enumerate() {
                        let e = (c.delta_mean - d.delta_mean).abs();
                        if e > worst.0 {
                            worst = (e, i);
                        }
                        if i % 30 == 0 || i + 1 == n {
                            t.row([
                                i.to_string(),
                                sci(c.delta_mean - d.delta_mean),
                                sci(c.x_s_mean - d.x_s_mean),
                                sci(c.force_mean - d.force_mean),
                                sci(c.delta_mean - c.x_s_mean),
                                sci(d.delta_mean - d.x_s_mean),
                            ]);
                        }
                    }
                    doc += &t.markdown();
                    let _ = writeln!(
                        doc,
                        "\nWorst |Δ⟨δ⟩| {} m at cycle {} of {n}.",
                        sci(worst.0),
                        worst.1
                    );
                }
                (a, r) => {
                    let _ = writeln!(doc, "failed: {:?} / {:?}", a.err(), r.err());
                }
            }
        }
        Err(e) => {
            let _ = writeln!(doc, "cannot load: {e}");
        }
    }

    print!("{doc}");
    args.write("pull-off-sensitivity.md", &doc);
}
