//! What a fit reports: `fit.json` ([`FitReport`]), the outcome the files are written from
//! ([`FitOutcome`]), the options ([`FitOptions`]), the progress events ([`FitEvent`]) and the
//! error of a fit that has no estimate ([`FitError`]).

use std::sync::atomic::AtomicBool;

use serde::Serialize;

use nalgebra::DMatrix;

use super::free::{FreeKey, Transform};
use super::model::{ParamSet, Prediction};
use super::starts;

/// What a fit reports as it goes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum FitEvent {
    /// A forward run ended.
    Run,
    /// An iteration (a Jacobian) ended, or the first evaluation (`iteration` 0).
    Iteration {
        /// Iterations so far (all starts, profiles and refits).
        iteration: usize,
        /// χ² at the iteration's point.
        chi2: f64,
        /// The best χ² met.
        best: f64,
        /// Forward runs so far.
        runs: usize,
    },
    /// A new stage of the fit begins (a start, the check of the tolerances, the uncertainty
    /// analysis, a profile), with the forward runs it is expected to take in all from now on.
    Stage {
        /// What, in words.
        what: String,
        /// Forward runs expected from now on (an estimate).
        runs_expected: usize,
    },
}

/// How to fit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FitOptions<'a> {
    /// Most Jacobians (iterations) of each optimisation.
    pub max_iterations: usize,
    /// Starting points: the given one and `starts − 1` drawn by Latin hypercube.
    pub starts: usize,
    /// Profile-likelihood intervals for every key (otherwise only where the linear model fails).
    pub profile: bool,
    /// Raised (Ctrl-C): stop and keep the best estimate.
    pub stop: Option<&'a AtomicBool>,
}

impl Default for FitOptions<'_> {
    fn default() -> Self {
        FitOptions {
            max_iterations: 30,
            starts: 1,
            profile: false,
            stop: None,
        }
    }
}

/// One parameter of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// The key.
    pub key: String,
    /// The estimate (in `unit`).
    pub value: f64,
    /// Its standard deviation from the curvature (in `unit`), or null where the curvature does
    /// not support one (a fit that did not converge, a bound hit, a key the data cannot fix, a
    /// model that is not linear over one σ).
    pub sigma: Option<f64>,
    /// The 68 % interval `[lo, hi]` (in `unit`): the profile likelihood's where
    /// `interval_from` is `"profile"`, else the curvature's (the estimate ± σ in the fit
    /// coordinate: `value · exp(∓σ/value)` for a key in log space); null without either.
    pub interval: Option<[f64; 2]>,
    /// `"profile"` or `"curvature"` (null without an interval).
    pub interval_from: Option<&'static str>,
    /// The key's SI unit.
    pub unit: String,
    /// The starting value (the scenario's, in `unit`).
    pub initial: f64,
    /// The fit coordinate: `"log"` (`ln x`) or `"linear"` (`x / |initial|`, or `x` from a start
    /// of 0); what `predict` and `design` differentiate and draw in.
    pub coordinate: &'static str,
    /// The bounds `[lo, hi]` the key was fitted within (in `unit`; null where none).
    pub bounds: [Option<f64>; 2],
}

/// One start of a multi-start fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StartReport {
    /// The starting values (in the keys' units).
    pub start: Vec<f64>,
    /// Where the optimiser ended (in the keys' units).
    pub estimate: Vec<f64>,
    /// χ² there (at the fit's tolerances; null where the start could not be evaluated).
    pub chi2: Option<f64>,
    /// Whether it met a convergence criterion.
    pub converged: bool,
    /// Which distinct minimum it reached: 0 the best, 1 the next, …
    pub minimum: usize,
    /// Iterations.
    pub iterations: usize,
    /// Why it ended, or why it could not start.
    pub termination: String,
}

