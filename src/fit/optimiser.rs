//! The optimiser of a fit (step 2 of [`super::driver`]): Levenberg–Marquardt ([`super::lm`])
//! on all free keys from each starting point, the given start and those [`start_points`] draws
//! for `--starts`, and the best of their ends ([`best`]).

use nalgebra::DVector;

use super::free::Transform;
use super::lm::{self, End, Halt, Outcome};
use super::model::expected_runs;
use super::model::{EvalError, ForwardModel, Prediction};
use super::problem::{Evaluator, View};
use super::report::FitEvent;
use super::starts;

/// One optimisation's end.
pub(super) struct End1 {
    /// The start (y).
    pub(super) start: Vec<f64>,
    /// The optimiser's outcome (Err: the start could not be evaluated, with why).
    pub(super) outcome: Result<Outcome, String>,
    /// The estimate (y).
    pub(super) y: Vec<f64>,
}

/// Optimise all keys of `ev` from `y0` (residuals `r0`).
pub(super) fn optimise(
    ev: &Evaluator,
    y0: &[f64],
    r0: DVector<f64>,
    s: &lm::Settings,
) -> (Outcome, Vec<f64>) {
    let mut view = View::new(ev, y0.to_vec(), (0..ev.k()).collect());
    let u0 = view.u_of(y0);
    let o = lm::minimise(&mut view, &u0, r0, s);
    let y = view.y_of(&o.u);
    (o, y)
}

/// The start in the fit coordinates, moved 1 % of the span between the bounds (0.01 with one)
/// inside a bound it lies on or near: at a bound `dy/du = 0` and the key could not move.
pub(super) fn start_inside(tr: &[Transform], x0: &[f64]) -> Vec<f64> {
    x0.iter()
        .zip(tr)
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
        .collect()
}

/// The starting points in the fit coordinates: `y0` first, then `starts − 1` drawn by Latin
/// hypercube ([`starts::latin_hypercube`], the same at every run) over each key's
/// [`starts::range`].
pub(super) fn start_points(tr: &[Transform], y0: &[f64], starts: usize) -> Vec<Vec<f64>> {
    let mut out = vec![y0.to_vec()];
    if starts > 1 {
        let ranges: Vec<(f64, f64)> = tr
            .iter()
            .zip(y0)
            .map(|(t, &y)| starts::range(t.log, y, t.lo, t.hi))
            .collect();
        for p in starts::latin_hypercube(starts - 1, tr.len(), starts::SEED) {
            out.push(
                p.iter()
                    .zip(&ranges)
                    .map(|(q, (a, b))| a + q * (b - a))
                    .collect(),
            );
        }
    }
    out
}

/// The end with the lowest χ² among those that could be optimised (the first of equals).
pub(super) fn best(ends: &[End1]) -> Option<usize> {
    (0..ends.len())
        .filter(|&i| ends[i].outcome.is_ok())
        .min_by(|&a, &b| {
            let c = |i: usize| ends[i].outcome.as_ref().map_or(f64::INFINITY, |o| o.chi2);
            c(a).total_cmp(&c(b))
        })
}

/// Optimise from each of `start_ys` (the first's prediction `p0` is known), in order; a stop
/// ends the loop. Returns the ends and whether the fit was stopped.
pub(super) fn run_starts(
    ev: &Evaluator,
    start_ys: &[Vec<f64>],
    p0: &Prediction,
    s: &lm::Settings,
    model: &ForwardModel,
    starts: usize,
) -> (Vec<End1>, bool) {
    let k = ev.k();
    let mut ends: Vec<End1> = Vec::new();
    let mut stopped = false;
    for (i, ys) in start_ys.iter().enumerate() {
        if starts > 1 {
            ev.event(FitEvent::Stage {
                what: format!("start {} of {}", i + 1, starts),
                runs_expected: expected_runs(model, k, starts - i),
            });
        }
        let r0 = if i == 0 {
            Ok(ev.residuals_of(p0))
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
                let (o, y) = optimise(ev, ys, r0, s);
                stopped |= o.end == End::Halted(Halt::Stopped);
                End1 {
                    start: ys.clone(),
                    y,
                    outcome: Ok(o),
                }
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
    (ends, stopped)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(lo: Option<f64>, hi: Option<f64>) -> Transform {
        // The scale 1: y = x.
        Transform {
            log: false,
            scale: 1.0,
            lo,
            hi,
        }
    }

    /// The given start comes first; the others are distinct, one per slice of each key's
    /// range (a Latin hypercube: every slice of N used once per key), inside the bounds.
    #[test]
    fn starts_cover_each_range_once_per_slice() {
        let tr = [linear(Some(-1.0), Some(3.0)), linear(None, None)];
        let y0 = [0.5, 1.0];
        assert_eq!(start_points(&tr, &y0, 1), vec![y0.to_vec()]);
        let pts = start_points(&tr, &y0, 9);
        assert_eq!(pts.len(), 9);
        assert_eq!(pts[0], y0.to_vec());
        for (j, t) in tr.iter().enumerate() {
            let (a, b) = starts::range(t.log, y0[j], t.lo, t.hi);
            let mut slices: Vec<usize> = pts[1..]
                .iter()
                .map(|p| {
                    assert!(p[j] >= a && p[j] <= b, "{p:?} outside [{a}, {b}]");
                    (((p[j] - a) / (b - a)) * 8.0).floor() as usize
                })
                .collect();
            slices.sort_unstable();
            assert_eq!(slices, (0..8).collect::<Vec<_>>(), "key {j}");
        }
        // The same draws at every run.
        assert_eq!(start_points(&tr, &y0, 9), pts);
    }

    /// A start on or near a bound moves 1 % of the span inside; one well inside stays.
    #[test]
    fn a_start_on_a_bound_moves_inside() {
        let both = linear(Some(0.0), Some(2.0));
        let one = linear(None, Some(1.0));
        let y = start_inside(
            &[both, both, one, linear(None, None)],
            &[0.0, 1.0, 1.0, 5.0],
        );
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(
            close(y[0], 0.02) && close(y[1], 1.0) && close(y[2], 0.99),
            "{y:?}"
        );
        assert!(close(y[3], 5.0), "{y:?}");
    }

    fn end(chi2: Option<f64>) -> End1 {
        End1 {
            start: vec![0.0],
            outcome: match chi2 {
                Some(c) => Ok(Outcome {
                    u: vec![0.0],
                    r: DVector::zeros(1),
                    chi2: c,
                    jacobian: None,
                    end: End::Gradient,
                    iterations: 0,
                    rejected: 0,
                    last_step: None,
                    gn_fall: f64::NAN,
                }),
                None => Err("a run failed at this start".into()),
            },
            y: vec![0.0],
        }
    }

    #[test]
    fn the_best_end_has_the_lowest_chi2_among_those_optimised() {
        assert_eq!(best(&[]), None);
        assert_eq!(best(&[end(None)]), None);
        assert_eq!(
            best(&[end(Some(3.0)), end(None), end(Some(1.5)), end(Some(2.0))]),
            Some(2)
        );
        assert_eq!(best(&[end(Some(1.0)), end(Some(1.0))]), Some(0));
    }
}
