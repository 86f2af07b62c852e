//! Tables: the one way djkr holds columns of results, and their CSV form.
//!
//! A [`Table`] is an ordered list of [`Column`]s, each with a name, an SI unit, a one-line
//! description and its data (f64, i64 or text), all of the same length. Its schema (the columns
//! without their data, [`Field`]) is kept apart from the data so that a streaming writer can
//! write a header once and append rows later ([`CsvWriter`], [`Table::push_row`],
//! [`Table::append_rows`]).
//!
//! **CSV** ([`Table::write_csv`]), one style for the whole project:
//! - header cells `name [unit]`, the unit in SI as stored in HDF5 (`t [s]`, `v_s [m/s]`,
//!   `G [J/m^2]`); a dimensionless number has unit `1` (`amplification [1]`); a text column has no
//!   unit and its header is the bare `name`. Every numeric column has a unit.
//! - numbers in SI, in Rust's shortest round-trip form ([`format_f64`]): parsing a cell as f64
//!   gives back the exact value. Plain notation for magnitudes in [1e-3, 1e9) and zero, exponent
//!   notation (`1.5e-7`) otherwise; non-finite values as `NaN`, `inf`, `-inf` (which Python's
//!   `float`, numpy and pandas read). A missing number is NaN, as in HDF5.
//! - text cells quoted (RFC 4180) only when they hold a comma, a quote or a line break.
//! - `,` separated, `\n` line ends, one header line, no comments. A table without rows is its
//!   header line alone.
//!
//! **HDF5**: a table is written as one dataset per column by [`super::hdf5_file`], the one
//! module that assembles HDF5 files; this module knows no HDF5 (nor any other crate's format).

use std::io::{self, Write};
use std::ops::Range;
use std::path::Path;

use thiserror::Error;

use super::atomic::AtomicFile;
use super::error::OutputError;

/// The type of a column's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// 64-bit floats (NaN where a value is missing).
    F64,
    /// 64-bit integers (indices, counts).
    I64,
    /// Text (names, kinds, messages).
    Text,
}

/// A column without its data: name, unit, description and type. The schema of a table is its
/// list of fields.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Name: the HDF5 dataset name and the CSV header's name.
    pub name: String,
    /// SI unit as written in HDF5 `units` and the CSV header (`1` for dimensionless); empty for
    /// text.
    pub unit: String,
    /// One line (HDF5 `description`).
    pub description: String,
    /// Type of the values.
    pub kind: Kind,
}

impl Field {
    /// An f64 field.
    pub fn f64(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
    ) -> Self {
        Self::new(name, unit, description, Kind::F64)
    }

    /// An i64 field.
    pub fn i64(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
    ) -> Self {
        Self::new(name, unit, description, Kind::I64)
    }

    /// A text field (no unit).
    pub fn text(name: impl Into<String>, description: impl Into<String>) -> Self {
        Self::new(name, "", description, Kind::Text)
    }

    fn new(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
        kind: Kind,
    ) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            description: description.into(),
            kind,
        }
    }

    /// The CSV header cell: `name [unit]`, or `name` for text.
    pub fn csv_header(&self) -> String {
        if self.unit.is_empty() {
            self.name.clone()
        } else {
            format!("{} [{}]", self.name, self.unit)
        }
    }
}

/// A column's values.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// Floats.
    F64(Vec<f64>),
    /// Integers.
    I64(Vec<i64>),
    /// Text.
    Text(Vec<String>),
}

