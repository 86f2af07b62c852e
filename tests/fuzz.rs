//! Fuzz test of the scenario parser and the simulator driver (issue 15, item 10): mutations of
//! the good corpus (tests/scenarios/good) must parse to a scenario or a clear error, and a valid
//! scenario must run to a result or a clear error under small budgets — no panic, no abort, no
//! hang.
//!
//! A small hand-written mutator edits the TOML text, driven by a seeded RNG (splitmix64): numbers
//! scaled by powers of ten (up to 1e±300) or set to 0, signs flipped, values replaced by other
//! types or by nan/inf, units swapped, keys dropped, duplicated or moved, sections removed. Each
//! case applies 1 to 3 mutations to one corpus file. A valid case runs with `max_steps` ≤ 2e4
//! and `max_wall_s` ≤ 0.2 s, on worker threads under `catch_unwind`; a watchdog fails the test
//! if one case runs longer than [`HANG_S`] (its text is written under the target directory).
//!
//! - `fuzz_corpus_quick` (default suite): [`QUICK_CASES`] cases.
//! - `fuzz_corpus_long` (opt-in): `cargo test --release --test fuzz -- --ignored --nocapture`,
//!   [`LONG_CASES`] cases (`DJKR_FUZZ_CASES` and `DJKR_FUZZ_SEED` override count and seed).
//!
//! Both print the count of cases per outcome.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use djkr::scenario::parse::{ScenarioError, ScenarioSource};
use djkr_core::dynamics::{Event, Observer, Sample, SimError};

/// Cases of the default suite.
const QUICK_CASES: usize = 2000;
/// Cases of the opt-in run.
const LONG_CASES: usize = 100_000;
/// A case running longer than this (s) is a hang: its budgets did not hold.
const HANG_S: f64 = 10.0;

/// splitmix64: small, seeded, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

/// A number's span in a line (after `=`), if the value is a bare number or a quoted one with a
/// unit.
fn number_span(line: &str) -> Option<(usize, usize)> {
    let eq = line.find('=')?;
    let rest = &line[eq + 1..];
    let start = eq + 1 + rest.find(|c: char| c.is_ascii_digit() || c == '-' || c == '.')?;
    let b = line.as_bytes();
    let mut end = start;
    while end < b.len()
        && (b[end].is_ascii_digit()
            || matches!(b[end], b'.' | b'-' | b'+')
            || (matches!(b[end], b'e' | b'E') && end + 1 < b.len()))
    {
        end += 1;
    }
    (end > start).then_some((start, end))
}

const UNITS: &[&str] = &[
    "m", "mm", "um", "nm", "Hz", "kHz", "N", "mN", "g", "kg", "s", "ms", "m/s", "mm/s", "um/s",
    "MPa", "Pa", "J/m^2", "mJ/m^2", "N/m", "Ns/m", "furlong", "",
];
const VALUES: &[&str] = &[
    "0",
    "-1",
    "1e308",
    "-1e308",
    "1e-308",
    "5e-324",
    "nan",
    "inf",
    "-inf",
    "true",
    "\"x\"",
    "\"1e3mm\"",
    "[1, 2]",
    "{ a = 1 }",
    "\"\"",
    "\"pull-off\"",
    "\"seed\"",
    "\"tabulated\"",
    "\"constant\"",
    "\"dopri5\"",
    "\"dop853\"",
    "\"implicit\"",
    "\"dp8\"",
    "9223372036854775807",
    "1.0",
    "\"gent-schultz-saturated\"",
    "\"approach\"",
    "\"unload\"",
    "\"hold\"",
];
const KEYS: &[&str] = &[
    "version = 1",
    "[base]",
    "amplitude = 1e-5",
    "frequency = 300",
    "vibration = true",
    "[damping]",
    "c = 1",
    "on = \"contact\"",
    "[contact]",
    "formation = \"seed\"",
    "seed_radius = 1e-6",
    "[spring]",
    "rigid = true",
    "stiffness = 0",
    "[initial]",
    "gap = 1e-4",
    "preload = 0.05",
    "[[stage]]",
    "kind = \"unload\"",
    "speed = 1e-3",
    "until = \"pull-off\"",
    "duration = 0.01",
    "[solver]",
    "method = \"dopri5\"",
    "[output]",
    "sample_rate = 1e5",
    "max_duration = 0.5",
    "v_sat = 1e-3",
    "law = \"gent-schultz-saturated\"",
    "n = 1.5",
];

