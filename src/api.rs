//! What a command computes and reports, as calls: the command line (`src/cli/`) and the Python
//! binding (`python/`) both call these, so that `djkr cycle --json` and `djkr.cycle(...)` give
//! the same keys and the same numbers, and `djkr.run(...)` the same arrays as `djkr run`'s
//! `run.h5`.
//!
//! - Requests are typed: a [`Scenario`] or its parsed source, overrides ([`Override`]), numbers
//!   as [`Quantity`] (a value parsed for its dimension that keeps the text it came from, so a
//!   message can quote it), swept keys as [`Axis`]. An error ([`Error`]) says what happened and
//!   to which input; each front end words the input (`--a-amp` on the command line, `a_amp` in
//!   Python).
//! - [`cycle`] and [`pull_off`]: the reports of `djkr cycle` and `djkr pulloff` (exact, approx,
//!   Yi), serialised as `--json` prints them.
//! - [`run`]: a run kept in memory (the time series, events and period records as the run file's
//!   tables) and optionally written into a run folder by the same writer as `djkr run`.
//! - [`validate`], [`resonance`], [`sweep`]: the steady-state comparison, the frequency response
//!   and a study, each returning a typed report (what the command's `--json` or table holds).
//! - [`fit`], [`predict`], [`design`]: measured data turned into the rig's unknowns, the model's
//!   predictions with their uncertainty from such a fit, and the new measurements that would
//!   pin the unknowns down best.
//! - [`check_finite`]: whether a report can be written as JSON (JSON has no NaN or infinity).
//!
//! Every long computation here takes its cancellation from the scenario's
//! [`Solver::cancel`](djkr_core::dynamics::Solver::cancel) (or, for a sweep, a stop flag), so a
//! caller can stop it from another thread ([`djkr_core::cancel`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use serde_json::{json, Value};

use crate::error::{input, Error};
pub use crate::fit::Column;
use crate::output::summary::{summary_json, SummaryFiles};
use crate::output::table::Table;
use crate::output::{cycles, OutputError, OutputPaths, RunWriter, TimeSeriesWriter};
pub use crate::record::RunRecord;
use crate::reports::steady::{self as report, ValidateReport};
/// The peak of a frequency response's samples, as `djkr resonance` finds it.
pub use crate::reports::steady::{maximum as resonance_peak, NoPeak, Peak};
use crate::run_plot::RunPlotError;
use crate::scenario::checks::{contact_radius_error, small_contact_warning};
use crate::scenario::overrides::{Override, OverrideError};
use crate::scenario::{Initial, Scenario};
use crate::sweep::{rows_table, run_all, Axis, Ensemble, Grid, RunOptions, Sweep};
use djkr_core::adhesion::{GentSchultz, Law};
use djkr_core::closed_form::DeltaAmpForm;
use djkr_core::comparators;
use djkr_core::dynamics::{
    CycleRecord, Ending, Event, Gap, Observer, Reason, RunResult, Sample, Status,
};
use djkr_core::error::{non_negative, positive, ParamError};
use djkr_core::imposed_area::{self, Cycle};
use djkr_core::material::Material;
use djkr_core::steady::sweep::{self as steady_sweep, Direction, Linearisation, SweepPoint};
use djkr_core::steady::{crosscheck, Options, Problem, SteadyError};
use djkr_core::text::excerpt;
use djkr_core::units::{parse_quantity, Dimension};

/// Limits on the grids and lists of the commands that take ranges: each bounds the work one
/// invocation may ask for (a 100000 × 100000 shortcut map is 1e10 steady states).
pub(crate) mod limits {
    /// `resonance --freq START:STOP:COUNT`: frequencies per sweep.
    pub(crate) const RESONANCE_FREQUENCIES: usize = 2001;
    /// `shortcut-map --freq` and `--amp`: COUNT of each axis.
    pub(crate) const MAP_AXIS: usize = 1001;
    /// `shortcut-map`: cells (frequencies × amplitudes).
    pub(crate) const MAP_CELLS: usize = 10_000;
    /// `beta-fit --n-values`: exponents.
    pub(crate) const BETA_FIT_N_VALUES: usize = 100;
    /// `beta-fit --speed-ratio`: COUNT.
    pub(crate) const BETA_FIT_SPEED_RATIOS: usize = 1000;
    /// `beta-fit`: exact pull-offs (n values × speed ratios).
    pub(crate) const BETA_FIT_PULL_OFFS: usize = 20_000;
    /// `beta-fit --beta`: COUNT of the β grid.
    pub(crate) const BETA_FIT_BETAS: usize = 10_000;
    /// `accuracy --tolerances`: values.
    pub(crate) const ACCURACY_TOLERANCES: usize = 20;
    /// `accuracy --methods`: values (each method once).
    pub(crate) const ACCURACY_METHODS: usize = 5;
    /// `accuracy --repeats`.
    pub(crate) const ACCURACY_REPEATS: usize = 100;
    /// `accuracy --nodes`: node counts.
    pub(crate) const ACCURACY_NODES: usize = 32;
}

/// The longest path the system can open, in bytes, and the longest name in it (Linux's
/// `PATH_MAX` and `NAME_MAX`; macOS has 1024 and 255).
pub(crate) const PATH_BYTES: usize = if cfg!(target_os = "macos") {
    1024
} else {
    4096
};
/// See [`PATH_BYTES`].
pub(crate) const NAME_BYTES: usize = 255;

/// Why no system call would take `path` (longer than `PATH_BYTES`, or a name in it longer
/// than `NAME_BYTES`), quoting its beginning, or `None`. A path argument is checked so before
/// anything else: every later message names files by their path, whole, which for such a path
/// would be the 100 kB a user pasted.
pub fn path_length_error(path: &Path) -> Option<String> {
    let value = path.as_os_str();
    let longest_name = path.components().map(|c| c.as_os_str().len()).max();
    (value.len() > PATH_BYTES || longest_name.unwrap_or(0) > NAME_BYTES).then(|| {
        format!(
            "{}: a path longer than the system allows ({PATH_BYTES} bytes in all, {NAME_BYTES} \
             for one name)",
            excerpt(&value.to_string_lossy())
        )
    })
}

/// An argument as text with the name errors give it (`--freq`, or `freq`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Arg<'a> {
    /// The name.
    pub name: &'a str,
    /// The value as given: a bare SI number or a number with a unit.
    pub text: &'a str,
}

impl<'a> Arg<'a> {
    /// `name = text`.
    pub(crate) fn new(name: &'a str, text: &'a str) -> Self {
        Self { name, text }
    }
}

/// Parse a quantity that must be > 0 (and normal: a subnormal is refused as for every key,
/// [`djkr_core::error::subnormal_error`]).
pub(crate) fn positive_quantity(name: &str, text: &str, dim: Dimension) -> Result<f64, ParamError> {
    let v = parse_quantity(name, text, dim)?;
    refuse_subnormal(
        name,
        text,
        v,
        &format!("a normal finite number > 0 ({})", unit_of(dim)),
    )?;
    positive(name, v, dim.si()).map_err(|e| ParamError {
        value: text.to_string(),
        ..e
    })
}

/// Parse a quantity that must be ≥ 0 (0, or normal: a subnormal is refused).
pub(crate) fn non_negative_quantity(
    name: &str,
    text: &str,
    dim: Dimension,
) -> Result<f64, ParamError> {
    let v = parse_quantity(name, text, dim)?;
    refuse_subnormal(
        name,
        text,
        v,
        &format!("0 or a normal finite number > 0 ({})", unit_of(dim)),
    )?;
    non_negative(name, v, dim.si()).map_err(|e| ParamError {
        value: text.to_string(),
        ..e
    })
}

