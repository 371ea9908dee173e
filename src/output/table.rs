//! A small column-oriented table, written to and read from Parquet.
//!
//! The rest of the crate builds [`Table`]s from plain `Vec`s; polars is used only inside
//! [`write_parquet`] and [`read_parquet`], so no polars type leaks out of this module.
//!
//! Type round trip: every [`ColumnData`] variant reads back as itself. [`write_parquet`]
//! records the variant of each column in the file's key-value metadata (key
//! `magopt.column_kinds`), so an [`ColumnData::OptF64`] column without any `None` still reads
//! back as `OptF64`. For Parquet files written by other tools (no such metadata), a nullable
//! float column reads as `OptF64` if it holds at least one null and as `F64` otherwise;
//! other integer widths, floats and types are rejected with [`Error::Output`].
//!
//! Units: a column may carry its unit ([`Column::unit`]; `"1"` for a dimensionless number,
//! none for text and booleans). [`write_parquet`] stores it twice: as the Arrow field metadata
//! `unit` of the column (what pyarrow shows in `schema.field(name).metadata`, and polars keeps)
//! and as a JSON map `{column: unit}` under the file key `magopt.units`. [`read_parquet`]
//! restores the units from either.
//!
//! Missing values are nulls, never NaN: the `Opt*` variants hold `None` where a value is
//! missing, and NaN stays for a value that was computed and is NaN.

use std::io::Cursor;
use std::path::Path;

use polars::prelude as pl;
use polars::prelude::{IntoSeries, NewChunkedArray, SerReader};

use super::atomic::write_atomic;
use super::guard::{read_limited, read_text_limited};
use crate::{Error, Result};

/// Key of the Parquet key-value metadata entry that records the column variants.
const KINDS_KEY: &str = "magopt.column_kinds";

/// Key of the Parquet key-value metadata entry that maps column names to units.
pub const UNITS_KEY: &str = "magopt.units";

/// Key of the Arrow field metadata entry that holds a column's unit.
pub const UNIT_FIELD_KEY: &str = "unit";

/// The values of one column.
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnData {
    /// 64-bit floats (NaN and infinities allowed).
    F64(Vec<f64>),
    /// 64-bit floats with missing values.
    OptF64(Vec<Option<f64>>),
    /// Signed 64-bit integers.
    I64(Vec<i64>),
    /// Signed 64-bit integers with missing values.
    OptI64(Vec<Option<i64>>),
    /// Unsigned 64-bit integers (seeds, counts).
    U64(Vec<u64>),
    /// UTF-8 strings.
    Str(Vec<String>),
    /// UTF-8 strings with missing values.
    OptStr(Vec<Option<String>>),
    /// Booleans.
    Bool(Vec<bool>),
}

impl ColumnData {
    /// Row `r` as JSON (null for a missing or non-finite value).
    pub fn json_at(&self, r: usize) -> serde_json::Value {
        use serde_json::Value as J;
        let float = |x: f64| serde_json::Number::from_f64(x).map_or(J::Null, J::Number);
        match self {
            ColumnData::F64(v) => float(v[r]),
            ColumnData::OptF64(v) => v[r].map_or(J::Null, float),
            ColumnData::I64(v) => J::from(v[r]),
            ColumnData::OptI64(v) => v[r].map_or(J::Null, J::from),
            ColumnData::U64(v) => J::from(v[r]),
            ColumnData::Str(v) => J::from(v[r].clone()),
            ColumnData::OptStr(v) => v[r].clone().map_or(J::Null, J::from),
            ColumnData::Bool(v) => J::from(v[r]),
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            ColumnData::F64(v) => v.len(),
            ColumnData::OptF64(v) => v.len(),
            ColumnData::I64(v) => v.len(),
            ColumnData::OptI64(v) => v.len(),
            ColumnData::U64(v) => v.len(),
            ColumnData::Str(v) => v.len(),
            ColumnData::OptStr(v) => v.len(),
            ColumnData::Bool(v) => v.len(),
        }
    }

