//! Per-cycle records ([`CycleRecord`]: exact averages and first harmonics over each base period)
//! as a table, for the HDF5 `/cycles` group, `cycles.csv` and summary.json.
//!
//! The schema is [`CYCLE_FIELDS`], one entry per field of [`CycleRecord`]: `index`, `stage`,
//! `t_start`, `t_end`, then the other fields in alphabetical order (the column order of the files
//! since the first release). Its names are the record's serde names, which a unit test checks, so
//! a field added to the record fails that test until it is listed here with its unit and definition. `index` and `stage` are int64 columns,
//! the rest f64. Each field's description defines it (unit, what is averaged or fitted, over
//! which period); the harmonic convention they share is [`HARMONIC_CONVENTION`].

use super::table::{Cell, Column, Data, Field, Table};
use super::timeseries::stage_index;
use djkr_core::dynamics::CycleRecord;

/// How a cycle field is read from a record.
#[derive(Debug, Clone, Copy)]
enum Get {
    F64(fn(&CycleRecord) -> f64),
    I64(fn(&CycleRecord) -> i64),
}

/// One field of the cycle table.
#[derive(Debug, Clone, Copy)]
pub struct CycleField {
    /// Name: the record's field, the HDF5 dataset, the CSV header's name.
    pub name: &'static str,
    /// SI unit (`1` for indices).
    pub unit: &'static str,
    /// What the value is: the HDF5 description of its dataset.
    pub description: &'static str,
    get: Get,
}

/// The convention of every `*_mean`, `*_sin` and `*_cos` field, written once in the run file's
/// root attribute `harmonics` and in docs/guide/output.md (what `record_cycle` in
/// `dynamics::simulator` computes from quadratures integrated with the solution).
pub const HARMONIC_CONVENTION: &str = "each cycles/ row covers one base period T = 2 pi/omega \
from t_start to t_end = t_start + T, starting where the base phase theta = omega (t - t_on) is a \
multiple of 2 pi (t_on: when the base motion started, its stage's start plus base.phase/omega), so \
that x_b = X_b sin theta. Over that period a signal s(t) ~ s_mean + s_sin sin theta + s_cos cos \
theta, with s_mean = (1/T) int s dt, s_sin = (2/T) int s sin theta dt, s_cos = (2/T) int s cos \
theta dt (exact integrals over the solution, not fits to samples); amplitude hypot(s_sin, s_cos), \
phase lead over the base atan2(s_cos, s_sin)";

impl CycleField {
    /// This field's schema.
    pub fn field(&self) -> Field {
        match self.get {
            Get::F64(_) => Field::f64(self.name, self.unit, self.description),
            Get::I64(_) => Field::i64(self.name, self.unit, self.description),
        }
    }

    /// The value in a record, as f64 (indices converted): what the tests compare the written
    /// columns with.
    #[cfg(test)]
    pub fn value(&self, c: &CycleRecord) -> f64 {
        match self.get {
            Get::F64(g) => g(c),
            Get::I64(g) => g(c) as f64,
        }
    }
}

const fn f(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    g: fn(&CycleRecord) -> f64,
) -> CycleField {
    CycleField {
        name,
        unit,
        description,
        get: Get::F64(g),
    }
}

/// The cycle table's fields, in file order: identification and times first, then alphabetical.
pub const CYCLE_FIELDS: [CycleField; 24] = [
    CycleField {
        name: "index",
        unit: "1",
        description: "period number since the shaker last switched on (0-based)",
        get: Get::I64(|c| i64::try_from(c.index).unwrap_or(i64::MAX)),
    },
    CycleField {
        name: "stage",
        unit: "1",
        description: "index of the stage at the end of the period (0-based, as /stage)",
        get: Get::I64(|c| stage_index(c.stage)),
    },
    f("t_start", "s", "start of the base period (s): theta = omega (t - t_on) is a multiple of 2 pi here", |c| c.t_start),
    f("t_end", "s", "end of the base period, t_start + 2 pi/omega (s)", |c| c.t_end),
    f("a_cos", "m", "contact radius a, first harmonic, cosine part: (2/T) int a cos theta dt over the period (m; root attribute harmonics)", |c| c.a_cos),
    f("a_mean", "m", "contact radius a averaged over the period, (1/T) int a dt (m)", |c| c.a_mean),
    f("a_sin", "m", "contact radius a, first harmonic, sine part: (2/T) int a sin theta dt over the period (m; root attribute harmonics)", |c| c.a_sin),
    f("delta_cos", "m", "indentation delta = x_s + x_b, first harmonic, cosine part: (2/T) int delta cos theta dt (m)", |c| c.delta_cos),
    f("delta_mean", "m", "indentation delta = x_s + x_b averaged over the period (m; equals x_s_mean: x_b averages to 0)", |c| c.delta_mean),
    f("delta_sin", "m", "indentation delta = x_s + x_b, first harmonic, sine part: (2/T) int delta sin theta dt (m; includes X_b from the base)", |c| c.delta_sin),
    f("dissipation_adhesion", "J", "energy dissipated by the rate-dependent adhesion over the period, int (w0 - w) 2 pi a a_dot dt (J)", |c| c.dissipation_adhesion),
    f("dissipation_damping", "J", "energy dissipated by viscous damping over the period (J)", |c| c.dissipation_damping),
    f("energy_end", "J", "total mechanical energy at t_end (J; dynamics::model::total_energy)", |c| c.energy_end),
    f("energy_start", "J", "total mechanical energy at t_start (J; dynamics::model::total_energy)", |c| c.energy_start),
    f("force_cos", "N", "contact force F (tensile negative), first harmonic, cosine part: (2/T) int F cos theta dt (N)", |c| c.force_cos),
    f("force_mean", "N", "contact force F (tensile negative) averaged over the period, (1/T) int F dt (N): the cycle-averaged force", |c| c.force_mean),
    f("force_sin", "N", "contact force F (tensile negative), first harmonic, sine part: (2/T) int F sin theta dt (N)", |c| c.force_sin),
    f("spring_cos", "N", "holder force on the sphere (down positive), first harmonic, cosine part: (2/T) int f cos theta dt (N)", |c| c.spring_cos),
    f("spring_mean", "N", "holder force on the sphere (down positive) averaged over the period: k (<x_k> - <x_s>) for a spring, F - m g for a rigid link, 0 without a holder (N)", |c| c.spring_mean),
    f("spring_sin", "N", "holder force on the sphere (down positive), first harmonic, sine part: (2/T) int f sin theta dt (N)", |c| c.spring_sin),
    f("work_base", "J", "work done by the base on the sphere-contact system over the period (J)", |c| c.work_base),
    f("work_holder", "J", "work done by the moving spring end over the period (J)", |c| c.work_holder),
    f("x_k_mean", "m", "spring-end position x_k averaged over the period (m, down positive)", |c| c.x_k_mean),
    f("x_s_mean", "m", "sphere position x_s averaged over the period (m, down positive)", |c| c.x_s_mean),
];

