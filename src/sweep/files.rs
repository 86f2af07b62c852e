//! A sweep's folder: what is written while it runs, what `--resume` reads, what the end writes,
//! and the merge of Slurm shards.
//!
//! ```text
//! DIR/sweep.json      the sweep's description (scenario text, KEY=SPEC list, zip, ensemble, seed,
//!                     shard, counts), written first; --resume and merge check against it
//! DIR/progress.csv    the rows in the order their runs end, each appended and flushed as it ends
//!                     (`tail -f` works; same columns as sweep.csv); removed once the sweep is
//!                     complete. A killed sweep leaves it for --resume (a torn last line is
//!                     ignored)
//! DIR/sweep.csv       one row per run, sorted by (point, member)        } written atomically
//! DIR/sweep.h5        the same rows at the root, group points/           } at the end (and on
//! DIR/points.csv      one row per point: members' statistics             } Ctrl-C: what is done)
//! DIR/amplification.png/.svg, amplification-map.png/.svg, phase.png/.svg
//! DIR/runs/p0003-m07/ each run's own folder, with --keep-runs
//! ```
//!
//! The rows already done are those of `sweep.csv` and `progress.csv` together; `--resume` skips
//! them and appends the rest to `progress.csv`. A sweep holds the folder's lock
//! (`DIR/.djkr.lock`, [`DirLock`]) from [`open`] to its end, so a second sweep (or run) into the
//! folder is refused at once, naming the holder's process id; and the files above are djkr's
//! by its record in the folder ([`crate::output::folder`]): a file of the user's under one of
//! these names stops the sweep before it starts, unless `--force`.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::input::{self, InputKind};
use crate::output::atomic::{sync_dir, AtomicFile};
use crate::output::folder::write_atomic;
use crate::output::folder::{self, DirLock};
use crate::output::hdf5_file::{hdf5_tables, Attr};
use crate::output::OutputError;
use crate::plot::PlotError;

use super::engine::{RunId, Sweep};
use super::plots::{plot_file_names, sweep_plots};
pub use super::row::KeyInfo;
use super::row::{parse_rows_csv, row_schema, rows_table, KeyColumn, Row};
use super::spec::SpecForm;
use super::stats::{point_stats, points_table, PointStats};

/// `sweep.json`.
pub const MANIFEST_NAME: &str = "sweep.json";
/// `progress.csv`.
pub const PROGRESS_NAME: &str = "progress.csv";
/// `sweep.csv`.
pub const ROWS_CSV_NAME: &str = "sweep.csv";
/// `sweep.h5`.
pub const ROWS_H5_NAME: &str = "sweep.h5";
/// `points.csv`.
pub const POINTS_CSV_NAME: &str = "points.csv";
/// The folder of kept runs.
pub const RUNS_DIR: &str = "runs";
/// Version of the folder's layout (`sweep.json` `format_version`).
pub const FORMAT_VERSION: i64 = 1;