    /// True if the column holds no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Short name of the variant (`"f64"`, `"opt_f64"`, `"i64"`, `"opt_i64"`, `"u64"`, `"str"`,
    /// `"opt_str"`, `"bool"`), used in error messages and in the Parquet metadata.
    pub fn kind(&self) -> &'static str {
        match self {
            ColumnData::F64(_) => "f64",
            ColumnData::OptF64(_) => "opt_f64",
            ColumnData::I64(_) => "i64",
            ColumnData::OptI64(_) => "opt_i64",
            ColumnData::U64(_) => "u64",
            ColumnData::Str(_) => "str",
            ColumnData::OptStr(_) => "opt_str",
            ColumnData::Bool(_) => "bool",
        }
    }

    /// Appends the values of `other`, which must be the same variant (checked by the caller).
    fn extend_from(&mut self, other: &ColumnData) {
        match (self, other) {
            (ColumnData::F64(a), ColumnData::F64(b)) => a.extend_from_slice(b),
            (ColumnData::OptF64(a), ColumnData::OptF64(b)) => a.extend_from_slice(b),
            (ColumnData::I64(a), ColumnData::I64(b)) => a.extend_from_slice(b),
            (ColumnData::OptI64(a), ColumnData::OptI64(b)) => a.extend_from_slice(b),
            (ColumnData::U64(a), ColumnData::U64(b)) => a.extend_from_slice(b),
            (ColumnData::Str(a), ColumnData::Str(b)) => a.extend_from_slice(b),
            (ColumnData::OptStr(a), ColumnData::OptStr(b)) => a.extend_from_slice(b),
            (ColumnData::Bool(a), ColumnData::Bool(b)) => a.extend_from_slice(b),
            (a, b) => unreachable!(
                "column kinds checked before extend: {} vs {}",
                a.kind(),
                b.kind()
            ),
        }
    }
}

/// A named column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Column name (unique within its table).
    pub name: String,
    /// Column values.
    pub data: ColumnData,
    /// Unit of the values (`"1"`: dimensionless; None: text, flags, or not recorded).
    pub unit: Option<String>,
}

/// An ordered set of equally long, uniquely named columns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// The columns, in output order.
    pub columns: Vec<Column>,
}

impl Table {
    /// An empty table (no columns, no rows).
    pub fn new() -> Self {
        Self::default()
    }

    /// Builder form of [`Table::push`].
    ///
    /// # Panics
    /// As [`Table::push`].
    #[must_use]
    pub fn with(mut self, name: &str, data: ColumnData) -> Self {
        self.push(name, data);
        self
    }

    /// Adds a column at the end.
    ///
    /// # Panics
    /// If `data` is not as long as the existing columns or `name` is already used: both are
    /// programming errors.
    pub fn push(&mut self, name: &str, data: ColumnData) {
        self.push_column(name, data, None);
    }

    /// Builder form of [`Table::push_unit`].
    ///
    /// # Panics
    /// As [`Table::push`].
    #[must_use]
    pub fn with_unit(mut self, name: &str, data: ColumnData, unit: &str) -> Self {
        self.push_unit(name, data, unit);
        self
    }

    /// Adds a column with its unit (`"1"` for a dimensionless number) at the end.
    ///
    /// # Panics
    /// As [`Table::push`].
    pub fn push_unit(&mut self, name: &str, data: ColumnData, unit: &str) {
        self.push_column(name, data, Some(unit.to_string()));
    }

    fn push_column(&mut self, name: &str, data: ColumnData, unit: Option<String>) {
        if let Some(first) = self.columns.first() {
            assert!(
                first.data.len() == data.len(),
                "column '{name}' has {} rows but column '{}' has {}",
                data.len(),
                first.name,
                first.data.len()
            );
        }
        assert!(
            self.column(name).is_none(),
            "duplicate column name '{name}'"
        );
        self.columns.push(Column {
            name: name.to_string(),
            data,
            unit,
        });
    }

