//! `djkr validate`, `djkr resonance` and `djkr shortcut-map`: the periodic steady state of a
//! scenario (shooting, with time-stepping as the fallback) compared with the imposed-area method,
//! the linear transfer, the paper's printed equations and harmonic balance; frequency sweeps;
//! a map of where the imposed-area shortcut holds.

use super::common::{load_scenario, positive_quantity, print_json, write_atomic, SetArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use djkr::plot::{self, Figure, Heatmap, LegendPosition, Series, Style};
use djkr::steady::crosscheck::{self, Comparison, Prediction};
use djkr::steady::map::{self as smap, MapCell, ShortcutMap};
use djkr::steady::sweep::{self, Direction, Linearisation, Sweep, SweepPoint};
use djkr::steady::{Options, Problem, Strategy};
use djkr::units::Dimension;
use hdf5_pure::{AttrValue, DatasetBuilder, FileBuilder};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How to find the steady state.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum MethodArg {
    /// Shooting, falling back to time-stepping.
    Auto,
    /// Shooting only (Newton on the one-cycle map).
    Shooting,
    /// Time-stepping with stroboscopic detection only.
    TimeStepping,
}

/// Settings shared by the three commands.
#[derive(Args, Debug, Clone)]
pub struct SteadyArgs {
    /// Steady-state method.
    #[arg(long, value_enum, default_value = "auto")]
    method: MethodArg,
    /// Tolerance on the scaled once-per-cycle residual (x_s by the indentation amplitude, v_s by
    /// ω times it, a by the mean radius).
    #[arg(
        long,
        default_value = "1e-8",
        value_name = "TOL",
        allow_hyphen_values = true
    )]
    tol: String,
    /// Relative tolerance of the time integration (overrides the scenario's).
    #[arg(
        long,
        default_value = "1e-10",
        value_name = "RTOL",
        allow_hyphen_values = true
    )]
    rtol: String,
    /// Cycle budget of time-stepping.
    #[arg(long, default_value = "20000", value_name = "N")]
    max_cycles: u64,
    #[command(flatten)]
    set: SetArgs,
}

impl SteadyArgs {
    fn options(&self) -> Result<Options> {
        let tol = positive_quantity("--tol", &self.tol, Dimension::Dimensionless)?;
        let rtol = positive_quantity("--rtol", &self.rtol, Dimension::Dimensionless)?;
        if tol >= 1.0 {
            bail!("--tol = {}: must be in (0, 1)", self.tol);
        }
        if rtol >= 1e-3 {
            bail!("--rtol = {}: must be in (0, 1e-3)", self.rtol);
        }
        if self.max_cycles == 0 {
            bail!("--max-cycles = 0: must be >= 1");
        }
        Ok(Options {
            tol,
            rtol,
            max_cycles: self.max_cycles,
            strategy: match self.method {
                MethodArg::Auto => Strategy::Auto,
                MethodArg::Shooting => Strategy::Shooting,
                MethodArg::TimeStepping => Strategy::TimeStepping,
            },
            ..Options::default()
        })
    }
}

/// Flags of `djkr validate`.
#[derive(Args, Debug)]
pub struct ValidateArgs {
    /// Scenario file: its first stage with the vibration on, at its base amplitude and frequency,
    /// with the spring end held where that stage starts.
    file: PathBuf,
    /// Print one JSON object (SI values).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

/// Sweep direction(s).
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepArg {
    /// Increasing frequency.
    Up,
    /// Decreasing frequency.
    Down,
    /// Both, in parallel.
    Both,
}

/// Flags of `djkr resonance`.
#[derive(Args, Debug)]
pub struct ResonanceArgs {
    /// Scenario file (mechanics, contact, mean load, base amplitude; see `djkr validate`).
    file: PathBuf,
    /// Frequencies START:STOP:COUNT, evenly spaced, e.g. 300:500:101 or 300Hz:0.5kHz:41.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    freq: String,
    /// Sweep direction.
    #[arg(long, value_enum, default_value = "both")]
    sweep: SweepArg,
    /// Base amplitude X_b [default: the scenario's]. Units: m, mm, um, nm.
    #[arg(long, value_name = "X_B", allow_hyphen_values = true)]
    amp: Option<String>,
    /// Output directory for resonance.csv, resonance.h5 and the plots [default:
    /// out/<scenario name>-resonance].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Skip the harmonic-balance predictor.
    #[arg(long)]
    no_harmonic_balance: bool,
    /// Print a JSON summary (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

/// Flags of `djkr shortcut-map`.
#[derive(Args, Debug)]
pub struct ShortcutMapArgs {
    /// Scenario file (mechanics, contact, mean load; see `djkr validate`).
    file: PathBuf,
    /// Frequencies START:STOP:COUNT, evenly spaced.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    freq: String,
    /// Base amplitudes START:STOP:COUNT, log-spaced, e.g. 0.05um:2um:9.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    amp: String,
    /// Output directory for shortcut-map.csv, .h5 and the maps [default:
    /// out/<scenario name>-shortcut-map].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print a JSON summary (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

/// Parse START:STOP:COUNT with units, 0 < START ≤ STOP, COUNT ≥ 1 (START = STOP when COUNT = 1
/// is not required: COUNT = 1 gives START).
fn range(flag: &str, text: &str, dim: Dimension) -> Result<(f64, f64, usize)> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        bail!("{flag} = {text}: expected START:STOP:COUNT, e.g. 300:500:101");
    }
    let lo = positive_quantity(flag, parts[0].trim(), dim)?;
    let hi = positive_quantity(flag, parts[1].trim(), dim)?;
    let n: usize = parts[2].trim().parse().map_err(|_| {
        anyhow::anyhow!(
            "{flag} = {text}: COUNT = {} must be an integer >= 1",
            parts[2]
        )
    })?;
    if n == 0 || n > 100_000 {
        bail!("{flag} = {text}: COUNT = {n} must be in 1..=100000");
    }
    if hi < lo {
        bail!("{flag} = {text}: STOP must be >= START");
    }
    Ok((lo, hi, n))
}

fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scenario".into())
}

