//! `djkr plot DIR`: the figures of an existing run folder (`run.png`, `run.svg` from its
//! `run.h5`) or sweep folder (from its `sweep.csv` and `progress.csv`).

use anyhow::{bail, Result};
use clap::Args;
use djkr::sweep::files::{self, Manifest};
use std::path::PathBuf;

/// Flags of `djkr plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A run folder (holding run.h5, from `djkr run`) or a sweep folder (holding sweep.json,
    /// from `djkr sweep`).
    dir: PathBuf,
}

/// Run `djkr plot`.
pub fn plot(a: &PlotArgs) -> Result<()> {
    let files: Vec<PathBuf> = if a.dir.join(djkr::output::HDF5_NAME).exists() {
        let (png, svg) = djkr::run_plot::plot_run_dir(&a.dir)?;
        vec![png, svg]
    } else if a.dir.join(files::MANIFEST_NAME).exists() {
        let text = std::fs::read_to_string(a.dir.join(files::MANIFEST_NAME))?;
        let manifest: Manifest = serde_json::from_str(&text).map_err(|e| {
            anyhow::anyhow!("{}: not a djkr sweep description: {e}", a.dir.display())
        })?;
        let rows = files::read_rows(&a.dir, &manifest)?;
        let points = djkr::sweep::stats::point_stats(&rows);
        djkr::sweep::plots::sweep_plots(&a.dir, &manifest, &points, &rows)?
    } else {
        bail!(
            "{}: neither a run folder (run.h5) nor a sweep folder (sweep.json)",
            a.dir.display()
        );
    };
    outln!("wrote:")?;
    for p in &files {
        outln!("  {}", p.display())?;
    }
    Ok(())
}
