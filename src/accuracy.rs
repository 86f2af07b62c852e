//! Speed versus accuracy: work-precision studies of the time-domain simulator and of the
//! imposed-area method (issue 5).
//!
//! # Time domain ([`work_precision`])
//!
//! For each method and relative tolerance the scene is run `repeats` times; the wall time is the
//! median over the repeats (measured around [`Scenario::simulate`], setup included), the solver statistics
//! and the outputs come from the first repeat (runs are deterministic). The repeats are
//! interleaved (all pairs once, then all again, …), so a change in machine load during the study
//! affects every method alike. The outputs users care
//! about ([`KeyOutputs`]) are compared with those of a **reference run**: the implicit method at
//! `reference_rtol` (default 1e-12). The reference is checked by an independent run, DP8 (a
//! different method and order) at the same tolerance (if DP8 cannot integrate the scene, e.g. a
//! rate-independent law, the implicit method at 10 × the tolerance); the difference between the two is reported as the reference's own uncertainty
//! ([`Study::reference_uncertainty`]): errors at or below it are not resolved.
//!
//! Each studied run has a wall-clock budget (`max_wall_s`, default 60 s; exceeding it is a failed
//! row), and a run slower than `repeat_below_s` (5 s) is timed once (marked "1 run").
//!
//! Absolute tolerances are `atol = atol_ratio · rtol` (default ratio 0.01, the crate's default
//! pairing 1e-8 / 1e-10); `atol` is relative to each state component's natural scale (see
//! [`crate::scenario::Solver::atol`]).
//!
//! Errors ([`OutputErrors`]), all dimensionless:
//! - pull-off force: |ΔF_po| / |F_po,ref|;
//! - last common cycle (the last base period both runs completed, matched by stage and index
//!   since the shaker switched on): mean
//!   force |Δ⟨F⟩| / max(|⟨F⟩_ref|, 10⁻³ |F0|) with F0 = −(3/2)πRw0; mean indentation
//!   |Δ⟨δ⟩| / max(|⟨δ⟩_ref|, L); first-harmonic indentation amplitude |Δδ_A| / max(δ_A,ref, 10⁻³ L),
//!   with L = a_J²/R the jump-in indentation scale;
//! - events (contact loss, impact, pull-off, preload reached): max |Δt| / T (T the base period, or
//!   the reference's duration without base motion); `None` when the event sequences differ
//!   (kinds or count): then the count of each is reported;
//! - final state: max of |Δx_s| / L, |Δa| / max(a_ref, a_J), |ΔF| / max(|F_ref|, |F0|) (the final
//!   times are the same unless the run ends at a located event, whose time error then enters too);
//! - **pull-off relevant** ([`OutputErrors::pull_off_relevant`]): the largest of the pull-off and
//!   the last-cycle errors, the number of the work-precision plot.
//!
//! A method that fails at a tolerance is a row with its error message, never a crash.
//!
//! # Imposed area (`quadrature_study`, `closed_form_map`)
//!
//! The imposed-area cycle costs two law evaluations per quadrature node; `quadrature_study`
//! gives the worst relative error of F_m (and of δ_m, δ_A on the JKR indentation scale) over a box
//! of cases, per tanh-sinh node count, against the graded Gauss–Legendre reference
//! ([`QuadratureRule::graded_gauss_legendre`], an independent rule; its own uncertainty is the
//! difference between two gradings), with the median time per cycle. `closed_form_map` maps the
//! closed form's error against the exact pull-off, ln(A_exact / A_approx), over (n, v_max/v0).

use crate::output::{Column, Table};
use crate::plot::{Figure, Heatmap, LegendPosition, Series, Style};
use crate::scenario::{Method, Scenario};
use djkr_core::adhesion::GentSchultz;
use djkr_core::beta_fit::{self, ExactPoint};
use djkr_core::dynamics::{CycleRecord, EventKind, Observer, RunResult, Sample, SimError, Stats};
use djkr_core::error::ParamError;
use djkr_core::imposed_area;
use djkr_core::jkr;
use djkr_core::material::Material;
use djkr_core::quadrature::QuadratureRule;
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;
use std::time::Instant;

pub use djkr_core::dynamics::methods::method_name;

/// Parse a method name ([`djkr_core::dynamics::methods::METHODS`]); `flag` names the source.
pub(crate) fn parse_method(flag: &str, text: &str) -> Result<Method, ParamError> {
    djkr_core::dynamics::methods::method_from_name(text.trim()).ok_or_else(|| {
        ParamError::new(
            flag,
            text.trim(),
            format!(
                "must be one of {}",
                djkr_core::dynamics::methods::method_names().join(", ")
            ),
        )
    })
}

/// Settings of a work-precision study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyConfig {
    /// Methods to measure, in order.
    #[serde(serialize_with = "ser_methods")]
    pub methods: Vec<Method>,
    /// Relative tolerances, in order (each in (0, 1)).
    pub tolerances: Vec<f64>,
    /// Timed runs per (method, tolerance) (≥ 1); the wall time reported is their median.
    pub repeats: usize,
    /// Relative tolerance of the reference run (implicit) and of its check (DP8).
    pub reference_rtol: f64,
    /// atol = atol_ratio · rtol, for the study and the reference.
    pub atol_ratio: f64,
    /// Wall-clock budget of each studied run (s; `solver.max_wall_s`): a slower run is a failed
    /// row. The reference and its check keep the scene's own budget.
    pub max_wall_s: f64,
    /// A run slower than this (s) is timed once, not `repeats` times.
    pub repeat_below_s: f64,
}

