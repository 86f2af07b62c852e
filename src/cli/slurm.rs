//! `djkr sweep ... --slurm`: a ready Slurm batch script for a sweep.
//!
//! `OUT/sweep.sbatch` is an array job with one task per shard (`--array=1-N`). Task K runs
//! `djkr sweep FILE ... --shard K/N --resume --out OUT/shards/K` on its `--cpus-per-task`
//! threads: a chunk of runs, not one, because Slurm starts about one array task per second per
//! slot. The first task to start submits the merge step once (a marker file guards against a
//! requeue): `djkr sweep merge OUT/shards/* --out OUT` with `--dependency=afterok` on the whole
//! array, so it runs when every task has succeeded and writes the files of the unsharded sweep
//! into OUT. When a task fails, that dependency can never be met: the merge step is submitted
//! with `--kill-on-invalid-dep=yes`, so Slurm cancels it instead of leaving it pending for ever
//! (the default on clusters without `DependencyParameters=kill_invalid_depend`). The failed task
//! can be resubmitted alone (`sbatch --array=K OUT/sweep.sbatch`; it resumes), and then the merge
//! run by hand.
//!
//! Every path in the script is absolute (the djkr binary, the scenario, OUT), so it can be
//! submitted from any directory, and quoted once for the one reader of each line (bash, or
//! sbatch for an `#SBATCH` line). No path is evaluated twice: the merge step's `--wrap` command,
//! which sbatch runs through `sh`, is fixed text that finds the paths in its environment.

use crate::sweep::files::shell_quote;

/// What the script needs.
#[derive(Debug, Clone)]
pub struct SlurmScript {
    /// The djkr binary (absolute).
    pub djkr: String,
    /// The scenario file (absolute).
    pub scenario: String,
    /// `KEY=SPEC`, in order.
    pub set: Vec<String>,
    /// `--zip`.
    pub zip: bool,
    /// `--ensemble N --seed S`.
    pub ensemble: Option<(usize, u64)>,
    /// `--keep-runs`.
    pub keep_runs: bool,
    /// The sweep folder (absolute).
    pub out: String,
    /// Array tasks (shards).
    pub shards: usize,
    /// Threads (cpus) per task.
    pub cpus_per_task: usize,
    /// `#SBATCH --time` (e.g. `1:00:00`), if given.
    pub time: Option<String>,
    /// `#SBATCH --partition`, if given.
    pub partition: Option<String>,
    /// Total runs (for the comments).
    pub runs: usize,
}

/// A shard count that gives each array task a chunk of runs: `runs / 64` rounded up, at most
/// 1000 (Slurm's default MaxArraySize is 1001).
pub fn default_shards(runs: usize) -> usize {
    runs.div_ceil(64).clamp(1, 1000)
}

/// Check `--slurm-partition`: one partition name or a comma-separated list of them (sbatch
/// accepts a list and takes the first that can start the job), each of letters, digits, `_`,
/// `-` and `.`. Anything else (whitespace, a newline, quotes, shell metacharacters) is refused:
/// the value is written into an `#SBATCH` line, where a newline would start a command.
pub fn check_partition(text: &str) -> Result<(), String> {
    let name_ok = |n: &str| {
        !n.is_empty()
            && n.len() <= 64
            && n.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    };
    if !text.is_empty() && text.len() <= 1024 && text.split(',').all(name_ok) {
        Ok(())
    } else {
        Err(
            "must be a Slurm partition name, or a comma-separated list of them: letters, \
             digits, '_', '-' and '.', at most 64 characters each"
                .into(),
        )
    }
}

/// Check `--slurm-time` against the formats `sbatch --time` accepts: `MINUTES`, `MM:SS`,
/// `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS` (each field a whole number of at most 8 digits),
/// or `UNLIMITED` / `INFINITE` (any case). Anything else is refused, for the reason of
/// [`check_partition`].
pub fn check_time(text: &str) -> Result<(), String> {
    let field = |f: &str| !f.is_empty() && f.len() <= 8 && f.bytes().all(|b| b.is_ascii_digit());
    let clock = |t: &str, max_fields: usize| {
        let parts: Vec<&str> = t.split(':').collect();
        parts.len() <= max_fields && parts.iter().all(|p| field(p))
    };
    let ok = match text.split_once('-') {
        Some((days, rest)) => field(days) && clock(rest, 3),
        None => {
            clock(text, 3)
                || text.eq_ignore_ascii_case("unlimited")
                || text.eq_ignore_ascii_case("infinite")
        }
    };
    if ok {
        Ok(())
    } else {
        Err(
            "must be a Slurm time limit: MINUTES, MM:SS, HH:MM:SS, D-HH, D-HH:MM or \
             D-HH:MM:SS (whole numbers), or UNLIMITED"
                .into(),
        )
    }
}

/// Check a path or `KEY=SPEC` that goes into the script: no control characters (a newline
/// would end the comment or `#SBATCH` line that quotes it and start a command).
pub fn check_script_text(text: &str) -> Result<(), String> {
    if text.chars().any(char::is_control) {
        Err(
            "holds a control character (a newline, a tab, ...): it cannot go into a Slurm \
             script"
                .into(),
        )
    } else {
        Ok(())
    }
}

