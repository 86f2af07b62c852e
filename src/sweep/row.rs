//! One row per run: what `sweep.csv` and `sweep.h5` hold, and how a row file is read back
//! (`--resume`, `djkr sweep merge`).
//!
//! Columns, in order: `point`, `member`, one column per swept key named as the key (its SI value,
//! or the text of a text key), `phase [rad]`, `status` (`ok` or `error`), `error` (the message,
//! empty when ok), `pull_off_force [N]`, `pull_off_amplification [1]`, `pull_off_time [s]`,
//! `detached` (`true`, `false`; empty when the run failed), `steps [1]`, `rhs_evals [1]`,
//! `wall_s [s]`, and the last cycle's `force_mean [N]`, `delta_mean [m]`, `delta_amp [m]`
//! (δ_A = hypot(δ_sin, δ_cos)). A number a failed run (or a run without cycles) does not have is
//! NaN; `steps` and `rhs_evals` are whole numbers stored as f64 for that reason (exact below
//! 2⁵³). Every number is the one `djkr run FILE --set ...` writes into `summary.json` for the
//! same overrides (`wall_s` aside: a failed run's is the sweep's own measurement).

use serde::{Deserialize, Serialize};

use crate::output::table::{Column, Field, Table};
use djkr_core::dynamics::RunResult;

use super::spec::KeyCell;

/// A swept key as `sweep.json` describes it: its column and how the plots draw it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyInfo {
    /// The key.
    pub name: String,
    /// SI unit (`None`: text).
    pub unit: Option<String>,
    /// Given as a log range (the plots use a log axis).
    pub log: bool,
}

/// The numbers of a run that succeeded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunNumbers {
    /// `pull_off.force` (N).
    pub pull_off_force: f64,
    /// `pull_off.amplification` (1).
    pub pull_off_amplification: f64,
    /// `pull_off.time` (s).
    pub pull_off_time: f64,
    /// `detached`.
    pub detached: bool,
    /// `stats.steps`.
    pub steps: u64,
    /// `stats.rhs_evals`.
    pub rhs_evals: u64,
    /// The last cycle's ⟨F⟩ (N; NaN without cycles).
    pub force_mean: f64,
    /// The last cycle's ⟨δ⟩ (m; NaN without cycles).
    pub delta_mean: f64,
    /// The last cycle's δ_A = hypot(δ_sin, δ_cos) (m; NaN without cycles).
    pub delta_amp: f64,
}

impl RunNumbers {
    /// The row's numbers from a run's result (the same fields `summary.json` prints).
    pub fn of(r: &RunResult) -> Self {
        let last = r.last_cycle.as_ref();
        let nan = f64::NAN;
        RunNumbers {
            pull_off_force: r.pull_off.force,
            pull_off_amplification: r.pull_off.amplification,
            pull_off_time: r.pull_off.time,
            detached: r.detached,
            steps: r.stats.steps,
            rhs_evals: r.stats.rhs_evals,
            force_mean: last.map_or(nan, |c| c.force_mean),
            delta_mean: last.map_or(nan, |c| c.delta_mean),
            delta_amp: last.map_or(nan, |c| c.delta_sin.hypot(c.delta_cos)),
        }
    }
}

/// One run of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Point index (from 0, in grid order).
    pub point: usize,
    /// Ensemble member (from 0; 0 without an ensemble).
    pub member: usize,
    /// The swept keys' values at the point, in the order given.
    pub keys: Vec<KeyCell>,
    /// The base phase of the run (rad): the drawn one in an ensemble, else the scenario's.
    pub phase: f64,
    /// The run's numbers, or why it failed or stopped.
    pub result: Result<RunNumbers, String>,
    /// A budget (`solver.max_steps`, `max_wall_s`, `max_events`, `max_memory`) stopped the run:
    /// status `stopped` rather than `error` (`result` holds the message either way).
    pub stopped: bool,
    /// Wall-clock time of the run (s): `stats.wall_s`, or the sweep's measurement of a run that
    /// failed.
    pub wall_s: f64,
}

impl Row {
    /// A failed run's row: its message on one line (the journal is read line by line).
    pub fn failed(
        point: usize,
        member: usize,
        keys: Vec<KeyCell>,
        phase: f64,
        message: &str,
        wall_s: f64,
    ) -> Row {
        Row {
            point,
            member,
            keys,
            phase,
            result: Err(message.replace("\r\n", "; ").replace(['\n', '\r'], "; ")),
            stopped: false,
            wall_s,
        }
    }

