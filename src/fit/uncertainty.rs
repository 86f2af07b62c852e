//! The uncertainty analysis of a fit at its estimate: the covariance from the curvature, per
//! direction of the parameter space; the check of the linear model that curvature assumes; and
//! the profile-likelihood intervals where that check fails (or when asked for).
//!
//! **Identifiability per direction.** The weighted Jacobian `J` (∂(pred/σ)/∂y, keys at a bound
//! left out) is decomposed `J = U S Vᵀ`. A singular value `sₗ ≤` [`SINGULAR_REL`] `· s₁` marks a
//! direction `vₗ` the data cannot fix; it is named by its keys with loadings of at least
//! [`LOADING_MIN`] (of a unit vector). Those keys get no σ; the covariance of the others is the
//! pseudo-inverse restricted to the well-determined directions, `C = Σ vₗvₗᵀ/sₗ²` (times the
//! reduced χ² without a sigma column; with an ensemble the sandwich `C B C`). So a key with no
//! effect on the data (a column of zeros) removes no σ but its own. A column whose change
//! stands below the model's error even at the widest step (signal-to-noise below 1, see
//! [`super::problem`]) counts as a column of zeros.
//!
//! **The linear model's check.** For each key `j` with a σ, the point `ŷ ± δⱼ`, `δⱼ = C eⱼ/σⱼ`
//! (key `j` moved by one σ, the others by their regression on it) is where the linear model puts
//! the profile's `Δχ² = 1`. The true `Δχ²` is evaluated there (2k parameter sets); where it lies
//! outside `[1/F, F]` with `F =` [`LINEAR_FACTOR`] on either side, σ means nothing for that
//! key: `notes` says so, and the key's interval is its profile's instead. Where χ² rises
//! steeply on both sides or falls on one ([`jumps`]) the model jumps or kinks, and its profile
//! is scanned to its reach. The last accepted step is checked too: where the linear model
//! predicted a fall of χ² of at least 1 and the fall met differs from it by more than half,
//! every key's interval is its profile's. With an ensemble the check is not made (its χ² is
//! noisy by construction; the sandwich covariance accounts for that noise).
//!
//! **Profile-likelihood interval** (Venzon & Moolgavkar 1988): the `θⱼ` for which the minimum
//! of χ² over the other keys is at most `χ²(θ̂) + 1` (68 %). [`scan`] steps out from the
//! estimate on each side in the fit coordinate, from one σ (or [`FIRST_STEP_MIN`]) doubling each
//! time, each point's other keys refitted from the point before moved along their regression
//! on the key (the covariance's: where the linear model puts their conditional minimum), out to the scan's reach
//! ([`reach`]: a factor 100 either side for a key in log space, ±100 % of the starting magnitude
//! for a linear one, within the bounds). For a smooth profile a side ends at the first point
//! above `Δχ² = 1`; where the model jumps it goes on to the reach whatever χ² it meets (a
//! jump's spike of χ² must not hide a lower valley beyond it). Each point's refit is at most
//! [`PROFILE_ITERATIONS`] iterations from the point before. The end is interpolated
//! linearly in `√Δχ²` between the outermost point inside and the next one, and refined by one
//! more point. An interval that reaches the end of the scan is *open* there (the data do not
//! bound it). A point whose χ² lies more than [`LOWER_DCHI2`] below the estimate's shows that
//! the estimate is not the minimum: the fit goes on from there.

use nalgebra::{DMatrix, DVector};

use super::lm::Halt;

/// A singular value at most this fraction of the largest marks a direction the data cannot fix.
pub const SINGULAR_REL: f64 = 1e-6;

/// The loading (of a unit vector) from which a key is part of a direction the data cannot fix.
pub const LOADING_MIN: f64 = 0.01;

/// The factor by which the true Δχ² at ±1σ may differ from the linear model's 1.
pub const LINEAR_FACTOR: f64 = 2.0;

/// The Δχ² at ±1σ above which, on both sides, the model jumps or kinks (rather than being
/// smooth and far from quadratic).
pub const JUMP_DCHI2: f64 = 4.0;

/// The smallest first step of a profile scan in the fit coordinate (where σ is far smaller, as
/// at a jump).
pub const FIRST_STEP_MIN: f64 = 0.01;

