//! Output folders: which files in a folder djkr may replace or delete, and who is writing there.
//!
//! A folder given as `--out` may hold anything of the user's (`--out .` is fine). djkr keeps
//! its own record of what it wrote there, `DIR/.djkr-manifest.json` ([`MANIFEST_NAME`]): for
//! each file it published, the file's identity when published (device, inode, size and
//! modification time to the nanosecond; for a file djkr appends to, such as a sweep's
//! `progress.csv`, device and inode only). A file is djkr's when it is a regular file whose
//! identity matches its record; anything else under a name djkr is about to publish is a
//! *clash*, refused before any work ([`check_names`]) and again at the moment of replacing it
//! ([`commit_all`]) unless the user gave `--force` for the folder ([`force_overwrite`]). A name
//! that is a directory, a symbolic link or another non-regular file is refused even with
//! `--force`.
//!
//! Why the identity and not a content hash: a run file can be gigabytes, and hashing it at every
//! later run into the folder would cost seconds; the identity costs one `stat`. A rename (which
//! is how djkr publishes) keeps inode, size and time, while a user who edits a file in place
//! changes its time and one who saves a new one over it changes its inode: either way the file
//! is then the user's, and protected. Only a deliberate forgery (same inode, `touch -d` to the
//! nanosecond) would pass, and that user could delete the file anyway.
//!
//! Deleting: djkr removes only regular files it can prove it wrote: a partial recorded (name and
//! inode) in the folder's lock file by the writer that created it ([`DirLock::note_partial`]),
//! which the next holder of the lock removes when a killed writer left it, and a file recorded in
//! the manifest ([`remove_owned`], a complete sweep's `progress.csv`). Nothing is recognised by
//! its name alone, since a name can be planted.
//!
//! Locks: a run or a sweep holds `DIR/.djkr.lock` ([`DirLock`]) for its whole life and writes
//! its process id into it, so that a second writer is refused at once, naming the holder. The
//! manifest itself is read and replaced under a short lock on the folder ([`FolderGuard`]), so
//! that writers that do not hold the life lock (two `djkr plot` on one folder) both succeed.

use std::collections::BTreeMap;
use std::fs::{self, File, Metadata};
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use super::atomic::AtomicFile;
use super::error::OutputError;
use super::names::{LOCK_NAME, SUMMARY_NAME};
use crate::input::{self, InputError, InputKind};

/// djkr's record of the files it wrote in a folder.
pub const MANIFEST_NAME: &str = ".djkr-manifest.json";

/// The first line of a lock file djkr wrote.
const LOCK_HEADER: &str = "djkr lock";

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What a file is that djkr did not expect (for error messages).
fn kind_of(m: &Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a directory";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
    }
    "not a regular file"
}

/// Make `dir` usable as an output folder: create it when missing; refuse, naming the path and
/// what it is, a file, a dangling symbolic link or anything else that is not a folder (instead
/// of the bare "File exists" the system gives).
pub fn prepare(dir: &Path) -> Result<(), OutputError> {
    let not_folder = |what: String| OutputError::NotAFolder {
        path: dir.to_path_buf(),
        what,
    };
    match fs::symlink_metadata(dir) {
        Ok(m) if m.is_dir() => return Ok(()),
        Ok(m) if m.file_type().is_symlink() => {
            let target = fs::read_link(dir)
                .map(|t| t.display().to_string())
                .unwrap_or_default();
            return match fs::metadata(dir) {
                Ok(t) if t.is_dir() => Ok(()),
                Ok(t) => Err(not_folder(format!(
                    "a symbolic link to {target}, which is {}",
                    if t.is_file() { "a file" } else { kind_of(&t) }
                ))),
                Err(_) => Err(not_folder(format!(
                    "a dangling symbolic link (to {target}, which does not exist)"
                ))),
            };
        }
        Ok(m) if m.is_file() => return Err(not_folder("a file".into())),
        Ok(m) => return Err(not_folder(kind_of(&m).into())),
        Err(_) => {}
    }
    fs::create_dir_all(dir).map_err(io_err(dir))
}

/// The identity of a file djkr published (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
struct Stamp {
    dev: u64,
    ino: u64,
    size: u64,
    mtime_ns: i64,
    /// A file djkr appends to: compared by device and inode only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    append: bool,
}

