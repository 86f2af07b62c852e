//! The measured data of a fit: a CSV file in djkr's own header style (`name [unit]`).
//!
//! Columns:
//! - one per condition, named by its scenario key as `--set` takes it (`base.frequency [Hz]`,
//!   `base.amplitude [um]`, `stage[3].speed [m/s]`); numeric keys are read in the header's unit
//!   (any unit the key accepts, or its SI unit as sweep.csv writes it) and held in SI; a text key
//!   (`solver.method`) takes its cells as typed;
//! - one observable, named as in `sweep.csv` ([`Observable`]); with several, the caller names the
//!   one to fit and the others are ignored;
//! - optionally `sigma [unit of the observable]`, the observation's standard deviation (> 0).
//!
//! Lines starting with `#` are comments. A bad file is refused naming the file, the line (as an
//! editor numbers it: CRLF files, blank and comment lines counted) and the column, as the scenario
//! parser does. A message quotes at most [`djkr_core::text::EXCERPT_CHARS`] characters of a cell, and
//! a header cell only when djkr recognises it (see [`shown_cell`]). A row whose
//! |observed| / sigma passes [`MAX_WEIGHTED`] is refused: its χ² could not be finite. The file is
//! read with a size limit of 16 MiB ([`crate::input::InputKind::FitData`]) and holds at most
//! [`MAX_ROWS`] rows.

use std::path::Path;

use thiserror::Error;

use crate::input::{read_text, show_limit, InputKind};
use crate::scenario::overrides::SetKey;
use crate::sweep::spec::{key_kind, KeyKind};
use crate::words::input_value;
use djkr_core::text::excerpt;
use djkr_core::units::{parse_quantity, Dimension};

/// An observable a fit can use: a numeric column of `sweep.csv` that a run's physics gives
/// (not its bookkeeping such as `steps` or `wall_s`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observable {
    /// `pull_off_force [N]`.
    PullOffForce,
    /// `pull_off_amplification [1]`.
    PullOffAmplification,
    /// `pull_off_time [s]`.
    PullOffTime,
    /// `force_mean [N]`.
    ForceMean,
    /// `delta_mean [m]`.
    DeltaMean,
    /// `delta_amp [m]`.
    DeltaAmp,
}

impl Observable {
    /// Every observable, in `sweep.csv`'s column order.
    pub const ALL: [Observable; 6] = [
        Observable::PullOffForce,
        Observable::PullOffAmplification,
        Observable::PullOffTime,
        Observable::ForceMean,
        Observable::DeltaMean,
        Observable::DeltaAmp,
    ];