fn default_out(file: &Path, suffix: &str) -> PathBuf {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scenario".into());
    PathBuf::from("out").join(format!("{stem}-{suffix}"))
}

fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} [{{elapsed}}] {what} {{bar:30}} {{pos}}/{{len}} {{msg}}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

// ---------------------------------------------------------------------------------------------
// validate

/// Run `djkr validate`.
pub fn validate(a: &ValidateArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let scn = load_scenario(&a.file, &a.steady.set)?;
    let bar = ProgressBar::new_spinner();
    bar.set_message("finding the periodic steady state");
    bar.enable_steady_tick(Duration::from_millis(200));
    let c = crosscheck::compare(&scn.plan(), &opts);
    bar.finish_and_clear();
    let c = c.with_context(|| format!("{}", a.file.display()))?;
    if a.json {
        print_json(&comparison_json(&c))?;
    } else {
        print_comparison(&a.file, &c);
    }
    if !c.force_balance.holds {
        bail!(
            "internal inconsistency: the force balance <F> = m g - k(<x_s> - x_k) fails by {:.3e} (relative), above {:.0e}",
            c.force_balance.relative_error,
            c.force_balance.tolerance
        );
    }
    Ok(())
}

fn prediction_json(p: &Prediction) -> Value {
    let mut m = Map::new();
    for (k, v) in p.fields() {
        if let Some(v) = v.filter(|v| v.is_finite()) {
            m.insert(k.into(), json!(v));
        }
    }
    Value::Object(m)
}

fn methods(c: &Comparison) -> Vec<(&'static str, &'static str, Option<&Prediction>)> {
    vec![
        ("time_domain", "time domain", Some(&c.time_domain)),
        ("imposed_area", "imposed area", c.imposed_area.as_ref()),
        (
            "harmonic_balance",
            "harmonic balance",
            c.harmonic_balance.as_ref(),
        ),
        (
            "linear_transfer",
            "linear transfer",
            c.linear_transfer.as_ref(),
        ),
        (
            "paper_transfer",
            "paper (37) printed",
            c.paper_transfer.as_ref(),
        ),
        (
            "paper_far_from_resonance",
            "paper (39)",
            c.paper_far_from_resonance.as_ref(),
        ),
    ]
}

fn comparison_json(c: &Comparison) -> Value {
    let mut root = Map::new();
    root.insert("frequency".into(), json!(c.frequency));
    root.insert("amplitude".into(), json!(c.amplitude));
    let mut rel = Map::new();
    for (key, _, p) in methods(c) {
        if let Some(p) = p {
            root.insert(key.into(), prediction_json(p));
            if key != "time_domain" {
                let mut m = Map::new();
                for (k, v) in p.relative_to(&c.time_domain) {
                    if let Some(v) = v.filter(|v| v.is_finite()) {
                        m.insert(k.into(), json!(v));
                    }
                }
                rel.insert(key.into(), Value::Object(m));
            }
        }
    }
    root.insert("relative_difference".into(), Value::Object(rel));
    let s = &c.steady;
    let mut st = json!({
        "method": s.method.name(),
        "cycles": s.cycles,
        "residual": s.residual,
        "newton_iterations": s.newton_iterations,
        "contact_lost": s.contact_lost,
        "wall_s": s.wall_s,
    });
    if s.distance.is_finite() {
        st["distance"] = json!(s.distance);
    }
    root.insert("steady".into(), st);
    let fb = &c.force_balance;
    root.insert(
        "force_balance".into(),
        json!({
            "force_mean": fb.force_mean,
            "predicted": fb.predicted,
            "relative_error": fb.relative_error,
            "tolerance": fb.tolerance,
            "holds": fb.holds,
        }),
    );
    if let Some(f) = c.linear_resonance {
        root.insert("linear_resonance_frequency".into(), json!(f));
    }
    let mut notes = Vec::new();
    if let Some(e) = &c.imposed_area_error {
        notes.push(format!("imposed area: {e}"));
    }
    if let Some(e) = &c.predictor_error {
        notes.push(e.clone());
    }
    if !notes.is_empty() {
        root.insert("notes".into(), json!(notes));
    }
    Value::Object(root)
}

fn cell(v: Option<f64>, scale: f64) -> String {
    match v {
        Some(x) if x.is_finite() && (x * scale).abs() < 1e4 => format!("{:>11.5}", x * scale),
        Some(x) if x.is_finite() => format!("{:>11.3e}", x * scale),
        _ => format!("{:>11}", "—"),
    }
}

