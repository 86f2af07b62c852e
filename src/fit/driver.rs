//! The fit: the orchestration of the optimiser ([`super::lm`], from each start of
//! [`super::starts`]), the check of the tolerances ([`super::tolerance`]), the uncertainty
//! analysis ([`super::uncertainty`]) and the report ([`super::report`]), over the evaluation
//! layer ([`super::problem`]).
//!
//! The steps, each said in `notes` where it changes what the numbers mean:
//! 1. the weights (the data's sigma, with an ensemble its pooled standard error) and the fit's
//!    tolerances from the data;
//! 2. Levenberg–Marquardt from the start, and from each of the other starts of `--starts`;
//!    the best (lowest χ²) is the estimate;
//! 3. one run of the estimate at the scenario's tolerances: where the model's error is above
//!    what the data allow, tighter tolerances and the fit goes on;
//! 4. for a converged fit: the covariance per direction, the linear model's check at ±1σ, the
//!    profile-likelihood intervals where it fails (or with `--profile`); a profile point below
//!    the estimate's χ² makes the fit go on from there (at most [`MAX_RESTARTS`] times);
//! 5. the report: estimates, σ (none for a fit that did not converge), intervals, covariance
//!    in the keys' units, χ², AIC, BIC, the starts, the tolerances.
//!
//! **Weights with an ensemble.** A row's σ joins the file's sigma and the standard error of its
//! ensemble mean. One mean's standard error is itself noisy (a chaotic pull-off has a skewed,
//! clustered distribution: 16 members give standard errors from 0.1 to 1.5 % at neighbouring
//! parameter values), so it is pooled (root mean square) over the parameter sets of the first
//! Jacobian for the weights, and over every set evaluated for the covariance, which is then the
//! sandwich `A⁻¹ B A⁻¹` of the weighted normal matrix `A` and the same with the pooled variances.
//!
//! **Interruption.** The best parameter set met so far (lowest χ²) is kept at every evaluation;
//! a stop (Ctrl-C) ends the fit and that set is the result, said so in `notes`.

use nalgebra::DVector;

use super::analysis::{analyse, Analysis};
use super::free::{FreeKey, Transform};
use super::lm::{self, End, Halt, Outcome};
use super::model::{expected_runs, EvalError, ForwardModel, Prediction};
use super::problem::{fd_step, Evaluator};
use super::report::{
    self, FitError, FitEvent, FitOptions, FitOutcome, FitReport, StartReport, Tolerances,
};
use super::stencil::{pooled_se, stencil, INITIAL_HALF_STEP};
use super::{optimiser, starts, tolerance};
use crate::words::{input_value, set_item};

/// How many times a profile's lower point may restart the optimiser.
pub const MAX_RESTARTS: usize = 3;

/// How many times a failed check of the tolerances may tighten them.
const MAX_TIGHTENINGS: usize = 2;

/// Each row's weight (the σ of its residual): the data's sigma joined with the pooled standard
/// error of the ensemble mean (0 without one), or 1 without a sigma column.
fn weights(data: &super::data::FitData, pooled: &[f64]) -> Vec<f64> {
    (0..data.rows.len())
        .map(|i| {
            if data.has_sigma {
                let s = data.rows[i].sigma.unwrap_or(1.0);
                let w2 = s * s + pooled[i] * pooled[i];
                // A sigma of 1e-200 squares to 0: the weight was 0 and every residual infinite.
                if w2.is_normal() {
                    w2.sqrt()
                } else {
                    s.hypot(pooled[i])
                }
            } else {
                1.0
            }
        })
        .collect()
}

/// Degrees of freedom: rows − free keys.
fn dof_of(n: usize, k: usize) -> usize {
    n.saturating_sub(k)
}