/// The solver tolerances of the forward runs and their check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tolerances {
    /// `solver.rtol` of the fit's runs.
    pub rtol: f64,
    /// `solver.envelope_tol` of the fit's runs.
    pub envelope_tol: f64,
    /// The scenario's (with `--set`): those of the check, and of `fitted.toml`.
    pub scenario_rtol: f64,
    /// The scenario's `solver.envelope_tol`.
    pub scenario_envelope_tol: f64,
    /// Whether the fit chose its tolerances (false: the scenario's, kept: `--set`, no sigma
    /// column, an ensemble, or data more precise than the scenario's tolerances resolve).
    pub chosen: bool,
    /// The largest model error allowed, as a fraction of a row's sigma.
    pub limit: f64,
    /// The model error at the estimate: the largest over the rows of |prediction at the fit's
    /// tolerances − at the scenario's| / sigma (null when not checked).
    pub model_error: Option<f64>,
    /// Why the fit's tolerances are what they are, in words.
    pub why: String,
}

/// A fit's ensemble in `fit.json`: the members of each row's mean and the seed of their base
/// phases ([`crate::sweep::phase::ensemble_phase`]`(seed, row, member)`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Ensemble {
    /// Members per row.
    pub members: usize,
    /// The seed of their phases.
    pub seed: u64,
}

/// The content of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The estimates.
    pub parameters: Vec<Parameter>,
    /// Covariance matrix in the keys' units (`unit_i · unit_j`), in the order of `parameters`
    /// (null where a key has no σ).
    pub covariance: Vec<Vec<Option<f64>>>,
    /// Correlation matrix, in the order of `parameters` (null where undefined).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Σ ((obs − fit)/σ)² at the estimate (σ = 1 in the observable's unit without a sigma column).
    pub chi2: f64,
    /// Rows − free keys.
    pub dof: usize,
    /// χ² / dof.
    pub reduced_chi2: f64,
    /// χ² + 2k.
    pub aic: f64,
    /// χ² + k ln n.
    pub bic: f64,
    /// Whether the optimiser met a convergence criterion (false when stopped, out of
    /// iterations or ended by a failed run).
    pub converged: bool,
    /// The criterion that ended the optimiser of the best start, in words.
    pub termination: String,
    /// Jacobians computed (all starts, refits and profiles).
    pub iterations: usize,
    /// Forward runs made.
    pub forward_runs: usize,
    /// Right-hand-side evaluations of those runs (the integration's work).
    pub rhs_evals: u64,
    /// The observable fitted (as named in sweep.csv).
    pub observable: String,
    /// The ensemble each row's prediction was the mean of (`--ensemble N --seed S`; null
    /// without): what `predict` needs to predict with the same members.
    pub ensemble: Option<Ensemble>,
    /// What the numbers need said.
    pub notes: Vec<String>,
    /// Every start (one without `--starts`).
    pub starts: Vec<StartReport>,
    /// The forward runs' tolerances.
    pub tolerances: Tolerances,
    /// Data rows.
    pub rows: usize,
    /// Wall time of the fit (s).
    pub wall_s: f64,
    /// Whether a stop (Ctrl-C) ended the fit (the estimate is the best so far).
    pub interrupted: bool,
}

/// A fit's result: the report and what the files need.
#[derive(Debug, Clone)]
pub(crate) struct FitOutcome {
    /// `fit.json`.
    pub report: FitReport,
    /// The estimates (SI), in the order of the free keys.
    pub values: ParamSet,
    /// The prediction at the estimates (at the scenario's tolerances when they were checked).
    pub prediction: Prediction,
    /// The σ each row was weighted with (SI; 1 without a sigma column).
    pub weights: Vec<f64>,
    /// The covariance of the keys in their fit coordinates (k × k, NaN where none), and the
    /// derivative dx/dy of each key at the estimate: what a ±1σ band of the model needs.
    pub cov_y: Vec<Vec<f64>>,
    /// Each key's forward-difference step in the fit coordinate at the end.
    pub steps: Vec<f64>,
    /// The parameter sets (SI) of the estimate with each key stepped by its step in `steps`.
    pub stepped: Vec<ParamSet>,
}