/// Apply one random mutation to `text`.
fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return text.to_string();
    }
    let numbered: Vec<usize> = (0..lines.len())
        .filter(|&i| number_span(&lines[i]).is_some())
        .collect();
    match rng.below(14) {
        // Scale a number by a power of ten: mostly small, sometimes extreme.
        0..=5 if !numbered.is_empty() => {
            let i = *rng.pick(&numbered);
            let (a, b) = number_span(&lines[i]).unwrap_or((0, 0));
            let k: i32 = if rng.below(4) == 0 {
                rng.below(601) as i32 - 300
            } else {
                rng.below(13) as i32 - 6
            };
            let v: f64 = lines[i][a..b].parse().unwrap_or(1.0);
            let s = format!("{:e}", v * 10f64.powi(k));
            lines[i].replace_range(a..b, &s);
        }
        // Flip a sign or set to zero.
        6 if !numbered.is_empty() => {
            let i = *rng.pick(&numbered);
            let (a, b) = number_span(&lines[i]).unwrap_or((0, 0));
            let old = lines[i][a..b].to_string();
            let new = match rng.below(3) {
                0 => "0".to_string(),
                1 => "-0.0".to_string(),
                _ => old
                    .strip_prefix('-')
                    .map_or_else(|| format!("-{old}"), str::to_string),
            };
            lines[i].replace_range(a..b, &new);
        }
        // Replace a value by another type or special value.
        7 => {
            let i = rng.below(lines.len());
            if let Some(eq) = lines[i].find('=') {
                let v = *rng.pick(VALUES);
                lines[i] = format!("{}= {v}", &lines[i][..eq]);
            }
        }
        // Swap a unit inside a quoted quantity, or quote a bare number with a unit.
        8 => {
            let i = rng.below(lines.len());
            let u = *rng.pick(UNITS);
            if let Some((a, b)) = number_span(&lines[i]) {
                let num = lines[i][a..b].to_string();
                let line = &lines[i];
                let quoted = line[..a].ends_with('"');
                let close = line[b..].find('"').map(|p| b + p);
                match (quoted, close) {
                    (true, Some(c)) => lines[i].replace_range(b..c, u),
                    _ => lines[i].replace_range(a..b, &format!("\"{num}{u}\"")),
                }
            }
        }
        // Drop a line.
        9 => {
            let i = rng.below(lines.len());
            lines.remove(i);
        }
        // Duplicate a line (a duplicate key, or a second section header).
        10 => {
            let i = rng.below(lines.len());
            let l = lines[i].clone();
            let j = rng.below(lines.len() + 1);
            lines.insert(j, l);
        }
        // Move a line elsewhere.
        11 => {
            let i = rng.below(lines.len());
            let l = lines.remove(i);
            let j = rng.below(lines.len() + 1);
            lines.insert(j, l);
        }
        // Remove a whole section.
        12 => {
            let heads: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].trim_start().starts_with('['))
                .collect();
            if !heads.is_empty() {
                let h = *rng.pick(&heads);
                let end = (h + 1..lines.len())
                    .find(|&i| lines[i].trim_start().starts_with('['))
                    .unwrap_or(lines.len());
                lines.drain(h..end);
            }
        }
        // Insert a key or section from another file.
        _ => {
            let j = rng.below(lines.len() + 1);
            lines.insert(j, rng.pick(KEYS).to_string());
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// An observer that takes every sample (exercising the sampling path) and keeps nothing but a
/// count of events: events that never end (a budget that does not hold) would fill memory, so
/// past [`MAX_EVENTS`] it stops the run by panicking, which the case reports as a failure.
struct Counting {
    events: u64,
}

/// More events than any run within the fuzz budgets (2e4 steps) can have.
const MAX_EVENTS: u64 = 1_000_000;
/// The panic message of a run stopped by [`Counting`].
const RUNAWAY: &str = "more than 1e6 events: the run did not end within its budgets";

impl Observer for Counting {
    fn sample(&mut self, _s: &Sample) -> bool {
        true
    }
    fn event(&mut self, _e: &Event) {
        self.events += 1;
        if self.events > MAX_EVENTS {
            panic!("{RUNAWAY}");
        }
    }
}

fn scenario_error_kind(e: &ScenarioError) -> &'static str {
    match e {
        ScenarioError::Io { .. } => "refused: unreadable law file",
        ScenarioError::Syntax { .. } => "refused: TOML syntax",
        ScenarioError::Value { .. } => "refused: value",
        ScenarioError::Key { .. } => "refused: key",
        ScenarioError::Setup { .. } => "refused: setup",
        ScenarioError::Override { .. } => "refused: override",
    }
}