    /// A row whose run a budget stopped (status `stopped`), with the run's message.
    pub fn stopped(
        point: usize,
        member: usize,
        keys: Vec<KeyCell>,
        phase: f64,
        message: &str,
        wall_s: f64,
    ) -> Row {
        Row {
            stopped: true,
            ..Row::failed(point, member, keys, phase, message, wall_s)
        }
    }

    /// The row's `status`: `ok`, `stopped` or `error`.
    pub fn status(&self) -> &'static str {
        match (&self.result, self.stopped) {
            (Ok(_), _) => "ok",
            (Err(_), true) => "stopped",
            (Err(_), false) => "error",
        }
    }

    /// The pull-off amplification, when the run succeeded.
    pub fn amplification(&self) -> Option<f64> {
        self.result.as_ref().ok().map(|n| n.pull_off_amplification)
    }
}

/// A swept key's column: its name (the key) and unit (`None`: text).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyColumn {
    /// The key, as `--set` writes it.
    pub name: String,
    /// SI unit (`None` for a text key).
    pub unit: Option<String>,
}

/// The fixed numeric columns after `error`: (name, unit, description).
const NUMBERS: [(&str, &str, &str); 10] = [
    (
        "pull_off_force",
        "N",
        "summary.json pull_off.force: most tensile cycle-mean (or contact) force before detachment",
    ),
    (
        "pull_off_amplification",
        "1",
        "pull_off_force / (-3/2 pi R w0); NaN when pull_off_force is not tensile (>= 0)",
    ),
    (
        "pull_off_time",
        "s",
        "time at which pull_off_force was reached",
    ),
    ("detached", "", "true when final detachment happened"),
    ("steps", "1", "accepted steps"),
    ("rhs_evals", "1", "right-hand-side evaluations"),
    ("wall_s", "s", "wall-clock time of the run"),
    ("force_mean", "N", "last cycle's mean contact force"),
    ("delta_mean", "m", "last cycle's mean indentation"),
    (
        "delta_amp",
        "m",
        "last cycle's first-harmonic indentation amplitude hypot(delta_sin, delta_cos)",
    ),
];

/// The columns of a row table.
pub fn row_schema(keys: &[KeyColumn]) -> Vec<Field> {
    let mut f = vec![
        Field::i64("point", "1", "point index (grid order, from 0)"),
        Field::i64("member", "1", "ensemble member (from 0)"),
    ];
    for k in keys {
        f.push(match &k.unit {
            Some(u) => Field::f64(&k.name, u, format!("swept key {} (SI)", k.name)),
            None => Field::text(&k.name, format!("swept key {}", k.name)),
        });
    }
    f.push(Field::f64(
        "phase",
        "rad",
        "base phase at shaker-on ([base] phase)",
    ));
    f.push(Field::text(
        "status",
        "ok, stopped (a budget stopped the run) or error (it failed)",
    ));
    f.push(Field::text(
        "error",
        "why the run failed or stopped (empty when ok)",
    ));
    for (name, unit, description) in NUMBERS {
        f.push(if unit.is_empty() {
            Field::text(name, description)
        } else {
            Field::f64(name, unit, description)
        });
    }
    f
}

