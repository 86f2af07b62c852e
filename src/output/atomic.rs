//! Atomic file output: the one way djkr puts a file on disk.
//!
//! A file is written in full under a hidden partial name beside the target, flushed, and only
//! then renamed into place, so an interrupted or failed writer never leaves a file that looks
//! complete. This module stages the partial ([`AtomicFile`]) and renames it into place; the
//! folder policy above it ([`super::folder`]) decides whether a target may be replaced and
//! records what djkr wrote: [`super::folder::write_atomic`] for one file,
//! [`super::folder::commit_all`] for a writer that must commit several files together (the run
//! writer: `summary.json` last, see [`super::run::RunWriter`]). An [`AtomicFile`] dropped without
//! committing removes its partial.
//!
//! **Partials are never a path a user can plant.** Each partial is created new
//! (`O_CREAT | O_EXCL | O_NOFOLLOW`) under a name no one can guess, `DIR/.NAME.XXXXXX.partial`
//! (`DIR/.NAME.TAG.XXXXXX.partial` for a run's files, tagged with its run id), with random
//! characters that are drawn again should the name exist: a symbolic link or file planted under
//! any name is never opened, written or followed. Committing checks the target first (through
//! the folder's manifest, [`super::folder`]): a directory, a symbolic link or another file that
//! is not a regular one is never replaced, nor a user's file without `--force`.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use tempfile::TempPath;

use super::error::OutputError;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Create a new partial file for `target` in its folder, `.NAME.[TAG.]XXXXXX.partial`, opened
/// for writing: created exclusively, never through a symbolic link, readable as any other file
/// the user creates (mode 0666 less the umask, not the 0600 of a temporary file).
fn create_partial(target: &Path, tag: Option<&str>) -> Result<(File, TempPath), OutputError> {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let prefix = match tag {
        Some(t) => format!(".{name}.{t}."),
        None => format!(".{name}."),
    };
    let made = tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(".partial")
        .rand_bytes(6)
        .make_in(dir, |path| {
            let mut o = fs::OpenOptions::new();
            o.read(true).write(true).create_new(true);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                o.mode(0o666).custom_flags(libc::O_NOFOLLOW);
            }
            o.open(path)
        })
        .map_err(|source| OutputError::Io {
            path: dir.join(format!("{prefix}XXXXXX.partial")),
            source,
        })?;
    Ok(made.into_parts())
}

/// A file being written atomically: its content goes to a fresh partial file until it is
/// committed ([`super::folder::commit`], [`super::folder::commit_all`]). Dropped uncommitted, it
/// removes the partial.
#[derive(Debug)]
pub(crate) struct AtomicFile {
    target: PathBuf,
    partial: TempPath,
    /// A file djkr appends to after publishing it (its manifest record ignores size and time).
    append: bool,
}

impl AtomicFile {
    /// Create `target`'s partial (tagged `tag`), empty, to be written by the caller (e.g.
    /// streamed during a run) at [`AtomicFile::partial`] through the returned handle.
    pub fn create(target: &Path, tag: &str) -> Result<(Self, File), OutputError> {
        let (file, partial) = create_partial(target, Some(tag))?;
        let staged = Self {
            target: target.to_path_buf(),
            partial,
            append: false,
        };
        Ok((staged, file))
    }

    /// Where the content is written until the commit.
    pub fn partial(&self) -> &Path {
        &self.partial
    }

    /// Write `bytes` as the content of `target` (under a partial name, flushed to disk).
    pub fn write(target: &Path, bytes: &[u8]) -> Result<Self, OutputError> {
        Self::write_with(target, |w| w.write_all(bytes))
    }

    /// Let `fill` write the content of `target` through a buffer (under a partial name,
    /// flushed to disk). For content too large to build in memory first.
    pub fn write_with(
        target: &Path,
        fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
    ) -> Result<Self, OutputError> {
        Self::fill(target, None, true, fill)
    }

