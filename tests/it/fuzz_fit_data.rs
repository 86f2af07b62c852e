//! Fuzz test of `djkr fit` and `djkr keys` (issue 35): random data files and `--free` specs
//! through the library's fit path, and through the command line with `djkr keys`' flags too. No
//! case may panic, abort, hang or die by a signal; each ends in a result or one of the
//! documented errors (exit status 0 or 2 on the command line), and no message echoes more than a
//! cut of what the file holds.
//!
//! Data files are drawn by a seeded generator (splitmix64, as tests/it/fuzz.rs): one to three
//! conditions, one or two observables, sometimes sigma, zero to six rows of plausible values,
//! then up to four mutations: an empty file, a header alone, NaN, ±inf, ±1e308, 1e-308,
//! subnormals, words and empty cells, duplicated columns, a byte-order mark, CRLF or CR line
//! ends, blank and comment lines, quoted cells, cells of up to a megabyte, a line of random
//! characters, a cell too many or too few, 100 001 rows. `--free` specs mix real keys, text and
//! unknown keys, bounds of every size (±1e308, NaN, units, empty sides, a megabyte), and
//! `--set`, `--observable` and `--ensemble` are drawn likewise. Fits are kept cheap: the scenario
//! is tests/sweep/tiny.toml (runs of milliseconds), one iteration (two on the command line), one
//! thread; most inputs are refused before anything runs.
//!
//! - `fuzz_fit_library_quick` (default suite): [`QUICK_CASES`] cases through the library.
//! - `fuzz_fit_and_keys_cli_quick` (default suite): [`CLI_CASES`] command lines, `djkr fit` and
//!   `djkr keys`, each a process under a deadline (a signal death or a hang is seen as such).
//! - `fuzz_fit_long` (opt-in): `cargo test --release --test it fuzz_fit_data:: -- --ignored --nocapture`,
//!   [`LONG_CASES`] library cases (`DJKR_FUZZ_CASES` and `DJKR_FUZZ_SEED` override).
//!
//! Each prints the count of cases per outcome.

use crate::tools;

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use djkr::api::{self, FitRequest};
use djkr::fit::{FitData, FreeKey};
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;

/// Library cases of the default suite.
const QUICK_CASES: usize = 10_000;
/// Command lines of the default suite.
const CLI_CASES: usize = 300;
/// Library cases of the opt-in run.
const LONG_CASES: usize = 100_000;
/// A case running longer than this (s) is a hang.
const HANG_S: f64 = 20.0;
/// The longest message a case may give: a file name, a line and column, and a cut of a cell
/// (80 characters) or of a value fit in far less; an echo of a long cell does not.
const MAX_MESSAGE: usize = 1500;

/// splitmix64: small, seeded, good enough to draw inputs.
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
    fn chance(&mut self, p: f64) -> bool {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64) < p
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

