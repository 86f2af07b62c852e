//! Per-cycle records ([`CycleRecord`]: exact averages and first harmonics over each base period)
//! as columns, for the HDF5 `/cycles` group, `cycles.csv` and summary.json.
//!
//! The columns are taken from the record's serde serialisation, so a field added to
//! [`CycleRecord`] reaches every file without touching the writers; its unit then comes from
//! [`cycle_unit`] (by name pattern), which answers `""` for a name it does not know. Integer
//! fields (`index`, `stage`) become int64 columns, the rest f64. Column order: `index`, `stage`,
//! `t_start`, `t_end`, then the other fields in serialisation order. A non-finite f64 (which serde
//! turns into `null`) is stored as NaN.

use serde_json::Value;

use crate::dynamics::types::CycleRecord;

/// One column of the cycle table.
#[derive(Debug, Clone, PartialEq)]
pub enum CycleColumn {
    /// Floating-point values.
    F64(Vec<f64>),
    /// Integer values (indices).
    I64(Vec<i64>),
}

/// The cycle records as named columns (empty when there are no records: the field names are
/// only known from a record).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CycleTable {
    /// Column names (the record's field names).
    pub names: Vec<String>,
    /// Columns, parallel to `names`.
    pub columns: Vec<CycleColumn>,
}

impl CycleTable {
    /// Number of records.
    pub fn len(&self) -> usize {
        match self.columns.first() {
            Some(CycleColumn::F64(v)) => v.len(),
            Some(CycleColumn::I64(v)) => v.len(),
            None => 0,
        }
    }

    /// True when there are no records.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The unit of a cycle-record field, by name: `index`, `stage` → `1`; `t_*` → `s`; `force_*`,
/// `spring_*` → `N`; `delta_*`, `a_*`, `x_*` → `m`; `work_*`, `dissipation_*`, `energy_*` → `J`;
/// anything else `""` (unknown to this writer).
pub fn cycle_unit(name: &str) -> &'static str {
    let prefix = |p: &str| name.starts_with(p);
    if name == "index" || name == "stage" {
        "1"
    } else if prefix("t_") {
        "s"
    } else if prefix("force_") || prefix("spring_") {
        "N"
    } else if prefix("delta_") || prefix("a_") || prefix("x_") {
        "m"
    } else if prefix("work_") || prefix("dissipation_") || prefix("energy_") {
        "J"
    } else {
        ""
    }
}

/// Columns put first, in this order, when the record has them.
const LEADING: [&str; 4] = ["index", "stage", "t_start", "t_end"];

/// Fields of one record, in serialisation order.
fn fields(c: &CycleRecord) -> Vec<(String, Value)> {
    match serde_json::to_value(c) {
        Ok(Value::Object(m)) => m.into_iter().collect(),
        _ => Vec::new(),
    }
}

/// The records as columns.
pub fn cycle_table(cycles: &[CycleRecord]) -> CycleTable {
    let Some(first) = cycles.first() else {
        return CycleTable::default();
    };
    let mut proto = fields(first);
    // Identification columns first, then the rest in serialisation order.
    proto.sort_by_key(|(k, _)| LEADING.iter().position(|l| l == k).unwrap_or(LEADING.len()));
    let names: Vec<String> = proto.iter().map(|(k, _)| k.clone()).collect();
    let mut columns: Vec<CycleColumn> = proto
        .iter()
        .map(|(_, v)| match v {
            Value::Number(n) if n.is_i64() || n.is_u64() => {
                CycleColumn::I64(Vec::with_capacity(cycles.len()))
            }
            _ => CycleColumn::F64(Vec::with_capacity(cycles.len())),
        })
        .collect();
    for c in cycles {
        let values = fields(c);
        for (col, name) in columns.iter_mut().zip(&names) {
            let v = values.iter().find(|(k, _)| k == name).map(|(_, v)| v);
            match col {
                CycleColumn::F64(data) => {
                    data.push(v.and_then(Value::as_f64).unwrap_or(f64::NAN));
                }
                CycleColumn::I64(data) => data.push(
                    v.and_then(|v| v.as_i64().or_else(|| v.as_u64().map(|_| i64::MAX)))
                        .unwrap_or(-1),
                ),
            }
        }
    }
    CycleTable { names, columns }
}