    /// As [`AtomicFile::write_with`], under a partial name tagged `tag`, flushed to disk only
    /// when `sync` (the run writer's choice: docs/guide/output.md, "Crash safety").
    pub fn write_tagged(
        target: &Path,
        tag: &str,
        sync: bool,
        fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
    ) -> Result<Self, OutputError> {
        Self::fill(target, Some(tag), sync, fill)
    }

    fn fill(
        target: &Path,
        tag: Option<&str>,
        sync: bool,
        fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
    ) -> Result<Self, OutputError> {
        let (f, partial) = create_partial(target, tag)?;
        // On error `staged` is dropped, which removes the partial.
        let staged = Self {
            target: target.to_path_buf(),
            partial,
            append: false,
        };
        let p: &Path = &staged.partial;
        let mut w = BufWriter::with_capacity(1 << 16, f);
        fill(&mut w).map_err(io_err(p))?;
        let f = w.into_inner().map_err(|e| OutputError::Io {
            path: p.to_path_buf(),
            source: e.into_error(),
        })?;
        if sync {
            f.sync_all().map_err(io_err(p))?;
        }
        Ok(staged)
    }

    /// As [`AtomicFile::write`], not flushed to disk: for djkr's record of a folder, whose loss
    /// in a crash of the machine costs only a `--force` at the next run (a sync is ~3.5 ms).
    pub(super) fn write_unsynced(target: &Path, bytes: &[u8]) -> Result<Self, OutputError> {
        Self::fill(target, None, false, |w| w.write_all(bytes))
    }

    /// Mark this as a file djkr appends to once published (a sweep's `progress.csv`).
    pub fn appending(mut self) -> Self {
        self.append = true;
        self
    }

    /// Whether this is a file djkr appends to.
    pub fn appends(&self) -> bool {
        self.append
    }

    /// The file this will become.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Put the partial in place of the target ([`replace`]), unchecked: for the folder code,
    /// which has checked the target.
    pub(super) fn rename_into_place(self) -> Result<(), OutputError> {
        let Self {
            target, partial, ..
        } = self;
        let from = partial.to_path_buf();
        match replace(&from, &target) {
            Ok(()) => {
                // Moved away (or swapped and removed): nothing left to remove on drop.
                let _ = partial.keep();
                Ok(())
            }
            Err(e) => Err(io_err(&target)(e)),
        }
    }
}
/// Move `from` to `to`, replacing a file there, in one step that every reader sees whole: `to`
/// is always either the old file or the new one.
///
/// On Linux an existing `to` is swapped with `from` (`renameat2` with `RENAME_EXCHANGE`) and the
/// old file, now at `from`, removed, rather than renamed over: ext4 (with its default
/// `auto_da_alloc`) starts writing the new file's data out from inside a rename over an existing
/// file, which cost 0.9 ms per 600 kB file here, a tenth of a 1 s run end to end, against 0.06 ms
/// for the swap and the removal. djkr makes no promise that rename-over would have kept (docs/guide/output.md,
/// "Crash safety"): without `[output] fsync` a crash of the machine within the write-back delay
/// may lose what a rename published either way. Where the swap is not supported (another
/// system, a file system without it) or there is no file to replace, a plain rename. Only a
/// regular file is ever swapped out: a directory in the way makes the rename fail, naming it, and
/// a symbolic link is replaced itself, never followed (the callers refuse both before: the
/// folder's checks in [`super::folder`]).
pub fn replace(from: &Path, to: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    if fs::symlink_metadata(to).is_ok_and(|m| m.file_type().is_file()) && exchange(from, to).is_ok()
    {
        // `from` now holds the replaced file. Failing to remove it loses nothing: it keeps
        // the hidden partial name.
        let _ = fs::remove_file(from);
        return Ok(());
    }
    fs::rename(from, to)
}

/// Swap the files at `a` and `b` atomically (both must exist).
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| {
        CString::new(p.as_os_str().as_bytes())
            .map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))
    };
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: two valid NUL-terminated paths, relative ones resolved against the working
    // directory as by rename(2); the call reads nothing else.
    let r = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Make the renames in `dir` durable (best effort: not every file system can sync a directory).
pub fn sync_dir(dir: &Path) {
    if let Ok(d) = open_dir(dir) {
        let _ = d.sync_all();
    }
}

