//! The `djkr` command line: parses arguments, loads inputs, calls the library, reports.
//! Everything physical lives in the library; see `djkr --help`.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