fn ser_methods<S: serde::Serializer>(m: &[Method], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(m.iter().map(|&x| method_name(x)))
}

impl Default for StudyConfig {
    /// implicit, dp8, dopri5, dop853, auto at rtol 1e-4, 1e-6, 1e-8, 1e-10; 3 repeats; reference 1e-12;
    /// atol ratio 0.01; 60 s per run; runs over 5 s timed once.
    fn default() -> Self {
        Self {
            methods: vec![
                Method::Implicit,
                Method::Dp8,
                Method::Dopri5,
                Method::Dop853,
                Method::Auto,
            ],
            tolerances: vec![1e-4, 1e-6, 1e-8, 1e-10],
            repeats: 3,
            reference_rtol: 1e-12,
            atol_ratio: 0.01,
            max_wall_s: 60.0,
            repeat_below_s: 5.0,
        }
    }
}

impl StudyConfig {
    /// Check every setting; an error names the setting as the request's field (`tolerances`,
    /// `ref_rtol`), for a front end to word.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.methods.is_empty() {
            return Err(ParamError::new("methods", "", "needs at least one method"));
        }
        if self.tolerances.is_empty() {
            return Err(ParamError::new(
                "tolerances",
                "",
                "needs at least one tolerance",
            ));
        }
        for &t in &self.tolerances {
            if !(t.is_finite() && t > 0.0 && t < 1.0) {
                return Err(ParamError::new("tolerances", t, "each must lie in (0, 1)"));
            }
        }
        if self.repeats == 0 || self.repeats > 1000 {
            return Err(ParamError::new(
                "repeats",
                self.repeats,
                "must lie in 1..=1000",
            ));
        }
        if !(self.reference_rtol.is_finite()
            && self.reference_rtol >= 1e-14
            && self.reference_rtol < 1e-6)
        {
            return Err(ParamError::new(
                "ref_rtol",
                self.reference_rtol,
                "must lie in [1e-14, 1e-6)",
            ));
        }
        if !(self.atol_ratio.is_finite() && self.atol_ratio > 0.0 && self.atol_ratio <= 1e3) {
            return Err(ParamError::new(
                "atol_ratio",
                self.atol_ratio,
                "must lie in (0, 1000]",
            ));
        }
        if !(self.max_wall_s.is_finite() && self.max_wall_s > 0.0) {
            return Err(ParamError::new(
                "max_wall",
                self.max_wall_s,
                "must be a finite time > 0 s",
            ));
        }
        if !(self.repeat_below_s.is_finite() && self.repeat_below_s >= 0.0) {
            return Err(ParamError::new(
                "repeat_below_s",
                self.repeat_below_s,
                "must be a finite time >= 0 s",
            ));
        }
        Ok(())
    }
}

/// The outputs of a run that users care about.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KeyOutputs {
    /// Pull-off summary force (N).
    pub pull_off_force: f64,
    /// Final detachment happened.
    pub detached: bool,
    /// Per-cycle outputs.
    pub cycles: Vec<CycleOutput>,
    /// Located physical events (kind, time (s)): contact loss, impact, pull-off, preload reached.
    pub events: Vec<(EventKind, f64)>,
    /// Final state.
    pub final_state: Sample,
    /// Final time of the run (s).
    pub duration: f64,
}

/// The outputs of one base period.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CycleOutput {
    /// Stage at the end of the cycle.
    pub stage: usize,
    /// Cycle index since the shaker last switched on.
    pub index: u64,
    /// Start time (s).
    pub t_start: f64,
    /// ⟨F⟩ (N).
    pub force_mean: f64,
    /// ⟨δ⟩ (m).
    pub delta_mean: f64,
    /// First-harmonic amplitude δ_A = hypot(δ_s, δ_c) (m).
    pub delta_amp: f64,
}

impl From<&CycleRecord> for CycleOutput {
    fn from(c: &CycleRecord) -> Self {
        Self {
            stage: c.stage,
            index: c.index,
            t_start: c.t_start,
            force_mean: c.force_mean,
            delta_mean: c.delta_mean,
            delta_amp: c.delta_sin.hypot(c.delta_cos),
        }
    }
}

/// Keeps the per-cycle outputs of a run (its result holds only the last period record).
#[derive(Debug, Default)]
struct CycleOutputs(Vec<CycleOutput>);

impl Observer for CycleOutputs {
    fn wants_samples(&self) -> bool {
        false
    }
    fn cycle(&mut self, c: &CycleRecord) {
        self.0.push(c.into());
    }
}

/// Extract the [`KeyOutputs`] of a run from its result and its period records.
pub(crate) fn key_outputs(r: &RunResult, cycles: Vec<CycleOutput>) -> KeyOutputs {
    KeyOutputs {
        pull_off_force: r.pull_off.force,
        detached: r.detached,
        cycles,
        events: r
            .events
            .iter()
            .filter(|e| {
                matches!(
                    e.kind,
                    EventKind::ContactLoss
                        | EventKind::Impact
                        | EventKind::PullOff
                        | EventKind::PreloadReached
                )
            })
            .map(|e| (e.kind, e.time))
            .collect(),
        final_state: r.final_state,
        duration: r.final_state.t,
    }
}

/// Run `s` and extract its [`KeyOutputs`].
pub fn simulate_key_outputs(s: &Scenario) -> Result<(RunResult, KeyOutputs), SimError> {
    let mut cycles = CycleOutputs::default();
    let r = s.simulate(&mut cycles)?;
    let k = key_outputs(&r, cycles.0);
    Ok((r, k))
}