/// Check the sweep folder of a Slurm job: besides [`check_script_text`], no backslash. Slurm
/// builds the log files' names (`#SBATCH --output=OUT/slurm/%x-%A_%a.out`) from patterns in
/// which a backslash turns the patterns off, so the logs would not land where the script says.
pub fn check_sweep_folder(text: &str) -> Result<(), String> {
    check_script_text(text)?;
    if text.contains('\\') {
        Err(
            "holds a backslash, which Slurm's log file names (#SBATCH --output) cannot hold: \
             choose another --out"
                .into(),
        )
    } else {
        Ok(())
    }
}

/// `text` as one value of an `#SBATCH` line: sbatch splits those lines itself (not a shell), at
/// blanks outside double quotes, and reads a backslash as an escape and an unescaped `#` as the
/// start of a comment (in the versions that know no single quotes too): double quotes, with `\`,
/// `"` and `#` escaped.
fn directive_quote(text: &str) -> String {
    let mut s = String::from('"');
    for c in text.chars() {
        if matches!(c, '\\' | '"' | '#') {
            s.push('\\');
        }
        s.push(c);
    }
    s.push('"');
    s
}

impl SlurmScript {
    /// The sweep command of task `$K` (without the shard, threads and folder).
    fn sweep_command(&self) -> String {
        let mut s = format!("\"$DJKR\" sweep {}", shell_quote(&self.scenario));
        for set in &self.set {
            s.push_str(&format!(" \\\n    --set {}", shell_quote(set)));
        }
        if self.zip {
            s.push_str(" --zip");
        }
        if let Some((n, seed)) = self.ensemble {
            s.push_str(&format!(" --ensemble {n} --seed {seed}"));
        }
        if self.keep_runs {
            s.push_str(" --keep-runs");
        }
        s
    }

