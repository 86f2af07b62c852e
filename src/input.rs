//! Reading files: the one reader every file djkr reads goes through, the files users name
//! (scenario files, `--material` files, a tabulated law's CSV, `gs-fit` records) and the files
//! djkr reads back from its own folders (`run.h5` for `djkr plot`, a sweep's `sweep.json`,
//! `sweep.csv` and `progress.csv` for `plot`, `sweep merge` and `--resume`, its record of a folder
//! and its lock).
//!
//! A user may name anything, and a folder may hold anything under the names djkr reads:
//! `/dev/zero`, `/dev/urandom`, a FIFO, a directory, a 5 GB log, a link to any of them. So
//! `open` (and `read_bytes`, [`read_text`] on top of it)
//! - refuses anything that is not a regular file *before* opening it (checked with the file's
//!   metadata), naming what it is (a directory, a FIFO, a character device, ...); djkr's own
//!   bookkeeping files (its record of a folder, its lock) are not followed through a symbolic
//!   link either ([`InputKind::follows_links`]);
//! - opens it non-blocking on Unix, so a file swapped for a FIFO between the check and the open
//!   cannot hang the open, and checks the opened file's type again;
//! - refuses a file larger than the kind's limit before reading, and reads at most `limit`
//!   bytes (one byte more tells that the file is larger), so a file that grows or lies about its
//!   size cannot make djkr read gigabytes;
//! - ([`read_text`]) requires UTF-8 text.
//!
//! The limits are per kind of file ([`InputKind::limit`], listed in
//! docs/guide/unattended.md, "Input limits"). Every message says the limit.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use thiserror::Error;

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// The kinds of file djkr reads, each with its size limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// A scenario file (TOML), also read by `--material`.
    Scenario,
    /// A tabulated adhesion law (CSV, speed and w).
    LawTable,
    /// A measured unloading record for `gs-fit` (CSV; a run's own timeseries.csv).
    Record,
    /// A run's `run.h5`, read by `djkr plot` and `djkr run --plot`.
    RunFile,
    /// A sweep's description, `sweep.json`.
    SweepDescription,
    /// A sweep's table of runs, `sweep.csv` or `progress.csv`.
    SweepRows,
    /// A run's `summary.json`, djkr's own (read back to recognise a run folder an older djkr
    /// wrote).
    Summary,
    /// djkr's record of the files it wrote in a folder, `.djkr-manifest.json`.
    FolderRecord,
    /// A folder's lock file, `.djkr.lock`.
    Lock,
    /// The measured data of `djkr fit` (CSV, one row per condition). 16 MiB holds its most rows
    /// (100 000) at 160 bytes each.
    FitData,
}

impl InputKind {
    /// The largest file of this kind djkr reads, in bytes.
    ///
    /// Why each: a scenario is a page of TOML; a law table a few thousand rows; a measured
    /// record may be a long run's timeseries.csv (300 bytes a sample: 512 MiB is 1.8 million
    /// samples). A run file of 4 GiB holds about 40 million samples (104 bytes each), 1.3 GB in
    /// memory for the four series `djkr plot` draws. A sweep description holds the scenario's
    /// text (1 MiB at most), the `--set` list and the key columns, all JSON-escaped. A sweep
    /// table holds one row per run, about 150 to 400 bytes: 4 GiB is 10 million runs, the most
    /// a sweep may have. A summary lists at most 10 000 events (a few MB). djkr's record of a
    /// folder holds one line per file it published there, its lock a header and a line per
    /// partial file.
    pub fn limit(self) -> u64 {
        match self {
            InputKind::Scenario => MIB,
            InputKind::LawTable => 16 * MIB,
            InputKind::Record => 512 * MIB,
            InputKind::RunFile => 4 * GIB,
            InputKind::SweepDescription => 64 * MIB,
            InputKind::SweepRows => 4 * GIB,
            InputKind::Summary => 64 * MIB,
            InputKind::FolderRecord => 16 * MIB,
            InputKind::Lock => MIB,
            InputKind::FitData => 16 * MIB,
        }
    }