/// Condition columns: real keys with units, a text key, a wrong unit, unknown keys.
const CONDITIONS: &[(&str, &[&str])] = &[
    ("base.amplitude [um]", &["5", "10", "20", "30"]),
    ("base.amplitude [m]", &["5e-6", "1e-5", "2e-5"]),
    ("base.frequency [Hz]", &["250", "300", "350"]),
    ("stage[1].speed [mm/s]", &["1", "2", "3"]),
    ("solver.method", &["auto", "dopri5", "implicit"]),
    ("damping.c", &["0.01", "0.05"]),
    ("base.amplitude [Hz]", &["1", "2"]),
    ("base.wobble", &["1"]),
    ("material.K [MPa]", &["9.33", "9"]),
    ("stage[7].speed", &["1e-3"]),
];
/// Observable columns and plausible values.
const OBSERVABLES: &[(&str, &[&str])] = &[
    ("pull_off_amplification [1]", &["2", "3.5", "7", "9.5"]),
    ("pull_off_amplification", &["2", "4"]),
    ("pull_off_force [mN]", &["-1", "-5", "-20"]),
    ("pull_off_force [Hz]", &["1"]),
    ("force_mean [N]", &["0.01", "-0.002"]),
    ("delta_amp [um]", &["1", "3"]),
    ("pull_off_time [s]", &["0.1", "0.5"]),
    ("steps [1]", &["100"]),
];
const SIGMAS: &[&str] = &["sigma [1]", "sigma", "sigma [mN]", "sigma [um]"];
/// What a cell may be replaced by.
const CELLS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-308",
    "5e-324",
    "1e-200",
    "0",
    "-0",
    "",
    " ",
    "abc",
    "0x10",
    "1e400",
    "1,5",
    "\"1\"",
    "\"a,b\"",
    "+1",
    "1e",
    "1_000",
    "10um",
    "∞",
    "1.7976931348623157e308",
    "2.2250738585072014e-308",
    "\u{1b}[2J",
    "#",
    "\"\"",
];
/// `--free` keys and bounds.
const FREE_KEYS: &[&str] = &[
    "adhesion.n",
    "adhesion.v0",
    "damping.c",
    "material.w0",
    "base.phase",
    "stage[1].speed",
    "adhesion.law",
    "base.amplitude",
    "solver.rtol",
    "nope",
    "adhesion.wobble",
    "",
    "stage[9].speed",
    "solver.max_steps",
];
const BOUNDS: &[&str] = &[
    "",
    "0",
    "0.1",
    "2",
    "1e-3",
    "10",
    "-1",
    "-1e308",
    "1e308",
    "nan",
    "inf",
    "5e-324",
    "1e-310",
    "2um/s",
    "1mm/s",
    "1Hz",
    "abc",
    "6.283185307179586",
    "1e-15",
    "1e3",
];
/// `--set` values (besides the budgets every fuzzed fit gets).
const SETS: &[&str] = &[
    "solver.max_memory=1048576",
    "base.amplitude=20um",
    "adhesion.n=0.5",
    "adhesion.n=-1",
    "adhesion.v0=1e-4",
    "stage[1].speed=5mm/s",
    "solver.rtol=1e-4",
    "base.phase=1",
    "nope=1",
    "adhesion.n",
];

/// A random data file's text.
fn data_text(rng: &mut Rng) -> String {
    let nc = 1 + rng.below(3);
    let mut cols: Vec<(String, Vec<String>)> = Vec::new();
    for _ in 0..nc {
        let (h, v) = rng.pick(CONDITIONS);
        cols.push((h.to_string(), v.iter().map(|s| s.to_string()).collect()));
    }
    for _ in 0..1 + usize::from(rng.chance(0.15)) {
        let (h, v) = rng.pick(OBSERVABLES);
        cols.push((h.to_string(), v.iter().map(|s| s.to_string()).collect()));
    }
    if rng.chance(0.4) {
        let s = rng.pick(SIGMAS).to_string();
        cols.push((
            s,
            vec!["0.1".into(), "0.5".into(), "1".into(), "1e-3".into()],
        ));
    }
    let rows = rng.below(7);
    let mut lines: Vec<Vec<String>> = vec![cols.iter().map(|c| c.0.clone()).collect()];
    for _ in 0..rows {
        lines.push(
            cols.iter()
                .map(|c| rng.pick(&c.1).clone())
                .collect::<Vec<_>>(),
        );
    }
    let mut sep = "\n";
    let mut prefix = "";
    for _ in 0..rng.below(5) {
        let nlines = lines.len();
        match rng.below(16) {
            0..=3 if nlines > 1 => {
                // A special or malformed cell.
                let i = 1 + rng.below(nlines - 1);
                let j = rng.below(lines[i].len());
                if let Some(c) = lines[i].get_mut(j) {
                    *c = rng.pick(CELLS).to_string();
                }
            }
            4 => {
                // Duplicate a column.
                let j = rng.below(lines[0].len());
                for l in lines.iter_mut() {
                    if let Some(c) = l.get(j).cloned() {
                        l.push(c);
                    }
                }
            }
            5 => {
                let i = rng.below(nlines);
                let j = rng.below(lines[i].len());
                let n = *rng.pick(&[100usize, 5000, 100_000, 1 << 20]);
                let fill = *rng.pick(&["x", "9", "é", "\u{1b}"]);
                if let Some(c) = lines[i].get_mut(j) {
                    *c = fill.repeat(n);
                }
            }
            6 => prefix = "\u{feff}",
            7 => sep = *rng.pick(&["\r\n", "\r", "\n\n", "\r\n\r\n"]),
            8 => {
                let i = rng.below(nlines + 1);
                let l = rng
                    .pick(&["# a comment", "", "   ", "#", "# x,y"])
                    .to_string();
                lines.insert(i, vec![l]);
            }
            9 => {
                let i = rng.below(nlines);
                lines[i].push(rng.pick(CELLS).to_string());
            }
            10 if nlines > 0 => {
                let i = rng.below(nlines);
                lines[i].pop();
            }
            11 => lines.truncate(1),
            12 => return String::new(),
            13 => {
                // A line of random characters.
                let n = rng.below(60);
                let chars = [
                    'a', ',', '"', ' ', '\t', '#', '[', ']', '1', 'é', '\r', '\u{0}',
                ];
                let l: String = (0..n).map(|_| *rng.pick(&chars)).collect();
                let i = rng.below(nlines + 1);
                lines.insert(i, vec![l]);
            }
            14 => {
                // Cut the text in the middle of a line.
                let text = join(&lines, sep, prefix);
                let mut cut = rng.below(text.len() + 1);
                while !text.is_char_boundary(cut) {
                    cut -= 1;
                }
                return text[..cut].to_string();
            }
            _ => {
                let row = lines.get(1).cloned().unwrap_or_default();
                if rng.chance(0.05) && row.iter().map(String::len).sum::<usize>() < 100 {
                    // More rows than a data file may hold.
                    for _ in 0..100_001 {
                        lines.push(row.clone());
                    }
                } else {
                    let i = rng.below(nlines);
                    let j = rng.below(lines[i].len().max(1));
                    if let Some(c) = lines[i].get_mut(j) {
                        *c = format!("\"{c}\"");
                    }
                }
            }
        }
    }
    join(&lines, sep, prefix)
}