/// Why a sweep folder cannot be used or written.
#[derive(Debug, Error)]
pub enum FilesError {
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// A table or file could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The folder does not hold what this sweep or merge needs.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong, and what to do.
        message: String,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FilesError + '_ {
    move |source| FilesError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn invalid(path: &Path, message: impl Into<String>) -> FilesError {
    FilesError::Invalid {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// One of N fixed, disjoint slices of a sweep's runs: run i belongs to shard (i mod N) + 1, so
/// every shard gets runs from all over the grid (cheap and expensive points alike).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct Shard {
    /// K, from 1.
    pub index: usize,
    /// N.
    pub count: usize,
}

impl Shard {
    /// Parse `K/N` (1 ≤ K ≤ N).
    pub fn parse(text: &str) -> Result<Shard, String> {
        let bad = || {
            format!("«shard» {shown_text}: expected K/N with 1 <= K <= N, e.g. 3/10 (or 'slurm' in a Slurm array job)", shown_text = djkr_core::text::excerpt(text))
        };
        let (k, n) = text.trim().split_once('/').ok_or_else(bad)?;
        let (k, n) = (
            k.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { index: k, count: n })
    }

    /// From a Slurm array job's environment: K = SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN + 1,
    /// N = SLURM_ARRAY_TASK_COUNT (the array must be contiguous).
    pub fn from_slurm(env: impl Fn(&str) -> Option<String>) -> Result<Shard, String> {
        let get = |k: &str| -> Result<usize, String> {
            let v = env(k).ok_or_else(|| {
                format!("«shard» slurm: {k} is not set: not in a Slurm array job (use «shard» K/N)")
            })?;
            v.trim().parse::<usize>().map_err(|_| {
                format!(
                    "«shard» slurm: {k} = {}: not a whole number",
                    djkr_core::text::excerpt(&v)
                )
            })
        };
        let (id, count) = (get("SLURM_ARRAY_TASK_ID")?, get("SLURM_ARRAY_TASK_COUNT")?);
        let min = get("SLURM_ARRAY_TASK_MIN").unwrap_or(1);
        let max = get("SLURM_ARRAY_TASK_MAX").unwrap_or(min + count.saturating_sub(1));
        if max + 1 != min + count || id < min || id > max {
            return Err(format!(
                "«shard» slurm: the array {min}-{max} with {count} tasks is not contiguous: \
                 submit it as --array={min}-{} or use «shard» K/N",
                min + count.saturating_sub(1)
            ));
        }
        Ok(Shard {
            index: id - min + 1,
            count,
        })
    }

    /// Whether run `index` belongs to this shard.
    pub fn contains(&self, index: usize) -> bool {
        index % self.count == self.index - 1
    }
}

/// `sweep.json`: what a sweep is, so that a resume or a merge can check it is the same one.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct Manifest {
    /// Layout version ([`FORMAT_VERSION`]).
    pub format_version: i64,
    /// djkr's version.
    pub djkr_version: String,
    /// The scenario file as given.
    pub scenario: String,
    /// Its text.
    pub scenario_text: String,
    /// `KEY=SPEC`, in the order given.
    pub set: Vec<String>,
    /// `--zip`.
    pub zip: bool,
    /// `--ensemble N`.
    pub ensemble: Option<usize>,
    /// `--seed S` (with an ensemble).
    pub seed: Option<u64>,
    /// The key columns.
    pub keys: Vec<KeyInfo>,
    /// Points.
    pub points: usize,
    /// Members per point.
    pub members: usize,
    /// Runs (points × members).
    pub runs: usize,
    /// This folder's shard (`None`: the whole sweep).
    pub shard: Option<Shard>,
}

impl Manifest {
    /// The manifest of `sweep` (whose `set` arguments, as given, are `set`).
    pub fn of(sweep: &Sweep, shard: Option<Shard>) -> Manifest {
        let e = sweep.ensemble();
        Manifest {
            format_version: FORMAT_VERSION,
            djkr_version: env!("CARGO_PKG_VERSION").to_string(),
            scenario: sweep.source().name().to_string(),
            scenario_text: sweep.source().text().to_string(),
            set: sweep.grid().axes().iter().map(|a| a.shown()).collect(),
            zip: sweep.grid().zip(),
            ensemble: e.map(|e| e.members),
            seed: e.map(|e| e.seed),
            keys: sweep
                .grid()
                .axes()
                .iter()
                .map(|a| KeyInfo {
                    name: a.key.to_string(),
                    unit: a.unit().map(str::to_string),
                    log: a.form == SpecForm::Log,
                })
                .collect(),
            points: sweep.grid().points(),
            members: sweep.members(),
            runs: sweep.runs(),
            shard,
        }
    }

    /// The key columns of the tables.
    pub fn key_columns(&self) -> Vec<KeyColumn> {
        self.keys
            .iter()
            .map(|k| KeyColumn {
                name: k.name.clone(),
                unit: k.unit.clone(),
            })
            .collect()
    }

    /// The first difference from `other` that makes them different sweeps (the scenario is
    /// compared by its text, not its path; the shard is not compared).
    pub fn difference(&self, other: &Manifest) -> Option<String> {
        let checks: [(&str, bool); 8] = [
            ("djkr version", self.djkr_version == other.djkr_version),
            (
                "scenario file text",
                self.scenario_text == other.scenario_text,
            ),
            ("«set» list", self.set == other.set),
            ("«zip»", self.zip == other.zip),
            ("«ensemble»", self.ensemble == other.ensemble),
            ("«seed»", self.seed == other.seed),
            (
                "format version",
                self.format_version == other.format_version,
            ),
            (
                "grid",
                self.points == other.points && self.runs == other.runs && self.keys == other.keys,
            ),
        ];
        checks
            .iter()
            .find(|(_, same)| !same)
            .map(|(what, _)| (*what).to_string())
    }