    /// The column name in `sweep.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Observable::PullOffForce => "pull_off_force",
            Observable::PullOffAmplification => "pull_off_amplification",
            Observable::PullOffTime => "pull_off_time",
            Observable::ForceMean => "force_mean",
            Observable::DeltaMean => "delta_mean",
            Observable::DeltaAmp => "delta_amp",
        }
    }

    /// The SI unit of the column in `sweep.csv`.
    pub fn unit(self) -> &'static str {
        match self {
            Observable::PullOffForce | Observable::ForceMean => "N",
            Observable::PullOffAmplification => "1",
            Observable::PullOffTime => "s",
            Observable::DeltaMean | Observable::DeltaAmp => "m",
        }
    }

    /// The units a data file may give the column in.
    pub fn dimension(self) -> Dimension {
        match self {
            Observable::PullOffForce | Observable::ForceMean => Dimension::Force,
            Observable::PullOffAmplification => Dimension::Dimensionless,
            Observable::PullOffTime => Dimension::Time,
            Observable::DeltaMean | Observable::DeltaAmp => Dimension::Length,
        }
    }

    /// The observable named `name` (`pull_off_amplification`).
    pub fn parse(name: &str) -> Option<Observable> {
        Observable::ALL
            .into_iter()
            .find(|o| o.name() == name.trim())
    }

    /// The observable's value in a run's numbers (the same number `sweep.csv` holds).
    pub fn of(self, n: &crate::sweep::RunNumbers) -> f64 {
        match self {
            Observable::PullOffForce => n.pull_off_force,
            Observable::PullOffAmplification => n.pull_off_amplification,
            Observable::PullOffTime => n.pull_off_time,
            Observable::ForceMean => n.force_mean,
            Observable::DeltaMean => n.delta_mean,
            Observable::DeltaAmp => n.delta_amp,
        }
    }

    /// The names, for messages.
    pub fn list() -> String {
        Observable::ALL
            .iter()
            .map(|o| format!("{} [{}]", o.name(), o.unit()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A condition column: a scenario key, with its SI unit (`None`: a text key).
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// The key.
    pub key: SetKey,
    /// The SI unit of its values (`None`: text).
    pub unit: Option<&'static str>,
}

/// A condition's value in one row: SI number, or text as typed.
#[derive(Debug, Clone, PartialEq)]
pub enum CondValue {
    /// SI value of a numeric key.
    Num(f64),
    /// Text of a text key.
    Text(String),
}

/// One row of data.
#[derive(Debug, Clone, PartialEq)]
pub struct DataRow {
    /// The line of the file (from 1, the header being line 1).
    pub line: u64,
    /// The conditions, in the order of [`FitData::conditions`].
    pub conditions: Vec<CondValue>,
    /// The observed value (SI).
    pub observed: f64,
    /// Its standard deviation (SI), when the file has a `sigma` column.
    pub sigma: Option<f64>,
}

/// A data file, read.
#[derive(Debug, Clone, PartialEq)]
pub struct FitData {
    /// The file's name, for messages.
    pub name: String,
    /// The condition columns.
    pub conditions: Vec<Condition>,
    /// The observable fitted.
    pub observable: Observable,
    /// Whether the file gives `sigma`.
    pub has_sigma: bool,
    /// The fitted observable's column, for messages: its number (from 1) and its header cell.
    pub observable_column: (usize, String),
    /// The sigma column, if any, for messages: its number (from 1) and its header cell.
    pub sigma_column: Option<(usize, String)>,
    /// The rows.
    pub rows: Vec<DataRow>,
}

/// A data file that cannot be used: the message names the file, and the line and column where
/// one is at fault.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{0}")]
pub struct DataError(pub String);

/// Most rows a data file may hold (each is at least one run per evaluation).
pub const MAX_ROWS: usize = 100_000;

/// A header cell `name [unit]`: the name and the unit (`None` without brackets).
fn split_header(cell: &str) -> (String, Option<String>) {
    let t = cell.trim();
    if let Some(open) = t.rfind('[') {
        if t.ends_with(']') {
            let name = t[..open].trim().to_string();
            let unit = t[open + 1..t.len() - 1].trim().to_string();
            return (name, Some(unit));
        }
    }
    (t.to_string(), None)
}

/// The factor from `unit` to SI for values of dimension `dim` (`si` is the SI unit as sweep.csv
/// writes it: `1` for a bare number). An absent unit means SI. `name` is a column name djkr
/// recognised; the unit, read from the file, is quoted as [`excerpt`] cuts it.
fn unit_factor(
    name: &str,
    unit: Option<&str>,
    dim: Option<Dimension>,
    si: &str,
) -> Result<f64, String> {
    let Some(u) = unit.map(str::trim).filter(|u| !u.is_empty()) else {
        return Ok(1.0);
    };
    if u == si || (si == "1" && u == "1") {
        return Ok(1.0);
    }
    let shown = excerpt(u);
    let dim = dim.unwrap_or(Dimension::Dimensionless);
    if dim == Dimension::Dimensionless {
        return Err(format!(
            "unit [{shown}]: {name} is a plain number; write [1] or no unit"
        ));
    }
    parse_quantity(name, &format!("1{u}"), dim).map_err(|_| {
        let units: Vec<&str> = dim.units().iter().map(|(u, _)| *u).collect();
        format!(
            "unit [{shown}]: {name} takes one of the units {} (SI: {si})",
            units.join(", ")
        )
    })
}

/// The largest |observed| / σ a row may have (σ = 1 in the observable's SI unit without a sigma
/// column). χ² sums ((observed − predicted)/σ)² over at most [`MAX_ROWS`] rows: with
/// |observed|/σ and |predicted|/σ at most 1e150 each, a term is at most 4e300 and the sum at most
/// 4e305, finite; an observable of 1e308 (or a σ of 1e-308) gives χ² = ∞ whatever the model
/// predicts, so such a row is refused before anything runs. No observable djkr produces comes
/// near: forces, lengths and times of a rig are far below 1e150 in SI, and so are their ratios
/// to any σ a measurement has.
pub const MAX_WEIGHTED: f64 = 1e150;

/// Physical line numbers, as an editor shows them, of the records the CSV reader returns. The
/// reader's own count ends a line at `\r` as well as at `\n` (a CRLF file counted half its
/// lines) and its record positions start where it began skipping blank and comment lines (a
/// record after a comment took the comment's line); so the line is counted here from the
/// record's position: skip what the reader skips (line breaks, lines starting with `#`, a
/// byte-order mark at the start), then count `\n`, `\r\n` and a lone `\r` as one line break
/// each. The count is incremental (records come in order), so a file is scanned once.
struct Lines<'a> {
    text: &'a [u8],
    /// Bytes counted so far.
    at: usize,
    /// The line at byte `at` (from 1).
    line: u64,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Lines<'a> {
        Lines {
            text: text.as_bytes(),
            at: 0,
            line: 1,
        }
    }

    /// The line of the record whose position (as the reader gives it) is byte `from`.
    fn of_record(&mut self, from: usize) -> u64 {
        let t = self.text;
        let mut s = from.max(self.at);
        if s == 0 && t.starts_with("\u{feff}".as_bytes()) {
            s = 3;
        }
        loop {
            match t.get(s) {
                Some(b'\r' | b'\n') => s += 1,
                Some(b'#') => {
                    while t.get(s).is_some_and(|c| !matches!(c, b'\r' | b'\n')) {
                        s += 1;
                    }
                }
                _ => break,
            }
        }
        for i in self.at..s.min(t.len()) {
            match t[i] {
                b'\n' => self.line += 1,
                b'\r' if t.get(i + 1) != Some(&b'\n') => self.line += 1,
                _ => {}
            }
        }
        self.at = s;
        self.line
    }
}