impl Data {
    /// No values of `kind`.
    pub fn empty(kind: Kind) -> Self {
        match kind {
            Kind::F64 => Data::F64(Vec::new()),
            Kind::I64 => Data::I64(Vec::new()),
            Kind::Text => Data::Text(Vec::new()),
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Data::F64(v) => v.len(),
            Data::I64(v) => v.len(),
            Data::Text(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The type of the values.
    pub fn kind(&self) -> Kind {
        match self {
            Data::F64(_) => Kind::F64,
            Data::I64(_) => Kind::I64,
            Data::Text(_) => Kind::Text,
        }
    }

    /// The floats, if this is an f64 column.
    pub fn as_f64(&self) -> Option<&[f64]> {
        match self {
            Data::F64(v) => Some(v),
            _ => None,
        }
    }

    /// The integers, if this is an i64 column.
    pub fn as_i64(&self) -> Option<&[i64]> {
        match self {
            Data::I64(v) => Some(v),
            _ => None,
        }
    }

    /// The strings, if this is a text column.
    pub fn as_text(&self) -> Option<&[String]> {
        match self {
            Data::Text(v) => Some(v),
            _ => None,
        }
    }
}

/// One value of a row, for [`Table::push_row`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell<'a> {
    /// A float.
    F64(f64),
    /// An integer.
    I64(i64),
    /// A string.
    Text(&'a str),
}

impl Cell<'_> {
    fn kind(&self) -> Kind {
        match self {
            Cell::F64(_) => Kind::F64,
            Cell::I64(_) => Kind::I64,
            Cell::Text(_) => Kind::Text,
        }
    }
}

/// A column: name, unit, description and data.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Name (HDF5 dataset, CSV header).
    pub name: String,
    /// SI unit (`1` for dimensionless; empty for text).
    pub unit: String,
    /// One line.
    pub description: String,
    /// The values.
    pub data: Data,
}

impl Column {
    /// An f64 column.
    pub fn f64(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
        data: Vec<f64>,
    ) -> Self {
        Self::of(Field::f64(name, unit, description), Data::F64(data))
    }

    /// An f64 column with NaN where a value is missing.
    pub fn f64_opt(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
        data: impl IntoIterator<Item = Option<f64>>,
    ) -> Self {
        let v = data.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect();
        Self::f64(name, unit, description, v)
    }

    /// An i64 column.
    pub fn i64(
        name: impl Into<String>,
        unit: impl Into<String>,
        description: impl Into<String>,
        data: Vec<i64>,
    ) -> Self {
        Self::of(Field::i64(name, unit, description), Data::I64(data))
    }

    /// A text column (no unit).
    pub fn text(
        name: impl Into<String>,
        description: impl Into<String>,
        data: Vec<String>,
    ) -> Self {
        Self::of(Field::text(name, description), Data::Text(data))
    }

    /// A column of `field`'s schema holding `data` (whose type wins over `field.kind`).
    pub fn of(field: Field, data: Data) -> Self {
        Self {
            name: field.name,
            unit: field.unit,
            description: field.description,
            data,
        }
    }

    /// The column's schema.
    pub fn field(&self) -> Field {
        Field {
            name: self.name.clone(),
            unit: self.unit.clone(),
            description: self.description.clone(),
            kind: self.data.kind(),
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

/// Why a table could not be built (a programming error in a writer, not a user's input).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum TableError {
    /// A column has no name.
    #[error("a table column has no name")]
    EmptyName,
    /// Two columns share a name.
    #[error("table column '{0}' appears twice")]
    DuplicateName(String),
    /// A numeric column has no unit, or a text column has one.
    #[error("table column '{name}': a numeric column needs a unit (1 if dimensionless), a text column has none (unit '{unit}')")]
    Unit {
        /// The column.
        name: String,
        /// Its unit.
        unit: String,
    },
    /// A column's length differs from the table's.
    #[error("table column '{name}' has {len} values, the table {rows} rows")]
    Length {
        /// The column.
        name: String,
        /// Its length.
        len: usize,
        /// The table's rows.
        rows: usize,
    },
    /// A row or table does not match the schema (count, names or types).
    #[error("rows do not match the table's columns: {0}")]
    Schema(String),
}

fn check_field(f: &Field) -> Result<(), TableError> {
    if f.name.is_empty() {
        return Err(TableError::EmptyName);
    }
    if (f.kind == Kind::Text) != f.unit.is_empty() {
        return Err(TableError::Unit {
            name: f.name.clone(),
            unit: f.unit.clone(),
        });
    }
    Ok(())
}

/// Columns of equal length, in order (see the module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    columns: Vec<Column>,
}

impl Table {
    /// A table without columns.
    pub fn new() -> Self {
        Self::default()
    }

    /// A table without rows with the columns of `schema`.
    pub fn from_schema(schema: &[Field]) -> Result<Self, TableError> {
        Self::from_columns(
            schema
                .iter()
                .map(|f| Column::of(f.clone(), Data::empty(f.kind)))
                .collect(),
        )
    }

    /// A table of `columns` (checked as by [`push`](Self::push)).
    pub fn from_columns(columns: Vec<Column>) -> Result<Self, TableError> {
        let mut t = Self::new();
        for c in columns {
            t.push(c)?;
        }
        Ok(t)
    }

