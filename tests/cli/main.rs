//! Integration tests of the `djkr` binary end to end (flags, files, folders, messages, exit
//! statuses, and the outside tools it meets: Slurm, Python), one module per subject, in one test
//! binary (one link instead of one per file).
//!
//! `cargo test --release --test cli SUBJECT::` runs one subject.

#[path = "../tools/mod.rs"]
mod tools;

mod basics;
mod design;
mod docs_run;
mod figure_svg;
mod fit_refusals;
mod flag_ranges;
#[cfg(unix)]
mod folders;
mod hostile_input;
mod python;
mod reported_values;
mod slurm;
#[cfg(unix)]
mod special_files;
mod sweep;
