//! Reading the files users name: the one helper every input file goes through (scenario files,
//! `--material` files, a tabulated law's CSV, `gs-fit` records, `fit` data files).
//!
//! A user may name anything: `/dev/zero`, `/dev/urandom`, a FIFO, a directory, a 5 GB log. So
//! [`read_text`]
//! - refuses anything that is not a regular file *before* opening it (checked with the file's
//!   metadata), naming what it is (a directory, a FIFO, a character device, ...);
//! - opens it non-blocking on Unix, so a file swapped for a FIFO between the check and the open
//!   cannot hang the open, and checks the opened file's type again;
//! - reads at most `limit` bytes (one byte more tells that the file is larger), so a file that
//!   grows or lies about its size cannot make djkr read gigabytes;
//! - requires UTF-8 text.
//!
//! The limits are per kind of file ([`InputKind`]): 1 MiB for a scenario or material file,
//! 16 MiB for a tabulated law or a fit's data file, 512 MiB for a measured record. Every message
//! says the limit.

use std::io::Read;
use std::path::Path;

use thiserror::Error;

const MIB: u64 = 1 << 20;

/// The kinds of input file, each with its size limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// A scenario file (TOML), also read by `--material`.
    Scenario,
    /// A tabulated adhesion law (CSV, speed and w).
    LawTable,
    /// A measured unloading record for `gs-fit` (CSV; a run's own timeseries.csv).
    Record,
    /// The measured data of `djkr fit` (CSV, one row per condition). 16 MiB holds its most rows
    /// (100 000) at 160 bytes each.
    FitData,
}

impl InputKind {
    /// The largest file of this kind djkr reads, in bytes.
    pub fn limit(self) -> u64 {
        match self {
            InputKind::Scenario => MIB,
            InputKind::LawTable => 16 * MIB,
            InputKind::Record => 512 * MIB,
            InputKind::FitData => 16 * MIB,
        }
    }

    /// What the file is, in words.
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Scenario => "scenario file",
            InputKind::LawTable => "tabulated law",
            InputKind::Record => "record",
            InputKind::FitData => "fit data file",
        }
    }
}

/// Why an input file was not read. The message does not repeat the file's name: the caller puts
/// it in front (`FILE: is a directory, not a regular file`).
#[derive(Debug, Error)]
pub enum InputError {
    /// The file does not exist or cannot be opened or read (the OS message, once).
    #[error("cannot read: {0}")]
    Io(std::io::Error),
    /// A directory, FIFO, device or socket.
    #[error("is {0}, not a regular file: give a file")]
    NotRegular(&'static str),
    /// Larger than the kind's limit.
    #[error("larger than {limit} bytes ({limit_text}), the limit for a {kind}")]
    TooLarge {
        /// The limit in bytes.
        limit: u64,
        /// The limit in words (`1 MiB`).
        limit_text: String,
        /// The kind of file.
        kind: &'static str,
    },
    /// Not UTF-8 text.
    #[error("not UTF-8 text (invalid byte at offset {0}): a {1} is a text file")]
    NotText(usize, &'static str),
}

/// A limit in bytes in words: `1 MiB`, `512 MiB`, `100 bytes`.
pub fn show_limit(bytes: u64) -> String {
    if bytes >= MIB && bytes.is_multiple_of(MIB) {
        format!("{} MiB", bytes / MIB)
    } else {
        format!("{bytes} bytes")
    }
}

/// What a non-regular file is, in words (`None`: a regular file).
fn special_kind(t: &std::fs::FileType) -> Option<&'static str> {
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

/// Read `path` as UTF-8 text of at most `kind.limit()` bytes (see the module documentation).
pub fn read_text(path: &Path, kind: InputKind) -> Result<String, InputError> {
    read_text_limited(path, kind, kind.limit())
}

/// [`read_text`] with an explicit limit in bytes (for tests).
pub fn read_text_limited(path: &Path, kind: InputKind, limit: u64) -> Result<String, InputError> {
    let too_large = || InputError::TooLarge {
        limit,
        limit_text: show_limit(limit),
        kind: kind.name(),
    };
    let meta = std::fs::metadata(path).map_err(InputError::Io)?;
    if let Some(what) = special_kind(&meta.file_type()) {
        return Err(InputError::NotRegular(what));
    }
    if meta.len() > limit {
        return Err(too_large());
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(InputError::Io)?;
    // The file may have been replaced between the check and the open.
    let meta = file.metadata().map_err(InputError::Io)?;
    if let Some(what) = special_kind(&meta.file_type()) {
        return Err(InputError::NotRegular(what));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(limit) as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(InputError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large());
    }
    String::from_utf8(bytes)
        .map_err(|e| InputError::NotText(e.utf8_error().valid_up_to(), kind.name()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_small_files_and_refuses_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.toml");
        std::fs::write(&p, "version = 1\n").unwrap();
        assert_eq!(read_text(&p, InputKind::Scenario).unwrap(), "version = 1\n");
        let e = read_text_limited(&p, InputKind::Scenario, 4).unwrap_err();
        assert_eq!(
            e.to_string(),
            "larger than 4 bytes (4 bytes), the limit for a scenario file"
        );
        let e = read_text(dir.path(), InputKind::Scenario).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is a directory, not a regular file: give a file"
        );
        std::fs::write(&p, b"ok\xff").unwrap();
        let e = read_text(&p, InputKind::LawTable).unwrap_err();
        assert!(e.to_string().contains("offset 2"), "{e}");
        let e = read_text(&dir.path().join("none"), InputKind::Record).unwrap_err();
        assert!(e.to_string().starts_with("cannot read: "), "{e}");
        assert_eq!(show_limit(InputKind::Scenario.limit()), "1 MiB");
    }

    #[cfg(unix)]
    #[test]
    fn devices_are_refused_up_front() {
        for dev in ["/dev/zero", "/dev/urandom", "/dev/null"] {
            if Path::new(dev).exists() {
                let e = read_text(Path::new(dev), InputKind::Scenario).unwrap_err();
                assert!(e.to_string().contains("character device"), "{dev}: {e}");
            }
        }
    }
}