    /// The unit of the column called `name`, if it has one.
    pub fn unit(&self, name: &str) -> Option<&str> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .and_then(|c| c.unit.as_deref())
    }

    /// Number of rows (0 for a table without columns).
    pub fn n_rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }

    /// The rows as JSON objects (column name → value; null for a missing or non-finite
    /// value), for summaries that repeat a small table.
    pub fn to_json_rows(&self) -> Vec<serde_json::Value> {
        (0..self.n_rows())
            .map(|r| {
                let row: serde_json::Map<String, serde_json::Value> = self
                    .columns
                    .iter()
                    .map(|c| (c.name.clone(), c.data.json_at(r)))
                    .collect();
                serde_json::Value::Object(row)
            })
            .collect()
    }

    /// The values of the column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&ColumnData> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| &c.data)
    }

    /// Append the rows of `other`, which must have the same column names and types in the
    /// same order. Appending to a table without columns makes it a copy of `other`.
    ///
    /// # Errors
    /// [`Error::Output`] if the column layouts differ; `self` is then left unchanged.
    pub fn append(&mut self, other: &Table) -> Result<()> {
        if self.columns.is_empty() {
            self.columns = other.columns.clone();
            return Ok(());
        }
        let layout = |t: &Table| {
            t.columns
                .iter()
                .map(|c| format!("{}: {}", c.name, c.data.kind()))
                .collect::<Vec<_>>()
        };
        let (mine, theirs) = (layout(self), layout(other));
        if mine != theirs {
            return Err(Error::Output(format!(
                "cannot append table with columns [{}] to table with columns [{}]",
                theirs.join(", "),
                mine.join(", ")
            )));
        }
        for (a, b) in self.columns.iter_mut().zip(&other.columns) {
            a.data.extend_from(&b.data);
        }
        Ok(())
    }
}

/// Converts one column to a polars column.
fn to_polars(col: &Column) -> pl::Column {
    let name = pl::PlSmallStr::from(col.name.as_str());
    let series = match &col.data {
        ColumnData::F64(v) => pl::Float64Chunked::from_vec(name, v.clone()).into_series(),
        ColumnData::OptF64(v) => pl::Float64Chunked::from_slice_options(name, v).into_series(),
        ColumnData::I64(v) => pl::Int64Chunked::from_vec(name, v.clone()).into_series(),
        ColumnData::OptI64(v) => pl::Int64Chunked::from_slice_options(name, v).into_series(),
        ColumnData::U64(v) => pl::UInt64Chunked::from_vec(name, v.clone()).into_series(),
        ColumnData::Str(v) => {
            pl::StringChunked::from_iter_values(name, v.iter().map(String::as_str)).into_series()
        }
        ColumnData::OptStr(v) => {
            pl::StringChunked::from_iter_options(name, v.iter().map(Option::as_deref)).into_series()
        }
        ColumnData::Bool(v) => pl::BooleanChunked::from_slice(name, v).into_series(),
    };
    pl::Column::from(series)
}

/// Write as Parquet (zstd-compressed) atomically: the file is built in memory, then written
/// with [`write_atomic`] (temporary file + rename). The column variants and units are recorded
/// in the file metadata so that [`read_parquet`] restores them exactly.
///
/// # Errors
/// [`Error::Output`] if the table has no columns or polars fails to encode it;
/// [`Error::Io`] if the file cannot be written.
pub fn write_parquet(path: &Path, table: &Table) -> Result<()> {
    write_parquet_with(path, table, &[])
}

/// [`write_parquet`] with extra file-level key-value metadata (`(key, value)`; keys starting
/// with `magopt.column_kinds`, `magopt.units` or `ARROW:` are reserved).
///
/// # Errors
/// As [`write_parquet`].
pub fn write_parquet_with(path: &Path, table: &Table, extra: &[(String, String)]) -> Result<()> {
    let bytes = parquet_bytes(table, extra)
        .map_err(|msg| Error::Output(format!("cannot write '{}': {msg}", path.display())))?;
    write_atomic(path, &bytes)
}