/// Refuse data whose χ² at the starting values is not finite, naming the first row at fault
/// and its column (sigma's when the file has one, else the observable's): the rows passed the
/// reader's bound ([`super::data::MAX_WEIGHTED`]), but the model predicts values so far from
/// them, in units of their sigma, that a term overflows (an observed 0 with sigma 1e-200).
fn check_start_chi2(
    data: &super::data::FitData,
    p0: &Prediction,
    w: &[f64],
) -> Result<(), FitError> {
    let bad = (0..data.rows.len()).find(|&i| {
        let r = (data.rows[i].observed - p0.values[i]) / w[i];
        !(r * r).is_finite()
    });
    let Some(i) = bad else {
        let chi2: f64 = (0..data.rows.len())
            .map(|i| ((data.rows[i].observed - p0.values[i]) / w[i]).powi(2))
            .sum();
        return if chi2.is_finite() {
            Ok(())
        } else {
            Err(FitError::new(format!(
                "{}: chi2 at the starting values sums to more than the largest double: the \
                 rows' sigma are too small for what the model predicts",
                data.name
            )))
        };
    };
    let row = &data.rows[i];
    let (col, cell) = data
        .sigma_column
        .as_ref()
        .unwrap_or(&data.observable_column);
    Err(FitError::new(format!(
        "{}: line {}, column {col} '{cell}': at the starting values the model predicts {:.6e}{u} \
         where {:.6e}{u} was observed, with sigma {:.6e}{u}: (observed - predicted) / sigma \
         squared is not finite, so chi2 cannot be; give a sigma of the size of the \
         measurement's error{}",
        data.name,
        row.line,
        p0.values[i],
        row.observed,
        w[i],
        if data.has_sigma {
            ""
        } else {
            " (without a sigma column sigma is 1 in the observable's SI unit)"
        },
        u = match data.observable.unit() {
            "1" => String::new(),
            u => format!(" {u}"),
        }
    )))
}

/// Refuse a starting value outside its key's bounds, and bounds too far from it for the fit's
/// coordinate (before anything runs).
pub(crate) fn check_start(free: &[FreeKey], x0: &[f64]) -> Result<(), FitError> {
    for (f, &x) in free.iter().zip(x0) {
        let given = djkr_core::text::excerpt(&f.given);
        let t = Transform::new(f, x);
        if !x.is_finite() || !t.inside(t.y(x)) {
            return Err(FitError::new(format!(
                "{}: the starting value {x} {} (the scenario's) lies outside the bounds; start \
                 inside with {}",
                input_value("free", &given),
                f.unit,
                set_item(&format!("{}=VALUE", f.key))
            )));
        }
        // A linear key moves in units of its starting magnitude: bounds 1e300 times that (a
        // start of 1e-300) would overflow the coordinate or the span between the bounds.
        let span_ok = match (t.lo, t.hi) {
            (Some(l), Some(h)) => (h - l).is_finite(),
            (l, h) => l.is_none_or(f64::is_finite) && h.is_none_or(f64::is_finite),
        };
        if !span_ok {
            return Err(FitError::new(format!(
                "{}: the bounds lie too far from the starting value {x} {} for the fit's \
                 coordinate (the value over its starting magnitude): narrow them, or start nearer \
                 with {}",
                input_value("free", &given),
                f.unit,
                set_item(&format!("{}=VALUE", f.key))
            )));
        }
    }
    Ok(())
}

/// The optimiser's settings of a fit (and, looser, of a profile point's refit).
fn settings(max_iterations: usize, has_sigma: bool, dof: usize) -> lm::Settings {
    lm::Settings {
        max_iterations,
        dof: (!has_sigma).then_some(dof),
        ..lm::Settings::default()
    }
}

/// What the fit's steps 3 and 4 work with, fixed for the fit.
struct Context<'c> {
    model: &'c ForwardModel,
    free: &'c [FreeKey],
    tr: &'c [Transform],
    tol_s: &'c tolerance::Scenario,
    /// The fit chose its own tolerances (then they are checked at the estimate).
    chosen: bool,
    w: &'c [f64],
    obs_abs: &'c [f64],
    s: &'c lm::Settings,
    opts: &'c FitOptions<'c>,
    dof: usize,
}

/// Where steps 3 and 4 settled.
struct Settled {
    /// The estimate's optimisation (None: no start could be optimised).
    current: Option<(Outcome, Vec<f64>)>,
    /// The uncertainty analysis at the estimate (a converged fit whose analysis ran).
    analysis: Option<Analysis>,
    /// The model's error at the estimate against the scenario's tolerances (in sigma).
    model_error: Option<f64>,
    /// The tolerances the fit ended at.
    rtol: f64,
    envelope_tol: f64,
    stopped: bool,
}

/// The model's relative error at `rtol` and `env` ([`tolerance::RTOL_GAIN`],
/// [`tolerance::ENVELOPE_GAIN`]; the latter only with envelope following).
fn error_level(tol_s: &tolerance::Scenario, rtol: f64, env: f64) -> f64 {
    tolerance::RTOL_GAIN * rtol
        + if tol_s.envelope {
            tolerance::ENVELOPE_GAIN * env
        } else {
            0.0
        }
}

