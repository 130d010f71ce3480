//! CSV tables of saddleflow: named columns in, files out.
//!
//! A [`Table`] is an ordered list of named, typed columns of equal length (`f64`, `i64`,
//! `bool`, `String`). It is written as a CSV file with a header by [`write_csv`] (polars'
//! CSV writer; floats are written in their shortest round-trip form, so reading a table back
//! gives the same bits), published atomically: the bytes go to a temporary file in the target
//! folder, are flushed and synced, and the file is then renamed over the target, so a reader
//! never sees a half-written table. [`read_csv`] loads a CSV and checks that the required
//! columns exist with the required types, with an error that names the file and the column.
//! [`Table::to_markdown`] renders the same data as a GitHub-flavoured Markdown table (for the
//! README's results-vs-paper tables).
//!
//! ```
//! use tables::{Table, ColumnType};
//! let t = Table::new()
//!     .with_str("model", ["hexagonal", "square"])
//!     .with_f64("a_p", [0.178, 0.402])
//!     .with_i64("n", [1024, 1024]);
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("ap.csv");
//! tables::write_csv(&t, &path).unwrap();
//! let back = tables::read_csv(&path, &[("a_p", ColumnType::F64), ("model", ColumnType::Str)]).unwrap();
//! assert_eq!(back.f64("a_p").unwrap(), &[0.178, 0.402]);
//! ```

use std::fmt;
use std::path::Path;

use anyhow::{Context, Result, anyhow, bail, ensure};
use polars::prelude::{
    Column as PlColumn, CsvReadOptions, CsvWriter, DataFrame, DataType, SerReader, SerWriter,
};

/// The type of a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnType {
    /// 64-bit float. On reading, an integer column is accepted and converted.
    F64,
    /// 64-bit signed integer.
    I64,
    /// Boolean, written as `true` / `false`.
    Bool,
    /// UTF-8 text. On reading, any column can be read as text.
    Str,
}

impl fmt::Display for ColumnType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ColumnType::F64 => "f64",
            ColumnType::I64 => "i64",
            ColumnType::Bool => "bool",
            ColumnType::Str => "string",
        })
    }
}

/// The values of one column.
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnData {
    /// Floats; NaN is written as `NaN` and read back as NaN; an empty cell reads as NaN.
    F64(Vec<f64>),
    /// Integers.
    I64(Vec<i64>),
    /// Booleans.
    Bool(Vec<bool>),
    /// Text.
    Str(Vec<String>),
}

impl ColumnData {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            ColumnData::F64(v) => v.len(),
            ColumnData::I64(v) => v.len(),
            ColumnData::Bool(v) => v.len(),
            ColumnData::Str(v) => v.len(),
        }
    }

    /// True when the column has no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The column's type.
    pub fn column_type(&self) -> ColumnType {
        match self {
            ColumnData::F64(_) => ColumnType::F64,
            ColumnData::I64(_) => ColumnType::I64,
            ColumnData::Bool(_) => ColumnType::Bool,
            ColumnData::Str(_) => ColumnType::Str,
        }
    }
}

/// A named column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Header name (unique within a table).
    pub name: String,
    /// Values.
    pub data: ColumnData,
}

/// Ordered named columns of equal length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    columns: Vec<Column>,
}

impl Table {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends a column. Fails when the name is taken or the length differs from the
    /// existing columns'.
    pub fn push(&mut self, name: impl Into<String>, data: ColumnData) -> Result<()> {
        let name = name.into();
        ensure!(!name.is_empty(), "table column names must not be empty");
        ensure!(
            self.column(&name).is_none(),
            "table already has a column named {name:?}"
        );
        if let Some(first) = self.columns.first() {
            ensure!(
                first.data.len() == data.len(),
                "column {name:?} has {} rows but column {:?} has {}",
                data.len(),
                first.name,
                first.data.len()
            );
        }
        self.columns.push(Column { name, data });
        Ok(())
    }

    fn with(mut self, name: &str, data: ColumnData) -> Self {
        if let Err(e) = self.push(name, data) {
            panic!("{e}");
        }
        self
    }

    /// Builder: appends an `f64` column. Panics on a duplicate name or a length mismatch (a
    /// programming error); use [`Table::push`] to handle those as errors.
    pub fn with_f64(self, name: &str, values: impl IntoIterator<Item = f64>) -> Self {
        self.with(name, ColumnData::F64(values.into_iter().collect()))
    }

