//! Flag parsing shared by the commands: quantities with units, the material and the law.

use crate::scenario::overrides::Override;
use crate::scenario::parse::ScenarioSource;
use crate::scenario::Scenario;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr_core::adhesion::{GentSchultz, Law};
use djkr_core::material::Material;
use djkr_core::units::Dimension;
use std::path::{Path, PathBuf};

pub(crate) use crate::api::{
    beta_from, fmt_force, fmt_len, key_non_negative_quantity, key_positive_quantity, limits,
    no_negative_zero,
};
pub(crate) use crate::api::{non_negative_quantity, omega_from, positive_quantity};

/// `--set KEY=VALUE`: scenario values overridden from the command line, shared by every command
/// that reads a scenario file.
#[derive(Args, Debug, Clone, Default)]
pub struct SetArgs {
    /// Override a scenario value, as if the file said so (repeatable), e.g.
    /// --set base.amplitude=30um --set 'stage[3].speed=1mm/s'
    ///
    /// KEY is the dotted key error messages print: SECTION.KEY (base.amplitude, adhesion.n,
    /// solver.rtol) or stage[N].KEY with N counted from 0 (stage[0].duration,
    /// stage[3].until). VALUE is written as in the file, units welcome (30um, 2s, 0.3kHz,
    /// gent-schultz, pull-off, true); quotes are optional. An absent section is created; stages
    /// are not. Setting a stage's duration, preload or until replaces the end condition the file
    /// gives it. The result is exactly that of the file with the value edited in it; summary
    /// files record the overrides.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl SetArgs {
    /// The overrides, parsed and their keys checked (before any file is read).
    pub fn overrides(&self) -> Result<Vec<Override>> {
        Ok(crate::api::overrides(&self.set)?)
    }

    /// Refuse a `--set` of a key that `command` takes from a flag of its own instead
    /// (`replaced`: key and flag): an override is honoured or refused, never silently ignored.
    pub fn refuse_replaced(&self, command: &str, replaced: &[(&str, &str)]) -> Result<()> {
        match crate::api::replaced_override(&self.overrides()?, replaced) {
            Some((key, flag)) => bail!("--set {key} has no effect on {command}: use {flag}"),
            None => Ok(()),
        }
    }
}

/// What the steady-state commands (`validate`, `resonance`, `shortcut-map`, `continue`) do not
/// read of a scenario, for their `--help`.
pub const STEADY_UNUSED_KEYS: &str = "Not read (a --set of them changes nothing): the [output] keys, solver.envelope, solver.envelope_tol, solver.max_memory, and the stages after the first vibrating one. Keys that a flag of this command sets (solver.rtol by --rtol, and the swept or continued key) are refused with --set.";

/// Read and validate a scenario file with the `--set` overrides applied.
pub fn load_scenario(file: &Path, set: &SetArgs) -> Result<Scenario> {
    let overrides = set.overrides()?;
    Ok(ScenarioSource::read(file)?.scenario(&overrides)?)
}

/// Material and adhesion law (a scenario file, then flags). Defaults: the paper's Fig. 2 set.
#[derive(Args, Debug, Clone, Default)]
pub struct MaterialArgs {
    /// Scenario file whose [material] and [adhesion] sections to use (flags below override it).
    #[arg(long, value_name = "FILE", allow_hyphen_values = true)]
    pub material: Option<PathBuf>,
    /// JKR elastic constant K = 4E*/3 [default 9.33MPa], in [1 Pa, 1e13 Pa] as material.K.
    /// Units: Pa, kPa, MPa, GPa.
    #[arg(long = "modulus", value_name = "K", allow_hyphen_values = true)]
    pub k: Option<String>,
    /// Sphere radius R [default 51mm], at most 10 m as material.R. Units: m, cm, mm, um (µm,
    /// μm), nm.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub radius: Option<String>,
    /// Quasi-static work of adhesion w0 [default 240mJ/m^2], in [1e-9, 1e4] J/m^2 as
    /// material.w0. Units: J/m^2, mJ/m^2.
    #[arg(long, value_name = "W0", allow_hyphen_values = true)]
    pub w0: Option<String>,
    /// Gent–Schultz reference speed v0 (C = v0^-n) [default 0.0445mm/s], in [1e-15, 1e3] m/s as
    /// adhesion.v0. Units: m/s, mm/s, um/s.
    #[arg(long, value_name = "V0", allow_hyphen_values = true)]
    pub v0: Option<String>,
    /// Gent–Schultz exponent n [default 0.531], in [1e-3, 10] as adhesion.n.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub n: Option<String>,
}

