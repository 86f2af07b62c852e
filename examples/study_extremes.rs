//! The full extremes matrix: every time-domain scene of `tests/extremes/matrix.rs` with every
//! method (auto, implicit, dp8, dopri5, dop853), longer runs, and the dense imposed-area grid.
//! Asserts what the reduced matrix in `tests/it/extremes.rs` asserts (valid output or a clear error;
//! no panic, no hang, no invalid output), exiting with status 1 on any failure, and writes the
//! result.
//!
//!   cargo run --release --example study_extremes   # about 15 s
//!
//! Writes `docs/extremes.md`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;
#[path = "../tests/extremes/matrix.rs"]
mod matrix;

use common::Args;

fn main() {
    let args = Args::parse(
        "study_extremes",
        "docs",
        "The full extremes matrix (every scene × every method). Writes extremes.md; exits 1 on a \
         failure.",
    );
    let r = matrix::run_matrix(true);
    let mut doc = args.header("Extremes matrix (full)");
    doc += &format!(
        "{} cases, {:.1} s in total; {} failures. Per scene the outcome of each method (ok with \
         wall time, or the clear error's reason), then every case.\n\n",
        r.cases,
        r.wall_s,
        r.failures.len()
    );
    if !r.failures.is_empty() {
        doc += "**Failures:**\n\n";
        for f in &r.failures {
            doc += &format!("- {f}\n");
        }
        doc += "\n";
    }
    doc += &r.summary;
    doc += "\n## Every case\n\n";
    doc += &r.table;
    print!("{doc}");
    args.write("extremes.md", &doc);
    if !r.failures.is_empty() {
        eprintln!("{} failures", r.failures.len());
        std::process::exit(1);
    }
}