    /// A table of columns whose names, units and lengths are fixed by the code that builds them
    /// (every writer of djkr): a column that [`push`](Self::push) refuses is a bug, which fails
    /// debug builds and the tests, and is left out of release builds' output.
    pub fn from_fixed(columns: Vec<Column>) -> Self {
        let mut t = Self::new();
        for c in columns {
            let pushed = t.push(c);
            debug_assert!(pushed.is_ok(), "{pushed:?}");
        }
        t
    }

    /// Add a column at the end. Its name must be new and not empty, a numeric column must have a
    /// unit and a text column none, and its length must equal the other columns'.
    pub fn push(&mut self, column: Column) -> Result<(), TableError> {
        check_field(&column.field())?;
        if self.columns.iter().any(|c| c.name == column.name) {
            return Err(TableError::DuplicateName(column.name));
        }
        if let Some(first) = self.columns.first() {
            if column.len() != first.len() {
                return Err(TableError::Length {
                    len: column.len(),
                    name: column.name,
                    rows: first.len(),
                });
            }
        }
        self.columns.push(column);
        Ok(())
    }

    /// The columns by value, in order (a table handed on whole, e.g. to Python).
    pub fn into_columns(self) -> Vec<Column> {
        self.columns
    }

    /// The columns, in order.
    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// The schema: the columns without their data.
    pub fn schema(&self) -> Vec<Field> {
        self.columns.iter().map(Column::field).collect()
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Column::len)
    }

    /// True when the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.rows() == 0
    }

    fn check_kinds(&self, kinds: impl ExactSizeIterator<Item = Kind>) -> Result<(), TableError> {
        if kinds.len() != self.columns.len() {
            return Err(TableError::Schema(format!(
                "{} values for {} columns",
                kinds.len(),
                self.columns.len()
            )));
        }
        for (c, k) in self.columns.iter().zip(kinds) {
            if c.data.kind() != k {
                return Err(TableError::Schema(format!(
                    "column '{}' holds {:?}, got {k:?}",
                    c.name,
                    c.data.kind()
                )));
            }
        }
        Ok(())
    }

    /// Append one row (one cell per column, of the column's type).
    pub fn push_row(&mut self, row: &[Cell]) -> Result<(), TableError> {
        self.check_kinds(row.iter().map(Cell::kind))?;
        for (c, v) in self.columns.iter_mut().zip(row) {
            match (&mut c.data, v) {
                (Data::F64(d), Cell::F64(x)) => d.push(*x),
                (Data::I64(d), Cell::I64(x)) => d.push(*x),
                (Data::Text(d), Cell::Text(x)) => d.push((*x).to_string()),
                _ => {} // excluded by check_kinds
            }
        }
        Ok(())
    }

    /// Append one row of a table whose columns are `f.len()` f64 columns followed by `i.len()`
    /// i64 columns (the time series): the per-sample path, without a `Cell` per value. A row
    /// of another shape is refused.
    pub fn push_numeric_row(&mut self, f: &[f64], i: &[i64]) -> Result<(), TableError> {
        let shape_ok = self.columns.len() == f.len() + i.len()
            && self.columns[..f.len()]
                .iter()
                .all(|c| c.data.kind() == Kind::F64)
            && self.columns[f.len()..]
                .iter()
                .all(|c| c.data.kind() == Kind::I64);
        if !shape_ok {
            return Err(TableError::Schema(format!(
                "a row of {} floats and {} integers does not fit this table",
                f.len(),
                i.len()
            )));
        }
        let (fc, ic) = self.columns.split_at_mut(f.len());
        for (c, &x) in fc.iter_mut().zip(f) {
            if let Data::F64(d) = &mut c.data {
                d.push(x);
            }
        }
        for (c, &x) in ic.iter_mut().zip(i) {
            if let Data::I64(d) = &mut c.data {
                d.push(x);
            }
        }
        Ok(())
    }

    /// Append the rows of `other`, which must have the same column names and types.
    pub fn append_rows(&mut self, other: &Table) -> Result<(), TableError> {
        self.check_kinds(other.columns.iter().map(|c| c.data.kind()))?;
        if let Some((a, b)) = self
            .columns
            .iter()
            .zip(&other.columns)
            .find(|(a, b)| a.name != b.name)
        {
            return Err(TableError::Schema(format!(
                "column '{}' where '{}' was expected",
                b.name, a.name
            )));
        }
        for (a, b) in self.columns.iter_mut().zip(&other.columns) {
            match (&mut a.data, &b.data) {
                (Data::F64(x), Data::F64(y)) => x.extend_from_slice(y),
                (Data::I64(x), Data::I64(y)) => x.extend_from_slice(y),
                (Data::Text(x), Data::Text(y)) => x.extend_from_slice(y),
                _ => {} // excluded by check_kinds
            }
        }
        Ok(())
    }

