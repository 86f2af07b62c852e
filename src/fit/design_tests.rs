//! `djkr design` (issue 34): the design's mathematics on a model linear in its keys, where the
//! D-optimal design and the expected covariance are known in closed form. The design is
//! computed by [`super::plan`], the function the command calls with the model's
//! sensitivities; here the sensitivities are those of a straight line, exact.

use super::{plan, uniform, Criterion};
use nalgebra::{DMatrix, DVector};

/// The weighted sensitivities of `y = a + b x` to (a, b) at `x` with noise `sigma`.
fn line(x: f64, sigma: f64) -> DVector<f64> {
    DVector::from_vec(vec![1.0 / sigma, x / sigma])
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
    let g: Vec<DVector<f64>> = xs.iter().map(|&x| line(x, sigma)).collect();
    let before = [0.5, 0.5, 0.5, 0.5, 0.2, 0.9];
    let mut f0 = DMatrix::zeros(2, 2);
    for &x in &before {
        let v = line(x, sigma);
        f0 += &v * v.transpose();
    }
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
    let g: Vec<DVector<f64>> = (0..=20).map(|i| line(i as f64 / 20.0, sigma)).collect();
    let f0 = DMatrix::identity(2, 2) * 1e-9;
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
