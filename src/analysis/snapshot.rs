//! 2D snapshots as `magopt analyze` reads them: a Parquet or CSV table with columns `x`, `y`
//! (m) and optional `diameter` (m), `species` (integer) and `force` (N); or the particle table
//! the bed model writes ([`crate::output::particles`]): `x_m`, `y_m`, optional `radius_m` (m),
//! `type` (1-based, species = type − 1) and `force_magnitude_N` (N). Other columns (e.g.
//! `vx`, `z_m`) are ignored.

use std::path::Path;

use nalgebra::Vector2;

use crate::output::table::{read_csv, read_parquet, ColumnData, Table};
use crate::{Error, Result};

/// Particle data of one 2D snapshot (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Particle centres (m).
    pub positions: Vec<Vector2<f64>>,
    /// Diameters (m), if the file has them.
    pub diameter: Option<Vec<f64>>,
    /// Species labels, if the file has them.
    pub species: Option<Vec<i64>>,
    /// Force magnitudes (N), if the file has them.
    pub force: Option<Vec<f64>>,
}

impl Snapshot {
    /// Reads a snapshot: `.csv` files as CSV, everything else as Parquet.
    ///
    /// # Errors
    /// [`Error::Io`] or [`Error::Output`] if the file cannot be read; [`Error::Input`] for a
    /// missing `x`/`y` column or a column of the wrong type (see [`Snapshot::from_table`]).
    pub fn read(path: &Path) -> Result<Self> {
        let is_csv = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let table = if is_csv {
            read_csv(path)?
        } else {
            read_parquet(path)?
        };
        Self::from_table(&table).map_err(|e| Error::input(format!("{}: {e}", path.display())))
    }

    /// Takes the snapshot columns from a table. Numeric columns may be floats or integers;
    /// `species` must hold whole numbers.
    ///
    /// # Errors
    /// [`Error::Input`] naming the column that is missing or has the wrong type.
    pub fn from_table(table: &Table) -> Result<Self> {
        let x = required(table, alias(table, "x", "x_m"))?;
        let y = required(table, alias(table, "y", "y_m"))?;
        if let Some(kind) = optional(table, "type")? {
            let species = kind.iter().map(|t| *t as i64 - 1).collect();
            return Ok(Self {
                positions: x
                    .iter()
                    .zip(&y)
                    .map(|(a, b)| Vector2::new(*a, *b))
                    .collect(),
                diameter: optional(table, "radius_m")?.map(|r| r.iter().map(|r| 2.0 * r).collect()),
                species: Some(species),
                force: optional(table, "force_magnitude_N")?,
            });
        }
        let species = match table.column("species") {
            None => None,
            Some(ColumnData::I64(v)) => Some(v.clone()),
            Some(ColumnData::U64(v)) => Some(v.iter().map(|s| *s as i64).collect()),
            Some(ColumnData::F64(v)) if v.iter().all(|s| s.fract() == 0.0) => {
                Some(v.iter().map(|s| *s as i64).collect())
            }
            Some(other) => {
                return Err(Error::input(format!(
                    "column 'species' holds {} values; it must hold whole numbers",
                    other.kind()
                )))
            }
        };
        Ok(Self {
            positions: x
                .iter()
                .zip(&y)
                .map(|(a, b)| Vector2::new(*a, *b))
                .collect(),
            diameter: optional(table, "diameter")?,
            species,
            force: optional(table, "force")?,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the snapshot holds no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Species labels, or 0 for every particle when the file has none.
    pub fn species_or_zero(&self) -> Vec<i64> {
        self.species.clone().unwrap_or_else(|| vec![0; self.len()])
    }
}

/// `new` if the table has it but not `old`, else `old`.
fn alias<'a>(table: &Table, old: &'a str, new: &'a str) -> &'a str {
    if table.column(old).is_none() && table.column(new).is_some() {
        new
    } else {
        old
    }
}

/// A numeric column as floats; None if absent.
fn optional(table: &Table, name: &str) -> Result<Option<Vec<f64>>> {
    match table.column(name) {
        None => Ok(None),
        Some(ColumnData::F64(v)) => Ok(Some(v.clone())),
        Some(ColumnData::I64(v)) => Ok(Some(v.iter().map(|a| *a as f64).collect())),
        Some(ColumnData::U64(v)) => Ok(Some(v.iter().map(|a| *a as f64).collect())),
        Some(other) => Err(Error::input(format!(
            "column '{name}' holds {} values; it must be numeric",
            other.kind()
        ))),
    }
}

/// A numeric column that must be present.
fn required(table: &Table, name: &str) -> Result<Vec<f64>> {
    optional(table, name)?.ok_or_else(|| {
        let names: Vec<&str> = table.columns.iter().map(|c| c.name.as_str()).collect();
        Error::input(format!(
            "missing column '{name}' (found: {}); a snapshot needs x and y in m",
            names.join(", ")
        ))
    })
}