/// Parse a quantity of any sign (0, or normal: a subnormal is refused).
pub(crate) fn normal_quantity(name: &str, text: &str, dim: Dimension) -> Result<f64, ParamError> {
    let v = parse_quantity(name, text, dim)?;
    refuse_subnormal(
        name,
        text,
        v,
        &format!("0 or a normal finite number ({})", unit_of(dim)),
    )?;
    Ok(v)
}

/// `Err` naming `name = text` when `v` is subnormal ([`djkr_core::error::subnormal_error`]).
fn refuse_subnormal(name: &str, text: &str, v: f64, allowed: &str) -> Result<(), ParamError> {
    match djkr_core::error::subnormal_error(v, allowed) {
        Some(e) => Err(ParamError::new(name, excerpt(text), e)),
        None => Ok(()),
    }
}

/// The SI unit of `dim` as messages name it.
fn unit_of(dim: Dimension) -> &'static str {
    match dim.si() {
        "" => "dimensionless",
        u => u,
    }
}

/// Parse a quantity that sets the scenario key `key` (`--modulus` sets `material.K`), > 0 and
/// normal, within that key's range ([`crate::scenario::checks::key_range_error`]: the same
/// table the scenario parser applies).
pub(crate) fn key_positive_quantity(
    name: &str,
    text: &str,
    dim: Dimension,
    key: &str,
) -> Result<f64, ParamError> {
    let v = positive_quantity(name, text, dim)?;
    key_range(name, text, dim, key, v)
}

/// As [`key_positive_quantity`], for a quantity that may be 0 (`--base-amp`, `base.amplitude`).
pub(crate) fn key_non_negative_quantity(
    name: &str,
    text: &str,
    dim: Dimension,
    key: &str,
) -> Result<f64, ParamError> {
    let v = non_negative_quantity(name, text, dim)?;
    key_range(name, text, dim, key, v)
}

/// `v` (parsed from `text` by [`positive_quantity`] or [`non_negative_quantity`], which refuse
/// subnormals) within the range of `key`.
fn key_range(name: &str, text: &str, dim: Dimension, key: &str, v: f64) -> Result<f64, ParamError> {
    let unit = unit_of(dim);
    match crate::scenario::checks::key_range_error(key, v, unit) {
        Some(e) => Err(ParamError::new(
            name,
            excerpt(text),
            format!("{e} (as {key})"),
        )),
        None => Ok(v),
    }
}

/// The range of the speed correction β of eq. (24) (`--beta`): it is of order 1 (the paper's
/// 2.5; `djkr beta-fit` finds it between 0.5 and 10 for n from 0.1 to 0.9).
pub(crate) const BETA_RANGE: (f64, f64) = (1e-2, 1e2);

/// Parse β of eq. (24), within [`BETA_RANGE`].
pub(crate) fn beta_from(name: &str, text: &str) -> Result<f64, ParamError> {
    let b = positive_quantity(name, text, Dimension::Dimensionless)?;
    let (lo, hi) = BETA_RANGE;
    if !(lo..=hi).contains(&b) {
        return Err(ParamError::new(
            name,
            excerpt(text),
            format!(
                "must lie in [{lo:e}, {hi:e}] (dimensionless): the speed correction of eq. (24) \
                 is of order 1 (the paper's 2.5)"
            ),
        ));
    }
    Ok(b)
}

/// Angular frequency from a frequency argument (Hz), within the range of `base.frequency`.
pub(crate) fn omega_from(name: &str, text: &str) -> Result<f64, ParamError> {
    let f = key_positive_quantity(name, text, Dimension::Frequency, "base.frequency")?;
    Ok(2.0 * std::f64::consts::PI * f)
}

/// Refuse a result that holds a non-finite number (`values`: each with its name), naming the
/// inputs it came from (`inputs`: `--freq = 400, --a-mean = 1mm`, as the caller spells them):
/// the inputs are within their ranges but beyond what double precision carries together.
pub(crate) fn finite_result(inputs: &[Arg], values: &[(&str, f64)]) -> Result<(), ParamError> {
    let Some((bad, v)) = values.iter().find(|(_, v)| !v.is_finite()) else {
        return Ok(());
    };
    let (last, first) = inputs.split_last().expect("at least one input");
    let mut name = String::new();
    for a in first {
        name.push_str(&format!("{} = {}, ", a.name, excerpt(a.text)));
    }
    name.push_str(last.name);
    Err(ParamError::new(
        name,
        excerpt(last.text),
        format!(
            "the result is not finite ({bad} = {v}): these inputs together are beyond what the \
             computation carries in double precision"
        ),
    ))
}

/// Parse START:STOP:COUNT with units, 0 < START ≤ STOP, 1 ≤ COUNT ≤ `max` (START = STOP when
/// COUNT = 1 is not required: COUNT = 1 gives START). A grid of frequencies or lengths sets the
/// base's frequency or amplitude, and is held to the range of `base.frequency` or
/// `base.amplitude`.
pub(crate) fn range(
    name: &str,
    text: &str,
    dim: Dimension,
    max: usize,
) -> Result<(f64, f64, usize), Error> {
    let shown = excerpt(text);
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        return Err(Error::Invalid(format!(
            "{name} = {shown}: expected START:STOP:COUNT, e.g. 300:500:101"
        )));
    }
    // The ranges are those of the base's frequency and amplitude, the keys these grids set.
    let parse = |t: &str| match dim {
        Dimension::Frequency => key_positive_quantity(name, t, dim, "base.frequency"),
        Dimension::Length => key_positive_quantity(name, t, dim, "base.amplitude"),
        _ => positive_quantity(name, t, dim),
    };
    let lo = parse(parts[0].trim())?;
    let hi = parse(parts[1].trim())?;
    let n: usize = parts[2].trim().parse().map_err(|_| {
        Error::Invalid(format!(
            "{name} = {shown}: COUNT = {} must be an integer >= 1",
            excerpt(parts[2])
        ))
    })?;
    if n == 0 || n > max {
        return Err(Error::Invalid(format!(
            "{name} = {shown}: COUNT = {n} must be in 1..={max} (the limit of this command)"
        )));
    }
    if hi < lo {
        return Err(Error::Invalid(format!(
            "{name} = {shown}: STOP must be >= START"
        )));
    }
    Ok((lo, hi, n))
}

/// A grid of base frequencies as `djkr resonance --freq` and `djkr.resonance(freq=)` take it,
/// given for the input `name`: `START:STOP:COUNT` (Hz, units welcome: `300Hz:0.5kHz:101`),
/// within the range of `base.frequency`, at most 2001 frequencies. Returns (start, stop, count).
pub fn frequency_range(name: &str, text: &str) -> Result<(f64, f64, usize), Error> {
    range(
        &input(name),
        text,
        Dimension::Frequency,
        limits::RESONANCE_FREQUENCIES,
    )
}

/// `KEY=VALUE` overrides, parsed and their keys checked.
pub(crate) fn overrides<S: AsRef<str>>(sets: &[S]) -> Result<Vec<Override>, OverrideError> {
    Override::parse_all(sets)
}

/// The first override of `overrides` whose key a command takes from elsewhere (`replaced`: the
/// key and where its value comes from), with that place: the command line and Python refuse it,
/// each in its own words, so that an override is honoured or refused, never silently ignored.
pub fn replaced_override<'a>(
    overrides: &[Override],
    replaced: &[(&str, &'a str)],
) -> Option<(String, &'a str)> {
    overrides.iter().find_map(|o| {
        let key = o.key().to_string();
        replaced
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, how)| (key, *how))
    })
}

