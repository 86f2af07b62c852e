//! Which integrator when: every method on the catalogue scenes, timed (minimum wall over
//! repeats, robust to load) with its error against a converged reference; the basis of the
//! `auto` rule (`dynamics::methods::auto_method`) and of the method tables in README and the
//! module docs of `djkr_core::dynamics`. Also `ode_solvers`' own Dop853/Dopri5 on a closed-form
//! oscillator (why djkr has its own DP8).
//!
//!   cargo run --release --example study_methods            # 3 repeats, about 1 min
//!   cargo run --release --example study_methods -- --full  # 15 repeats, work-precision of both holds
//!
//! Writes `docs/studies/methods.md` (and `methods.csv`).

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::Bundled;
use common::{ms, sci, Args, Table};
use djkr::accuracy::{self, StudyConfig};
use djkr::scenario::Scenario;
use djkr_core::dynamics::Method;
use djkr_core::dynamics::{NoObserver, Recorder};
use djkr_core::rig::Holder;
use std::fmt::Write as _;

const METHODS: [Method; 5] = [
    Method::Implicit,
    Method::Dp8,
    Method::Dopri5,
    Method::Dop853,
    Method::Auto,
];

/// The scenes of the comparison: (name, scene, has inertia).
fn scenes() -> Vec<(&'static str, Scenario, bool)> {
    let mut v: Vec<(&'static str, Scenario, bool)> = vec![
        (
            "`gs_rigid_unload(0.1 µm/s)`: GS, rigid link",
            catalogue::gs_rigid_unload(1e-7),
            false,
        ),
        (
            "`gs_massless_unload(0.1 µm/s)`: GS, m = 0 on 10 N/m",
            catalogue::gs_massless_unload(1e-7),
            false,
        ),
    ];
    let mut s = catalogue::vibrating_hold(2e-6, 400.0, 0.2);
    s.rig.holder = Holder::Rigid;
    v.push((
        "`vibrating_hold(2 µm, 400 Hz, 0.2 s)` through a rigid link",
        s,
        false,
    ));
    v.push((
        "`vibrating_hold(1 µm, 400 Hz, 0.2 s)`",
        catalogue::vibrating_hold(1e-6, 400.0, 0.2),
        true,
    ));
    v.push((
        "`vibrating_hold(5 µm, 400 Hz, 0.2 s)`",
        catalogue::vibrating_hold(5e-6, 400.0, 0.2),
        true,
    ));
    let mut s = catalogue::light_protocol(1e-3);
    s.rig.base = None;
    s.stages[2].vibration = Some(false);
    v.push(("`light_protocol(1 mm/s)` without shaker", s, true));
    v.push((
        "`light_protocol(1 mm/s)`",
        catalogue::light_protocol(1e-3),
        true,
    ));
    match Bundled::PaperProtocol300.scenario() {
        Ok(s) => v.push(("`scenarios/paper-protocol-300hz.toml`", s, true)),
        Err(e) => eprintln!("{e}"),
    }
    v
}

fn short_method(used: &str) -> String {
    used.split(['(', ':', ';'])
        .next()
        .unwrap_or("")
        .trim()
        .to_string()
}