/// Natural scales of a scene used to normalise errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scales {
    /// |F0| = (3/2) π R w0 (N).
    pub force: f64,
    /// Jump-in indentation a_J²/R (m).
    pub length: f64,
    /// Jump-in radius a_J (m).
    pub radius: f64,
    /// Base period (s), if the scene has base motion.
    pub period: Option<f64>,
}

/// The scales of a scene (see the module documentation).
pub fn scales(s: &Scenario) -> Scales {
    let a_j = jkr::jump_in_radius(&s.rig.material, s.rig.material.w0);
    Scales {
        force: s.rig.material.static_pull_off_force().abs(),
        length: a_j * a_j / s.rig.material.r,
        radius: a_j,
        period: s.rig.base.map(|b| 1.0 / b.frequency),
    }
}

/// Errors of one run's outputs against the reference (dimensionless; see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutputErrors {
    /// Relative pull-off force error.
    pub pull_off_force: f64,
    /// Last common cycle's mean force error; `None` without common cycles.
    pub cycle_force_mean: Option<f64>,
    /// Last common cycle's mean indentation error.
    pub cycle_delta_mean: Option<f64>,
    /// Last common cycle's indentation amplitude error.
    pub cycle_delta_amp: Option<f64>,
    /// max |Δt| / T over the events; `None` when the sequences differ or there are none.
    pub event_time: Option<f64>,
    /// (run, reference) event counts.
    pub event_counts: (usize, usize),
    /// Whether the detachment verdicts agree.
    pub detached_agrees: bool,
    /// Final-state error.
    pub final_state: f64,
    /// The largest of the pull-off and last-cycle errors.
    pub pull_off_relevant: f64,
}

fn rel(x: f64, r: f64, floor: f64) -> f64 {
    (x - r).abs() / r.abs().max(floor)
}

/// Compare a run's outputs with the reference's.
pub fn compare(run: &KeyOutputs, reference: &KeyOutputs, sc: &Scales) -> OutputErrors {
    let pull_off_force = rel(
        run.pull_off_force,
        reference.pull_off_force,
        1e-9 * sc.force,
    );
    // Last cycle both runs completed, matched by (stage, index since the shaker switched on): the
    // switch-on time itself may follow an event (a preload reached), whose time differs a little
    // between runs.
    let common = reference.cycles.iter().rev().find_map(|c| {
        run.cycles
            .iter()
            .rev()
            .find(|d| d.stage == c.stage && d.index == c.index)
            .map(|d| (*d, *c))
    });
    let (cf, cd, ca) = match common {
        Some((d, c)) => (
            Some(rel(d.force_mean, c.force_mean, 1e-3 * sc.force)),
            Some(rel(d.delta_mean, c.delta_mean, sc.length)),
            Some(rel(d.delta_amp, c.delta_amp, 1e-3 * sc.length)),
        ),
        None => (None, None, None),
    };
    let same_events = run.events.len() == reference.events.len()
        && run
            .events
            .iter()
            .zip(&reference.events)
            .all(|(a, b)| a.0 == b.0);
    let t_scale = sc.period.unwrap_or(reference.duration.abs().max(1e-300));
    let event_time = (same_events && !run.events.is_empty()).then(|| {
        run.events
            .iter()
            .zip(&reference.events)
            .map(|(a, b)| (a.1 - b.1).abs() / t_scale)
            .fold(0.0, f64::max)
    });
    let (f, g) = (&run.final_state, &reference.final_state);
    let final_state = [
        (f.x_s - g.x_s).abs() / sc.length,
        rel(f.a, g.a, sc.radius),
        rel(f.force, g.force, sc.force),
    ]
    .into_iter()
    .fold(0.0, f64::max);
    let pull_off_relevant = [Some(pull_off_force), cf, cd, ca]
        .into_iter()
        .flatten()
        .fold(0.0, f64::max);
    OutputErrors {
        pull_off_force,
        cycle_force_mean: cf,
        cycle_delta_mean: cd,
        cycle_delta_amp: ca,
        event_time,
        event_counts: (run.events.len(), reference.events.len()),
        detached_agrees: run.detached == reference.detached,
        final_state,
        pull_off_relevant,
    }
}

/// A measured (method, tolerance) pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measured {
    /// Errors against the reference.
    pub errors: OutputErrors,
    /// Median wall time over the repeats (s).
    pub wall_median_s: f64,
    /// Fastest repeat (s).
    pub wall_min_s: f64,
    /// Number of timed runs (fewer than `repeats` for runs slower than `repeat_below_s`).
    pub timed_runs: usize,
    /// Solver statistics of the first repeat.
    pub stats: Stats,
    /// The method the run reports (`auto` says what it chose).
    pub method_used: String,
}

/// One row of the study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyRow {
    /// Requested method.
    pub method: &'static str,
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
    /// The measurement, or the run's error message.
    pub outcome: Result<Measured, String>,
}

/// The reference and its check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reference {
    /// Outputs of the reference run.
    pub outputs: KeyOutputs,
    /// How the reference was run.
    pub description: String,
    /// How the check was run.
    pub check_description: String,
    /// The check's errors against the reference: the reference's own uncertainty.
    pub check_errors: OutputErrors,
    /// Wall time of the reference run (s).
    pub wall_s: f64,
}

/// A whole study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Study {
    /// The scene's name (its source).
    pub scene: String,
    /// Settings.
    pub config: StudyConfig,
    /// Normalisation scales.
    pub scales: Scales,
    /// The reference.
    pub reference: Reference,
    /// One row per (method, tolerance), methods outer.
    pub rows: Vec<StudyRow>,
}