impl Stamp {
    fn of(m: &Metadata, append: bool) -> Stamp {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Stamp {
                dev: m.dev(),
                ino: m.ino(),
                size: m.size(),
                mtime_ns: m.mtime().saturating_mul(1_000_000_000) + m.mtime_nsec(),
                append,
            }
        }
        #[cfg(not(unix))]
        {
            let mtime_ns = m
                .modified()
                .ok()
                .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                .map_or(0, |d| d.as_nanos() as i64);
            Stamp {
                dev: 0,
                ino: 0,
                size: m.len(),
                mtime_ns,
                append,
            }
        }
    }

    /// Whether `m` is still the file this stamp recorded.
    fn matches(&self, m: &Metadata) -> bool {
        let now = Stamp::of(m, self.append);
        m.file_type().is_file()
            && now.dev == self.dev
            && now.ino == self.ino
            && (self.append || (now.size == self.size && now.mtime_ns == self.mtime_ns))
    }
}

/// The manifest's content.
#[derive(Debug, Default, Serialize, Deserialize)]
struct Record {
    /// What this file is, for a reader who finds it.
    #[serde(default)]
    about: String,
    /// The files djkr published in the folder, by name.
    #[serde(default)]
    files: BTreeMap<String, Stamp>,
    /// In a folder without a record, the files of a run an older djkr wrote there, by name, with
    /// their sizes ([`legacy_run`]).
    #[serde(skip)]
    legacy: BTreeMap<String, u64>,
}

impl Record {
    /// The folder's record (empty when there is none). A manifest that is not a regular file or
    /// not djkr's JSON is refused, naming it: djkr cannot tell then what is its own.
    fn read(dir: &Path) -> Result<Record, OutputError> {
        let path = dir.join(MANIFEST_NAME);
        let Some(text) = read_own(&path, InputKind::FolderRecord)? else {
            return Ok(Record {
                legacy: legacy_run(dir),
                ..Record::default()
            });
        };
        serde_json::from_str(&text).map_err(|e| OutputError::NotRegular {
            path: path.clone(),
            what: format!("not djkr's record of the folder ({e}); move it away"),
        })
    }

    /// Replace the folder's manifest with this record (a partial of a unique name, renamed).
    fn write(&mut self, dir: &Path) -> Result<(), OutputError> {
        self.about = "djkr's record of the files it wrote in this folder: it replaces or deletes \
                      only these (README, \"Output folders\")"
            .into();
        // A run of an older djkr keeps its files djkr's once the folder has a record.
        for (name, size) in std::mem::take(&mut self.legacy) {
            if let Ok(m) = fs::symlink_metadata(dir.join(&name)) {
                if m.file_type().is_file() && m.len() == size {
                    self.files.entry(name).or_insert(Stamp::of(&m, false));
                }
            }
        }
        let text = serde_json::to_string_pretty(self).unwrap_or_default();
        let target = dir.join(MANIFEST_NAME);
        let file = AtomicFile::write_unsynced(&target, text.as_bytes())?;
        file.rename_into_place()
    }

    /// Whether the file at `dir/name` is djkr's.
    fn owns(&self, dir: &Path, name: &str) -> bool {
        let meta = fs::symlink_metadata(dir.join(name));
        match (self.files.get(name), self.legacy.get(name), meta) {
            (Some(s), _, Ok(m)) => s.matches(&m),
            (None, Some(&size), Ok(m)) => m.file_type().is_file() && m.len() == size,
            _ => false,
        }
    }
}

