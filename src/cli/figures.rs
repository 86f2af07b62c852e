//! `djkr figures`: the paper's figures as CSV + PNG + SVG.

use super::common::MaterialArgs;
use crate::figures::{write_figures, FigureId};
use anyhow::{bail, Result};
use clap::Args;
use djkr_core::units::Dimension;
use std::path::PathBuf;

/// Flags of `djkr figures`.
#[derive(Args, Debug)]
pub struct FiguresArgs {
    /// Output directory (created if needed).
    #[arg(long, value_name = "DIR", default_value = "out/figures")]
    out: PathBuf,
    /// Which figures, comma-separated: fig2, fig3a, fig3b, fig4-8 [default: all].
    #[arg(long, value_name = "LIST")]
    only: Option<String>,
    /// Speed correction β of eq. (24) for the dashed (closed-form) curves (> 0).
    #[arg(long, default_value = "2.5", allow_hyphen_values = true)]
    beta: String,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    material: MaterialArgs,
}

/// Run `djkr figures`.
pub fn figures(a: &FiguresArgs) -> Result<()> {
    let (m, law) = a.material.resolve_gent_schultz("djkr figures")?;
    let beta = super::common::positive_quantity("--beta", &a.beta, Dimension::Dimensionless)?;
    let which: Vec<FigureId> = match &a.only {
        None => FigureId::ALL.to_vec(),
        Some(list) => list
            .split(',')
            .map(|t| {
                FigureId::parse(t).ok_or_else(|| {
                    anyhow::anyhow!(
                        "--only = {shown_t}: unknown figure; allowed: fig2, fig3a, fig3b, fig4-8",
                        shown_t = djkr_core::text::excerpt(t)
                    )
                })
            })
            .collect::<Result<_>>()?,
    };
    if which.is_empty() {
        bail!("--only: no figure named");
    }
    super::common::claim_out(&a.out, &[], a.force)?;
    eprintln!(
        "writing {} figure group(s) into {} ...",
        which.len(),
        a.out.display()
    );
    let files = write_figures(&a.out, &which, &m, &law, beta)?;
    for f in files {
        outln!("{}", f.display())?;
    }
    Ok(())
}
