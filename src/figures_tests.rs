//! The paper's figures as data, checked against what the paper's text states and against closed
//! forms, plus the files `write_figures` produces.

use crate::figures::{self, FigureId};
use djkr_core::adhesion::GentSchultz;
use djkr_core::material::Material;
use std::f64::consts::PI;

const M: Material = Material::PAPER;
const LAW: GentSchultz = GentSchultz::PAPER;

fn argmax(v: &[f64]) -> usize {
    (0..v.len()).fold(0, |b, i| if v[i] > v[b] { i } else { b })
}
fn argmin(v: &[f64]) -> usize {
    (0..v.len()).fold(0, |b, i| if v[i] < v[b] { i } else { b })
}

/// Sec. 2.1: "maxima and minima of indentation oscillation occur near π/2 and π, in cases where
/// contact is not lost"; the black and red curves (a_m = 33, 500 µm) have an interval with δ = 0.
#[test]
fn fig2_extrema_and_contact_loss_as_the_text_says() {
    let curves = figures::fig2(&M, &LAW, 1441);
    let c1500 = &curves[3];
    assert!((c1500.a_mean - 1.5e-3).abs() < 1e-12);
    let th_max = c1500.theta[argmax(&c1500.delta)];
    let th_min = c1500.theta[argmin(&c1500.delta)];
    assert!((th_max - PI / 2.0).abs() < 0.1, "max at {th_max}");
    assert!((th_min - PI).abs() < 0.5, "min at {th_min}");
    for c in &curves[..2] {
        let zeros = c.delta.iter().filter(|d| **d == 0.0).count();
        assert!(
            zeros > c.delta.len() / 10,
            "a_m {}: {zeros} zero samples",
            c.a_mean
        );
    }
    // a_m = 1.5 mm > a_A: never out of contact, so δ is never exactly 0 away from isolated points.
    assert!(curves[3].delta.iter().filter(|d| **d == 0.0).count() <= 1);
}

/// Figs. 4–8: classical JKR at a_A = 0; amplification grows with a_A at small a_A and with
/// frequency; the closed form (β = 2.5) is a reasonable approximation at moderate a_A, as the paper
/// claims; a_m,po around 2 mm; δ_m,po negative and small against δ_A,po.
#[test]
fn figs4_to_8_table_against_jkr_and_the_papers_claims() {
    let amps: Vec<f64> = vec![0.0, 0.05e-3, 0.1e-3, 0.25e-3, 0.5e-3, 1.0e-3];
    let rows = figures::table(&M, &LAW, &figures::TABLE_FREQUENCIES, &amps, 2.5).unwrap();
    assert_eq!(rows.len(), 18);
    let a_jkr = djkr_core::jkr::load_controlled_pull_off_radius(&M, M.w0);
    for r in &rows {
        if r.a_amp == 0.0 {
            assert!((r.exact.amplification - 1.0).abs() < 1e-8);
            assert!((r.approx.amplification - 1.0).abs() < 1e-12);
            assert!((r.exact.cycle.a_mean / a_jkr - 1.0).abs() < 1e-6);
            continue;
        }
        let ratio = r.exact.amplification / r.approx.amplification;
        if r.a_amp <= 0.5e-3 {
            assert!(
                (0.85..1.0).contains(&ratio),
                "{} Hz, a_A {}: ratio {ratio}",
                r.frequency,
                r.a_amp
            );
            assert!((r.exact.cycle.a_mean / r.approx.a_mean - 1.0).abs() < 0.05);
        }
        assert!(r.exact.cycle.harmonics.delta_mean < 0.0);
        assert!(r.exact.cycle.harmonics.delta_mean.abs() < 0.5 * r.exact.cycle.harmonics.delta_amp);
        if r.a_amp >= 0.25e-3 {
            assert!(
                (1.5e-3..3e-3).contains(&r.exact.cycle.a_mean),
                "{}",
                r.exact.cycle.a_mean
            );
        }
    }
    for f in 0..3 {
        let s = &rows[f * amps.len()..(f + 1) * amps.len()];
        for w in s.windows(2) {
            assert!(w[1].exact.amplification > w[0].exact.amplification);
        }
    }
    for i in 1..amps.len() {
        let (a200, a300, a400) = (&rows[i], &rows[amps.len() + i], &rows[2 * amps.len() + i]);
        assert!(a200.exact.amplification < a300.exact.amplification);
        assert!(a300.exact.amplification < a400.exact.amplification);
    }
}

/// Fig. 3(a): each exact F_m(δ_m) curve's minimum is that amplitude's exact pull-off force.
#[test]
fn fig3a_minimum_is_the_pull_off() {
    let curves = figures::fig3a(&M, &LAW, &[0.5e-3], 2.5, 400).unwrap();
    let c = &curves[0];
    let fmin = c.force_mean.iter().cloned().fold(f64::INFINITY, f64::min);
    let po = djkr_core::imposed_area::pull_off(&M, &LAW, 2.0 * PI * 400.0, 0.5e-3).unwrap();
    assert!(fmin >= po.force - 1e-12 * po.force.abs());
    assert!(
        (fmin / po.force - 1.0).abs() < 2e-3,
        "grid min {fmin} vs pull-off {}",
        po.force
    );
}

#[test]
fn write_figures_produces_csv_png_svg() {
    let dir = tempfile::tempdir().unwrap();
    let files = figures::write_figures(
        dir.path(),
        &[FigureId::Fig2, FigureId::Figs4to8],
        &M,
        &LAW,
        2.5,
    )
    .unwrap();
    for name in [
        "fig2.csv",
        "fig2.png",
        "fig2.svg",
        "figs4-8.csv",
        "fig4.png",
        "fig7.svg",
        "fig8.png",
    ] {
        let p = dir.path().join(name);
        assert!(files.contains(&p), "{name} not reported");
        assert!(std::fs::metadata(&p).unwrap().len() > 100, "{name} empty");
    }
    let csv = std::fs::read_to_string(dir.path().join("figs4-8.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * 61);
    assert!(csv.lines().next().unwrap().contains("exact_amplification"));
    let png = std::fs::read(dir.path().join("fig7.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        // Hidden files but djkr's record of the files it wrote: partials left behind.
        .filter(|n| n.starts_with('.') && n != crate::output::folder::MANIFEST_NAME)
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn figure_ids_parse() {
    assert_eq!(FigureId::parse("fig3b"), Some(FigureId::Fig3b));
    assert_eq!(FigureId::parse("7"), Some(FigureId::Figs4to8));
    assert_eq!(FigureId::parse("fig9"), None);
}