fn main() {
    let args = Args::parse(
        "study_methods",
        "docs/studies",
        "Every integrator on the catalogue scenes: min wall over repeats, steps, error against a \
         converged reference. Writes methods.md and methods.csv.",
    );
    let repeats = if args.full { 15 } else { 3 };
    let mut doc = args.header("Time-domain methods compared per scene");
    let _ = writeln!(
        doc,
        "Each method at the scene's rtol (1e-8 unless noted, atol 1e-10), minimum wall time over \
         {repeats} runs (robust to machine load, unlike the median). Error: the pull-off-relevant \
         error of `djkr::accuracy` (pull-off force and last cycle's ⟨F⟩, ⟨δ⟩, δ_A) against the \
         implicit method at rtol 1e-12, checked by DP8 at 1e-12. Scenes from `tests/catalogue/mod.rs`.\n"
    );
    let mut t = Table::new(&[
        "scene",
        "method",
        "ran",
        "min wall",
        "steps",
        "rhs evals",
        "error",
        "reference uncertainty",
    ]);
    let mut summary = Vec::new();
    let cfg = StudyConfig::default();
    for (name, s0, inertia) in scenes() {
        eprintln!("{name}");
        let reference = accuracy::reference(&s0, &cfg);
        let sc = accuracy::scales(&s0);
        let mut walls = Vec::new();
        for m in METHODS {
            let mut s = s0.clone();
            s.solver.method = m;
            let (wall, r) = common::min_wall(repeats, || accuracy::simulate_key_outputs(&s));
            match r {
                Ok((r, k)) => {
                    let (err, unc) = match &reference {
                        Ok(rf) => {
                            let e = accuracy::compare(&k, &rf.outputs, &sc);
                            (
                                sci(e.pull_off_relevant),
                                sci(rf.check_errors.pull_off_relevant),
                            )
                        }
                        Err(e) => (format!("no reference: {e}"), String::new()),
                    };
                    walls.push((m, wall));
                    t.row([
                        name.to_string(),
                        accuracy::method_name(m).to_string(),
                        short_method(&r.method),
                        ms(wall),
                        r.stats.steps.to_string(),
                        r.stats.rhs_evals.to_string(),
                        err,
                        unc,
                    ]);
                }
                Err(e) => {
                    let msg: String = e.to_string().chars().take(90).collect();
                    t.row([
                        name.to_string(),
                        accuracy::method_name(m).to_string(),
                        format!("fails: {msg}…"),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                    ]);
                }
            }
        }
        let get = |m: Method| walls.iter().find(|w| w.0 == m).map(|w| w.1);
        if let (Some(i), Some(d)) = (get(Method::Implicit), get(Method::Dp8)) {
            summary.push((name, inertia, i, d));
        }
    }
    doc += &t.markdown();
    doc += "\n## DP8 against the implicit method\n\n";
    doc += "Wall time of DP8 over that of the implicit method (below 1: DP8 faster). `auto` takes \
            the implicit method for the scenes without inertia (rigid link, m = 0), DP8 for the \
            others.\n\n";
    let mut s = Table::new(&["scene", "inertia", "implicit", "dp8", "dp8 / implicit"]);
    for (name, inertia, i, d) in &summary {
        s.row([
            name.to_string(),
            if *inertia { "yes" } else { "no" }.to_string(),
            ms(*i),
            ms(*d),
            format!("{:.2}", d / i),
        ]);
    }
    doc += &s.markdown();

    // The 1 s / 400 Hz target, and its work-precision.
    doc += "\n## The 1 s / 400 Hz hold (`catalogue::hold_400hz_1s`)\n\n";
    let mut t = Table::new(&[
        "X_b",
        "method",
        "min wall",
        "steps",
        "rejected",
        "rhs evals",
        "ran",
    ]);
    for xb in [5e-6, 1e-6] {
        for m in METHODS {
            let mut s = catalogue::vibrating_hold(xb, 400.0, 1.0);
            s.solver.method = m;
            let (wall, r) = common::min_wall(repeats, || s.simulate(&mut NoObserver));
            let row = match r {
                Ok(r) => [
                    ms(wall),
                    r.stats.steps.to_string(),
                    r.stats.rejected.to_string(),
                    r.stats.rhs_evals.to_string(),
                    short_method(&r.method),
                ],
                Err(e) => [
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    format!(
                        "fails: {}…",
                        e.to_string().chars().take(60).collect::<String>()
                    ),
                ],
            };
            let mut cells = vec![format!("{} µm", xb * 1e6), accuracy::method_name(m).into()];
            cells.extend(row);
            t.row(cells);
        }
    }
    doc += &t.markdown();
    if args.full {
        for xb in [5e-6, 1e-6] {
            let s = catalogue::vibrating_hold(xb, 400.0, 1.0);
            let cfg = StudyConfig {
                tolerances: vec![1e-6, 1e-8, 5e-9, 1e-9, 4e-10, 1e-10],
                repeats: 5,
                ..StudyConfig::default()
            };
            match accuracy::work_precision(&s, &cfg, |i, n, m, rtol| {
                eprintln!("work-precision X_b {xb:e}: {i}/{n} {m} {rtol:e}")
            }) {
                Ok(st) => {
                    let _ = writeln!(
                        doc,
                        "\nWork-precision at X_b = {} µm (median wall of 5 runs; errors relative):\n",
                        xb * 1e6
                    );
                    doc += &accuracy::study_table(&st);
                }
                Err(e) => {
                    let _ = writeln!(doc, "\nWork-precision at X_b = {} µm failed: {e}", xb * 1e6);
                }
            }
        }
    } else {
        doc +=
            "\nWork-precision tables of this hold: `docs/accuracy/hold-400hz-1s/` (`djkr accuracy \
                docs/accuracy/hold-400hz-1s.toml`), and both amplitudes with `--full`.\n";
    }

    // ode_solvers on a closed form.
    doc += "\n## `ode_solvers`' Dop853 and Dopri5 on y'' = −y\n\n";
    doc += "The crate's integrators alone (no djkr), y(0) = (1, 0) over [0, 10] with h_max = 0.5, \
            error in y₀(10) against cos 10. Its Dop853 has the node c₁₂ = 0 instead of 1 \
            (srenevey/ode-solvers PR #42), harmless on this autonomous system.\n\n";
    doc += &ode_solvers_table().markdown();

    doc += "\n## `ode_solvers`' Dop853 on the free-flight closed form\n\n";
    doc += "`catalogue::free_flight(5 mm, 2 mm/s, 0.5 s)` with the GS law (time passed as a state \
            component, as djkr does): worst |x_s − x(t)| against `RampOscillator::position`.\n\n";
    let mut t = Table::new(&["method", "rtol", "steps", "rejected", "worst error (m)"]);
    for m in [
        Method::Dop853,
        Method::Dopri5,
        Method::Dp8,
        Method::Implicit,
    ] {
        for rtol in [1e-8, 1e-10, 1e-12] {
            let (mut s, osc) = catalogue::free_flight(5e-3, 2e-3, 0.5);
            s.rig.law =
                djkr_core::adhesion::Law::GentSchultz(djkr_core::adhesion::GentSchultz::PAPER);
            s.solver.method = m;
            s.solver.rtol = rtol;
            let mut rec = Recorder::default();
            match s.simulate(&mut rec) {
                Ok(r) => {
                    let worst = rec
                        .samples
                        .iter()
                        .map(|x| (x.x_s - osc.position(x.t)).abs())
                        .fold(0.0, f64::max);
                    t.row([
                        accuracy::method_name(m).to_string(),
                        sci(rtol),
                        r.stats.steps.to_string(),
                        r.stats.rejected.to_string(),
                        sci(worst),
                    ]);
                }
                Err(e) => t.row([
                    accuracy::method_name(m).to_string(),
                    sci(rtol),
                    format!("fails: {e}"),
                    String::new(),
                    String::new(),
                ]),
            }
        }
    }
    doc += &t.markdown();

    print!("{doc}");
    args.write("methods.md", &doc);
}