    /// The command line that makes this sweep (without --out, --jobs, --shard).
    pub fn command(&self) -> String {
        let mut s = format!("djkr sweep {}", shell_quote(&self.scenario));
        for set in &self.set {
            s.push_str(&format!(" --set {}", shell_quote(set)));
        }
        if self.zip {
            s.push_str(" --zip");
        }
        if let Some(n) = self.ensemble {
            s.push_str(&format!(
                " --ensemble {n} --seed {}",
                self.seed.unwrap_or(0)
            ));
        }
        s
    }

    /// The sweep description in `dir` (`None`: there is none), read through the one reader of
    /// input files ([`crate::input`]: a regular file within its limit, or refused naming it).
    pub fn read(dir: &Path) -> Result<Option<Manifest>, FilesError> {
        let path = dir.join(MANIFEST_NAME);
        let text = match input::read_text(&path, InputKind::SweepDescription) {
            Ok(text) => text,
            Err(e) if e.is_missing() => return Ok(None),
            Err(e) => return Err(invalid(&path, e.to_string())),
        };
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| invalid(&path, format!("not a djkr sweep description: {e}")))
    }

    fn write(&self, dir: &Path) -> Result<(), FilesError> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| invalid(dir, format!("sweep.json: {e}")))?;
        write_atomic(&dir.join(MANIFEST_NAME), format!("{text}\n").as_bytes())?;
        Ok(())
    }

    /// The figures a sweep of this description may draw (`plots::plot_file_names`), claimed before a
    /// sweep or `djkr plot` writes into a folder.
    pub fn plot_file_names(&self) -> Vec<String> {
        plot_file_names(self.ensemble.is_some())
    }

    /// Whether run `index` belongs to this folder.
    pub fn owns(&self, index: usize) -> bool {
        index < self.runs && self.shard.is_none_or(|s| s.contains(index))
    }
}

/// `s` as one word of a POSIX shell command line, for a command djkr prints or writes into a
/// script: `shlex::try_quote`, which leaves a plain word (letters, digits, `-_./:@+`) as it is and
/// otherwise puts it in single quotes (or double quotes around a `'`, with nothing in them that
/// `sh` or bash would expand). A NUL byte, which no path or argument can hold, is dropped.
pub fn shell_quote(s: &str) -> String {
    match shlex::try_quote(s) {
        Ok(q) => q.into_owned(),
        Err(_) => shell_quote(&s.replace('\0', "")),
    }
}

/// The rows a folder holds: `sweep.csv` and `progress.csv` together, one per run (the later
/// file wins), only runs of the folder's shard.
pub fn read_rows(dir: &Path, manifest: &Manifest) -> Result<Vec<Row>, FilesError> {
    let keys = manifest.key_columns();
    let mut by_run = std::collections::BTreeMap::new();
    for name in [ROWS_CSV_NAME, PROGRESS_NAME] {
        let path = dir.join(name);
        let text = match input::read_text(&path, InputKind::SweepRows) {
            Ok(text) => text,
            Err(e) if e.is_missing() => continue,
            Err(e) => return Err(invalid(&path, e.to_string())),
        };
        let rows = parse_rows_csv(&text, &keys).map_err(|m| invalid(&path, m))?;
        for r in rows {
            let index = r.point * manifest.members + r.member;
            if r.member >= manifest.members || !manifest.owns(index) {
                return Err(invalid(
                    &path,
                    format!(
                        "row of point {} member {} does not belong to this sweep{}",
                        r.point,
                        r.member,
                        manifest
                            .shard
                            .map(|s| format!(" (shard {}/{})", s.index, s.count))
                            .unwrap_or_default()
                    ),
                ));
            }
            by_run.insert((r.point, r.member), r);
        }
    }
    Ok(by_run.into_values().collect())
}

/// The progress file, open for appending rows.
#[derive(Debug)]
pub struct Progress {
    file: File,
    keys: Vec<KeyColumn>,
    path: PathBuf,
}

impl Progress {
    /// Append one row, flushed.
    pub fn append(&mut self, row: &Row) -> Result<(), FilesError> {
        let csv = rows_table(&self.keys, std::slice::from_ref(row)).to_csv();
        let line = csv.split_once('\n').map_or("", |(_, l)| l);
        self.file
            .write_all(line.as_bytes())
            .and_then(|_| self.file.flush())
            .map_err(io(&self.path))
    }
}