/// The material and adhesion law of the commands that take one, when none is given: the
/// paper's Fig. 2 set (K 9.33 MPa, R 51 mm, w0 240 mJ/m², v0 0.0445 mm/s, n 0.531).
pub fn default_material() -> (Material, Law) {
    (Material::PAPER, Law::GentSchultz(GentSchultz::PAPER))
}

/// A report as a JSON value, refusing non-finite numbers (serde_json would write `null`); the
/// error names the path of the first one (`$.notes[0]`).
pub(crate) fn finite_json(report: &impl serde::Serialize) -> Result<Value, Error> {
    let v = serde_json::to_value(report).map_err(|e| Error::NonFinite(e.to_string()))?;
    check_finite_value(&v)?;
    Ok(v)
}

/// Refuse a report that holds a non-finite number (its JSON would have `null` there), naming
/// the number's path (`$.notes[0]`).
pub fn check_finite(report: &impl serde::Serialize) -> Result<(), Error> {
    let v = serde_json::to_value(report).map_err(|e| Error::Invalid(e.to_string()))?;
    check_finite_value(&v)
}

/// [`check_finite`] on a JSON value: serde_json writes a non-finite number as `null`.
fn check_finite_value(v: &Value) -> Result<(), Error> {
    fn check(v: &Value, path: &str) -> Result<(), Error> {
        match v {
            Value::Null => Err(Error::NonFinite(path.to_string())),
            Value::Object(o) => o
                .iter()
                .try_for_each(|(k, x)| check(x, &format!("{path}.{k}"))),
            Value::Array(a) => a
                .iter()
                .enumerate()
                .try_for_each(|(i, x)| check(x, &format!("{path}[{i}]"))),
            _ => Ok(()),
        }
    }
    check(v, "$")
}

/// A formatted number that rounded to zero is shown without a sign: `-0.000000 mm` (a value
/// of -1e-12 m at 6 decimals, or an IEEE -0.0) becomes `0.000000 mm`. Every number in `text`
/// is treated alike.
pub(crate) fn no_negative_zero(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let starts_number = b[i] == b'-'
            && b.get(i + 1).is_some_and(u8::is_ascii_digit)
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'.'));
        if starts_number {
            let end = (i + 1..b.len())
                .find(|&j| !(b[j].is_ascii_digit() || b[j] == b'.'))
                .unwrap_or(b.len());
            let mantissa_is_zero = b[i + 1..end].iter().all(|&c| c == b'0' || c == b'.');
            // An exponent (`-0.0e0`) or more digits after it are part of the number too.
            let exponent = b.get(end).is_some_and(|&c| c == b'e' || c == b'E');
            if mantissa_is_zero && !exponent {
                i += 1; // drop the sign
                continue;
            }
        }
        let c = text[i..].chars().next().unwrap_or(' ');
        out.push(c);
        i += c.len_utf8();
    }
    out
}

/// Format a length in the most readable unit.
pub(crate) fn fmt_len(x: f64) -> String {
    no_negative_zero(&fmt_len_signed(x))
}

fn fmt_len_signed(x: f64) -> String {
    let a = x.abs();
    if a >= 1e-3 || a == 0.0 {
        format!("{:.6} mm", x * 1e3)
    } else if a >= 1e-6 {
        format!("{:.6} µm", x * 1e6)
    } else {
        format!("{:.6} nm", x * 1e9)
    }
}

/// Format a force in the most readable unit.
pub(crate) fn fmt_force(f: f64) -> String {
    no_negative_zero(&fmt_force_signed(f))
}

fn fmt_force_signed(f: f64) -> String {
    if f.abs() >= 1.0 {
        format!("{f:.6} N")
    } else {
        format!("{:.6} mN", f * 1e3)
    }
}

// ---------------------------------------------------------------------------------------------
// cycle, pull-off

/// One imposed-area cycle (`djkr cycle`) and the model-range warnings it raised.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleReport {
    /// Angular frequency ω (rad/s).
    pub omega: f64,
    /// The cycle.
    pub cycle: Cycle,
    /// Where the answer leaves the model's range (a beyond 0.2 R): shown as warnings and listed
    /// under `notes`.
    pub notes: Vec<String>,
}

impl serde::Serialize for CycleReport {
    /// As `djkr cycle --json` prints it.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.json().serialize(s)
    }
}

impl CycleReport {
    /// The object `djkr cycle --json` prints.
    pub(crate) fn json(&self) -> Value {
        let c = &self.cycle;
        json!({
            "a_mean": c.a_mean,
            "a_mean_imposed": c.a_mean_imposed,
            "a_amp": c.a_amp,
            "delta_mean": c.harmonics.delta_mean,
            "delta_amp": c.harmonics.delta_amp,
            "delta_sin": c.harmonics.delta_sin,
            "delta_cos": c.harmonics.delta_cos,
            "force_mean": c.harmonics.force_mean,
            "contact_fraction": c.contact_fraction,
            "notes": self.notes,
        })
    }
}

/// A number as a front end received it: a bare SI number or a number with a unit (`400Hz`,
/// `1mm`), parsed for its dimension, keeping the input's name and the text it came as so that
/// a message quotes what was typed. The name is a request field (`freq`, `a_amp`); each front
/// end words it ([`crate::error::Words`]: `--freq` on the command line, `freq` in Python).
#[derive(Debug, Clone, PartialEq)]
pub struct Quantity {
    name: String,
    text: String,
    value: f64,
}

impl Quantity {
    /// Parse `text` as a quantity of `dim` given for the input `name`.
    pub fn parse(name: &str, text: &str, dim: Dimension) -> Result<Quantity, ParamError> {
        let value = djkr_core::units::parse_quantity(&input(name), text, dim)?;
        Ok(Quantity {
            name: name.to_string(),
            text: text.to_string(),
            value,
        })
    }

    /// A value in SI for the input `name` (written in messages as Rust's `{:?}` prints it:
    /// `0.001`, `1e300`).
    pub fn si(name: &str, value: f64) -> Quantity {
        Quantity {
            name: name.to_string(),
            text: format!("{value:?}"),
            value,
        }
    }

    /// The value (SI).
    pub fn value(&self) -> f64 {
        self.value
    }

    /// The input's name as messages mark it ([`crate::error::input`]).
    fn marked(&self) -> String {
        input(&self.name)
    }
}

/// One imposed-area cycle ([`cycle`]): the base frequency (Hz) and the imposed contact radius
/// a(t) = a_mean + a_amp sin ωt (m).
#[derive(Debug, Clone, PartialEq)]
pub struct CycleRequest {
    /// The base frequency f (Hz): ω = 2πf, within the range of `base.frequency`.
    pub freq: Quantity,
    /// The mean contact radius a_m (m), ≥ −a_amp.
    pub a_mean: Quantity,
    /// The contact-radius amplitude a_A (m), ≥ 0.
    pub a_amp: Quantity,
}

/// One imposed-area cycle (`djkr cycle`, `djkr.cycle`) of the material `m` under the law `law`.
/// Errors name the request's fields, worded by each front end.
pub fn cycle(m: &Material, law: &Law, req: &CycleRequest) -> Result<CycleReport, ParamError> {
    let names = [req.freq.marked(), req.a_mean.marked(), req.a_amp.marked()];
    cycle_args(
        m,
        law,
        Arg::new(&names[0], &req.freq.text),
        Arg::new(&names[1], &req.a_mean.text),
        Arg::new(&names[2], &req.a_amp.text),
    )
}