    /// What the file is, in words.
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Scenario => "scenario file",
            InputKind::LawTable => "tabulated law",
            InputKind::Record => "record",
            InputKind::RunFile => "run file",
            InputKind::SweepDescription => "sweep description",
            InputKind::SweepRows => "sweep table",
            InputKind::Summary => "run summary",
            InputKind::FolderRecord => "folder record",
            InputKind::Lock => "lock file",
            InputKind::FitData => "fit data file",
        }
    }

    /// Whether a symbolic link at the path is followed. A file the user names, or that a user
    /// may have linked into a folder (`run.h5` → elsewhere), is read through a link (its target
    /// is held to the same rules); djkr's own bookkeeping files in a folder (its record and its
    /// lock, a run's summary.json read as its record of the run) are not: a link there was planted,
    /// and is refused.
    pub fn follows_links(self) -> bool {
        !matches!(
            self,
            InputKind::FolderRecord | InputKind::Lock | InputKind::Summary
        )
    }
}

/// Why a file was not read. The message does not repeat the file's name: the caller puts it in
/// front (`FILE: is a directory, not a regular file`).
#[derive(Debug, Error)]
pub enum InputError {
    /// The file does not exist or cannot be opened or read (the OS message, once).
    #[error("cannot read: {0}")]
    Io(std::io::Error),
    /// A directory, FIFO, device, socket (or, for djkr's own files, a symbolic link).
    #[error("is {0}, not a regular file: a {1} must be one")]
    NotRegular(&'static str, &'static str),
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

impl InputError {
    /// True when the file does not exist (a caller for which that is no error tells it apart).
    pub fn is_missing(&self) -> bool {
        matches!(self, InputError::Io(e) if e.kind() == std::io::ErrorKind::NotFound)
    }