impl MaterialArgs {
    /// Resolve the material and the adhesion law: the file's (any law) or the paper's
    /// Gent–Schultz constants, then the flags. `--w0` sets the law's w0 too (refused for a
    /// tabulated law, whose w(0) is its table's); `--v0` and `--n` need a Gent–Schultz law (plain
    /// or saturated).
    pub fn resolve(&self) -> Result<(Material, Law)> {
        let (mut m, mut law) = crate::api::default_material();
        if let Some(path) = &self.material {
            // Only [material] and [adhesion] are read (the rest of the scenario is ignored).
            (m, law) = crate::scenario::parse::material_and_law(path)
                .with_context(|| format!("--material {}", path.display()))?;
        }
        if let Some(t) = &self.k {
            m.k = key_positive_quantity("--modulus", t, Dimension::Pressure, "material.K")?;
        }
        if let Some(t) = &self.radius {
            m.r = key_positive_quantity("--radius", t, Dimension::Length, "material.R")?;
        }
        if let Some(t) = &self.w0 {
            m.w0 = key_positive_quantity("--w0", t, Dimension::EnergyPerArea, "material.w0")?;
            match &mut law {
                Law::Constant(c) => c.w0 = m.w0,
                Law::GentSchultz(gs) => gs.w0 = m.w0,
                Law::Saturated(s) => s.base.w0 = m.w0,
                Law::Tabulated(_) => bail!(
                    "--w0 = {shown_t}: {} has a tabulated law, whose w0 is its table's w(0); edit the table instead",
                    self.origin(), shown_t = djkr_core::text::excerpt(t)),
            }
        }
        if self.v0.is_some() || self.n.is_some() {
            let gs = match &mut law {
                Law::GentSchultz(gs) => gs,
                Law::Saturated(s) => &mut s.base,
                other => bail!(
                    "--v0 and --n set Gent-Schultz constants, but {} has a {} law",
                    self.origin(),
                    law_name(other)
                ),
            };
            if let Some(t) = &self.v0 {
                gs.v0 = key_positive_quantity("--v0", t, Dimension::Speed, "adhesion.v0")?;
            }
            if let Some(t) = &self.n {
                gs.n = key_positive_quantity("--n", t, Dimension::Dimensionless, "adhesion.n")?;
            }
        }
        Ok((m, law))
    }

    /// As [`resolve`](Self::resolve), for commands built on the Gent–Schultz constants
    /// themselves (`command`: the paper's figures, the β refit).
    pub fn resolve_gent_schultz(&self, command: &str) -> Result<(Material, GentSchultz)> {
        match self.resolve()? {
            (m, Law::GentSchultz(gs)) => Ok((m, gs)),
            (_, other) => bail!(
                "{command} is built on the Gent-Schultz law (v0, n), but {} has a {} law",
                self.origin(),
                law_name(&other)
            ),
        }
    }

    /// Where the law comes from, for error messages.
    fn origin(&self) -> String {
        match &self.material {
            Some(path) => format!("--material {}", path.display()),
            None => "the default".into(),
        }
    }
}

/// The scenario-file name of a law (as `[adhesion] law` spells it; "constant w0" when absent).
pub fn law_name(l: &Law) -> &'static str {
    match l {
        Law::Constant(_) => "constant w0",
        other => other.name(),
    }
}

/// The name of a default output folder for `file`: its stem made safe as one path component
/// under `out/`, so that `out/<name>` is always a proper subfolder of `out/`: characters other
/// than letters, digits, `-`, `_` and `.` become `_`, leading dots are dropped (a file named
/// `...toml` has the stem `..`), and an empty result becomes `scenario`.
pub fn out_name(file: &Path) -> String {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let clean: String = stem
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let clean = clean.trim_start_matches('.');
    if clean.is_empty() {
        "scenario".into()
    } else {
        clean.to_string()
    }
}

/// `out/<out_name(file)><suffix>`: the default output folder of a command run on `file`.
pub fn default_out(file: &Path, suffix: &str) -> PathBuf {
    PathBuf::from("out").join(format!("{}{suffix}", out_name(file)))
}

/// Refuse a grid or list of `count` items beyond `max`, naming the flag (`what`: what is
/// counted).
pub fn limit_count(flag: &str, text: &str, count: usize, max: usize, what: &str) -> Result<()> {
    if count > max {
        bail!(
            "{flag} = {shown_text}: {count} {what}, more than the limit of {max}",
            shown_text = djkr_core::text::excerpt(text)
        );
    }
    Ok(())
}