/// Open the folder `dir` to sync or lock it: only a directory (`O_DIRECTORY`: a FIFO or device
/// swapped in at the name is neither opened nor waited on).
pub fn open_dir(dir: &Path) -> std::io::Result<File> {
    let mut o = fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_DIRECTORY | libc::O_NONBLOCK);
    }
    o.open(dir)
}

#[cfg(test)]
mod tests {
    use super::super::folder::{commit, write_atomic};
    use super::*;

    #[test]
    fn commit_replaces_and_drop_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"two");
        let partial;
        {
            let staged = AtomicFile::write(&p, b"three").unwrap();
            partial = staged.partial().to_path_buf();
            assert!(partial.exists());
            let name = partial.file_name().unwrap().to_str().unwrap();
            assert!(
                name.starts_with(".a.txt.") && name.ends_with(".partial"),
                "{name}"
            );
            assert_eq!(staged.target(), p);
        }
        assert!(!partial.exists());
        assert_eq!(fs::read(&p).unwrap(), b"two");
        let failed = AtomicFile::write_with(&p, |_| Err(std::io::Error::other("boom")));
        assert!(failed.unwrap_err().to_string().contains("boom"));
        let mut names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, [".djkr-manifest.json", "a.txt"]);
    }

    #[test]
    fn replace_puts_the_new_file_in_place_and_leaves_no_old_one() {
        let dir = tempfile::tempdir().unwrap();
        let (new, target) = (dir.path().join(".t.partial"), dir.path().join("t"));
        fs::write(&new, b"first").unwrap();
        replace(&new, &target).unwrap(); // nothing to replace: a plain rename
        assert_eq!(fs::read(&target).unwrap(), b"first");
        // A reader of the old file keeps it whole while it is replaced.
        let mut reader = File::open(&target).unwrap();
        fs::write(&new, b"second").unwrap();
        replace(&new, &target).unwrap(); // swapped in, the old one removed
        assert_eq!(fs::read(&target).unwrap(), b"second");
        let mut old = String::new();
        std::io::Read::read_to_string(&mut reader, &mut old).unwrap();
        assert_eq!(old, "first");
        let names: Vec<_> = fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(names.len(), 1, "only the target is left: {names:?}");
        // A directory of that name is not swapped away: the replacement fails and leaves it.
        let d = dir.path().join("d");
        fs::create_dir(&d).unwrap();
        fs::write(d.join("inside"), b"keep").unwrap();
        fs::write(&new, b"third").unwrap();
        assert!(replace(&new, &d).is_err());
        assert_eq!(fs::read(d.join("inside")).unwrap(), b"keep");
        // A symbolic link is replaced itself: its target is neither written nor swapped away.
        #[cfg(unix)]
        {
            let victim = dir.path().join("victim");
            fs::write(&victim, b"precious").unwrap();
            let link = dir.path().join("link");
            std::os::unix::fs::symlink(&victim, &link).unwrap();
            replace(&new, &link).unwrap();
            assert_eq!(fs::read(&victim).unwrap(), b"precious");
            assert!(fs::symlink_metadata(&link).unwrap().is_file());
            assert_eq!(fs::read(&link).unwrap(), b"third");
        }
    }

    #[test]
    fn partials_are_new_files_that_no_planted_link_redirects() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        fs::write(&victim, b"precious").unwrap();
        let target = dir.path().join("out.png");
        #[cfg(unix)]
        for name in [".out.png.partial", ".out.png.tag.partial"] {
            std::os::unix::fs::symlink(&victim, dir.path().join(name)).unwrap();
        }
        let staged =
            AtomicFile::write_tagged(&target, "tag", false, |w| w.write_all(b"png")).unwrap();
        assert!(fs::symlink_metadata(staged.partial()).unwrap().is_file());
        commit(staged).unwrap();
        write_atomic(&target, b"png2").unwrap();
        assert_eq!(fs::read(&victim).unwrap(), b"precious");
        assert_eq!(fs::read(&target).unwrap(), b"png2");
    }
}
