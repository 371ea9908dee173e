//! 2D snapshots as `magopt analyze` reads them: a Parquet or CSV table with columns `x`, `y`
//! (m) and optional `diameter` (m), `species` (integer), `force` (N) and the force vector
//! `force_x`, `force_y` (N); or the particle table the bed model writes
//! ([`crate::output::particles`]): `x_m`, `y_m`, optional `radius_m` (m), `type` (1-based,
//! species = type − 1), `force_magnitude_N` and `magnetic_force_x_N`, `magnetic_force_y_N`
//! (N). A force vector without a magnitude column gives the magnitude. Other columns (e.g.
//! `vx`, `z_m`) are ignored. Extended XYZ and LAMMPS dump files as magopt writes them
//! ([`crate::output::particles`]) are read too, one frame of them (see [`Snapshot::read_frame`]).

use std::path::Path;

use nalgebra::Vector2;

use crate::output::guard::read_text_limited;
use crate::output::particles::{
    lammps_frames, read_lammps_dump_frame, read_xyz, xyz_frame_count, ParticleFrame, Values,
};
use crate::output::table::{read_csv, read_parquet, ColumnData, Table, MAX_CSV_INPUT};
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
    /// Force vectors in the plane (N), if the file has them.
    pub force_vector: Option<Vec<Vector2<f64>>>,
}

impl Snapshot {
    /// Reads a snapshot (the last frame of a multi-frame file); see [`Snapshot::read_frame`].
    ///
    /// # Errors
    /// As [`Snapshot::read_frame`].
    pub fn read(path: &Path) -> Result<Self> {
        Self::read_frame(path, -1).map(|(s, _)| s)
    }

