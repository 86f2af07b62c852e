//! Multi-start (`--starts N`): the given start and `N − 1` points drawn by Latin hypercube, each
//! fitted; the distinct minima they reach.
//!
//! **Where the starts are drawn.** In the fit coordinates, per key: between its bounds when it
//! has both; otherwise within [`RANGE_LOG`] of the start for a key in log space (a factor 10
//! either side) or [`RANGE_LINEAR`] for a linear one (±50 % of its starting magnitude), cut at a
//! single bound. The Latin hypercube puts one point in each of `N − 1` equal slices of every
//! key's range, the slices paired at random; the numbers come from
//! [`crate::sweep::phase::uniform`] with seed [`SEED`], so the starts are the same at every run.
//!
//! **Distinct minima.** Two ends are the same minimum when each fit coordinate differs by less
//! than [`SAME_Y`] and χ² by less than [`SAME_CHI2`]. A note names another converged minimum
//! whose χ² lies within the 95 % quantile of χ² with k degrees of freedom of the best
//! ([`chi2_95`]: 3.84 for one key, 5.99 for two): the data do not tell it from the best.

use crate::sweep::phase::uniform;

/// The half-width of the range of starts of a key in log space (ln 10: a factor 10).
pub const RANGE_LOG: f64 = std::f64::consts::LN_10;

/// The half-width of the range of starts of a linear key (in units of its starting magnitude).
pub const RANGE_LINEAR: f64 = 0.5;

/// The seed of the draws.
pub const SEED: u64 = 0x5747_4152_5453;

/// Two ends within this in every fit coordinate (and [`SAME_CHI2`]) are one minimum.
pub const SAME_Y: f64 = 0.01;

/// Two ends within this in χ² (and [`SAME_Y`]) are one minimum.
pub const SAME_CHI2: f64 = 0.1;

/// `n` points of a Latin hypercube in `[0, 1)^k`.
pub fn latin_hypercube(n: usize, k: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut pts = vec![vec![0.0; k]; n];
    for j in 0..k {
        // A random permutation of the slices (Fisher–Yates on the counter-based stream).
        let mut slices: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let r = uniform(seed, j as u64, 2 * i as u64);
            let s = ((r * (i + 1) as f64) as usize).min(i);
            slices.swap(i, s);
        }
        for (i, p) in pts.iter_mut().enumerate() {
            let within = uniform(seed, j as u64, 2 * i as u64 + 1);
            p[j] = (slices[i] as f64 + within) / n as f64;
        }
    }
    pts
}

/// The range of starts of a key at `y0` (fit coordinate) with bounds `lo`, `hi` in `y`.
pub fn range(log: bool, y0: f64, lo: Option<f64>, hi: Option<f64>) -> (f64, f64) {
    if let (Some(l), Some(h)) = (lo, hi) {
        return (l, h);
    }
    let d = if log { RANGE_LOG } else { RANGE_LINEAR };
    (
        (y0 - d).max(lo.unwrap_or(f64::NEG_INFINITY)),
        (y0 + d).min(hi.unwrap_or(f64::INFINITY)),
    )
}

/// The 95 % quantile of χ² with `k` degrees of freedom (a table to 10, Wilson–Hilferty beyond).
pub fn chi2_95(k: usize) -> f64 {
    const T: [f64; 10] = [
        3.841, 5.991, 7.815, 9.488, 11.070, 12.592, 14.067, 15.507, 16.919, 18.307,
    ];
    match k {
        0 => 0.0,
        1..=10 => T[k - 1],
        _ => {
            let k = k as f64;
            let z = 1.644_854;
            k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
        }
    }
}

/// The distinct minimum of each end (`(y, χ²)`, None for a start that could not run), numbered
/// by χ² (0 the lowest); a start that could not run gets the number after the last.
pub fn minima(ends: &[Option<(Vec<f64>, f64)>]) -> Vec<usize> {
    let mut reps: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut of = vec![usize::MAX; ends.len()];
    let mut order: Vec<usize> = (0..ends.len()).filter(|&i| ends[i].is_some()).collect();
    order.sort_by(|&a, &b| {
        let (ca, cb) = (
            ends[a].as_ref().map_or(0.0, |e| e.1),
            ends[b].as_ref().map_or(0.0, |e| e.1),
        );
        ca.total_cmp(&cb)
    });
    for i in order {
        let Some((y, c)) = &ends[i] else { continue };
        let same = reps.iter().position(|(ry, rc)| {
            (c - rc).abs() < SAME_CHI2 && y.iter().zip(ry).all(|(a, b)| (a - b).abs() < SAME_Y)
        });
        of[i] = match same {
            Some(r) => r,
            None => {
                reps.push((y.clone(), *c));
                reps.len() - 1
            }
        };
    }
    for m in of.iter_mut() {
        if *m == usize::MAX {
            *m = reps.len();
        }
    }
    of
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every slice of every key's range holds one point.
    #[test]
    fn a_latin_hypercube_fills_each_slice_once() {
        let pts = latin_hypercube(7, 3, SEED);
        for j in 0..3 {
            let mut slices: Vec<usize> = pts.iter().map(|p| (p[j] * 7.0) as usize).collect();
            slices.sort_unstable();
            assert_eq!(slices, (0..7).collect::<Vec<_>>());
        }
        assert_eq!(pts, latin_hypercube(7, 3, SEED));
        assert_ne!(pts, latin_hypercube(7, 3, SEED + 1));
    }

    #[test]
    fn ranges_and_quantiles() {
        assert_eq!(range(false, 1.0, None, None), (0.5, 1.5));
        assert_eq!(range(false, 1.0, Some(0.8), None), (0.8, 1.5));
        assert_eq!(range(true, 0.0, Some(-1.0), Some(5.0)), (-1.0, 5.0));
        let (a, b) = range(true, 0.0, None, None);
        assert!((b - 10f64.ln()).abs() < 1e-15 && (a + b).abs() < 1e-15);
        assert!((chi2_95(2) - 5.991).abs() < 1e-12);
        // Wilson–Hilferty at 20 against the table's 31.410.
        assert!((chi2_95(20) - 31.41).abs() < 0.05, "{}", chi2_95(20));
    }

    /// Ends within 0.01 in y and 0.1 in χ² are one minimum; numbered by χ².
    #[test]
    fn distinct_minima_are_numbered_by_chi2() {
        let ends = vec![
            Some((vec![1.0, 2.0], 16.5)),
            Some((vec![0.5, 1.0], 10.6)),
            Some((vec![0.505, 1.002], 10.65)),
            None,
            Some((vec![0.5, 1.5], 10.6)),
        ];
        assert_eq!(minima(&ends), vec![2, 0, 0, 3, 1]);
    }
}
