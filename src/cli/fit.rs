//! `djkr gs-fit FILE`: Gent–Schultz constants from a quasi-static unloading record (Sec. 3).

use super::common::{print_json, print_table, reject_unused, MaterialArgs};
use crate::input::{read_text, InputKind};
use anyhow::{bail, Result};
use clap::Args;
use djkr_core::gs_fit::{self, GsFitOptions, GsFitReport};
use std::path::PathBuf;

/// Flags of `djkr gs-fit`.
#[derive(Args, Debug)]
#[command(after_help = GS_FIT_HELP)]
pub struct GsFitArgs {
    /// CSV record with a header naming the columns t, a, F (compressive +), with units in the
    /// header or SI (`t [s]`, `a [mm]`, `F [N]`; other columns are ignored). A run's own
    /// timeseries.csv is a record; only its last stretch in contact (a > 0) is fitted.
    file: PathBuf,
    /// Half-width (rows) of the local polynomial window used to differentiate a(t).
    #[arg(long, default_value_t = GsFitOptions::default().half_window)]
    half_window: usize,
    /// Print one JSON object of SI values.
    #[arg(long)]
    json: bool,
    /// K and R of the contact (--w0, --v0 and --n are refused: they are what is fitted).
    #[command(flatten)]
    material: MaterialArgs,
}

const GS_FIT_HELP: &str = "Example record: docs/gs-fit/unload-record.csv, the timeseries.csv of
`djkr run docs/gs-fit/unload-record.toml --csv` (rigid-link unloading at 10 um/s of the paper's
material; it goes on after pull-off with a = 0, rows that are left out):
  djkr gs-fit docs/gs-fit/unload-record.csv";

/// Run `djkr gs-fit`.
pub fn gs_fit(a: &GsFitArgs) -> Result<()> {
    reject_unused(
        &[
            ("--w0", a.material.w0.is_some()),
            ("--v0", a.material.v0.is_some()),
            ("--n", a.material.n.is_some()),
        ],
        "in gs-fit (w0, v0 and n are what it fits; only K and R of the material are used)",
    )?;
    let (m, _) = a.material.resolve()?;
    let text = read_text(&a.file, InputKind::Record)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let all = gs_fit::parse_csv(&text, &a.file.display().to_string())?;
    let Some(span) = gs_fit::contact_span(&all) else {
        bail!(
            "{}: no row is in contact (a > 0): nothing to fit",
            a.file.display()
        );
    };
    let out_of_contact = all.len() - span.len();
    let rows = &all[span.clone()];
    let opts = GsFitOptions {
        half_window: a.half_window,
        ..GsFitOptions::default()
    };
    let fit = gs_fit::fit_gent_schultz(&m, rows, &opts)?;
    if a.json {
        return print_json(&GsFitReport::new(&fit, out_of_contact));
    }
    print_table(
        &format!(
            "Gent–Schultz fit of {} (w by eq. 28, crack speed −ȧ by local fits)",
            a.file.display()
        ),
        &[
            (
                "w0",
                format!("{:.4} ± {:.4} mJ/m^2", fit.w0 * 1e3, fit.sigma[0] * 1e3),
            ),
            (
                "v0",
                format!("{:.5} ± {:.5} mm/s", fit.v0 * 1e3, fit.sigma[1] * 1e3),
            ),
            ("n", format!("{:.4} ± {:.4}", fit.n, fit.sigma[2])),
            (
                "points used / rows in contact",
                format!("{} / {}", fit.points_used, fit.rows),
            ),
            (
                "crack speeds used",
                format!("{:.3e} .. {:.3e} m/s", fit.speed_range.0, fit.speed_range.1),
            ),
            (
                "residual RMS",
                format!("{:.4} mJ/m^2", fit.residual_rms * 1e3),
            ),
            ("reduced χ²", format!("{:.3}", fit.chi2_reduced)),
        ],
    )?;
    if out_of_contact > 0 {
        outln!(
            "  note: fitted the last stretch in contact, data rows {}..{} of {}; left out {} {} \
             out of contact (a = 0, e.g. after pull-off)",
            span.start + 1,
            span.end,
            all.len(),
            out_of_contact,
            if out_of_contact == 1 { "row" } else { "rows" }
        )?;
    }
    if fit.n_at_bound {
        outln!("  note: n sits at the edge of its search range: the data may not constrain it")?;
    }
    Ok(())
}