/// Steps 3 and 4 from the best end `current`: the check of the tolerances at the estimate
/// (tighter ones and the optimiser again where the model's error is above what the data
/// allow, at most [`MAX_TIGHTENINGS`] times), then for a converged fit the uncertainty
/// analysis ([`analyse`]), whose profile may meet a lower χ² and restart the optimiser (at most
/// [`MAX_RESTARTS`] times), until neither moves the estimate.
#[allow(clippy::too_many_arguments)]
fn settle(
    ev: &mut Evaluator,
    c: &Context,
    mut current: Option<(Outcome, Vec<f64>)>,
    mut rtol: f64,
    mut envelope_tol: f64,
    mut stopped: bool,
    notes: &mut Vec<String>,
) -> Settled {
    let (n, data, members) = (c.model.data().rows.len(), c.model.data(), c.model.members());
    let k = c.free.len();
    let mut model_error = None;
    let mut analysis: Option<Analysis> = None;
    let mut restarts = 0;
    let mut tightenings = 0;
    let reference = c.model;
    // 3 and 4: the check of the tolerances, then the uncertainty, until neither moves the
    // estimate.
    while let (false, Some((o, y))) = (stopped, current.clone()) {
        if let End::Halted(Halt::Failed(m)) = &o.end {
            notes.push(format!("a forward run failed, which ended the fit: {m}"));
            break;
        }
        if c.chosen {
            ev.event(FitEvent::Stage {
                what: "checking the model's error at the scenario's tolerances".into(),
                runs_expected: c.model.runs_per_set(),
            });
            let x = ev.x_of_y(&y);
            let p_fit = ev.eval_y(&y);
            let p_ref = ev.predict_on(reference, std::slice::from_ref(&x));
            match (p_fit, p_ref) {
                (Ok(pf), Ok(mut pr)) => {
                    let pr = pr.remove(0);
                    let e = (0..n)
                        .map(|i| (pf.values[i] - pr.values[i]).abs() / c.w[i])
                        .fold(0.0, f64::max);
                    model_error = Some(e);
                    if e > tolerance::ERROR_FRACTION && tightenings < MAX_TIGHTENINGS {
                        tightenings += 1;
                        let (r, en) = tolerance::tighten(c.tol_s, rtol, envelope_tol, e);
                        notes.push(format!(
                            "at the estimate the model's error was {e:.3} sigma at rtol {rtol:e}, \
                             envelope_tol {envelope_tol:e} (more than {} allowed): the fit went \
                             on at rtol {r:e}, envelope_tol {en:e}",
                            tolerance::ERROR_FRACTION
                        ));
                        rtol = r;
                        envelope_tol = en;
                        let lvl = error_level(c.tol_s, rtol, envelope_tol);
                        ev.set_model(c.model.with_solver(tolerance::overrides(
                            c.tol_s,
                            rtol,
                            envelope_tol,
                        )));
                        ev.set_error(c.obs_abs.iter().map(|o| lvl * o).collect(), fd_step(lvl));
                        match ev.eval_y(&y) {
                            Ok(p) => {
                                let (o2, y2) =
                                    optimiser::optimise(ev, &y, ev.residuals_of(&p), c.s);
                                stopped |= o2.end == End::Halted(Halt::Stopped);
                                current = Some((o2, y2));
                                continue;
                            }
                            Err(EvalError::Stopped) => {
                                stopped = true;
                                break;
                            }
                            Err(EvalError::Failed(m)) => {
                                notes.push(format!(
                                    "a forward run failed, which ended the fit: {m}"
                                ));
                                break;
                            }
                        }
                    }
                }
                (Err(EvalError::Stopped), _) | (_, Err(EvalError::Stopped)) => {
                    stopped = true;
                    break;
                }
                (Err(EvalError::Failed(m)), _) | (_, Err(EvalError::Failed(m))) => {
                    notes.push(format!(
                        "the check of the model's error at the scenario's tolerances failed: {m}"
                    ));
                }
            }
        }
        if !o.end.converged() {
            break;
        }
        ev.event(FitEvent::Stage {
            what: "uncertainties".into(),
            runs_expected: 2 * k * c.model.runs_per_set(),
        });
        let scale = if data.has_sigma {
            1.0
        } else {
            o.chi2 / c.dof as f64
        };
        let ratio = {
            let st = ev.st.borrow();
            (members > 1 && data.has_sigma && st.se2_sets > 0).then(|| {
                DVector::from_fn(n, |i, _| {
                    let sg = data.rows[i].sigma.unwrap_or(1.0);
                    (sg * sg + st.se2[i] / st.se2_sets as f64) / (c.w[i] * c.w[i])
                })
            })
        };
        match analyse(
            ev,
            c.free,
            &y,
            o.chi2,
            o.last_step.as_ref(),
            scale,
            ratio.as_ref(),
            c.opts,
            c.s,
            restarts < MAX_RESTARTS,
        ) {
            Ok(a) => {
                if let (Some((c2, yl)), true) = (&a.lower, restarts < MAX_RESTARTS) {
                    restarts += 1;
                    notes.push(format!(
                        "a profile met chi2 = {c2:.4} at {}, below the estimate's {:.4}: the fit \
                         went on from there",
                        describe(c.free, c.tr, yl),
                        o.chi2
                    ));
                    match ev.eval_y(yl) {
                        Ok(p) => {
                            let (o2, y2) = optimiser::optimise(ev, yl, ev.residuals_of(&p), c.s);
                            stopped |= o2.end == End::Halted(Halt::Stopped);
                            if o2.chi2 < o.chi2 {
                                current = Some((o2, y2));
                            }
                            continue;
                        }
                        Err(EvalError::Stopped) => stopped = true,
                        Err(EvalError::Failed(_)) => analysis = Some(a),
                    }
                } else {
                    if let Some((c2, yl)) = &a.lower {
                        notes.push(format!(
                            "a profile met chi2 = {c2:.4} at {}, below the estimate's {:.4}, \
                             after {MAX_RESTARTS} restarts from such points: the model has \
                             many minima; see the intervals",
                            describe(c.free, c.tr, yl),
                            o.chi2
                        ));
                    }
                    analysis = Some(a);
                }
            }
            Err(EvalError::Stopped) => stopped = true,
            Err(EvalError::Failed(m)) => {
                notes.push(format!(
                    "no sigma: a run of the uncertainty analysis failed: {m}"
                ));
            }
        }
        break;
    }
    Settled {
        current,
        analysis,
        model_error,
        rtol,
        envelope_tol,
        stopped,
    }
}

