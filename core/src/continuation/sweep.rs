//! Natural-parameter sweeps of a [`Family`] in its key, up and down: the steady state at each
//! value started from the previous value's orbit, as `djkr resonance` sweeps the frequency. They
//! follow the stable branches and jump where a branch ends; the continuation's plot overlays
//! them on the branch, whose folds must sit between the values across which they jump.

use serde::Serialize;

use crate::dynamics::protocol::Initial;
use crate::steady::{Options, Steady, SteadyError};

use super::family::Family;

/// One value of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// The parameter value (SI).
    pub value: f64,
    /// The steady state (`None` when it could not be found; see `error`).
    pub steady: Option<Steady>,
    /// Why it is missing.
    pub error: Option<String>,
}

/// The values in the order swept, each started from the previous steady state (the first from
/// the scene's own start).
pub fn sweep(family: &Family, values: &[f64], opts: &Options) -> Vec<SweepPoint> {
    let mut from: Option<Steady> = None;
    values
        .iter()
        .map(|&value| {
            let result = family
                .setup(&[value])
                .map_err(|e| e.to_string())
                .and_then(|setup| {
                    let start = match &from {
                        // The previous orbit, with this value's spring end (a preload moves it).
                        Some(s) => Initial::State {
                            x_s: s.state.x_s,
                            v_s: s.state.v_s,
                            a: s.state.a,
                            a_dot: s.state.a_dot,
                            x_k: setup.x_k,
                        },
                        None => setup.start,
                    };
                    setup
                        .problem
                        .solve(&start, opts)
                        .map_err(|e: SteadyError| e.to_string())
                });
            match result {
                Ok(s) => {
                    from = Some(s);
                    SweepPoint {
                        value,
                        steady: Some(s),
                        error: None,
                    }
                }
                Err(e) => SweepPoint {
                    value,
                    steady: None,
                    error: Some(e),
                },
            }
        })
        .collect()
}

/// `count` values from `lo` to `hi` inclusive, swept up and down in parallel: (up, down), each
/// in the order computed.
pub fn sweep_both(
    family: &Family,
    (lo, hi): (f64, f64),
    count: usize,
    opts: &Options,
) -> (Vec<SweepPoint>, Vec<SweepPoint>) {
    let (lo, hi) = (lo.min(hi), lo.max(hi));
    let up: Vec<f64> = crate::steady::sweep::frequencies(lo, hi, count);
    let down: Vec<f64> = up.iter().rev().copied().collect();
    let (f1, f2) = (family.clone(), family.clone());
    rayon::join(|| sweep(&f1, &up, opts), || sweep(&f2, &down, opts))
}