/// A sweep folder opened to run in: its manifest, the rows already done, the progress file,
/// and the folder's lock, held as long as this lives.
#[derive(Debug)]
pub struct Opened {
    /// The folder's lock (`None` where the file system cannot lock).
    pub lock: Option<DirLock>,
    /// The manifest (written or checked).
    pub manifest: Manifest,
    /// Rows already done (`--resume`), sorted.
    pub done: Vec<Row>,
    /// The progress file.
    pub progress: Progress,
}

/// The files a sweep (or a merge) publishes in its folder, claimed before it starts.
fn result_names(manifest: &Manifest) -> Vec<String> {
    let mut names: Vec<String> = [MANIFEST_NAME, ROWS_CSV_NAME, ROWS_H5_NAME, POINTS_CSV_NAME]
        .map(String::from)
        .to_vec();
    names.extend(manifest.plot_file_names());
    names
}

/// Take `dir` for a sweep or merge: a folder (created if missing), its lock held, none of the
/// `names` to publish a file of the user's (unless `force`).
fn claim(dir: &Path, names: &[String], force: bool) -> Result<Option<DirLock>, FilesError> {
    folder::prepare(dir)?;
    let lock = DirLock::acquire(dir)?;
    folder::check_names(dir, names, force)?;
    Ok(lock)
}

/// The sweep description in `dir` that djkr wrote (or, under `--force`, one that reads as
/// one); a file of the user's that `--force` lets djkr replace counts as none.
fn own_manifest(dir: &Path) -> Result<Option<Manifest>, FilesError> {
    match Manifest::read(dir) {
        Err(_) if !folder::is_owned(dir, MANIFEST_NAME) => Ok(None),
        other => other,
    }
}

/// Open `dir` for `manifest`'s sweep, holding its lock. A folder that already holds a sweep is
/// refused unless `resume`, and then it must be the same sweep (same shard too). With `resume`
/// and no sweep in the folder, the sweep starts afresh. Files of the user's under the names
/// the sweep writes are refused unless `force`.
pub fn open(
    dir: &Path,
    manifest: Manifest,
    resume: bool,
    force: bool,
) -> Result<Opened, FilesError> {
    let mut names = result_names(&manifest);
    names.push(PROGRESS_NAME.into());
    let lock = claim(dir, &names, force)?;
    let done = match own_manifest(dir)? {
        Some(old) => {
            if !resume {
                return Err(invalid(
                    dir,
                    "already holds a sweep (sweep.json): add «resume» to continue it, or choose \
                     another «out»",
                ));
            }
            if let Some(what) = old.difference(&manifest) {
                return Err(invalid(
                    dir,
                    format!(
                        "«resume»: the sweep there differs in its {what}: it was made by `{}`",
                        old.command()
                    ),
                ));
            }
            if old.shard != manifest.shard {
                let show = |s: Option<Shard>| {
                    s.map_or("the whole sweep".to_string(), |s| {
                        format!("shard {}/{}", s.index, s.count)
                    })
                };
                return Err(invalid(
                    dir,
                    format!(
                        "«resume»: the folder holds {}, not {}",
                        show(old.shard),
                        show(manifest.shard)
                    ),
                ));
            }
            read_rows(dir, &old)?
        }
        None => {
            manifest.write(dir)?;
            Vec::new()
        }
    };
    let path = dir.join(PROGRESS_NAME);
    let keys = manifest.key_columns();
    let header = crate::output::table::Table::from_schema(&row_schema(&keys))
        .map(|t| t.to_csv())
        .unwrap_or_default();
    // A resumed sweep's progress file is djkr's (claimed above): cut a torn last line (a writer
    // killed mid-line) before appending. Otherwise it starts afresh, published as every file.
    let mut fresh = done.is_empty() || !folder::is_owned(dir, PROGRESS_NAME);
    if !fresh {
        let text = input::read_bytes(&path, InputKind::SweepRows)
            .map_err(|e| invalid(&path, e.to_string()))?;
        let keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        if keep < text.len() {
            open_nofollow(&path, false)?
                .set_len(keep as u64)
                .map_err(io(&path))?;
        }
        fresh = keep == 0;
    }
    if fresh {
        folder::commit(AtomicFile::write(&path, header.as_bytes())?.appending())?;
    }
    let file = open_nofollow(&path, true)?;
    Ok(Opened {
        lock,
        manifest,
        done,
        progress: Progress { file, keys, path },
    })
}