    /// Write the table as CSV (header and rows; style in the module doc).
    pub fn write_csv(&self, out: &mut impl Write) -> io::Result<()> {
        let mut w = CsvWriter::new(out, &self.schema())?;
        w.write_rows(self)
    }

    /// Write the table as the CSV file `path`, atomically (`super::folder::commit`).
    pub fn save_csv(&self, path: &Path) -> Result<(), OutputError> {
        super::folder::commit(AtomicFile::write_with(path, |w| self.write_csv(w))?).map(|_| ())
    }

    /// The table as CSV text.
    pub fn to_csv(&self) -> String {
        let mut out = Vec::new();
        // Writing to memory cannot fail, and the table's own schema always matches it.
        let _ = self.write_csv(&mut out);
        String::from_utf8(out).unwrap_or_default()
    }

    /// Empty the table (its schema stays): the rows went to disk.
    pub fn clear(&mut self) {
        for c in &mut self.columns {
            match &mut c.data {
                Data::F64(v) => v.clear(),
                Data::I64(v) => v.clear(),
                Data::Text(v) => v.clear(),
            }
        }
    }

    /// Drop the first `n` rows (those already written).
    pub fn remove_first_rows(&mut self, n: usize) {
        for c in &mut self.columns {
            match &mut c.data {
                Data::F64(v) => drop(v.drain(..n.min(v.len()))),
                Data::I64(v) => drop(v.drain(..n.min(v.len()))),
                Data::Text(v) => drop(v.drain(..n.min(v.len()))),
            }
        }
    }
}

/// The descriptions of a file's datasets and groups, written as the group `/descriptions`: two
/// variable-length string datasets of equal length, `path` (the object's absolute path:
/// `/F`, `/cycles/a_cos`, `/events`) and `text` (what it is: unit, what is averaged or fitted,
/// over which period). A dataset gets its row from its table's schema
/// ([`Descriptions::table`]); a group or a dataset written by hand gets one from
/// [`Descriptions::add`]. Rows follow the order they were added in; the table describes itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Descriptions {
    rows: Vec<(String, String)>,
}

/// Name of the group holding a file's [`Descriptions`].
pub const DESCRIPTIONS_GROUP: &str = "descriptions";

impl Descriptions {
    /// The description of `path`, if it has one (the tests read files back).
    #[cfg(test)]
    pub fn get(&self, path: &str) -> Option<&str> {
        self.rows
            .iter()
            .find(|(p, _)| p == path)
            .map(|(_, t)| t.as_str())
    }

    /// No rows yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Describe the object at `path` (absolute: `/events`, `/gaps/t_start`).
    pub fn add(&mut self, path: &str, text: &str) -> &mut Self {
        self.rows.push((path.to_string(), text.to_string()));
        self
    }

    /// Describe the datasets a table of `schema` writes into the group at `group` (`/` for the
    /// root, `/events`, ...), one row per column.
    pub fn table(&mut self, group: &str, schema: &[Field]) -> &mut Self {
        let prefix = group.trim_end_matches('/');
        for f in schema {
            self.add(&format!("{prefix}/{}", f.name), &f.description);
        }
        self
    }

    /// The rows, with the table's own two rows appended, as a table of columns `path` and `text`.
    pub fn to_table(&self) -> Table {
        let g = format!("/{DESCRIPTIONS_GROUP}");
        let mut rows = self.rows.clone();
        rows.push((
            g.clone(),
            "the description of every dataset and group of this file, one per row".into(),
        ));
        rows.push((
            format!("{g}/path"),
            "absolute path of a dataset or group".into(),
        ));
        rows.push((format!("{g}/text"), "what the object at path holds".into()));
        Table::from_fixed(vec![
            Column::text(
                "path",
                "absolute path of a dataset or group",
                rows.iter().map(|r| r.0.clone()).collect(),
            ),
            Column::text(
                "text",
                "what the object at path holds",
                rows.iter().map(|r| r.1.clone()).collect(),
            ),
        ])
    }
}