/// A header cell as messages show it. A cell djkr recognises as a column name (an observable,
/// `sigma`, a scenario key, another column of sweep.csv) or as an attempt at a key (its section is one djkr knows:
/// `base.wobble`) is quoted, cut by [`excerpt`]; any other is described by its length alone,
/// since a file that is not a data file at all (`djkr fit /etc/shadow`) must not have its first
/// line shown.
fn shown_cell(cell: &str) -> String {
    let (name, _) = split_header(cell);
    let head = name.split(['.', '[']).next().unwrap_or("");
    let recognised = name == "sigma"
        || Observable::parse(&name).is_some()
        || (name.contains('.') && crate::scenario::keys::SECTIONS.contains(&head))
        || crate::sweep::row::row_schema(&[])
            .iter()
            .any(|f| f.name == name);
    if recognised {
        format!("'{}'", excerpt(cell.trim()))
    } else {
        format!(
            "(a header cell of {} characters, not shown)",
            cell.trim().chars().count()
        )
    }
}

impl FitData {
    /// Read a data file; `observable` names the observable column to fit (needed when the file
    /// has several). The file goes through [`crate::input::read_text`]: a FIFO, a device or a
    /// directory is refused at once, naming what it is, and so is a file larger than
    /// [`InputKind::FitData`]'s limit (16 MiB).
    pub fn read(path: &Path, observable: Option<&str>) -> Result<FitData, DataError> {
        let name = path.display().to_string();
        let text =
            read_text(path, InputKind::FitData).map_err(|e| DataError(format!("{name}: {e}")))?;
        FitData::parse(&text, &name, observable)
    }