/// A run folder that a djkr older than this record wrote: its `summary.json`, a JSON object with
/// the run's `run_id` and `file_bytes` (the size of every other file of the run), is djkr's own
/// record of that run. The files it lists, at those sizes, and `summary.json` itself count as
/// djkr's, so that rerunning into such a folder needs no `--force`. Empty for anything else.
fn legacy_run(dir: &Path) -> BTreeMap<String, u64> {
    let mut files = BTreeMap::new();
    let path = dir.join(SUMMARY_NAME);
    // Anything that is not a regular file within a summary's limit is not one.
    let Ok(text) = input::read_bytes(&path, InputKind::Summary) else {
        return files;
    };
    let len = text.len() as u64;
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(&text) else {
        return files;
    };
    let (Some(_), Some(bytes)) = (v["run_id"].as_str(), v["file_bytes"].as_object()) else {
        return files;
    };
    for (name, size) in bytes {
        if let (Some(size), false) = (
            size.as_u64(),
            name.contains(['/', '\\']) || name.starts_with('.'),
        ) {
            files.insert(name.clone(), size);
        }
    }
    files.insert(SUMMARY_NAME.to_string(), len);
    files
}

/// Read djkr's own file `path` (its record of a folder) through the one reader of input files
/// ([`crate::input`]); `None` when there is none. Anything else than a regular file within the
/// kind's limit, in UTF-8, is refused naming it: djkr cannot tell then what is its own.
fn read_own(path: &Path, kind: InputKind) -> Result<Option<String>, OutputError> {
    let refused = |what: String| OutputError::NotRegular {
        path: path.to_path_buf(),
        what,
    };
    match input::read_text(path, kind) {
        Ok(text) => Ok(Some(text)),
        Err(e) if e.is_missing() => Ok(None),
        Err(InputError::NotRegular(what, _)) => Err(refused(what.into())),
        Err(InputError::Io(source)) => Err(OutputError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Err(e) => Err(refused(format!(
            "not djkr's {} ({e}); move it away",
            kind.name()
        ))),
    }
}

/// Open the existing file `path` to read and write it, without following a symbolic link (and
/// without blocking on a FIFO); `None` when it does not exist; refused, naming it, when it is not
/// a regular file.
fn open_existing_rw(path: &Path) -> Result<Option<File>, OutputError> {
    let mut o = fs::OpenOptions::new();
    o.read(true).write(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let f = match o.open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(match fs::symlink_metadata(path) {
                Ok(m) if !m.is_file() => OutputError::NotRegular {
                    path: path.to_path_buf(),
                    what: kind_of(&m).into(),
                },
                _ => OutputError::Io {
                    path: path.to_path_buf(),
                    source: e,
                },
            })
        }
    };
    let m = f.metadata().map_err(io_err(path))?;
    if !m.is_file() {
        return Err(OutputError::NotRegular {
            path: path.to_path_buf(),
            what: kind_of(&m).into(),
        });
    }
    Ok(Some(f))
}

/// A short exclusive lock on the folder itself (a `flock` of the directory), under which the
/// manifest is read, files are replaced and the manifest rewritten. Best effort: where the
/// folder cannot be locked (a file system without `flock` on directories), nothing waits.
pub struct FolderGuard {
    _dir: Option<File>,
}

impl FolderGuard {
    /// Wait for the folder's short lock.
    pub fn lock(dir: &Path) -> FolderGuard {
        let d = super::atomic::open_dir(dir)
            .ok()
            .filter(|d| d.lock().is_ok());
        FolderGuard { _dir: d }
    }
}

/// Folders where the user asked `--force` (canonical paths): a clash there is overwritten.
static FORCED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Let djkr replace files of the user's in `dir` under the names it publishes (`--force`).
pub fn force_overwrite(dir: &Path) {
    if let (Ok(d), Ok(mut v)) = (fs::canonicalize(dir), FORCED.lock()) {
        v.push(d);
    }
}

fn forced(dir: &Path) -> bool {
    match (fs::canonicalize(dir), FORCED.lock()) {
        (Ok(d), Ok(v)) => v.contains(&d),
        _ => false,
    }
}

/// Refuse before any work to publish `names` in `dir` when one of them is not a regular file
/// (always) or a file djkr did not write (unless `force`, which then lets djkr replace them).
pub fn check_names<S: AsRef<str>>(dir: &Path, names: &[S], force: bool) -> Result<(), OutputError> {
    let _guard = FolderGuard::lock(dir);
    let record = Record::read(dir)?;
    let mut clashes = Vec::new();
    for name in names {
        let name = name.as_ref();
        let path = dir.join(name);
        match fs::symlink_metadata(&path) {
            Err(_) => {}
            Ok(m) if !m.file_type().is_file() => {
                return Err(OutputError::NotRegular {
                    path,
                    what: format!("{}, where djkr writes a file", kind_of(&m)),
                })
            }
            Ok(_) if record.owns(dir, name) => {}
            Ok(_) => clashes.push(name.to_string()),
        }
    }
    if clashes.is_empty() {
        return Ok(());
    }
    if force {
        force_overwrite(dir);
        return Ok(());
    }
    Err(OutputError::Clash {
        dir: dir.to_path_buf(),
        names: clashes,
    })
}