/// Most iterations of the refit of the other keys at one point of a profile (each starts from
/// the point before, one step away).
pub const PROFILE_ITERATIONS: usize = 4;

/// How far below the estimate's χ² a point must lie to show that the estimate is not the
/// minimum (above the model's numerical noise).
pub const LOWER_DCHI2: f64 = 0.1;

/// A direction of the parameter space the data cannot fix.
#[derive(Debug, Clone, PartialEq)]
pub struct Direction {
    /// Its singular value.
    pub singular: f64,
    /// The keys in it and their loadings, scaled so that the largest is 1 in magnitude, largest
    /// first.
    pub loadings: Vec<(usize, f64)>,
}

/// The covariance from the curvature.
#[derive(Debug, Clone, PartialEq)]
pub struct Curvature {
    /// The covariance in the fit coordinates (k × k; NaN in the rows and columns of keys with
    /// no σ).
    pub cov: DMatrix<f64>,
    /// Each key's σ in the fit coordinate.
    pub sigma: Vec<Option<f64>>,
    /// The directions the data cannot fix.
    pub unidentified: Vec<Direction>,
    /// The singular values, largest first.
    pub singular: Vec<f64>,
}

/// The covariance of the keys `usable` (not at a bound) from the weighted Jacobian `jy`
/// (∂(pred/σ)/∂y), scaled by `scale` (the reduced χ² without a sigma column, else 1); with an
/// ensemble, `ratio` (each row's pooled variance over its weight's square) makes it the
/// sandwich.
pub fn curvature(
    jy: &DMatrix<f64>,
    usable: &[bool],
    scale: f64,
    ratio: Option<&DVector<f64>>,
) -> Curvature {
    let k = jy.ncols();
    let n = jy.nrows();
    let idx: Vec<usize> = (0..k).filter(|&j| usable[j]).collect();
    let mut out = Curvature {
        cov: DMatrix::from_element(k, k, f64::NAN),
        sigma: vec![None; k],
        unidentified: Vec::new(),
        singular: Vec::new(),
    };
    if idx.is_empty() || n == 0 {
        return out;
    }
    let m = idx.len();
    let jf = DMatrix::from_fn(n, m, |i, c| jy[(i, idx[c])]);
    if !jf.iter().all(|x| x.is_finite()) {
        return out;
    }
    let Some(svd) = jf.clone().try_svd(false, true, 1e-15, 10_000) else {
        return out;
    };
    let Some(vt) = svd.v_t else {
        return out;
    };
    let s = &svd.singular_values;
    let s1 = s.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
    out.singular = order.iter().map(|&l| s[l]).collect();
    let good = |l: usize| s1 > 0.0 && s[l] > SINGULAR_REL * s1;
    let mut sigma_ok = vec![true; m];
    for &l in &order {
        if good(l) {
            continue;
        }
        let v: Vec<f64> = (0..m).map(|c| vt[(l, c)]).collect();
        // Scaled by the largest loading, signed: that key loads +1.
        let top = v
            .iter()
            .fold(0.0f64, |a, &b| if b.abs() > a.abs() { b } else { a });
        let mut loadings: Vec<(usize, f64)> = v
            .iter()
            .enumerate()
            .filter(|(_, x)| x.abs() >= LOADING_MIN)
            .map(|(c, &x)| (idx[c], x / top))
            .collect();
        loadings.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        for (c, x) in v.iter().enumerate() {
            if x.abs() >= LOADING_MIN {
                sigma_ok[c] = false;
            }
        }
        out.unidentified.push(Direction {
            singular: s[l],
            loadings,
        });
    }
    let mut cov = DMatrix::zeros(m, m);
    for l in (0..s.len()).filter(|&l| good(l)) {
        let v = vt.row(l).transpose();
        cov += &v * v.transpose() / (s[l] * s[l]);
    }
    cov *= scale;
    if let Some(ratio) = ratio {
        let b = jf.transpose() * DMatrix::from_diagonal(ratio) * &jf;
        cov = &cov * b * &cov;
    }
    for a in 0..m {
        if !sigma_ok[a] {
            continue;
        }
        let sy = cov[(a, a)].sqrt();
        if sy.is_finite() && sy > 0.0 {
            out.sigma[idx[a]] = Some(sy);
        }
    }
    for a in 0..m {
        for b in 0..m {
            if out.sigma[idx[a]].is_some() && out.sigma[idx[b]].is_some() {
                out.cov[(idx[a], idx[b])] = cov[(a, b)];
            }
        }
    }
    out
}

