//! Why output could not be written ([`OutputError`]).

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::names::LOCK_NAME;

/// Why output could not be written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The HDF5 encoder refused the data.
    #[error("{}: HDF5 writer: {message}", path.display())]
    Hdf5 {
        /// The file being written.
        path: PathBuf,
        /// What hdf5-pure said.
        message: String,
    },
    /// Another run or sweep holds the output directory.
    #[error(
        "{}: another djkr run or sweep is writing into this directory ({}, holding {LOCK_NAME}); \
         wait for it or choose another «out»",
        dir.display(),
        holder.map_or("another process".to_string(), |p| format!("pid {p}"))
    )]
    Busy {
        /// The output directory.
        dir: PathBuf,
        /// The process id of the holder, when its lock file says.
        holder: Option<u32>,
    },
    /// Files djkr is about to publish exist and djkr did not write them.
    #[error(
        "{}: {} {} there and not written by djkr: move {it} away, choose another «out», or add \
         «force» to overwrite {it} (nothing else in the folder is touched)",
        dir.display(),
        names.join(", "),
        if names.len() == 1 { "is already" } else { "are already" },
        it = if names.len() == 1 { "it" } else { "them" }
    )]
    Clash {
        /// The output directory.
        dir: PathBuf,
        /// The clashing names.
        names: Vec<String>,
    },
    /// A name djkr writes (or its own record or lock) is not a regular file.
    #[error("{}: is {what}; remove it or choose another «out»", path.display())]
    NotRegular {
        /// The path.
        path: PathBuf,
        /// What it is.
        what: String,
    },
    /// The output directory is not a folder.
    #[error("{}: is {what}, not a folder; choose a folder for «out» (it is created if missing)", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
        /// What it is.
        what: String,
    },
    /// The run's certain samples would not fit on the disk (`disk::check_up_front`).
    #[error(
        "{}: the run's output would take about {} ({samples:.3e} samples of the stages with a \
         fixed duration at [output] sample_rate), more than the {} free; lower [output] \
         sample_rate, drop CSV, or choose another «out»",
        dir.display(),
        human_bytes(*need),
        human_bytes(*free)
    )]
    DiskSpace {
        /// The output directory.
        dir: PathBuf,
        /// Estimated bytes.
        need: f64,
        /// Free bytes.
        free: f64,
        /// Estimated samples.
        samples: f64,
    },
}

/// `1.2 GB`-style size.
pub(super) fn human_bytes(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut x = b;
    let mut i = 0;
    while x >= 1000.0 && i + 1 < units.len() {
        x /= 1000.0;
        i += 1;
    }
    format!("{x:.1} {}", units[i])
}

/// An I/O error on `path` as [`OutputError::Io`] (for `map_err`).
pub(super) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}