/// A fit that could not start, whose first evaluation failed, or that was stopped (Ctrl-C)
/// before its first evaluation ended, so that no estimate exists to report.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub(crate) struct FitError {
    /// What went wrong, as one line.
    pub message: String,
    /// The stop flag ended the first evaluation: not an error of the input, and nothing to write.
    pub stopped: bool,
}

impl FitError {
    /// An error of the input or of a forward run.
    pub fn new(message: impl Into<String>) -> Self {
        FitError {
            message: message.into(),
            stopped: false,
        }
    }
}

/// The keys' part of the report: [`Parameter`]s, covariance and correlation in the keys'
/// units, the covariance in the fit coordinates as [`FitOutcome::cov_y`] keeps it, and notes.
#[derive(Debug, Clone, PartialEq)]
pub struct Keys {
    /// The parameters as `fit.json` lists them.
    pub parameters: Vec<Parameter>,
    /// The covariance in the keys' units (None where a key has no σ).
    pub covariance: Vec<Vec<Option<f64>>>,
    /// The correlations (None where a key has no σ).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// The covariance in the fit coordinates (NaN where a key has no σ).
    pub cov_y: Vec<Vec<f64>>,
    /// What the report says about them.
    pub notes: Vec<String>,
}

/// The report of the keys `free` (transforms `tr`, starts `x0`) at the estimate `values` (SI;
/// `y` in the fit coordinates, `at_bound` per key) from the uncertainty analysis, when there is
/// one (a converged fit): σ per key, the covariance and the intervals in the fit coordinates
/// (the interval's flag: from the profile). σ and the covariance go to the keys' units by the
/// transform's derivative (`dx/dy`: `x` for a key in log space); a key at its bound, or whose σ
/// is not finite or underflowed to 0, has none (with a note for the latter); correlations above
/// 0.999 are named. A key keeps a curvature interval only with its σ, a profile one always.
#[allow(clippy::type_complexity)]
pub fn keys(
    free: &[FreeKey],
    tr: &[Transform],
    x0: &[f64],
    values: &[f64],
    y: &[f64],
    at_bound: &[bool],
    analysis: Option<(
        Vec<Option<f64>>,
        DMatrix<f64>,
        Vec<Option<(f64, f64, bool)>>,
    )>,
) -> Keys {
    let k = free.len();
    let mut notes = Vec::new();
    let mut sigma_y: Vec<Option<f64>> = vec![None; k];
    let mut cov_y = DMatrix::from_element(k, k, f64::NAN);
    let mut intervals: Vec<Option<(f64, f64, bool)>> = vec![None; k];
    if let Some((s, c, iv)) = analysis {
        for j in 0..k {
            if !at_bound[j] {
                sigma_y[j] = s[j];
                intervals[j] = iv[j];
            }
        }
        cov_y = c;
    }
    let dx: Vec<f64> = y.iter().zip(tr).map(|(&y, t)| t.dx_dy(y)).collect();
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
    // The upper triangle's element for both: the matrices come out exactly symmetric, whatever
    // the rounding of the covariance's two halves.
    let upper = |a: usize, b: usize| cov_y[(a.min(b), a.max(b))];
    let covariance: Vec<Vec<Option<f64>>> = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| (has(a) && has(b)).then(|| upper(a, b) * (dx[a] * dx[b])))
                .collect()
        })
        .collect();
    let correlation: Vec<Vec<Option<f64>>> = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| {
                    (has(a) && has(b)).then(|| upper(a, b) / (cov_y[(a, a)] * cov_y[(b, b)]).sqrt())
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
                coordinate: if tr[j].log { "log" } else { "linear" },
                bounds: [f.lo, f.hi],
            }
        })
        .collect();
    Keys {
        parameters,
        cov_y: (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| {
                        if has(a) && has(b) {
                            upper(a, b)
                        } else {
                            f64::NAN
                        }
                    })
                    .collect()
            })
            .collect(),
        covariance,
        correlation,
        notes,
    }
}