/// The offset `δⱼ = C eⱼ / σⱼ` in the fit coordinates along which the linear model puts the
/// profile of key `j` at Δχ² = 1 (NaN-free: the keys without σ stay).
pub fn linear_offset(c: &Curvature, j: usize) -> Option<Vec<f64>> {
    let sj = c.sigma[j]?;
    Some(
        (0..c.sigma.len())
            .map(|i| {
                if c.sigma[i].is_some() {
                    c.cov[(i, j)] / sj
                } else {
                    0.0
                }
            })
            .collect(),
    )
}

/// Whether the true Δχ² at a point where the linear model puts 1 agrees with it (within a
/// factor [`LINEAR_FACTOR`]).
pub fn linear_agrees(dchi2: f64) -> bool {
    (1.0 / LINEAR_FACTOR..=LINEAR_FACTOR).contains(&dchi2)
}

/// Whether the true Δχ² at the points of ±1σ (`sides`, NaN where a run failed) show a jump or
/// a kink rather than a smooth profile that is far from quadratic: χ² rising above
/// [`JUMP_DCHI2`] on both sides (the curvature's σ more than twice too large both ways), or
/// falling below the estimate's on one side, or a run failing within one σ. A smooth but
/// asymmetric profile (0.1 on one side, 2.3 on the other, as in log space far from the
/// minimum's quadratic region) is not one.
pub fn jumps(sides: &[f64]) -> bool {
    sides.iter().any(|d| d.is_nan() || *d < 0.0)
        || (!sides.is_empty() && sides.iter().all(|&d| d > JUMP_DCHI2))
}

/// Whether the last accepted step disagrees with the linear model: it predicted a fall of at
/// least 1 and the fall met differs from it by more than half.
pub fn step_disagrees(predicted: f64, actual: f64) -> bool {
    predicted >= 1.0 && ((actual / predicted) - 1.0).abs() > 0.5
}

/// The profile of one key, evaluated by a caller: the minimum of χ² over the other keys with
/// key `j` at `yj`, the other keys started from `from` (a full point in `y`); `None` where it
/// cannot be evaluated (a run fails there).
pub trait Profiler {
    /// The profile's χ² at `yj` and the full point it was met at.
    fn point(&mut self, j: usize, yj: f64, from: &[f64]) -> Result<Option<(f64, Vec<f64>)>, Halt>;
}

/// A profile-likelihood interval in the fit coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Whether the interval reaches the scan's end below (not bounded by the data there).
    pub open_lo: bool,
    /// Whether it reaches the scan's end above.
    pub open_hi: bool,
    /// The lowest point met below the estimate's χ² by more than [`LOWER_DCHI2`]: χ², y.
    pub lower: Option<(f64, Vec<f64>)>,
    /// The points evaluated: `yj`, Δχ².
    pub points: Vec<(f64, f64)>,
}

/// The reach of a profile scan of a key at `y` in the fit coordinate: ln 100 either side in log
/// space, 1 (the starting magnitude) for a linear key, within the bounds `lo`, `hi`.
pub fn reach(log: bool, y: f64, lo: Option<f64>, hi: Option<f64>) -> (f64, f64) {
    let d = if log { 100f64.ln() } else { 1.0 };
    let a = (y - d).max(lo.unwrap_or(f64::NEG_INFINITY));
    let b = (y + d).min(hi.unwrap_or(f64::INFINITY));
    (a, b)
}

/// Where `√Δχ²` crosses 1 between `(ya, da)` (inside) and `(yb, db)` (outside), linearly.
fn crossing(ya: f64, da: f64, yb: f64, db: f64) -> f64 {
    let (a, b) = (da.max(0.0).sqrt(), db.max(0.0).sqrt());
    if b - a <= 0.0 {
        return yb;
    }
    ya + (yb - ya) * ((1.0 - a) / (b - a)).clamp(0.0, 1.0)
}

