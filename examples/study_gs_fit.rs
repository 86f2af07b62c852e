//! The Gent–Schultz fit (paper Sec. 3) on synthetic unloading records from the model
//! (`catalogue::synthetic_unloading_record`): recovery of w0, v0, n against sampling, the local
//! fit's window and degree, and noise; and whether the reported standard errors are honest (pull
//! statistics over 20 noise seeds).
//!
//!   cargo run --release --example study_gs_fit   # a few seconds
//!
//! Writes `docs/studies/gs-fit.md`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use common::{sci, Args, Table};
use djkr_core::adhesion::GentSchultz;
use djkr_core::gs_fit::{self, GsFitOptions};
use djkr_core::material::Material;
use std::fmt::Write as _;

const M: Material = Material::PAPER;

fn main() {
    let args = Args::parse(
        "study_gs_fit",
        "docs/studies",
        "Gent–Schultz fit on synthetic records: accuracy and honesty of the errors. Writes \
         gs-fit.md.",
    );
    let law = GentSchultz::PAPER;
    let mut doc = args.header("Gent–Schultz fit on synthetic records");
    doc += "Records: a 2 mm contact of the paper's material and law unloaded at 10 µm/s through a \
            rigid link, down to a = 0.3 mm (crack speeds ~0 to ~30 v0), sampled every dt. Noise: \
            Gaussian, σ_a on the radius and σ_F on the force (seed 7). Deviations in units of the \
            reported σ and relative to the truth.\n\n";
    let mut t = Table::new(&[
        "dt (s)",
        "local fit: degree, half-window",
        "σ_a (m) / σ_F (N)",
        "w0",
        "v0",
        "n",
        "χ²/(N−3)",
        "points",
    ]);
    let dev =
        |x: f64, truth: f64, s: f64| format!("{:+.2}σ ({})", (x - truth) / s, sci(x / truth - 1.0));
    for &dt in &[0.01, 0.004] {
        let clean = catalogue::synthetic_unloading_record(&law, 2e-3, 10e-6, dt, 20, 0.3e-3);
        for &(deg, h) in &[(1usize, 1usize), (1, 3), (3, 3), (3, 5), (3, 10)] {
            for &(sa, sf) in &[(0.0, 0.0), (0.02e-6, 2e-5), (0.2e-6, 2e-4)] {
                let rows = if sa > 0.0 {
                    catalogue::add_noise(&clean, sa, sf, 7)
                } else {
                    clean.clone()
                };
                let opts = GsFitOptions {
                    half_window: h,
                    degree: deg,
                    ..GsFitOptions::default()
                };
                let noise = if sa > 0.0 {
                    format!("{sa:.0e} / {sf:.0e}")
                } else {
                    "none".into()
                };
                let head = [format!("{dt}"), format!("{deg}, {h}"), noise];
                match gs_fit::fit_gent_schultz(&M, &rows, &opts) {
                    Ok(f) => t.row(head.into_iter().chain([
                        dev(f.w0, law.w0, f.sigma[0]),
                        dev(f.v0, law.v0, f.sigma[1]),
                        dev(f.n, law.n, f.sigma[2]),
                        format!("{:.2}", f.chi2_reduced),
                        f.points_used.to_string(),
                    ])),
                    Err(e) => t.row(head.into_iter().chain([
                        format!("failed: {e}"),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                    ])),
                }
            }
        }
    }
    doc += &t.markdown();

    doc += "\n## Are the reported errors honest?\n\nPulls (fit − truth)/σ over 20 noise seeds on \
            `catalogue::paper_unloading_record` (dt = 4 ms), cubic local fits over 21 rows: for \
            honest errors they are N(0, 1), sd ≈ 1; an sd below 1 means σ is conservative by 1/sd.\n\n";
    let clean = catalogue::paper_unloading_record();
    let opts = GsFitOptions {
        half_window: 10,
        degree: 3,
        ..GsFitOptions::default()
    };
    let mut t = Table::new(&[
        "σ_a (m) / σ_F (N)",
        "constant",
        "pull mean",
        "pull sd",
        "max |pull|",
        "σ conservative by",
    ]);
    for &(sa, sf) in &[(0.2e-6, 2e-4), (0.02e-6, 2e-5)] {
        let mut pulls = [Vec::new(), Vec::new(), Vec::new()];
        for seed in 0..20u64 {
            let rows = catalogue::add_noise(&clean, sa, sf, 1 + seed * 0x1234_5678_9ABC);
            match gs_fit::fit_gent_schultz(&M, &rows, &opts) {
                Ok(f) => {
                    pulls[0].push((f.w0 - law.w0) / f.sigma[0]);
                    pulls[1].push((f.v0 - law.v0) / f.sigma[1]);
                    pulls[2].push((f.n - law.n) / f.sigma[2]);
                }
                Err(e) => eprintln!("seed {seed}: {e}"),
            }
        }
        for (name, p) in ["w0", "v0", "n"].iter().zip(&pulls) {
            let k = p.len().max(2) as f64;
            let mean = p.iter().sum::<f64>() / k;
            let sd = (p.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
            let max = p.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            t.row([
                format!("{sa:.0e} / {sf:.0e}"),
                name.to_string(),
                format!("{mean:+.2}"),
                format!("{sd:.2}"),
                format!("{max:.2}"),
                format!("{:.1}×", 1.0 / sd),
            ]);
        }
    }
    doc += &t.markdown();
    let _ = writeln!(doc);
    print!("{doc}");
    args.write("gs-fit.md", &doc);
}