/// The cycle table's schema.
pub fn cycle_schema() -> Vec<Field> {
    CYCLE_FIELDS.iter().map(CycleField::field).collect()
}

/// The records as a table of [`cycle_schema`] (its header alone when there are none).
pub fn cycle_table(cycles: &[CycleRecord]) -> Table {
    let columns = CYCLE_FIELDS
        .iter()
        .map(|def| {
            let field = def.field();
            match def.get {
                Get::F64(g) => Column::of(field, Data::F64(cycles.iter().map(g).collect())),
                Get::I64(g) => Column::of(field, Data::I64(cycles.iter().map(g).collect())),
            }
        })
        .collect();
    Table::from_fixed(columns)
}

/// Append one record to a table of [`cycle_schema`] (a run writer's buffer).
pub fn push_cycle(table: &mut Table, c: &CycleRecord) {
    let mut row = [Cell::F64(0.0); CYCLE_FIELDS.len()];
    for (cell, def) in row.iter_mut().zip(CYCLE_FIELDS.iter()) {
        *cell = match def.get {
            Get::F64(g) => Cell::F64(g(c)),
            Get::I64(g) => Cell::I64(g(c)),
        };
    }
    // The row is built from the schema itself.
    let pushed = table.push_row(&row);
    debug_assert!(pushed.is_ok(), "{pushed:?}");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> CycleRecord {
        CycleRecord {
            index: 7,
            stage: 2,
            t_start: 1.0,
            t_end: 2.0,
            force_mean: 3.0,
            force_sin: 4.0,
            force_cos: 5.0,
            delta_mean: 6.0,
            delta_sin: 7.0,
            delta_cos: 8.0,
            a_mean: 9.0,
            a_sin: 10.0,
            a_cos: 11.0,
            x_s_mean: 12.0,
            x_k_mean: 13.0,
            spring_mean: 14.0,
            spring_sin: 15.0,
            spring_cos: 16.0,
            work_base: 17.0,
            work_holder: 18.0,
            dissipation_damping: 19.0,
            dissipation_adhesion: 20.0,
            energy_start: 21.0,
            energy_end: 22.0,
        }
    }

    #[test]
    fn schema_follows_the_record_field_by_field() {
        let r = record();
        let serde_json::Value::Object(m) = serde_json::to_value(r).unwrap() else {
            panic!("a record serialises to an object");
        };
        let names: Vec<&str> = m.keys().map(String::as_str).collect();
        let mut ours: Vec<&str> = CYCLE_FIELDS.iter().map(|c| c.name).collect();
        assert_eq!(ours[..4], ["index", "stage", "t_start", "t_end"]);
        assert!(ours[4..].is_sorted(), "{ours:?}");
        ours.sort_unstable();
        assert_eq!(
            ours, names,
            "CYCLE_FIELDS must list every CycleRecord field"
        );
        for def in &CYCLE_FIELDS {
            let v = m[def.name].as_f64().unwrap();
            assert_eq!(def.value(&r).to_bits(), v.to_bits(), "{}", def.name);
        }
        let mut t = cycle_table(&[r, r]);
        assert_eq!(t.rows(), 2);
        push_cycle(&mut t, &r);
        let mut three = cycle_table(&[r, r, r]);
        assert_eq!(t, three);
        three.clear();
        assert_eq!(three, cycle_table(&[]));
        assert_eq!(t.columns().len(), CYCLE_FIELDS.len());
        assert!(cycle_table(&[]).columns().len() == CYCLE_FIELDS.len());
    }
}