    /// [`FitData::read`] on a file's text (`name` names it in messages), held to the same size
    /// limit.
    pub fn parse(text: &str, name: &str, observable: Option<&str>) -> Result<FitData, DataError> {
        let fail = |m: String| DataError(format!("{name}: {m}"));
        let limit = InputKind::FitData.limit();
        if text.len() as u64 > limit {
            return Err(fail(format!(
                "{} bytes: larger than {limit} bytes ({}), the limit for a {}",
                text.len(),
                show_limit(limit),
                InputKind::FitData.name()
            )));
        }
        let wanted = match observable {
            Some(o) => Some(Observable::parse(o).ok_or_else(|| {
                fail(format!(
                    "{}: djkr does not produce it; it produces {}",
                    input_value("observable", &excerpt(o)),
                    Observable::list()
                ))
            })?),
            None => None,
        };
        let mut lines = Lines::new(text);
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let header_record = rdr
            .headers()
            .map_err(|e| fail(format!("header: {e}")))?
            .clone();
        let hl = lines.of_record(header_record.position().map_or(0, |p| p.byte() as usize));
        let header: Vec<String> = header_record.iter().map(str::to_string).collect();
        if header.iter().all(|h| h.trim().is_empty()) {
            return Err(fail(
                "empty file: expected a header line such as `base.amplitude [um],pull_off_amplification [1],sigma [1]`"
                    .into(),
            ));
        }
        // What each column is.
        enum Col {
            Cond(usize, f64),
            Obs(f64),
            Sigma,
        }
        let mut cols = Vec::new();
        let mut conditions: Vec<Condition> = Vec::new();
        let mut observables: Vec<(Observable, Option<String>)> = Vec::new();
        let mut sigma_unit: Option<Option<String>> = None;
        for (j, cell) in header.iter().enumerate() {
            let col = j + 1;
            let (cname, unit) = split_header(cell);
            let at = |m: String| fail(format!("line {hl}, column {col} {}: {m}", shown_cell(cell)));
            if cname.is_empty() {
                return Err(at("empty column name".into()));
            }
            if cname == "sigma" {
                if sigma_unit.is_some() {
                    return Err(at("a second sigma column".into()));
                }
                sigma_unit = Some(unit);
                cols.push(None);
                continue;
            }
            if let Some(o) = Observable::parse(&cname) {
                if observables.iter().any(|(p, _)| *p == o) {
                    return Err(at(format!("a second {} column", o.name())));
                }
                observables.push((o, unit));
                cols.push(None);
                continue;
            }
            let key = SetKey::parse(&cname).map_err(|_| {
                at(format!(
                    "neither a scenario key (as «set» takes it: base.amplitude, stage[3].speed) \
                     nor an observable djkr produces ({}), nor sigma",
                    Observable::list()
                ))
            })?;
            if conditions.iter().any(|c| c.key == key) {
                return Err(at(format!("a second column for {key}")));
            }
            let (unit_si, factor) = match key_kind(&key) {
                Some(KeyKind::Number { dim, unit: si }) => (
                    Some(si),
                    unit_factor(&cname, unit.as_deref(), dim, si).map_err(at)?,
                ),
                _ => {
                    if unit.is_some() {
                        return Err(at(format!("{key} is a text key: give no unit")));
                    }
                    (None, 1.0)
                }
            };
            conditions.push(Condition { key, unit: unit_si });
            cols.push(Some(Col::Cond(conditions.len() - 1, factor)));
        }
        let observable = match (wanted, observables.len()) {
            (Some(o), _) => {
                if !observables.iter().any(|(p, _)| *p == o) {
                    return Err(fail(format!(
                        "{}: the file has no {} column{}",
                        input_value("observable", o.name()),
                        o.name(),
                        if observables.is_empty() {
                            String::new()
                        } else {
                            format!(
                                " (it has {})",
                                observables
                                    .iter()
                                    .map(|(p, _)| p.name())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        }
                    )));
                }
                o
            }
            (None, 1) => observables[0].0,
            (None, 0) => {
                return Err(fail(format!(
                    "line {hl}: no observable column; name one as sweep.csv does: {}",
                    Observable::list()
                )))
            }
            (None, _) => {
                return Err(fail(format!(
                    "the file has several observables ({}): name the one to fit with «observable»",
                    observables
                        .iter()
                        .map(|(p, _)| p.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            }
        };
        // Units of the fitted observable and of sigma.
        let obs_unit = observables
            .iter()
            .find(|(p, _)| *p == observable)
            .and_then(|(_, u)| u.clone());
        let obs_col_name = format!(
            "{}{}",
            observable.name(),
            obs_unit
                .as_ref()
                .map(|u| format!(" [{}]", excerpt(u)))
                .unwrap_or_default()
        );
        let obs_factor = unit_factor(
            observable.name(),
            obs_unit.as_deref(),
            Some(observable.dimension()),
            observable.unit(),
        )
        .map_err(|m| fail(format!("line {hl}, column '{obs_col_name}': {m}")))?;
        let sigma_factor = match &sigma_unit {
            Some(u) => unit_factor(
                "sigma",
                u.as_deref(),
                Some(observable.dimension()),
                observable.unit(),
            )
            .map_err(|m| {
                fail(format!(
                    "line {hl}, column sigma: {m} (sigma is in the unit of {})",
                    observable.name()
                ))
            })?,
            None => 1.0,
        };
        let mut obs_col = 0;
        let mut sigma_col = None;
        for (j, cell) in header.iter().enumerate() {
            let (cname, _) = split_header(cell);
            if cols[j].is_none() {
                cols[j] = if cname == "sigma" {
                    sigma_col = Some(j);
                    Some(Col::Sigma)
                } else if Observable::parse(&cname) == Some(observable) {
                    obs_col = j;
                    Some(Col::Obs(obs_factor))
                } else {
                    None
                };
            }
        }
        let mut rows = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| fail(format!("{e}")))?;
            let line = lines.of_record(rec.position().map_or(0, |p| p.byte() as usize));
            if rec.iter().all(|c| c.is_empty()) {
                continue;
            }
            if rec.len() != header.len() {
                return Err(fail(format!(
                    "line {line}: {} cells for {} columns",
                    rec.len(),
                    header.len()
                )));
            }
            let at = |j: usize, m: String| {
                fail(format!(
                    "line {line}, column {} '{}': {m}",
                    j + 1,
                    excerpt(header[j].trim())
                ))
            };
            let mut conds = vec![CondValue::Num(f64::NAN); conditions.len()];
            let mut observed = f64::NAN;
            let mut sigma = None;
            for (j, col) in cols.iter().enumerate() {
                let cell = rec.get(j).unwrap_or("");
                // A number in the header's unit, held in SI.
                let number = |what: &str, factor: f64| -> Result<f64, DataError> {
                    let x: f64 = cell.parse().map_err(|_| {
                        at(
                            j,
                            format!(
                                "'{}' is not a number ({what}, in the header's unit)",
                                excerpt(cell)
                            ),
                        )
                    })?;
                    if !x.is_finite() {
                        return Err(at(j, format!("'{}' is not a finite number", excerpt(cell))));
                    }
                    let si = x * factor;
                    if !si.is_finite() {
                        return Err(at(
                            j,
                            format!(
                                "'{}' in the header's unit is beyond the largest number in SI",
                                excerpt(cell)
                            ),
                        ));
                    }
                    Ok(si)
                };
                match col {
                    None => {}
                    Some(Col::Cond(i, factor)) => {
                        conds[*i] = if conditions[*i].unit.is_some() {
                            CondValue::Num(number("a condition", *factor)?)
                        } else if cell.is_empty() {
                            return Err(at(j, "empty cell".into()));
                        } else {
                            CondValue::Text(cell.to_string())
                        };
                    }
                    Some(Col::Obs(factor)) => observed = number("the observable", *factor)?,
                    Some(Col::Sigma) => {
                        let s = number("sigma", sigma_factor)?;
                        if s <= 0.0 {
                            return Err(at(
                                j,
                                format!(
                                    "sigma '{}' must be > 0 (a standard deviation)",
                                    excerpt(cell)
                                ),
                            ));
                        }
                        if s < f64::MIN_POSITIVE {
                            return Err(at(
                                j,
                                format!(
                                    "sigma '{}' is subnormal (below 2.2e-308 in SI): it has lost \
                                 digits and its reciprocal overflows",
                                    excerpt(cell)
                                ),
                            ));
                        }
                        sigma = Some(s);
                    }
                }
            }
            // χ² must be able to be finite (see MAX_WEIGHTED): the cell at fault is sigma when
            // the observable alone is within the bound.
            let weighted = observed.abs() / sigma.unwrap_or(1.0);
            if weighted > MAX_WEIGHTED {
                let shown = |j: usize| excerpt(rec.get(j).unwrap_or("").trim());
                return Err(match sigma_col {
                    Some(sc) if observed.abs() <= MAX_WEIGHTED => at(
                        sc,
                        format!(
                            "sigma '{}' is too small for the observed '{}': |observed| / sigma = \
                         {weighted:.3e} (SI) passes {MAX_WEIGHTED:e}, beyond which chi2 cannot \
                         be finite",
                            shown(sc),
                            shown(obs_col)
                        ),
                    ),
                    _ => {
                        at(
                            obs_col,
                            format!(
                        "'{}' is too large to fit: |observed| / sigma = {weighted:.3e} (SI{}) \
                         passes {MAX_WEIGHTED:e}, beyond which chi2 cannot be finite",
                        shown(obs_col),
                        if sigma_col.is_some() { "" } else { ", sigma = 1 without a sigma column" }
                    ),
                        )
                    }
                });
            }
            rows.push(DataRow {
                line,
                conditions: conds,
                observed,
                sigma,
            });
            if rows.len() > MAX_ROWS {
                return Err(fail(format!("more than {MAX_ROWS} rows")));
            }
        }
        if rows.is_empty() {
            return Err(fail("no data rows after the header".into()));
        }
        Ok(FitData {
            name: name.to_string(),
            conditions,
            observable,
            has_sigma: sigma_unit.is_some(),
            observable_column: (obs_col + 1, excerpt(header[obs_col].trim())),
            sigma_column: sigma_col.map(|j| (j + 1, excerpt(header[j].trim()))),
            rows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn observables_are_named_as_in_sweep_csv() {
        // The names and units must be sweep.csv's own columns.
        let fields = crate::sweep::row::row_schema(&[]);
        for o in Observable::ALL {
            let f = fields
                .iter()
                .find(|f| f.name == o.name())
                .unwrap_or_else(|| panic!("{} not in sweep.csv", o.name()));
            assert_eq!(f.csv_header(), format!("{} [{}]", o.name(), o.unit()));
        }
    }

    #[test]
    fn units_in_the_header_are_honoured() {
        let d = FitData::parse(
            "# a comment\nbase.amplitude [um],base.frequency [kHz],pull_off_force [mN],sigma [uN]\n\
             10,0.2,-100,50\n20,0.3,-110,60\n",
            "d.csv",
            None,
        )
        .unwrap();
        assert_eq!(d.observable, Observable::PullOffForce);
        assert_eq!(d.rows.len(), 2);
        assert_eq!(d.rows[0].conditions[0], CondValue::Num(10.0 * 1e-6));
        assert_eq!(d.rows[1].conditions[1], CondValue::Num(0.3 * 1e3));
        assert!((d.rows[0].observed + 0.1).abs() < 1e-15);
        assert!((d.rows[1].sigma.unwrap() - 60e-6).abs() < 1e-18);
        assert_eq!(d.rows[1].line, 4);
    }

    #[test]
    fn bad_files_are_refused_naming_line_and_column() {
        let e = |t: &str, o: Option<&str>| FitData::parse(t, "d.csv", o).unwrap_err().0;
        let m = e(
            "base.amplitude [m],pull_off_amplification [1]\n1e-5,1.7\n2e-5,x\n",
            None,
        );
        assert!(m.contains("line 3, column 2"), "{m}");
        let m = e(
            "base.amplitude [Hz],pull_off_amplification [1]\n1,1\n",
            None,
        );
        assert!(m.contains("line 1, column 1") && m.contains("[Hz]"), "{m}");
        let m = e("base.wobble,pull_off_amplification [1]\n1,1\n", None);
        assert!(m.contains("neither a scenario key"), "{m}");
        let m = e("base.amplitude [m],steps [1]\n1,1\n", None);
        assert!(m.contains("column 2 'steps"), "{m}");
        let m = e(
            "base.amplitude [m],pull_off_force [N],force_mean [N]\n1,1,1\n",
            None,
        );
        assert!(m.contains("«observable»"), "{m}");
        let m = e(
            "base.amplitude [m],pull_off_force [N]\n1,1\n",
            Some("wall_s"),
        );
        assert!(m.contains("does not produce"), "{m}");
        let m = e(
            "base.amplitude [m],pull_off_force [N],sigma [N]\n1,1,0\n",
            None,
        );
        assert!(m.contains("line 2, column 3") && m.contains("> 0"), "{m}");
        let m = e("base.amplitude [m],pull_off_force [N]\n1,1,3\n", None);
        assert!(m.contains("line 2"), "{m}");
        let m = e("base.amplitude [m],pull_off_force [N]\n", None);
        assert!(m.contains("no data rows"), "{m}");
    }

    /// The line of an error is the one an editor shows: CRLF and lone-CR line ends, blank
    /// lines, comment lines (before the header too), a byte-order mark and a quoted cell
    /// holding a line break all counted.
    #[test]
    fn errors_name_the_physical_line() {
        let line_of = |t: &str| {
            let m = FitData::parse(t, "d.csv", None).unwrap_err().0;
            let at = m.find("line ").unwrap_or_else(|| panic!("{m}")) + 5;
            m[at..]
                .split([',', ':'])
                .next()
                .unwrap()
                .parse::<u64>()
                .unwrap()
        };
        let h = "base.amplitude [um],pull_off_amplification [1]";
        for (t, want) in [
            (format!("{h}\r\n5,x\r\n"), 2),
            (format!("{h}\r\n\r\n5,2\r\n\r\n10,x\r\n"), 5),
            (format!("{h}\n\n5,2\n  \n10,x\n"), 5),
            (format!("{h}\n5,2\n# a comment\n10,x\n"), 4),
            (format!("{h}\r5,2\r10,x\r"), 3),
            (format!("{h}\n\"5\n\",2\n10,x\n"), 4),
            (format!("\u{feff}{h}\n1,2\n3,x\n"), 3),
            (format!("\u{feff}# c\r\n\r\n{h}\r\n1,2\r\n3,x\r\n"), 5),
            (format!("{h}\n1,2\n\n# c\n\n3,2,1\n"), 6),
            (
                "# c\n\nbase.amplitude [Hz],pull_off_amplification [1]\n5,2\n".to_string(),
                3,
            ),
        ] {
            assert_eq!(line_of(&t), want, "{t:?}");
        }
        let d =
            FitData::parse(&format!("# c\r\n{h}\r\n\r\n1,2\r\n3,4\r\n"), "d.csv", None).unwrap();
        assert_eq!(d.rows.iter().map(|r| r.line).collect::<Vec<_>>(), [4, 5]);
    }

    /// A header cell djkr does not recognise is not shown (the file may be anything); one it
    /// recognises, or an attempt at a key, is quoted, cut at 80 characters; a data cell too.
    #[test]
    fn cells_of_a_file_are_shown_at_most_cut() {
        let e = |t: &str| FitData::parse(t, "d.csv", None).unwrap_err().0;
        let m = e("root:*:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n");
        assert!(!m.contains("root") && !m.contains("19000"), "{m}");
        assert!(
            m.contains("line 1, column 1 (a header cell of 25 characters, not shown)"),
            "{m}"
        );
        let m = e("base.wobble [um],pull_off_amplification [1]\n1,2\n3,4\n");
        assert!(m.contains("'base.wobble [um]'"), "{m}");
        let long = "9".repeat(100_000);
        let m = e(&format!(
            "base.amplitude [um],pull_off_amplification [1]\n1,2\n3,x{long}\n"
        ));
        assert!(m.len() < 400 && m.contains("(100001 bytes in all)"), "{m}");
        let m = e(&format!(
            "base.amplitude [um],pull_off_amplification [1]\n1,2\n3,{long}\n"
        ));
        assert!(m.len() < 400 && m.contains("line 3, column 2"), "{m}");
        let m = e(&format!(
            "base.amplitude [{long}],pull_off_amplification [1]\n1,2\n"
        ));
        assert!(m.len() < 600, "{m}");
    }

    /// Data whose chi2 cannot be finite are refused naming the row and the column.
    #[test]
    fn rows_whose_chi2_cannot_be_finite_are_refused() {
        let e = |t: &str| FitData::parse(t, "d.csv", None).unwrap_err().0;
        let m = e("base.amplitude [um],pull_off_amplification [1]\n5,2\n10,1e308\n20,4\n");
        assert!(
            m.contains("line 3, column 2 'pull_off_amplification [1]'"),
            "{m}"
        );
        assert!(m.contains("chi2 cannot be finite"), "{m}");
        let m = e("base.amplitude [um],pull_off_amplification [1],sigma [1]\n5,2,1e-300\n");
        assert!(
            m.contains("line 2, column 3 'sigma [1]'") && m.contains("too small"),
            "{m}"
        );
        for tiny in ["1e-308", "5e-324"] {
            let m = e(&format!(
                "base.amplitude [um],pull_off_amplification [1],sigma [1]\n5,0,{tiny}\n"
            ));
            assert!(
                m.contains("line 2, column 3") && m.contains("subnormal"),
                "{m}"
            );
        }
        let m = e("base.frequency [kHz],pull_off_force [N]\n1e306,1\n");
        assert!(
            m.contains("line 2, column 1") && m.contains("largest number in SI"),
            "{m}"
        );
        // At the bound, accepted.
        let d = FitData::parse(
            "base.amplitude [um],pull_off_amplification [1],sigma [1]\n5,1e150,1\n6,1,1e-150\n",
            "d.csv",
            None,
        )
        .unwrap();
        assert_eq!(d.rows.len(), 2);
    }

    #[test]
    fn text_beyond_the_size_limit_is_refused() {
        let limit = InputKind::FitData.limit() as usize;
        let mut t = String::from("base.amplitude [um],pull_off_amplification [1]\n");
        t.push_str(&"#".repeat(limit - t.len()));
        assert!(FitData::parse(&t, "d.csv", None)
            .unwrap_err()
            .0
            .contains("no data rows"));
        t.push('#');
        let m = FitData::parse(&t, "d.csv", None).unwrap_err().0;
        assert!(m.contains("16 MiB") && m.contains("fit data file"), "{m}");
    }
}