/// Open djkr's own `path` for writing (appending when `append`), never through a symbolic link.
fn open_nofollow(path: &Path, append: bool) -> Result<File, FilesError> {
    let mut o = OpenOptions::new();
    if append {
        o.append(true);
    } else {
        o.write(true);
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW);
    }
    o.open(path).map_err(io(path))
}

/// Write the tables and plots of `rows` into `dir` (atomically, each file) and, when the sweep
/// is `complete`, remove `progress.csv`. `rows` are sorted in place. Returns the files written.
pub fn write_results(
    dir: &Path,
    manifest: &Manifest,
    rows: &mut [Row],
    complete: bool,
) -> Result<Vec<PathBuf>, FilesError> {
    rows.sort_by_key(|r| (r.point, r.member));
    let keys = manifest.key_columns();
    let table = rows_table(&keys, rows);
    let points = point_stats(rows);
    let ptable = points_table(&keys, &points);
    let mut written = Vec::new();

    let csv = dir.join(ROWS_CSV_NAME);
    table.save_csv(&csv)?;
    written.push(csv);

    let h5 = dir.join(ROWS_H5_NAME);
    let attrs = [
        ("source", Attr::text(&manifest.command())),
        ("scenario", Attr::text(&manifest.scenario_text)),
        ("set", Attr::text(&manifest.set.join("\n"))),
        ("zip", Attr::I64(i64::from(manifest.zip))),
        (
            "ensemble",
            Attr::I64(manifest.ensemble.map_or(0, |n| n as i64)),
        ),
        ("seed", Attr::I64(manifest.seed.map_or(0, |s| s as i64))),
        ("points", Attr::I64(manifest.points as i64)),
        ("members", Attr::I64(manifest.members as i64)),
        ("runs", Attr::I64(manifest.runs as i64)),
        (
            "layout",
            Attr::text("one row per run at the root (as sweep.csv); group points: as points.csv"),
        ),
    ];
    let groups = [(
        "points",
        "one row per point: the members' statistics (as points.csv)",
        &ptable,
    )];
    let bytes =
        hdf5_tables(&attrs, Some(&table), &groups).map_err(|message| OutputError::Hdf5 {
            path: h5.clone(),
            message,
        })?;
    write_atomic(&h5, &bytes)?;
    written.push(h5);

    let pcsv = dir.join(POINTS_CSV_NAME);
    ptable.save_csv(&pcsv)?;
    written.push(pcsv);

    written.extend(draw_plots(dir, manifest, &points, rows)?);

    if complete {
        // Only djkr's own progress file (its record in the folder), never one of that name.
        folder::remove_owned(dir, PROGRESS_NAME)?;
    }
    sync_dir(dir);
    Ok(written)
}

/// Draw the figures that fit the sweep described by `manifest` from its `points` and `rows`
/// (`plots::sweep_plots`); returns the files written.
pub fn draw_plots(
    dir: &Path,
    manifest: &Manifest,
    points: &[PointStats],
    rows: &[Row],
) -> Result<Vec<PathBuf>, PlotError> {
    sweep_plots(
        dir,
        &manifest.keys,
        manifest.zip,
        manifest.ensemble.is_some(),
        points,
        rows,
    )
}

