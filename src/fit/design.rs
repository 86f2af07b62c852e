//! The choice of new measurements (`djkr design`, issue 34; the command is not written yet):
//! which K candidates, added to a fit's data, minimise the expected covariance of the free keys
//! (/work/shared/STATS.md, "Design of experiments").
//!
//! A candidate `c` with sensitivities `g_c` (∂prediction/∂y in the fit coordinates, divided by
//! the new measurement's σ) adds `g_c g_cᵀ` to the Fisher information `F`. The criteria, each
//! minimised: D-optimal `−ln det F`, A-optimal `trace F⁻¹`, or one key's variance `(F⁻¹)_jj`.
//! The algorithm is the classic one: a greedy choice (each addition the best given those before),
//! then exchange passes (Fedorov): each chosen measurement is replaced by the candidate that
//! improves the criterion most, until a pass changes nothing (at most [`MAX_PASSES`]).

use nalgebra::{DMatrix, DVector};

/// Most exchange passes after the greedy choice.
pub const MAX_PASSES: usize = 50;

/// What a design minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criterion {
    /// `−ln det F` (D-optimal: the volume of the confidence ellipsoid).
    D,
    /// `trace F⁻¹` (A-optimal: the sum of the keys' variances).
    A,
    /// `(F⁻¹)_jj`: the variance of key `j`.
    Key(usize),
}

/// The criterion's value at information `f` (+∞ where `f` is singular).
pub fn criterion_value(f: &DMatrix<f64>, c: Criterion) -> f64 {
    let Some(ch) = f.clone().cholesky() else {
        return f64::INFINITY;
    };
    match c {
        Criterion::D => -2.0 * ch.l().diagonal().iter().map(|d| d.ln()).sum::<f64>(),
        Criterion::A => ch.inverse().trace(),
        Criterion::Key(j) => ch.inverse()[(j, j)],
    }
}

/// `f0` plus `g gᵀ` for each chosen candidate.
pub fn information(f0: &DMatrix<f64>, g: &[DVector<f64>], chosen: &[usize]) -> DMatrix<f64> {
    let mut f = f0.clone();
    for &c in chosen {
        f += &g[c] * g[c].transpose();
    }
    f
}

/// Choose `k` candidates (indices into `g`, sorted; an index more than once is a repeat) that
/// minimise `criterion` of `f0 + Σ g_c g_cᵀ`. Without `repeats`, each candidate at most once
/// (then `k` may not exceed the candidates). Ties go to the lower index, so the choice is
/// reproducible.
pub fn choose(
    f0: &DMatrix<f64>,
    g: &[DVector<f64>],
    k: usize,
    repeats: bool,
    criterion: Criterion,
) -> Vec<usize> {
    let allowed = |chosen: &[usize], c: usize| repeats || !chosen.contains(&c);
    let mut chosen: Vec<usize> = Vec::with_capacity(k);
    for _ in 0..k {
        let mut best: Option<(f64, usize)> = None;
        for c in 0..g.len() {
            if !allowed(&chosen, c) {
                continue;
            }
            let mut with = chosen.clone();
            with.push(c);
            let v = criterion_value(&information(f0, g, &with), criterion);
            if best.is_none_or(|(b, _)| v < b) {
                best = Some((v, c));
            }
        }
        match best {
            Some((_, c)) => chosen.push(c),
            None => break,
        }
    }
    // Exchange passes.
    let mut current = criterion_value(&information(f0, g, &chosen), criterion);
    for _ in 0..MAX_PASSES {
        let mut changed = false;
        for slot in 0..chosen.len() {
            let mut best: Option<(f64, usize)> = None;
            for c in 0..g.len() {
                if c == chosen[slot] {
                    continue;
                }
                let mut others = chosen.clone();
                others.remove(slot);
                if !allowed(&others, c) {
                    continue;
                }
                others.push(c);
                let v = criterion_value(&information(f0, g, &others), criterion);
                // A relative margin, so that rounding cannot swap back and forth.
                if v < current - 1e-12 * current.abs().max(1.0) && best.is_none_or(|(b, _)| v < b) {
                    best = Some((v, c));
                }
            }
            if let Some((v, c)) = best {
                chosen[slot] = c;
                current = v;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    chosen.sort_unstable();
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line y = a + b x on [0, 1] with equal σ, candidates at 0, 0.1, …, 1: the
    /// D-optimal design puts half the points at each end (the classic result, STATS.md), and so
    /// does the one for the slope's variance (1 / Σ (x − x̄)², largest spread at the ends).
    fn line() -> Vec<DVector<f64>> {
        (0..=10)
            .map(|i| DVector::from_vec(vec![1.0, i as f64 / 10.0]))
            .collect()
    }

    #[test]
    fn d_optimal_for_a_line_is_half_at_each_end() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        for k in [2, 4, 6, 10] {
            let c = choose(&f0, &line(), k, true, Criterion::D);
            let at0 = c.iter().filter(|&&i| i == 0).count();
            let at1 = c.iter().filter(|&&i| i == 10).count();
            assert_eq!((at0, at1), (k / 2, k / 2), "K = {k}: {c:?}");
        }
    }

    #[test]
    fn the_slopes_variance_is_least_with_half_at_each_end() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        let c = choose(&f0, &line(), 6, true, Criterion::Key(1));
        assert_eq!(c, vec![0, 0, 0, 10, 10, 10]);
        // Its expected variance: 1 / Σ (x − x̄)² = 1 / (6 · 0.25), with the prior's 1e-9
        // negligible.
        let f = information(&f0, &line(), &c);
        let v = criterion_value(&f, Criterion::Key(1));
        assert!((v - 1.0 / 1.5).abs() < 1e-8, "{v}");
    }

    #[test]
    fn without_repeats_each_candidate_once_and_the_ends_first() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        let c = choose(&f0, &line(), 4, false, Criterion::D);
        assert_eq!(c, vec![0, 1, 9, 10]);
    }

    #[test]
    fn existing_data_move_the_choice() {
        // Data already pin the intercept at x = 0 (100 measurements there): the slope needs
        // only the far end.
        let g = line();
        let f0 = information(&(DMatrix::identity(2, 2) * 1e-9), &g, &[0; 100]);
        let c = choose(&f0, &g, 3, true, Criterion::D);
        assert_eq!(c, vec![10, 10, 10]);
    }
}