    /// The script's text.
    ///
    /// Every path and value in it is quoted once, for the one shell (or `#SBATCH` parser) that
    /// reads it. The merge step's `--wrap` command is fixed text: the paths reach it through the
    /// environment (`DJKR_MERGE_BIN`, `DJKR_MERGE_OUT`, passed on by `--export=ALL`), because
    /// sbatch runs `--wrap` through `sh` a second time, where a path pasted into it would be
    /// evaluated again (`$(...)`, backquotes, a `"`).
    pub fn text(&self) -> String {
        let q = |s: &str| shell_quote(s);
        let mut opts = String::new();
        if let Some(t) = &self.time {
            opts.push_str(&format!("#SBATCH --time={t}\n"));
        }
        if let Some(p) = &self.partition {
            opts.push_str(&format!("#SBATCH --partition={p}\n"));
        }
        let mut merge_opts = String::new();
        if let Some(t) = &self.time {
            merge_opts.push_str(&format!(" --time={}", q(t)));
        }
        if let Some(p) = &self.partition {
            merge_opts.push_str(&format!(" --partition={}", q(p)));
        }
        let per_task = self.runs.div_ceil(self.shards.max(1));
        let out = q(&self.out);
        let djkr = q(&self.djkr);
        // The log files' folder, in the `#SBATCH --output` line (read by sbatch) and in the merge
        // step's `--output=` (read by bash, then by sbatch).
        let logs_directive = directive_quote(&format!("{}/slurm", self.out.replace('%', "%%")));
        let logs = q(&format!("{}/slurm", self.out.replace('%', "%%")));
        let merge_hint = format!("  {djkr} sweep merge {out}/shards/* --out {out}");
        format!(
            r#"#!/bin/bash
# A djkr sweep as a Slurm array job: {runs} runs in {n} tasks of about {per_task} runs each.
# Written by `djkr sweep ... --slurm` (djkr {version}).
#
#   submit:   sbatch {out}/sweep.sbatch
#   watch:    squeue --me; tail -f {out}/shards/*/progress.csv
#   result:   {out}/sweep.csv, points.csv, sweep.h5 and the plots, written by the merge step
#             that the first task submits (it waits for every task: afterok).
#   a task failed: the merge step is cancelled (it could never run); resubmit the task alone,
#             it resumes (sbatch --array=K {out}/sweep.sbatch), then merge by hand:
#             {djkr} sweep merge {out}/shards/* --out {out}
#
#SBATCH --job-name=djkr-sweep
#SBATCH --array=1-{n}
#SBATCH --cpus-per-task={cpus}
#SBATCH --output={logs_directive}/%x-%A_%a.out
{opts}
set -euo pipefail
DJKR={djkr}
OUT={out}
K=$(( SLURM_ARRAY_TASK_ID - ${{SLURM_ARRAY_TASK_MIN:-1}} + 1 ))

# The merge step, submitted once (the marker survives a requeue). Its command is fixed text that
# reads the paths from its environment: sbatch runs --wrap through sh once more, so no path is
# ever pasted into it.
if ( set -o noclobber; echo "$SLURM_ARRAY_JOB_ID" > "$OUT/slurm/merge.submitted" ) 2>/dev/null; then
  if ! DJKR_MERGE_BIN="$DJKR" DJKR_MERGE_OUT="$OUT" sbatch --parsable --export=ALL \
      --job-name=djkr-sweep-merge --dependency="afterok:$SLURM_ARRAY_JOB_ID" \
      --kill-on-invalid-dep=yes --cpus-per-task=1 --output={logs}/%x-%j.out{merge_opts} \
      --wrap='exec "$DJKR_MERGE_BIN" sweep merge "$DJKR_MERGE_OUT"/shards/* --out "$DJKR_MERGE_OUT"' \
      > "$OUT/slurm/merge.jobid"; then
    echo "warning: could not submit the merge step; when every task is done, run:" >&2
    echo {merge_hint} >&2
  fi
fi

exec {cmd} \
    --shard "$K/{n}" --jobs "${{SLURM_CPUS_PER_TASK:-1}}" --resume --out "$OUT/shards/$K"
"#,
            runs = self.runs,
            n = self.shards,
            per_task = per_task,
            version = env!("CARGO_PKG_VERSION"),
            out = out,
            cpus = self.cpus_per_task.max(1),
            opts = opts,
            djkr = djkr,
            logs = logs,
            logs_directive = logs_directive,
            merge_opts = merge_opts,
            merge_hint = q(&merge_hint),
            cmd = self.sweep_command(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_runs_shards_and_submits_the_merge() {
        let s = SlurmScript {
            djkr: "/opt/djkr".into(),
            scenario: "/data/x.toml".into(),
            set: vec!["base.amplitude=10um,20um".into(), "stage[3].speed=1".into()],
            zip: false,
            ensemble: Some((8, 3)),
            keep_runs: false,
            out: "/scratch/sweep one".into(),
            shards: 4,
            cpus_per_task: 2,
            time: Some("1:00:00".into()),
            partition: None,
            runs: 16,
        }
        .text();
        assert!(s.starts_with("#!/bin/bash\n"));
        assert!(s.contains("#SBATCH --array=1-4\n"), "{s}");
        assert!(s.contains("#SBATCH --cpus-per-task=2\n"));
        assert!(s.contains("#SBATCH --time=1:00:00\n"));
        assert!(s.contains("--set 'stage[3].speed=1'"));
        assert!(s.contains("--ensemble 8 --seed 3"));
        assert!(s.contains("--shard \"$K/4\""));
        assert!(s.contains("OUT='/scratch/sweep one'"));
        assert!(s.contains("--dependency=\"afterok:$SLURM_ARRAY_JOB_ID\""));
        assert!(s.contains("--kill-on-invalid-dep=yes"));
        assert!(s.contains("#SBATCH --output=\"/scratch/sweep one/slurm\"/%x-%A_%a.out\n"));
        // The merge step's command, which sbatch runs through sh, holds no path.
        let wrap = s.lines().find(|l| l.contains("--wrap=")).unwrap();
        assert!(!wrap.contains("scratch") && !wrap.contains("opt"), "{wrap}");
        assert!(s.contains("DJKR_MERGE_OUT=\"$OUT\""));
        assert_eq!(default_shards(10), 1);
        assert_eq!(default_shards(640), 10);
        assert_eq!(default_shards(10_000_000), 1000);
    }

    #[test]
    fn partition_and_time_follow_slurm_grammar() {
        for p in ["batch", "gpu-a100", "long_q", "a.b", "short,long"] {
            assert!(check_partition(p).is_ok(), "{p}");
        }
        for p in [
            "",
            "a b",
            "batch\necho pwned",
            "a;b",
            "$(id)",
            "`id`",
            "a'b",
            "a\"b",
            ",",
            "a,",
        ] {
            assert!(check_partition(p).is_err(), "{p:?}");
        }
        for t in [
            "30",
            "30:00",
            "2:00:00",
            "1-12",
            "1-12:30",
            "1-12:30:00",
            "0",
            "UNLIMITED",
            "infinite",
        ] {
            assert!(check_time(t).is_ok(), "{t}");
        }
        for t in [
            "",
            "1:00:00\necho pwned",
            "1h",
            "1:2:3:4",
            "1-",
            "-1",
            "1-2-3",
            "1-1:2:3:4",
            " 30",
            "30 ",
            "1.5",
            "999999999",
        ] {
            assert!(check_time(t).is_err(), "{t:?}");
        }
        assert!(check_script_text("/scratch/sweep one").is_ok());
        assert!(check_script_text("/scratch/x\necho pwned").is_err());
        assert!(check_sweep_folder("/scratch/it's \"$(id)\" `id` 100%").is_ok());
        assert!(check_sweep_folder("/scratch/a\\b").is_err());
        assert!(check_sweep_folder("/scratch/x\necho pwned").is_err());
    }

    #[test]
    fn directive_values_are_quoted_for_sbatch() {
        assert_eq!(directive_quote("/a b/slurm"), "\"/a b/slurm\"");
        assert_eq!(directive_quote(r#"/a"b#c\d"#), r#""/a\"b\#c\\d""#);
    }
}