fn ode_solvers_table() -> Table {
    use ode_solvers::{dop_shared::OutputType, Dop853, Dopri5, System, Vector2};
    struct Osc;
    impl System<f64, Vector2<f64>> for Osc {
        fn system(&self, _t: f64, y: &Vector2<f64>, dy: &mut Vector2<f64>) {
            dy[0] = y[1];
            dy[1] = -y[0];
        }
    }
    let mut t = Table::new(&[
        "rtol = atol",
        "Dop853 error",
        "Dop853 points",
        "Dopri5 error",
        "Dopri5 points",
    ]);
    for rtol in [1e-6, 1e-9, 1e-12] {
        let y0 = Vector2::new(1.0, 0.0);
        let exact = 10f64.cos();
        let mut a = Dop853::from_param(
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
            100_000,
            1000,
            OutputType::Sparse,
        );
        let ra = a.integrate().map(|_| {
            let (x, y) = a.results().get();
            (y.last().map_or(f64::NAN, |v| (v[0] - exact).abs()), x.len())
        });
        let mut b = Dopri5::from_param(
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
            100_000,
            1000,
            OutputType::Sparse,
        );
        let rb = b.integrate().map(|_| {
            let (x, y) = b.results().get();
            (y.last().map_or(f64::NAN, |v| (v[0] - exact).abs()), x.len())
        });
        let cell = |r: &Result<(f64, usize), _>| match r {
            Ok((e, n)) => (sci(*e), n.to_string()),
            Err(e) => (format!("fails: {e:?}"), String::new()),
        };
        let (ea, na) = cell(&ra);
        let (eb, nb) = cell(&rb);
        t.row([sci(rtol), ea, na, eb, nb]);
    }
    t
}