/// Notes for the other converged minima of a multi-start whose χ² lies within the 95 %
/// quantile of χ² for `k` keys ([`starts::chi2_95`]) of the best's `chi2_best`: `ends` per
/// start (χ², converged, the keys' values in words; None where the start could not be
/// optimised), `minima` the distinct minimum of each ([`starts::minima`]), `best` the
/// estimate's start. One note per minimum, from its first start.
pub fn other_minima(
    ends: &[Option<(f64, bool, String)>],
    minima: &[usize],
    best: Option<usize>,
    chi2_best: f64,
    k: usize,
) -> Vec<String> {
    let best_m = best.map(|i| minima[i]);
    let q = starts::chi2_95(k);
    let mut seen = Vec::new();
    let mut notes = Vec::new();
    for (i, e) in ends.iter().enumerate() {
        let Some((chi2, converged, at)) = e else {
            continue;
        };
        let m = minima[i];
        if Some(m) == best_m || seen.contains(&m) || !converged {
            continue;
        }
        seen.push(m);
        if chi2 - chi2_best <= q {
            notes.push(format!(
                "another minimum lies within delta chi2 = {:.3} of the best (less than {q}, the \
                 95 % quantile for {k} key(s)): {at} (start {}); the data do not tell it from \
                 the estimate",
                chi2 - chi2_best,
                i + 1
            ));
        }
    }
    notes
}

/// What `notes` says of the fit as a whole: interrupted (`stopped`), not converged (`end`: the
/// termination in words), or a poor fit (`reduced`: the reduced χ² with a sigma column, above
/// 10: the model misses the data, or a local minimum; `starts` the starting points tried).
pub fn verdict(
    stopped: bool,
    converged: bool,
    end: &str,
    reduced: Option<f64>,
    starts: usize,
) -> Vec<String> {
    let mut notes = Vec::new();
    if stopped {
        notes.push(
            "interrupted: the estimate is the best met so far (lowest chi2), not converged; no \
             sigma"
                .into(),
        );
    } else if !converged {
        notes.push(format!(
            "not converged ({end}): the estimate is the best met; no sigma is given for a fit \
             that did not converge"
        ));
    }
    if let Some(reduced) = reduced.filter(|&r| r > 10.0) {
        notes.push(format!(
            "poor fit: reduced chi2 = {reduced:.3e}: the model does not describe the data within \
             their sigma, or the fit ended in a local minimum ({}); the sigma of the parameters \
             are not reliable",
            if starts > 1 {
                format!("the best of {starts} starts")
            } else {
                "fitting from several starting points (starts) may find a better one".to_string()
            }
        ));
    }
    notes
}

