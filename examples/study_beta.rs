//! The closed form of eqs. (16)–(24) against the exact imposed-area pull-off: the β refit of the
//! paper's Fig. 3(b) over several ranges of n and v_max/v0, its error curve, and the δ_A forms
//! (printed and derived) against the exact first harmonic at pull-off.
//!
//!   cargo run --release --example study_beta   # about 20 s
//!
//! Writes `docs/studies/beta-refit.md`.

mod common;

use common::{Args, Table};
use djkr_core::adhesion::GentSchultz;
use djkr_core::beta_fit::{self, BetaFitConfig, RatioPoint};
use djkr_core::closed_form::{self as cf, DeltaAmpForm};
use djkr_core::imposed_area;
use djkr_core::material::Material;
use std::f64::consts::PI;

const M: Material = Material::PAPER;
const LAW: GentSchultz = GentSchultz::PAPER;

fn range(r: &[RatioPoint]) -> (f64, f64) {
    r.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.ratio), hi.max(p.ratio))
        })
}

fn summary(t: &mut Table, label: &str, cfg: &BetaFitConfig) {
    eprintln!("{label}");
    let fit = beta_fit::exact_grid(cfg)
        .and_then(|pts| beta_fit::fit_beta_on(&pts, cfg.beta_min, cfg.beta_max, cfg.beta_points));
    match fit {
        Ok(fit) => {
            let (lb, hb) = range(&fit.ratios_best);
            let (lp, hp) = range(&fit.ratios_paper);
            t.row([
                label.to_string(),
                format!(
                    "{:.2}{}",
                    fit.best_beta,
                    if fit.at_bound { " (at the bound)" } else { "" }
                ),
                format!("{:.3}", fit.best_error),
                format!("{lb:.2}–{hb:.2}"),
                format!("{:.3}", fit.error_at_paper_beta),
                format!("{lp:.2}–{hp:.2}"),
            ]);
        }
        Err(e) => t.row([
            label.to_string(),
            format!("failed: {e}"),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
        ]),
    }
}

fn main() {
    let args = Args::parse(
        "study_beta",
        "docs/studies",
        "β refit of the closed form (Fig. 3(b)) over several ranges; δ_A forms. Writes \
         beta-refit.md.",
    );
    let mut doc = args.header("Closed form: the β refit of Fig. 3(b)");
    doc += "Error = RMS over the grid of ln(A_exact / A_approx), A the pull-off amplification, \
            exact by the imposed-area method, approximate by eqs. (21), (24) with the derived δ_A. \
            β searched in [0.5, 100]. `djkr beta-fit` runs the first row.\n\n";
    let base = BetaFitConfig {
        beta_max: 100.0,
        ..BetaFitConfig::default()
    };
    let mut t = Table::new(&[
        "grid",
        "best β",
        "error at best",
        "exact/approx at best",
        "error at β = 2.5",
        "exact/approx at 2.5",
    ]);
    summary(
        &mut t,
        "paper range: n = 0.1…0.9, v_max/v0 = 1e-2…1e2, 200 Hz",
        &base,
    );
    for (lo, hi, lab) in [
        (1e-3, 1e2, "1e-3…1e2"),
        (1e-2, 1e1, "1e-2…1e1"),
        (1e-2, 1e3, "1e-2…1e3"),
        (1e-2, 1e4, "1e-2…1e4"),
        (1e0, 1e2, "1…1e2"),
        (1e1, 1e2, "10…1e2"),
    ] {
        let mut c = base.clone();
        c.speed_ratios = beta_fit::log_space(lo, hi, 25);
        summary(
            &mut t,
            &format!("n = 0.1…0.9, v_max/v0 = {lab}, 200 Hz"),
            &c,
        );
    }
    for n in [0.1, 0.3, 0.5, 0.531, 0.7, 0.9] {
        let mut c = base.clone();
        c.n_values = vec![n];
        summary(
            &mut t,
            &format!("n = {n} only, v_max/v0 = 1e-2…1e2, 200 Hz"),
            &c,
        );
    }
    for f in [2.0, 0.2, 0.02] {
        let mut c = base.clone();
        c.frequency_hz = f;
        summary(&mut t, &format!("paper range at {f} Hz"), &c);
    }
    for f in [200.0, 300.0, 400.0] {
        let omega = 2.0 * PI * f;
        let mut c = base.clone();
        c.frequency_hz = f;
        c.n_values = vec![0.531];
        c.speed_ratios = beta_fit::log_space(1e-5 * omega / c.v0, 1e-3 * omega / c.v0, 15);
        summary(
            &mut t,
            &format!("Figs. 4–7 setting: n = 0.531, a_A = 10 µm…1 mm, {f} Hz"),
            &c,
        );
    }
    doc += &t.markdown();

    match beta_fit::fit_beta(&base) {
        Ok(fit) => {
            doc += "\n## Error curve over the paper range\n\n";
            let mut t = Table::new(&["β", "RMS ln(A_exact/A_approx)"]);
            for (b, e) in fit.error_curve.iter().step_by(6) {
                t.row([format!("{b:.3}"), format!("{e:.4}")]);
            }
            doc += &t.markdown();
        }
        Err(e) => doc += &format!("\nerror curve failed: {e}\n"),
    }

    doc +=
        "\n## δ_A at pull-off, 200 Hz: exact first harmonic against the closed forms (β = 2.5)\n\n";
    let mut t = Table::new(&[
        "a_A",
        "exact A",
        "exact a_m",
        "exact δ_m",
        "exact δ_A",
        "approx A",
        "approx a_m",
        "approx δ_m",
        "δ_A derived",
        "δ_A printed",
    ]);
    for &a_amp in &[0.05e-3, 0.1e-3, 0.3e-3, 0.6e-3, 1e-3] {
        let omega = 2.0 * PI * 200.0;
        let rows = (
            imposed_area::pull_off(&M, &LAW, omega, a_amp),
            cf::pull_off_approx(&M, &LAW, omega, a_amp, 2.5, DeltaAmpForm::Derived),
            cf::pull_off_approx(&M, &LAW, omega, a_amp, 2.5, DeltaAmpForm::Printed),
        );
        match rows {
            (Ok(po), Ok(d), Ok(p)) => t.row([
                format!("{} mm", a_amp * 1e3),
                format!("{:.2}", po.amplification),
                format!("{:.3} mm", po.cycle.a_mean * 1e3),
                format!("{:+.1} µm", po.cycle.harmonics.delta_mean * 1e6),
                format!("{:.0} µm", po.cycle.harmonics.delta_amp * 1e6),
                format!("{:.2}", d.amplification),
                format!("{:.3} mm", d.a_mean * 1e3),
                format!("{:+.1} µm", d.delta_mean * 1e6),
                format!("{:.0} µm", d.delta_amp * 1e6),
                format!("{:.0} µm", p.delta_amp * 1e6),
            ]),
            _ => t.row([
                format!("{} mm", a_amp * 1e3),
                "failed".into(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
            ]),
        }
    }
    doc += &t.markdown();
    print!("{doc}");
    args.write("beta-refit.md", &doc);
}