/// The first `n` characters of `s`, for a failure's report.
fn cut(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}

fn join(lines: &[Vec<String>], sep: &str, prefix: &str) -> String {
    let mut t = prefix.to_string();
    for l in lines {
        t.push_str(&l.join(","));
        t.push_str(sep);
    }
    t
}

/// Random `--free` specs (one or two).
fn free_specs(rng: &mut Rng) -> Vec<String> {
    (0..1 + usize::from(rng.chance(0.2)))
        .map(|_| {
            // Some specs are ones a user means (so that fits run: about 1 % of the inputs, each
            // a tenth of a second), the rest drawn from every kind of key and bound.
            if rng.chance(0.15) {
                return rng
                    .pick(&[
                        "adhesion.n",
                        "adhesion.n=0.1:2",
                        "adhesion.v0",
                        "adhesion.v0=1um/s:1mm/s",
                        "damping.c=0:1",
                        "adhesion.n=0.3:",
                    ])
                    .to_string();
            }
            let k = rng.pick(FREE_KEYS);
            match rng.below(5) {
                0 | 1 => k.to_string(),
                2 => format!("{k}={}:{}", rng.pick(BOUNDS), rng.pick(BOUNDS)),
                3 => format!("{k}={}", rng.pick(BOUNDS)),
                _ => match rng.below(3) {
                    // Below the 128 KiB a single argument of a command line may have.
                    0 => format!("{k}={}:1", "9".repeat(100_000)),
                    1 => format!("{k}=0.1:2:3"),
                    _ => format!("{k}=:{}", rng.pick(BOUNDS)),
                },
            }
        })
        .collect()
}

/// A random input: data text, free specs, `--set`s, observable, ensemble.
struct Input {
    data: String,
    free: Vec<String>,
    set: Vec<String>,
    observable: Option<String>,
    ensemble: Option<usize>,
}