/// What `notes` says of the Jacobian's columns at the estimate (`keys`, their signal-to-noise
/// `snr`: how far each column's change stands above the model's error, or with an ensemble
/// its noise): with an ensemble (`steps`: the central differences' half-steps) both listed,
/// and a column below 3 makes its σ uncertain; without, a column below 3 (a key not at its
/// bound) is one the data barely see.
pub fn columns(
    keys: &[String],
    steps: Option<&[f64]>,
    snr: &[f64],
    at_bound: &[bool],
) -> Vec<String> {
    let mut notes = Vec::new();
    match steps {
        Some(steps) => {
            let list = |f: &dyn Fn(usize) -> String| {
                keys.iter()
                    .enumerate()
                    .map(|(j, key)| format!("{key} {}", f(j)))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            notes.push(format!(
                "Jacobians by central differences whose steps widen until the change stands 10 \
                 times above the ensemble noise; half-steps in the fit coordinates at the \
                 estimate: {}; signal-to-noise: {}",
                list(&|j| format!("{:.3}", steps[j])),
                list(&|j| format!("{:.1}", snr.get(j).copied().unwrap_or(f64::NAN)))
            ));
            for (j, key) in keys.iter().enumerate() {
                if snr.get(j).is_some_and(|&r| r < 3.0) {
                    notes.push(format!(
                        "{key}: the ensemble noise dominates its Jacobian column even at the \
                         widest step (signal-to-noise {:.1} < 3), so its sigma is uncertain: fit \
                         with more ensemble members",
                        snr[j]
                    ));
                }
            }
        }
        None => {
            for (j, key) in keys.iter().enumerate() {
                if snr.get(j).is_some_and(|&r| r < 3.0) && !at_bound[j] {
                    notes.push(format!(
                        "{key}: its Jacobian column stands at most {:.1} times above the model's \
                         numerical error even at the widest step: the data barely see it",
                        snr[j]
                    ));
                }
            }
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two() -> (Vec<FreeKey>, Vec<Transform>, Vec<f64>) {
        let free: Vec<FreeKey> = ["adhesion.v0", "damping.c=0:100"]
            .iter()
            .map(|a| FreeKey::parse(a).expect("a key"))
            .collect();
        let x0 = vec![6e-5, 10.0];
        let tr = free
            .iter()
            .zip(&x0)
            .map(|(f, &x)| Transform::new(f, x))
            .collect();
        (free, tr, x0)
    }

    /// The covariance in the keys' units is the fit coordinates' carried by the transforms'
    /// slopes, checked against central differences of `x(y)`; the correlation is unchanged.
    #[test]
    fn the_covariance_is_in_the_keys_units() {
        let (free, tr, x0) = two();
        let values = [5e-5, 12.0];
        let y: Vec<f64> = tr.iter().zip(&values).map(|(t, &x)| t.y(x)).collect();
        let (s0, s1, rho) = (0.1, 0.02, 0.6);
        let cov = DMatrix::from_row_slice(2, 2, &[s0 * s0, rho * s0 * s1, rho * s0 * s1, s1 * s1]);
        let iv = vec![None, Some((y[1] - 0.03, y[1] + 0.02, true))];
        let r = keys(
            &free,
            &tr,
            &x0,
            &values,
            &y,
            &[false, false],
            Some((vec![Some(s0), Some(s1)], cov, iv)),
        );
        let slope = |j: usize| {
            let h = 1e-6;
            (tr[j].x(y[j] + h) - tr[j].x(y[j] - h)) / (2.0 * h)
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs();
        let c = &r.covariance;
        assert!(
            close(c[0][0].unwrap(), s0 * s0 * slope(0) * slope(0)),
            "{c:?}"
        );
        assert!(
            close(c[1][1].unwrap(), s1 * s1 * slope(1) * slope(1)),
            "{c:?}"
        );
        assert!(close(c[0][1].unwrap(), rho * s0 * s1 * slope(0) * slope(1)));
        assert_eq!(c[0][1].map(f64::to_bits), c[1][0].map(f64::to_bits));
        assert_eq!(
            r.correlation[0][1].map(f64::to_bits),
            r.correlation[1][0].map(f64::to_bits)
        );
        assert!(close(r.correlation[0][1].unwrap(), rho));
        let p = &r.parameters;
        assert!(close(p[0].sigma.unwrap(), s0 * slope(0).abs()));
        assert_eq!(p[0].interval, None);
        assert_eq!(p[1].interval_from, Some("profile"));
        let [lo, hi] = p[1].interval.unwrap();
        assert!(lo < 12.0 && hi > 12.0, "{lo} {hi}");
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        assert!(close(r.cov_y[0][1], rho * s0 * s1));
    }

    /// A key at its bound, or whose σ is not finite, has none, nor covariance or correlation
    /// with the others; a curvature interval goes with its σ; correlations above 0.999 and a
    /// σ that is not finite are named; without an analysis nothing is given.
    #[test]
    fn keys_without_sigma_and_tight_correlations_are_named() {
        let (free, tr, x0) = two();
        let values = [6e-5, 10.0];
        let y: Vec<f64> = tr.iter().zip(&values).map(|(t, &x)| t.y(x)).collect();
        let cov = DMatrix::from_row_slice(2, 2, &[1e-2, 0.9995e-3, 0.9995e-3, 1e-4]);
        let iv = vec![Some((y[0] - 0.1, y[0] + 0.1, false)); 2];
        let full = Some((vec![Some(0.1), Some(0.01)], cov.clone(), iv.clone()));
        let r = keys(&free, &tr, &x0, &values, &y, &[false, true], full.clone());
        assert!(r.parameters[0].sigma.is_some() && r.parameters[1].sigma.is_none());
        assert_eq!(r.parameters[1].interval, None);
        assert_eq!(r.covariance[0][1], None);
        assert!(r.cov_y[1][1].is_nan());
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        let r = keys(&free, &tr, &x0, &values, &y, &[false, false], full);
        assert!(
            r.notes.iter().any(|n| n.contains("correlated by 0.9995")),
            "{:?}",
            r.notes
        );
        let inf = Some((vec![Some(f64::INFINITY), Some(0.01)], cov, iv));
        let r = keys(&free, &tr, &x0, &values, &y, &[false, false], inf);
        assert_eq!(r.parameters[0].sigma, None);
        assert!(r.notes[0].contains("adhesion.v0: sigma is not finite"));
        let r = keys(&free, &tr, &x0, &values, &y, &[false, false], None);
        assert!(r
            .parameters
            .iter()
            .all(|p| p.sigma.is_none() && p.interval.is_none()));
        assert!(r.covariance.iter().flatten().all(Option::is_none));
    }

    /// Another converged minimum within the 95 % quantile of χ² for k keys gets one note (5.99
    /// for two keys); one beyond it, an unconverged end, the best's own minimum and a second
    /// start of a minimum already named get none.
    #[test]
    fn other_minima_within_the_quantile_are_named_once() {
        let e = |c: f64, conv: bool, at: &str| Some((c, conv, at.to_string()));
        let ends = vec![
            e(10.0, true, "best"),
            e(15.0, true, "near"),
            e(15.0, true, "near again"),
            e(16.5, true, "far"),
            e(11.0, false, "unconverged"),
            None,
            e(10.0, true, "the best again"),
        ];
        let minima = [0, 1, 1, 2, 3, 4, 0];
        let notes = other_minima(&ends, &minima, Some(0), 10.0, 2);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("delta chi2 = 5.000") && notes[0].contains("near (start 2)"),
            "{notes:?}"
        );
        assert!(other_minima(&ends, &minima, Some(0), 10.0, 1).is_empty());
    }

    #[test]
    fn the_verdict_says_why_a_fit_is_not_to_be_trusted() {
        assert!(verdict(false, true, "gradient", Some(1.2), 1).is_empty());
        assert!(verdict(false, true, "gradient", None, 1).is_empty());
        let n = verdict(true, false, "interrupted", Some(1.0), 1);
        assert!(n.len() == 1 && n[0].starts_with("interrupted"), "{n:?}");
        let n = verdict(false, false, "iterations", Some(16.5), 1);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(n[0].starts_with("not converged (iterations)"));
        assert!(n[1].contains("reduced chi2 = 1.650e1") && n[1].contains("several starting"));
        let n = verdict(false, true, "gradient", Some(16.5), 5);
        assert!(n[0].contains("the best of 5 starts"), "{n:?}");
    }

    #[test]
    fn weak_jacobian_columns_are_named() {
        let keys = vec!["adhesion.v0".to_string(), "damping.c".to_string()];
        assert!(columns(&keys, None, &[40.0, 12.0], &[false, false]).is_empty());
        let n = columns(&keys, None, &[40.0, 1.5], &[false, false]);
        assert!(
            n.len() == 1 && n[0].starts_with("damping.c: its Jacobian column"),
            "{n:?}"
        );
        // At its bound a key has no sigma to doubt.
        assert!(columns(&keys, None, &[40.0, 1.5], &[false, true]).is_empty());
        let n = columns(&keys, Some(&[0.05, 0.2]), &[8.0, 2.0], &[false, false]);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(n[0].contains("adhesion.v0 0.050, damping.c 0.200"), "{n:?}");
        assert!(n[0].contains("adhesion.v0 8.0, damping.c 2.0"), "{n:?}");
        assert!(n[1].starts_with("damping.c: the ensemble noise"), "{n:?}");
    }
}