    /// Reads frame `frame` of a snapshot file (negative: counted from the end, −1 the last),
    /// chosen by extension: `.parquet`/`.pq` and `.csv` tables (one frame), extended XYZ
    /// (`.xyz`/`.extxyz`) and LAMMPS dumps (`.dump`/`.lammpstrj`). Particle frames give x, y,
    /// diameter = 2 × radius, species = type − 1 and force = the `force_magnitude` column.
    ///
    /// # Errors
    /// [`Error::Input`] for an unknown extension (naming the formats), a frame out of range
    /// or a file that does not parse; [`Error::Io`] or [`Error::Output`] if the file cannot
    /// be read; as [`Snapshot::from_table`] for tables.
    pub fn read_frame(path: &Path, frame: isize) -> Result<(Self, FrameInfo)> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let format = match ext.as_str() {
            "parquet" | "pq" => "parquet",
            "csv" => "csv",
            "xyz" | "extxyz" => "extxyz",
            "dump" | "lammpstrj" => "lammps-dump",
            _ => {
                return Err(Error::input(format!(
                    "{}: unknown snapshot format '.{ext}' (allowed: .parquet/.pq, .csv, \
                     .xyz/.extxyz, .dump/.lammpstrj)",
                    path.display()
                )))
            }
        };
        let at = |e: Error| match e {
            Error::Input(m) => Error::input(format!("{}: {m}", path.display())),
            other => other,
        };
        let (snapshot, frames, index, time) = match format {
            "parquet" | "csv" => {
                let index = resolve(frame, 1).map_err(at)?;
                let table = if format == "csv" {
                    read_csv(path)?
                } else {
                    read_parquet(path)?
                };
                let time = match table.column("time_s") {
                    Some(ColumnData::F64(t)) => t.first().copied(),
                    _ => None,
                };
                (Self::from_table(&table).map_err(at)?, 1, index, time)
            }
            _ => {
                let text = read_text_limited(path, MAX_CSV_INPUT, "particle file")?;
                let (count, read): (usize, Box<dyn Fn(isize) -> Result<ParticleFrame>>) =
                    if format == "extxyz" {
                        let n = xyz_frame_count(&text).map_err(at)?;
                        (n, Box::new(|k| read_xyz(&text, k)))
                    } else {
                        let n = lammps_frames(&text).len();
                        (n, Box::new(|k| read_lammps_dump_frame(&text, k)))
                    };
                let index = resolve(frame, count).map_err(at)?;
                let particles = read(index as isize).map_err(at)?;
                let time = Some(particles.time);
                (Self::from_frame(&particles), count, index, time)
            }
        };
        let size_bytes = std::fs::metadata(path).map_or(0, |m| m.len());
        let info = FrameInfo {
            path: path.display().to_string(),
            format,
            size_bytes,
            frames,
            frame: index,
            time_s: time,
        };
        Ok((snapshot, info))
    }

    /// The 2D snapshot of a particle frame: x, y, diameter = 2 × radius, species = type − 1,
    /// force from the scalar `force_magnitude` column and the force vector from the vector
    /// `magnetic_force`, where the frame has them.
    pub fn from_frame(frame: &ParticleFrame) -> Self {
        let force = frame.extra.iter().find_map(|p| match &p.values {
            Values::Scalar(v) if p.name == "force_magnitude" => Some(v.clone()),
            _ => None,
        });
        let force_vector = frame.extra.iter().find_map(|p| match &p.values {
            Values::Vector(v) if p.name == "magnetic_force" => {
                Some(v.iter().map(|f| Vector2::new(f.x, f.y)).collect())
            }
            _ => None,
        });
        Self::with_vector(Self {
            positions: frame
                .position
                .iter()
                .map(|p| Vector2::new(p.x, p.y))
                .collect(),
            diameter: Some(frame.radius.iter().map(|r| 2.0 * r).collect()),
            species: Some(frame.kind.iter().map(|k| i64::from(*k) - 1).collect()),
            force,
            force_vector,
        })
    }

    /// Fills a missing force magnitude from the force vector.
    fn with_vector(mut self) -> Self {
        if self.force.is_none() {
            self.force = (self.force_vector.as_ref()).map(|v| v.iter().map(|f| f.norm()).collect());
        }
        self
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
            return Ok(Self::with_vector(Self {
                positions: x
                    .iter()
                    .zip(&y)
                    .map(|(a, b)| Vector2::new(*a, *b))
                    .collect(),
                diameter: optional(table, "radius_m")?.map(|r| r.iter().map(|r| 2.0 * r).collect()),
                species: Some(species),
                force: optional(table, "force_magnitude_N")?,
                force_vector: vector(table, "magnetic_force_x_N", "magnetic_force_y_N")?,
            }));
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
        Ok(Self::with_vector(Self {
            positions: x
                .iter()
                .zip(&y)
                .map(|(a, b)| Vector2::new(*a, *b))
                .collect(),
            diameter: optional(table, "diameter")?,
            species,
            force: optional(table, "force")?,
            force_vector: vector(table, "force_x", "force_y")?,
        }))
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

/// Where a snapshot came from (recorded with the analysis).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameInfo {
    /// The file, as given.
    pub path: String,
    /// `parquet`, `csv`, `extxyz` or `lammps-dump`.
    pub format: &'static str,
    /// File size, bytes.
    pub size_bytes: u64,
    /// Number of frames in the file (1 for tables).
    pub frames: usize,
    /// The frame analysed, 0-based.
    pub frame: usize,
    /// Its time (s), where the file records one.
    pub time_s: Option<f64>,
}

/// The 0-based frame `k` of `count` (negative: from the end).
fn resolve(k: isize, count: usize) -> Result<usize> {
    let i = if k < 0 { count as isize + k } else { k };
    usize::try_from(i)
        .ok()
        .filter(|i| *i < count)
        .ok_or_else(|| {
            Error::input(format!(
                "--frame {k} is out of range: the file holds {count} frame(s) (0..={}, or -1 for the last)",
                count.saturating_sub(1)
            ))
        })
}

/// `new` if the table has it but not `old`, else `old`.
fn alias<'a>(table: &Table, old: &'a str, new: &'a str) -> &'a str {
    if table.column(old).is_none() && table.column(new).is_some() {
        new
    } else {
        old
    }
}

/// Two numeric columns as plane vectors; None if both are absent.
///
/// # Errors
/// [`Error::Input`] if only one of them is there, or as [`optional`].
fn vector(table: &Table, x: &str, y: &str) -> Result<Option<Vec<Vector2<f64>>>> {
    match (optional(table, x)?, optional(table, y)?) {
        (Some(a), Some(b)) => Ok(Some(
            a.iter()
                .zip(&b)
                .map(|(a, b)| Vector2::new(*a, *b))
                .collect(),
        )),
        (None, None) => Ok(None),
        _ => Err(Error::input(format!(
            "columns '{x}' and '{y}' come together (a force vector needs both)"
        ))),
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