impl Study {
    /// The reference's own uncertainty in the pull-off-relevant outputs.
    pub fn reference_uncertainty(&self) -> f64 {
        self.reference.check_errors.pull_off_relevant
    }
}

/// The scene with a method and tolerances; envelope following off, so that the study measures
/// the integrators (and the reference integrates every period).
fn with_solver(s: &Scenario, method: Method, rtol: f64, atol_ratio: f64) -> Scenario {
    let mut t = s.clone();
    t.solver.method = method;
    t.solver.rtol = rtol;
    t.solver.atol = rtol * atol_ratio;
    t.solver.envelope = djkr_core::dynamics::EnvelopeMode::Off;
    t
}

type Outcome = Result<(RunResult, KeyOutputs), SimError>;

fn timed(s: &Scenario) -> (Outcome, f64) {
    let start = Instant::now();
    let r = simulate_key_outputs(s);
    (r, start.elapsed().as_secs_f64())
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Why the reference could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    /// A setting is out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The reference run (or both candidate checks) failed.
    #[error("reference run ({what}) failed: {source}")]
    Reference {
        /// Which run.
        what: String,
        /// Why.
        source: SimError,
    },
}

/// Run the reference (implicit at `reference_rtol`) and its independent check.
pub fn reference(s: &Scenario, cfg: &StudyConfig) -> Result<Reference, StudyError> {
    cfg.validate()?;
    let sc = scales(s);
    let rt = cfg.reference_rtol;
    let what = format!("implicit, rtol {rt:e}");
    let (r, wall_s) = timed(&with_solver(s, Method::Implicit, rt, cfg.atol_ratio));
    let r = r.map_err(|source| StudyError::Reference {
        what: what.clone(),
        source,
    })?;
    let (_, outputs) = r;
    let check_dp8 = format!("dp8, rtol {rt:e}");
    let (c, _) = timed(&with_solver(s, Method::Dp8, rt, cfg.atol_ratio));
    let (check, check_description) = match c {
        Ok(c) => (c, check_dp8),
        Err(e) => {
            let rt2 = (10.0 * rt).min(1e-7);
            let d = format!("implicit, rtol {rt2:e} (dp8 at {rt:e} failed: {e})");
            let (c2, _) = timed(&with_solver(s, Method::Implicit, rt2, cfg.atol_ratio));
            let c2 = c2.map_err(|source| StudyError::Reference {
                what: format!("check: implicit, rtol {rt2:e}"),
                source,
            })?;
            (c2, d)
        }
    };
    let check_errors = compare(&check.1, &outputs, &sc);
    Ok(Reference {
        outputs,
        description: what,
        check_description,
        check_errors,
        wall_s,
    })
}

/// The work-precision study of a scene (see the module documentation). `progress` is called
/// before each (method, tolerance) with (index, total, method, rtol).
pub fn work_precision(
    s: &Scenario,
    cfg: &StudyConfig,
    mut progress: impl FnMut(usize, usize, &str, f64),
) -> Result<Study, StudyError> {
    let reference = reference(s, cfg)?;
    let sc = scales(s);
    let total = cfg.methods.len() * cfg.tolerances.len();
    // First pass: every (method, tolerance) once, for the outputs and a first time.
    let mut pending: Vec<(Scenario, Vec<f64>)> = Vec::with_capacity(total);
    let mut rows = Vec::with_capacity(total);
    for &m in &cfg.methods {
        for &rtol in &cfg.tolerances {
            progress(rows.len(), total, method_name(m), rtol);
            let mut scene = with_solver(s, m, rtol, cfg.atol_ratio);
            scene.solver.max_wall_s = cfg.max_wall_s;
            let (first, w0) = timed(&scene);
            let outcome = first
                .map(|(r, k)| Measured {
                    errors: compare(&k, &reference.outputs, &sc),
                    wall_median_s: w0,
                    wall_min_s: w0,
                    timed_runs: 1,
                    stats: r.stats,
                    method_used: r.method.clone(),
                })
                .map_err(|e| e.to_string());
            pending.push((scene, vec![w0]));
            rows.push(StudyRow {
                method: method_name(m),
                rtol,
                atol: rtol * cfg.atol_ratio,
                outcome,
            });
        }
    }
    // Further passes interleave the repeats, so a change in machine load over the study
    // affects every method alike.
    for _ in 1..cfg.repeats {
        for (row, (scene, walls)) in rows.iter().zip(pending.iter_mut()) {
            if matches!(&row.outcome, Ok(m) if m.wall_median_s < cfg.repeat_below_s) {
                walls.push(timed(scene).1);
            }
        }
    }
    for (row, (_, walls)) in rows.iter_mut().zip(pending.iter_mut()) {
        if let Ok(m) = &mut row.outcome {
            m.wall_min_s = walls.iter().copied().fold(f64::INFINITY, f64::min);
            m.timed_runs = walls.len();
            m.wall_median_s = median(walls);
        }
    }
    Ok(Study {
        scene: s.source_name.clone(),
        config: cfg.clone(),
        scales: sc,
        reference,
        rows,
    })
}