/// Fit the free keys `free` (starting at `x0`, SI) of `model` to its data.
pub(crate) fn fit(
    model: &ForwardModel,
    free: &[FreeKey],
    x0: &[f64],
    opts: FitOptions,
    progress: &mut dyn FnMut(FitEvent),
) -> Result<FitOutcome, FitError> {
    let t0 = std::time::Instant::now();
    let data = model.data();
    let n = data.rows.len();
    let k = free.len();
    if k == 0 {
        return Err(FitError::new("give at least one «free» KEY"));
    }
    if n <= k {
        return Err(FitError::new(format!(
            "{}: {n} row(s) for {k} free key(s): a fit needs more rows than free keys",
            data.name
        )));
    }
    let tr: Vec<Transform> = free
        .iter()
        .zip(x0)
        .map(|(f, &x)| Transform::new(f, x))
        .collect();
    check_start(free, x0)?;
    let y0 = optimiser::start_inside(&tr, x0);
    let dof = dof_of(n, k);
    let members = model.members();
    let mut notes = Vec::new();

    // 1. The tolerances, from the data.
    // The scenario as the fit starts it: the fixed overrides and the free keys' starts (a key
    // that the file lacks, such as a saturated law's v_sat, is given by its start).
    let mut at_start = model.fixed().to_vec();
    for (f, &x) in free.iter().zip(x0) {
        at_start.push(
            crate::scenario::overrides::Override::from_key(f.key, x)
                .map_err(|e| FitError::new(e.to_string()))?,
        );
    }
    let scn = model
        .source()
        .scenario(&at_start)
        .map_err(|e| FitError::new(e.to_string()))?;
    let is_set = |key: &str| model.fixed().iter().any(|o| o.key().to_string() == key);
    let tol_s = tolerance::Scenario {
        rtol: scn.solver.rtol,
        envelope_tol: scn.solver.envelope_tol,
        envelope: scn.solver.envelope == djkr_core::dynamics::methods::EnvelopeMode::Auto,
        rtol_set: is_set("solver.rtol"),
        envelope_tol_set: is_set("solver.envelope_tol"),
    };
    let eps = tolerance::data_error(data, members);
    let (rtol, envelope_tol, chosen, why) = tolerance::choose(&tol_s, eps);
    let fit_model = model.with_solver(tolerance::overrides(&tol_s, rtol, envelope_tol));

    // The first evaluation: the start (with an ensemble, also the first Jacobian's stencil,
    // whose standard errors are pooled into the weights).
    let mut sets0 = vec![y0.clone()];
    if members > 1 {
        for (j, t) in tr.iter().enumerate() {
            let (a, b) = stencil(t, y0[j], INITIAL_HALF_STEP);
            for yj in [a, b] {
                let mut y = y0.clone();
                y[j] = yj;
                sets0.push(y);
            }
        }
    }
    let eps_rel = error_level(&tol_s, rtol, envelope_tol);
    let obs_abs: Vec<f64> = data.rows.iter().map(|r| r.observed.abs()).collect();
    let mut ev = Evaluator::new(
        fit_model,
        tr.clone(),
        vec![1.0; n],
        obs_abs.iter().map(|o| eps_rel * o).collect(),
        fd_step(eps_rel),
        (members > 1).then(|| (vec![0.0; n], INITIAL_HALF_STEP)),
        opts.stop,
        progress,
    );
    ev.event(FitEvent::Stage {
        what: "the model at the starting values".into(),
        runs_expected: expected_runs(model, k, opts.starts),
    });
    let preds0 = ev.predict_y(&sets0).map_err(|e| match e {
        EvalError::Stopped => FitError {
            message: "during the first evaluation (the model at the starting values): no \
                      estimate was computed yet"
                .into(),
            stopped: true,
        },
        EvalError::Failed(m) => FitError::new(format!("at the starting values: {m}")),
    })?;
    let p0 = preds0
        .first()
        .cloned()
        .ok_or_else(|| FitError::new("no prediction"))?;
    let pooled = pooled_se(&preds0);
    let w = weights(data, &pooled);
    check_start_chi2(data, &p0, &w)?;
    ev.w = w.clone();
    if members > 1 {
        ev.set_noise(pooled.clone());
    }
    ev.st.borrow_mut().best = None;
    ev.remember(&y0, &p0);
    let chi2_0 = ev.chi2(&p0);
    {
        let runs = ev.st.borrow().runs;
        ev.event(FitEvent::Iteration {
            iteration: 0,
            chi2: chi2_0,
            best: chi2_0,
            runs,
        });
    }
    if !data.has_sigma {
        notes.push(format!(
            "{} has no sigma column: every row weighs the same (sigma = 1 {} in chi2), and the \
             parameters' sigma are scaled by the reduced chi2",
            data.name,
            data.observable.unit()
        ));
    }
    if members > 1 && data.has_sigma {
        notes.push(format!(
            "each row's sigma includes the standard error of its {members}-member ensemble mean \
             (root mean square over the {} parameter sets of the start and the first Jacobian)",
            sets0.len()
        ));
    }
    let s = settings(opts.max_iterations, data.has_sigma, dof);

    // 2. The optimiser from each start.
    let start_ys = optimiser::start_points(&tr, &y0, opts.starts);
    let (ends, stopped) = optimiser::run_starts(&ev, &start_ys, &p0, &s, model, opts.starts);
    let best_i = optimiser::best(&ends);
    let current: Option<(Outcome, Vec<f64>)> = best_i.and_then(|i| {
        ends[i]
            .outcome
            .as_ref()
            .ok()
            .map(|o| (o.clone(), ends[i].y.clone()))
    });
    let settled = settle(
        &mut ev,
        &Context {
            model,
            free,
            tr: &tr,
            tol_s: &tol_s,
            chosen,
            w: &w,
            obs_abs: &obs_abs,
            s: &s,
            opts: &opts,
            dof,
        },
        current,
        rtol,
        envelope_tol,
        stopped,
        &mut notes,
    );
    let Settled {
        current,
        analysis,
        model_error,
        rtol,
        envelope_tol,
        mut stopped,
    } = settled;
    // The estimate: the current one, or after a stop the best met.
    let st_best = ev.st.borrow().best.clone();
    let (chi2_fit, y_best, end, iterations_best) = match (&current, stopped) {
        (Some((o, y)), false) => (o.chi2, y.clone(), o.end.clone(), o.iterations),
        _ => {
            let (c, y, _) = st_best
                .clone()
                .ok_or_else(|| FitError::new("no estimate"))?;
            (c, y, End::Halted(Halt::Stopped), 0)
        }
    };
    let _ = iterations_best;
    let values = ev.x_of_y(&y_best);
    // The prediction of the files: at the scenario's tolerances (what fitted.toml reproduces)
    // when the fit chose others and the run is not stopped.
    let pred_fit = st_best
        .as_ref()
        .filter(|(_, y, _)| *y == y_best)
        .map(|(_, _, p)| p.clone());
    let prediction = match (chosen && !stopped, pred_fit) {
        (true, _) => match ev.predict_on(model, std::slice::from_ref(&values)) {
            Ok(mut p) => Some(p.remove(0)),
            Err(EvalError::Stopped) => {
                stopped = true;
                ev.eval_y(&y_best).ok()
            }
            Err(EvalError::Failed(_)) => ev.eval_y(&y_best).ok(),
        },
        (false, Some(p)) => Some(p),
        (false, None) => ev.eval_y(&y_best).ok(),
    };
    let prediction = prediction.ok_or_else(|| FitError::new("no prediction at the estimate"))?;
    let chi2 = {
        let c = ev.chi2(&prediction);
        if c.is_finite() {
            c
        } else {
            chi2_fit
        }
    };
    if !chi2.is_finite() {
        return Err(FitError::new(format!(
            "{}: chi2 is not finite at the estimate: nothing to report",
            data.name
        )));
    }
    let converged = end.converged() && !stopped;
    let reduced = chi2 / dof as f64;
    notes.extend(report::verdict(
        stopped,
        converged,
        &end.words(),
        data.has_sigma.then_some(reduced),
        opts.starts,
    ));
    let at_bound: Vec<bool> = y_best
        .iter()
        .zip(&tr)
        .map(|(&y, t)| t.at_bound(y))
        .collect();
    for (j, f) in free.iter().enumerate() {
        if at_bound[j] {
            notes.push(format!(
                "{} ran to its bound ({} {}): no sigma for it",
                f.key, values[j], f.unit
            ));
        }
    }
    let keys_named: Vec<String> = free.iter().map(|f| f.key.to_string()).collect();
    if members > 1 {
        let snr = ev.st.borrow().snr.clone();
        notes.extend(report::columns(
            &keys_named,
            Some(&ev.steps()),
            &snr,
            &at_bound,
        ));
    } else if converged {
        // The Jacobian at the estimate is the optimiser's last (not computed again).
        let snr = ev.jacobian_snr(&y_best).map(|(_, s)| s).unwrap_or_default();
        notes.extend(report::columns(&keys_named, None, &snr, &at_bound));
    }
    // Minima of the starts, their χ² in units of one Δχ² of the σ reported: 1 with the data's
    // σ, the reduced χ² of the estimate without (the σ are scaled by it).
    let unit = if data.has_sigma {
        1.0
    } else {
        Some(chi2_fit / dof as f64)
            .filter(|u| u.is_finite() && *u > 0.0)
            .unwrap_or(1.0)
    };
    let ends_y: Vec<Option<(Vec<f64>, f64)>> = ends
        .iter()
        .map(|e| {
            e.outcome
                .as_ref()
                .ok()
                .map(|o| (e.y.clone(), o.chi2 / unit))
        })
        .collect();
    let minima = starts::minima(&ends_y);
    if opts.starts > 1 {
        let found: Vec<Option<(f64, bool, String)>> = ends
            .iter()
            .map(|e| {
                e.outcome
                    .as_ref()
                    .ok()
                    .map(|o| (o.chi2 / unit, o.end.converged(), describe(free, &tr, &e.y)))
            })
            .collect();
        notes.extend(report::other_minima(
            &found,
            &minima,
            best_i,
            chi2_fit / unit,
            k,
        ));
    }
    let start_reports: Vec<StartReport> = ends
        .iter()
        .enumerate()
        .map(|(i, e)| StartReport {
            start: ev.x_of_y(&e.start),
            estimate: ev.x_of_y(&e.y),
            chi2: e.outcome.as_ref().ok().map(|o| o.chi2),
            converged: e.outcome.as_ref().is_ok_and(|o| o.end.converged()),
            minimum: minima[i],
            iterations: e.outcome.as_ref().map_or(0, |o| o.iterations),
            termination: match &e.outcome {
                Ok(o) => o.end.words(),
                Err(m) => m.clone(),
            },
        })
        .collect();
    // σ, covariance and intervals (a converged fit only).
    let analysis = analysis.filter(|_| converged).map(|a| {
        notes.extend(a.notes);
        (a.sigma, a.cov, a.intervals)
    });
    let keys = report::keys(free, &tr, x0, &values, &y_best, &at_bound, analysis);
    notes.extend(keys.notes);
    let steps = ev.steps();
    let st = ev.st.borrow();
    let report = FitReport {
        parameters: keys.parameters,
        covariance: keys.covariance,
        correlation: keys.correlation,
        chi2,
        dof,
        reduced_chi2: reduced,
        aic: chi2 + 2.0 * k as f64,
        bic: chi2 + k as f64 * (n as f64).ln(),
        converged,
        termination: end.words(),
        iterations: st.iterations,
        forward_runs: st.runs,
        rhs_evals: st.rhs_evals,
        observable: data.observable.name().to_string(),
        ensemble: model
            .ensemble()
            .map(|(members, seed)| report::Ensemble { members, seed }),
        notes,
        starts: start_reports,
        tolerances: Tolerances {
            rtol,
            envelope_tol,
            scenario_rtol: tol_s.rtol,
            scenario_envelope_tol: tol_s.envelope_tol,
            chosen,
            limit: tolerance::ERROR_FRACTION,
            model_error,
            why,
        },
        rows: n,
        wall_s: t0.elapsed().as_secs_f64(),
        interrupted: stopped,
    };
    Ok(FitOutcome {
        report,
        values,
        prediction,
        weights: w,
        cov_y: keys.cov_y,
        stepped: (0..k)
            .map(|j| {
                let mut y = y_best.clone();
                y[j] += steps[j];
                ev.x_of_y(&y)
            })
            .collect(),
        steps,
    })
}

