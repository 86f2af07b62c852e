//! `djkr design` (issue 34): the design's mathematics on a model linear in its keys, where the
//! D-optimal design and the expected covariance are known in closed form. The design is
//! computed by [`super::plan`], the function the command calls, with the candidates'
//! sensitivities made as the command makes them: each key's central secant over ±σ of the
//! current covariance ([`super::secant_ends`], [`super::secant_points`], [`super::secants`]),
//! per unit of the measurement's σ ([`super::weighted`]), here of a straight line evaluated at
//! those points. A secant of a linear model is its slope, so the closed forms hold; and a secant
//! of a model that jumps is its trend over the keys' uncertainty, not a tooth's slope.

use super::{plan, secant_ends, secant_points, secants, uniform, weighted, Criterion};
use crate::fit::free::Transform;
use nalgebra::{DMatrix, DVector};

/// The weighted sensitivities of `y = a + b x` to (a, b) at `x` with noise `sigma`, exact: the
/// information of the measurements already made (the fit's `JᵀWJ`).
fn line(x: f64, sigma: f64) -> DVector<f64> {
    DVector::from_vec(vec![1.0 / sigma, x / sigma])
}

/// A key in its own units, unbounded (`y = x`).
const PLAIN: Transform = Transform {
    log: false,
    scale: 1.0,
    lo: None,
    hi: None,
};

/// The candidates' weighted sensitivities as `design` makes them: the line `a + b x` at each of
/// `xs` run at the secant points of (a, b) = `at` over ±σ of the covariance `f0⁻¹`, the secants
/// divided by the noise `sigma`.
fn line_by_secants(xs: &[f64], at: [f64; 2], f0: &DMatrix<f64>, sigma: f64) -> Vec<DVector<f64>> {
    let cov = f0.clone().cholesky().unwrap().inverse();
    let sd = [cov[(0, 0)].sqrt(), cov[(1, 1)].sqrt()];
    let ends = secant_ends(&[PLAIN, PLAIN], &at, &sd);
    let values: Vec<Vec<f64>> = secant_points(&at, &ends)
        .iter()
        .map(|p| xs.iter().map(|x| p[0] + p[1] * x).collect())
        .collect();
    let (g, silent) = weighted(&secants(&values, &ends), &vec![sigma; xs.len()]);
    assert_eq!(silent, 0);
    g
}

/// The covariance of (a, b) of a straight line fitted by least squares to measurements at `xs`,
/// each with noise `sigma`, by the textbook formula: with `S = Σ 1`, `Sx = Σ x`, `Sxx = Σ x²`
/// and `Δ = S Sxx − Sx²`, `Var a = σ² Sxx / Δ`, `Var b = σ² S / Δ`, `Cov ab = −σ² Sx / Δ`.
fn line_cov(xs: &[f64], sigma: f64) -> [f64; 3] {
    let s = xs.len() as f64;
    let sx: f64 = xs.iter().sum();
    let sxx: f64 = xs.iter().map(|x| x * x).sum();
    let d = s * sxx - sx * sx;
    let v = sigma * sigma;
    [v * sxx / d, v * s / d, -v * sx / d]
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs()
}