/// A short label of what ran: the requested method, and for `auto` what it used
/// (`auto→dp8`, `auto→implicit`, `auto→dp8+implicit` when some DP8 steps were taken
/// implicitly).
pub fn method_label(requested: &str, used: &str) -> String {
    if requested != "auto" {
        return requested.to_string();
    }
    let u = used.to_lowercase();
    if u.contains("steps implicit") {
        "auto→dp8+implicit".into()
    } else if u.starts_with("dp8") {
        "auto→dp8".into()
    } else if u.starts_with("implicit") {
        "auto→implicit".into()
    } else {
        format!("auto→{used}")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(|| "n/a".into(), |v| format!("{v:.2e}"))
}

/// The study as a table (`work_precision.csv`): one row per (method, tolerance), SI values. A
/// failed run has `failed` in `status`, its message in `message`, and NaN numbers.
pub(crate) fn work_precision_table(st: &Study) -> Table {
    let ok = |f: &dyn Fn(&Measured) -> f64| -> Vec<f64> {
        st.rows
            .iter()
            .map(|r| r.outcome.as_ref().map_or(f64::NAN, f))
            .collect()
    };
    let opt = |f: &dyn Fn(&OutputErrors) -> Option<f64>| -> Vec<f64> {
        ok(&|m| f(&m.errors).unwrap_or(f64::NAN))
    };
    let text = |f: &dyn Fn(&StudyRow) -> String| -> Vec<String> { st.rows.iter().map(f).collect() };
    let n = |name: &str, unit: &str, description: &str, v: Vec<f64>| {
        Column::f64(name, unit, description, v)
    };
    let e = "relative error against the reference (see `djkr::accuracy`)";
    table_of(vec![
        Column::text(
            "method",
            "requested method",
            text(&|r| r.method.to_string()),
        ),
        n(
            "rtol",
            "1",
            "relative tolerance",
            st.rows.iter().map(|r| r.rtol).collect(),
        ),
        n(
            "atol",
            "1",
            "absolute tolerance (scaled states)",
            st.rows.iter().map(|r| r.atol).collect(),
        ),
        Column::text(
            "status",
            "ok or failed",
            text(&|r| if r.outcome.is_ok() { "ok" } else { "failed" }.into()),
        ),
        Column::text(
            "method_used",
            "what the run reports it ran",
            text(&|r| {
                r.outcome
                    .as_ref()
                    .map_or(String::new(), |m| m.method_used.clone())
            }),
        ),
        n(
            "wall_median",
            "s",
            "median wall time over the repeats",
            ok(&|m| m.wall_median_s),
        ),
        n("wall_min", "s", "fastest repeat", ok(&|m| m.wall_min_s)),
        n(
            "steps",
            "1",
            "accepted steps",
            ok(&|m| m.stats.steps as f64),
        ),
        n(
            "rejected",
            "1",
            "rejected steps",
            ok(&|m| m.stats.rejected as f64),
        ),
        n(
            "rhs_evals",
            "1",
            "right-hand-side evaluations",
            ok(&|m| m.stats.rhs_evals as f64),
        ),
        n(
            "err_pull_off_relevant",
            "1",
            e,
            ok(&|m| m.errors.pull_off_relevant),
        ),
        n(
            "err_pull_off_force",
            "1",
            e,
            ok(&|m| m.errors.pull_off_force),
        ),
        n("err_cycle_force_mean", "1", e, opt(&|x| x.cycle_force_mean)),
        n("err_cycle_delta_mean", "1", e, opt(&|x| x.cycle_delta_mean)),
        n("err_cycle_delta_amp", "1", e, opt(&|x| x.cycle_delta_amp)),
        n(
            "err_event_time",
            "1",
            "max |Δt| / T over the events",
            opt(&|x| x.event_time),
        ),
        n(
            "events_run",
            "1",
            "events of the run",
            ok(&|m| m.errors.event_counts.0 as f64),
        ),
        n(
            "events_ref",
            "1",
            "events of the reference",
            ok(&|m| m.errors.event_counts.1 as f64),
        ),
        Column::text(
            "detached_agrees",
            "true when run and reference agree on detachment",
            text(&|r| {
                r.outcome
                    .as_ref()
                    .map_or(String::new(), |m| m.errors.detached_agrees.to_string())
            }),
        ),
        n("err_final_state", "1", e, ok(&|m| m.errors.final_state)),
        Column::text(
            "message",
            "why the run failed",
            text(&|r| r.outcome.as_ref().err().cloned().unwrap_or_default()),
        ),
    ])
}

/// The study as CSV text ([`work_precision_table`]), as the tests read it.
#[cfg(test)]
pub(crate) fn study_csv(st: &Study) -> String {
    work_precision_table(st).to_csv()
}

fn table_of(columns: Vec<Column>) -> Table {
    Table::from_fixed(columns)
}

/// The quadrature study as a table (`quadrature.csv`).
pub(crate) fn quadrature_table(q: &QuadratureStudy) -> Table {
    let r = &q.rows;
    table_of(vec![
        Column::i64(
            "nodes",
            "1",
            "tanh-sinh nodes",
            r.iter().map(|x| x.nodes as i64).collect(),
        ),
        Column::f64(
            "worst_force_rel",
            "1",
            "worst relative error of F_m over the cases",
            r.iter().map(|x| x.worst_force_rel).collect(),
        ),
        Column::f64(
            "worst_delta_scaled",
            "1",
            "worst error of delta_m and delta_A over the JKR indentation scale",
            r.iter().map(|x| x.worst_delta_scaled).collect(),
        ),
        Column::f64(
            "time_per_cycle",
            "s",
            "median wall time of one cycle",
            r.iter().map(|x| x.time_per_cycle_s).collect(),
        ),
        Column::text(
            "worst_case",
            "the case of the worst F_m error",
            r.iter().map(|x| x.worst_case.clone()).collect(),
        ),
    ])
}

/// The closed-form error map as a table (`closed_form_map.csv`; NaN where the exact pull-off
/// failed).
pub(crate) fn closed_form_map_table(map: &[MapPoint]) -> Table {
    let col = |name: &str, description: &str, f: fn(&MapPoint) -> Option<f64>| {
        Column::f64_opt(name, "1", description, map.iter().map(f))
    };
    table_of(vec![
        col("n", "Gent–Schultz exponent", |p| Some(p.n)),
        col("speed_ratio", "v_max / v0", |p| Some(p.speed_ratio)),
        col("amp_exact", "exact pull-off amplification", |p| p.amp_exact),
        col("amp_approx", "closed-form pull-off amplification", |p| {
            p.amp_approx
        }),
        col("ln_ratio", "ln(amp_exact / amp_approx)", |p| p.ln_ratio),
    ])
}

/// The study as a markdown table, with the reference and its uncertainty above it.
pub fn study_table(st: &Study) -> String {
    let re = &st.reference;
    let mut out = format!(
        "Scene: {}\nReference: {} ({:.3} s); check: {}; reference uncertainty (pull-off \
         relevant) {:.1e}, events {}, final state {:.1e}\n\n",
        st.scene,
        re.description,
        re.wall_s,
        re.check_description,
        re.check_errors.pull_off_relevant,
        opt(re.check_errors.event_time),
        re.check_errors.final_state
    );
    let ro = &re.outputs;
    out += &format!(
        "Reference values: pull-off force {:.6e} N{}; last cycle ⟨F⟩ {}, ⟨δ⟩ {}, δ_A {}; {} \
         events; final t {:.6} s\n\n",
        ro.pull_off_force,
        if ro.detached { " (detached)" } else { "" },
        ro.cycles
            .last()
            .map_or("n/a".into(), |c| format!("{:.6e} N", c.force_mean)),
        ro.cycles
            .last()
            .map_or("n/a".into(), |c| format!("{:.6e} m", c.delta_mean)),
        ro.cycles
            .last()
            .map_or("n/a".into(), |c| format!("{:.6e} m", c.delta_amp)),
        ro.events.len(),
        ro.final_state.t
    );
    out += "Steps are the driver's steps; for dopri5/dop853 each is a macro span of many inner \
            steps, so compare rhs evaluations across methods.\n\n";
    out += "| method | rtol | wall (median) | steps | rejected | rhs evals | pull-off rel. | \
            F_po | ⟨F⟩ | ⟨δ⟩ | δ_A | events Δt/T | final state |\n";
    out += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in &st.rows {
        match &r.outcome {
            Ok(m) => {
                let e = &m.errors;
                let ev = match e.event_time {
                    Some(t) => format!("{t:.1e}"),
                    None if e.event_counts == (0, 0) => "none".into(),
                    None => format!("≠ ({} vs {})", e.event_counts.0, e.event_counts.1),
                };
                out += &format!(
                    "| {} | {:.0e} | {} | {} | {} | {} | {:.1e} | {:.1e} | {} | {} | {} | {} | {:.1e} |\n",
                    method_label(r.method, &m.method_used),
                    r.rtol,
                    if m.timed_runs > 1 {
                        fmt_time(m.wall_median_s)
                    } else {
                        format!("{} (1 run)", fmt_time(m.wall_median_s))
                    },
                    m.stats.steps,
                    m.stats.rejected,
                    m.stats.rhs_evals,
                    e.pull_off_relevant,
                    e.pull_off_force,
                    opt(e.cycle_force_mean),
                    opt(e.cycle_delta_mean),
                    opt(e.cycle_delta_amp),
                    ev,
                    e.final_state
                );
            }
            Err(msg) => {
                let short: String = msg.chars().take(120).collect();
                out += &format!(
                    "| {} | {:.0e} | failed: {} | | | | | | | | | | |\n",
                    r.method,
                    r.rtol,
                    short.replace('|', "/")
                );
            }
        }
    }
    out
}

/// Human-readable time.
pub(crate) fn fmt_time(s: f64) -> String {
    if s >= 1.0 {
        format!("{s:.3} s")
    } else if s >= 1e-3 {
        format!("{:.3} ms", s * 1e3)
    } else {
        format!("{:.1} µs", s * 1e6)
    }
}

/// Which error a work-precision figure shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// [`OutputErrors::pull_off_relevant`]: the largest of the pull-off and last-cycle errors.
    PullOffRelevant,
    /// [`OutputErrors::pull_off_force`] alone.
    PullOffForce,
}