fn print_comparison(file: &Path, c: &Comparison) {
    let s = &c.steady;
    println!(
        "{}: periodic steady state at f = {} Hz, X_b = {:.6} µm",
        file.display(),
        c.frequency,
        c.amplitude * 1e6
    );
    println!(
        "  found by {}: {} Newton iterations, {} periods integrated, residual {:.2e}, {:.1} ms{}",
        s.method.name(),
        s.newton_iterations,
        s.cycles,
        s.residual,
        s.wall_s * 1e3,
        if s.contact_lost {
            "; the cycle loses contact"
        } else {
            ""
        }
    );
    if let Some(f) = c.linear_resonance {
        println!("  linear resonance √((k + k_c)/m)/2π = {f:.3} Hz (k_c = 3/2 K a_0)");
    }
    println!();
    let head = format!(
        "{:<20}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}",
        "", "a_m mm", "a_A µm", "δ_m µm", "δ_s µm", "δ_c µm", "δ_A µm", "F_m mN"
    );
    println!("{head}");
    let scales = [1e3, 1e6, 1e6, 1e6, 1e6, 1e6, 1e3];
    for (_, name, p) in methods(c) {
        if let Some(p) = p {
            let mut line = format!("{name:<20}");
            for ((_, v), sc) in p.fields().iter().zip(scales) {
                line.push_str(&cell(*v, sc));
            }
            println!("{line}");
        }
    }
    println!("\nrelative difference from the time domain, % (δ_s, δ_c relative to δ_A):");
    println!(
        "{:<20}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}",
        "", "a_m", "a_A", "δ_m", "δ_s", "δ_c", "δ_A", "F_m"
    );
    for (key, name, p) in methods(c) {
        if key == "time_domain" {
            continue;
        }
        if let Some(p) = p {
            let mut line = format!("{name:<20}");
            for (_, v) in p.relative_to(&c.time_domain) {
                line.push_str(&cell(v, 100.0));
            }
            println!("{line}");
        }
    }
    if let Some(e) = &c.imposed_area_error {
        println!("  imposed area: {e}");
    }
    if let Some(e) = &c.predictor_error {
        println!("  {e}");
    }
    let fb = &c.force_balance;
    println!(
        "\nforce balance  <F> = {:.9} mN,  m g - k(<x_s> - x_k) = {:.9} mN,  relative error {:.2e}  ({})",
        fb.force_mean * 1e3,
        fb.predicted * 1e3,
        fb.relative_error,
        if fb.holds {
            "holds"
        } else {
            "VIOLATED: internal inconsistency"
        }
    );
}

// ---------------------------------------------------------------------------------------------
// tables written as CSV and HDF5

/// A column of a results table.
enum Data {
    Num(Vec<Option<f64>>),
    Text(Vec<String>),
}

struct Column {
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    data: Data,
}

fn num(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    v: Vec<Option<f64>>,
) -> Column {
    Column {
        name,
        unit,
        description,
        data: Data::Num(v),
    }
}

fn csv_bytes(cols: &[Column]) -> Result<Vec<u8>> {
    let rows = cols
        .iter()
        .map(|c| match &c.data {
            Data::Num(v) => v.len(),
            Data::Text(v) => v.len(),
        })
        .max()
        .unwrap_or(0);
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(cols.iter().map(|c| {
        if c.unit.is_empty() {
            c.name.to_string()
        } else {
            format!("{} [{}]", c.name, c.unit)
        }
    }))?;
    for i in 0..rows {
        w.write_record(cols.iter().map(|c| match &c.data {
            Data::Num(v) => match v.get(i).copied().flatten() {
                Some(x) if x.is_finite() => format!("{x:e}"),
                _ => String::new(),
            },
            Data::Text(v) => v.get(i).cloned().unwrap_or_default(),
        }))?;
    }
    w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))
}

fn vstr(s: &str) -> AttrValue {
    AttrValue::VarLenString(s.to_string())
}

/// Elements per chunk; below 65536 (hdf5-pure 0.47 writes larger chunk dimensions in a form
/// libhdf5 rejects).
const CHUNK: usize = 1 << 14;

fn fill(ds: &mut DatasetBuilder, c: &Column) {
    match &c.data {
        Data::Num(v) => {
            let x: Vec<f64> = v.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
            if x.is_empty() {
                ds.with_dtype(hdf5_pure::make_f64_type()).with_shape(&[0]);
            } else {
                ds.with_f64_data(&x);
                ds.with_chunks(&[x.len().min(CHUNK) as u64])
                    .with_shuffle()
                    .with_deflate(1);
            }
        }
        Data::Text(v) => {
            let r: Vec<&str> = v.iter().map(String::as_str).collect();
            ds.with_vlen_strings(&r);
        }
    }
    ds.set_attr("units", vstr(c.unit));
    ds.set_attr("description", vstr(c.description));
}

fn h5_bytes(
    root_attrs: &[(&str, AttrValue)],
    groups: &[(&str, &str, Vec<Column>)],
) -> Result<Vec<u8>> {
    let mut b = FileBuilder::new();
    b.set_attr("djkr_version", vstr(env!("CARGO_PKG_VERSION")));
    b.set_attr(
        "missing",
        vstr("NaN in a numeric dataset marks a value the method did not produce (see `error`)"),
    );
    for (k, v) in root_attrs {
        b.set_attr(k, v.clone());
    }
    for (name, description, cols) in groups {
        let mut g = b.create_group(name);
        g.set_attr("description", vstr(description));
        for c in cols {
            let ds = g.create_dataset(c.name);
            fill(ds, c);
        }
        b.add_group(g.finish());
    }
    b.finish().map_err(|e| anyhow::anyhow!("HDF5: {e}"))
}