fn sim_error_kind(e: &SimError) -> &'static str {
    match e {
        SimError::Setup(_) => "run error: setup",
        SimError::StepSizeUnderflow { .. } => "run error: step size underflow",
        SimError::StepBudget { .. } => "run error: step budget",
        SimError::WallBudget { .. } => "run error: wall budget",
        SimError::StageTimeout { .. } => "run error: stage max_duration",
        SimError::NonFinite { .. } => "run error: non-finite state",
        SimError::Explicit { .. } => "run error: explicit method stopped",
        #[allow(unreachable_patterns)]
        _ => "run error: other",
    }
}

/// One case: parse, and run if valid. Returns the outcome's name; `Err` for a panic.
fn one_case(text: &str, name: &str, base: &Path) -> Result<&'static str, String> {
    catch_unwind(AssertUnwindSafe(|| {
        let src = match ScenarioSource::parse(text, name, Some(base)) {
            Ok(s) => s,
            Err(e) => return scenario_error_kind(&e),
        };
        let mut s = match src.scenario(&[]) {
            Ok(s) => s,
            Err(e) => {
                // Every refusal names the file.
                assert!(e.to_string().starts_with(name), "{e}");
                return scenario_error_kind(&e);
            }
        };
        s.solver.max_steps = s.solver.max_steps.min(20_000);
        s.solver.max_wall_s = s.solver.max_wall_s.min(0.2);
        s.output.sample_rate = s.output.sample_rate.min(1e4);
        match s.simulate(&mut Counting { events: 0 }) {
            Ok(r) if r.detached => "ran: detached",
            Ok(_) => "ran: no detachment",
            Err(e) => sim_error_kind(&e),
        }
    }))
    .map_err(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into())
    })
}

struct Corpus {
    files: Vec<(String, String)>,
    base: PathBuf,
}

fn corpus() -> Corpus {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/good");
    let mut files: Vec<(String, String)> = std::fs::read_dir(&base)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    files.sort();
    Corpus { files, base }
}

/// The text of case `i` of the run seeded `seed` (deterministic: a failing case is rebuilt
/// from its index).
fn case_text(c: &Corpus, seed: u64, i: usize) -> (String, String) {
    let mut rng = Rng(seed ^ (i as u64).wrapping_mul(0xA24B_AED4_963E_E407));
    let (name, text) = &c.files[rng.below(c.files.len())];
    let mut t = text.clone();
    for _ in 0..1 + rng.below(3) {
        t = mutate(&mut rng, &t);
    }
    (format!("fuzz-{i}-{name}"), t)
}

/// Run cases `next..cases` on one worker, recording outcomes and panics.
fn worker(w: usize, shared: Arc<Shared>) {
    loop {
        let i = shared.next.fetch_add(1, Ordering::Relaxed);
        if i >= shared.cases {
            shared.current.lock().unwrap()[w] = None;
            return;
        }
        shared.current.lock().unwrap()[w] = Some((i, Instant::now()));
        let (name, text) = case_text(&shared.corpus, shared.seed, i);
        let outcome = one_case(&text, &name, &shared.corpus.base);
        if shared.current.lock().unwrap()[w].is_none_or(|c| c.0 != i) {
            return; // abandoned by the watchdog as hung: its outcome is recorded already
        }
        match outcome {
            Ok(kind) => *shared.counts.lock().unwrap().entry(kind).or_default() += 1,
            Err(msg) => {
                *shared.counts.lock().unwrap().entry("PANIC").or_default() += 1;
                shared
                    .failures
                    .lock()
                    .unwrap()
                    .push((i, format!("panicked: {msg}")));
            }
        }
    }
}

struct Shared {
    corpus: Corpus,
    cases: usize,
    seed: u64,
    next: AtomicUsize,
    counts: Mutex<BTreeMap<&'static str, usize>>,
    failures: Mutex<Vec<(usize, String)>>,
    /// Per worker: the case it runs and when it started (for the watchdog).
    current: Mutex<Vec<Option<(usize, Instant)>>>,
}