/// [`prepare`] `dir`, then [`check_names`]: the start of every command that writes `names`
/// into a folder the user named.
pub fn claim<S: AsRef<str>>(dir: &Path, names: &[S], force: bool) -> Result<(), OutputError> {
    prepare(dir)?;
    check_names(dir, names, force)
}

/// Put `file` in place of its target and record it as djkr's in its folder's manifest; a target
/// that is not djkr's is refused ([`commit_all`]).
pub fn commit(file: AtomicFile) -> Result<PathBuf, OutputError> {
    let dir = match file.target().parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut done = commit_all(&dir, vec![file])?;
    Ok(done.pop().unwrap_or_default())
}

/// Write one file atomically ([`super::atomic::AtomicFile`]): figures, tables, sweeps, studies. Refuses,
/// naming it, to replace a file djkr did not write.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    commit(AtomicFile::write(path, bytes)?).map(|_| ())
}

/// Put the staged `files` (all in `dir`) in place, in order, and record them in the manifest,
/// under the folder's short lock. A target that is not a regular file, or a file djkr did not
/// write in a folder without `--force`, is refused, naming it (the files before it are in place
/// and recorded; the rest are removed).
pub fn commit_all(dir: &Path, files: Vec<AtomicFile>) -> Result<Vec<PathBuf>, OutputError> {
    let _guard = FolderGuard::lock(dir);
    let mut record = Record::read(dir)?;
    let mut done = Vec::new();
    let mut result = Ok(());
    for f in files {
        let target = f.target().to_path_buf();
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match fs::symlink_metadata(&target) {
            Ok(m) if !m.file_type().is_file() => {
                result = Err(OutputError::NotRegular {
                    path: target,
                    what: format!("{}, where djkr writes a file", kind_of(&m)),
                });
                break;
            }
            Ok(_) if !record.owns(dir, &name) && !forced(dir) => {
                result = Err(OutputError::Clash {
                    dir: dir.to_path_buf(),
                    names: vec![name],
                });
                break;
            }
            _ => {}
        }
        let append = f.appends();
        if let Err(e) = f.rename_into_place() {
            result = Err(e);
            break;
        }
        if let Ok(m) = fs::symlink_metadata(&target) {
            record.files.insert(name, Stamp::of(&m, append));
        }
        done.push(target);
    }
    if !done.is_empty() {
        record.write(dir)?;
    }
    result.map(|()| done)
}

/// Remove `dir/name` if it is djkr's (recorded in the manifest and unchanged), and its record;
/// `Ok(false)` leaves a file that is not djkr's where it is.
pub fn remove_owned(dir: &Path, name: &str) -> Result<bool, OutputError> {
    let _guard = FolderGuard::lock(dir);
    let mut record = Record::read(dir)?;
    if !record.owns(dir, name) {
        return Ok(false);
    }
    let path = dir.join(name);
    fs::remove_file(&path).map_err(io_err(&path))?;
    record.files.remove(name);
    record.write(dir)?;
    Ok(true)
}

/// Whether `dir/name` is a file djkr wrote (recorded in the folder's manifest, unchanged since).
pub fn is_owned(dir: &Path, name: &str) -> bool {
    Record::read(dir).is_ok_and(|r| r.owns(dir, name))
}