// ---------------------------------------------------------------------------------------------
// resonance

fn sweep_columns(sw: &Sweep) -> Vec<Column> {
    let p = &sw.points;
    let st = |f: &dyn Fn(&djkr::steady::Steady) -> f64| -> Vec<Option<f64>> {
        p.iter().map(|x| x.steady.as_ref().map(f)).collect()
    };
    let hb = |f: &dyn Fn(&djkr::describing::HarmonicBalance) -> f64| -> Vec<Option<f64>> {
        p.iter().map(|x| x.harmonic.as_ref().map(f)).collect()
    };
    let xb = sw.amplitude;
    vec![
        Column {
            name: "direction",
            unit: "",
            description: "sweep direction",
            data: Data::Text(p.iter().map(|_| sw.direction.name().to_string()).collect()),
        },
        num(
            "frequency",
            "Hz",
            "base frequency",
            p.iter().map(|x| Some(x.frequency)).collect(),
        ),
        num(
            "delta_amp_over_xb",
            "1",
            "time domain: first-harmonic indentation amplitude |delta_1| / X_b",
            st(&|s| s.transfer_magnitude()),
        ),
        num(
            "phase",
            "rad",
            "time domain: phase phi of delta_1, delta - delta_m ~ |delta_1| sin(wt + phi)",
            st(&|s| s.transfer_phase()),
        ),
        num(
            "delta_mean",
            "m",
            "time domain: cycle-mean indentation",
            st(&|s| s.cycle.delta_mean),
        ),
        num(
            "delta_sin",
            "m",
            "time domain: coefficient of sin wt in delta",
            st(&|s| s.cycle.delta_sin),
        ),
        num(
            "delta_cos",
            "m",
            "time domain: coefficient of cos wt in delta",
            st(&|s| s.cycle.delta_cos),
        ),
        num(
            "force_mean",
            "N",
            "time domain: cycle-mean contact force",
            st(&|s| s.cycle.force_mean),
        ),
        num(
            "force_amp",
            "N",
            "time domain: first-harmonic contact-force amplitude",
            st(&|s| s.cycle.force_sin.hypot(s.cycle.force_cos)),
        ),
        num(
            "a_mean",
            "m",
            "time domain: cycle-mean contact radius",
            st(&|s| s.cycle.a_mean),
        ),
        num(
            "a_amp",
            "m",
            "time domain: first-harmonic contact-radius amplitude",
            st(&|s| s.a_amp()),
        ),
        num(
            "cycles",
            "1",
            "base periods integrated for this frequency",
            st(&|s| s.cycles as f64),
        ),
        num(
            "residual",
            "1",
            "scaled once-per-cycle residual at the steady state",
            st(&|s| s.residual),
        ),
        num(
            "contact_lost",
            "1",
            "1 when the steady cycle loses contact",
            st(&|s| f64::from(u8::from(s.contact_lost))),
        ),
        Column {
            name: "method",
            unit: "",
            description: "how the steady state was found: shooting or time-stepping",
            data: Data::Text(
                p.iter()
                    .map(|x| {
                        x.steady
                            .as_ref()
                            .map(|s| s.method.name().to_string())
                            .unwrap_or_default()
                    })
                    .collect(),
            ),
        },
        num(
            "linear_delta_amp_over_xb",
            "1",
            "corrected linear transfer |delta_1|/X_b, k_c = 3/2 K a_0",
            p.iter().map(|x| x.linear.map(|t| t.magnitude())).collect(),
        ),
        num(
            "linear_phase",
            "rad",
            "corrected linear transfer: phase",
            p.iter().map(|x| x.linear.map(|t| t.phase())).collect(),
        ),
        num(
            "hb_delta_amp_over_xb",
            "1",
            "harmonic balance |delta_1|/X_b",
            hb(&|h| h.delta_amp / xb),
        ),
        num(
            "hb_phase",
            "rad",
            "harmonic balance: phase of delta_1",
            hb(&|h| h.delta_cos.atan2(h.delta_sin)),
        ),
        num(
            "hb_force_mean",
            "N",
            "harmonic balance: mean contact force",
            hb(&|h| h.force_mean),
        ),
        num(
            "hb_a_mean",
            "m",
            "harmonic balance: mean contact radius",
            hb(&|h| h.a_mean),
        ),
        num(
            "hb_a_amp",
            "m",
            "harmonic balance: contact-radius amplitude",
            hb(&|h| h.a_amp),
        ),
        Column {
            name: "error",
            unit: "",
            description: "why the time-domain steady state is missing (empty when found)",
            data: Data::Text(
                p.iter()
                    .map(|x| x.error.clone().unwrap_or_default())
                    .collect(),
            ),
        },
    ]
}

fn concat_columns(mut a: Vec<Column>, b: Vec<Column>) -> Vec<Column> {
    for (ca, cb) in a.iter_mut().zip(b) {
        match (&mut ca.data, cb.data) {
            (Data::Num(x), Data::Num(y)) => x.extend(y),
            (Data::Text(x), Data::Text(y)) => x.extend(y),
            _ => {}
        }
    }
    a
}

fn sorted_by_freq(
    points: &[SweepPoint],
    f: impl Fn(&SweepPoint) -> Option<f64>,
) -> (Vec<f64>, Vec<f64>) {
    let mut v: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| f(p).filter(|y| y.is_finite()).map(|y| (p.frequency, y)))
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v.into_iter().unzip()
}