/// The Parquet file of a table, in memory.
fn parquet_bytes(
    table: &Table,
    extra: &[(String, String)],
) -> std::result::Result<Vec<u8>, String> {
    if table.columns.is_empty() {
        return Err("the table has no columns".to_string());
    }
    let columns: Vec<pl::Column> = table.columns.iter().map(to_polars).collect();
    let mut df = pl::DataFrame::new(table.n_rows(), columns).map_err(|e| e.to_string())?;
    let kinds: Vec<&str> = table.columns.iter().map(|c| c.data.kind()).collect();
    let units: serde_json::Map<String, serde_json::Value> = table
        .columns
        .iter()
        .filter_map(|c| Some((c.name.clone(), c.unit.clone()?.into())))
        .collect();
    // The Arrow schema polars writes, with each column's unit as field metadata. The
    // writer keeps an `ARROW:schema` entry given to it instead of making its own.
    let mut schema = pl::SchemaExt::to_arrow(df.schema().as_ref(), pl::CompatLevel::newest());
    for (field, col) in schema.iter_values_mut().zip(&table.columns) {
        if let Some(unit) = &col.unit {
            let mut metadata = field.metadata.as_deref().cloned().unwrap_or_default();
            metadata.insert(UNIT_FIELD_KEY.into(), unit.as_str().into());
            field.metadata = Some(std::sync::Arc::new(metadata));
        }
    }
    let arrow = polars_parquet::write::schema_to_metadata_key(&schema);
    let mut kv = vec![
        (arrow.key, arrow.value.unwrap_or_default()),
        (
            KINDS_KEY.to_string(),
            serde_json::Value::from(kinds).to_string(),
        ),
        (
            UNITS_KEY.to_string(),
            serde_json::Value::Object(units).to_string(),
        ),
    ];
    for (k, v) in extra {
        if k == KINDS_KEY || k == UNITS_KEY || k.starts_with("ARROW:") {
            return Err(format!("metadata key '{k}' is reserved"));
        }
        kv.push((k.clone(), v.clone()));
    }
    let mut bytes = Vec::new();
    pl::ParquetWriter::new(&mut bytes)
        .with_compression(pl::ParquetCompression::Zstd(None))
        .with_key_value_metadata(Some(pl::KeyValueMetadata::from_static(kv)))
        .finish(&mut df)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// Converts a polars column back, as the variant `kind` if known (from the metadata), else
/// inferred from the polars type.
fn from_polars(col: &pl::Column, kind: Option<&str>) -> std::result::Result<ColumnData, String> {
    let nulls = col.null_count();
    let no_nulls = |what: &str| {
        if nulls > 0 {
            Err(format!("{what} column holds {nulls} null value(s)"))
        } else {
            Ok(())
        }
    };
    let err = |e: pl::PolarsError| e.to_string();
    let data = match (col.dtype(), kind) {
        (pl::DataType::Float64, Some("opt_f64")) => {
            ColumnData::OptF64(col.f64().map_err(err)?.iter().collect())
        }
        (pl::DataType::Float64, None) if nulls > 0 => {
            ColumnData::OptF64(col.f64().map_err(err)?.iter().collect())
        }
        (pl::DataType::Float64, Some("f64") | None) => {
            no_nulls("f64")?;
            ColumnData::F64(col.f64().map_err(err)?.into_no_null_iter().collect())
        }
        (pl::DataType::Int64, Some("opt_i64")) => {
            ColumnData::OptI64(col.i64().map_err(err)?.iter().collect())
        }
        (pl::DataType::Int64, None) if nulls > 0 => {
            ColumnData::OptI64(col.i64().map_err(err)?.iter().collect())
        }
        (pl::DataType::Int64, Some("i64") | None) => {
            no_nulls("i64")?;
            ColumnData::I64(col.i64().map_err(err)?.into_no_null_iter().collect())
        }
        (pl::DataType::UInt64, Some("u64") | None) => {
            no_nulls("u64")?;
            ColumnData::U64(col.u64().map_err(err)?.into_no_null_iter().collect())
        }
        (pl::DataType::String, Some("opt_str")) => ColumnData::OptStr(
            col.str()
                .map_err(err)?
                .iter()
                .map(|v| v.map(str::to_string))
                .collect(),
        ),
        (pl::DataType::String, None) if nulls > 0 => ColumnData::OptStr(
            col.str()
                .map_err(err)?
                .iter()
                .map(|v| v.map(str::to_string))
                .collect(),
        ),
        (pl::DataType::String, Some("str") | None) => {
            no_nulls("str")?;
            ColumnData::Str(
                col.str()
                    .map_err(err)?
                    .iter()
                    .flatten()
                    .map(str::to_string)
                    .collect(),
            )
        }
        (pl::DataType::Boolean, Some("bool") | None) => {
            no_nulls("bool")?;
            ColumnData::Bool(col.bool().map_err(err)?.iter().flatten().collect())
        }
        (dtype, Some(kind)) => {
            return Err(format!(
                "stored type {dtype} does not match recorded kind '{kind}'"
            ))
        }
        (dtype, None) => return Err(format!("unsupported column type {dtype}")),
    };
    Ok(data)
}

/// Read a Parquet file written by [`write_parquet`] back into a [`Table`]. Every variant
/// round-trips exactly (including NaN, `None`, empty strings and zero-row tables), and so do
/// the units; see the module documentation for files written by other tools (their units
/// come from the Arrow field metadata `unit`, if any).
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Output`] if it is not valid Parquet or
/// holds a column type [`ColumnData`] cannot represent.
pub fn read_parquet(path: &Path) -> Result<Table> {
    read_parquet_with_metadata(path).map(|(table, _)| table)
}

/// [`read_parquet`], also returning the file's key-value metadata (`(key, value)`, in file
/// order, including magopt's own entries and `ARROW:schema`).
///
/// # Errors
/// As [`read_parquet`].
pub fn read_parquet_with_metadata(path: &Path) -> Result<(Table, Vec<(String, String)>)> {
    let bytes = read_limited(path, MAX_CSV_INPUT, "Parquet file")?;
    let fail = |msg: String| Error::Output(format!("cannot read '{}': {msg}", path.display()));
    let mut reader = pl::ParquetReader::new(Cursor::new(bytes));
    let metadata = reader
        .get_metadata()
        .map_err(|e| fail(e.to_string()))?
        .clone();
    let kv: Vec<(String, String)> = metadata
        .key_value_metadata()
        .as_ref()
        .map(|kv| {
            kv.iter()
                .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
                .collect()
        })
        .unwrap_or_default();
    let entry = |key: &str| kv.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    let kinds: Option<Vec<String>> = entry(KINDS_KEY).and_then(|v| serde_json::from_str(v).ok());
    let mut units: std::collections::HashMap<String, String> = entry(UNITS_KEY)
        .and_then(|v| serde_json::from_str(v).ok())
        .unwrap_or_default();
    let schema = reader.schema().map_err(|e| fail(e.to_string()))?;
    for field in schema.iter_values() {
        let unit = field.metadata.as_ref().and_then(|m| m.get(UNIT_FIELD_KEY));
        if let Some(unit) = unit {
            units
                .entry(field.name.to_string())
                .or_insert_with(|| unit.to_string());
        }
    }
    let df = reader.finish().map_err(|e| fail(e.to_string()))?;
    let kinds = kinds.filter(|k| k.len() == df.width());
    let mut table = Table::new();
    for (i, col) in df.columns().iter().enumerate() {
        let kind = kinds.as_ref().map(|k| k[i].as_str());
        let data = from_polars(col, kind)
            .map_err(|msg| fail(format!("column '{}': {msg}", col.name())))?;
        let name = col.name().to_string();
        let unit = units.remove(&name);
        table.columns.push(Column { name, data, unit });
    }
    Ok((table, kv))
}

/// Largest table file (CSV or Parquet) the readers take, bytes.
pub const MAX_CSV_INPUT: u64 = 2 << 30;

/// Read a plain CSV file: a header row of column names, then one row per line, fields
/// separated by commas (surrounding spaces trimmed). Empty lines and lines starting with `#`
/// are skipped. A column whose every field parses as an integer is [`ColumnData::I64`], else
/// one whose every field parses as a number is [`ColumnData::F64`] (`nan`, `inf` accepted),
/// else [`ColumnData::Str`]. Quoted fields are not supported.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Output`] (naming the file and line) for
/// no header, a duplicate or empty column name, a row with the wrong number of fields, or a
/// quote character.
pub fn read_csv(path: &Path) -> Result<Table> {
    let text = read_text_limited(path, MAX_CSV_INPUT, "CSV file")?;
    // a byte-order mark (spreadsheet exports) is not part of the first column's name
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let fail = |msg: String| Error::Output(format!("cannot read '{}': {msg}", path.display()));
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let split =
        |line: &str| -> Vec<String> { line.split(',').map(|f| f.trim().to_string()).collect() };
    let Some((_, header)) = lines.next() else {
        return Err(fail("no header row".to_string()));
    };
    let names = split(header);
    let mut fields: Vec<Vec<String>> = vec![Vec::new(); names.len()];
    for (k, line) in lines {
        if line.contains('"') {
            return Err(fail(format!(
                "line {}: quoted fields are not supported",
                k + 1
            )));
        }
        let row = split(line);
        if row.len() != names.len() {
            return Err(fail(format!(
                "line {}: {} fields, but the header names {} columns",
                k + 1,
                row.len(),
                names.len()
            )));
        }
        for (column, value) in fields.iter_mut().zip(row) {
            column.push(value);
        }
    }
    let mut table = Table::new();
    for (name, values) in names.iter().zip(fields) {
        if name.is_empty() || table.column(name).is_some() {
            return Err(fail(format!("column name '{name}' is empty or repeated")));
        }
        table.push(name, csv_column(values));
    }
    Ok(table)
}

/// The narrowest [`ColumnData`] that holds every field: integers, numbers, or strings.
fn csv_column(values: Vec<String>) -> ColumnData {
    if let Ok(ints) = values.iter().map(|v| v.parse::<i64>()).collect() {
        return ColumnData::I64(ints);
    }
    if let Ok(floats) = values.iter().map(|v| v.parse::<f64>()).collect() {
        return ColumnData::F64(floats);
    }
    ColumnData::Str(values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::atomic::tests::test_dir;

    fn sample() -> Table {
        Table::new()
            .with(
                "f",
                ColumnData::F64(vec![1.5, f64::NAN, -0.0, f64::INFINITY, 1e-300]),
            )
            .with(
                "of",
                ColumnData::OptF64(vec![Some(1.0), None, Some(f64::NAN), None, Some(-2.5)]),
            )
            .with("i", ColumnData::I64(vec![i64::MIN, -1, 0, 1, i64::MAX]))
            .with("u", ColumnData::U64(vec![0, 1, 2, u64::MAX, 42]))
            .with(
                "s",
                ColumnData::Str(
                    ["", "a", "ünïcödé μ0", "", "with \"quotes\", commas"]
                        .map(String::from)
                        .to_vec(),
                ),
            )
            .with("b", ColumnData::Bool(vec![true, false, false, true, true]))
            .with_unit(
                "oi_N",
                ColumnData::OptI64(vec![None, Some(-3), Some(0), None, Some(i64::MAX)]),
                "N",
            )
            .with(
                "os",
                ColumnData::OptStr(vec![
                    None,
                    Some(String::new()),
                    Some("x".into()),
                    None,
                    None,
                ]),
            )
    }

    /// Bitwise comparison, so that NaN == NaN and -0.0 != 0.0.
    fn assert_same(a: &Table, b: &Table) {
        assert_eq!(a.columns.len(), b.columns.len());
        for (x, y) in a.columns.iter().zip(&b.columns) {
            assert_eq!(x.name, y.name);
            assert_eq!(x.unit, y.unit, "unit of column {}", x.name);
            match (&x.data, &y.data) {
                (ColumnData::F64(p), ColumnData::F64(q)) => {
                    let p: Vec<u64> = p.iter().map(|v| v.to_bits()).collect();
                    let q: Vec<u64> = q.iter().map(|v| v.to_bits()).collect();
                    assert_eq!(p, q, "column {}", x.name);
                }
                (ColumnData::OptF64(p), ColumnData::OptF64(q)) => {
                    let p: Vec<_> = p.iter().map(|v| v.map(f64::to_bits)).collect();
                    let q: Vec<_> = q.iter().map(|v| v.map(f64::to_bits)).collect();
                    assert_eq!(p, q, "column {}", x.name);
                }
                (p, q) => assert_eq!(p, q, "column {}", x.name),
            }
        }
    }

    #[test]
    fn builder_and_accessors() {
        let t = sample();
        assert_eq!(t.n_rows(), 5);
        assert_eq!(
            t.column("i"),
            Some(&ColumnData::I64(vec![i64::MIN, -1, 0, 1, i64::MAX]))
        );
        assert!(t.column("missing").is_none());
        assert_eq!(Table::new().n_rows(), 0);
        let mut t2 = Table::new();
        t2.push("x", ColumnData::F64(vec![]));
        assert_eq!(t2.n_rows(), 0);
        assert!(t2.column("x").unwrap().is_empty());
    }

    #[test]
    #[should_panic(expected = "has 2 rows")]
    fn push_with_wrong_length_panics() {
        let _ = Table::new()
            .with("a", ColumnData::F64(vec![1.0]))
            .with("b", ColumnData::I64(vec![1, 2]));
    }

    #[test]
    #[should_panic(expected = "duplicate column name 'a'")]
    fn push_duplicate_name_panics() {
        let _ = Table::new()
            .with("a", ColumnData::F64(vec![1.0]))
            .with("a", ColumnData::I64(vec![1]));
    }

    #[test]
    fn parquet_round_trip_every_type() {
        let dir = test_dir("parquet");
        let path = dir.join("t.parquet");
        let t = sample();
        write_parquet(&path, &t).unwrap();
        let back = read_parquet(&path).unwrap();
        assert_same(&t, &back);
        // Overwrite in place, no temp files left behind.
        write_parquet(&path, &t).unwrap();
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(names.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parquet_units_and_extra_metadata() {
        let dir = test_dir("parquet-units");
        let path = dir.join("t.parquet");
        let t = Table::new()
            .with_unit("time_s", ColumnData::F64(vec![0.5, 1.0]), "s")
            .with_unit("n", ColumnData::I64(vec![3, 4]), "1")
            .with("label", ColumnData::Str(vec!["a".into(), "b".into()]));
        let extra = [("magopt.input".to_string(), "{\"path\":\"x\"}".to_string())];
        write_parquet_with(&path, &t, &extra).unwrap();
        let (back, kv) = read_parquet_with_metadata(&path).unwrap();
        assert_same(&t, &back);
        assert_eq!(back.unit("time_s"), Some("s"));
        assert_eq!(back.unit("label"), None);
        let get = |k: &str| kv.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone());
        assert_eq!(get("magopt.input").as_deref(), Some("{\"path\":\"x\"}"));
        let units: serde_json::Value = serde_json::from_str(&get(UNITS_KEY).unwrap()).unwrap();
        assert_eq!(units, serde_json::json!({"time_s": "s", "n": "1"}));
        assert!(get("ARROW:schema").is_some());
        // the units also come back from the Arrow field metadata alone
        let mut reader = pl::ParquetReader::new(Cursor::new(std::fs::read(&path).unwrap()));
        let schema = reader.schema().unwrap();
        let field = schema.get("time_s").unwrap();
        let unit = field.metadata.as_ref().and_then(|m| m.get(UNIT_FIELD_KEY));
        assert_eq!(unit.map(|u| u.as_str()), Some("s"));
        let reserved = [(UNITS_KEY.to_string(), String::new())];
        assert!(write_parquet_with(&path, &t, &reserved).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parquet_round_trip_opt_f64_without_nulls_stays_opt() {
        let dir = test_dir("parquet-opt");
        let path = dir.join("t.parquet");
        let t = Table::new()
            .with("of", ColumnData::OptF64(vec![Some(1.0), Some(f64::NAN)]))
            .with("f", ColumnData::F64(vec![2.0, 3.0]));
        write_parquet(&path, &t).unwrap();
        assert_same(&t, &read_parquet(&path).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parquet_round_trip_zero_rows() {
        let dir = test_dir("parquet-empty");
        let path = dir.join("t.parquet");
        let t = Table::new()
            .with("f", ColumnData::F64(vec![]))
            .with("of", ColumnData::OptF64(vec![]))
            .with("i", ColumnData::I64(vec![]))
            .with("u", ColumnData::U64(vec![]))
            .with("s", ColumnData::Str(vec![]))
            .with("b", ColumnData::Bool(vec![]))
            .with("oi", ColumnData::OptI64(vec![]))
            .with("os", ColumnData::OptStr(vec![]));
        write_parquet(&path, &t).unwrap();
        let back = read_parquet(&path).unwrap();
        assert_eq!(back.n_rows(), 0);
        assert_same(&t, &back);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parquet_rejects_table_without_columns() {
        let dir = test_dir("parquet-nocols");
        let err = write_parquet(&dir.join("t.parquet"), &Table::new()).unwrap_err();
        assert!(
            matches!(err, Error::Output(ref m) if m.contains("no columns")),
            "{err:?}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn read_parquet_errors() {
        let dir = test_dir("parquet-bad");
        let missing = dir.join("missing.parquet");
        assert!(matches!(read_parquet(&missing), Err(Error::Io { .. })));
        let garbage = dir.join("garbage.parquet");
        std::fs::write(&garbage, b"not a parquet file at all").unwrap();
        let err = read_parquet(&garbage).unwrap_err();
        assert!(
            matches!(err, Error::Output(ref m) if m.contains("garbage.parquet")),
            "{err:?}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn append_rows_and_layout_check() {
        let mut acc = Table::new();
        acc.append(&sample()).unwrap();
        acc.append(&sample()).unwrap();
        assert_eq!(acc.n_rows(), 10);
        assert_eq!(
            acc.column("u"),
            Some(&ColumnData::U64(vec![
                0,
                1,
                2,
                u64::MAX,
                42,
                0,
                1,
                2,
                u64::MAX,
                42
            ]))
        );
        let before = acc.clone();
        // Same names, different type.
        let mut wrong = sample();
        wrong.columns[2].data = ColumnData::U64(vec![0; 5]);
        let err = acc.append(&wrong).unwrap_err();
        assert!(
            matches!(err, Error::Output(ref m) if m.contains("i: u64")),
            "{err:?}"
        );
        // Different order.
        let mut swapped = sample();
        swapped.columns.swap(0, 1);
        assert!(acc.append(&swapped).is_err());
        // Missing column.
        let mut fewer = sample();
        fewer.columns.pop();
        assert!(acc.append(&fewer).is_err());
        assert_same(&acc, &before);
        // Appending an empty-rows table of the same layout is a no-op.
        let mut empty = sample();
        for c in &mut empty.columns {
            c.data = match &c.data {
                ColumnData::F64(_) => ColumnData::F64(vec![]),
                ColumnData::OptF64(_) => ColumnData::OptF64(vec![]),
                ColumnData::I64(_) => ColumnData::I64(vec![]),
                ColumnData::OptI64(_) => ColumnData::OptI64(vec![]),
                ColumnData::U64(_) => ColumnData::U64(vec![]),
                ColumnData::Str(_) => ColumnData::Str(vec![]),
                ColumnData::OptStr(_) => ColumnData::OptStr(vec![]),
                ColumnData::Bool(_) => ColumnData::Bool(vec![]),
            };
        }
        acc.append(&empty).unwrap();
        assert_eq!(acc.n_rows(), 10);
    }

    #[test]
    fn csv_byte_order_mark_is_not_part_of_the_first_name() {
        let dir = test_dir("csv-bom");
        let path = dir.join("bom.csv");
        std::fs::write(&path, "\u{feff}x,y\n1,2\n").unwrap();
        let t = read_csv(&path).unwrap();
        assert_eq!(t.columns[0].name, "x");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn csv_types_and_errors() {
        let dir = test_dir("csv");
        let path = dir.join("t.csv");
        std::fs::write(
            &path,
            "# comment\nx, y ,species,name\n1.5,2,1,a\n\n-3e-3,4,2,b\n",
        )
        .unwrap();
        let t = read_csv(&path).unwrap();
        assert_eq!(t.column("x"), Some(&ColumnData::F64(vec![1.5, -3e-3])));
        assert_eq!(t.column("y"), Some(&ColumnData::I64(vec![2, 4])));
        assert_eq!(
            t.column("name"),
            Some(&ColumnData::Str(vec!["a".into(), "b".into()]))
        );
        for (bad, needle) in [
            ("x,y\n1,2,3\n", "line 2"),
            ("", "no header"),
            ("x,x\n1,2\n", "repeated"),
            ("x\n\"1\"\n", "quoted"),
        ] {
            std::fs::write(&path, bad).unwrap();
            let err = read_csv(&path).unwrap_err();
            assert!(
                matches!(err, Error::Output(ref m) if m.contains(needle)),
                "{err:?}"
            );
        }
        assert!(matches!(
            read_csv(&dir.join("missing.csv")),
            Err(Error::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