/// Largest number of hung cases before the run gives up (each leaves a thread spinning).
const MAX_HANGS: usize = 3;

fn run_fuzz(cases: usize, seed: u64) {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let shared = Arc::new(Shared {
        corpus: corpus(),
        cases,
        seed,
        next: AtomicUsize::new(0),
        counts: Mutex::default(),
        failures: Mutex::default(),
        current: Mutex::new(Vec::new()),
    });
    assert!(shared.corpus.files.len() >= 10);
    let t0 = Instant::now();
    let mut handles = Vec::new();
    let spawn = |w: usize, handles: &mut Vec<std::thread::JoinHandle<()>>| {
        let mut cur = shared.current.lock().unwrap();
        if cur.len() <= w {
            cur.resize(w + 1, None);
        }
        drop(cur);
        let sh = shared.clone();
        handles.push(std::thread::spawn(move || worker(w, sh)));
    };
    for w in 0..threads {
        spawn(w, &mut handles);
    }
    // Watchdog: a case running longer than HANG_S is a hang (its budgets did not hold): record
    // it, abandon its thread (worker w runs on handles[w]) and start another worker in its place.
    let mut abandoned = vec![false; handles.len()];
    let mut hangs = 0;
    loop {
        let done = handles
            .iter()
            .zip(&abandoned)
            .all(|(h, &a)| a || h.is_finished());
        if done {
            break;
        }
        let stuck: Vec<(usize, usize)> = shared
            .current
            .lock()
            .unwrap()
            .iter()
            .enumerate()
            .filter_map(|(w, c)| {
                c.filter(|c| c.1.elapsed().as_secs_f64() > HANG_S)
                    .map(|c| (w, c.0))
            })
            .collect();
        for (w, i) in stuck {
            shared.current.lock().unwrap()[w] = None;
            abandoned[w] = true;
            hangs += 1;
            *shared.counts.lock().unwrap().entry("HANG").or_default() += 1;
            shared.failures.lock().unwrap().push((
                i,
                format!("still running after {HANG_S} s: its budgets did not hold"),
            ));
            if hangs >= MAX_HANGS {
                shared.next.store(cases, Ordering::Relaxed); // stop handing out cases
            } else {
                spawn(handles.len(), &mut handles);
                abandoned.push(false);
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let counts = shared.counts.lock().unwrap().clone();
    let total: usize = counts.values().sum();
    println!(
        "fuzz: {total} cases (seed {seed}) in {:.1} s on {threads} threads",
        t0.elapsed().as_secs_f64()
    );
    for (k, n) in counts.iter() {
        println!("  {k:<36} {n:>8}");
    }
    let failures = shared.failures.lock().unwrap().clone();
    for (i, msg) in &failures {
        let (name, text) = case_text(&shared.corpus, seed, *i);
        let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(&name);
        std::fs::write(&path, &text).ok();
        println!("  case {i}: {msg}; text in {}", path.display());
    }
    assert!(
        failures.is_empty(),
        "{} case(s) failed (seed {seed}), listed above",
        failures.len()
    );
    assert_eq!(total, cases);
    // The mutations must reach the simulator, not only the parser.
    let ran: usize = counts
        .iter()
        .filter(|(k, _)| k.starts_with("ran") || k.starts_with("run error"))
        .map(|(_, n)| n)
        .sum();
    assert!(
        ran * 10 >= total,
        "only {ran} of {total} cases reached the simulator"
    );
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
fn mutator_changes_text_and_is_deterministic() {
    let c = corpus();
    let a = case_text(&c, 7, 3);
    assert_eq!(a, case_text(&c, 7, 3));
    let changed = (0..50).filter(|&i| {
        let (name, t) = case_text(&c, 7, i);
        let orig = &c.files.iter().find(|f| name.ends_with(&f.0)).unwrap().1;
        &t != orig
    });
    assert!(changed.count() >= 40);
}

#[test]
fn fuzz_corpus_quick() {
    run_fuzz(QUICK_CASES, env_or("DJKR_FUZZ_SEED", 0x5EED));
}

#[test]
#[ignore = "opt-in: cargo test --release --test fuzz -- --ignored --nocapture"]
fn fuzz_corpus_long() {
    run_fuzz(
        env_or("DJKR_FUZZ_CASES", LONG_CASES as u64) as usize,
        env_or("DJKR_FUZZ_SEED", 0xD1CE),
    );
}