    /// A file of `kind` larger than its limit.
    pub fn too_large(kind: InputKind) -> InputError {
        too_large(kind, kind.limit())
    }
}

/// A limit in bytes in words: `1 MiB`, `512 MiB`, `4 GiB`, `100 bytes`.
pub fn show_limit(bytes: u64) -> String {
    if bytes >= GIB && bytes.is_multiple_of(GIB) {
        format!("{} GiB", bytes / GIB)
    } else if bytes >= MIB && bytes.is_multiple_of(MIB) {
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
    if t.is_symlink() {
        return Some("a symbolic link");
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

fn too_large(kind: InputKind, limit: u64) -> InputError {
    InputError::TooLarge {
        limit,
        limit_text: show_limit(limit),
        kind: kind.name(),
    }
}

/// Open `path` to read a file of `kind` (see the module documentation): a regular file of at
/// most `kind.limit()` bytes when opened, or the reason it is refused. What is read from it
/// after is bounded by the caller ([`read_from`], or a reader that knows the length).
pub(crate) fn open(path: &Path, kind: InputKind) -> Result<File, InputError> {
    open_limited(path, kind, kind.limit())
}

fn open_limited(path: &Path, kind: InputKind, limit: u64) -> Result<File, InputError> {
    let not_regular = |what| InputError::NotRegular(what, kind.name());
    let meta = if kind.follows_links() {
        std::fs::metadata(path)
    } else {
        std::fs::symlink_metadata(path)
    }
    .map_err(InputError::Io)?;
    if let Some(what) = special_kind(&meta.file_type()) {
        return Err(not_regular(what));
    }
    if meta.len() > limit {
        return Err(too_large(kind, limit));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let nofollow = if kind.follows_links() {
            0
        } else {
            libc::O_NOFOLLOW
        };
        options.custom_flags(libc::O_NONBLOCK | nofollow);
    }
    let file = options.open(path).map_err(InputError::Io)?;
    // The file may have been replaced between the check and the open.
    let meta = file.metadata().map_err(InputError::Io)?;
    if let Some(what) = special_kind(&meta.file_type()) {
        return Err(not_regular(what));
    }
    if meta.len() > limit {
        return Err(too_large(kind, limit));
    }
    Ok(file)
}

/// Read the rest of `file` (opened by [`open`], or a regular file djkr opened itself), at most
/// `kind.limit()` bytes.
pub(crate) fn read_from(file: &File, kind: InputKind) -> Result<Vec<u8>, InputError> {
    read_from_limited(file, kind, kind.limit())
}

fn read_from_limited(file: &File, kind: InputKind, limit: u64) -> Result<Vec<u8>, InputError> {
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut bytes = Vec::with_capacity(len.min(limit) as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(InputError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(kind, limit));
    }
    Ok(bytes)
}

/// Read `path`, a file of `kind`, whole: at most `kind.limit()` bytes (see the module
/// documentation).
pub(crate) fn read_bytes(path: &Path, kind: InputKind) -> Result<Vec<u8>, InputError> {
    read_bytes_limited(path, kind, kind.limit())
}

/// [`read_bytes`] with an explicit limit in bytes (for tests).
pub(crate) fn read_bytes_limited(
    path: &Path,
    kind: InputKind,
    limit: u64,
) -> Result<Vec<u8>, InputError> {
    let file = open_limited(path, kind, limit)?;
    read_from_limited(&file, kind, limit)
}

/// Read `path` as UTF-8 text of at most `kind.limit()` bytes (see the module documentation).
pub fn read_text(path: &Path, kind: InputKind) -> Result<String, InputError> {
    read_text_limited(path, kind, kind.limit())
}

/// [`read_text`] with an explicit limit in bytes (for tests).
pub(crate) fn read_text_limited(
    path: &Path,
    kind: InputKind,
    limit: u64,
) -> Result<String, InputError> {
    text(read_bytes_limited(path, kind, limit)?, kind)
}

/// `bytes` read from a file of `kind` as UTF-8 text.
pub(crate) fn text(bytes: Vec<u8>, kind: InputKind) -> Result<String, InputError> {
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
            "is a directory, not a regular file: a scenario file must be one"
        );
        std::fs::write(&p, b"ok\xff").unwrap();
        let e = read_text(&p, InputKind::LawTable).unwrap_err();
        assert!(e.to_string().contains("offset 2"), "{e}");
        let e = read_text(&dir.path().join("none"), InputKind::Record).unwrap_err();
        assert!(e.to_string().starts_with("cannot read: "), "{e}");
        assert_eq!(show_limit(InputKind::Scenario.limit()), "1 MiB");
        assert_eq!(show_limit(InputKind::RunFile.limit()), "4 GiB");
        assert!(e.is_missing());
    }

    #[test]
    fn binary_files_are_read_whole_within_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("run.h5");
        let bytes: Vec<u8> = (0..=255u8).cycle().take(1000).collect();
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(read_bytes(&p, InputKind::RunFile).unwrap(), bytes);
        let e = read_bytes_limited(&p, InputKind::RunFile, 999).unwrap_err();
        assert_eq!(
            e.to_string(),
            "larger than 999 bytes (999 bytes), the limit for a run file"
        );
        // A file that grew after it was opened is read no further than the limit.
        let f = open(&p, InputKind::RunFile).unwrap();
        let e = read_from_limited(&f, InputKind::RunFile, 500).unwrap_err();
        assert!(matches!(e, InputError::TooLarge { limit: 500, .. }), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn links_are_followed_to_a_regular_file_only_and_never_for_djkrs_own_files() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target");
        std::fs::write(&target, b"djkr lock\n").unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        assert_eq!(
            read_bytes(&link, InputKind::RunFile).unwrap(),
            b"djkr lock\n"
        );
        for kind in [InputKind::Lock, InputKind::FolderRecord] {
            let e = read_bytes(&link, kind).unwrap_err();
            assert!(e.to_string().starts_with("is a symbolic link"), "{e}");
        }
        let zero = dir.path().join("zero");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        let e = read_bytes(&zero, InputKind::RunFile).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is a character device, not a regular file: a run file must be one"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("sweep.json");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        // No writer ever opens it: a read that blocked would hang this test.
        let e = read_text(&fifo, InputKind::SweepDescription).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is a FIFO (named pipe), not a regular file: a sweep description must be one"
        );
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