/// The exclusive lock on `DIR/.djkr.lock` that a run or a sweep holds for its whole life. The
/// file holds `djkr lock`, the holder's process id (`pid N`), and one line `partial NAME INODE`
/// per partial file the holder created, so that the next holder removes what a killed one left
/// (only regular files of that name and inode).
///
/// djkr writes only into a lock file it created itself (`O_CREAT | O_EXCL`), or into one a djkr
/// left (a holder killed, or finished: the file stays, released): a regular file of one link
/// whose content is a djkr lock's, read under the lock ([`is_djkr_lock`]). Anything else at
/// that name is a clash, refused naming it, and never written: a symbolic link, a FIFO, a
/// device (refused before it is opened), a file of the user's, an empty file, a file with more
/// than one hard link (writing it would write the user's other name).
#[derive(Debug)]
pub struct DirLock {
    file: File,
    path: PathBuf,
}

/// How long a new lock file may stay empty while its creator locks it and writes its header
/// (microseconds in practice), before an empty file at the name counts as someone else's.
const LOCK_SETTLE: std::time::Duration = std::time::Duration::from_millis(250);

/// Whether `text` is what djkr writes into its lock file: its header, the holder's process id,
/// then only lines recording partial files.
fn is_djkr_lock(text: &str) -> bool {
    let mut lines = text.lines();
    let pid = lines
        .next()
        .filter(|h| *h == LOCK_HEADER)
        .and_then(|_| lines.next())
        .and_then(|l| l.strip_prefix("pid "))
        .is_some_and(|p| p.trim().parse::<u32>().is_ok());
    pid && text.ends_with('\n')
        && lines.all(|l| {
            let mut it = l.split(' ');
            matches!(
                (it.next(), it.next(), it.next(), it.next()),
                (Some("partial"), Some(name), Some(ino), None)
                    if !name.is_empty() && ino.parse::<u64>().is_ok()
            )
        })
}

/// Open the lock file djkr creates: new (`O_EXCL`), never through a link.
fn create_lock_file(path: &Path) -> std::io::Result<File> {
    let mut o = fs::OpenOptions::new();
    o.read(true).write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    o.open(path)
}

/// Remove the lock file this process created at `path` and could not make a lock (`file` is
/// it: only while the name still holds that file).
fn remove_created(file: &File, path: &Path) {
    if let (Ok(a), Ok(b)) = (file.metadata(), fs::symlink_metadata(path)) {
        let (a, b) = (Stamp::of(&a, true), Stamp::of(&b, true));
        if (a.dev, a.ino) == (b.dev, b.ino) {
            let _ = fs::remove_file(path);
        }
    }
}

/// How many names the file has (1 where the platform cannot tell).
fn links(m: &Metadata) -> u64 {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        m.nlink()
    }
    #[cfg(not(unix))]
    {
        let _ = m;
        1
    }
}

/// What happened at one attempt to take the lock.
enum Attempt {
    /// Taken (`None`: the file system cannot lock).
    Taken(Option<DirLock>),
    /// Try again: the file at the name changed under us, or a new lock file is still empty.
    Again,
}

impl DirLock {
    /// Take the lock of `dir` (a folder: [`prepare`] first). `Ok(None)` when the file system
    /// cannot lock (the writer goes on unprotected, as before locks existed);
    /// [`OutputError::Busy`] naming the holder's process id when another process holds it;
    /// [`OutputError::NotRegular`] naming what is at the name when it is not a djkr lock (see
    /// the type's documentation).
    pub fn acquire(dir: &Path) -> Result<Option<DirLock>, OutputError> {
        let path = dir.join(LOCK_NAME);
        let t0 = std::time::Instant::now();
        loop {
            let settled = t0.elapsed() >= LOCK_SETTLE;
            match Self::attempt(dir, &path, settled)? {
                Attempt::Taken(lock) => return Ok(lock),
                Attempt::Again => std::thread::sleep(std::time::Duration::from_millis(10)),
            }
        }
    }

