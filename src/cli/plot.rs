//! `djkr plot DIR`: the figures of an existing run folder (`run.png`, `run.svg` from its
//! `run.h5`) or sweep folder (from its `sweep.csv` and `progress.csv`).

use crate::output::folder;
use crate::sweep::files::{self, Manifest};
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;

/// Flags of `djkr plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A run folder (holding run.h5, from `djkr run`) or a sweep folder (holding sweep.json,
    /// from `djkr sweep`).
    dir: PathBuf,
    /// Overwrite files in DIR that djkr did not write under the names of the figures; without
    /// it such a file is refused before anything is drawn. Nothing else in DIR is touched.
    #[arg(long)]
    force: bool,
}

/// Run `djkr plot`.
pub fn plot(a: &PlotArgs) -> Result<()> {
    // Two `djkr plot` on one folder at once both succeed: neither takes the folder's lock (a
    // run or sweep may hold it), each writes its own partials and the renames are serialised.
    // Whatever is at the name (a FIFO, a link to a device) decides the kind of folder; the one
    // reader of input files then refuses what is not a regular file within its limit.
    let present = |name: &str| std::fs::symlink_metadata(a.dir.join(name)).is_ok();
    let files: Vec<PathBuf> = if present(crate::output::HDF5_NAME) {
        folder::check_names(&a.dir, &crate::run_plot::RUN_PLOT_FILES, a.force)?;
        let (png, svg) = crate::run_plot::plot_run_dir(&a.dir)?;
        vec![png, svg]
    } else if present(files::MANIFEST_NAME) {
        let Some(manifest) = Manifest::read(&a.dir)? else {
            bail!("{}: no sweep.json: not a sweep folder", a.dir.display());
        };
        folder::check_names(&a.dir, &manifest.plot_file_names(), a.force)?;
        let rows = files::read_rows(&a.dir, &manifest)?;
        let points = crate::sweep::stats::point_stats(&rows);
        files::draw_plots(&a.dir, &manifest, &points, &rows)?
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