/// Format an f64 so that it parses back to the same bits: plain notation for magnitudes in
/// [1e-3, 1e9) and zero, exponent notation otherwise, `NaN`, `inf`, `-inf`.
pub fn format_f64(x: f64) -> String {
    let m = x.abs();
    if !x.is_finite() || x == 0.0 || (1e-3..1e9).contains(&m) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

pub use djkr_core::text::format_sig;

/// A value with its standard deviation for a human reader, to the digits the deviation supports:
/// σ to two significant digits and the value to the same decimal place, with a shared power of
/// ten outside [1e-3, 1e6) (`0.468 ± 0.012`, `(5.54 ± 0.87)e-4`). Without a usable σ (none, 0,
/// not finite) the value to 6 significant digits ([`format_sig`]); with a σ below a double's
/// resolution of the value, the value's shortest round-trip digits and σ in e-notation.
pub fn format_pm(x: f64, sigma: Option<f64>) -> String {
    let s = match sigma {
        Some(s) if s.is_finite() && s > 0.0 && x.is_finite() => s,
        _ => return format_sig(x, 6),
    };
    // A σ below what a double resolves of x (its 16th significant digit): x in the shortest
    // digits that read back to it, σ in e-notation (σ's decimals would be hundreds of zeros).
    if s < x.abs() * 1e-15 {
        return format!("{} ± {s:.1e}", format_f64(x));
    }
    let lead = if x == 0.0 { s } else { x.abs().max(s) };
    let mag = lead.log10().floor() as i32;
    let exp = if (-3..6).contains(&mag) { 0 } else { mag };
    let (xs, ss) = (x / 10f64.powi(exp), s / 10f64.powi(exp));
    // Two significant digits of σ (σ rounding up into the next decade keeps its decimals).
    let decimals = (1 - ss.log10().floor() as i32).max(0) as usize;
    if exp == 0 {
        format!("{xs:.decimals$} ± {ss:.decimals$}")
    } else {
        format!("({xs:.decimals$} ± {ss:.decimals$})e{exp}")
    }
}

/// A text cell, quoted when it holds a comma, a quote or a line break (RFC 4180).
fn push_text(line: &mut String, s: &str) {
    if s.contains([',', '"', '\n', '\r']) {
        line.push('"');
        line.push_str(&s.replace('"', "\"\""));
        line.push('"');
    } else {
        line.push_str(s);
    }
}

/// Writes CSV with a fixed schema: the header at creation, then rows of tables with that schema,
/// as many times as needed (streaming).
#[derive(Debug)]
pub(crate) struct CsvWriter<W: Write> {
    out: W,
    schema: Vec<Field>,
    line: String,
}

impl<W: Write> CsvWriter<W> {
    /// Write the header line of `schema` to `out`.
    pub fn new(mut out: W, schema: &[Field]) -> io::Result<Self> {
        let mut line = String::new();
        for (i, f) in schema.iter().enumerate() {
            if i > 0 {
                line.push(',');
            }
            push_text(&mut line, &f.csv_header());
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
        Ok(Self {
            out,
            schema: schema.to_vec(),
            line,
        })
    }

    /// Append the rows of `table`, whose columns must match the schema (names and types).
    pub fn write_rows(&mut self, table: &Table) -> io::Result<()> {
        self.write_row_range(table, 0..table.rows())
    }

    /// [`CsvWriter::write_rows`] for the rows in `rows` only.
    pub fn write_row_range(&mut self, table: &Table, rows: Range<usize>) -> io::Result<()> {
        let same = table.columns.len() == self.schema.len()
            && table
                .columns
                .iter()
                .zip(&self.schema)
                .all(|(c, f)| c.name == f.name && c.data.kind() == f.kind);
        if !same {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "CSV rows do not match the header's columns",
            ));
        }
        for i in rows {
            self.line.clear();
            for (j, c) in table.columns.iter().enumerate() {
                if j > 0 {
                    self.line.push(',');
                }
                match &c.data {
                    Data::F64(v) => self.line.push_str(&format_f64(v[i])),
                    Data::I64(v) => self.line.push_str(&v[i].to_string()),
                    Data::Text(v) => push_text(&mut self.line, &v[i]),
                }
            }
            self.line.push('\n');
            self.out.write_all(self.line.as_bytes())?;
        }
        Ok(())
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.out
    }
}