/// The work-precision figure: the chosen error against median wall time, log axes, one series
/// per method (points in tolerance order); the reference uncertainty in the same measure as a
/// dashed line. Errors below 1e-16 are drawn at 1e-16 (exact agreement).
pub(crate) fn study_figure(st: &Study, measure: Measure) -> Figure {
    let pick = |e: &OutputErrors| match measure {
        Measure::PullOffRelevant => e.pull_off_relevant,
        Measure::PullOffForce => e.pull_off_force,
    };
    let y_label = match measure {
        Measure::PullOffRelevant => "max relative error: F_po, last-cycle ⟨F⟩, ⟨δ⟩, δ_A (–)",
        Measure::PullOffForce => "relative error of the pull-off force (–)",
    };
    let walls: Vec<f64> = st
        .rows
        .iter()
        .filter_map(|r| r.outcome.as_ref().ok().map(|m| m.wall_median_s))
        .collect();
    let (ts, t_label) = crate::plot::axis_label("median wall time", "s", &walls);
    let mut fig = Figure::new(
        format!("Work-precision: {}", short_name(&st.scene)),
        t_label,
        y_label,
    )
    .with_log(true, true)
    // Error falls as time grows: the slow-and-inaccurate corner is the empty one.
    .with_legend(LegendPosition::UpperRight);
    let mut t_all = Vec::new();
    for (i, &m) in st.config.methods.iter().enumerate() {
        let name = method_name(m);
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for r in st.rows.iter().filter(|r| r.method == name) {
            if let Ok(me) = &r.outcome {
                x.push(me.wall_median_s * ts);
                y.push(pick(&me.errors).max(1e-16));
                t_all.push(me.wall_median_s * ts);
            }
        }
        fig = fig.with_series(Series::new(name, x, y, Style::LineMarkers).with_color(i));
    }
    let u = pick(&st.reference.check_errors);
    if u > 0.0 && !t_all.is_empty() {
        let lo = t_all.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = t_all.iter().copied().fold(0.0, f64::max);
        fig = fig.with_series(
            Series::new(
                "reference uncertainty",
                vec![lo, hi],
                vec![u, u],
                Style::Dashed,
            )
            .with_color(crate::plot::GREY),
        );
    }
    fig
}