    /// Builder: appends an `i64` column (panics like [`Table::with_f64`]).
    pub fn with_i64(self, name: &str, values: impl IntoIterator<Item = i64>) -> Self {
        self.with(name, ColumnData::I64(values.into_iter().collect()))
    }

    /// Builder: appends a `bool` column (panics like [`Table::with_f64`]).
    pub fn with_bool(self, name: &str, values: impl IntoIterator<Item = bool>) -> Self {
        self.with(name, ColumnData::Bool(values.into_iter().collect()))
    }

    /// Builder: appends a text column (panics like [`Table::with_f64`]).
    pub fn with_str<S: Into<String>>(
        self,
        name: &str,
        values: impl IntoIterator<Item = S>,
    ) -> Self {
        self.with(
            name,
            ColumnData::Str(values.into_iter().map(Into::into).collect()),
        )
    }

    /// The columns in order.
    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// Number of rows (0 for a table without columns).
    pub fn n_rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.name == name)
    }

    fn typed(&self, name: &str, ty: ColumnType) -> Result<&ColumnData> {
        let c = self
            .column(name)
            .ok_or_else(|| anyhow!("table has no column {name:?}"))?;
        ensure!(
            c.data.column_type() == ty,
            "column {name:?} is {}, not {ty}",
            c.data.column_type()
        );
        Ok(&c.data)
    }

    /// The values of an `f64` column.
    pub fn f64(&self, name: &str) -> Result<&[f64]> {
        match self.typed(name, ColumnType::F64)? {
            ColumnData::F64(v) => Ok(v),
            _ => unreachable!(),
        }
    }

    /// The values of an `i64` column.
    pub fn i64(&self, name: &str) -> Result<&[i64]> {
        match self.typed(name, ColumnType::I64)? {
            ColumnData::I64(v) => Ok(v),
            _ => unreachable!(),
        }
    }

    /// The values of a `bool` column.
    pub fn bool(&self, name: &str) -> Result<&[bool]> {
        match self.typed(name, ColumnType::Bool)? {
            ColumnData::Bool(v) => Ok(v),
            _ => unreachable!(),
        }
    }

    /// The values of a text column.
    pub fn str(&self, name: &str) -> Result<&[String]> {
        match self.typed(name, ColumnType::Str)? {
            ColumnData::Str(v) => Ok(v),
            _ => unreachable!(),
        }
    }

    /// Converts to a polars `DataFrame`.
    pub fn to_dataframe(&self) -> Result<DataFrame> {
        let cols: Vec<PlColumn> = self
            .columns
            .iter()
            .map(|c| {
                let name = c.name.as_str().into();
                match &c.data {
                    ColumnData::F64(v) => PlColumn::new(name, v.as_slice()),
                    ColumnData::I64(v) => PlColumn::new(name, v.as_slice()),
                    ColumnData::Bool(v) => PlColumn::new(name, v.as_slice()),
                    ColumnData::Str(v) => PlColumn::new(name, v.as_slice()),
                }
            })
            .collect();
        Ok(DataFrame::new(self.n_rows(), cols)?)
    }

    /// Renders a GitHub-flavoured Markdown table. Floats use `format` (see [`FloatFormat`]);
    /// numeric columns are right-aligned, text and booleans left-aligned; `|` in text is
    /// escaped.
    pub fn to_markdown(&self, format: FloatFormat) -> String {
        let n = self.n_rows();
        let mut cells: Vec<Vec<String>> = Vec::with_capacity(self.columns.len());
        for c in &self.columns {
            let col: Vec<String> = match &c.data {
                ColumnData::F64(v) => v.iter().map(|&x| format.apply(x)).collect(),
                ColumnData::I64(v) => v.iter().map(|x| x.to_string()).collect(),
                ColumnData::Bool(v) => v.iter().map(|x| x.to_string()).collect(),
                ColumnData::Str(v) => v.iter().map(|s| s.replace('|', "\\|")).collect(),
            };
            cells.push(col);
        }
        let widths: Vec<usize> = self
            .columns
            .iter()
            .zip(&cells)
            .map(|(c, col)| {
                col.iter()
                    .map(|s| s.chars().count())
                    .chain([c.name.chars().count(), 3])
                    .max()
                    .unwrap_or(3)
            })
            .collect();
        let right: Vec<bool> = self
            .columns
            .iter()
            .map(|c| matches!(c.data, ColumnData::F64(_) | ColumnData::I64(_)))
            .collect();
        let pad = |s: &str, w: usize, right: bool| {
            let fill = " ".repeat(w - s.chars().count());
            if right {
                format!("{fill}{s}")
            } else {
                format!("{s}{fill}")
            }
        };
        let mut out = String::new();
        let header: Vec<String> = self
            .columns
            .iter()
            .enumerate()
            .map(|(k, c)| pad(&c.name.replace('|', "\\|"), widths[k], right[k]))
            .collect();
        out.push_str(&format!("| {} |\n", header.join(" | ")));
        let rule: Vec<String> = (0..self.columns.len())
            .map(|k| {
                if right[k] {
                    format!("{}:", "-".repeat(widths[k] - 1))
                } else {
                    "-".repeat(widths[k])
                }
            })
            .collect();
        out.push_str(&format!("| {} |\n", rule.join(" | ")));
        for r in 0..n {
            let row: Vec<String> = (0..self.columns.len())
                .map(|k| pad(&cells[k][r], widths[k], right[k]))
                .collect();
            out.push_str(&format!("| {} |\n", row.join(" | ")));
        }
        out
    }
}

