//! The uncertainty analysis of a converged fit (step 4 of [`super::driver`]): the covariance
//! per direction from the Jacobian at the estimate (the optimiser's last, not computed again),
//! the linear model's check at ±1σ, and the profile-likelihood intervals where it fails or
//! where asked, over the pure functions of [`super::uncertainty`].

use nalgebra::{DMatrix, DVector};

use super::free::FreeKey;
use super::lm::{self, End, Halt, LeastSquares};
use super::model::EvalError;
use super::problem::{Evaluator, View};
use super::report::{FitEvent, FitOptions};
use super::uncertainty;

/// The other keys' regression on key `j` (`cov[i][j] / cov[j][j]`, 0 for `j` itself and where
/// not finite): how far their conditional minimum moves per unit of key `j` in the linear
/// model, the direction a profile's points start along.
pub(super) fn regression(cov: &DMatrix<f64>, j: usize) -> Vec<f64> {
    (0..cov.nrows())
        .map(|i| {
            let r = cov[(i, j)] / cov[(j, j)];
            if i != j && r.is_finite() {
                r
            } else {
                0.0
            }
        })
        .collect()
}

/// A direction the data cannot fix, in words: its keys with their loadings (the largest 1,
/// written without one): `initial.gap -0.500 stage[0].speed`.
pub(super) fn combination(loadings: &[(usize, f64)], keys: &[String]) -> String {
    loadings
        .iter()
        .map(|&(j, l)| {
            if (l - 1.0).abs() < 1e-9 {
                keys[j].clone()
            } else {
                format!("{l:+.3} {}", keys[j])
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The profile of a key through an [`Evaluator`]: the other keys refitted, each point started
/// from the point before moved along `dir` (the other keys' regression on the profiled one,
/// from the covariance: where the linear model puts the conditional minimum).
struct ProfileOf<'e, 'a, 'b> {
    ev: &'e Evaluator<'a, 'b>,
    s: lm::Settings,
    dir: Vec<f64>,
    /// What one unit of Δχ² is: 1 with the data's σ, the reduced χ² without (the profile's
    /// χ² is returned in these units, so its Δχ² = 1 is the interval of the σ reported).
    scale: f64,
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
            return Ok(Some((r0.norm_squared() / self.scale, base)));
        }
        let o = lm::minimise(&mut view, &u0, r0, &self.s);
        if o.end == End::Halted(Halt::Stopped) {
            return Err(Halt::Stopped);
        }
        Ok(Some((o.chi2 / self.scale, view.y_of(&o.u))))
    }
}

/// The uncertainty analysis of a converged fit at `y` (χ² `chi2`, the optimiser's last step
/// `last`): σ per key in y (None where none), the covariance in y, intervals in y with whether
/// they are the profile's, notes, and a lower point met by a profile (χ², y).
pub(super) struct Analysis {
    /// σ per key in the fit coordinates (None where none).
    pub(super) sigma: Vec<Option<f64>>,
    /// The covariance in the fit coordinates (NaN where none).
    pub(super) cov: DMatrix<f64>,
    /// Intervals in the fit coordinates, and whether they are the profile's.
    pub(super) intervals: Vec<Option<(f64, f64, bool)>>,
    /// What the analysis found, for `notes`.
    pub(super) notes: Vec<String>,
    /// A point below the estimate's χ² met by a profile (χ², y).
    pub(super) lower: Option<(f64, Vec<f64>)>,
}

#[allow(clippy::too_many_arguments)]
pub(super) fn analyse(
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
    // One unit of Δχ² for the checks and the profiles: 1 with the data's σ, the reduced χ²
    // without (the σ reported are scaled by it, so their Δχ² = 1 is that many raw units).
    let unit = if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        1.0
    };
    for d in &c.unidentified {
        let keys: Vec<String> = free.iter().map(|f| f.key.to_string()).collect();
        let combo = combination(&d.loadings, &keys);
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
            // In units of the σ reported: scaled by the reduced χ² without the data's σ.
            let d = p.as_ref().map_or(f64::NAN, |p| (ev.chi2(p) - chi2) / unit);
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
            if uncertainty::step_disagrees(st.predicted / unit, st.actual / unit) {
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
        let dir = regression(&c.cov, j);
        let mut p = ProfileOf {
            ev,
            dir,
            s: lm::Settings {
                max_iterations: uncertainty::PROFILE_ITERATIONS,
                gtol: 1e-2,
                ..*s
            },
            scale: unit,
        };
        let prof = match uncertainty::scan(
            &mut p,
            j,
            y,
            chi2 / unit,
            first,
            limits,
            flagged[j],
            may_restart,
        ) {
            Ok(p) => p,
            Err(_) => return Err(EvalError::Stopped),
        };
        if let Some((c2, yl)) = prof.lower.clone().map(|(c2, yl)| (c2 * unit, yl)) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The regression of the others on a key is the covariance's column over its variance,
    /// checked against the conditional mean of a bivariate normal (ρ σᵢ/σⱼ).
    #[test]
    fn the_regression_is_the_conditional_mean_slope() {
        let (s0, s1, rho) = (2.0, 0.5, 0.8);
        let cov = DMatrix::from_row_slice(2, 2, &[s0 * s0, rho * s0 * s1, rho * s0 * s1, s1 * s1]);
        let d = regression(&cov, 0);
        assert!(d[0].abs() < f64::MIN_POSITIVE, "{d:?}");
        assert!((d[1] - rho * s1 / s0).abs() < 1e-15, "{d:?}");
        let d = regression(&cov, 1);
        assert!((d[0] - rho * s0 / s1).abs() < 1e-15, "{d:?}");
        // A key without a variance moves nothing.
        let nan = DMatrix::from_row_slice(2, 2, &[f64::NAN, 0.0, 0.0, 1.0]);
        assert_eq!(regression(&nan, 0), vec![0.0, 0.0]);
    }

    #[test]
    fn a_combination_names_its_keys_with_their_loadings() {
        let keys = vec!["initial.gap".to_string(), "stage[0].speed".to_string()];
        assert_eq!(
            combination(&[(0, 1.0), (1, -0.5)], &keys),
            "initial.gap -0.500 stage[0].speed"
        );
        assert_eq!(combination(&[(1, 1.0)], &keys), "stage[0].speed");
    }
}