/// What a merge found and wrote.
#[derive(Debug, Clone)]
pub struct Merged {
    /// Rows merged.
    pub rows: usize,
    /// Of them, failed runs.
    pub failed: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Merge the shard folders `dirs` of one sweep into `out`: the same files as the unsharded
/// sweep. Every folder must hold a shard of the same sweep, every run exactly once. `out` is
/// locked while it is written; files of the user's under the names it writes are refused
/// unless `force`. `out` may not be one of `dirs` nor lie inside one ([`check_out_apart`]).
pub fn merge(dirs: &[PathBuf], out: &Path, force: bool) -> Result<Merged, FilesError> {
    let Some(first) = dirs.first() else {
        return Err(invalid(out, "merge: no shard folders given"));
    };
    let mut base: Option<Manifest> = None;
    let mut rows: Vec<Row> = Vec::new();
    let mut seen_shards = Vec::new();
    for d in dirs {
        let m = Manifest::read(d)?
            .ok_or_else(|| invalid(d, "no sweep.json: not a djkr sweep folder"))?;
        if let Some(b) = &base {
            if let Some(what) = b.difference(&m) {
                return Err(invalid(
                    d,
                    format!(
                        "a shard of another sweep: its {what} differs from {}'s",
                        first.display()
                    ),
                ));
            }
        }
        if let Some(s) = m.shard {
            if seen_shards.contains(&s) {
                return Err(invalid(
                    d,
                    format!("shard {}/{} is given twice", s.index, s.count),
                ));
            }
            seen_shards.push(s);
        }
        let mut r = read_rows(d, &m)?;
        let expected = (0..m.runs).filter(|&i| m.owns(i)).count();
        if r.len() < expected {
            return Err(invalid(
                d,
                format!(
                    "incomplete: {} of its {expected} runs are done; finish it with \
                     `{} --shard {} --resume --out {}`",
                    r.len(),
                    m.command(),
                    m.shard
                        .map_or("1/1".to_string(), |s| format!("{}/{}", s.index, s.count)),
                    shell_quote(&d.display().to_string())
                ),
            ));
        }
        rows.append(&mut r);
        if base.is_none() {
            base = Some(m);
        }
    }
    // Read-only so far: what the shards hold is reported first (`no sweep.json`), then where
    // the merge would go, before anything is written.
    check_out_apart(dirs, out)?;
    let Some(mut manifest) = base else {
        return Err(invalid(out, "merge: no shard folders given"));
    };
    manifest.shard = None;
    rows.sort_by_key(|r| (r.point, r.member));
    check_every_run_once(out, &manifest, &rows, &seen_shards)?;
    let _lock = claim(out, &result_names(&manifest), force)?;
    if let Some(old) = own_manifest(out)? {
        if let Some(what) = old.difference(&manifest) {
            return Err(invalid(
                out,
                format!("already holds another sweep (its {what} differs): choose another «out»"),
            ));
        }
    }
    manifest.write(out)?;
    let files = write_results(out, &manifest, &mut rows, true)?;
    Ok(Merged {
        failed: rows.iter().filter(|r| r.result.is_err()).count(),
        rows: rows.len(),
        files,
    })
}

/// Refuse a merge whose `out` is one of the shard folders `dirs` or lies inside one: its
/// `sweep.json` and `sweep.csv` would replace the shard's own, and every later merge of those
/// shards would fail. (The shards may lie inside `out`: `--slurm` puts them in `OUT/shards/`.)
/// Paths are compared as the file system resolves them: links, `..` and the part of `out`
/// that does not exist yet included.
fn check_out_apart(dirs: &[PathBuf], out: &Path) -> Result<(), FilesError> {
    let target = resolved(out);
    for d in dirs {
        let shard = resolved(d);
        if target == shard || target.starts_with(&shard) {
            let place = if target == shard {
                "is the shard folder".to_string()
            } else {
                "lies inside the shard folder".to_string()
            };
            return Err(invalid(
                out,
                format!(
                    "«out» {place} {}: the merge would overwrite the shard's own files; choose \
                     a folder outside every shard folder (their parent, for one)",
                    d.display()
                ),
            ));
        }
    }
    Ok(())
}

/// `path` as the file system would resolve it: its longest existing ancestor made canonical
/// (links resolved), then the rest, which does not exist yet, with `.` and `..` applied.
fn resolved(path: &Path) -> PathBuf {
    let mut existing = path;
    let mut rest = Vec::new();
    let base = loop {
        if let Ok(c) = std::fs::canonicalize(if existing.as_os_str().is_empty() {
            Path::new(".")
        } else {
            existing
        }) {
            break c;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            // `..` or `.` at the end of a path that does not exist: resolve it lexically.
            (Some(parent), None) => {
                rest.push(
                    existing
                        .components()
                        .next_back()
                        .map_or_else(Default::default, |c| c.as_os_str().to_os_string()),
                );
                existing = parent;
            }
            _ => break std::env::current_dir().unwrap_or_default(),
        }
    };
    let mut out = base;
    for part in rest.iter().rev() {
        match part.to_str() {
            Some("..") => {
                out.pop();
            }
            Some(".") => {}
            _ => out.push(part),
        }
    }
    out
}

/// The merged `rows` (sorted) hold every run of `manifest` exactly once; `seen` are the shards
/// given (to name those missing).
fn check_every_run_once(
    out: &Path,
    manifest: &Manifest,
    rows: &[Row],
    seen: &[Shard],
) -> Result<(), FilesError> {
    if let Some(w) = rows
        .windows(2)
        .find(|w| (w[0].point, w[0].member) == (w[1].point, w[1].member))
    {
        return Err(invalid(
            out,
            format!(
                "point {} member {} is in two shard folders",
                w[0].point, w[0].member
            ),
        ));
    }
    if rows.len() != manifest.runs {
        let have: std::collections::HashSet<_> = rows.iter().map(|r| (r.point, r.member)).collect();
        let missing: Vec<usize> = (0..manifest.runs)
            .filter(|&i| !have.contains(&(i / manifest.members, i % manifest.members)))
            .collect();
        let count = seen.first().map_or(1, |s| s.count);
        let absent: Vec<String> = (1..=count)
            .filter(|k| !seen.iter().any(|s| s.index == *k))
            .map(|k| format!("{k}/{count}"))
            .collect();
        return Err(invalid(
            out,
            format!(
                "merge: {} of {} runs are missing (first: point {} member {}){}",
                missing.len(),
                manifest.runs,
                missing.first().map_or(0, |i| i / manifest.members),
                missing.first().map_or(0, |i| i % manifest.members),
                if absent.is_empty() {
                    String::new()
                } else {
                    format!("; shards not given: {}", absent.join(", "))
                }
            ),
        ));
    }
    Ok(())
}

/// The runs of `manifest`'s folder not in `done` (indices in (point, member) order).
pub fn remaining(sweep: &Sweep, manifest: &Manifest, done: &[Row]) -> Vec<usize> {
    let have: std::collections::HashSet<usize> = done
        .iter()
        .map(|r| {
            sweep.run_index(RunId {
                point: r.point,
                member: r.member,
            })
        })
        .collect();
    (0..sweep.runs())
        .filter(|&i| manifest.owns(i) && !have.contains(&i))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_resolve_as_the_file_system_would_create_them() {
        let tmp = tempfile::tempdir().unwrap();
        let root = std::fs::canonicalize(tmp.path()).unwrap();
        std::fs::create_dir_all(root.join("s1")).unwrap();
        assert_eq!(resolved(&root.join("s1")), root.join("s1"));
        assert_eq!(resolved(&root.join("new/../s1")), root.join("s1"));
        assert_eq!(resolved(&root.join("s1/./a/b/..")), root.join("s1/a"));
        assert_eq!(resolved(&root.join("x/y")), root.join("x/y"));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(root.join("s1"), root.join("link")).unwrap();
            assert_eq!(resolved(&root.join("link/m")), root.join("s1/m"));
        }
        let dirs = [root.join("s1"), root.join("s2")];
        assert!(check_out_apart(&dirs, &root.join("s1")).is_err());
        assert!(check_out_apart(&dirs, &root.join("s2/merged")).is_err());
        assert!(check_out_apart(&dirs, &root.join("s1x")).is_ok());
        assert!(check_out_apart(&dirs, &root).is_ok());
    }