/// The pull-off method of a [`PullOffRequest`].
#[derive(Debug, Clone, PartialEq)]
pub enum PullOff {
    /// The imposed-area method minimised over a_m, at the contact-radius amplitude `a_amp` (m).
    Exact {
        /// a_A (m), ≥ 0.
        a_amp: Quantity,
    },
    /// The closed form, eqs. (20)–(24), with the δ_A derived from eqs. (14)–(15).
    Approx {
        /// a_A (m), ≥ 0.
        a_amp: Quantity,
        /// β of eq. (24) (dimensionless, of order 1); the paper's 2.5 when absent.
        beta: Option<Quantity>,
    },
    /// Yi et al. eq. (8) with δ_m = δ_A, δ_A from a_A (m) by
    /// [`comparators::yi_indentation_amplitude_from_area_amplitude`].
    Yi {
        /// a_A (m), ≥ 0.
        a_amp: Quantity,
    },
}

/// The pull-off under vibration ([`pull_off`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PullOffRequest {
    /// The base frequency f (Hz), within the range of `base.frequency`.
    pub freq: Quantity,
    /// The method and its inputs.
    pub method: PullOff,
}

/// The pull-off under vibration (`djkr pulloff`, `djkr.pulloff`) of the material `m` under
/// the law `law`. Errors name the request's fields, worded by each front end.
pub fn pull_off(
    m: &Material,
    law: &Law,
    req: &PullOffRequest,
) -> Result<PullOffReport, ParamError> {
    let omega = omega_from(&req.freq.marked(), &req.freq.text)?;
    let a_amp = match &req.method {
        PullOff::Exact { a_amp } | PullOff::Approx { a_amp, .. } | PullOff::Yi { a_amp } => {
            non_negative_quantity(&a_amp.marked(), &a_amp.text, Dimension::Length)?
        }
    };
    let method = match &req.method {
        PullOff::Exact { .. } => PullOffMethod::Exact { a_amp },
        PullOff::Approx { beta, .. } => PullOffMethod::Approx {
            a_amp,
            beta: match beta {
                Some(b) => positive_quantity(&b.marked(), &b.text, Dimension::Dimensionless)?,
                None => djkr_core::closed_form::BETA_PAPER,
            },
            form: DeltaAmpForm::Derived,
        },
        PullOff::Yi { .. } => PullOffMethod::Yi {
            delta_amp: comparators::yi_indentation_amplitude_from_area_amplitude(m, a_amp),
        },
    };
    pull_off_at(m, law, omega, method)
}

/// One imposed-area cycle at frequency `freq` (Hz) with a(t) = a_mean + a_amp sin ωt (m), the
/// inputs as the command line gives them (text, named by their flags).
pub(crate) fn cycle_args(
    m: &Material,
    law: &Law,
    freq: Arg,
    a_mean: Arg,
    a_amp: Arg,
) -> Result<CycleReport, ParamError> {
    let omega = omega_from(freq.name, freq.text)?;
    let amp = non_negative_quantity(a_amp.name, a_amp.text, Dimension::Length)?;
    let mean = normal_quantity(a_mean.name, a_mean.text, Dimension::Length)?;
    if mean < -amp {
        return Err(ParamError::new(
            a_mean.name,
            a_mean.text,
            format!(
                "must be >= -a_A = {} m (below, the contact never forms)",
                -amp
            ),
        ));
    }
    if let Some(e) = contact_radius_error(amp, m.r) {
        return Err(ParamError::new(a_amp.name, excerpt(a_amp.text), e));
    }
    if let Some(e) = contact_radius_error(mean + amp, m.r) {
        return Err(ParamError::new(
            a_mean.name,
            excerpt(a_mean.text),
            format!("with {} = {}: {e}", a_amp.name, excerpt(a_amp.text)),
        ));
    }
    let c = imposed_area::cycle(m, law, omega, mean, amp)?;
    finite_result(
        &[freq, a_mean, a_amp],
        &[
            ("a_m", c.a_mean),
            ("delta_m", c.harmonics.delta_mean),
            ("delta_s", c.harmonics.delta_sin),
            ("delta_c", c.harmonics.delta_cos),
            ("delta_A", c.harmonics.delta_amp),
            ("F_m", c.harmonics.force_mean),
            ("contact fraction", c.contact_fraction),
        ],
    )?;
    // The same small-contact rule as `pulloff` and `run`.
    let notes = small_contact_warning(
        "the contact reaches a_m + a_A",
        c.a_mean_imposed + c.a_amp,
        m.r,
    )
    .into_iter()
    .collect();
    Ok(CycleReport {
        omega,
        cycle: c,
        notes,
    })
}

/// A pull-off method of [`pull_off_at`] with its inputs in SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PullOffMethod {
    /// The imposed-area method minimised over a_m, at amplitude a_A (m).
    Exact {
        /// a_A (m).
        a_amp: f64,
    },
    /// The closed form, eqs. (20)–(24).
    Approx {
        /// a_A (m).
        a_amp: f64,
        /// β of eq. (24) (the paper's: [`djkr_core::closed_form::BETA_PAPER`]).
        beta: f64,
        /// The δ_A form.
        form: DeltaAmpForm,
    },
    /// Yi et al. eq. (8) with δ_m = δ_A.
    Yi {
        /// δ_A (m); from a_A by [`comparators::yi_indentation_amplitude_from_area_amplitude`].
        delta_amp: f64,
    },
}

/// What `djkr pulloff` reports for the exact, approx and yi methods.
#[derive(Debug, Clone, PartialEq)]
pub struct PullOffReport {
    /// The method, in words.
    pub method: &'static str,
    /// a_m at pull-off (m).
    pub a_mean: f64,
    /// δ_m at pull-off (m).
    pub delta_mean: f64,
    /// δ_A at pull-off (m).
    pub delta_amp: f64,
    /// Pull-off force (N, negative tensile).
    pub force: f64,
    /// Over −3/2 πRw0.
    pub amplification: f64,
    /// Caveats (several minima, contact loss, the closed form's settings, the model's range).
    pub notes: Vec<String>,
    /// The notes that are warnings (the answer leaves the model's range).
    pub warnings: Vec<String>,
}

impl serde::Serialize for PullOffReport {
    /// As `djkr pulloff --json` prints it.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.json().serialize(s)
    }
}

impl PullOffReport {
    /// The object `djkr pulloff --json` prints.
    pub(crate) fn json(&self) -> Value {
        json!({
            "method": self.method,
            "a_mean": self.a_mean,
            "delta_mean": self.delta_mean,
            "delta_amp": self.delta_amp,
            "force": self.force,
            "amplification": self.amplification,
            "notes": self.notes,
        })
    }
}

