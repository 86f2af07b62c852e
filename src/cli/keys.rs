//! `djkr keys [--json]`: every key a scenario file takes, with unit, default, allowed range and
//! meaning, printed from the table the parser, `--set`, sweeps and continuation read
//! ([`crate::scenario::keys`]), so that the reference cannot drift from the parser.

use anyhow::Result;
use clap::Args;

/// Flags of `djkr keys`.
#[derive(Args, Debug)]
pub struct KeysArgs {
    /// Print a JSON list of objects with the fields key, unit ("" when dimensionless), default
    /// (the TOML value, null when required or derived), range and description.
    #[arg(long)]
    json: bool,
}

/// Print the table of scenario keys.
pub fn keys(a: &KeysArgs) -> Result<()> {
    if a.json {
        // Not `print_json`: its check for non-finite numbers reads the null defaults as NaN.
        outln!(
            "{}",
            serde_json::to_string_pretty(&crate::scenario::keys::to_json())?
        )?;
        Ok(())
    } else {
        out!("{}", crate::scenario::keys::to_text())?;
        Ok(())
    }
}
