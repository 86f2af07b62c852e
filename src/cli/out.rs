//! Standard output as a fallible writer. `println!` panics when stdout cannot be written (a full
//! disk, `> /dev/full`: "failed printing to stdout", exit 101); every command prints through
//! [`outln!`] and [`out!`] instead, which return an error ([`StdoutError`]) that `main` reports on
//! one line with exit status 1. A closed pipe still ends djkr quietly (SIGPIPE, see
//! `restore_sigpipe`).

use std::fmt;
use std::io::Write;

/// Standard output could not be written: the listing is incomplete (the files a command wrote
/// before printing are whole).
#[derive(Debug, thiserror::Error)]
#[error("writing to standard output: {0}")]
pub struct StdoutError(#[from] pub std::io::Error);

/// Write `args` to standard output, flushed, so that a failure is seen here and not at exit.
pub fn write(args: fmt::Arguments) -> Result<(), StdoutError> {
    let mut lock = std::io::stdout().lock();
    lock.write_fmt(args)?;
    lock.flush()?;
    Ok(())
}

/// `println!` that returns `Result<(), StdoutError>` instead of panicking.
macro_rules! outln {
    () => {
        $crate::cli::out::write(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::out::write(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that returns `Result<(), StdoutError>` instead of panicking.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::out::write(format_args!($($arg)*))
    };
}
