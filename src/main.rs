//! The `djkr` command line: parses arguments, loads inputs, calls the library, reports.
//! Everything physical lives in the library; see `djkr --help`.

fn main() -> std::process::ExitCode {
    djkr::cli::main()
}