/// A value with its 1σ error in the concise notation of the literature: two significant digits
/// of the error in parentheses, applying to the last digits of the value ("0.17826(11)" for
/// 0.178262 ± 0.000107, "31.5(12)" for 31.49 ± 1.2, "123(15)" for 123.4 ± 15). An error that
/// is zero, negative or not finite gives the value alone with `sig` significant digits.
pub fn concise(value: f64, error: f64, sig: usize) -> String {
    if !value.is_finite() {
        return FloatFormat::Significant(sig).apply(value);
    }
    if !(error.is_finite() && error > 0.0) {
        return FloatFormat::Significant(sig).apply(value);
    }
    let mut decimals = (1 - error.log10().floor() as i32).max(0);
    let mut digits = (error * 10f64.powi(decimals)).round();
    // 0.0996 rounds to 100 at 5 decimals: one decimal fewer
    if digits >= 100.0 && decimals > 0 {
        decimals -= 1;
        digits = (error * 10f64.powi(decimals)).round();
    }
    let v = FloatFormat::Fixed(decimals as usize).apply(value);
    format!("{v}({})", digits as i64)
}

/// How [`Table::to_markdown`] prints floats.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FloatFormat {
    /// Shortest representation that reads back to the same value.
    Shortest,
    /// This many significant digits (plain or scientific notation, whichever is
    /// conventional for the magnitude).
    Significant(usize),
    /// This many digits after the decimal point.
    Fixed(usize),
}

impl FloatFormat {
    /// `x` as [`Table::to_markdown`] prints it (NaN as "–", a typographic minus).
    pub fn apply(self, x: f64) -> String {
        if !x.is_finite() {
            return if x.is_nan() {
                "–".to_string()
            } else if x > 0.0 {
                "∞".to_string()
            } else {
                "−∞".to_string()
            };
        }
        let s = match self {
            FloatFormat::Shortest => format!("{x}"),
            FloatFormat::Fixed(d) => format!("{x:.d$}"),
            FloatFormat::Significant(d) => {
                let d = d.max(1);
                if x == 0.0 {
                    "0".to_string()
                } else {
                    let e = x.abs().log10().floor() as i32;
                    if (-3..6).contains(&e) {
                        let decimals = (d as i32 - 1 - e).max(0) as usize;
                        format!("{x:.decimals$}")
                    } else {
                        format!("{x:.prec$e}", prec = d - 1)
                    }
                }
            }
        };
        // a typographic minus reads better in a rendered table
        if let Some(rest) = s.strip_prefix('-') {
            format!("−{rest}")
        } else {
            s
        }
    }
}

/// The CSV encoding of `table` with a header (nulls empty): the one encoding of every CSV the
/// project writes.
pub fn csv_bytes(table: &Table) -> Result<Vec<u8>> {
    let mut df = table.to_dataframe()?;
    let mut bytes = Vec::new();
    CsvWriter::new(&mut bytes)
        .include_header(true)
        .with_null_value("".into())
        .finish(&mut df)
        .context("encoding CSV")?;
    Ok(bytes)
}