/// Scan the profile of key `j` about the estimate `y_best` (χ² `chi2`), first step `first`,
/// within `limits` (from [`reach`]); `jumpy`: the model jumps (go on past Δχ² = 1);
/// `stop_at_lower`: end the scan at the first point below the estimate's χ² (the fit will go on
/// from there).
#[allow(clippy::too_many_arguments)]
pub fn scan<P: Profiler + ?Sized>(
    p: &mut P,
    j: usize,
    y_best: &[f64],
    chi2: f64,
    first: f64,
    limits: (f64, f64),
    jumpy: bool,
    stop_at_lower: bool,
) -> Result<Profile, Halt> {
    let y0 = y_best[j];
    let mut out = Profile {
        lo: y0,
        hi: y0,
        open_lo: false,
        open_hi: false,
        lower: None,
        points: Vec::new(),
    };
    for side in [-1.0f64, 1.0] {
        let limit = if side < 0.0 {
            y0 - limits.0
        } else {
            limits.1 - y0
        };
        // (offset, Δχ²) of the outermost point inside and of the first point outside beyond it.
        let mut inside = (0.0, 0.0);
        let mut outside: Option<(f64, f64)> = None;
        let mut from = y_best.to_vec();
        let mut d = first.min(limit);
        let mut open = limit <= 0.0;
        while !open {
            let yj = y0 + side * d;
            let Some((c, y)) = p.point(j, yj, &from)? else {
                // A run failed: the scan ends here, open unless a point outside was met.
                open = outside.is_none();
                break;
            };
            let dchi2 = c - chi2;
            out.points.push((yj, dchi2));
            if dchi2 < -LOWER_DCHI2 && out.lower.as_ref().is_none_or(|(b, _)| c < *b) {
                out.lower = Some((c, y.clone()));
            }
            from = y;
            if stop_at_lower && out.lower.is_some() {
                return Ok(out);
            }
            if dchi2 <= 1.0 {
                if outside.is_none_or(|_| jumpy) {
                    inside = (d, dchi2);
                    outside = None;
                }
            } else {
                if outside.is_none() {
                    outside = Some((d, dchi2));
                }
                if !jumpy {
                    break;
                }
            }
            if d >= limit {
                open = outside.is_none();
                break;
            }
            d = (2.0 * d).min(limit);
        }
        let end = match outside {
            Some((db, cb)) if !open => {
                let (da, ca) = inside;
                let guess = crossing(da, ca, db, cb);
                // One more point at the guess, then the crossing between the two nearest.
                let yj = y0 + side * guess;
                let refined = if guess > da && guess < db {
                    p.point(j, yj, y_best)?.map(|(c, y)| {
                        let dc = c - chi2;
                        out.points.push((yj, dc));
                        if dc < -LOWER_DCHI2 && out.lower.as_ref().is_none_or(|(b, _)| c < *b) {
                            out.lower = Some((c, y));
                        }
                        dc
                    })
                } else {
                    None
                };
                match refined {
                    Some(dc) if dc <= 1.0 => crossing(guess, dc, db, cb),
                    Some(dc) => crossing(da, ca, guess, dc),
                    None => guess,
                }
            }
            _ => inside.0,
        };
        if side < 0.0 {
            out.lo = y0 - end;
            out.open_lo = open;
        } else {
            out.hi = y0 + end;
            out.open_hi = open;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile of closed form: `f(yj)` is the minimum of χ² over the other keys.
    struct Closed<F: Fn(f64) -> Option<f64>> {
        f: F,
        calls: usize,
    }

    impl<F: Fn(f64) -> Option<f64>> Profiler for Closed<F> {
        fn point(
            &mut self,
            _j: usize,
            yj: f64,
            _from: &[f64],
        ) -> Result<Option<(f64, Vec<f64>)>, Halt> {
            self.calls += 1;
            Ok((self.f)(yj).map(|c| (c, vec![yj])))
        }
    }

    /// A quadratic profile (σ = 0.2 about 1, χ² 10 at the minimum): the interval is ±σ, found
    /// from a first step of σ in a few points per side.
    #[test]
    fn a_quadratic_profile_gives_one_sigma() {
        let mut p = Closed {
            f: |y: f64| Some(10.0 + ((y - 1.0) / 0.2).powi(2)),
            calls: 0,
        };
        let r = scan(&mut p, 0, &[1.0], 10.0, 0.15, (-3.0, 5.0), false, false).unwrap();
        assert!(
            (r.lo - 0.8).abs() < 1e-9 && (r.hi - 1.2).abs() < 1e-9,
            "{r:?}"
        );
        assert!(!r.open_lo && !r.open_hi && r.lower.is_none());
        assert!(p.calls <= 8, "{} points", p.calls);
    }

    /// An asymmetric profile (log-like: steeper below): the ends are where Δχ² = 1, to 1 %.
    #[test]
    fn an_asymmetric_profile_is_followed() {
        // Δχ² = (e^(y−1) − 1)² / 0.1²: Δχ² = 1 at y = 1 + ln 1.1 and 1 + ln 0.9.
        let f = |y: f64| Some(5.0 + (((y - 1.0).exp() - 1.0) / 0.1).powi(2));
        let mut p = Closed { f, calls: 0 };
        let r = scan(&mut p, 0, &[1.0], 5.0, 0.1, (-3.0, 5.0), false, false).unwrap();
        let (lo, hi) = (1.0 + 0.9f64.ln(), 1.0 + 1.1f64.ln());
        assert!((r.lo - lo).abs() < 0.01 * (1.0 - lo), "{r:?}");
        assert!((r.hi - hi).abs() < 0.01 * (hi - 1.0), "{r:?}");
    }

    /// A jumpy profile (issue 36, the damping case): a spike of χ² just beside the estimate,
    /// a flat valley beyond it holding a lower χ² far off. The scan goes past the spike, reports
    /// the lower point, and the interval holds the valley.
    #[test]
    fn a_jump_does_not_end_the_scan_and_a_lower_point_is_reported() {
        // Estimate at 0 with χ² 11.87; a spike of +8.4 within 0.002; the valley down to
        // χ² 10.655 at −3.1 (a factor 22 in log space), χ² rising beyond −4.
        let f = |y: f64| {
            Some(if y.abs() < 0.002 && y != 0.0 {
                20.25
            } else if y > 0.0 {
                11.87 + (y / 0.5).powi(2)
            } else if y > -4.0 {
                11.87 - 1.215 * (1.0 - ((y + 3.1) / 3.1).powi(2)).max(0.0)
            } else {
                11.87 + 30.0 * (-4.0 - y)
            })
        };
        let mut p = Closed { f, calls: 0 };
        let (a, b) = reach(true, 0.0, None, None);
        let r = scan(&mut p, 0, &[0.0], 11.87, 2.8e-4, (a, b), true, false).unwrap();
        let (c, y) = r.lower.clone().expect("the lower valley is found");
        assert!(c < 11.0 && y[0] < -1.0, "{r:?}");
        assert!(r.lo <= -3.1 && r.hi >= 0.4, "{r:?}");
        // Asked to stop at a lower point, the scan ends there.
        let mut p = Closed { f, calls: 0 };
        let r = scan(&mut p, 0, &[0.0], 11.87, 2.8e-4, (a, b), true, true).unwrap();
        // (Doubling from 2.8e-4, the valley falls below LOWER_DCHI2 at the 10th point.)
        let (last, before) = r.points.split_last().expect("points");
        assert!(
            r.lower
                .as_ref()
                .is_some_and(|(_, y)| (y[0] - last.0).abs() < 1e-12)
                && last.1 < -LOWER_DCHI2,
            "{r:?}"
        );
        assert!(before.iter().all(|p| p.1 >= -LOWER_DCHI2), "{r:?}");
        assert!(r.lo > -0.2, "not scanned on past it: {r:?}");
        // Without the jump rule, the spike ended the scan at once.
        let mut p = Closed { f, calls: 0 };
        let r = scan(&mut p, 0, &[0.0], 11.87, 2.8e-4, (a, b), false, false).unwrap();
        assert!(r.lo > -0.01, "{r:?}");
    }

    /// A flat profile reaches the scan's end: the interval is open there.
    #[test]
    fn a_flat_profile_is_open() {
        let mut p = Closed {
            f: |y: f64| Some(3.0 + 0.01 * y * y),
            calls: 0,
        };
        let limits = reach(false, 1.0, Some(0.5), None);
        assert_eq!(limits, (0.5, 2.0));
        let r = scan(&mut p, 0, &[1.0], 3.0, 0.1, limits, false, false).unwrap();
        assert!(r.open_lo && r.open_hi, "{r:?}");
        assert_eq!((r.lo, r.hi), (0.5, 2.0));
        // A run that fails ends a side, open at the last point that ran.
        let mut p = Closed {
            f: |y: f64| (y < 1.3).then_some(3.0 + 0.01 * y * y),
            calls: 0,
        };
        let r = scan(&mut p, 0, &[1.0], 3.0, 0.1, limits, false, false).unwrap();
        assert!(r.open_hi && (r.hi - 1.2).abs() < 1e-12, "{r:?}");
    }

    /// A key with no effect (a zero column) loses its σ alone; the others keep theirs, equal to
    /// those of the fit without it (issue 36, item 3).
    #[test]
    fn a_useless_key_removes_only_its_own_sigma() {
        let j2 = DMatrix::from_row_slice(4, 2, &[1.0, 0.5, 2.0, 0.1, 0.5, 1.5, 1.0, 1.0]);
        let j3 = DMatrix::from_fn(4, 3, |i, c| if c < 2 { j2[(i, c)] } else { 0.0 });
        let a = curvature(&j2, &[true, true], 1.0, None);
        let b = curvature(&j3, &[true, true, true], 1.0, None);
        assert_eq!(b.sigma[2], None);
        for c in 0..2 {
            let (x, y) = (a.sigma[c].unwrap(), b.sigma[c].unwrap());
            assert!((x - y).abs() < 1e-12 * x, "{x} {y}");
        }
        assert_eq!(b.unidentified.len(), 1);
        assert_eq!(b.unidentified[0].loadings, vec![(2, 1.0)]);
        // The two keys' σ against the inverse of JᵀJ.
        let inv = (j2.transpose() * &j2).try_inverse().unwrap();
        assert!((a.sigma[0].unwrap() - inv[(0, 0)].sqrt()).abs() < 1e-12);
        assert!((a.cov[(0, 1)] - inv[(0, 1)]).abs() < 1e-12);
    }

    /// Two keys with the same effect: the direction of their difference is named with both,
    /// neither has a σ, and a third key independent of them keeps its own.
    #[test]
    fn a_degenerate_pair_is_named_and_the_rest_keep_sigma() {
        let jy = DMatrix::from_row_slice(
            4,
            3,
            &[1.0, 2.0, 0.0, 2.0, 4.0, 1.0, 0.5, 1.0, 3.0, 1.0, 2.0, 0.0],
        );
        let c = curvature(&jy, &[true, true, true], 1.0, None);
        assert_eq!(c.sigma[0], None);
        assert_eq!(c.sigma[1], None);
        assert!(c.sigma[2].is_some());
        let d = &c.unidentified[0];
        // v ∝ (2, −1, 0): key 0 loads 1, key 1 loads −0.5.
        assert_eq!(d.loadings[0].0, 0);
        assert!((d.loadings[1].1 + 0.5).abs() < 1e-9, "{d:?}");
    }

    #[test]
    fn the_linear_checks() {
        // The damping case (issue 36): 179 and 34 where the curvature puts 1: a jump.
        assert!(jumps(&[179.4, 34.3]) && jumps(&[-1.2, 8.4]) && jumps(&[f64::NAN, 1.0]));
        // The plain law fitted to saturated data: asymmetric, smooth.
        assert!(!jumps(&[0.105, 2.317]) && !jumps(&[6.5, 2.37]) && !jumps(&[1.0, 1.1]));
        assert!(linear_agrees(1.0) && linear_agrees(0.6) && linear_agrees(1.9));
        assert!(!linear_agrees(8.4) && !linear_agrees(0.3) && !linear_agrees(-1.2));
        assert!(step_disagrees(3.0, 0.1) && !step_disagrees(3.0, 2.5) && !step_disagrees(0.5, 0.0));
    }
}
