//! How far a run's pull-off can be trusted: twin runs whose input differs by a few ulps.
//!
//! Under vibration the approach to pull-off can be chaotic: contact losses and impacts in the
//! last cycles before detachment amplify a difference of one ulp in an input to a shift of
//! hundreds of periods in the detachment time, and the pull-off force (the most tensile cycle
//! mean, which the unloading ramp moves by k v per second) moves with it by percent
//! (`docs/studies/sensitivity.md` has the measurements: twin divergence, finite-time Lyapunov
//! exponent, the events before detachment, ensembles). No tolerance removes that; what
//! converges is the distribution over an ensemble.
//!
//! [`twins`] runs the scene again `members` times with its base amplitude (or, without a base,
//! its initial preload or gap) scaled by 1 + k·ε (k = 1 … members, ε = 1e-12 by default), and
//! reports the spread of the pull-off force and time over the run and its twins, the digits they
//! share, and how many ensemble members a given standard error needs. A spread below 1e-6
//! relative (a few integration tolerances) is a deterministic pull-off; above, the single run's
//! digits beyond the shared ones are noise and the user should report an ensemble
//! (`djkr sweep FILE --ensemble N`).

use rayon::prelude::*;
use serde::Serialize;

use crate::scenario::Scenario;
use crate::sweep::stats::Summary;
use djkr_core::dynamics::protocol::Initial;
use djkr_core::dynamics::{NoObserver, RunResult, SimError};

/// Relative spread of the pull-off force above which a pull-off is reported as sensitive:
/// well above what the integration tolerances move (rtol ≤ 1e-6 moves a deterministic pull-off
/// by ≤ 1e-7 on the bundled scenes), well below the percent of a chaotic approach.
pub const SENSITIVE_SPREAD: f64 = 1e-6;

/// Default relative perturbation of a twin.
pub const EPSILON: f64 = 1e-12;

/// Which input the twins perturb.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Perturbed {
    /// `[base] amplitude`.
    BaseAmplitude,
    /// `[initial] preload`.
    InitialPreload,
    /// `[initial] gap`.
    InitialGap,
}

impl Perturbed {
    /// The scenario key.
    pub fn key(self) -> &'static str {
        match self {
            Perturbed::BaseAmplitude => "base.amplitude",
            Perturbed::InitialPreload => "initial.preload",
            Perturbed::InitialGap => "initial.gap",
        }
    }
}

/// One twin's outcome.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Twin {
    /// Relative perturbation of the input (0 for the run itself).
    pub perturbation: f64,
    /// Pull-off force (N).
    pub pull_off_force: f64,
    /// Pull-off time (s).
    pub pull_off_time: f64,
    /// Whether it detached.
    pub detached: bool,
}

/// The spread of the pull-off over a run and its twins.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The input the twins perturb.
    pub perturbed: Perturbed,
    /// The scenario key of that input.
    pub key: &'static str,
    /// ε: twin k has the input scaled by 1 + k ε.
    pub epsilon: f64,
    /// The run (perturbation 0) and its twins.
    pub runs: Vec<Twin>,
    /// Mean pull-off force (N).
    pub force_mean: f64,
    /// Sample standard deviation of the pull-off force (N).
    pub force_std: f64,
    /// Smallest and largest pull-off force (N).
    pub force_min: f64,
    /// Largest pull-off force (N).
    pub force_max: f64,
    /// (max − min)/|mean| of the pull-off force.
    pub force_spread: f64,
    /// Largest minus smallest pull-off time (s).
    pub time_spread: f64,
    /// Significant digits of the pull-off force the runs share.
    pub digits: usize,
    /// True when the spread exceeds [`SENSITIVE_SPREAD`]: report a distribution.
    pub sensitive: bool,
}

impl Sensitivity {
    /// Ensemble members needed for a standard error `se` (N) of the mean pull-off force,
    /// (σ/se)² from this spread's standard deviation (at least 2).
    pub fn members_for(&self, se: f64) -> usize {
        let n = (self.force_std / se).powi(2).ceil();
        if n.is_finite() {
            (n as usize).max(2)
        } else {
            2
        }
    }
}

