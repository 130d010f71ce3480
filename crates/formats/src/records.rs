//! Record specs: the one declaration of an artefact's table of records (a sweep's points, a
//! flow's stops, …) that its writer, its reader and its CSV table all use.
//!
//! An artefact stores a table of records column by column, one 1-D dataset per field under a
//! group (`points/load`, `points/branch`, …). [`record!`](crate::record) declares the record
//! struct once and derives [`Record`] from its fields: the column list ([`Record::COLUMNS`],
//! name and [`ColumnKind`] in declaration order), [`Record::write`] (the datasets, in that
//! order), [`Record::read`] (every column, lengths checked, errors naming the dataset) and
//! [`Record::values`] (one column as plain [`Values`], what a CSV table is built from).
//!
//! A field's type says how it is stored ([`Column`]): `f64` as float64, `i64` and `usize` as
//! int64, `bool` as uint8 (0 or 1), `String` as variable-length text, and an enum as text
//! through its `Display`/`FromStr` ([`text_column!`](crate::text_column); an unknown name in
//! a file is an error that names the dataset, the row and the value).

use anyhow::{Context, Result, anyhow, bail};
use store::{ArtefactReader, ArtefactWriter};

/// How a column is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColumnKind {
    /// float64.
    F64,
    /// int64.
    I64,
    /// uint8, 0 or 1.
    Bool,
    /// Variable-length text (also enums, by name).
    Text,
}

/// One column of a record: its dataset name (the field's name) and storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnSpec {
    /// Dataset name under the record's group, and the field's name.
    pub name: &'static str,
    /// Storage.
    pub kind: ColumnKind,
}

/// One column's values, in plain types (what a table is built from).
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    /// Floats.
    F64(Vec<f64>),
    /// Integers.
    I64(Vec<i64>),
    /// Booleans.
    Bool(Vec<bool>),
    /// Text (enums by name).
    Text(Vec<String>),
}

/// A field type that can be a column.
pub trait Column: Sized + Clone {
    /// How it is stored.
    const KIND: ColumnKind;
    /// Writes `values` as the dataset `path`.
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()>;
    /// Reads the dataset `path`.
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>>;
    /// The values in plain types.
    fn values(values: Vec<Self>) -> Values;
}

impl Column for f64 {
    const KIND: ColumnKind = ColumnKind::F64;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        w.write_f64_1d(path, values)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        r.read_f64_1d(path)
    }
    fn values(values: Vec<Self>) -> Values {
        Values::F64(values)
    }
}

impl Column for i64 {
    const KIND: ColumnKind = ColumnKind::I64;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        w.write_i64_1d(path, values)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        r.read_i64_1d(path)
    }
    fn values(values: Vec<Self>) -> Values {
        Values::I64(values)
    }
}

/// Reads an int64 column as `T`; an entry out of `T`'s range names the row, value and `allowed`.
fn read_int<T: TryFrom<i64>>(r: &ArtefactReader, path: &str, allowed: &str) -> Result<Vec<T>> {
    r.read_i64_1d(path)?
        .into_iter()
        .enumerate()
        .map(|(k, x)| {
            T::try_from(x).map_err(|_| anyhow!("`{path}` row {k}: {x}; allowed: {allowed}"))
        })
        .collect()
}

impl Column for usize {
    const KIND: ColumnKind = ColumnKind::I64;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        let v: Vec<i64> = values.iter().map(|&x| x as i64).collect();
        w.write_i64_1d(path, &v)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        read_int(r, path, "an index ≥ 0")
    }
    fn values(values: Vec<Self>) -> Values {
        Values::I64(values.into_iter().map(|x| x as i64).collect())
    }
}

impl Column for u32 {
    const KIND: ColumnKind = ColumnKind::I64;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        let v: Vec<i64> = values.iter().map(|&x| i64::from(x)).collect();
        w.write_i64_1d(path, &v)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        read_int(r, path, &format!("an integer in [0, {}]", u32::MAX))
    }
    fn values(values: Vec<Self>) -> Values {
        Values::I64(values.into_iter().map(i64::from).collect())
    }
}