/// A line on [0, 1] (candidates 0, 0.1, ..., 1, noise 0.1), measured already 4 times at
/// x = 0.5 and once at 0.2 and 0.9 (so that the current covariance is finite and not
/// symmetric about the middle). Adding K = 6 measurements: the D-optimal design has them all at
/// the ends (one more point at x multiplies det F by 1 + gᵀF⁻¹g, a quadratic in x with a
/// positive leading term, largest at an end), split between them as the brute force over the
/// closed form's determinant finds best; a design with an interior point instead is worse. The
/// expected covariance is exactly the least-squares covariance of all 12 measurements (the
/// textbook formula), and so are the current one (the 6 before) and the uniform spread's
/// (x = 0, 0.2, 0.4, 0.6, 0.8, 1).
#[test]
fn a_straight_lines_d_optimal_design_and_its_exact_covariance() {
    let sigma = 0.1;
    let xs: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
    let before = [0.5, 0.5, 0.5, 0.5, 0.2, 0.9];
    let mut f0 = DMatrix::zeros(2, 2);
    for &x in &before {
        let v = line(x, sigma);
        f0 += &v * v.transpose();
    }
    let g = line_by_secants(&xs, [1.3, -0.7], &f0, sigma);
    let k = 6;
    let p = plan(&f0, &g, k, true, Criterion::D);
    assert_eq!(p.chosen.iter().sum::<usize>(), k, "{:?}", p.chosen);
    // The best split between the two ends, by brute force over the closed form's determinant
    // (Var a · Var b − Cov², the covariance's determinant: the D criterion).
    let det = |xs: &[f64]| {
        let [va, vb, c] = line_cov(xs, sigma);
        va * vb - c * c
    };
    let best = (0..=k)
        .min_by(|&a, &b| {
            let with = |m: usize| {
                let mut all = before.to_vec();
                all.extend(std::iter::repeat_n(0.0, m));
                all.extend(std::iter::repeat_n(1.0, k - m));
                det(&all)
            };
            with(a).total_cmp(&with(b))
        })
        .unwrap();
    assert_eq!(
        (p.chosen[0], p.chosen[10]),
        (best, k - best),
        "{:?}",
        p.chosen
    );
    assert_eq!(
        p.chosen[0] + p.chosen[10],
        k,
        "only the ends: {:?}",
        p.chosen
    );
    // Each design with one of its points moved to the inside has a larger determinant.
    let mut chosen_x = before.to_vec();
    for (i, &c) in p.chosen.iter().enumerate() {
        chosen_x.extend(std::iter::repeat_n(xs[i], c));
    }
    let d_design = det(&chosen_x);
    for &inner in &xs[1..10] {
        for m in 0..k {
            let mut all = before.to_vec();
            all.extend(std::iter::repeat_n(0.0, m));
            all.extend(std::iter::repeat_n(1.0, k - 1 - m));
            all.push(inner);
            assert!(det(&all) > d_design, "x = {inner} beats the design");
        }
    }
    // The expected covariance is the least-squares covariance of all the measurements.
    for (cov, xs_all) in [
        (&p.current, before.to_vec()),
        (&p.expected, chosen_x.clone()),
        (&p.uniform_cov, {
            let mut all = before.to_vec();
            all.extend([0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
            all
        }),
    ] {
        let [va, vb, c] = line_cov(&xs_all, sigma);
        assert!(close(cov[(0, 0)], va, 1e-12), "{} vs {va}", cov[(0, 0)]);
        assert!(close(cov[(1, 1)], vb, 1e-12), "{} vs {vb}", cov[(1, 1)]);
        assert!(close(cov[(0, 1)], c, 1e-12), "{} vs {c}", cov[(0, 1)]);
    }
    // The criterion: −ln det F = ln det(covariance), less after the design than after the
    // uniform spread, which is less than now.
    assert!(close(p.criterion[1], d_design.ln(), 1e-12));
    assert!(p.criterion[1] < p.criterion[2] && p.criterion[2] < p.criterion[0]);
    // A candidate's information is the prediction's variance over the measurement's: at x,
    // (Var a + 2x Cov + x² Var b) / σ².
    let [va, vb, c] = line_cov(&before, sigma);
    for (i, &x) in xs.iter().enumerate() {
        let want = (va + 2.0 * x * c + x * x * vb) / (sigma * sigma);
        assert!(close(p.information[i], want, 1e-12), "x = {x}");
    }
}

/// Without existing data worth speaking of (a prior of 1e-9), K = 2m measurements of a line
/// D-optimally are m at each end, and the slope's variance then is σ² / (K/4) exactly (Σ(x − x̄)²
/// = K/4 on [0, 1]): the closed form of the textbook, for K = 2, 4, 8.
#[test]
fn without_data_half_at_each_end_and_the_slopes_variance_is_4_sigma2_over_k() {
    let sigma = 0.05;
    let xs: Vec<f64> = (0..=20).map(|i| i as f64 / 20.0).collect();
    let f0 = DMatrix::identity(2, 2) * 1e-9;
    // Secants over ±σ ≈ ±3e4 of each key: still the slopes.
    let g = line_by_secants(&xs, [0.4, 2.5], &f0, sigma);
    for k in [2, 4, 8] {
        let p = plan(&f0, &g, k, true, Criterion::D);
        assert_eq!((p.chosen[0], p.chosen[20]), (k / 2, k / 2), "K = {k}");
        let want = sigma * sigma * 4.0 / k as f64;
        assert!(close(p.expected[(1, 1)], want, 1e-6), "K = {k}");
        // The intercept: σ² Sxx / Δ = σ² (K/2) / (K · K/2 − K²/4) = 2σ²/K.
        assert!(close(
            p.expected[(0, 0)],
            2.0 * sigma * sigma / k as f64,
            1e-6
        ));
    }
}

/// The uniform spread: K over N candidates, the i-th at ⌊(i + ½) N / K⌋.
#[test]
fn uniform_spreads_evenly_in_the_grids_order() {
    assert_eq!(uniform(11, 6), vec![1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1]);
    assert_eq!(uniform(3, 6), vec![2, 2, 2]);
    assert_eq!(uniform(4, 1), vec![0, 0, 1, 0]);
    assert_eq!(uniform(5, 7).iter().sum::<usize>(), 7);
}

/// A staircase `m(y) = h ⌊y / h⌋`: its slope is 0 wherever it is defined (a finite difference
/// of a small step sees nothing, or a jump), while over ±σ = ±h its central secant is 2h / 2h
/// = 1, its trend, wherever the estimate falls between the steps. And a sawtooth-like model,
/// `m(y) = y + A sin(2π y / h)`, whose local slope `1 + (2πA/h) cos(2π y / h)` swings between
/// −2.8 and 4.8 here: over ±σ = ±h (a whole period either side) its secant is 1.
#[test]
fn a_secant_over_one_sigma_is_the_trend_of_a_model_that_jumps() {
    let h = 0.25;
    for y in [1.1, 1.2, 1.37, -0.6] {
        let ends = secant_ends(&[PLAIN], &[y], &[h]);
        assert_eq!(ends, vec![(y - h, y + h)]);
        let pts = secant_points(&[y], &ends);
        let stair: Vec<Vec<f64>> = pts.iter().map(|p| vec![h * (p[0] / h).floor()]).collect();
        let s = secants(&stair, &ends)[(0, 0)];
        assert!((s - 1.0).abs() < 1e-12, "staircase at {y}: {s}");
        let a = 0.15;
        let saw: Vec<Vec<f64>> = pts
            .iter()
            .map(|p| vec![p[0] + a * (2.0 * std::f64::consts::PI * p[0] / h).sin()])
            .collect();
        let s = secants(&saw, &ends)[(0, 0)];
        assert!((s - 1.0).abs() < 1e-12, "sawtooth at {y}: {s}");
    }
}

/// The secant's interval stays inside a key's bounds: ±σ clipped at a bound, the secant then
/// taken over what is left (for a line, still its slope), and the points are `y` with one key
/// moved at a time, lower end first.
#[test]
fn the_secants_interval_is_clipped_to_the_keys_bounds() {
    let bounded = Transform {
        lo: Some(0.0),
        hi: Some(1.0),
        ..PLAIN
    };
    let y = [0.9, 0.05];
    let ends = secant_ends(&[bounded, bounded], &y, &[0.2, 0.1]);
    assert_eq!(ends, vec![(0.9 - 0.2, 1.0), (0.0, 0.05 + 0.1)]);
    let pts = secant_points(&y, &ends);
    assert_eq!(
        pts,
        vec![
            vec![0.9 - 0.2, 0.05],
            vec![1.0, 0.05],
            vec![0.9, 0.0],
            vec![0.9, 0.05 + 0.1]
        ]
    );
    // m = 3 y0 − 2 y1 at one candidate.
    let values: Vec<Vec<f64>> = pts.iter().map(|p| vec![3.0 * p[0] - 2.0 * p[1]]).collect();
    let s = secants(&values, &ends);
    assert!((s[(0, 0)] - 3.0).abs() < 1e-12 && (s[(0, 1)] + 2.0).abs() < 1e-12);
}