    fn attempt(dir: &Path, path: &Path, settled: bool) -> Result<Attempt, OutputError> {
        let clash = |what: String| OutputError::NotRegular {
            path: path.to_path_buf(),
            what: format!("{what}, not djkr's lock file (djkr reserves this name)"),
        };
        match create_lock_file(path) {
            Ok(file) => return Self::take_new(file, path),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => {
                return Err(match fs::symlink_metadata(path) {
                    Ok(m) if !m.is_file() => clash(kind_of(&m).into()),
                    _ => io_err(path)(e),
                })
            }
        }
        // A file is there: refuse what is not a regular file before opening it.
        let seen = match fs::symlink_metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Attempt::Again),
            Err(e) => return Err(io_err(path)(e)),
        };
        if !seen.is_file() {
            return Err(clash(kind_of(&seen).into()));
        }
        let file = match open_existing_rw(path) {
            Ok(Some(f)) => f,
            Ok(None) => return Ok(Attempt::Again),
            Err(OutputError::NotRegular { what, .. }) => return Err(clash(what)),
            Err(e) => return Err(e),
        };
        let m = file.metadata().map_err(io_err(path))?;
        let (now, then) = (Stamp::of(&m, true), Stamp::of(&seen, true));
        if (now.dev, now.ino) != (then.dev, then.ino) {
            // Replaced between the look and the open.
            return Ok(Attempt::Again);
        }
        match file.try_lock() {
            Ok(()) => {}
            Err(fs::TryLockError::WouldBlock) => {
                let text = input::read_from(&file, InputKind::Lock).unwrap_or_default();
                let text = String::from_utf8_lossy(&text);
                let holder = text
                    .lines()
                    .find_map(|l| l.strip_prefix("pid "))
                    .and_then(|p| p.trim().parse().ok());
                return Err(OutputError::Busy {
                    dir: dir.to_path_buf(),
                    holder,
                });
            }
            Err(fs::TryLockError::Error(_)) => return Ok(Attempt::Taken(None)),
        }
        // Locked: what the file is now cannot change under a djkr.
        let m = file.metadata().map_err(io_err(path))?;
        if links(&m) > 1 {
            return Err(clash(format!("a file with {} hard links", links(&m))));
        }
        let text =
            input::read_from(&file, InputKind::Lock).and_then(|b| input::text(b, InputKind::Lock));
        let text = match text {
            Ok(t) if t.is_empty() && !settled => {
                // Perhaps a lock file another djkr has just created and not yet written: let go
                // and look again (it will be busy, or written).
                drop(file);
                return Ok(Attempt::Again);
            }
            Ok(t) if t.is_empty() => return Err(clash("an empty file".into())),
            Ok(t) if is_djkr_lock(&t) => t,
            Ok(_) => return Err(clash("a file".into())),
            Err(e) => return Err(clash(format!("a file that is {e}"))),
        };
        for line in text.lines() {
            let mut it = line.split(' ');
            if let (Some("partial"), Some(name), Some(ino)) = (it.next(), it.next(), it.next()) {
                remove_recorded_partial(dir, name, ino);
            }
        }
        let lock = DirLock {
            file,
            path: path.to_path_buf(),
        };
        lock.rewrite()?;
        Ok(Attempt::Taken(Some(lock)))
    }

    /// The lock file this process has just created: lock it and write the header. Another djkr
    /// that opened it meanwhile, found it empty and holds it for a moment lets go at once.
    fn take_new(file: File, path: &Path) -> Result<Attempt, OutputError> {
        #[cfg(test)]
        std::thread::sleep(std::time::Duration::from_millis(
            tests::PAUSE_AFTER_CREATE_MS.load(std::sync::atomic::Ordering::Relaxed),
        ));
        let t0 = std::time::Instant::now();
        let locked = loop {
            match file.try_lock() {
                Ok(()) => break true,
                Err(fs::TryLockError::Error(_)) => break false,
                Err(fs::TryLockError::WouldBlock) if t0.elapsed() < 2 * LOCK_SETTLE => {
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
                Err(fs::TryLockError::WouldBlock) => {
                    remove_created(&file, path);
                    return Err(OutputError::Busy {
                        dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
                        holder: None,
                    });
                }
            }
        };
        let lock = DirLock {
            file,
            path: path.to_path_buf(),
        };
        if let Err(e) = lock.rewrite() {
            // Left empty, it would read as a clash to every later writer.
            remove_created(&lock.file, path);
            return Err(e);
        }
        Ok(Attempt::Taken(locked.then_some(lock)))
    }

    /// Start the lock file afresh: the header and this process's id, written in place at a fixed
    /// width, and the file cut after them only when it holds more (partials a holder recorded).
    /// Truncating the file to nothing first cost 1.9 ms a run on ext4 (its allocation on
    /// truncate-to-zero), a tenth of a short run.
    fn rewrite(&self) -> Result<(), OutputError> {
        let head = format!("{LOCK_HEADER}\npid {:>10}\n", std::process::id());
        let mut f = &self.file;
        f.rewind()
            .and_then(|()| f.write_all(head.as_bytes()))
            .and_then(|()| f.metadata())
            .and_then(|m| {
                if m.len() > head.len() as u64 {
                    f.set_len(head.len() as u64)
                } else {
                    Ok(())
                }
            })
            .map_err(io_err(&self.path))
    }

    /// Record the partial file at `path` (in the locked folder: its name is recorded), so that
    /// the next holder removes it if this process is killed before it is renamed into place or
    /// removed. (A partial renamed or removed in time is gone by then: nothing to remove.)
    pub fn note_partial(&self, path: &Path) {
        let (Some(name), Ok(m)) = (path.file_name(), fs::symlink_metadata(path)) else {
            return;
        };
        let name = name.to_string_lossy();
        if name.contains([' ', '\n']) {
            return;
        }
        let ino = Stamp::of(&m, false).ino;
        let mut f = &self.file;
        let _ = f
            .seek(std::io::SeekFrom::End(0))
            .and_then(|_| writeln!(f, "partial {name} {ino}"));
    }
}

