//! Closed forms (eqs. 16–24, 29), the comparator models (Shui, Yi) and the β refit, checked against
//! independent references.

use djkr_core::adhesion::{AdhesionLaw, ConstantW, GentSchultz};
use djkr_core::beta_fit::{self, BetaFitConfig};
use djkr_core::closed_form::{self as cf, DeltaAmpForm};
use djkr_core::comparators::{self as cmp, ShuiSystem};
use djkr_core::imposed_area;
use djkr_core::jkr;
use djkr_core::material::Material;
use proptest::prelude::*;
use std::f64::consts::PI;

const M: Material = Material::PAPER;
const LAW: GentSchultz = GentSchultz::PAPER;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// Golden-section minimum of f on [lo, hi] (independent of the crate's Brent).
fn golden_min(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..200 {
        let x1 = hi - g * (hi - lo);
        let x2 = lo + g * (hi - lo);
        if f(x1) < f(x2) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    let x = 0.5 * (lo + hi);
    (x, f(x))
}

#[test]
fn zero_amplitude_is_classical_jkr() {
    let omega = 2.0 * PI * 200.0;
    assert!(
        rel(
            cf::effective_work_of_adhesion(&LAW, omega, 0.0, 2.5),
            LAW.w0
        ) < 1e-15
    );
    let d = cf::pull_off_approx(&M, &LAW, omega, 0.0, 2.5, DeltaAmpForm::Derived).unwrap();
    let p = cf::pull_off_approx(&M, &LAW, omega, 0.0, 2.5, DeltaAmpForm::Printed).unwrap();
    let a_po = (3.0 * PI * M.w0 * M.r * M.r / (2.0 * M.k)).cbrt();
    assert!(rel(d.a_mean, a_po) < 1e-14);
    assert!(rel(d.force, -1.5 * PI * M.r * M.w0) < 1e-14);
    assert!(rel(d.amplification, 1.0) < 1e-14);
    // JKR indentation at the load-controlled pull-off: δ = a²/R − √(8π a w/(3K)) = −a²/(3R).
    assert!(rel(d.delta_mean, -a_po * a_po / (3.0 * M.r)) < 1e-12);
    // Derived amplitude vanishes; the printed one is the JKR edge opening √S ≠ 0.
    assert_eq!(d.delta_amp, 0.0);
    let root_s = (8.0 * PI * a_po * M.w0 / (3.0 * M.k)).sqrt();
    assert!(rel(p.delta_amp, root_s) < 1e-14);
    assert!(p.delta_amp > 1e-6);
}

#[test]
fn beta_one_is_eq19_and_eq16_is_eq22() {
    let law = GentSchultz::new(0.24, 4.45e-5, 0.531).unwrap();
    let (omega, a_amp) = (2.0 * PI * 300.0, 2e-4);
    let c = law.v0.powf(-law.n);
    let x = c * (a_amp * omega).powf(law.n);
    let eq19 = law.w0 / 4.0 * ((1.0 + x).sqrt() + 1.0).powi(2);
    assert!(
        rel(
            cf::effective_work_of_adhesion(&law, omega, a_amp, 1.0),
            eq19
        ) < 1e-13
    );
    let x_b = c * (a_amp * omega / 2.5).powf(law.n);
    let eq24 = law.w0 / 4.0 * ((1.0 + x_b).sqrt() + 1.0).powi(2);
    assert!(
        rel(
            cf::effective_work_of_adhesion(&law, omega, a_amp, 2.5),
            eq24
        ) < 1e-13
    );
    // Eq. (16) written with S equals eq. (22) with w_eff.
    for &a_m in &[5e-4, 1.5e-3, 3e-3] {
        let s = 8.0 * PI * a_m * law.w0 / (3.0 * M.k);
        let eq16 = a_m * a_m / M.r - 0.5 * ((s * (1.0 + x)).sqrt() + s.sqrt());
        assert!(
            (cf::mean_indentation(&M, a_m, eq19) - eq16).abs()
                < 1e-12 * eq16.abs().max(a_m * a_m / M.r)
        );
    }
}

#[test]
fn delta_amp_forms_against_eqs_14_15_and_23() {
    let (omega, a_amp, beta) = (2.0 * PI * 200.0, 1e-4, 2.5);
    let x = LAW.rate_factor(a_amp * omega / beta);
    for &a_m in &[8e-4, 2e-3] {
        let s = 8.0 * PI * a_m * LAW.w0 / (3.0 * M.k);
        // Eqs. (14) and (15) with the corrected speed in w_π.
        let d_half_pi = (a_m + a_amp).powi(2) / M.r - s.sqrt();
        let d_pi = a_m * a_m / M.r - (s * (1.0 + x)).sqrt();
        let derived =
            cf::indentation_amplitude(&M, &LAW, omega, a_m, a_amp, beta, DeltaAmpForm::Derived);
        assert!(rel(derived, 0.5 * (d_half_pi - d_pi)) < 1e-12);
        // Eq. (23) as printed, with w_eff of eq. (24).
        let w_eff = cf::effective_work_of_adhesion(&LAW, omega, a_amp, beta);
        let eq23 = a_m * a_amp / M.r + jkr::equilibrium_edge_opening(&M, a_m, w_eff);
        let printed =
            cf::indentation_amplitude(&M, &LAW, omega, a_m, a_amp, beta, DeltaAmpForm::Printed);
        assert!(rel(printed, eq23) < 1e-12);
    }
}

#[test]
fn eq18_minimum_is_eqs_20_21() {
    for &(freq, a_amp) in &[(200.0, 1e-4), (400.0, 6e-4), (300.0, 1e-6)] {
        let omega = 2.0 * PI * freq;
        let w_eff = cf::effective_work_of_adhesion(&LAW, omega, a_amp, 2.5);
        let (a, f) = golden_min(|a| cf::mean_force(&M, a, w_eff), 1e-5, 2e-2);
        let po = cf::pull_off_approx(&M, &LAW, omega, a_amp, 2.5, DeltaAmpForm::Derived).unwrap();
        assert!(rel(f, po.force) < 1e-12, "{f} vs {}", po.force);
        assert!(rel(a, po.a_mean) < 1e-6, "{a} vs {}", po.a_mean);
        assert!(rel(po.force, -1.5 * PI * M.r * w_eff) < 1e-14);
    }
}

#[test]
fn eq29_exact_inversion_and_the_papers_86_mm_per_s() {
    // The paper's numbers: A = 48, β = 2.5, n = 0.531, v0 = 0.0445 mm/s → "86 mm/s".
    let law = GentSchultz::new(0.236, 0.0445e-3, 0.531).unwrap();
    let printed = cf::vibration_speed_as_printed(&law, 48.0, 2.5).unwrap();
    assert!(
        (printed / 86e-3 - 1.0).abs() < 0.01,
        "printed eq. (29): {printed} m/s"
    );
    // The printed arithmetic inverts A = (√(1+X) + 1)², i.e. eq. (21) at amplification 48/4 = 12.
    assert!(rel(cf::amplification(&law, printed, 2.5), 12.0) < 1e-12);
    // The exact inverse of eqs. (21)/(24) round-trips, and for A = 48 is ≈ 1.66 m/s.
    for &target in &[1.0, 1.5, 12.0, 48.0, 300.0] {
        let v = cf::vibration_speed_for_amplification(&law, target, 2.5).unwrap();
        assert!(
            rel(cf::amplification(&law, v, 2.5), target) < 1e-12,
            "A = {target}"
        );
    }
    let v48 = cf::vibration_speed_for_amplification(&law, 48.0, 2.5).unwrap();
    println!(
        "eq. (29): as printed {:.2} mm/s, exact inverse {:.1} mm/s",
        printed * 1e3,
        v48 * 1e3
    );
    assert!(v48 > 1.6 && v48 < 1.7, "{v48}");
}

proptest! {
    // Eq. (29) inverts eqs. (21)/(24) for any n, β and amplification.
    #[test]
    fn eq29_inverts_the_closed_form(n in 0.1f64..1.5, beta in 0.5f64..10.0, log_a in 0.001f64..3.0) {
        let law = GentSchultz::new(0.24, 4.45e-5, n).unwrap();
        let target = 10f64.powf(log_a);
        let v = cf::vibration_speed_for_amplification(&law, target, beta).unwrap();
        prop_assert!(rel(cf::amplification(&law, v, beta), target) < 1e-9);
        let po = cf::pull_off_approx(&M, &law, 1.0, v, beta, DeltaAmpForm::Derived).unwrap();
        prop_assert!(rel(po.amplification, target) < 1e-9);
    }
}

#[test]
fn small_amplitude_limit_matches_the_exact_imposed_area_pull_off() {
    // At a_A/a_m ~ 1e-4 the exact pull-off must approach ⟨√(w/w0)⟩² (closed_form docs).
    let omega = 2.0 * PI * 200.0;
    for &n in &[0.1, 0.531, 0.9] {
        let law = GentSchultz::new(M.w0, LAW.v0, n).unwrap();
        for &ratio in &[0.1, 10.0, 100.0] {
            let v = ratio * law.v0;
            let po = imposed_area::pull_off(&M, &law, omega, v / omega).unwrap();
            let lim = cf::small_amplitude_amplification(&law, v);
            assert!(
                rel(po.amplification, lim) < 2e-3,
                "n {n} v/v0 {ratio}: exact {} limit {lim}",
                po.amplification
            );
        }
    }
}

#[test]
fn shui_without_vibration_is_jkr() {
    let s = ShuiSystem {
        mass: 0.05,
        damping: 5.0,
        base_amplitude: 0.0,
        omega: 2.0 * PI * 200.0,
    };
    for &a in &[1e-4f64, 1e-3, 3e-3] {
        let jkr_f = M.k * a.powi(3) / M.r - (6.0 * PI * M.w0 * M.k * a.powi(3)).sqrt();
        assert!((cmp::shui_mean_force(&M, &s, a) - jkr_f).abs() < 1e-12 * jkr_f.abs().max(1e-3));
    }
    let po = cmp::shui_pull_off(&M, &s).unwrap();
    assert!(rel(po.force, -1.5 * PI * M.r * M.w0) < 1e-12);
    assert!(rel(po.a_mean, jkr::load_controlled_pull_off_radius(&M, M.w0)) < 1e-6);
}

#[test]
fn shui_eq6_is_the_peak_of_the_dynamic_term_and_eq7_its_limit() {
    for &c in &[1.0, 30.0, 1e3] {
        let s = ShuiSystem {
            mass: 0.05,
            damping: c,
            base_amplitude: 40e-6,
            omega: 2.0 * PI * 200.0,
        };
        // Dense independent scan of the dynamic term over log a.
        let mut min = 0.0f64;
        for i in 0..200_000 {
            let a = 1e-6 * (1e7f64).powf(i as f64 / 199_999.0);
            min = min.min(cmp::shui_dynamic_term(&M, &s, a));
        }
        assert!(
            rel(min, cmp::shui_pull_off_eq6(&s)) < 1e-6,
            "c {c}: {min} vs {}",
            cmp::shui_pull_off_eq6(&s)
        );
    }
    let mut s = ShuiSystem {
        mass: 0.05,
        damping: 1e9,
        base_amplitude: 40e-6,
        omega: 2.0 * PI * 200.0,
    };
    assert!(rel(cmp::shui_pull_off_eq6(&s), cmp::shui_pull_off_eq7(&s)) < 1e-12);
    // The minimum of eq. (5) itself tends to the static JKR pull-off as c → ∞, not to eq. (7):
    // the dynamic term at fixed a_m vanishes like 1/c.
    let f0 = M.static_pull_off_force();
    let mut prev = f64::INFINITY;
    for &c in &[1e4, 1e5, 1e6, 1e7] {
        s.damping = c;
        let gap = (cmp::shui_pull_off(&M, &s).unwrap().force - f0).abs();
        assert!(gap < prev);
        prev = gap;
    }
    assert!(prev < 1e-4 * f0.abs(), "{prev}");
}

#[test]
fn shui_pull_off_finds_a_narrow_resonance() {
    // c/(mω) ≈ 1.6e-4: the resonance dip near 3K a/2 = mω² is far narrower than a coarse scan.
    let s = ShuiSystem {
        mass: 0.05,
        damping: 0.01,
        base_amplitude: 40e-6,
        omega: 2.0 * PI * 200.0,
    };
    let po = cmp::shui_pull_off(&M, &s).unwrap();
    let mut brute = (0.0, f64::INFINITY);
    for i in 1..=2_000_000 {
        let a = 1e-2 * i as f64 / 2_000_000.0;
        let f = cmp::shui_mean_force(&M, &s, a);
        if f < brute.1 {
            brute = (a, f);
        }
    }
    assert!(
        po.force <= brute.1 + 1e-9 * brute.1.abs(),
        "{} vs brute {}",
        po.force,
        brute.1
    );
    assert!(rel(po.a_mean, brute.0) < 1e-5);
    assert!(po.force < 100.0 * M.static_pull_off_force());
}

#[test]
fn yi_constant_w_hertz_mean_against_quadrature() {
    let law = ConstantW { w0: M.w0 };
    let delta_a = 20e-6;
    let y = cmp::yi_mean_force(&M, &law, 2.0 * PI * 200.0, delta_a).unwrap();
    // Independent midpoint rule in θ of K √R δ^{3/2}, δ = δ_A (1 + sin θ).
    let n = 100_000;
    let h = 2.0 * PI / n as f64;
    let hertz: f64 = (0..n)
        .map(|i| {
            let th = (i as f64 + 0.5) * h;
            M.k * M.r.sqrt() * (delta_a * (1.0 + th.sin())).powf(1.5)
        })
        .sum::<f64>()
        / n as f64;
    assert!(rel(y.hertz, hertz) < 1e-9, "{} vs {hertz}", y.hertz);
    assert!(rel(y.force, hertz - PI * M.r * M.w0) < 1e-9);
    assert!(rel(y.mean_work_of_adhesion, M.w0) < 1e-14);
}

#[test]
fn yi_gent_schultz_mean_against_the_original_speed_formula() {
    let omega = 2.0 * PI * 300.0;
    for &(n, a_amp) in &[(0.531, 50e-6), (0.2, 300e-6), (0.9, 5e-6)] {
        let law = GentSchultz::new(M.w0, LAW.v0, n).unwrap();
        let delta_a = cmp::yi_indentation_amplitude_from_area_amplitude(&M, a_amp);
        let y = cmp::yi_mean_force(&M, &law, omega, delta_a).unwrap();
        // The Hertz radius spans 0 .. 2 a_A, and the peak speed is a_A ω.
        assert!(rel(jkr::hertz_radius(&M, 2.0 * delta_a), 2.0 * a_amp) < 1e-12);
        assert!(rel(y.peak_speed, a_amp * omega) < 1e-12);
        // Midpoint rule in θ with ȧ = (√R/2) δ_A ω cos θ / √(δ_m + δ_A sin θ), as Yi et al. write it.
        let k = 400_000;
        let h = 2.0 * PI / k as f64;
        let mean_w: f64 = (0..k)
            .map(|i| {
                let th = (i as f64 + 0.5) * h;
                let adot = 0.5 * M.r.sqrt() * delta_a * omega * th.cos()
                    / (delta_a * (1.0 + th.sin())).sqrt();
                law.work_of_adhesion(adot)
            })
            .sum::<f64>()
            / k as f64;
        assert!(
            rel(y.mean_work_of_adhesion, mean_w) < 1e-6,
            "n {n}: {} vs {mean_w}",
            y.mean_work_of_adhesion
        );
    }
}

#[test]
fn beta_refit_on_a_small_grid() {
    let cfg = BetaFitConfig {
        n_values: vec![0.3, 0.7],
        speed_ratios: beta_fit::log_space(0.1, 100.0, 5),
        beta_min: 0.5,
        beta_max: 50.0,
        beta_points: 40,
        ..BetaFitConfig::default()
    };
    let fit = beta_fit::fit_beta(&cfg).unwrap();
    assert!(!fit.at_bound);
    // The refined β is at least as good as every point of its own error curve, and a minimum.
    for &(b, e) in &fit.error_curve {
        assert!(
            fit.best_error <= e + 1e-12,
            "beta {b}: {e} < {}",
            fit.best_error
        );
    }
    for f in [1.0 - 1e-3, 1.0 + 1e-3] {
        assert!(beta_fit::error_at(&fit.exact, fit.best_beta * f) >= fit.best_error);
    }
    // The exact points are the small-amplitude limit (a_A/a_m ≤ 1e-3 here): independent check.
    for p in &fit.exact {
        let law = GentSchultz::new(M.w0, cfg.v0, p.n).unwrap();
        let lim = cf::small_amplitude_amplification(&law, p.speed_ratio * cfg.v0);
        assert!(rel(p.amp_exact, lim) < 2e-3);
    }
    // The paper's claim, qualitatively: at β = 2.5 the ratio stays within a factor 1.5 of 1.
    let (lo, hi) = fit
        .ratios_paper
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), r| {
            (l.min(r.ratio), h.max(r.ratio))
        });
    println!(
        "beta* = {:.3}; ratios at 2.5: {lo:.3} .. {hi:.3}",
        fit.best_beta
    );
    assert!(lo > 1.0 / 1.5 && hi < 1.5, "{lo} .. {hi}");
}