/// The pull-off for vibration at angular frequency `omega` (rad/s) by `method`.
pub(crate) fn pull_off_at(
    m: &Material,
    law: &Law,
    omega: f64,
    method: PullOffMethod,
) -> Result<PullOffReport, ParamError> {
    // A contact wider than the sphere is refused, as by `djkr pulloff --a-amp` (which checks
    // it first, naming its flag): here for the callers that pass a_A as a number.
    if let PullOffMethod::Exact { a_amp } | PullOffMethod::Approx { a_amp, .. } = method {
        if let Some(e) = contact_radius_error(a_amp, m.r) {
            return Err(ParamError::new("a_amp", format!("{a_amp:e}"), e));
        }
    }
    let (mut r, a_amp) = match method {
        PullOffMethod::Exact { a_amp } => {
            let p = imposed_area::pull_off(m, law, omega, a_amp)?;
            let mut notes = Vec::new();
            if p.local_minima.len() > 1 {
                notes.push(format!(
                    "the mean-force curve F_m(a_m) has {} local minima; the global one is reported. Others (a_m imposed, F_m): {}",
                    p.local_minima.len(),
                    p.local_minima
                        .iter()
                        .map(|(am, f)| format!("({}, {})", fmt_len(*am), fmt_force(*f)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            if !p.global {
                notes.push("the global minimum could not be certified (see local minima)".into());
            }
            if p.cycle.contact_fraction < 1.0 {
                notes.push(format!(
                    "contact is lost during part of the cycle (contact fraction {:.4}); a_m is the a-posteriori mean",
                    p.cycle.contact_fraction
                ));
            }
            let r = PullOffReport {
                method: "exact (imposed-area method, Sec. 2.1)",
                a_mean: p.cycle.a_mean,
                delta_mean: p.cycle.harmonics.delta_mean,
                delta_amp: p.cycle.harmonics.delta_amp,
                force: p.force,
                amplification: p.amplification,
                notes,
                warnings: Vec::new(),
            };
            (r, a_amp)
        }
        PullOffMethod::Approx { a_amp, beta, form } => {
            let p = djkr_core::closed_form::pull_off_approx(m, law, omega, a_amp, beta, form)?;
            let r = PullOffReport {
                method: "approx (closed form, eqs. 20-24)",
                a_mean: p.a_mean,
                delta_mean: p.delta_mean,
                delta_amp: p.delta_amp,
                force: p.force,
                amplification: p.amplification,
                notes: vec![format!(
                    "beta = {beta}, delta_A {}",
                    match form {
                        DeltaAmpForm::Derived =>
                            "as derived from eqs. (14)-(15) (delta form: derived)",
                        DeltaAmpForm::Printed => "as printed in eq. (23) (delta form: printed)",
                    }
                )],
                warnings: Vec::new(),
            };
            (r, a_amp)
        }
        PullOffMethod::Yi { delta_amp } => {
            let p = comparators::yi_mean_force(m, law, omega, delta_amp)?;
            return Ok(PullOffReport {
                method: "Yi et al. (2024) eq. (8), δ_m = δ_A",
                a_mean: (m.r * delta_amp).sqrt(),
                delta_mean: delta_amp,
                delta_amp,
                force: p.force,
                amplification: p.amplification,
                notes: vec![
                    "a_m here is the Hertz radius at δ_m (Yi's model does not search a_m)".into(),
                    format!(
                        "peak contact-radius speed {:.6} mm/s, mean w {:.6} mJ/m^2",
                        p.peak_speed * 1e3,
                        p.mean_work_of_adhesion * 1e3
                    ),
                ],
                warnings: Vec::new(),
            });
        }
    };
    // JKR is a small-contact theory (a ≪ R, half-space substrate): say so when the answer
    // leaves that range instead of presenting it as if it were valid.
    if let Some(w) = small_contact_warning("the contact reaches a_m + a_A", r.a_mean + a_amp, m.r) {
        r.notes.push(w.clone());
        r.warnings.push(w);
    }
    Ok(r)
}

// ---------------------------------------------------------------------------------------------
// run

/// Bytes one time-series sample is charged in memory: the [`crate::output::timeseries::SERIES`]
/// columns, the stage and the segment index, 8 bytes each (the data itself; while a column
/// grows, its buffer briefly holds up to twice this: the estimate before the run,
/// [`crate::memory::SAMPLE_BYTES`], counts that peak).
pub(crate) const SAMPLE_BYTES: u64 = 8 * (crate::output::timeseries::SERIES.len() as u64 + 2);
/// Bytes one event holds in memory.
pub(crate) const EVENT_BYTES: u64 = std::mem::size_of::<Event>() as u64;
/// Bytes one period record holds in memory (its table row, 8 bytes a column).
pub(crate) const CYCLE_BYTES: u64 = 8 * cycles::CYCLE_FIELDS.len() as u64;

/// Keeps everything in memory and hands it on to a run writer, when there is one. It counts
/// the bytes it holds (samples, events, period records: [`SAMPLE_BYTES`], [`EVENT_BYTES`],
/// [`CYCLE_BYTES`]) and stops the run, with [`Reason::Memory`], before a sample would take them
/// past `budget` (`solver.max_memory`): a run whose length is not known up front (samples at
/// every step, stages that end at pull-off) cannot exhaust the machine's memory. The count is
/// of the data itself; a growing column may briefly hold up to twice its length while it
/// grows.
struct InMemory<'a> {
    series: TimeSeriesWriter,
    cycles: Table,
    writer: Option<&'a mut RunWriter>,
    /// Bytes held.
    held: u64,
    /// `solver.max_memory` (bytes).
    budget: u64,
    /// The budget stopped the run.
    over_budget: bool,
}

impl InMemory<'_> {
    /// Count `bytes` more; `false` (and the run stops) when they would pass the budget.
    fn hold(&mut self, bytes: u64) -> bool {
        if self.over_budget || self.held.saturating_add(bytes) > self.budget {
            self.over_budget = true;
            return false;
        }
        self.held += bytes;
        true
    }
}

impl Observer for InMemory<'_> {
    fn sample(&mut self, s: &Sample) -> bool {
        if !self.hold(SAMPLE_BYTES) {
            return false;
        }
        self.series.push(s);
        match self.writer.as_deref_mut() {
            Some(w) => w.sample(s),
            None => true,
        }
    }
    fn event(&mut self, e: &Event) {
        // Events and records cannot stop the run themselves (the budget of events bounds
        // them); counted here, they stop it at the next sample.
        self.held = self.held.saturating_add(EVENT_BYTES);
        self.series.event(e);
        if let Some(w) = self.writer.as_deref_mut() {
            w.event(e);
        }
    }
    fn cycle(&mut self, c: &CycleRecord) {
        self.held = self.held.saturating_add(CYCLE_BYTES);
        cycles::push_cycle(&mut self.cycles, c);
        if let Some(w) = self.writer.as_deref_mut() {
            w.cycle(c);
        }
    }
    fn gap(&mut self, g: &Gap) {
        self.held = self.held.saturating_add(std::mem::size_of::<Gap>() as u64);
        self.series.gap(g);
        if let Some(w) = self.writer.as_deref_mut() {
            w.gap(g);
        }
    }
    fn stop_reason(&self) -> Option<Reason> {
        if self.over_budget {
            return Some(Reason::Memory);
        }
        // The run writer's own reason (the free disk space).
        self.writer.as_deref().and_then(Observer::stop_reason)
    }
}

/// How a run is written into its folder: what `djkr run` takes from its flags (`--csv`,
/// `--plot`, `--force`) and [`run`] from the scenario's `[output]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct FolderOptions {
    /// Also the CSV files.
    pub csv: bool,
    /// Also the run's figure (`run.png`, `run.svg`), drawn from `run.h5` once it is written.
    pub plot: bool,
    /// Overwrite files of the names the run publishes that djkr did not write.
    pub force: bool,
}

impl FolderOptions {
    /// As the scenario's `[output]` section asks (`force` off).
    pub fn of(scn: &Scenario) -> Self {
        Self {
            csv: scn.output.csv,
            plot: scn.output.plot,
            force: false,
        }
    }
}

/// Open `dir` for a run of `scn`: the folder's lock and record, and every name the run will
/// publish claimed before it starts (the figure's too with `o.plot`), so that a file of the
/// user's under one of them stops the run before any work (unless `o.force`). The writer is the
/// observer that streams the run into the folder; [`close_run_folder`] finishes it.
pub(crate) fn open_run_folder(
    scn: &Scenario,
    dir: &Path,
    o: FolderOptions,
) -> Result<RunWriter, OutputError> {
    let extra: &[&str] = if o.plot {
        &crate::run_plot::RUN_PLOT_FILES
    } else {
        &[]
    };
    RunWriter::create_with(dir, scn, o.csv, extra, o.force)
}

/// What [`close_run_folder`] wrote.
#[derive(Debug)]
pub(crate) struct RunFolderFiles {
    /// The run's files (summary, HDF5, CSV).
    pub paths: OutputPaths,
    /// The figure's files (empty without `plot`, or when drawing failed).
    pub plots: Vec<PathBuf>,
    /// Why the figure could not be drawn (the run's files are written all the same: the caller
    /// decides whether that fails the run).
    pub plot_error: Option<RunPlotError>,
}

/// Finish the run written by `writer` into `dir` (its `result` and how it ended), then draw its
/// figure from the finished `run.h5` when `plot`.
pub(crate) fn close_run_folder(
    writer: RunWriter,
    dir: &Path,
    result: &RunResult,
    ending: &Ending,
    plot: bool,
) -> Result<RunFolderFiles, OutputError> {
    let paths = writer.finish_with(result, ending)?;
    let (plots, plot_error) = if plot {
        match crate::run_plot::plot_run_dir(dir) {
            Ok((png, svg)) => (vec![png, svg], None),
            Err(e) => (Vec::new(), Some(e)),
        }
    } else {
        (Vec::new(), None)
    };
    Ok(RunFolderFiles {
        paths,
        plots,
        plot_error,
    })
}

/// Run `scn` and keep its samples, events and period records in memory; with `out`, also write
/// the run folder `djkr run --out` writes (`run.h5`, `summary.json`, the CSV files and figure
/// its `[output]` asks for), by the same writer. A run whose known samples would not fit in
/// `solver.max_memory` is refused before it starts (`crate::memory::check_in_memory`; an input
/// error). Cancelled through `scn.solver.cancel` ([`Error::Cancelled`]; a run folder is still
/// published, with reason `SIGINT`). A run stopped by a budget (`solver.max_memory` included: the
/// bytes held in memory) or failed mid-way returns [`Error::Ended`] with what it computed, and
/// its run folder is published with its status.
pub fn run(scn: &Scenario, out: Option<&Path>) -> Result<RunRecord, Error> {
    run_into(scn, out, false)
}

/// [`run`], with `force` (`djkr run --force`): files of the names the run publishes in `out`
/// that djkr did not write are overwritten instead of refused.
pub fn run_into(scn: &Scenario, out: Option<&Path>, force: bool) -> Result<RunRecord, Error> {
    crate::memory::check_in_memory(scn)?;
    let options = FolderOptions {
        force,
        ..FolderOptions::of(scn)
    };
    let mut writer = match out {
        Some(dir) => Some(
            open_run_folder(scn, dir, options).map_err(|error| Error::Output {
                input: Some("out"),
                context: None,
                error,
            })?,
        ),
        None => None,
    };
    let mut obs = InMemory {
        series: TimeSeriesWriter::new(),
        cycles: cycles::cycle_table(&[]),
        writer: writer.as_mut(),
        held: 0,
        budget: scn.solver.max_memory,
        over_budget: false,
    };
    let outcome = scn.simulate_partial(&mut obs);
    let InMemory { series, cycles, .. } = obs;
    let outcome = match outcome {
        Ok(o) => o,
        Err(error) => {
            return Err(Error::Run {
                source: scn.source(),
                error,
            })
        }
    };
    let ending = match &writer {
        Some(w) => w.explain(outcome.ending()),
        None => outcome.ending(),
    };
    let result = outcome.result;
    let gaps = crate::output::timeseries::gaps_table(series.gaps());
    let (series, events) = series.into_parts();
    let samples = series.rows() as u64;
    let (summary, files, plots) = match (writer, out) {
        (Some(w), Some(dir)) => {
            let written =
                close_run_folder(w, dir, &result, &ending, scn.output.plot).map_err(|error| {
                    Error::Output {
                        input: None,
                        context: Some(format!("writing results into {}", dir.display())),
                        error,
                    }
                })?;
            if let Some(error) = written.plot_error {
                return Err(Error::Plot {
                    dir: dir.to_path_buf(),
                    error,
                });
            }
            (
                written.paths.summary_text.clone(),
                Some(written.paths),
                written.plots,
            )
        }
        _ => {
            let text = summary_json(
                scn,
                &result,
                &ending,
                samples,
                &SummaryFiles::default(),
                &crate::output::new_run_id(),
                &crate::output::gaps_section(&[], gaps.rows()),
            );
            (text, None, Vec::new())
        }
    };
    let record = RunRecord {
        series,
        events,
        cycles,
        gaps,
        result,
        summary,
        files,
        plots,
    };
    match ending.status() {
        Status::Ok => Ok(record),
        _ if ending.reason == Some(Reason::Sigint) => Err(Error::Cancelled),
        _ => Err(Error::Ended {
            source: scn.source(),
            ending,
            record: Box::new(record),
        }),
    }
}

// ---------------------------------------------------------------------------------------------
// validate, resonance

/// The periodic steady state of `scn` compared with the predictors (`djkr validate`; its
/// `--json` is `finite_json` of the report).
pub fn validate(scn: &Scenario, opts: &Options) -> Result<ValidateReport, SteadyError> {
    let c = crosscheck::compare(&scn.plan(), opts)?;
    Ok(ValidateReport::new(&c))
}

/// The message of a force balance that fails (an internal inconsistency), if it does.
pub fn force_balance_violation(r: &ValidateReport) -> Option<String> {
    let fb = &r.force_balance;
    (!fb.holds).then(|| {
        format!(
            "internal inconsistency: the force balance <F> = m g - k(<x_s> - x_k) fails by {:.3e} (relative), above {:.0e}",
            fb.relative_error, fb.tolerance
        )
    })
}

/// Which frequency sweeps [`resonance`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sweeps {
    /// Increasing frequency.
    Up,
    /// Decreasing frequency.
    Down,
    /// Both, in parallel (up first in the results).
    Both,
}

