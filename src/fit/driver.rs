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

use nalgebra::{DMatrix, DVector};

use super::free::{FreeKey, Transform};
use super::lm::{self, End, Halt, LeastSquares, Outcome};
use super::model::{EvalError, ForwardModel, Prediction};
use super::problem::{fd_step, Evaluator, View};
use super::report::{
    FitError, FitEvent, FitOptions, FitOutcome, FitReport, Parameter, StartReport, Tolerances,
};
use super::stencil::{pooled_se, stencil, INITIAL_HALF_STEP};
use super::{starts, tolerance, uncertainty};

/// How many times a profile's lower point may restart the optimiser.
pub const MAX_RESTARTS: usize = 3;

/// How many times a failed check of the tolerances may tighten them.
const MAX_TIGHTENINGS: usize = 2;

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

/// Parameter sets a typical iteration evaluates (the trial step and the Jacobian's) with `k`
/// free keys: `k + 1` with forward differences, `2k + 1` with an ensemble's central ones; for a
/// progress bar's length.
pub fn sets_per_iteration(members: usize, k: usize) -> usize {
    if members > 1 {
        2 * k + 1
    } else {
        k + 1
    }
}

/// Refuse a starting value outside its key's bounds, and bounds too far from it for the fit's
/// coordinate (before anything runs).
pub fn check_start(free: &[FreeKey], x0: &[f64]) -> Result<(), FitError> {
    for (f, &x) in free.iter().zip(x0) {
        let given = djkr_core::text::excerpt(&f.given);
        let t = Transform::new(f, x);
        if !x.is_finite() || !t.inside(t.y(x)) {
            return Err(FitError::new(format!(
                "--free {given}: the starting value {x} {} (the scenario's) lies outside the \
                 bounds; start inside with --set {}=VALUE",
                f.unit, f.key
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
                "--free {given}: the bounds lie too far from the starting value {x} {} for the \
                 fit's coordinate (the value over its starting magnitude): narrow them, or start \
                 nearer with --set {}=VALUE",
                f.unit, f.key
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

/// One optimisation's end.
struct End1 {
    /// The start (y).
    start: Vec<f64>,
    /// The optimiser's outcome (None: the start could not be evaluated, with why).
    outcome: Result<Outcome, String>,
    /// The estimate (y).
    y: Vec<f64>,
}

/// Optimise all keys of `ev` from `y0` (residuals `r0`).
fn optimise(ev: &Evaluator, y0: &[f64], r0: DVector<f64>, s: &lm::Settings) -> (Outcome, Vec<f64>) {
    let mut view = View::new(ev, y0.to_vec(), (0..ev.k()).collect());
    let u0 = view.u_of(y0);
    let o = lm::minimise(&mut view, &u0, r0, s);
    let y = view.y_of(&o.u);
    (o, y)
}

/// The profile of a key through an [`Evaluator`]: the other keys refitted, each point started
/// from the point before moved along `dir` (the other keys' regression on the profiled one,
/// from the covariance: where the linear model puts the conditional minimum).
struct ProfileOf<'e, 'a, 'b> {
    ev: &'e Evaluator<'a, 'b>,
    s: lm::Settings,
    dir: Vec<f64>,
}

impl uncertainty::Profiler for ProfileOf<'_, '_, '_> {
    fn point(&mut self, j: usize, yj: f64, from: &[f64]) -> Result<Option<(f64, Vec<f64>)>, Halt> {
        let step = yj - from[j];
        let mut base: Vec<f64> = from
            .iter()
            .zip(&self.dir)
            .zip(&self.ev.tr)
            .map(|((&y, &d), t)| {
                let v = y + d * step;
                // Within the bounds (a bounded key's regression may point beyond them).
                match (t.lo, t.hi) {
                    (Some(l), _) if v <= l => y,
                    (_, Some(h)) if v >= h => y,
                    _ => v,
                }
            })
            .collect();
        base[j] = yj;
        let idx: Vec<usize> = (0..self.ev.k()).filter(|&c| c != j).collect();
        let mut view = View::new(self.ev, base.clone(), idx);
        let u0 = view.u_of(&base);
        let Some(r0) = view.residuals(&u0)? else {
            return Ok(None);
        };
        if u0.is_empty() {
            return Ok(Some((r0.norm_squared(), base)));
        }
        let o = lm::minimise(&mut view, &u0, r0, &self.s);
        if o.end == End::Halted(Halt::Stopped) {
            return Err(Halt::Stopped);
        }
        Ok(Some((o.chi2, view.y_of(&o.u))))
    }
}

/// The uncertainty analysis of a converged fit at `y` (χ² `chi2`, the optimiser's last step
/// `last`): σ per key in y (None where none), the covariance in y, intervals in y with whether
/// they are the profile's, notes, and a lower point met by a profile (χ², y).
struct Analysis {
    sigma: Vec<Option<f64>>,
    cov: DMatrix<f64>,
    intervals: Vec<Option<(f64, f64, bool)>>,
    notes: Vec<String>,
    lower: Option<(f64, Vec<f64>)>,
}

#[allow(clippy::too_many_arguments)]
fn analyse(
    ev: &Evaluator,
    free: &[FreeKey],
    y: &[f64],
    chi2: f64,
    last: Option<&lm::Step>,
    scale: f64,
    ratio: Option<&DVector<f64>>,
    opts: &FitOptions,
    s: &lm::Settings,
    may_restart: bool,
) -> Result<Analysis, EvalError> {
    let k = ev.k();
    let mut notes = Vec::new();
    let at_bound: Vec<bool> = y.iter().zip(&ev.tr).map(|(&y, t)| t.at_bound(y)).collect();
    let (mut jy, snr) = ev.jacobian_snr(y)?;
    // A column that stands below the model's error even at its widest step is no information.
    for j in 0..k {
        if snr.get(j).is_some_and(|&r| r < 1.0) {
            jy.column_mut(j).fill(0.0);
        }
    }
    let usable: Vec<bool> = at_bound.iter().map(|b| !b).collect();
    let c = uncertainty::curvature(&jy, &usable, scale, ratio);
    for d in &c.unidentified {
        let combo = d
            .loadings
            .iter()
            .map(|&(j, l)| {
                if (l - 1.0).abs() < 1e-9 {
                    free[j].key.to_string()
                } else {
                    format!("{l:+.3} {}", free[j].key)
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
        notes.push(format!(
            "not identifiable: the data do not fix the combination {combo} (in the fit \
             coordinates; singular value {:.3e}, below {:e} of the largest {:.3e}): no sigma for \
             {}, whose interval is the profile likelihood's; the other keys keep theirs",
            d.singular,
            uncertainty::SINGULAR_REL,
            c.singular.first().copied().unwrap_or(f64::NAN),
            d.loadings
                .iter()
                .map(|&(j, _)| free[j].key.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let mut sigma = c.sigma.clone();
    let mut cov = c.cov.clone();
    // The keys of a direction the data cannot fix get their profile's interval: how far the
    // data let them go.
    let mut unfixed = vec![false; k];
    for d in &c.unidentified {
        for &(j, _) in &d.loadings {
            unfixed[j] = true;
        }
    }
    // The linear model's check at ±1σ (not with an ensemble: its χ² is noisy by construction).
    let mut flagged = vec![false; k];
    let mut jumpy = vec![false; k];
    if !ev.ensemble() {
        let offsets: Vec<(usize, Vec<f64>)> = (0..k)
            .filter_map(|j| uncertainty::linear_offset(&c, j).map(|d| (j, d)))
            .collect();
        let mut points = Vec::new();
        let mut which = Vec::new();
        for (j, d) in &offsets {
            for sign in [-1.0, 1.0] {
                let p: Vec<f64> = y.iter().zip(d).map(|(a, b)| a + sign * b).collect();
                if p.iter().zip(&ev.tr).all(|(&v, t)| t.inside(v)) {
                    points.push(p);
                    which.push((*j, sign));
                }
            }
        }
        if !points.is_empty() {
            ev.event(FitEvent::Stage {
                what: "checking the linear model at +-1 sigma".into(),
                runs_expected: points.len() * ev.model().runs_per_set(),
            });
        }
        let preds = match ev.predict_y(&points) {
            Ok(p) => p.into_iter().map(Some).collect(),
            // A run that fails within one σ: the response is not what σ assumes.
            Err(EvalError::Failed(_)) => vec![None; points.len()],
            Err(e) => return Err(e),
        };
        let mut found: Vec<Vec<String>> = vec![Vec::new(); k];
        let mut sides: Vec<Vec<f64>> = vec![Vec::new(); k];
        for ((j, sign), p) in which.iter().zip(&preds) {
            let d = p.as_ref().map_or(f64::NAN, |p| ev.chi2(p) - chi2);
            sides[*j].push(d);
            if !uncertainty::linear_agrees(d) {
                flagged[*j] = true;
                found[*j].push(format!(
                    "{} at {}1 sigma",
                    if d.is_nan() {
                        "a run failed".to_string()
                    } else {
                        format!("delta chi2 = {d:.3}")
                    },
                    if *sign < 0.0 { "-" } else { "+" }
                ));
            }
        }
        for j in 0..k {
            if flagged[j] {
                jumpy[j] = uncertainty::jumps(&sides[j]);
                notes.push(format!(
                    "{}: the model is not linear over one sigma ({} where the curvature puts 1, \
                     outside [{}, {}]): {}; the sigma from the curvature means nothing there, \
                     and the interval is the profile likelihood's",
                    free[j].key,
                    found[j].join(", "),
                    1.0 / uncertainty::LINEAR_FACTOR,
                    uncertainty::LINEAR_FACTOR,
                    if jumpy[j] {
                        "a jump or a kink of the model (chi2 rises steeply on both sides, or \
                         falls on one)"
                    } else {
                        "chi2 is far from quadratic over one sigma"
                    }
                ));
            }
        }
        if let Some(st) = last {
            if uncertainty::step_disagrees(st.predicted, st.actual) {
                notes.push(format!(
                    "along the optimiser's last step the linear model predicted a fall of chi2 \
                     of {:.3}, the model gave {:.3}: every interval is the profile \
                     likelihood's",
                    st.predicted, st.actual
                ));
                for (j, f) in flagged.iter_mut().enumerate() {
                    *f |= sigma[j].is_some();
                }
            }
        }
    }
    let mut intervals: Vec<Option<(f64, f64, bool)>> = (0..k)
        .map(|j| sigma[j].map(|s| (y[j] - s, y[j] + s, false)))
        .collect();
    let mut lower: Option<(f64, Vec<f64>)> = None;
    for j in 0..k {
        if !(flagged[j] || unfixed[j] || opts.profile && sigma[j].is_some()) {
            continue;
        }
        ev.event(FitEvent::Stage {
            what: format!("profile likelihood of {}", free[j].key),
            runs_expected: 20 * ev.model().runs_per_set() * k,
        });
        let t = &ev.tr[j];
        let limits = uncertainty::reach(t.log, y[j], t.lo, t.hi);
        let first = match sigma[j] {
            Some(s) if !jumpy[j] => s,
            Some(s) => s.max(uncertainty::FIRST_STEP_MIN),
            None => uncertainty::FIRST_STEP_MIN,
        };
        let dir: Vec<f64> = (0..k)
            .map(|i| {
                let r = c.cov[(i, j)] / c.cov[(j, j)];
                if i != j && r.is_finite() {
                    r
                } else {
                    0.0
                }
            })
            .collect();
        let mut p = ProfileOf {
            ev,
            dir,
            s: lm::Settings {
                max_iterations: uncertainty::PROFILE_ITERATIONS,
                gtol: 1e-2,
                ..*s
            },
        };
        let prof =
            match uncertainty::scan(&mut p, j, y, chi2, first, limits, flagged[j], may_restart) {
                Ok(p) => p,
                Err(_) => return Err(EvalError::Stopped),
            };
        if let Some((c2, yl)) = prof.lower.clone() {
            if lower.as_ref().is_none_or(|(b, _)| c2 < *b) {
                lower = Some((c2, yl));
            }
            if may_restart {
                // The fit goes on from there: the other intervals would be redone anyway.
                break;
            }
        }
        let x = |v: f64| t.x(v);
        for (open, end) in [(prof.open_lo, prof.lo), (prof.open_hi, prof.hi)] {
            if open {
                notes.push(format!(
                    "{}: its profile-likelihood interval reaches the end of the scan at {} {} \
                     (the data do not bound it there)",
                    free[j].key,
                    crate::output::table::format_sig(x(end), 4),
                    free[j].unit
                ));
            }
        }
        intervals[j] = Some((prof.lo, prof.hi, true));
        if flagged[j] {
            sigma[j] = None;
            for i in 0..k {
                cov[(i, j)] = f64::NAN;
                cov[(j, i)] = f64::NAN;
            }
        }
    }
    Ok(Analysis {
        sigma,
        cov,
        intervals,
        notes,
        lower,
    })
}

/// Fit the free keys `free` (starting at `x0`, SI) of `model` to its data.
pub fn fit(
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
        return Err(FitError::new("give at least one --free KEY"));
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
    // Start a little inside a bound: at a bound dy/du = 0 and the key could not move.
    let y0: Vec<f64> = x0
        .iter()
        .zip(&tr)
        .map(|(&x, t)| {
            let mut y = t.y(x);
            let span = match (t.lo, t.hi) {
                (Some(l), Some(h)) => 0.01 * (h - l),
                _ => 0.01,
            };
            if t.lo.is_some_and(|l| y - l < span) {
                y = t.lo.unwrap_or(y) + span;
            }
            if t.hi.is_some_and(|h| h - y < span) {
                y = t.hi.unwrap_or(y) - span;
            }
            y
        })
        .collect();
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
    let eps = if members > 1 {
        Err(
            "the scenario's: with an ensemble its standard error, not the integration, limits \
             the accuracy (and a chaotic member changes entirely with any tolerance)"
                .to_string(),
        )
    } else if !data.has_sigma {
        Err("the scenario's: the data have no sigma column to scale the model's error".into())
    } else {
        Ok(tolerance::ERROR_FRACTION
            * data
                .rows
                .iter()
                .filter(|r| r.observed != 0.0)
                .map(|r| r.sigma.unwrap_or(f64::INFINITY) / r.observed.abs())
                .fold(f64::INFINITY, f64::min))
    };
    let (mut rtol, mut envelope_tol, chosen, why) = tolerance::choose(&tol_s, eps);
    let error_level = |rtol: f64, env: f64| {
        tolerance::RTOL_GAIN * rtol
            + if tol_s.envelope {
                tolerance::ENVELOPE_GAIN * env
            } else {
                0.0
            }
    };
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
    let eps_rel = error_level(rtol, envelope_tol);
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
    let w: Vec<f64> = (0..n)
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
        .collect();
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
    let mut start_ys = vec![y0.clone()];
    if opts.starts > 1 {
        let ranges: Vec<(f64, f64)> = tr
            .iter()
            .zip(&y0)
            .map(|(t, &y)| starts::range(t.log, y, t.lo, t.hi))
            .collect();
        for p in starts::latin_hypercube(opts.starts - 1, k, starts::SEED) {
            start_ys.push(
                p.iter()
                    .zip(&ranges)
                    .map(|(q, (a, b))| a + q * (b - a))
                    .collect(),
            );
        }
    }
    let mut ends: Vec<End1> = Vec::new();
    let mut stopped = false;
    for (i, ys) in start_ys.iter().enumerate() {
        if opts.starts > 1 {
            ev.event(FitEvent::Stage {
                what: format!("start {} of {}", i + 1, opts.starts),
                runs_expected: expected_runs(model, k, opts.starts - i),
            });
        }
        let r0 = if i == 0 {
            Ok(ev.residuals_of(&p0))
        } else {
            match ev.eval_y(ys) {
                Ok(p) if ev.chi2(&p).is_finite() => Ok(ev.residuals_of(&p)),
                Ok(_) => Err("chi2 is not finite at this start".to_string()),
                Err(EvalError::Failed(m)) => Err(format!("a run failed at this start: {m}")),
                Err(EvalError::Stopped) => {
                    stopped = true;
                    break;
                }
            }
        };
        let end = match r0 {
            Ok(r0) => {
                let (o, y) = optimise(&ev, ys, r0, &s);
                let halted = o.end == End::Halted(Halt::Stopped);
                let e = End1 {
                    start: ys.clone(),
                    y,
                    outcome: Ok(o),
                };
                if halted {
                    stopped = true;
                }
                e
            }
            Err(m) => End1 {
                start: ys.clone(),
                y: ys.clone(),
                outcome: Err(m),
            },
        };
        ends.push(end);
        if stopped {
            break;
        }
    }
    let best_i = (0..ends.len())
        .filter(|&i| ends[i].outcome.is_ok())
        .min_by(|&a, &b| {
            let c = |i: usize| ends[i].outcome.as_ref().map_or(f64::INFINITY, |o| o.chi2);
            c(a).total_cmp(&c(b))
        });
    let mut current: Option<(Outcome, Vec<f64>)> = best_i.and_then(|i| {
        ends[i]
            .outcome
            .as_ref()
            .ok()
            .map(|o| (o.clone(), ends[i].y.clone()))
    });
    let mut model_error = None;
    let mut analysis: Option<Analysis> = None;
    let mut restarts = 0;
    let mut tightenings = 0;
    let reference = model.clone();
    // 3 and 4: the check of the tolerances, then the uncertainty, until neither moves the
    // estimate.
    while let (false, Some((o, y))) = (stopped, current.clone()) {
        if let End::Halted(Halt::Failed(m)) = &o.end {
            notes.push(format!("a forward run failed, which ended the fit: {m}"));
            break;
        }
        if chosen {
            ev.event(FitEvent::Stage {
                what: "checking the model's error at the scenario's tolerances".into(),
                runs_expected: model.runs_per_set(),
            });
            let x = ev.x_of_y(&y);
            let p_fit = ev.eval_y(&y);
            let p_ref = ev.predict_on(&reference, std::slice::from_ref(&x));
            match (p_fit, p_ref) {
                (Ok(pf), Ok(mut pr)) => {
                    let pr = pr.remove(0);
                    let e = (0..n)
                        .map(|i| (pf.values[i] - pr.values[i]).abs() / w[i])
                        .fold(0.0, f64::max);
                    model_error = Some(e);
                    if e > tolerance::ERROR_FRACTION && tightenings < MAX_TIGHTENINGS {
                        tightenings += 1;
                        let (r, en) = tolerance::tighten(&tol_s, rtol, envelope_tol, e);
                        notes.push(format!(
                            "at the estimate the model's error was {e:.3} sigma at rtol {rtol:e}, \
                             envelope_tol {envelope_tol:e} (more than {} allowed): the fit went \
                             on at rtol {r:e}, envelope_tol {en:e}",
                            tolerance::ERROR_FRACTION
                        ));
                        rtol = r;
                        envelope_tol = en;
                        let lvl = error_level(rtol, envelope_tol);
                        ev.set_model(model.with_solver(tolerance::overrides(
                            &tol_s,
                            rtol,
                            envelope_tol,
                        )));
                        ev.set_error(obs_abs.iter().map(|o| lvl * o).collect(), fd_step(lvl));
                        match ev.eval_y(&y) {
                            Ok(p) => {
                                let (o2, y2) = optimise(&ev, &y, ev.residuals_of(&p), &s);
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
            runs_expected: 2 * k * model.runs_per_set(),
        });
        let scale = if data.has_sigma {
            1.0
        } else {
            o.chi2 / dof as f64
        };
        let ratio = {
            let st = ev.st.borrow();
            (members > 1 && data.has_sigma && st.se2_sets > 0).then(|| {
                DVector::from_fn(n, |i, _| {
                    let sg = data.rows[i].sigma.unwrap_or(1.0);
                    (sg * sg + st.se2[i] / st.se2_sets as f64) / (w[i] * w[i])
                })
            })
        };
        match analyse(
            &ev,
            free,
            &y,
            o.chi2,
            o.last_step.as_ref(),
            scale,
            ratio.as_ref(),
            &opts,
            &s,
            restarts < MAX_RESTARTS,
        ) {
            Ok(a) => {
                if let (Some((c2, yl)), true) = (&a.lower, restarts < MAX_RESTARTS) {
                    restarts += 1;
                    notes.push(format!(
                        "a profile met chi2 = {c2:.4} at {}, below the estimate's {:.4}: the fit \
                         went on from there",
                        describe(free, &tr, yl),
                        o.chi2
                    ));
                    match ev.eval_y(yl) {
                        Ok(p) => {
                            let (o2, y2) = optimise(&ev, yl, ev.residuals_of(&p), &s);
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
                            describe(free, &tr, yl),
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
        (true, _) => match ev.predict_on(&reference, std::slice::from_ref(&values)) {
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
    if stopped {
        notes.push(
            "interrupted: the estimate is the best met so far (lowest chi2), not converged; no \
             sigma"
                .into(),
        );
    } else if !converged {
        notes.push(format!(
            "not converged ({}): the estimate is the best met; no sigma is given for a fit that \
             did not converge",
            end.words()
        ));
    }
    let reduced = chi2 / dof as f64;
    if data.has_sigma && reduced > 10.0 {
        notes.push(format!(
            "poor fit: reduced chi2 = {reduced:.3e}: the model does not describe the data within \
             their sigma, or the fit ended in a local minimum ({}); the sigma of the parameters \
             are not reliable",
            if opts.starts > 1 {
                format!("the best of {} starts", opts.starts)
            } else {
                "try --starts N to fit from N starting points".to_string()
            }
        ));
    }
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
    if members > 1 {
        let steps = ev.steps();
        let snr = ev.st.borrow().snr.clone();
        let list = |f: &dyn Fn(usize) -> String| {
            (0..k)
                .map(|j| format!("{} {}", free[j].key, f(j)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        notes.push(format!(
            "Jacobians by central differences whose steps widen until the change stands 10 times \
             above the ensemble noise; half-steps in the fit coordinates at the estimate: {}; \
             signal-to-noise: {}",
            list(&|j| format!("{:.3}", steps[j])),
            list(&|j| format!("{:.1}", snr.get(j).copied().unwrap_or(f64::NAN)))
        ));
        for (j, f) in free.iter().enumerate() {
            if snr.get(j).is_some_and(|&r| r < 3.0) {
                notes.push(format!(
                    "{}: the ensemble noise dominates its Jacobian column even at the widest step \
                     (signal-to-noise {:.1} < 3), so its sigma is uncertain: fit with more \
                     --ensemble members",
                    f.key, snr[j]
                ));
            }
        }
    } else if converged {
        let snr = ev.jacobian_snr(&y_best).map(|(_, s)| s).unwrap_or_default();
        for (j, f) in free.iter().enumerate() {
            if snr.get(j).is_some_and(|&r| r < 3.0) && !at_bound[j] {
                notes.push(format!(
                    "{}: its Jacobian column stands at most {:.1} times above the model's \
                     numerical error even at the widest step: the data barely see it",
                    f.key, snr[j]
                ));
            }
        }
    }
    // Minima of the starts.
    let ends_y: Vec<Option<(Vec<f64>, f64)>> = ends
        .iter()
        .map(|e| e.outcome.as_ref().ok().map(|o| (e.y.clone(), o.chi2)))
        .collect();
    let minima = starts::minima(&ends_y);
    if opts.starts > 1 {
        let best_m = best_i.map(|i| minima[i]);
        let q = starts::chi2_95(k);
        let mut seen = Vec::new();
        for (i, e) in ends.iter().enumerate() {
            let Ok(o) = &e.outcome else { continue };
            let m = minima[i];
            if Some(m) == best_m || seen.contains(&m) || !o.end.converged() {
                continue;
            }
            seen.push(m);
            if o.chi2 - chi2_fit <= q {
                notes.push(format!(
                    "another minimum lies within delta chi2 = {:.3} of the best (less than \
                     {q}, the 95 % quantile for {k} key(s)): {} (start {}); the data do not tell \
                     it from the estimate",
                    o.chi2 - chi2_fit,
                    describe(free, &tr, &e.y),
                    i + 1
                ));
            }
        }
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
    let analysis = analysis.filter(|_| converged);
    let mut sigma_y: Vec<Option<f64>> = vec![None; k];
    let mut cov_y = DMatrix::from_element(k, k, f64::NAN);
    let mut intervals: Vec<Option<(f64, f64, bool)>> = vec![None; k];
    if let Some(a) = analysis {
        notes.extend(a.notes);
        for j in 0..k {
            if !at_bound[j] {
                sigma_y[j] = a.sigma[j];
                intervals[j] = a.intervals[j];
            }
        }
        cov_y = a.cov;
    }
    let dx: Vec<f64> = y_best.iter().zip(&tr).map(|(&y, t)| t.dx_dy(y)).collect();
    let mut sigma: Vec<Option<f64>> = (0..k).map(|j| sigma_y[j].map(|s| s * dx[j])).collect();
    for (j, f) in free.iter().enumerate() {
        if let Some(s) = sigma[j] {
            if !s.is_finite() {
                sigma[j] = None;
                notes.push(format!("{}: sigma is not finite; none given", f.key));
            } else if s <= 0.0 {
                sigma[j] = None;
                notes.push(format!(
                    "{}: sigma underflowed to 0 (the rows' sigma are far below what the model \
                     resolves); none given",
                    f.key
                ));
            }
        }
    }
    let has = |j: usize| sigma[j].is_some();
    let covariance: Vec<Vec<Option<f64>>> = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| (has(a) && has(b)).then(|| cov_y[(a, b)] * dx[a] * dx[b]))
                .collect()
        })
        .collect();
    let correlation: Vec<Vec<Option<f64>>> = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| {
                    (has(a) && has(b))
                        .then(|| cov_y[(a, b)] / (cov_y[(a, a)] * cov_y[(b, b)]).sqrt())
                })
                .collect()
        })
        .collect();
    for a in 0..k {
        for b in a + 1..k {
            if let Some(c) = correlation[a][b] {
                if c.abs() > 0.999 {
                    notes.push(format!(
                        "not identifiable separately: {} and {} are correlated by {c:.4} \
                         (> 0.999); their sigma are large and mostly shared",
                        free[a].key, free[b].key
                    ));
                }
            }
        }
    }
    let parameters = free
        .iter()
        .enumerate()
        .map(|(j, f)| {
            let interval =
                intervals[j].filter(|_| sigma[j].is_some() || intervals[j].is_some_and(|i| i.2));
            Parameter {
                key: f.key.to_string(),
                value: values[j],
                sigma: sigma[j],
                interval: interval.map(|(lo, hi, _)| {
                    let (a, b) = (tr[j].x(lo), tr[j].x(hi));
                    [a.min(b), a.max(b)]
                }),
                interval_from: interval.map(|i| if i.2 { "profile" } else { "curvature" }),
                unit: f.unit.to_string(),
                initial: x0[j],
            }
        })
        .collect();
    let steps = ev.steps();
    let st = ev.st.borrow();
    let report = FitReport {
        parameters,
        covariance,
        correlation,
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
        cov_y: (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| {
                        if has(a) && has(b) {
                            cov_y[(a, b)]
                        } else {
                            f64::NAN
                        }
                    })
                    .collect()
            })
            .collect(),
        stepped: (0..k)
            .map(|j| {
                let mut y = y_best.clone();
                y[j] += steps[j];
                ev.x_of_y(&y)
            })
            .collect(),
        y: y_best,
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

/// Forward runs a fit is expected to take (for progress): the start, and per start about 8
/// iterations of [`sets_per_iteration`], and the check of the uncertainties.
pub fn expected_runs(model: &ForwardModel, k: usize, starts: usize) -> usize {
    let per_set = model.runs_per_set();
    per_set * (1 + starts.max(1) * 8 * sets_per_iteration(model.members(), k) + 2 * k)
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