/// The rows as a table of [`row_schema`].
pub(crate) fn rows_table(keys: &[KeyColumn], rows: &[Row]) -> Table {
    let schema = row_schema(keys);
    let mut cols: Vec<Column> = Vec::new();
    let field = |i: usize| schema[i].clone();
    let ok = |r: &Row| r.result.as_ref().ok().copied();
    cols.push(Column::of(
        field(0),
        crate::output::table::Data::I64(rows.iter().map(|r| r.point as i64).collect()),
    ));
    cols.push(Column::of(
        field(1),
        crate::output::table::Data::I64(rows.iter().map(|r| r.member as i64).collect()),
    ));
    for (j, k) in keys.iter().enumerate() {
        let f = field(2 + j);
        cols.push(match k.unit {
            Some(_) => Column::of(
                f,
                crate::output::table::Data::F64(
                    rows.iter()
                        .map(|r| r.keys.get(j).and_then(KeyCell::num).unwrap_or(f64::NAN))
                        .collect(),
                ),
            ),
            None => Column::of(
                f,
                crate::output::table::Data::Text(
                    rows.iter()
                        .map(|r| r.keys.get(j).map(ToString::to_string).unwrap_or_default())
                        .collect(),
                ),
            ),
        });
    }
    let mut i = 2 + keys.len();
    let f64_col = |i: &mut usize, get: &dyn Fn(&Row) -> f64| {
        let c = Column::of(
            field(*i),
            crate::output::table::Data::F64(rows.iter().map(get).collect()),
        );
        *i += 1;
        c
    };
    let text_col = |i: &mut usize, get: &dyn Fn(&Row) -> String| {
        let c = Column::of(
            field(*i),
            crate::output::table::Data::Text(rows.iter().map(get).collect()),
        );
        *i += 1;
        c
    };
    let nan = f64::NAN;
    cols.push(f64_col(&mut i, &|r| r.phase));
    cols.push(text_col(&mut i, &|r| r.status().to_string()));
    cols.push(text_col(&mut i, &|r| {
        r.result.as_ref().err().cloned().unwrap_or_default()
    }));
    cols.push(f64_col(&mut i, &|r| {
        ok(r).map_or(nan, |n| n.pull_off_force)
    }));
    cols.push(f64_col(&mut i, &|r| {
        ok(r).map_or(nan, |n| n.pull_off_amplification)
    }));
    cols.push(f64_col(&mut i, &|r| ok(r).map_or(nan, |n| n.pull_off_time)));
    cols.push(text_col(&mut i, &|r| {
        ok(r).map_or(String::new(), |n| n.detached.to_string())
    }));
    cols.push(f64_col(&mut i, &|r| ok(r).map_or(nan, |n| n.steps as f64)));
    cols.push(f64_col(&mut i, &|r| {
        ok(r).map_or(nan, |n| n.rhs_evals as f64)
    }));
    cols.push(f64_col(&mut i, &|r| r.wall_s));
    cols.push(f64_col(&mut i, &|r| ok(r).map_or(nan, |n| n.force_mean)));
    cols.push(f64_col(&mut i, &|r| ok(r).map_or(nan, |n| n.delta_mean)));
    cols.push(f64_col(&mut i, &|r| ok(r).map_or(nan, |n| n.delta_amp)));
    Table::from_fixed(cols)
}