#[cfg(test)]
mod tests {
    /// A value is printed to the decimal place of its σ's second significant digit.
    #[test]
    fn a_value_with_sigma_shows_the_digits_sigma_supports() {
        assert_eq!(format_pm(0.46821331, Some(0.0121878)), "0.468 ± 0.012");
        assert_eq!(format_pm(5.544306e-4, Some(8.7158e-5)), "(5.54 ± 0.87)e-4");
        assert_eq!(format_pm(4.3937886e-5, Some(6.503e-6)), "(4.39 ± 0.65)e-5");
        assert_eq!(format_pm(5.383021, Some(0.1254)), "5.38 ± 0.13");
        assert_eq!(format_pm(1234.5678, Some(25.0)), "1235 ± 25");
        assert_eq!(format_pm(5.0, Some(30.0)), "5 ± 30");
        assert_eq!(format_pm(0.0, Some(0.0123)), "0.000 ± 0.012");
        assert_eq!(format_pm(2.5e7, Some(3.1e5)), "(2.500 ± 0.031)e7");
        assert_eq!(format_pm(0.5, None), "0.500000");
        assert_eq!(format_pm(0.5, Some(f64::NAN)), "0.500000");
        assert_eq!(
            format_pm(0.5336862003788192, Some(2.8357535889366924e-153)),
            "0.5336862003788192 ± 2.8e-153"
        );
    }

    #[test]
    fn human_numbers_are_plain_decimals_to_their_significant_digits() {
        assert_eq!(format_sig(560.17823904678, 9), "560.178239");
        assert_eq!(format_sig(43.16, 4), "43.16");
        assert_eq!(format_sig(0.0123456, 3), "0.0123");
        assert_eq!(format_sig(999.9996, 6), "1000.00");
        assert_eq!(format_sig(2.5e-7, 3), "2.50e-7");
        assert_eq!(format_sig(-1.5e7, 2), "-1.5e7");
        assert_eq!(format_sig(0.0, 5), "0");
    }

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
        assert_eq!(format_f64(1e-6), "1e-6");
        assert_eq!(format_f64(1234.0), "1234");
    }

    fn sample() -> Table {
        Table::from_columns(vec![
            Column::text("kind", "what", vec!["a,b".into(), "say \"x\"".into()]),
            Column::f64("t", "s", "time", vec![0.5, f64::NAN]),
            Column::i64("stage", "1", "index", vec![0, 3]),
        ])
        .unwrap()
    }

    #[test]
    fn csv_has_unit_headers_quoted_text_and_exact_numbers() {
        let t = sample();
        assert_eq!(
            t.to_csv(),
            "kind,t [s],stage [1]\n\"a,b\",0.5,0\n\"say \"\"x\"\"\",NaN,3\n"
        );
        let empty = Table::from_schema(&t.schema()).unwrap();
        assert_eq!(empty.to_csv(), "kind,t [s],stage [1]\n");
    }

    #[test]
    fn streaming_rows_and_appends_keep_the_schema() {
        let mut t = sample();
        t.push_row(&[Cell::Text("c"), Cell::F64(2.0), Cell::I64(4)])
            .unwrap();
        assert_eq!(t.rows(), 3);
        assert!(t
            .push_row(&[Cell::F64(1.0), Cell::F64(2.0), Cell::I64(4)])
            .is_err());
        assert!(t.push_row(&[Cell::Text("c")]).is_err());
        assert_eq!(t.rows(), 3);
        let other = sample();
        t.append_rows(&other).unwrap();
        assert_eq!(t.rows(), 5);
        assert_eq!(t.column("stage").unwrap().data.as_i64().unwrap()[4], 3);

        let mut out = Vec::new();
        let mut w = CsvWriter::new(&mut out, &t.schema()).unwrap();
        w.write_rows(&sample()).unwrap();
        w.write_rows(&sample()).unwrap();
        assert!(w.write_rows(&Table::new()).is_err());
        assert_eq!(String::from_utf8(out).unwrap().lines().count(), 5);
    }

    #[test]
    fn bad_columns_are_refused() {
        let mut t = sample();
        assert!(matches!(
            t.push(Column::f64("t", "s", "again", vec![1.0, 2.0])),
            Err(TableError::DuplicateName(_))
        ));
        assert!(matches!(
            t.push(Column::f64("x", "m", "short", vec![1.0])),
            Err(TableError::Length { .. })
        ));
        assert!(matches!(
            t.push(Column::f64("x", "", "no unit", vec![1.0, 2.0])),
            Err(TableError::Unit { .. })
        ));
        assert!(matches!(
            t.push(Column::f64("", "m", "no name", vec![1.0, 2.0])),
            Err(TableError::EmptyName)
        ));
        assert_eq!(t.columns().len(), 3);
    }
}