/// Writes `table` as CSV with a header to `path`, atomically: the data go to a temporary file
/// in the same folder (created if missing), which is flushed, synced and renamed over `path`.
pub fn write_csv(table: &Table, path: &Path) -> Result<()> {
    let bytes = csv_bytes(table).with_context(|| format!("for {}", path.display()))?;
    write_atomic(path, &bytes)
}

pub use fsutil::write_atomic;

/// Reads a CSV file with a header. Every column of the file is returned (typed as polars
/// infers it: integer → `i64`, float → `f64`, `true`/`false` → `bool`, else text); each
/// `required` column must exist and be convertible to its type (`i64` → `f64` is, anything →
/// text is; nothing else). Errors name the file and the column.
pub fn read_csv(path: &Path, required: &[(&str, ColumnType)]) -> Result<Table> {
    let df = CsvReadOptions::default()
        .with_has_header(true)
        .with_infer_schema_length(None)
        .try_into_reader_with_file_path(Some(path.to_path_buf()))
        .and_then(|r| r.finish())
        .with_context(|| format!("reading CSV {}", path.display()))?;
    let mut table = Table::new();
    for c in df.columns() {
        let name = c.name().as_str();
        let want = required.iter().find(|(n, _)| *n == name).map(|(_, t)| *t);
        let data = convert(c, want)
            .with_context(|| format!("{}: column {name:?} (type {})", path.display(), c.dtype()))?;
        table.push(name, data)?;
    }
    for (name, ty) in required {
        if table.column(name).is_none() {
            let have: Vec<&str> = table.columns.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "{}: missing required column {name:?} ({ty}); the file has {have:?}",
                path.display()
            );
        }
    }
    Ok(table)
}