impl Column for bool {
    const KIND: ColumnKind = ColumnKind::Bool;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        let v: Vec<u8> = values.iter().map(|&x| x as u8).collect();
        w.write_u8_1d(path, &v)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        r.read_u8_1d(path)?
            .into_iter()
            .enumerate()
            .map(|(k, x)| match x {
                0 => Ok(false),
                1 => Ok(true),
                _ => Err(anyhow!("`{path}` row {k}: {x}; allowed: 0 or 1")),
            })
            .collect()
    }
    fn values(values: Vec<Self>) -> Values {
        Values::Bool(values)
    }
}

impl Column for String {
    const KIND: ColumnKind = ColumnKind::Text;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        w.write_strings(path, values)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        r.read_strings(path)
    }
    fn values(values: Vec<Self>) -> Values {
        Values::Text(values)
    }
}

/// Writes an enum column by `Display` (for [`text_column!`](crate::text_column)).
pub fn write_text<T: std::fmt::Display>(
    w: &mut ArtefactWriter,
    path: &str,
    values: &[T],
) -> Result<()> {
    let v: Vec<String> = values.iter().map(|x| x.to_string()).collect();
    w.write_strings(path, &v)
}

/// Reads an enum column by `FromStr`; an unknown name names the dataset, row and value.
pub fn read_text<T>(r: &ArtefactReader, path: &str) -> Result<Vec<T>>
where
    T: std::str::FromStr,
    T::Err: std::fmt::Display,
{
    r.read_strings(path)?
        .into_iter()
        .enumerate()
        .map(|(k, s)| {
            s.parse::<T>()
                .map_err(|e| anyhow!("`{path}` row {k}: `{s}`: {e}"))
        })
        .collect()
}

/// Implements [`Column`] for an enum with `Display` and `FromStr` (stored as text).
#[macro_export]
macro_rules! text_column {
    ($t:ty) => {
        impl $crate::records::Column for $t {
            const KIND: $crate::records::ColumnKind = $crate::records::ColumnKind::Text;
            fn write(
                w: &mut ::store::ArtefactWriter,
                path: &str,
                values: &[Self],
            ) -> ::anyhow::Result<()> {
                $crate::records::write_text(w, path, values)
            }
            fn read(r: &::store::ArtefactReader, path: &str) -> ::anyhow::Result<Vec<Self>> {
                $crate::records::read_text(r, path)
            }
            fn values(values: Vec<Self>) -> $crate::records::Values {
                $crate::records::Values::Text(values.iter().map(|x| x.to_string()).collect())
            }
        }
    };
}

text_column!(contact::path::Branch);

/// The flow solver's terminations by [`gapfile::termination_name`](crate::gapfile::termination_name).
impl Column for reynolds::Termination {
    const KIND: ColumnKind = ColumnKind::Text;
    fn write(w: &mut ArtefactWriter, path: &str, values: &[Self]) -> Result<()> {
        let v: Vec<&str> = values
            .iter()
            .map(|&t| crate::gapfile::termination_name(t))
            .collect();
        w.write_strings(path, &v)
    }
    fn read(r: &ArtefactReader, path: &str) -> Result<Vec<Self>> {
        r.read_strings(path)?
            .into_iter()
            .enumerate()
            .map(|(k, s)| {
                crate::gapfile::parse_termination(&s).map_err(|e| anyhow!("`{path}` row {k}: {e}"))
            })
            .collect()
    }
    fn values(values: Vec<Self>) -> Values {
        Values::Text(
            values
                .into_iter()
                .map(|t| crate::gapfile::termination_name(t).to_string())
                .collect(),
        )
    }
}

/// A table of records stored column by column under a group.
pub trait Record: Sized {
    /// The columns in declaration (and writing) order.
    const COLUMNS: &'static [ColumnSpec];
    /// Writes `rows` as `<group>/<column>` datasets (empty datasets for no rows; `group` `""`
    /// writes them at the root).
    fn write(rows: &[Self], w: &mut ArtefactWriter, group: &str) -> Result<()>;
    /// Reads the `<group>/<column>` datasets back; all columns must have the same length.
    fn read(r: &ArtefactReader, group: &str) -> Result<Vec<Self>>;
    /// One column's values (`None` for a name that is not a column).
    fn values(rows: &[Self], column: &str) -> Option<Values>;
}