/// The scene with its perturbable input scaled by `1 + rel`, and which input that is (`None`:
/// nothing to perturb, e.g. an explicit initial state).
pub fn perturbed(s: &Scenario, rel: f64) -> Option<(Scenario, Perturbed)> {
    let mut t = s.clone();
    let what = if let Some(b) = t.rig.base.as_mut() {
        b.amplitude *= 1.0 + rel;
        Perturbed::BaseAmplitude
    } else {
        match &mut t.initial {
            Initial::Preload(p) => {
                *p *= 1.0 + rel;
                Perturbed::InitialPreload
            }
            Initial::Gap(g) => {
                *g *= 1.0 + rel;
                Perturbed::InitialGap
            }
            _ => return None,
        }
    };
    Some((t, what))
}

/// Run `members` twins of `s` (which already ran with result `run`) in parallel and measure the
/// spread (module doc). `None` when the scene has no input to perturb.
pub fn twins(
    s: &Scenario,
    run: &RunResult,
    members: usize,
    epsilon: f64,
) -> Option<Result<Sensitivity, SimError>> {
    let (_, what) = perturbed(s, epsilon)?;
    let outcomes: Vec<Result<Twin, SimError>> = (1..=members)
        .into_par_iter()
        .map(|k| {
            let rel = k as f64 * epsilon;
            let (t, _) = perturbed(s, rel).expect("perturbable: checked above");
            let r = t.simulate(&mut NoObserver)?;
            Ok(twin(rel, &r))
        })
        .collect();
    let mut runs = vec![twin(0.0, run)];
    for o in outcomes {
        match o {
            Ok(t) => runs.push(t),
            Err(e) => return Some(Err(e)),
        }
    }
    Some(Ok(summarise(what, epsilon, runs)))
}

fn twin(perturbation: f64, r: &RunResult) -> Twin {
    Twin {
        perturbation,
        pull_off_force: r.pull_off.force,
        pull_off_time: r.pull_off.time,
        detached: r.detached,
    }
}

/// The spread of `runs` (the first is the unperturbed run).
pub(crate) fn summarise(perturbed: Perturbed, epsilon: f64, runs: Vec<Twin>) -> Sensitivity {
    let f = Summary::of(runs.iter().map(|t| t.pull_off_force));
    let t = Summary::of(runs.iter().map(|t| t.pull_off_time));
    let spread = if f.mean != 0.0 {
        (f.max - f.min) / f.mean.abs()
    } else {
        0.0
    };
    Sensitivity {
        perturbed,
        key: perturbed.key(),
        epsilon,
        force_mean: f.mean,
        force_std: f.std,
        force_min: f.min,
        force_max: f.max,
        force_spread: spread,
        time_spread: t.max - t.min,
        digits: shared_digits(spread),
        // A NaN spread counts as sensitive.
        sensitive: spread > SENSITIVE_SPREAD || spread.is_nan(),
        runs,
    }
}

/// Significant digits that values spread by `rel` (relative) share: ⌊−log10 rel⌋, within 1 … 15.
pub(crate) fn shared_digits(rel: f64) -> usize {
    if rel <= 0.0 || rel.is_nan() {
        return 15;
    }
    (-rel.log10()).floor().clamp(1.0, 15.0) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(f: f64, time: f64) -> Twin {
        Twin {
            perturbation: 0.0,
            pull_off_force: f,
            pull_off_time: time,
            detached: true,
        }
    }

    #[test]
    fn spread_digits_and_members() {
        let s = summarise(
            Perturbed::BaseAmplitude,
            1e-12,
            vec![t(-0.684, 30.0), t(-0.698, 30.7), t(-0.691, 30.3)],
        );
        assert!((s.force_spread - 0.014 / 0.691).abs() < 1e-12);
        assert_eq!(s.digits, 1);
        assert!(s.sensitive);
        assert!((s.time_spread - 0.7).abs() < 1e-12);
        // σ = 0.007 N: a standard error of 0.001 N needs 49 members.
        assert!((s.force_std - 0.007).abs() < 1e-12);
        assert_eq!(s.members_for(0.001), 49);
        let d = summarise(
            Perturbed::BaseAmplitude,
            1e-12,
            vec![t(-0.1, 1.0), t(-0.1 * (1.0 + 3e-9), 1.0)],
        );
        assert!(!d.sensitive);
        assert_eq!(d.digits, 8);
        assert_eq!(shared_digits(0.0), 15);
    }
}