fn convert(c: &PlColumn, want: Option<ColumnType>) -> Result<ColumnData> {
    let dt = c.dtype();
    let natural = match dt {
        DataType::Float64 | DataType::Float32 => ColumnType::F64,
        DataType::Int64 | DataType::Int32 | DataType::Int16 | DataType::Int8 => ColumnType::I64,
        DataType::UInt64 | DataType::UInt32 | DataType::UInt16 | DataType::UInt8 => ColumnType::I64,
        DataType::Boolean => ColumnType::Bool,
        DataType::Null => want.unwrap_or(ColumnType::Str),
        _ => ColumnType::Str,
    };
    let target = want.unwrap_or(natural);
    let ok = target == natural
        || target == ColumnType::Str
        || (target == ColumnType::F64 && natural == ColumnType::I64);
    if !ok {
        bail!("expected {target}, found {natural}");
    }
    let null_count = c.null_count();
    Ok(match target {
        ColumnType::F64 => {
            let s = c.cast(&DataType::Float64)?;
            ColumnData::F64(s.f64()?.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
        }
        ColumnType::I64 => {
            ensure!(null_count == 0, "{null_count} empty cells in an i64 column");
            let s = c.cast(&DataType::Int64)?;
            ColumnData::I64(s.i64()?.iter().map(|v| v.unwrap_or(0)).collect())
        }
        ColumnType::Bool => {
            ensure!(null_count == 0, "{null_count} empty cells in a bool column");
            ColumnData::Bool(c.bool()?.iter().map(|v| v.unwrap_or(false)).collect())
        }
        ColumnType::Str => {
            let s = c.cast(&DataType::String)?;
            ColumnData::Str(
                s.str()?
                    .iter()
                    .map(|v| v.unwrap_or("").to_string())
                    .collect(),
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    #[test]
    fn concise_notation() {
        assert_eq!(concise(0.178262, 0.000107, 5), "0.17826(11)");
        assert_eq!(concise(0.67323, 0.00001, 5), "0.673230(10)");
        assert_eq!(concise(31.49, 1.2, 4), "31.5(12)");
        assert_eq!(concise(123.4, 15.0, 4), "123(15)");
        assert_eq!(concise(0.5, 0.09996, 4), "0.50(10)");
        assert_eq!(concise(-0.0012, 0.00034, 4), "−0.00120(34)");
        assert_eq!(concise(0.25, f64::NAN, 3), "0.250");
        assert_eq!(concise(f64::NAN, 0.1, 3), "–");
    }

    fn sample() -> Table {
        Table::new()
            .with_str("model", ["hexagonal", "square", "tri|angular"])
            .with_f64("a_p", [0.178_26, 0.401_85, -1.0 / 3.0])
            .with_i64("n", [256, 512, 1024])
            .with_bool("percolates", [true, false, true])
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/t.csv");
        let t = sample().with_f64("odd", [f64::NAN, 1e-300, 6.02214076e23]);
        write_csv(&t, &path).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("model,a_p,n,percolates,odd\n"), "{text}");
        let back = read_csv(
            &path,
            &[
                ("model", ColumnType::Str),
                ("a_p", ColumnType::F64),
                ("n", ColumnType::I64),
                ("percolates", ColumnType::Bool),
                ("odd", ColumnType::F64),
            ],
        )
        .unwrap();
        assert_eq!(back.str("model").unwrap(), t.str("model").unwrap());
        assert_eq!(back.f64("a_p").unwrap(), t.f64("a_p").unwrap());
        assert_eq!(back.i64("n").unwrap(), &[256, 512, 1024]);
        assert_eq!(back.bool("percolates").unwrap(), &[true, false, true]);
        let odd = back.f64("odd").unwrap();
        assert!(odd[0].is_nan());
        assert_eq!(&odd[1..], &[1e-300, 6.02214076e23]);
        // no temporary files left behind
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("t.csv")]);
    }

    #[test]
    fn integers_are_accepted_as_floats_and_anything_as_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        write_csv(&sample(), &path).unwrap();
        let back = read_csv(&path, &[("n", ColumnType::F64), ("a_p", ColumnType::Str)]).unwrap();
        assert_eq!(back.f64("n").unwrap(), &[256.0, 512.0, 1024.0]);
        assert_eq!(back.str("a_p").unwrap()[1], "0.40185");
    }

    #[test]
    fn missing_and_ill_typed_columns_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        write_csv(&sample(), &path).unwrap();
        let err = read_csv(&path, &[("load", ColumnType::F64)]).unwrap_err();
        let msg = format!("{err:#}");
        assert!(msg.contains("t.csv") && msg.contains("\"load\""), "{msg}");
        let err = read_csv(&path, &[("model", ColumnType::F64)]).unwrap_err();
        let msg = format!("{err:#}");
        assert!(
            msg.contains("t.csv") && msg.contains("\"model\"") && msg.contains("expected f64"),
            "{msg}"
        );
        let err = read_csv(&path, &[("a_p", ColumnType::I64)]).unwrap_err();
        assert!(format!("{err:#}").contains("\"a_p\""));
        let err = read_csv(&dir.path().join("nope.csv"), &[]).unwrap_err();
        assert!(format!("{err:#}").contains("nope.csv"));
    }

    #[test]
    fn empty_float_cells_read_as_nan() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        fs::write(&path, "x,y\n1.5,2\n,3\n").unwrap();
        let t = read_csv(&path, &[("x", ColumnType::F64), ("y", ColumnType::I64)]).unwrap();
        let x = t.f64("x").unwrap();
        assert_eq!(x[0], 1.5);
        assert!(x[1].is_nan());
        assert_eq!(t.i64("y").unwrap(), &[2, 3]);
    }

    #[test]
    fn table_rejects_ragged_and_duplicate_columns() {
        let mut t = Table::new().with_f64("x", [1.0, 2.0]);
        assert!(t.push("y", ColumnData::I64(vec![1])).is_err());
        assert!(t.push("x", ColumnData::I64(vec![1, 2])).is_err());
        assert!(t.push("y", ColumnData::I64(vec![1, 2])).is_ok());
        assert!(t.f64("y").is_err());
        assert_eq!(t.n_rows(), 2);
    }

    #[test]
    fn markdown_rendering() {
        let md = sample().to_markdown(FloatFormat::Significant(3));
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(lines.len(), 5);
        assert_eq!(lines[0], "| model        |    a_p |    n | percolates |");
        assert_eq!(lines[1], "| ------------ | -----: | ---: | ---------- |");
        assert_eq!(lines[2], "| hexagonal    |  0.178 |  256 | true       |");
        assert_eq!(lines[4], "| tri\\|angular | −0.333 | 1024 | true       |");
        assert_eq!(FloatFormat::Significant(3).apply(1.234e-7), "1.23e-7");
        assert_eq!(FloatFormat::Fixed(2).apply(1.23456), "1.23");
        assert_eq!(FloatFormat::Shortest.apply(0.1), "0.1");
        assert_eq!(FloatFormat::Significant(2).apply(f64::NAN), "–");
    }
}