/// Refuse flags that were given but have no effect in the chosen mode (`given`: each flag's
/// name and whether it was given; `mode`: the mode, e.g. `with --method exact`), naming them:
/// a flag silently ignored reads as a result it did not shape.
pub fn reject_unused(given: &[(&str, bool)], mode: &str) -> Result<()> {
    let unused: Vec<&str> = given.iter().filter(|g| g.1).map(|g| g.0).collect();
    match unused.as_slice() {
        [] => Ok(()),
        [one] => bail!("{one} has no effect {mode}: leave it out"),
        many => bail!("{} have no effect {mode}: leave them out", many.join(", ")),
    }
}

/// Print a report as JSON (pretty, keys sorted), refusing non-finite numbers (serde_json would
/// write `null`): [`crate::api::finite_json`].
pub fn print_json(report: &impl serde::Serialize) -> Result<()> {
    let v = crate::api::finite_json(report)?;
    outln!("{}", serde_json::to_string_pretty(&v)?)?;
    Ok(())
}

/// A two-column table of (label, value with unit) rows, aligned (no value shown as `-0.0`).
pub fn print_table(title: &str, rows: &[(&str, String)]) -> anyhow::Result<()> {
    outln!("{title}")?;
    let w = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0);
    for (k, v) in rows {
        outln!("  {k:<w$}  {}", no_negative_zero(v))?;
    }
    Ok(())
}

/// A command stopped by its whole-command budget (`solver.max_wall_s` of `resonance` and
/// `shortcut-map`) after writing what it computed: `main` prints it and exits with status 3,
/// the status of a run stopped by a budget.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BudgetStopped(pub String);

/// The wall-clock budget of a whole command: a watchdog thread raises a cancellation flag when
/// `seconds` have passed, which every simulator the command builds polls (the scenario's
/// `solver.cancel`, [`djkr_core::cancel`]); the command then stops with what it has computed. Dropped
/// when the command is done, it ends its watchdog at once.
pub struct CommandBudget {
    flag: std::sync::Arc<djkr_core::cancel::CancelFlag>,
    done: Option<std::sync::mpsc::Sender<()>>,
    watchdog: Option<std::thread::JoinHandle<()>>,
    /// The budget (s).
    pub seconds: f64,
}

impl CommandBudget {
    /// Start the clock: `seconds` from now (a budget beyond any run's is never reached).
    pub fn start(seconds: f64) -> Self {
        let flag = std::sync::Arc::new(djkr_core::cancel::CancelFlag::acquire());
        let (done, wait) = std::sync::mpsc::channel::<()>();
        let raise = std::sync::Arc::clone(&flag);
        let limit =
            std::time::Duration::try_from_secs_f64(seconds).unwrap_or(std::time::Duration::MAX);
        let watchdog = std::thread::spawn(move || {
            if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = wait.recv_timeout(limit) {
                raise.cancel();
            }
        });
        Self {
            flag,
            done: Some(done),
            watchdog: Some(watchdog),
            seconds,
        }
    }

    /// The token to put into the scenario's solver settings.
    pub fn token(&self) -> djkr_core::cancel::Cancel {
        self.flag.token()
    }

    /// True once the budget has run out.
    pub fn exhausted(&self) -> bool {
        self.flag.is_cancelled()
    }
}

impl Drop for CommandBudget {
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(w) = self.watchdog.take() {
            let _ = w.join();
        }
    }
}

/// Take the folder `out` for a command's files before any work: a folder (created if missing;
/// a file or a dangling link there is named), none of `names` a file djkr did not write (the
/// names the command writes, or those of them known before it runs: a file of the user's under
/// another is refused when its turn comes). `force` (`--force`) lets djkr overwrite such files.
pub fn claim_out(out: &std::path::Path, names: &[&str], force: bool) -> Result<()> {
    crate::output::folder::claim(out, names, force)?;
    if force {
        crate::output::folder::force_overwrite(out);
    }
    Ok(())
}

/// Write a file atomically (see [`crate::output::write_atomic`]).
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    Ok(crate::output::write_atomic(path, bytes)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_output_folders_stay_under_out() {
        for (file, name) in [
            ("scenarios/a.toml", "a"),
            ("...toml", "scenario"),
            ("..toml", "scenario"),
            (".toml", "toml"),
            ("x/..", "scenario"),
            ("", "scenario"),
            ("/", "scenario"),
            ("a b\\c.toml", "a_b_c"),
            ("..hidden.toml", "hidden"),
            ("v1.2.toml", "v1.2"),
        ] {
            assert_eq!(out_name(Path::new(file)), name, "{file}");
            let out = default_out(Path::new(file), "-x");
            let parts: Vec<_> = out.components().collect();
            assert_eq!(parts.len(), 2, "{file}: {}", out.display());
            assert!(matches!(parts[1], std::path::Component::Normal(_)));
        }
    }
}
