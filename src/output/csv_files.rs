//! CSV output: `timeseries.csv`, `events.csv` and `cycles.csv`, with units in the header
//! (`t_s,x_s_m,v_s_m_per_s,...,F_N,G_J_per_m2,w_J_per_m2,stage`).
//!
//! Numbers are written in Rust's shortest round-trip form, so parsing a field as an f64 gives back
//! the exact value: plain notation for magnitudes in [1e-3, 1e9) and zero, exponent notation
//! (`1.5e-7`) otherwise; non-finite values as `NaN`, `inf`, `-inf` (which Python's `float`, numpy
//! and pandas read).

use std::io::Write;

use super::cycles::{cycle_unit, CycleColumn, CycleTable};
use super::hdf5_file::kind_name;
use super::timeseries::{TimeSeriesWriter, SERIES, STAGE};
use crate::dynamics::types::Event;

/// Format an f64 so that it parses back to the same bits (see the module doc).
pub fn format_f64(x: f64) -> String {
    let m = x.abs();
    if !x.is_finite() || x == 0.0 || (1e-3..1e9).contains(&m) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The time-series header line (without newline).
pub fn timeseries_header() -> String {
    let mut h: Vec<&str> = SERIES.iter().map(|c| c.csv_header).collect();
    h.push(STAGE);
    h.join(",")
}

/// The events header line (without newline): kind, time, stage, then the state (without t).
pub fn events_header() -> String {
    let mut h = vec!["kind", "time_s", STAGE];
    h.extend(
        SERIES
            .iter()
            .filter(|c| c.name != "t")
            .map(|c| c.csv_header),
    );
    h.join(",")
}

/// Write the time series as CSV.
pub fn write_timeseries(out: &mut impl Write, series: &TimeSeriesWriter) -> std::io::Result<()> {
    writeln!(out, "{}", timeseries_header())?;
    let cols = series.columns();
    let mut line = String::new();
    for (i, stage) in series.stages().iter().enumerate() {
        line.clear();
        for col in cols.iter() {
            line.push_str(&format_f64(col[i]));
            line.push(',');
        }
        line.push_str(&stage.to_string());
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// Write the events as CSV.
pub fn write_events(out: &mut impl Write, events: &[Event]) -> std::io::Result<()> {
    writeln!(out, "{}", events_header())?;
    for e in events {
        let mut fields = vec![kind_name(e.kind), format_f64(e.time), e.stage.to_string()];
        fields.extend(
            SERIES
                .iter()
                .filter(|c| c.name != "t")
                .map(|c| format_f64(c.value(&e.state))),
        );
        writeln!(out, "{}", fields.join(","))?;
    }
    Ok(())
}

/// The CSV header of a cycle-record field: the name, then its unit (`force_mean_N`, `t_start_s`;
/// no suffix for indices and unknown units).
pub fn cycle_header(name: &str) -> String {
    match cycle_unit(name) {
        "" | "1" => name.to_string(),
        unit => format!("{name}_{unit}"),
    }
}

/// Write the per-cycle records as CSV (a header only when there are none).
pub fn write_cycles(out: &mut impl Write, table: &CycleTable) -> std::io::Result<()> {
    let header: Vec<String> = table.names.iter().map(|n| cycle_header(n)).collect();
    writeln!(out, "{}", header.join(","))?;
    for i in 0..table.len() {
        let row: Vec<String> = table
            .columns
            .iter()
            .map(|c| match c {
                CycleColumn::F64(v) => format_f64(v[i]),
                CycleColumn::I64(v) => v[i].to_string(),
            })
            .collect();
        writeln!(out, "{}", row.join(","))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formatted_numbers_parse_back_bit_exactly() {
        let values = [
            0.0,
            -0.0,
            1.0,
            0.1,
            -2.5e-7,
            1e-300,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            -1.7976931348623157e308,
            123456789.123,
            1e9,
            0.001,
            0.000999999,
            std::f64::consts::PI,
        ];
        for x in values {
            let s = format_f64(x);
            let y: f64 = s.parse().unwrap();
            assert_eq!(x.to_bits(), y.to_bits(), "{x} -> {s}");
            assert!(s.len() <= 24, "{s}");
        }
        assert_eq!(format_f64(f64::NAN), "NaN");
        assert_eq!(format_f64(f64::INFINITY), "inf");
        assert_eq!(format_f64(f64::NEG_INFINITY), "-inf");
    }
}
