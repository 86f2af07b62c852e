//! djkr: dynamic JKR adhesion of a rigid sphere on a vibrating viscoelastic substrate.
//!
//! The physics is the `djkr-core` crate, addressed as itself: [`djkr_core::jkr`] (contact
//! relations), [`djkr_core::adhesion`] (rate-dependent work of adhesion),
//! [`djkr_core::imposed_area`] (the paper's Sec. 2.1 method), [`djkr_core::closed_form`] (eqs.
//! 16–24, 29), [`djkr_core::comparators`] (Shui et al., Yi et al.), [`djkr_core::dynamics`] (the
//! time-domain simulator).
//! I/O lives at the edges: [`scenario::parse`], [`output`], and the command line.
//!
//! Running a scenario from Rust is what `djkr run FILE` does: load and validate the file
//! ([`scenario::parse::load_scenario`], or [`scenario::parse::load_scenario_with`] for `--set`
//! overrides), then [`api::run`], which keeps the time series, events and period records in
//! memory and, given a folder, also writes the run's files there:
//!
//! ```
//! use std::path::Path;
//! let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-protocol-300hz.toml");
//! let scenario = djkr::scenario::parse::load_scenario(&file)?;
//! let run = djkr::api::run(&scenario, None)?; // Some(dir): also write summary.json and run.h5
//! let p = &run.result.pull_off;
//! assert!(p.force < 0.0 && (p.amplification - 1.783).abs() < 1e-3); // N, tensile negative
//! println!("pull-off {:.4} N, amplification {:.3}, at t = {:.2} s", p.force, p.amplification, p.time);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The user guide, `docs/guide/`, documents the scenario format, the commands and every output.
//!
//! # What the crate offers
//!
//! This crate adds to the physics what reads and writes files and what its two front ends, the
//! command line and the Python package, share. Its public items are what a third front end
//! needs; everything else is the crate's own (`pub(crate)`):
//!
//! - scenarios: [`Scenario`], built one way ([`ScenarioSource::scenario`]: a file, a text or a
//!   [`scenario::parse::Tree`], with typed [`scenario::overrides::Override`]s),
//!   [`load_scenario`], [`load_scenario_with`], [`ScenarioError`], the table of every key
//!   ([`scenario::keys`]) and one-parameter families ([`scenario::family`]);
//! - commands, each a typed request and a typed report that derives or implements `Serialize`
//!   ([`api`]): [`run`], [`validate`], [`api::cycle`], [`api::pull_off`], [`api::resonance`],
//!   [`api::sweep`] (and [`sweep`] for sweep folders), [`api::fit`] (and [`fit`] for data and
//!   free keys), [`api::predict`] and [`api::design`] (from a fit); the accuracy study
//!   ([`accuracy`]) and the sensitivity to one ulp ([`sensitivity`]);
//! - errors that carry what happened and where ([`error::Error`], [`ScenarioError`]), worded by
//!   each front end through [`error::Words`];
//! - output: [`TimeSeriesWriter`], the format-neutral [`Table`] and its
//!   [`Column`]s, written as CSV or HDF5 ([`output`]); the one reader of input files
//!   ([`input`]); memory estimates ([`memory`]).
//!
//! The command line is the private module behind [`cli::main`], which the `djkr` binary calls.
#![deny(clippy::float_cmp)]
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod accuracy;
pub mod api;
pub mod cli;
pub mod error;
mod figures;
pub mod fit;
pub mod input;
pub mod memory;
pub mod output;
mod plot;
mod record;
mod reports;
mod run_plot;
pub mod scenario;
pub mod sensitivity;
pub mod sweep;
mod words;

/// The output reference's generated column tables (a test that reads the whole crate's tables).
#[cfg(test)]
mod docs_reference_tests;

pub use api::{run, validate, RunRecord};
pub use output::{Column, Table, TimeSeriesWriter};
pub use scenario::parse::{load_scenario, load_scenario_with, ScenarioError, ScenarioSource};
pub use scenario::Scenario;