impl Sweeps {
    /// `up`, `down` or `both`.
    pub fn parse(name: &str, text: &str) -> Result<Sweeps, Error> {
        match text {
            "up" => Ok(Sweeps::Up),
            "down" => Ok(Sweeps::Down),
            "both" => Ok(Sweeps::Both),
            _ => Err(Error::Invalid(format!(
                "{name} = {}: must be up, down or both",
                excerpt(text)
            ))),
        }
    }
}

/// A frequency response (`djkr resonance`).
#[derive(Debug)]
pub struct Resonance {
    /// The linearisation about the static state, or why there is none.
    pub linearisation: Result<Linearisation, String>,
    /// Whether harmonic balance ran alongside.
    pub harmonic_balance: bool,
    /// The sweeps, up first.
    pub sweeps: Vec<steady_sweep::Sweep>,
    /// Wall time of the sweeps (s).
    pub wall_s: f64,
}

impl Resonance {
    /// `resonance.csv`: every sweep's rows in one table.
    pub fn table(&self) -> Table {
        report::sweeps_table(&self.sweeps)
    }
}

/// The frequency response of `problem` (from [`Problem::from_plan`], at the base amplitude
/// wanted) over `freqs` (`lo`, `hi` in Hz, `n` frequencies) from `start`, by continuation in the
/// `which` directions, with harmonic balance alongside when `harmonic_balance`. `progress` sees
/// every point. A point whose steady state is not found is a row with its error; cancelled
/// through the problem's solver settings, each sweep ends at its next frequency with the points
/// done (the caller checks the flag).
pub fn resonance(
    problem: &Problem,
    start: &Initial,
    freqs: (f64, f64, usize),
    which: Sweeps,
    opts: &Options,
    harmonic_balance: bool,
    progress: &(dyn Fn(Direction, &SweepPoint) + Sync),
) -> Resonance {
    let linearisation = Linearisation::for_problem(problem, start).map_err(|e| e.to_string());
    let hb = linearisation.as_ref().ok().filter(|_| harmonic_balance);
    let fs = steady_sweep::frequencies(freqs.0, freqs.1, freqs.2);
    let t0 = std::time::Instant::now();
    let one = |d| steady_sweep::sweep(problem, start, &fs, d, opts, hb, progress);
    let sweeps = match which {
        Sweeps::Up => vec![one(Direction::Up)],
        Sweeps::Down => vec![one(Direction::Down)],
        Sweeps::Both => {
            let (u, d) = steady_sweep::sweep_both(problem, start, &fs, opts, hb, progress);
            vec![u, d]
        }
    };
    let wall_s = t0.elapsed().as_secs_f64();
    let harmonic_balance = hb.is_some();
    Resonance {
        linearisation,
        harmonic_balance,
        sweeps,
        wall_s,
    }
}