/// The dataset path of column `name` under `group` (`""`: the root, the bare name).
pub fn column_path(group: &str, name: &str) -> String {
    let group = group.trim_end_matches('/');
    if group.is_empty() {
        name.to_string()
    } else {
        format!("{group}/{name}")
    }
}

/// Checks that column `name` has `len` rows like the first column (used by [`record!`](crate::record)).
pub fn check_len(group: &str, first: &str, n: usize, name: &str, len: usize) -> Result<()> {
    if len != n {
        bail!(
            "`{}` has {len} entries, `{}` has {n}",
            column_path(group, name),
            column_path(group, first)
        );
    }
    Ok(())
}

/// Adds the artefact's path to a reader's error.
pub fn read_in<R: Record>(r: &ArtefactReader, group: &str) -> Result<Vec<R>> {
    R::read(r, group).with_context(|| {
        format!(
            "reading the records `{}` of artefact `{}`",
            column_path(group, "*"),
            r.path().display()
        )
    })
}

/// Declares a record struct and derives [`Record`] from its fields (see the module doc).
/// Every field must be `pub` and its type a [`Column`].
#[macro_export]
macro_rules! record {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $( $(#[$fmeta:meta])* pub $field:ident : $ty:ty ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )+
        }

        impl $crate::records::Record for $name {
            const COLUMNS: &'static [$crate::records::ColumnSpec] = &[
                $( $crate::records::ColumnSpec {
                    name: stringify!($field),
                    kind: <$ty as $crate::records::Column>::KIND,
                }, )+
            ];
            fn write(
                rows: &[Self],
                w: &mut ::store::ArtefactWriter,
                group: &str,
            ) -> ::anyhow::Result<()> {
                $(
                    let col: Vec<$ty> = rows.iter().map(|r| r.$field.clone()).collect();
                    <$ty as $crate::records::Column>::write(
                        w,
                        &$crate::records::column_path(group, stringify!($field)),
                        &col,
                    )?;
                )+
                Ok(())
            }
            fn read(r: &::store::ArtefactReader, group: &str) -> ::anyhow::Result<Vec<Self>> {
                $(
                    let $field = <$ty as $crate::records::Column>::read(
                        r,
                        &$crate::records::column_path(group, stringify!($field)),
                    )?;
                )+
                let first = Self::COLUMNS[0].name;
                let n = [$( $field.len() ),+][0];
                $( $crate::records::check_len(group, first, n, stringify!($field), $field.len())?; )+
                $( let mut $field = $field.into_iter(); )+
                Ok((0..n)
                    .map(|_| Self {
                        $( $field: $field.next().expect("length checked"), )+
                    })
                    .collect())
            }
            fn values(rows: &[Self], column: &str) -> Option<$crate::records::Values> {
                $(
                    if column == stringify!($field) {
                        let col: Vec<$ty> = rows.iter().map(|r| r.$field.clone()).collect();
                        return Some(<$ty as $crate::records::Column>::values(col));
                    }
                )+
                None
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use contact::path::Branch;

    crate::record! {
        /// A test record with every column type.
        #[derive(Clone, Debug, PartialEq)]
        pub struct Row {
            /// An enum.
            pub branch: Branch,
            /// An index.
            pub index: usize,
            /// An integer.
            pub count: i64,
            /// A float.
            pub x: f64,
            /// A flag.
            pub ok: bool,
            /// Text.
            pub note: String,
        }
    }

    fn rows() -> Vec<Row> {
        vec![
            Row {
                branch: Branch::Loading,
                index: 3,
                count: -2,
                x: f64::NAN,
                ok: true,
                note: "a".into(),
            },
            Row {
                branch: Branch::Unloading,
                index: 0,
                count: 7,
                x: 1.5e-300,
                ok: false,
                note: String::new(),
            },
        ]
    }

    fn writer(dir: &std::path::Path) -> ArtefactWriter {
        ArtefactWriter::create(dir.join("a.h5")).unwrap()
    }

    #[test]
    fn columns_follow_the_declaration() {
        let names: Vec<&str> = Row::COLUMNS.iter().map(|c| c.name).collect();
        assert_eq!(names, ["branch", "index", "count", "x", "ok", "note"]);
        let kinds: Vec<ColumnKind> = Row::COLUMNS.iter().map(|c| c.kind).collect();
        use ColumnKind::*;
        assert_eq!(kinds, [Text, I64, I64, F64, Bool, Text]);
        assert_eq!(
            Row::values(&rows(), "branch"),
            Some(Values::Text(vec!["loading".into(), "unloading".into()]))
        );
        assert_eq!(Row::values(&rows(), "index"), Some(Values::I64(vec![3, 0])));
        assert_eq!(Row::values(&rows(), "nope"), None);
    }

    #[test]
    fn write_then_read_gives_the_rows_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = writer(dir.path());
        Row::write(&rows(), &mut w, "points").unwrap();
        Row::write(&[], &mut w, "none").unwrap();
        let path = w.publish().unwrap();
        let r = ArtefactReader::open(&path).unwrap();
        let back: Vec<Row> = read_in(&r, "points").unwrap();
        assert_eq!(back.len(), 2);
        assert!(back[0].x.is_nan());
        assert_eq!(back[1], rows()[1]);
        assert_eq!(
            (back[0].branch, back[0].index, back[0].ok),
            (Branch::Loading, 3, true)
        );
        assert!(read_in::<Row>(&r, "none").unwrap().is_empty());
    }

    #[test]
    fn unequal_columns_and_unknown_names_are_errors_that_name_the_dataset() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = writer(dir.path());
        Row::write(&rows(), &mut w, "short").unwrap();
        // a third row in one column only
        w.write_strings("short2/branch", &["loading", "loading"])
            .unwrap();
        w.write_i64_1d("short2/index", &[0, 1]).unwrap();
        w.write_i64_1d("short2/count", &[0, 1]).unwrap();
        w.write_f64_1d("short2/x", &[1.0, 2.0, 3.0]).unwrap();
        w.write_u8_1d("short2/ok", &[0, 1]).unwrap();
        w.write_strings("short2/note", &["", ""]).unwrap();
        // a branch name no Branch has
        w.write_strings("renamed/branch", &["loading", "sideways"])
            .unwrap();
        let path = w.publish().unwrap();
        let r = ArtefactReader::open(&path).unwrap();
        assert!(read_in::<Row>(&r, "short").is_ok());
        let e = format!("{:#}", read_in::<Row>(&r, "short2").unwrap_err());
        assert!(
            e.contains("`short2/x` has 3 entries, `short2/branch` has 2"),
            "{e}"
        );
        let e = format!("{:#}", read_in::<Row>(&r, "renamed").unwrap_err());
        assert!(e.contains("renamed/branch` row 1: `sideways`"), "{e}");
        assert!(e.contains("allowed loading, unloading"), "{e}");
    }

    crate::record! {
        /// A record with a `u32` column, stored at the root.
        #[derive(Clone, Debug, PartialEq)]
        pub struct Level {
            /// A grid exponent.
            pub n: u32,
            /// A spacing.
            pub h: f64,
        }
    }

    #[test]
    fn root_records_and_u32_columns_round_trip_and_reject_negatives() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = writer(dir.path());
        let rows = vec![Level { n: 7, h: 0.5 }, Level { n: 8, h: 0.25 }];
        Level::write(&rows, &mut w, "").unwrap();
        w.write_i64_1d("bad/n", &[3, -1]).unwrap();
        w.write_f64_1d("bad/h", &[1.0, 2.0]).unwrap();
        let path = w.publish().unwrap();
        let r = ArtefactReader::open(&path).unwrap();
        // at the root: the bare dataset names
        assert_eq!(r.read_i64_1d("n").unwrap(), [7, 8]);
        assert_eq!(read_in::<Level>(&r, "").unwrap(), rows);
        assert_eq!(Level::COLUMNS[0].kind, ColumnKind::I64);
        let e = format!("{:#}", read_in::<Level>(&r, "bad").unwrap_err());
        assert!(e.contains("`bad/n` row 1: -1"), "{e}");
    }

    #[test]
    fn termination_names_round_trip() {
        for t in crate::gapfile::TERMINATIONS {
            let name = crate::gapfile::termination_name(t);
            assert_eq!(crate::gapfile::parse_termination(name).unwrap(), t);
        }
        assert!(crate::gapfile::parse_termination("done").is_err());
    }
}
