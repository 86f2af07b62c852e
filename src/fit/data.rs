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
//! Lines starting with `#` are comments. A bad file is refused naming the file, the line and the
//! column, as the scenario parser does.

use std::path::Path;

use thiserror::Error;

use crate::scenario::overrides::SetKey;
use crate::sweep::spec::{key_kind, KeyKind};
use crate::units::{parse_quantity, Dimension};

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
/// writes it: `1` for a bare number). An absent unit means SI.
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
    let dim = dim.unwrap_or(Dimension::Dimensionless);
    if dim == Dimension::Dimensionless {
        return Err(format!(
            "unit [{u}]: {name} is a plain number; write [1] or no unit"
        ));
    }
    parse_quantity(name, &format!("1{u}"), dim).map_err(|e| {
        format!(
            "unit [{u}]: {name} takes {} (SI: {si})",
            e.allowed.trim_start_matches("a number in SI ")
        )
    })
}

impl FitData {
    /// Read a data file; `observable` names the observable column to fit (needed when the file
    /// has several).
    pub fn read(path: &Path, observable: Option<&str>) -> Result<FitData, DataError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| DataError(format!("{name}: cannot read the data file: {e}")))?;
        FitData::parse(&text, &name, observable)
    }

    /// [`FitData::read`] on a file's text (`name` names it in messages).
    pub fn parse(text: &str, name: &str, observable: Option<&str>) -> Result<FitData, DataError> {
        let fail = |m: String| DataError(format!("{name}: {m}"));
        let wanted = match observable {
            Some(o) => Some(Observable::parse(o).ok_or_else(|| {
                fail(format!(
                    "--observable {}: djkr does not produce it; it produces {}",
                    crate::text::excerpt(o),
                    Observable::list()
                ))
            })?),
            None => None,
        };
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let header: Vec<String> = rdr
            .headers()
            .map_err(|e| fail(format!("header: {e}")))?
            .iter()
            .map(str::to_string)
            .collect();
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
            let at = |m: String| fail(format!("line 1, column {col} '{}': {m}", cell.trim()));
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
                    "neither a scenario key (as --set takes it: base.amplitude, stage[3].speed) \
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
                        "--observable {}: the file has no {} column{}",
                        o.name(),
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
                    "line 1: no observable column; name one as sweep.csv does: {}",
                    Observable::list()
                )))
            }
            (None, _) => {
                return Err(fail(format!(
                    "the file has several observables ({}): name the one to fit with --observable",
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
                .map(|u| format!(" [{u}]"))
                .unwrap_or_default()
        );
        let obs_factor = unit_factor(
            observable.name(),
            obs_unit.as_deref(),
            Some(observable.dimension()),
            observable.unit(),
        )
        .map_err(|m| fail(format!("line 1, column '{obs_col_name}': {m}")))?;
        let sigma_factor = match &sigma_unit {
            Some(u) => unit_factor(
                "sigma",
                u.as_deref(),
                Some(observable.dimension()),
                observable.unit(),
            )
            .map_err(|m| {
                fail(format!(
                    "line 1, column sigma: {m} (sigma is in the unit of {})",
                    observable.name()
                ))
            })?,
            None => 1.0,
        };
        for (j, cell) in header.iter().enumerate() {
            let (cname, _) = split_header(cell);
            if cols[j].is_none() {
                cols[j] = if cname == "sigma" {
                    Some(Col::Sigma)
                } else if Observable::parse(&cname) == Some(observable) {
                    Some(Col::Obs(obs_factor))
                } else {
                    None
                };
            }
        }
        let mut rows = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| fail(format!("{e}")))?;
            let line = rec.position().map_or(0, |p| p.line());
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
            let mut conds = vec![CondValue::Num(f64::NAN); conditions.len()];
            let mut observed = f64::NAN;
            let mut sigma = None;
            for (j, col) in cols.iter().enumerate() {
                let cell = rec.get(j).unwrap_or("");
                let at = |m: String| {
                    fail(format!(
                        "line {line}, column {} '{}': {m}",
                        j + 1,
                        header[j].trim()
                    ))
                };
                let number = |what: &str| -> Result<f64, DataError> {
                    let x: f64 = cell.parse().map_err(|_| {
                        at(format!(
                            "'{}' is not a number ({what}, in the header's unit)",
                            crate::text::excerpt(cell)
                        ))
                    })?;
                    if !x.is_finite() {
                        return Err(at(format!("'{cell}' is not a finite number")));
                    }
                    Ok(x)
                };
                match col {
                    None => {}
                    Some(Col::Cond(i, factor)) => {
                        conds[*i] = if conditions[*i].unit.is_some() {
                            CondValue::Num(number("a condition")? * factor)
                        } else if cell.is_empty() {
                            return Err(at("empty cell".into()));
                        } else {
                            CondValue::Text(cell.to_string())
                        };
                    }
                    Some(Col::Obs(factor)) => observed = number("the observable")? * factor,
                    Some(Col::Sigma) => {
                        let s = number("sigma")? * sigma_factor;
                        if s <= 0.0 {
                            return Err(at(format!(
                                "sigma '{cell}' must be > 0 (a standard deviation)"
                            )));
                        }
                        sigma = Some(s);
                    }
                }
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
        assert!(m.contains("--observable"), "{m}");
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
}