fn input(seed: u64, i: usize) -> Input {
    let mut rng = Rng(seed ^ (i as u64).wrapping_mul(0xA24B_AED4_963E_E407));
    let data = data_text(&mut rng);
    let free = free_specs(&mut rng);
    // Budgets, 10 ms of vibration instead of 50 and an unload at 5 mm/s instead of 2 (runs
    // of a few milliseconds).
    let mut set = vec![
        "solver.max_wall_s=0.5".to_string(),
        "solver.max_steps=20000".to_string(),
        "stage[0].duration=0.01".to_string(),
        "stage[1].speed=5mm/s".to_string(),
    ];
    if rng.chance(0.15) {
        set.push(rng.pick(SETS).to_string());
    }
    let observable = rng.chance(0.1).then(|| {
        rng.pick(&[
            "pull_off_force",
            "pull_off_amplification",
            "wall_s",
            "",
            "force_mean ",
        ])
        .to_string()
    });
    let ensemble = rng
        .chance(0.08)
        .then(|| *rng.pick(&[0, 1, 2, 2, 5_000_000, 99_999_999_999, usize::MAX]));
    Input {
        data,
        free,
        set,
        observable,
        ensemble,
    }
}

fn tiny() -> ScenarioSource {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    ScenarioSource::read(&root.join("tests/sweep/tiny.toml")).unwrap()
}

/// The library's fit path (what `djkr fit` and `djkr.fit` call) on one input, at most one
/// iteration on one thread: the outcome's name, or the message that broke an invariant.
fn one_case(source: &ScenarioSource, inp: &Input, name: &str) -> Result<&'static str, String> {
    let gave_special = inp
        .free
        .iter()
        .chain(&inp.set)
        .chain(std::iter::once(&inp.data))
        .any(|a| a.contains("nan") || a.contains("inf"));
    let check = |kind: &'static str, m: String| -> Result<&'static str, String> {
        if m.len() > MAX_MESSAGE {
            return Err(format!(
                "{kind}: a message of {} bytes: {}",
                m.len(),
                cut(&m, 300)
            ));
        }
        // A value nobody gave (item 12 blamed `--set adhesion.n=nan` on bounds of ±1e308).
        let special = m.contains("=nan") || m.contains("=inf");
        if m.contains("panicked") || special && !gave_special {
            return Err(format!("{kind}: {m}"));
        }
        Ok(kind)
    };
    let free = match FreeKey::parse_all(&inp.free) {
        Ok(f) => f,
        Err(m) => return check("refused: --free", m),
    };
    let all = match inp
        .set
        .iter()
        .map(|s| Override::parse(s))
        .collect::<Result<Vec<_>, _>>()
    {
        Ok(a) => a,
        Err(e) => return check("refused: --set", e.to_string()),
    };
    let data = match FitData::parse(&inp.data, name, inp.observable.as_deref()) {
        Ok(d) => d,
        Err(e) => return check("refused: data", e.0),
    };
    if inp.ensemble == Some(0) {
        return Ok("refused: ensemble 0");
    }
    let request = FitRequest {
        set: all,
        ensemble: inp.ensemble.map(|m| (m, 7)),
        jobs: 1,
        max_iterations: 1,
        ..FitRequest::new(source.clone(), data, free)
    };
    match api::fit(&request, None) {
        // The library's fit refuses bad input (the scenario with the starts, the starting values,
        // the model, data whose chi2 cannot be finite) and reports a fit that failed alike.
        Err(e) => check(
            "fit refused or failed",
            djkr::error::render(&e.to_string(), &djkr::error::Plain),
        ),
        Ok(o) => {
            let r = &o.report;
            for (what, x) in [
                ("chi2", r.chi2),
                ("reduced_chi2", r.reduced_chi2),
                ("aic", r.aic),
                ("bic", r.bic),
            ] {
                if !x.is_finite() {
                    return Err(format!("fit reported {what} = {x}: {r:?}"));
                }
            }
            for p in &r.parameters {
                if !p.value.is_finite() || p.sigma.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
                    return Err(format!(
                        "fit reported {} = {} ± {:?}",
                        p.key, p.value, p.sigma
                    ));
                }
            }
            for n in &r.notes {
                if n.contains("Numerical(") || n.contains("LostPatience") {
                    return Err(format!("a note in Rust's words: {n}"));
                }
                check("fit", n.clone())?;
            }
            Ok(if r.converged {
                "fit: converged"
            } else {
                "fit: not converged"
            })
        }
    }
}