    #[test]
    fn shards_are_disjoint_and_cover() {
        let shards: Vec<Shard> = (1..=3).map(|k| Shard { index: k, count: 3 }).collect();
        for i in 0..20 {
            assert_eq!(shards.iter().filter(|s| s.contains(i)).count(), 1);
        }
        assert_eq!(Shard::parse("2/3").unwrap(), shards[1]);
        for bad in ["0/3", "4/3", "x", "1/0", "1-3"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |k: &str| {
                vars.iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| (*v).to_string())
            }
        };
        let s = Shard::from_slurm(env(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "10"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "9"),
        ]))
        .unwrap();
        assert_eq!(
            s,
            Shard {
                index: 6,
                count: 10
            }
        );
        assert!(Shard::from_slurm(env(&[])).is_err());
        assert!(Shard::from_slurm(env(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "5"),
        ]))
        .is_err());
    }

    #[test]
    fn quoting() {
        assert_eq!(shell_quote("/data/run-1.toml"), "/data/run-1.toml");
        assert_eq!(
            shell_quote("base.amplitude=10um,30um"),
            "'base.amplitude=10um,30um'"
        );
        assert_eq!(shell_quote("stage[3].speed=1"), "'stage[3].speed=1'");
        assert_eq!(shell_quote("x$(touch PWNED)y"), "'x$(touch PWNED)y'");
        assert_eq!(shell_quote("it's"), "\"it's\"");
        assert_eq!(shell_quote(""), "''");
        assert_eq!(shell_quote("a\0b"), "ab");
    }
}