/// Remove the partial `dir/name` a killed holder of the lock recorded, if it is still the
/// regular file of that inode with a partial's name.
fn remove_recorded_partial(dir: &Path, name: &str, ino: &str) {
    if !(name.starts_with('.') && name.ends_with(".partial")) || name.contains('/') {
        return;
    }
    let path = dir.join(name);
    if let Ok(m) = fs::symlink_metadata(&path) {
        if m.file_type().is_file() && ino.parse() == Ok(Stamp::of(&m, false).ino) {
            let _ = fs::remove_file(&path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_changed_in_place_or_replaced_is_no_longer_djkrs() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        commit(AtomicFile::write(&d.join("a.txt"), b"one").unwrap()).unwrap();
        assert!(is_owned(d, "a.txt"));
        check_names(d, &["a.txt", "b.txt"], false).unwrap();
        // Replaced by a file of the user's (a new inode).
        fs::remove_file(d.join("a.txt")).unwrap();
        fs::write(d.join("a.txt"), b"mine").unwrap();
        assert!(!is_owned(d, "a.txt"));
        let err = check_names(d, &["a.txt"], false).unwrap_err();
        assert!(matches!(err, OutputError::Clash { .. }), "{err}");
        assert!(!remove_owned(d, "a.txt").unwrap());
        assert_eq!(fs::read(d.join("a.txt")).unwrap(), b"mine");
    }

    #[test]
    fn a_lock_file_is_djkrs_by_its_content_only() {
        assert!(is_djkr_lock("djkr lock\npid         42\n"));
        assert!(is_djkr_lock(
            "djkr lock\npid 99\npartial .run.h5.1-2.abc.partial 123\n"
        ));
        for not in [
            "",
            "djkr lock\n",
            "djkr lock\npid x\n",
            "djkr lock\npid 42",
            "djkr locked\npid 42\n",
            "djkr lock\npid 42\nmy notes\n",
            "djkr lock\npid 42\npartial a 1 2\n",
        ] {
            assert!(!is_djkr_lock(not), "{not:?}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn the_lock_is_written_only_into_a_file_djkr_created() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("D");
        fs::create_dir(&d).unwrap();
        let lock = d.join(LOCK_NAME);
        let clash = |what: &str| {
            let e = DirLock::acquire(&d).unwrap_err();
            let msg = e.to_string();
            assert!(matches!(e, OutputError::NotRegular { .. }), "{msg}");
            assert!(
                msg.contains(what) && msg.contains("not djkr's lock file"),
                "{msg}"
            );
        };
        // An empty file of the user's, linked in (issue 35: djkr wrote its lock lines into it).
        let v = dir.path().join("v");
        fs::write(&v, b"").unwrap();
        fs::hard_link(&v, &lock).unwrap();
        clash("a file with 2 hard links");
        assert_eq!(fs::read(&v).unwrap(), b"");
        // Even when it holds a djkr lock's lines.
        fs::write(&v, b"djkr lock\npid 7\n").unwrap();
        clash("a file with 2 hard links");
        assert_eq!(fs::read(&v).unwrap(), b"djkr lock\npid 7\n");
        fs::remove_file(&lock).unwrap();
        // An empty file of one link, a file of the user's, a link, a FIFO: clashes, untouched.
        fs::write(&lock, b"").unwrap();
        clash("an empty file");
        fs::write(&lock, b"notes\n").unwrap();
        clash("is a file,");
        assert_eq!(fs::read(&lock).unwrap(), b"notes\n");
        fs::remove_file(&lock).unwrap();
        std::os::unix::fs::symlink(&v, &lock).unwrap();
        clash("a symbolic link");
        fs::remove_file(&lock).unwrap();
        let c = std::ffi::CString::new(lock.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        clash("a FIFO");
        fs::remove_file(&lock).unwrap();
        assert_eq!(fs::read(&v).unwrap(), b"djkr lock\npid 7\n");
        // None there: created, then reused once released (a finished or killed holder's).
        let held = DirLock::acquire(&d).unwrap().expect("a lock");
        assert!(matches!(
            DirLock::acquire(&d).unwrap_err(),
            OutputError::Busy { holder: Some(p), .. } if p == std::process::id()
        ));
        drop(held);
        fs::write(&lock, b"djkr lock\npid 99\n").unwrap();
        let again = DirLock::acquire(&d).unwrap().expect("a lock");
        let text = fs::read_to_string(&lock).unwrap();
        assert!(
            text.ends_with(&format!(" {}\n", std::process::id())),
            "{text}"
        );
        drop(again);
    }

    /// A pause between creating a lock file and locking it (tests only): widens the window in
    /// which another writer finds the new file empty.
    pub(super) static PAUSE_AFTER_CREATE_MS: std::sync::atomic::AtomicU64 =
        std::sync::atomic::AtomicU64::new(0);

    /// Writers starting together on a fresh folder: one takes the lock, every other is told the
    /// folder is busy (none mistakes the new, still empty lock file for a clash), also when the
    /// creator is slow to lock it.
    #[test]
    fn writers_racing_for_a_new_lock_file_are_busy_not_clashing() {
        PAUSE_AFTER_CREATE_MS.store(30, std::sync::atomic::Ordering::Relaxed);
        for _ in 0..5 {
            let dir = tempfile::tempdir().unwrap();
            let d = dir.path().to_path_buf();
            let start = std::sync::Arc::new(std::sync::Barrier::new(6));
            let done = std::sync::Arc::new(std::sync::Barrier::new(6));
            let threads: Vec<_> = (0..6)
                .map(|_| {
                    let (d, start, done) = (d.clone(), start.clone(), done.clone());
                    std::thread::spawn(move || {
                        start.wait();
                        let r = DirLock::acquire(&d);
                        let taken = match &r {
                            Ok(Some(_)) => true,
                            Err(OutputError::Busy { .. }) => false,
                            other => panic!("{other:?}"),
                        };
                        // Hold the lock until every writer has tried.
                        done.wait();
                        taken
                    })
                })
                .collect();
            let taken = threads
                .into_iter()
                .map(|t| t.join().unwrap())
                .filter(|t| *t)
                .count();
            assert_eq!(taken, 1);
        }
        PAUSE_AFTER_CREATE_MS.store(0, std::sync::atomic::Ordering::Relaxed);
    }

    #[test]
    fn prepare_names_what_is_in_the_way() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        fs::write(&f, b"x").unwrap();
        let msg = prepare(&f).unwrap_err().to_string();
        assert!(msg.contains("is a file") && msg.contains("/f"), "{msg}");
        #[cfg(unix)]
        {
            let l = dir.path().join("l");
            std::os::unix::fs::symlink(dir.path().join("nowhere"), &l).unwrap();
            let msg = prepare(&l).unwrap_err().to_string();
            assert!(msg.contains("dangling symbolic link"), "{msg}");
            assert!(msg.contains("nowhere"), "{msg}");
        }
        prepare(&dir.path().join("new/sub")).unwrap();
        assert!(dir.path().join("new/sub").is_dir());
    }
}
