//! Integration tests of the library and the physics through their public interfaces (a few
//! also run the `djkr` binary to compare with it), one module per subject, in one test binary
//! (one link instead of one per file).
//!
//! `cargo test --release --test it SUBJECT::` runs one subject. The two tests that measure the
//! process's memory (`tests/memory.rs`, `tests/memory_estimate.rs`: peak RSS, a counting global
//! allocator) keep binaries of their own: other tests running beside them would be counted.

#[path = "../tools/mod.rs"]
mod tools;

#[path = "../catalogue/mod.rs"]
mod catalogue;

mod closed_form;
mod continuation;
mod describing;
mod design;
mod docs_reference;
mod dynamics;
mod envelope_cost;
mod extremes;
mod fit;
mod fuzz;
mod fuzz_fit_data;
mod gent_schultz_fitting;
mod imposed_area;
mod predict;
mod restart;
mod scenario_files;
mod steady;
mod stops;
mod strong_vibration;