struct Shared {
    source: ScenarioSource,
    seed: u64,
    cases: usize,
    next: AtomicUsize,
    counts: Mutex<BTreeMap<&'static str, (usize, f64)>>,
    failures: Mutex<Vec<(usize, String)>>,
    current: Mutex<Vec<Option<(usize, Instant)>>>,
    slowest: Mutex<(f64, usize)>,
}

fn worker(w: usize, sh: Arc<Shared>) {
    loop {
        let i = sh.next.fetch_add(1, Ordering::Relaxed);
        if i >= sh.cases {
            sh.current.lock().unwrap()[w] = None;
            return;
        }
        let t0 = Instant::now();
        sh.current.lock().unwrap()[w] = Some((i, t0));
        let name = format!("fuzz-{i}.csv");
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            one_case(&sh.source, &input(sh.seed, i), &name)
        }))
        .unwrap_or_else(|p| {
            Err(format!(
                "panicked: {}",
                p.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            ))
        });
        let dt = t0.elapsed().as_secs_f64();
        {
            let mut s = sh.slowest.lock().unwrap();
            if dt > s.0 {
                *s = (dt, i);
            }
        }
        let kind = match outcome {
            Ok(kind) => kind,
            Err(m) => {
                sh.failures.lock().unwrap().push((i, m));
                "FAILED"
            }
        };
        let mut counts = sh.counts.lock().unwrap();
        let c = counts.entry(kind).or_default();
        c.0 += 1;
        c.1 += dt;
    }
}