fn short_name(s: &str) -> String {
    std::path::Path::new(s)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| s.to_string())
}

// ---------------------------------------------------------------------------------------------
// Imposed-area side.

/// One node count of the quadrature study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct QuadratureRow {
    /// Tanh-sinh nodes.
    pub nodes: usize,
    /// Worst relative error of F_m over the cases.
    pub worst_force_rel: f64,
    /// The case of that worst error.
    pub worst_case: String,
    /// Worst error of δ_m and δ_A, in units of the JKR indentation scale of the case.
    pub worst_delta_scaled: f64,
    /// Median wall time of one cycle (s), over all cases and repeats.
    pub time_per_cycle_s: f64,
}

/// The quadrature study's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct QuadratureStudy {
    /// Rows, in node order.
    pub rows: Vec<QuadratureRow>,
    /// Number of cases.
    pub cases: usize,
    /// Worst relative difference in F_m between the two reference gradings.
    pub reference_uncertainty: f64,
}

/// Worst-case error of the imposed-area cycle per tanh-sinh node count over a box of cases:
/// n ∈ {0.05, 0.1, 0.531, 1.0, 1.5}, f ∈ {1, 400, 10⁴} Hz, a_A ∈ {1 µm, 0.1 mm, 1 mm},
/// a_m/a_A ∈ {−0.9, 0.3, 1, 1.5, 3} (truncated, touching and full-contact cycles), paper K, R,
/// w0, v0. Reference: graded Gauss–Legendre (16 points, 70 levels, σ = 0.5), checked against
/// (20, 90, 0.45). Cases run in parallel for the errors; timing is sequential.
pub(crate) fn quadrature_study(node_counts: &[usize], repeats: usize) -> QuadratureStudy {
    let m = Material::PAPER;
    let reference = QuadratureRule::graded_gauss_legendre(16, 70, 0.5);
    let reference2 = QuadratureRule::graded_gauss_legendre(20, 90, 0.45);
    let mut cases = Vec::new();
    for &n in &[0.05, 0.1, 0.531, 1.0, 1.5] {
        for &f in &[1.0, 400.0, 1e4] {
            for &a_amp in &[1e-6, 1e-4, 1e-3] {
                for &x in &[-0.9, 0.3, 1.0, 1.5, 3.0] {
                    cases.push((n, f, a_amp, x * a_amp));
                }
            }
        }
    }
    let law_of = |n: f64| GentSchultz {
        w0: m.w0,
        v0: GentSchultz::PAPER.v0,
        n,
    };
    let refs: Vec<Option<(imposed_area::Cycle, f64, f64)>> = cases
        .par_iter()
        .map(|&(n, f, a_amp, a_m)| {
            let law = law_of(n);
            let om = 2.0 * PI * f;
            let r = imposed_area::cycle_with(&m, &law, om, a_m, a_amp, &reference).ok()?;
            let r2 = imposed_area::cycle_with(&m, &law, om, a_m, a_amp, &reference2).ok()?;
            let a_top = a_m + a_amp;
            let dscale = a_top * a_top / m.r + jkr::equilibrium_edge_opening(&m, a_top, m.w0);
            Some((
                r,
                (r2.harmonics.force_mean / r.harmonics.force_mean - 1.0).abs(),
                dscale,
            ))
        })
        .collect();
    let reference_uncertainty = refs.iter().flatten().map(|x| x.1).fold(0.0, f64::max);
    let rows = node_counts
        .iter()
        .map(|&nodes| {
            let rule = QuadratureRule::tanh_sinh(nodes);
            let mut worst = (0.0f64, String::new());
            let mut worst_d = 0.0f64;
            let mut times = Vec::new();
            for (&(n, f, a_amp, a_m), r) in cases.iter().zip(&refs) {
                let Some((r, _, dscale)) = r else { continue };
                let law = law_of(n);
                let om = 2.0 * PI * f;
                let mut c = None;
                for _ in 0..repeats.max(1) {
                    let t = Instant::now();
                    c = imposed_area::cycle_with(&m, &law, om, a_m, a_amp, &rule).ok();
                    times.push(t.elapsed().as_secs_f64());
                }
                let Some(c) = c else { continue };
                let e = rel(c.harmonics.force_mean, r.harmonics.force_mean, 1e-300);
                if e > worst.0 {
                    worst = (
                        e,
                        format!("n {n}, f {f} Hz, a_A {a_amp:e} m, a_m {a_m:e} m"),
                    );
                }
                let ed = ((c.harmonics.delta_mean - r.harmonics.delta_mean).abs()
                    + (c.harmonics.delta_amp - r.harmonics.delta_amp).abs())
                    / dscale;
                worst_d = worst_d.max(ed);
            }
            QuadratureRow {
                nodes: rule.len(),
                worst_force_rel: worst.0,
                worst_case: worst.1,
                worst_delta_scaled: worst_d,
                time_per_cycle_s: if times.is_empty() {
                    0.0
                } else {
                    median(&mut times)
                },
            }
        })
        .collect();
    QuadratureStudy {
        rows,
        cases: cases.len(),
        reference_uncertainty,
    }
}

