//! Why is pull-off under strong vibration not reproducible, and what converges instead?
//! `scenarios/gentle-unload-300hz.toml` (3 g, 200 N/m, 300 Hz, X_b = 20 µm, 3 s of vibration,
//! unloading at 100 µm/s): twin runs 1e-12 apart and how their difference grows (a finite-time
//! Lyapunov exponent per stage), the events before detachment, single runs against the
//! tolerance, ensembles over the base phase and over ulp-sized perturbations, and the members a
//! standard error needs. The heavy-rig paper protocol as the deterministic counter-example.
//!
//!   cargo run --release --example study_sensitivity            # about 1 min on 2 cores
//!   cargo run --release --example study_sensitivity -- --full  # 64-member ensembles
//!
//! Writes `docs/studies/sensitivity.md`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::Bundled;
use common::{sci, Args, Table};
use djkr::scenario::Scenario;
use djkr::sensitivity;
use djkr::sweep::Summary;
use djkr_core::dynamics::{CycleRecord, EnvelopeMode, Event, EventKind, Observer, RunResult};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Keeps period records and events.
#[derive(Default)]
struct Keep {
    cycles: Vec<CycleRecord>,
    events: Vec<Event>,
}

impl Observer for Keep {
    fn wants_samples(&self) -> bool {
        false
    }
    fn cycle(&mut self, c: &CycleRecord) {
        self.cycles.push(*c);
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
}

fn run(s: &Scenario) -> (RunResult, Keep) {
    let mut k = Keep::default();
    match s.simulate(&mut k) {
        Ok(r) => (r, k),
        Err(e) => {
            eprintln!("{}: {e}", s.source_name);
            std::process::exit(1)
        }
    }
}

fn scene(rtol: f64, envelope: EnvelopeMode) -> Scenario {
    let mut s = Bundled::GentleUnload300.scenario().unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    s.solver.rtol = rtol;
    s.solver.envelope = envelope;
    s.output.sample_rate = 0.0;
    s
}

/// The scaled distance of two period records: the mean contact radius by the radius, the
/// sphere's mean position by the base amplitude.
fn distance(a: &CycleRecord, b: &CycleRecord, xb: f64) -> f64 {
    let da = (a.a_mean - b.a_mean).abs() / a.a_mean.abs().max(1e-12);
    let dx = (a.x_s_mean - b.x_s_mean).abs() / xb;
    da.max(dx)
}

fn main() {
    let args = Args::parse(
        "study_sensitivity",
        "docs/studies",
        "Sensitivity of pull-off under strong vibration: twins, Lyapunov exponents, ensembles. \
         Writes sensitivity.md.",
    );
    let mut doc = args.header("How reproducible is a pull-off under strong vibration?");
    doc += "Scene: `scenarios/gentle-unload-300hz.toml` (m = 3 g, k = 200 N/m, c = 0.5 N s/m on \
            the sphere, 20 mN preload, 0.02 s settle, 3 s at 300 Hz with X_b = 20 µm, then \
            unloading at 100 µm/s with the shaker on). Counter-example: the heavy-rig \
            `scenarios/paper-protocol-300hz.toml`.\n\n";
    twins_section(&mut doc);
    tolerance_section(&mut doc);
    ensembles_section(&mut doc, &args);
    heavy_section(&mut doc);
    args.write("sensitivity.md", &doc);
}

/// The period-to-period roughness of the cycle mean force around record `i`: |second difference|
/// (N). A period-1 orbit under a slow ramp has ~1e-10; a period doubling or irregular motion of
/// the mean contact radius makes it a sizeable fraction of the force.
fn roughness(c: &[CycleRecord], i: usize) -> f64 {
    if i == 0 || i + 1 >= c.len() {
        return 0.0;
    }
    (c[i + 1].force_mean - 2.0 * c[i].force_mean + c[i - 1].force_mean).abs()
}

/// Twin runs 1e-12 apart, integrated directly (every period recorded).
fn twins_section(doc: &mut String) {
    eprintln!("twins");
    *doc += "## Twin runs 1e-12 apart\n\n";
    *doc += "Run A and run B, whose base amplitude differs by 1e-12 relative, both integrated \
             directly (no envelope following: every period recorded). d is the larger of \
             |Δ⟨a⟩|/⟨a⟩ and |Δ⟨x_s⟩|/X_b between the period records of equal index; the \
             roughness is |⟨F⟩_{k+1} − 2⟨F⟩_k + ⟨F⟩_{k−1}| of run A (a period-1 orbit under the \
             slow unloading ramp has ~1e-10 N; a period doubling or irregular motion of the mean \
             contact radius makes it a sizeable fraction of the force). The finite-time Lyapunov \
             exponent (FTLE) of a window is ln(d_end/d_start)/(t_end − t_start).\n\n";
    let mut summary = Table::new(&[
        "rtol",
        "period-1 orbit lost (roughness > 1e-6 N) at t (s)",
        "d there",
        "FTLE, unload start → that time (1/s)",
        "FTLE, that time → d = 1e-3 (1/s)",
        "d = 1e-3 at t (s)",
        "contact loss (detachment) at t (s)",
        "pull-off A / B (N)",
    ]);
    let mut profile = String::new();
    let mut last_events = String::new();
    // (t where the period-1 orbit is lost, FTLE after it, detachment) of the rtol 1e-10 twins.
    let mut fine = (f64::NAN, f64::NAN, f64::NAN);
    for rtol in [1e-8, 1e-10] {
        let a = scene(rtol, EnvelopeMode::Off);
        let (b, _) = sensitivity::perturbed(&a, 1e-12).expect("has a base");
        let xb = a.rig.base.map_or(1.0, |b| b.amplitude);
        let ((ra, ka), (rb, kb)) = rayon::join(|| run(&a), || run(&b));
        let t_hold = 0.02 + 3.0;
        let n = ka.cycles.len().min(kb.cycles.len());
        let d: Vec<f64> = (0..n)
            .map(|i| distance(&ka.cycles[i], &kb.cycles[i], xb))
            .collect();
        let t_of = |i: usize| ka.cycles.get(i).map_or(f64::NAN, |c| c.t_end);
        let first = |pred: &dyn Fn(usize) -> bool| (0..n).find(|&i| pred(i));
        let i0 = first(&|i| t_of(i) >= t_hold + 1.0).unwrap_or(0);
        let i_lost = first(&|i| i > i0 && roughness(&ka.cycles, i) > 1e-6);
        let i_3 = first(&|i| i > i0 && d[i] >= 1e-3);
        let ftle = |i: usize, j: usize| (d[j] / d[i]).ln() / (t_of(j) - t_of(i));
        let loss = ka
            .events
            .iter()
            .filter(|e| e.kind == EventKind::ContactLoss)
            .map(|e| e.time)
            .next_back()
            .unwrap_or(f64::NAN);
        let opt = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{v:.2}"));
        summary.row([
            sci(rtol),
            opt(i_lost.map(t_of)),
            i_lost.map_or("—".into(), |i| sci(d[i])),
            i_lost.map_or("—".into(), |i| format!("{:.2}", ftle(i0, i))),
            match (i_lost, i_3) {
                (Some(i), Some(j)) if j > i => format!("{:.1}", ftle(i, j)),
                _ => "—".into(),
            },
            opt(i_3.map(t_of)),
            format!("{loss:.3}"),
            format!("{:.4} / {:.4}", ra.pull_off.force, rb.pull_off.force),
        ]);
        if rtol == 1e-10 {
            fine = (
                i_lost.map_or(f64::NAN, t_of),
                match (i_lost, i_3) {
                    (Some(i), Some(j)) if j > i => ftle(i, j),
                    _ => f64::NAN,
                },
                loss,
            );
            let mut t = Table::new(&[
                "t (s)",
                "d",
                "⟨F⟩ of A (N)",
                "⟨a⟩ of A (mm)",
                "roughness (N)",
            ]);
            let marks = [
                4.0, 8.0, 12.0, 16.0, 20.0, 22.0, 24.0, 26.0, 28.0, 29.0, 30.0, 31.0, 32.0,
            ];
            for m in marks {
                if let Some(i) = first(&|i| t_of(i) >= t_hold + m) {
                    let c = &ka.cycles[i];
                    t.row([
                        format!("{:.2}", c.t_end),
                        sci(d[i]),
                        format!("{:.4}", c.force_mean),
                        format!("{:.4}", c.a_mean * 1e3),
                        sci(roughness(&ka.cycles, i)),
                    ]);
                }
            }
            profile = format!(
                "\n### The twins along the unload (rtol 1e-10; the unload starts at {t_hold} s)\n\n{}",
                t.markdown()
            );
            last_events = events_before(&ka, loss);
        }
    }
    *doc += &summary.markdown();
    *doc += &profile;
    let (t_lost, lyap, t_loss) = fine;
    let _ = write!(
        doc,
        "\nReading: while the orbit is period-1 (the vibrating hold and the first {:.0} s of the \
         unload) the twins stay within ~1e-11 of each other: the difference neither grows nor \
         is removed, it sits at the integration noise (rtol, not the 1e-12 of the input: the \
         twins take different steps). At t ≈ {t_lost:.0} s, {:.0} s before detachment, the \
         period-1 orbit loses its stability: the cycle means start to fluctuate from period to \
         period (the roughness jumps by eight orders of magnitude) and the mean contact radius \
         wanders by tenths of a millimetre. From there the twins separate exponentially, at a \
         finite-time Lyapunov exponent of {lyap:.0} per second ({:.3} per period), until their \
         difference is as large as the motion itself: the approach to pull-off is chaotic. \
         Detachment is the escape from this irregular motion, and its instant moves by \
         hundreds of periods between twins; the pull-off force, the most tensile cycle mean, \
         is an extreme of a fluctuating sequence and moves by percent. No tolerance removes \
         this: it is the dynamics.\n\n",
        t_lost - 3.02,
        t_loss - t_lost,
        lyap / 300.0
    );
    *doc += &last_events;
}

/// The events and the cycle means in the last periods before detachment (the contact loss at
/// `loss`).
fn events_before(k: &Keep, loss: f64) -> String {
    let mut s = String::from(
        "### The last periods before detachment (run A, rtol 1e-10)\n\n\
         Contact losses and impacts per period, and the period means, over the last 12 \
         recorded periods:\n\n",
    );
    let mut t = Table::new(&[
        "period",
        "t_end (s)",
        "⟨F⟩ (N)",
        "⟨a⟩ (mm)",
        "a amplitude (mm)",
        "contact losses",
        "impacts",
    ]);
    let n = k.cycles.len();
    for c in &k.cycles[n.saturating_sub(12)..] {
        let count = |kind: EventKind| {
            k.events
                .iter()
                .filter(|e| e.kind == kind && e.time > c.t_start && e.time <= c.t_end)
                .count()
        };
        t.row([
            c.index.to_string(),
            format!("{:.5}", c.t_end),
            format!("{:.5}", c.force_mean),
            format!("{:.4}", c.a_mean * 1e3),
            format!("{:.4}", c.a_sin.hypot(c.a_cos) * 1e3),
            count(EventKind::ContactLoss).to_string(),
            count(EventKind::Impact).to_string(),
        ]);
    }
    s += &t.markdown();
    let losses = k
        .events
        .iter()
        .filter(|e| e.kind == EventKind::ContactLoss)
        .count();
    let _ = writeln!(
        s,
        "\nContact losses in the whole run: {losses}, the detachment at t = {loss:.4} s. The \
         sensitivity is not a cascade of impacts: the contact holds in every cycle of the \
         irregular motion until the sphere escapes for good.\n"
    );
    s
}

/// One run against the tolerance, both methods.
fn tolerance_section(doc: &mut String) {
    eprintln!("tolerance");
    *doc += "## One run against the tolerance\n\n";
    let cases: Vec<(EnvelopeMode, f64)> = [EnvelopeMode::Auto, EnvelopeMode::Off]
        .into_iter()
        .flat_map(|e| [1e-8, 1e-9, 1e-10, 1e-11, 1e-12].map(move |r| (e, r)))
        .collect();
    let rows: Vec<(EnvelopeMode, f64, RunResult)> = cases
        .par_iter()
        .map(|&(e, rtol)| (e, rtol, run(&scene(rtol, e)).0))
        .collect();
    let mut t = Table::new(&["envelope", "rtol", "pull-off force (N)", "at t (s)"]);
    for (e, rtol, r) in rows {
        t.row([
            format!("{e:?}").to_lowercase(),
            sci(rtol),
            format!("{:.4}", r.pull_off.force),
            format!("{:.3}", r.pull_off.time),
        ]);
    }
    *doc += &t.markdown();
    *doc += "\nThe single-run pull-off wanders by percent as the tolerance tightens and does not \
             settle: there is no converged single number to approach.\n\n";
}

fn ensemble(label: &str, scenes: Vec<Scenario>) -> (String, Summary, Summary) {
    let runs: Vec<RunResult> = scenes.par_iter().map(|s| run(s).0).collect();
    let f = Summary::of(runs.iter().map(|r| r.pull_off.force));
    let t = Summary::of(runs.iter().map(|r| r.pull_off.time));
    (label.to_string(), f, t)
}

/// Ensembles over the base phase and over ulp-sized perturbations, at two tolerances.
fn ensembles_section(doc: &mut String, args: &Args) {
    let n = if args.full { 64 } else { 24 };
    *doc += "## What converges: the distribution\n\n";
    let _ = writeln!(
        doc,
        "{n} members each (envelope following on, `auto`). *Phase*: `[base] phase` = 2πk/{n} \
         (the shaker starts at a different instant of its own cycle). *Ulps*: X_b × (1 + k·1e-12). \
         Mean ± standard error; sd the sample standard deviation.\n"
    );
    let mut t = Table::new(&[
        "ensemble",
        "rtol",
        "pull-off force: mean ± se (N)",
        "sd (N)",
        "min … max (N)",
        "time: mean (s)",
        "time sd (s)",
    ]);
    let mut sds = Vec::new();
    let mut means = Vec::new();
    // (mean, standard error) of every ensemble, for the comparison below.
    let mut estimates: Vec<(f64, f64)> = Vec::new();
    for rtol in [1e-8, 1e-10] {
        eprintln!("ensembles at {rtol:e}");
        let base = scene(rtol, EnvelopeMode::Auto);
        let phase: Vec<Scenario> = (0..n)
            .map(|k| {
                let mut s = base.clone();
                if let Some(b) = s.rig.base.as_mut() {
                    b.phase = 2.0 * PI * k as f64 / n as f64;
                }
                s
            })
            .collect();
        let ulps: Vec<Scenario> = (0..n)
            .map(|k| {
                sensitivity::perturbed(&base, k as f64 * 1e-12)
                    .expect("has a base")
                    .0
            })
            .collect();
        for (label, scenes) in [("phase", phase), ("ulps", ulps)] {
            let (label, f, tm) = ensemble(label, scenes);
            sds.push(f.std);
            means.push(f.mean.abs());
            estimates.push((f.mean, f.sem()));
            t.row([
                label,
                sci(rtol),
                format!("{:.4} ± {:.4}", f.mean, f.sem()),
                format!("{:.4}", f.std),
                format!("{:.4} … {:.4}", f.min, f.max),
                format!("{:.2}", tm.mean),
                format!("{:.2}", tm.std),
            ]);
        }
    }
    *doc += &t.markdown();
    let sd = sds.iter().copied().fold(0.0f64, f64::max);
    let mean = means.iter().sum::<f64>() / means.len().max(1) as f64;
    // The largest difference between two ensemble means, in their combined standard errors.
    let (diff, z) = estimates
        .iter()
        .enumerate()
        .flat_map(|(i, a)| estimates[i + 1..].iter().map(move |b| (a, b)))
        .map(|(a, b)| {
            let d = (a.0 - b.0).abs();
            (d, d / a.1.hypot(b.1))
        })
        .fold((0.0f64, 0.0f64), |m, x| if x.1 > m.1 { x } else { m });
    let _ = writeln!(
        doc,
        "\nAcross tolerances and the two kinds of ensemble the means differ by at most {diff:.4} N, \
         {z:.1} combined standard errors (of {pairs} pairs; with independent estimates of one mean \
         the largest of {pairs} such ratios exceeds 2 in about one case of five), where single \
         runs wander by percent. Members needed for a standard error se of the mean pull-off \
         force, n = (sd/se)² with the largest sd above ({sd:.4} N):\n",
        pairs = estimates.len() * (estimates.len().max(1) - 1) / 2
    );
    let mut m = Table::new(&["se (N)", "se / |mean|", "members"]);
    for se in [0.01, 0.005, 0.002, 0.001] {
        m.row([
            format!("{se}"),
            format!("{:.1} %", 100.0 * se / mean),
            format!("{}", ((sd / se).powi(2)).ceil().max(2.0)),
        ]);
    }
    *doc += &m.markdown();
    *doc += "\n";
}

/// The heavy rig: the same twins, a deterministic pull-off.
fn heavy_section(doc: &mut String) {
    eprintln!("heavy rig");
    *doc += "## The heavy rig of the paper protocol: deterministic\n\n";
    let mut t = Table::new(&[
        "scene",
        "twins",
        "pull-off spread (relative)",
        "time spread (s)",
    ]);
    for b in [Bundled::PaperProtocol300, Bundled::GentleUnload300] {
        let s = b.scenario().unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        });
        let (r, _) = run(&s);
        match sensitivity::twins(&s, &r, 7, sensitivity::EPSILON) {
            Some(Ok(x)) => t.row([
                b.path().to_string(),
                "7".to_string(),
                sci(x.force_spread),
                format!("{:.3}", x.time_spread),
            ]),
            Some(Err(e)) => t.row([b.path().to_string(), "7".into(), e.to_string(), "".into()]),
            None => {}
        }
    }
    *doc += &t.markdown();
    *doc += "\nOn the 0.25 kg rig (resonance at 44 Hz, far below the shaker) the orbit is \
             strongly attracting up to pull-off and twins agree to integration accuracy; \
             `djkr run --sensitivity` tells the two regimes apart in one command.\n";
}