// ---------------------------------------------------------------------------------------------
// sweep

/// A study (`djkr sweep`) run to its end in memory: the table `sweep.csv` holds, one row per
/// run sorted by (point, member). `axes` are the swept keys ([`Axis`], parsed from `KEY=SPEC`
/// by [`Axis::parse`] as after `--set`), swept as the Cartesian grid, the first key slowest;
/// `ensemble` runs every point that many times with phases drawn from its seed; `jobs` 0 is
/// one per core. A raised `stop` abandons the sweep ([`Error::Cancelled`]).
///
/// ```no_run
/// use djkr::api;
/// use djkr::sweep::{Axis, Ensemble};
/// use djkr::ScenarioSource;
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let source = ScenarioSource::read("scenarios/paper-protocol-300hz.toml".as_ref())?;
/// let axes = vec![
///     Axis::parse("base.frequency=200,300,400")?,
///     Axis::parse("base.amplitude=10um:60um:6")?,
/// ];
/// let ensemble = Some(Ensemble { members: 8, seed: 1 });
/// let table = api::sweep(source, axes, ensemble, 2, None)?; // the columns of sweep.csv
/// let amplification = table.column("pull_off_amplification");
/// # let _ = amplification;
/// # Ok(()) }
/// ```
pub fn sweep(
    source: crate::scenario::parse::ScenarioSource,
    axes: Vec<Axis>,
    ensemble: Option<Ensemble>,
    jobs: usize,
    stop: Option<&AtomicBool>,
) -> Result<Table, Error> {
    let grid = Grid::new(axes, false)?;
    let sweep = Sweep::new(source, grid, ensemble)?;
    let rows = run_all(
        &sweep,
        &RunOptions {
            jobs,
            stop,
            keep_runs: None,
        },
    );
    if stop.is_some_and(|f| f.load(std::sync::atomic::Ordering::SeqCst)) {
        return Err(Error::Cancelled);
    }
    Ok(rows_table(&sweep.key_columns(), &rows))
}

/// A fit of measured data ([`fit`]): the scenario, the data, the keys to free and the options,
/// all typed (the front ends parse their text: [`crate::fit::FreeKey::parse_all`],
/// `overrides`, [`crate::fit::FitData::parse`]).
#[derive(Debug, Clone)]
pub struct FitRequest {
    /// The scenario file, read and parsed.
    pub source: crate::scenario::parse::ScenarioSource,
    /// The measured data.
    pub data: crate::fit::FitData,
    /// The keys to fit, with their bounds.
    pub free: Vec<crate::fit::FreeKey>,
    /// Overrides: of a free key its starting value, of another key its value for every row.
    pub set: Vec<Override>,
    /// An ensemble per row: `(members, seed)` (chaotic rigs).
    pub ensemble: Option<(usize, u64)>,
    /// Threads (0: one per core).
    pub jobs: usize,
    /// Most iterations of each optimisation.
    pub max_iterations: usize,
    /// Starting points.
    pub starts: usize,
    /// Profile-likelihood intervals for every key.
    pub profile: bool,
    /// An output folder for the fit's files, and whether to overwrite files of those names that
    /// djkr did not write.
    pub out: Option<(PathBuf, bool)>,
}

impl FitRequest {
    /// A fit of `data` on `source` for `free`, with the defaults: no overrides, no ensemble, one
    /// thread per core, 30 iterations, one start, no profiles, no folder.
    pub fn new(
        source: crate::scenario::parse::ScenarioSource,
        data: crate::fit::FitData,
        free: Vec<crate::fit::FreeKey>,
    ) -> Self {
        FitRequest {
            source,
            data,
            free,
            set: Vec::new(),
            ensemble: None,
            jobs: 0,
            max_iterations: 30,
            starts: 1,
            profile: false,
            out: None,
        }
    }
}

/// What [`fit`] gives: the report `fit.json` holds (with the covariance in the keys' units) and
/// the residuals' table as `residuals.csv` holds it (column name with unit, values).
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The report (`fit.json`).
    pub report: crate::fit::FitReport,
    /// The columns of `residuals.csv`.
    pub residuals: Vec<(String, Column)>,
    /// The fit as `djkr predict` reads it from the fit's folder, made from the texts of its
    /// files (the same whether or not they were written), or why it could not be.
    pub fitted: Result<crate::fit::FitFolder, String>,
}

/// Fit the request's data: with an output folder, it is claimed and locked before the fit
/// starts and the fit's files are written there. A stop raised through `stop` ends it as
/// [`Error::Cancelled`] (after writing the best estimate so far, with a folder).
pub fn fit(req: &FitRequest, stop: Option<&AtomicBool>) -> Result<FitResult, Error> {
    use crate::fit::{self as f, FitOptions, ForwardModel};
    let (source, free, ensemble) = (&req.source, &req.free, req.ensemble);
    let (starts, fixed): (Vec<Override>, Vec<Override>) = req
        .set
        .iter()
        .cloned()
        .partition(|o| free.iter().any(|k| k.key == o.key()));
    let with_starts: Vec<Override> = fixed.iter().chain(&starts).cloned().collect();
    // The scenario with the overrides must parse (its errors are the user's).
    source.scenario(&with_starts)?;
    let x0 = free
        .iter()
        .map(|k| f::fitted::initial_value(source, &starts, k).map_err(Error::Invalid))
        .collect::<Result<Vec<_>, _>>()?;
    f::check_start(free, &x0).map_err(|e| Error::Invalid(e.to_string()))?;
    if ensemble.is_some_and(|e| e.0 == 0) {
        return Err(Error::Invalid(
            "ensemble = 0: must be a whole number >= 1 (members per row)".into(),
        ));
    }
    if req.starts == 0 {
        return Err(Error::Invalid(
            "starts = 0: must be a whole number >= 1 (starting points)".into(),
        ));
    }
    let model = ForwardModel::new(
        source.clone(),
        req.data.clone(),
        free.iter().map(|k| k.key).collect(),
        fixed.clone(),
        ensemble,
        req.jobs,
    )
    .map_err(Error::Invalid)?;
    // The folder is claimed and locked before the fit starts, as the command line does.
    let _lock = match &req.out {
        Some((dir, force)) => {
            let output = |error| Error::Output {
                input: Some("out"),
                context: None,
                error,
            };
            crate::output::folder::claim(dir, &f::files::FILES, *force).map_err(output)?;
            if *force {
                crate::output::folder::force_overwrite(dir);
            }
            crate::output::folder::DirLock::acquire(dir).map_err(output)?
        }
        None => None,
    };
    let opts = FitOptions {
        max_iterations: req.max_iterations,
        starts: req.starts,
        profile: req.profile,
        stop,
    };
    // A stop before the first evaluation ended is a cancellation, as a stop after it.
    let outcome = f::fit(&model, free, &x0, opts, &mut |_| {}).map_err(|e| {
        if e.stopped {
            Error::Cancelled
        } else {
            Error::Invalid(e.to_string())
        }
    })?;
    if let Some((dir, _)) = &req.out {
        f::files::write(
            dir,
            source,
            &fixed,
            free,
            &model,
            &outcome,
            stop,
            &mut || {},
        )
        .map_err(|m| {
            Error::Invalid(format!(
                "{}={}: {m}",
                crate::error::input("out"),
                dir.display()
            ))
        })?;
    }
    if outcome.report.interrupted {
        return Err(Error::Cancelled);
    }
    let fitted = f::files::texts(source, &fixed, free, &model, &outcome).and_then(
        |[json, residuals, toml]| {
            let toml = crate::scenario::parse::ScenarioSource::parse(
                &toml,
                "fitted.toml",
                source.base_dir(),
            )
            .map_err(|e| e.to_string())?;
            f::predict::FitFolder::parse("(the fit's result)", &json, toml, &residuals)
                .map_err(|e| e.to_string())
        },
    );
    Ok(FitResult {
        fitted,
        residuals: f::residuals::residual_columns(&model, &outcome),
        report: outcome.report,
    })
}