/// Read the rows of a row CSV written with the columns of `keys` (`sweep.csv` or the journal),
/// from its text. A last line without its line end (a writer killed mid-line) is ignored. Errors
/// name the line and the column.
pub fn parse_rows_csv(text: &str, keys: &[KeyColumn]) -> Result<Vec<Row>, String> {
    // Only complete lines: the journal is appended line by line.
    let complete = match text.rfind('\n') {
        Some(i) => &text[..=i],
        None => "",
    };
    let schema = row_schema(keys);
    let want: Vec<String> = schema.iter().map(Field::csv_header).collect();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(complete.as_bytes());
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| format!("header: {e}"))?
        .iter()
        .map(str::to_string)
        .collect();
    if header.is_empty() && complete.is_empty() {
        return Ok(Vec::new());
    }
    if header != want {
        return Err(format!(
            "columns {} differ from this sweep's {}",
            header.join(","),
            want.join(",")
        ));
    }
    let mut rows = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| format!("line {line}: {e}"))?;
        let cell = |j: usize| rec.get(j).unwrap_or("");
        let num = |j: usize| -> Result<f64, String> {
            cell(j).parse::<f64>().map_err(|_| {
                format!(
                    "line {line}, column {}: '{}' is not a number",
                    schema[j].name,
                    djkr_core::text::excerpt(cell(j))
                )
            })
        };
        let int = |j: usize| -> Result<usize, String> {
            cell(j).parse::<usize>().map_err(|_| {
                format!(
                    "line {line}, column {}: '{}' is not a whole number",
                    schema[j].name,
                    djkr_core::text::excerpt(cell(j))
                )
            })
        };
        let mut kc = Vec::with_capacity(keys.len());
        for (j, k) in keys.iter().enumerate() {
            kc.push(match k.unit {
                Some(_) => KeyCell::Num(num(2 + j)?),
                None => KeyCell::Text(cell(2 + j).to_string()),
            });
        }
        let b = 2 + keys.len();
        let status = cell(b + 1);
        let result = match status {
            "ok" => {
                let detached = match cell(b + 6) {
                    "true" => true,
                    "false" => false,
                    other => {
                        return Err(format!(
                            "line {line}, column detached: '{}' is not true or false",
                            djkr_core::text::excerpt(other)
                        ))
                    }
                };
                Ok(RunNumbers {
                    pull_off_force: num(b + 3)?,
                    pull_off_amplification: num(b + 4)?,
                    pull_off_time: num(b + 5)?,
                    detached,
                    steps: num(b + 7)? as u64,
                    rhs_evals: num(b + 8)? as u64,
                    force_mean: num(b + 10)?,
                    delta_mean: num(b + 11)?,
                    delta_amp: num(b + 12)?,
                })
            }
            "error" | "stopped" => Err(cell(b + 2).to_string()),
            other => {
                return Err(format!(
                    "line {line}, column status: '{}' is not ok, stopped or error",
                    djkr_core::text::excerpt(other)
                ))
            }
        };
        rows.push(Row {
            point: int(0)?,
            member: int(1)?,
            keys: kc,
            phase: num(b)?,
            result,
            stopped: status == "stopped",
            wall_s: num(b + 9)?,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys() -> Vec<KeyColumn> {
        vec![
            KeyColumn {
                name: "base.amplitude".into(),
                unit: Some("m".into()),
            },
            KeyColumn {
                name: "solver.method".into(),
                unit: None,
            },
        ]
    }

    fn rows() -> Vec<Row> {
        vec![
            Row {
                point: 0,
                member: 1,
                keys: vec![KeyCell::Num(3e-5), KeyCell::Text("dp8".into())],
                phase: 1.25,
                result: Ok(RunNumbers {
                    pull_off_force: -0.1234567890123,
                    pull_off_amplification: 4.81,
                    pull_off_time: 12.5,
                    detached: true,
                    steps: 123456,
                    rhs_evals: 1234567,
                    force_mean: -0.05,
                    delta_mean: f64::NAN,
                    delta_amp: 1e-5,
                }),
                stopped: false,
                wall_s: 0.07,
            },
            Row {
                point: 1,
                member: 0,
                keys: vec![KeyCell::Num(6e-5), KeyCell::Text("implicit".into())],
                phase: 0.0,
                result: Err("step size underflow at t = 1e0 s, \"x\"; state: ...".into()),
                stopped: false,
                wall_s: 0.5,
            },
            Row {
                point: 2,
                member: 0,
                keys: vec![KeyCell::Num(9e-5), KeyCell::Text("auto".into())],
                phase: 0.5,
                result: Err("wall-clock budget of solver.max_wall_s = 1 s exhausted".into()),
                stopped: true,
                wall_s: 1.0,
            },
        ]
    }

    #[test]
    fn rows_round_trip_through_csv() {
        let t = rows_table(&keys(), &rows());
        let csv = t.to_csv();
        assert!(csv.starts_with(
            "point [1],member [1],base.amplitude [m],solver.method,phase [rad],status,error,\
             pull_off_force [N],pull_off_amplification [1],pull_off_time [s],detached,steps [1],\
             rhs_evals [1],wall_s [s],force_mean [N],delta_mean [m],delta_amp [m]\n"
        ));
        let back = parse_rows_csv(&csv, &keys()).unwrap();
        assert_eq!(back.len(), 3);
        let status: Vec<&str> = back.iter().map(Row::status).collect();
        assert_eq!(status, ["ok", "error", "stopped"]);
        assert!(csv.contains(",stopped,"), "{csv}");
        // NaN != NaN: compare the CSV they make.
        assert_eq!(rows_table(&keys(), &back).to_csv(), csv);
        assert_eq!(back[1].result, rows()[1].result);
        // A torn last line is ignored.
        let torn = &csv[..csv.len() - 5];
        assert_eq!(parse_rows_csv(torn, &keys()).unwrap().len(), 2);
        // Other columns are refused.
        let e = parse_rows_csv(&csv, &keys()[..1]).unwrap_err();
        assert!(e.contains("differ"), "{e}");
    }
}