fn run_library(cases: usize, seed: u64) {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let sh = Arc::new(Shared {
        source: tiny(),
        seed,
        cases,
        next: AtomicUsize::new(0),
        counts: Mutex::default(),
        failures: Mutex::default(),
        current: Mutex::new(vec![None; threads]),
        slowest: Mutex::new((0.0, 0)),
    });
    let t0 = Instant::now();
    let handles: Vec<_> = (0..threads)
        .map(|w| {
            let sh = sh.clone();
            std::thread::spawn(move || worker(w, sh))
        })
        .collect();
    while !handles.iter().all(|h| h.is_finished()) {
        for c in sh.current.lock().unwrap().iter().flatten() {
            assert!(
                c.1.elapsed().as_secs_f64() < HANG_S,
                "case {} (seed {seed}) still running after {HANG_S} s: {:?}",
                c.0,
                input(seed, c.0).free
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let counts = sh.counts.lock().unwrap().clone();
    let total: usize = counts.values().map(|c| c.0).sum();
    let slowest = *sh.slowest.lock().unwrap();
    let slow = input(seed, slowest.1);
    println!(
        "fuzz fit (library): {total} cases (seed {seed}) in {:.1} s on {threads} threads; \
         slowest case {} ({:.2} s: {} bytes of data, free {:?}, ensemble {:?})",
        t0.elapsed().as_secs_f64(),
        slowest.1,
        slowest.0,
        slow.data.len(),
        slow.free.iter().map(|a| cut(a, 40)).collect::<Vec<_>>(),
        slow.ensemble
    );
    for (k, (n, t)) in &counts {
        println!("  {k:<28} {n:>7}  ({t:.1} s)");
    }
    let failures = sh.failures.lock().unwrap().clone();
    for (i, m) in failures.iter().take(20) {
        let inp = input(seed, *i);
        let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-fit-{i}.csv"));
        std::fs::write(&path, &inp.data).ok();
        let short = |v: &[String]| v.iter().map(|a| cut(a, 80)).collect::<Vec<_>>();
        println!(
            "  case {i}: {}\n    free {:?} set {:?} observable {:?} ensemble {:?}; data in {}",
            cut(m, 2000),
            short(&inp.free),
            short(&inp.set),
            inp.observable,
            inp.ensemble,
            path.display()
        );
    }
    assert!(failures.is_empty(), "{} case(s) failed", failures.len());
    assert_eq!(total, cases);
    // The inputs must reach the whole path: refusals at each stage, and fits that run.
    let fits: usize = counts
        .iter()
        .filter(|(k, _)| k.starts_with("fit"))
        .map(|(_, c)| c.0)
        .sum();
    assert!(
        fits * 100 >= total,
        "only {fits} of {total} cases reached the fit"
    );
    assert!(counts.get("refused: data").map_or(0, |c| c.0) * 4 >= total);
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
fn generator_is_deterministic_and_varied() {
    let a = input(35, 11);
    let b = input(35, 11);
    assert_eq!((a.data, a.free), (b.data, b.free));
    let distinct: std::collections::BTreeSet<String> =
        (0..200).map(|i| input(35, i).data).collect();
    assert!(distinct.len() > 150, "{}", distinct.len());
}

#[test]
fn fuzz_fit_library_quick() {
    run_library(QUICK_CASES, env_or("DJKR_FUZZ_SEED", 0x35F1));
}

#[test]
#[ignore = "opt-in: cargo test --release --test it fuzz_fit_data:: -- --ignored --nocapture"]
fn fuzz_fit_long() {
    run_library(
        env_or("DJKR_FUZZ_CASES", LONG_CASES as u64) as usize,
        env_or("DJKR_FUZZ_SEED", 0xF17F),
    );
}

/// One command line: `djkr fit` on a random data file (or a special path) with random flags,
/// or `djkr keys` with random flags. The outcome's name, or what broke an invariant.
fn one_command(seed: u64, i: usize, dir: &Path) -> Result<&'static str, String> {
    let mut rng = Rng(seed ^ (i as u64).wrapping_mul(0x9FB2_1C65_1E98_DF25));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut args: Vec<String> = Vec::new();
    let keys = rng.chance(0.2);
    let mut long_cells = false;
    if keys {
        args.push("keys".into());
        for _ in 0..rng.below(3) {
            let a = rng.pick(&[
                "--json",
                "--help",
                "-h",
                "--bogus",
                "x",
                "--json=1",
                "--json=true",
                "-",
                "--",
                "\u{1b}[2J",
                "--set",
                "base.amplitude=1",
            ]);
            args.push(a.to_string());
        }
        if rng.chance(0.1) {
            args.push("y".repeat(100_000));
        }
    } else {
        args.push("fit".into());
        let mut inp = input(seed ^ 0xC11, i);
        if rng.chance(0.1) {
            // A file and a spec a user means, so that some command lines fit.
            let amp: Vec<String> = (0..4)
                .map(|_| rng.pick(&["2", "3.5", "7", "9.5"]).to_string())
                .collect();
            inp.data = format!(
                "base.amplitude [um],pull_off_amplification [1]\n5,{}\n10,{}\n20,{}\n30,{}\n",
                amp[0], amp[1], amp[2], amp[3]
            );
            inp.free = vec!["adhesion.n".into()];
        }
        long_cells = inp.data.lines().any(|l| l.len() > 200);
        let data = match rng.below(20) {
            0 => PathBuf::from("/dev/zero"),
            1 => {
                let f = dir.join(format!("fifo-{i}"));
                Command::new("mkfifo").arg(&f).status().ok();
                f
            }
            2 => dir.to_path_buf(),
            3 => dir.join("does-not-exist.csv"),
            _ => {
                let p = dir.join(format!("data-{i}.csv"));
                std::fs::write(&p, &inp.data).unwrap();
                p
            }
        };
        args.push(data.to_string_lossy().into_owned());
        args.extend(["--scenario".into(), "tests/sweep/tiny.toml".into()]);
        for f in &inp.free {
            args.push("--free".into());
            args.push(f.clone());
        }
        for s in &inp.set {
            args.push("--set".into());
            args.push(s.clone());
        }
        if let Some(o) = &inp.observable {
            args.push("--observable".into());
            args.push(o.clone());
        }
        if let Some(m) = inp.ensemble {
            args.push("--ensemble".into());
            args.push(m.to_string());
        }
        args.extend(
            ["--max-iterations", "2", "--jobs", "1", "--out"]
                .iter()
                .map(|s| s.to_string()),
        );
        args.push(dir.join(format!("out-{i}")).to_string_lossy().into_owned());
        if rng.chance(0.3) {
            args.push("--json".into());
        }
    }
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(&args)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("spawn: {e}"))?;
    let (status, stdout, stderr) = tools::finish_within(child, Duration::from_secs(HANG_S as u64));
    let shown: Vec<String> = args.iter().map(|a| a.chars().take(60).collect()).collect();
    let Some(status) = status else {
        return Err(format!("hung: {shown:?}"));
    };
    let Some(code) = status.code() else {
        return Err(format!(
            "killed by a signal ({status}): {shown:?}: {stderr}"
        ));
    };
    if stderr.contains("panicked") {
        return Err(format!("panicked: {shown:?}: {stderr}"));
    }
    // clap's own errors quote the argument they refuse (a 100 kB `y...` here): item 5 of the
    // issue, not this file's; fit's own messages are held to the bound.
    let clap_error = stderr.contains("Usage:");
    if !clap_error && stderr.lines().any(|l| l.len() > MAX_MESSAGE) {
        return Err(format!(
            "a stderr line of more than {MAX_MESSAGE} bytes: {shown:?}: {}",
            cut(&stderr, 300)
        ));
    }
    if long_cells
        && ["x", "9", "é"]
            .iter()
            .any(|f| stderr.contains(&f.repeat(100)))
    {
        return Err(format!("a long cell echoed: {shown:?}"));
    }
    match (keys, code) {
        (true, 0) => {
            let help = args.iter().any(|a| a == "--help" || a == "-h");
            if args.iter().any(|a| a == "--json") && !help {
                serde_json::from_str::<serde_json::Value>(&stdout)
                    .map_err(|e| format!("keys --json printed no JSON ({e}): {shown:?}"))?;
            }
            Ok("keys: ok")
        }
        (true, 2) => Ok("keys: refused"),
        (false, 0) => {
            let out = dir.join(format!("out-{i}/fit.json"));
            let text = std::fs::read_to_string(&out).map_err(|e| format!("{out:?}: {e}"))?;
            let j: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| format!("{out:?}: {e}"))?;
            if !j["chi2"].as_f64().is_some_and(f64::is_finite) {
                return Err(format!("fit.json chi2 {}: {shown:?}", j["chi2"]));
            }
            Ok("fit: ok")
        }
        (false, 2) => Ok("fit: refused"),
        (_, c) => Err(format!("exit status {c}: {shown:?}: {stderr}")),
    }
}

#[cfg(unix)]
#[test]
fn fuzz_fit_and_keys_cli_quick() {
    let seed = env_or("DJKR_FUZZ_SEED", 0x35C1);
    let dir = tempfile::tempdir().unwrap();
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let next = AtomicUsize::new(0);
    let counts: Mutex<BTreeMap<&'static str, usize>> = Mutex::default();
    let failures: Mutex<Vec<(usize, String)>> = Mutex::default();
    let t0 = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= CLI_CASES {
                    return;
                }
                match one_command(seed, i, dir.path()) {
                    Ok(k) => *counts.lock().unwrap().entry(k).or_default() += 1,
                    Err(m) => failures.lock().unwrap().push((i, m)),
                }
            });
        }
    });
    let counts = counts.into_inner().unwrap();
    println!(
        "fuzz fit/keys (command line): {CLI_CASES} cases (seed {seed}) in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    for (k, n) in &counts {
        println!("  {k:<16} {n:>5}");
    }
    let failures = failures.into_inner().unwrap();
    for (i, m) in failures.iter().take(20) {
        println!("  case {i}: {}", cut(m, 2000));
    }
    assert!(failures.is_empty(), "{} case(s) failed", failures.len());
    for k in ["keys: ok", "keys: refused", "fit: ok", "fit: refused"] {
        assert!(
            counts.get(k).is_some_and(|&n| n > 0),
            "no case {k}: {counts:?}"
        );
    }
}