/// Predict from a fit with uncertainty, as `djkr predict`: the report `prediction.json` holds
/// ([`crate::fit::PredictReport::columns`] gives `prediction.csv`'s columns). The request is
/// checked first; with an output folder `(folder, force)`, it is then claimed and locked and the
/// prediction's files are written there. A stop raised through `stop` ends it as
/// [`Error::Cancelled`], nothing written.
pub fn predict(
    fit: &crate::fit::FitFolder,
    req: &crate::fit::PredictRequest,
    out: Option<(PathBuf, bool)>,
    stop: Option<&AtomicBool>,
) -> Result<crate::fit::PredictReport, Error> {
    use crate::fit::predict as p;
    p::check(fit, req)?;
    let output = |error| Error::Output {
        input: Some("out"),
        context: None,
        error,
    };
    let _lock = match &out {
        Some((dir, force)) => {
            crate::output::folder::claim(dir, &p::FILES, *force).map_err(output)?;
            if *force {
                crate::output::folder::force_overwrite(dir);
            }
            crate::output::folder::DirLock::acquire(dir).map_err(output)?
        }
        None => None,
    };
    let report = p::predict(fit, req, stop, &mut || {})?;
    if let Some((dir, _)) = &out {
        p::write(dir, &report, fit).map_err(|m| {
            Error::Invalid(format!(
                "{}={}: {m}",
                crate::error::input("out"),
                dir.display()
            ))
        })?;
    }
    Ok(report)
}

/// Design new measurements from a fit, as `djkr design`: which K of the candidates, added to
/// the fit's data, pin the free keys down best, and the report `design.json` holds
/// ([`crate::fit::DesignReport::columns`] gives `design.csv`'s columns). The request is typed
/// (the front ends parse their text: [`crate::sweep::Axis::parse`],
/// [`crate::fit::Sigma::parse`], [`crate::fit::Target::parse`]) and checked first; with an output
/// folder `(folder, force)`, it is then claimed and locked and the design's files are written
/// there. A stop raised through `stop` ends it as [`Error::Cancelled`], nothing written.
pub fn design(
    fit: &crate::fit::FitFolder,
    req: &crate::fit::DesignRequest,
    out: Option<(PathBuf, bool)>,
    stop: Option<&AtomicBool>,
) -> Result<crate::fit::DesignReport, Error> {
    design_with_progress(fit, req, out, stop, &mut || {})
}

/// [`design`], calling `on_run` as each forward run ends (the command line counts them).
pub fn design_with_progress(
    fit: &crate::fit::FitFolder,
    req: &crate::fit::DesignRequest,
    out: Option<(PathBuf, bool)>,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<crate::fit::DesignReport, Error> {
    use crate::fit::design as d;
    d::check(fit, req)?;
    // A folder that refuses the design is named as the input that gave it; a folder another
    // process holds is named by its own message, which says to choose another «out».
    let _lock = match &out {
        Some((dir, force)) => {
            crate::output::folder::claim(dir, &d::FILES, *force).map_err(|error| {
                Error::Output {
                    input: Some("out"),
                    context: None,
                    error,
                }
            })?;
            if *force {
                crate::output::folder::force_overwrite(dir);
            }
            crate::output::folder::DirLock::acquire(dir).map_err(|error| Error::Output {
                input: None,
                context: None,
                error,
            })?
        }
        None => None,
    };
    let report = d::design(fit, req, stop, on_run)?;
    if let Some((dir, _)) = &out {
        d::write(&report, dir)?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {

    /// The sizes docs/guide/unattended.md ("Memory") gives for what a run holds in memory.
    #[test]
    fn the_documented_sizes_are_the_counted_ones() {
        assert_eq!(SAMPLE_BYTES, 104);
        // The estimate before a run counts a sample's peak, at most twice its data (a column's
        // buffer doubles when full) plus a little.
        assert!(crate::memory::SAMPLE_BYTES >= 2.0 * SAMPLE_BYTES as f64);
        assert_eq!(EVENT_BYTES, 120);
        assert_eq!(CYCLE_BYTES, 192);
    }
    #[test]
    fn a_contact_wider_than_the_sphere_is_refused() {
        let (m, law) = default_material();
        let e = pull_off_at(&m, &law, 2513.0, PullOffMethod::Exact { a_amp: 1e300 }).unwrap_err();
        assert!(e
            .to_string()
            .starts_with("a_amp = 1e300: the contact radius would exceed"));
        let e = cycle_args(
            &m,
            &law,
            Arg::new("freq", "400"),
            Arg::new("a_mean", "1mm"),
            Arg::new("a_amp", "1"),
        )
        .unwrap_err();
        assert_eq!(e.name, "a_amp");
    }

    #[test]
    fn a_non_finite_result_names_its_inputs() {
        let inputs = [Arg::new("--freq", "400"), Arg::new("--a-amp", "1mm")];
        assert!(finite_result(&inputs, &[("F_m", 1.0)]).is_ok());
        let e = finite_result(&inputs, &[("F_m", 1.0), ("delta_m", f64::NAN)]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--freq = 400, --a-amp = 1mm: the result is not finite (delta_m = NaN): these inputs \
             together are beyond what the computation carries in double precision"
        );
    }

    use super::*;

    #[test]
    fn numbers_that_round_to_zero_have_no_sign() {
        assert_eq!(no_negative_zero("-0.000000 mm"), "0.000000 mm");
        assert_eq!(
            no_negative_zero("a = -0.00000, b = -0.001"),
            "a = 0.00000, b = -0.001"
        );
        assert_eq!(
            no_negative_zero("-0 and -0.0e0 and x-0.0"),
            "0 and -0.0e0 and x-0.0"
        );
        assert_eq!(no_negative_zero("δ_c -0.00000 µm"), "δ_c 0.00000 µm");
        assert_eq!(fmt_len(-1e-18), "0.000000 nm");
        assert_eq!(fmt_force(-0.0), "0.000000 mN");
    }
}