/// One point of the closed-form error map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct MapPoint {
    /// Gent–Schultz exponent n.
    pub n: f64,
    /// v_max/v0.
    pub speed_ratio: f64,
    /// Exact (imposed-area) amplification; `None` if the exact pull-off failed.
    pub amp_exact: Option<f64>,
    /// Closed-form amplification at β.
    pub amp_approx: Option<f64>,
    /// ln(A_exact / A_approx).
    pub ln_ratio: Option<f64>,
}

/// ln(A_exact/A_approx) over the (n, v_max/v0) grid at frequency `freq` (Hz) and speed correction
/// `beta`, paper material and v0 (a_A = v_max/ω). Parallel over the grid. Row-major: n outer.
pub(crate) fn closed_form_map(
    n_values: &[f64],
    speed_ratios: &[f64],
    freq: f64,
    beta: f64,
) -> Result<Vec<MapPoint>, ParamError> {
    djkr_core::error::positive("freq", freq, "Hz")?;
    djkr_core::error::positive("beta", beta, "(dimensionless)")?;
    for &n in n_values {
        djkr_core::error::positive("n", n, "(dimensionless)")?;
    }
    for &r in speed_ratios {
        djkr_core::error::positive("v_max/v0", r, "(dimensionless)")?;
    }
    let m = Material::PAPER;
    let v0 = GentSchultz::PAPER.v0;
    let omega = 2.0 * PI * freq;
    let pairs: Vec<(f64, f64)> = n_values
        .iter()
        .flat_map(|&n| speed_ratios.iter().map(move |&r| (n, r)))
        .collect();
    Ok(pairs
        .par_iter()
        .map(|&(n, ratio)| {
            let law = GentSchultz { w0: m.w0, v0, n };
            let a_amp = ratio * v0 / omega;
            let exact = imposed_area::pull_off(&m, &law, omega, a_amp)
                .ok()
                .filter(|p| p.amplification.is_finite() && p.amplification > 0.0);
            match exact {
                Some(p) => {
                    let pt = ExactPoint {
                        n,
                        speed_ratio: ratio,
                        a_amp,
                        a_mean_exact: p.cycle.a_mean,
                        amp_exact: p.amplification,
                    };
                    let r = beta_fit::ratios_at(&[pt], beta)[0];
                    MapPoint {
                        n,
                        speed_ratio: ratio,
                        amp_exact: Some(r.amp_exact),
                        amp_approx: Some(r.amp_approx),
                        ln_ratio: Some(r.ratio.ln()).filter(|x| x.is_finite()),
                    }
                }
                None => MapPoint {
                    n,
                    speed_ratio: ratio,
                    amp_exact: None,
                    amp_approx: None,
                    ln_ratio: None,
                },
            }
        })
        .collect())
}

/// The map as a heat map of |ln ratio| (log colour scale), x = v_max/v0 (log), y = n.
pub(crate) fn closed_form_heatmap(
    points: &[MapPoint],
    n_values: &[f64],
    speed_ratios: &[f64],
    freq: f64,
    beta: f64,
) -> Heatmap {
    Heatmap {
        title: format!(
            "Closed form vs exact pull-off: |ln(A_exact/A_approx)|, β = {beta}, {freq} Hz"
        ),
        x_label: "v_max / v0 (–)".into(),
        y_label: "Gent–Schultz exponent n (–)".into(),
        z_label: "|ln ratio| (–)".into(),
        x: speed_ratios.to_vec(),
        y: n_values.to_vec(),
        z: points
            .iter()
            .map(|p| p.ln_ratio.map_or(f64::NAN, |v| v.abs().max(1e-6)))
            .collect(),
        x_log: true,
        y_log: false,
        z_log: true,
        z_range: Some((1e-3, 10.0)),
        size: (1000, 700),
    }
}

/// The quadrature study as a figure: worst relative F_m error against nodes (log y).
pub(crate) fn quadrature_figure(q: &QuadratureStudy) -> Figure {
    let x: Vec<f64> = q.rows.iter().map(|r| r.nodes as f64).collect();
    let y: Vec<f64> = q
        .rows
        .iter()
        .map(|r| r.worst_force_rel.max(1e-16))
        .collect();
    let yd: Vec<f64> = q
        .rows
        .iter()
        .map(|r| r.worst_delta_scaled.max(1e-16))
        .collect();
    Figure::new(
        format!(
            "Imposed-area cycle: tanh-sinh nodes vs worst error ({} cases)",
            q.cases
        ),
        "tanh-sinh nodes, 2 law evaluations each (–)",
        "worst error (–)",
    )
    .with_log(false, true)
    .with_series(Series::new(
        "F_m (relative)",
        x.clone(),
        y,
        Style::LineMarkers,
    ))
    .with_series(Series::new(
        "δ_m, δ_A (/ JKR scale)",
        x,
        yd,
        Style::LineMarkers,
    ))
}

#[cfg(test)]
#[path = "accuracy_tests.rs"]
mod tests;