/// Peak of the linear transfer over [lo, hi] (dense sampling, parabolic refinement).
fn linear_peak(lin: &Linearisation, lo: f64, hi: f64) -> Option<(f64, f64)> {
    let v: Vec<(f64, f64)> = sweep::frequencies(lo, hi, 4001)
        .into_iter()
        .map(|f| (f, lin.linear(f).magnitude()))
        .collect();
    sweep::peak_of(&v)
}

/// Run `djkr resonance`.
pub fn resonance(a: &ResonanceArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let (lo, hi, n) = range("--freq", &a.freq, Dimension::Frequency)?;
    let scn = load_scenario(&a.file, &a.steady.set)?;
    let (mut problem, start) =
        Problem::from_plan(&scn.plan()).with_context(|| format!("{}", a.file.display()))?;
    if let Some(t) = &a.amp {
        let xb = positive_quantity("--amp", t, Dimension::Length)?;
        problem = problem.at(problem.frequency, xb)?;
    }
    let lin = Linearisation::for_problem(&problem, &start);
    let lin_note = lin.as_ref().err().map(|e| e.to_string());
    let lin = lin.ok();
    let hb_lin = if a.no_harmonic_balance {
        None
    } else {
        lin.as_ref()
    };
    let freqs = sweep::frequencies(lo, hi, n);
    let dirs = match a.sweep {
        SweepArg::Up => 1,
        SweepArg::Down => 1,
        SweepArg::Both => 2,
    };
    let bar = progress_bar((n * dirs) as u64, "sweep");
    let report = |d: Direction, p: &SweepPoint| {
        bar.inc(1);
        bar.set_message(format!("{} {:.2} Hz", d.name(), p.frequency));
    };
    let t0 = std::time::Instant::now();
    let sweeps: Vec<Sweep> = match a.sweep {
        SweepArg::Up => vec![sweep::sweep(
            &problem,
            &start,
            &freqs,
            Direction::Up,
            &opts,
            hb_lin,
            &report,
        )],
        SweepArg::Down => vec![sweep::sweep(
            &problem,
            &start,
            &freqs,
            Direction::Down,
            &opts,
            hb_lin,
            &report,
        )],
        SweepArg::Both => {
            let (u, d) = sweep::sweep_both(&problem, &start, &freqs, &opts, hb_lin, &report);
            vec![u, d]
        }
    };
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "resonance"));
    std::fs::create_dir_all(&out).with_context(|| format!("--out {}", out.display()))?;
    // CSV: all sweeps in one table; HDF5: one group per direction.
    let mut all: Option<Vec<Column>> = None;
    let mut groups = Vec::new();
    for sw in &sweeps {
        all = Some(match all {
            None => sweep_columns(sw),
            Some(c) => concat_columns(c, sweep_columns(sw)),
        });
        groups.push((
            sw.direction.name(),
            "frequency sweep: time-domain steady state per frequency, started from the previous one",
            sweep_columns(sw),
        ));
    }
    let csv_path = out.join("resonance.csv");
    write_atomic(&csv_path, &csv_bytes(&all.unwrap_or_default())?)?;
    let h5_path = out.join("resonance.h5");
    let attrs = [
        ("source", vstr(&scn.source_name)),
        ("scenario", vstr(&scn.source_text)),
        ("base_amplitude", AttrValue::F64(problem.amplitude)),
        ("tolerance", AttrValue::F64(opts.tol)),
        ("rtol", AttrValue::F64(opts.rtol)),
    ];
    let refs: Vec<(&str, &str, Vec<Column>)> = groups;
    write_atomic(&h5_path, &h5_bytes(&attrs, &refs)?)?;

    // Plots: magnitude and phase.
    let mut fig = Figure::new(
        format!(
            "frequency response, X_b = {:.3} µm ({})",
            problem.amplitude * 1e6,
            stem(&a.file)
        ),
        "frequency f (Hz)",
        "|δ_A / X_b|",
    )
    .with_legend(LegendPosition::UpperRight);
    let mut phase = Figure::new(
        format!("phase of δ_1 ({})", stem(&a.file)),
        "frequency f (Hz)",
        "phase φ (rad), δ − δ_m ≈ |δ_1| sin(ωt + φ)",
    )
    .with_legend(LegendPosition::UpperRight);
    for (i, sw) in sweeps.iter().enumerate() {
        let style = if i == 0 {
            Style::LineMarkers
        } else {
            Style::Markers
        };
        let (x, y) = sorted_by_freq(&sw.points, |p| {
            p.steady.as_ref().map(|s| s.transfer_magnitude())
        });
        fig = fig.with_series(
            Series::new(
                format!("time domain, sweep {}", sw.direction.name()),
                x,
                y,
                style,
            )
            .with_color(i),
        );
        let (x, y) = sorted_by_freq(&sw.points, |p| {
            p.steady.as_ref().map(|s| s.transfer_phase())
        });
        phase = phase.with_series(
            Series::new(
                format!("time domain, sweep {}", sw.direction.name()),
                x,
                y,
                style,
            )
            .with_color(i),
        );
        if hb_lin.is_some() {
            let (x, y) = sorted_by_freq(&sw.points, |p| {
                p.harmonic.map(|h| h.delta_amp / problem.amplitude)
            });
            fig = fig.with_series(
                Series::new(
                    format!("harmonic balance, {}", sw.direction.name()),
                    x,
                    y,
                    Style::Dashed,
                )
                .with_color(3 + i),
            );
        }
    }
    if let Some(l) = &lin {
        let fd = sweep::frequencies(lo, hi, 801);
        let y: Vec<f64> = fd.iter().map(|&f| l.linear(f).magnitude()).collect();
        let yp: Vec<f64> = fd.iter().map(|&f| l.linear(f).phase()).collect();
        fig = fig.with_series(
            Series::new(
                "linear transfer, k_c = 3/2 K a_0",
                fd.clone(),
                y,
                Style::Line,
            )
            .with_color(2),
        );
        phase =
            phase.with_series(Series::new("linear transfer", fd, yp, Style::Line).with_color(2));
    }
    let (png, svg) = plot::render(&fig, &out.join("resonance"))?;
    let (ppng, psvg) = plot::render(&phase, &out.join("resonance-phase"))?;

    // Summary.
    let lin_peak = lin.as_ref().and_then(|l| linear_peak(l, lo, hi));
    let mut summary = Map::new();
    summary.insert("amplitude".into(), json!(problem.amplitude));
    summary.insert("frequencies".into(), json!(n));
    summary.insert("wall_s".into(), json!(wall));
    if let Some(l) = &lin {
        summary.insert(
            "linear_resonance_frequency".into(),
            json!(l.resonance_frequency()),
        );
    }
    if let Some((f, h)) = lin_peak {
        summary.insert("linear_peak".into(), json!({"frequency": f, "height": h}));
    }
    let mut rows = Vec::new();
    for sw in &sweeps {
        let mut m = Map::new();
        let ok = sw.points.iter().filter(|p| p.steady.is_some()).count();
        let shooting = sw
            .points
            .iter()
            .filter(|p| {
                p.steady
                    .as_ref()
                    .is_some_and(|s| s.method == djkr::steady::SteadyMethod::Shooting)
            })
            .count();
        m.insert("found".into(), json!(ok));
        m.insert("by_shooting".into(), json!(shooting));
        m.insert("cycles".into(), json!(sw.cycles));
        m.insert("wall_s".into(), json!(sw.wall_s));
        let pk = sweep::peak(&sw.points);
        if let Some((f, h)) = pk {
            let mut p = json!({"frequency": f, "height": h});
            if let Some((fl, hl)) = lin_peak {
                p["shift_from_linear"] = json!(f - fl);
                p["height_over_linear"] = json!(h / hl);
            }
            m.insert("peak".into(), p);
        }
        let hv: Vec<(f64, f64)> = {
            let (x, y) = sorted_by_freq(&sw.points, |p| {
                p.harmonic.map(|h| h.delta_amp / problem.amplitude)
            });
            x.into_iter().zip(y).collect()
        };
        if let Some((f, h)) = sweep::peak_of(&hv) {
            m.insert(
                "harmonic_balance_peak".into(),
                json!({"frequency": f, "height": h}),
            );
        }
        rows.push((sw.direction.name(), pk, m));
    }
    let mut hysteresis = None;
    if sweeps.len() == 2 {
        // Largest |up − down| in |δ_A/X_b| at the same frequency.
        let mut worst: Option<(f64, f64)> = None;
        for pu in &sweeps[0].points {
            if let Some(pd) = sweeps[1]
                .points
                .iter()
                .find(|p| (p.frequency - pu.frequency).abs() <= 1e-9 * pu.frequency)
            {
                if let (Some(su), Some(sd)) = (&pu.steady, &pd.steady) {
                    let d = (su.transfer_magnitude() - sd.transfer_magnitude()).abs();
                    if worst.is_none_or(|(_, w)| d > w) {
                        worst = Some((pu.frequency, d));
                    }
                }
            }
        }
        hysteresis = worst;
    }
    for (name, _, m) in &rows {
        summary.insert(format!("sweep_{name}"), Value::Object(m.clone()));
    }
    if let Some((f, d)) = hysteresis {
        summary.insert(
            "max_up_down_difference".into(),
            json!({"frequency": f, "delta_amp_over_xb": d}),
        );
    }
    if let Some(e) = &lin_note {
        summary.insert("notes".into(), json!([e]));
    }
    let files = [csv_path, h5_path, png, svg, ppng, psvg];
    summary.insert(
        "files".into(),
        json!(files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()),
    );
    if a.json {
        return print_json(&Value::Object(summary));
    }
    println!(
        "{}: frequency response {lo}–{hi} Hz ({n} frequencies), X_b = {:.4} µm, {:.2} s",
        a.file.display(),
        problem.amplitude * 1e6,
        wall
    );
    if let Some(l) = &lin {
        println!(
            "  linear transfer (k_c = 3/2 K a_0 = {:.1} N/m): f_r = {:.3} Hz{}",
            l.contact_stiffness,
            l.resonance_frequency(),
            lin_peak
                .map(|(f, h)| format!(", peak |δ_A/X_b| = {h:.4} at {f:.3} Hz"))
                .unwrap_or_default()
        );
    }
    for ((name, pk, m), sw) in rows.iter().zip(&sweeps) {
        let shooting = m.get("by_shooting").and_then(Value::as_u64).unwrap_or(0);
        let found = m.get("found").and_then(Value::as_u64).unwrap_or(0);
        print!(
            "  sweep {name:<4}: {found}/{n} steady states ({shooting} by shooting), {} periods, {:.2} s",
            sw.cycles, sw.wall_s
        );
        if let Some((f, h)) = pk {
            print!("; peak |δ_A/X_b| = {h:.4} at {f:.3} Hz");
            if let Some((fl, hl)) = lin_peak {
                print!(
                    " (shift {:+.3} Hz, height ×{:.4} of linear)",
                    f - fl,
                    h / hl
                );
            }
        }
        println!();
        if let Some(Value::Object(hb)) = m.get("harmonic_balance_peak") {
            let f = hb
                .get("frequency")
                .and_then(Value::as_f64)
                .unwrap_or(f64::NAN);
            let h = hb.get("height").and_then(Value::as_f64).unwrap_or(f64::NAN);
            println!("              harmonic balance peak {h:.4} at {f:.3} Hz");
        }
    }
    if let Some((f, d)) = hysteresis {
        println!("  largest up/down difference in |δ_A/X_b|: {d:.3e} at {f:.3} Hz");
    }
    if let Some(e) = &lin_note {
        println!("  {e}");
    }
    println!("\nwrote:");
    for p in &files {
        println!("  {}", p.display());
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// shortcut-map

fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

fn map_columns(m: &ShortcutMap) -> Vec<Column> {
    let c = &m.cells;
    let td = |f: &dyn Fn(&Prediction) -> Option<f64>| -> Vec<Option<f64>> {
        c.iter()
            .map(|x| x.time_domain.as_ref().and_then(f))
            .collect()
    };
    let ia = |f: &dyn Fn(&Prediction) -> Option<f64>| -> Vec<Option<f64>> {
        c.iter()
            .map(|x| x.imposed_area.as_ref().and_then(f))
            .collect()
    };
    vec![
        num(
            "frequency",
            "Hz",
            "base frequency",
            c.iter().map(|x| Some(x.frequency)).collect(),
        ),
        num(
            "amplitude",
            "m",
            "base amplitude X_b",
            c.iter().map(|x| Some(x.amplitude)).collect(),
        ),
        num(
            "force_error",
            "1",
            "(F_m imposed - F_m time) / max(|F_m time|, 3/2 pi R w0)",
            c.iter().map(|x| x.force_error).collect(),
        ),
        num(
            "delta_amp_error",
            "1",
            "(delta_A imposed - delta_A time) / delta_A time",
            c.iter().map(|x| x.delta_amp_error).collect(),
        ),
        num(
            "time_force_mean",
            "N",
            "time domain: mean contact force",
            td(&|p| p.force_mean),
        ),
        num(
            "imposed_force_mean",
            "N",
            "imposed area: mean contact force",
            ia(&|p| p.force_mean),
        ),
        num(
            "time_delta_amp",
            "m",
            "time domain: delta_A",
            td(&|p| p.delta_amp),
        ),
        num(
            "imposed_delta_amp",
            "m",
            "imposed area: delta_A",
            ia(&|p| p.delta_amp),
        ),
        num(
            "time_delta_mean",
            "m",
            "time domain: mean indentation",
            td(&|p| p.delta_mean),
        ),
        num(
            "imposed_delta_mean",
            "m",
            "imposed area: mean indentation",
            ia(&|p| p.delta_mean),
        ),
        num(
            "a_mean",
            "m",
            "time domain: mean contact radius",
            td(&|p| p.a_mean),
        ),
        num(
            "a_amp",
            "m",
            "time domain: contact-radius first-harmonic amplitude",
            td(&|p| p.a_amp),
        ),
        num(
            "contact_lost",
            "1",
            "1 when the steady cycle loses contact",
            c.iter()
                .map(|x| Some(f64::from(u8::from(x.contact_lost))))
                .collect(),
        ),
        num(
            "cycles",
            "1",
            "base periods integrated",
            c.iter().map(|x| Some(x.cycles as f64)).collect(),
        ),
        Column {
            name: "method",
            unit: "",
            description: "how the steady state was found",
            data: Data::Text(
                c.iter()
                    .map(|x| x.method.map(|m| m.name().to_string()).unwrap_or_default())
                    .collect(),
            ),
        },
        Column {
            name: "error",
            unit: "",
            description: "why a value is missing",
            data: Data::Text(
                c.iter()
                    .map(|x| x.error.clone().unwrap_or_default())
                    .collect(),
            ),
        },
    ]
}

fn heatmap(m: &ShortcutMap, title: String, z: Vec<f64>, log_amp: bool) -> Heatmap {
    let z: Vec<f64> = z.iter().map(|v| v.abs()).collect();
    let valid = z.iter().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = valid.fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
    // A logarithmic colour scale only when the errors span more than a decade.
    let z_log = hi > 10.0 * lo;
    Heatmap {
        title,
        x_label: "base frequency f (Hz)".into(),
        y_label: "base amplitude X_b (µm)".into(),
        z_label: if z_log {
            "|relative error| (log colour scale)".into()
        } else {
            "|relative error|".into()
        },
        x: m.frequencies.clone(),
        y: m.amplitudes.iter().map(|x| x * 1e6).collect(),
        z,
        x_log: false,
        y_log: log_amp,
        z_log,
        z_range: None,
        size: (1000, 700),
    }
}

/// Run `djkr shortcut-map`.
pub fn shortcut_map(a: &ShortcutMapArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let (flo, fhi, nf) = range("--freq", &a.freq, Dimension::Frequency)?;
    let (alo, ahi, na) = range("--amp", &a.amp, Dimension::Length)?;
    let scn = load_scenario(&a.file, &a.steady.set)?;
    let (problem, start) =
        Problem::from_plan(&scn.plan()).with_context(|| format!("{}", a.file.display()))?;
    let freqs = sweep::frequencies(flo, fhi, nf);
    let amps = log_space(alo, ahi, na);
    let bar = progress_bar((nf * na) as u64, "map");
    let report = |c: &MapCell| {
        bar.inc(1);
        bar.set_message(format!(
            "{:.1} Hz, {:.3} µm",
            c.frequency,
            c.amplitude * 1e6
        ));
    };
    let m = smap::shortcut_map(&problem, &start, &freqs, &amps, &opts, &report);
    bar.finish_and_clear();
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "shortcut-map"));
    std::fs::create_dir_all(&out).with_context(|| format!("--out {}", out.display()))?;
    let csv_path = out.join("shortcut-map.csv");
    write_atomic(&csv_path, &csv_bytes(&map_columns(&m))?)?;
    let h5_path = out.join("shortcut-map.h5");
    let attrs = [
        ("source", vstr(&scn.source_name)),
        ("scenario", vstr(&scn.source_text)),
        ("frequency_count", AttrValue::I64(nf as i64)),
        ("amplitude_count", AttrValue::I64(na as i64)),
        (
            "layout",
            vstr(
                "cells row-major in amplitude: index = i_amplitude * frequency_count + i_frequency",
            ),
        ),
    ];
    write_atomic(
        &h5_path,
        &h5_bytes(
            &attrs,
            &[(
                "cells",
                "imposed-area shortcut vs time-domain steady state per (frequency, amplitude)",
                map_columns(&m),
            )],
        )?,
    )?;
    let log_amp = na > 1 && ahi / alo > 4.0;
    let name = a
        .file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (fp, fs) = plot::render_heatmap(
        &heatmap(
            &m,
            format!(
                "{}: imposed-area error in the mean force F_m",
                scn.source_name
            ),
            m.field(|c| c.force_error),
            log_amp,
        ),
        &out.join("shortcut-map-force"),
    )?;
    let (dp, ds) = plot::render_heatmap(
        &heatmap(
            &m,
            format!("imposed-area error in δ_A ({name})"),
            m.field(|c| c.delta_amp_error),
            log_amp,
        ),
        &out.join("shortcut-map-delta"),
    )?;
    let files = [csv_path, h5_path, fp, fs, dp, ds];
    let found: Vec<&MapCell> = m.cells.iter().filter(|c| c.force_error.is_some()).collect();
    let stats = |f: &dyn Fn(&MapCell) -> Option<f64>| {
        let v: Vec<f64> = found.iter().filter_map(|c| f(c)).map(f64::abs).collect();
        let max = v.iter().copied().fold(0.0f64, f64::max);
        let min = v.iter().copied().fold(f64::INFINITY, f64::min);
        let below = |t: f64| v.iter().filter(|x| **x < t).count();
        (min, max, below(0.01), below(0.05), v.len())
    };
    let (fmin, fmax, f1, f5, fnn) = stats(&|c| c.force_error);
    let (dmin, dmax, d1, d5, dn) = stats(&|c| c.delta_amp_error);
    let lost = m.cells.iter().filter(|c| c.contact_lost).count();
    let ts = m
        .cells
        .iter()
        .filter(|c| c.method == Some(djkr::steady::SteadyMethod::TimeStepping))
        .count();
    if a.json {
        return print_json(&json!({
            "frequencies": m.frequencies,
            "amplitudes": m.amplitudes,
            "cells": nf * na,
            "found": found.len(),
            "by_time_stepping": ts,
            "contact_lost": lost,
            "cycles": m.cycles,
            "wall_s": m.wall_s,
            "force_error": {"min_abs": if fnn > 0 { fmin } else { 0.0 }, "max_abs": fmax, "below_1_percent": f1, "below_5_percent": f5},
            "delta_amp_error": {"min_abs": if dn > 0 { dmin } else { 0.0 }, "max_abs": dmax, "below_1_percent": d1, "below_5_percent": d5},
            "files": files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        }));
    }
    println!(
        "{}: imposed-area shortcut vs time domain over {nf} frequencies × {na} amplitudes, {:.2} s, {} periods",
        a.file.display(),
        m.wall_s,
        m.cycles
    );
    println!(
        "  steady states found: {}/{} ({} by time-stepping, {} losing contact)",
        found.len(),
        nf * na,
        ts,
        lost
    );
    println!(
        "  |mean-force error|: {:.2e} … {:.2e}; < 1 %: {f1} cells, < 5 %: {f5}",
        fmin, fmax
    );
    println!(
        "  |δ_A error|:        {:.2e} … {:.2e}; < 1 %: {d1} cells, < 5 %: {d5}",
        dmin, dmax
    );
    println!("\n  force error (%), rows X_b (µm), columns f (Hz):");
    print!("  {:>10}", "");
    for f in &m.frequencies {
        print!("{f:>9.1}");
    }
    println!();
    for (ia, xb) in m.amplitudes.iter().enumerate() {
        print!("  {:>10.4}", xb * 1e6);
        for i_f in 0..nf {
            match m.cells[ia * nf + i_f].force_error {
                Some(e) => print!("{:>9.2}", e * 100.0),
                None => print!("{:>9}", "—"),
            }
        }
        println!();
    }
    println!("\nwrote:");
    for p in &files {
        println!("  {}", p.display());
    }
    Ok(())
}