/// The keys' values at `y`, for notes: `adhesion.n = 0.5, damping.c = 10 N s/m`.
fn describe(free: &[FreeKey], tr: &[Transform], y: &[f64]) -> String {
    free.iter()
        .zip(tr)
        .zip(y)
        .map(|((f, t), &y)| {
            let unit = if f.unit == "1" {
                String::new()
            } else {
                format!(" {}", f.unit)
            };
            format!(
                "{} = {}{unit}",
                f.key,
                crate::output::table::format_sig(t.x(y), 5)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A start whose bounds' transform overflows is refused before any run (the transform
    /// itself stays finite: free.rs's `wide_bounds_stay_finite_or_are_refused`).
    #[test]
    fn a_start_too_far_inside_huge_bounds_is_refused() {
        let f = FreeKey::parse("damping.c=0:1e9").unwrap();
        assert!(check_start(std::slice::from_ref(&f), &[1.0]).is_ok());
        let e = check_start(&[f], &[1e-300]).unwrap_err();
        assert!(e.message.contains("too far from the starting value"), "{e}");
    }

    /// The step balances truncation against the model's error: √ε (1e-3 at 1e-6), kept within
    /// [1e-6, 0.1].
    #[test]
    fn the_step_follows_the_model_error() {
        let close = |a: f64, b: f64| assert!((a - b).abs() <= 1e-15 * b, "{a} vs {b}");
        close(fd_step(1e-6), 1e-3);
        close(fd_step(1e-8), 1e-4);
        close(fd_step(1e-14), 1e-6);
        close(fd_step(1.0), 0.1);
    }

    /// A row's weight joins its sigma and the ensemble's standard error in quadrature (checked
    /// against 3-4-5), survives a sigma whose square underflows, and is 1 without a sigma
    /// column.
    #[test]
    fn weights_join_sigma_and_the_ensemble_error() {
        let csv = "base.amplitude [um],pull_off_amplification [1],sigma [1]\n\
                   10,2.0,0.03\n20,1e-180,1e-200\n";
        let d = super::super::data::FitData::parse(csv, "d.csv", None).expect("data");
        let w = weights(&d, &[0.04, 0.0]);
        assert!((w[0] - 0.05).abs() < 1e-15 && w[1] > 0.0, "{w:?}");
        assert!((w[1] / 1e-200 - 1.0).abs() < 1e-12, "{w:?}");
        let csv = "base.amplitude [um],pull_off_amplification [1]\n10,2.0\n";
        let d = super::super::data::FitData::parse(csv, "d.csv", None).expect("data");
        assert_eq!(weights(&d, &[0.5]), vec![1.0]);
    }
}
