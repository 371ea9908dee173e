//! Particle snapshots in the formats that OVITO, ASE, ParaView, LAMMPS tools and polars read.
//!
//! A [`ParticleFrame`] holds one configuration: time (s), a cell (origin, lattice vectors and
//! periodic flags, m) and per-particle columns. Every model builds a frame and writes it with
//! [`ParticleFrame::write_all`]; the column names and SI units are the same in every format:
//!
//! | column | unit | extended XYZ | LAMMPS dump | VTK | Parquet |
//! |---|---|---|---|---|---|
//! | id (1-based) | – | (row order) | `id` | `id` | `id` |
//! | species | – | `species:S:1` | – | – | `species` |
//! | type (1-based) | – | `type:I:1` | `type` | `type` | `type` |
//! | position | m | `pos:R:3` | `x y z` | POINTS | `x_m y_m z_m` |
//! | radius | m | `radius:R:1` | `radius` | `radius` | `radius_m` |
//! | velocity | m/s | `velo:R:3` | `vx vy vz` | `velocity` | `vx_m_per_s` … |
//! | mass | kg | `masses:R:1` | `mass` | `mass` | `mass_kg` |
//! | momentum (ASE) | kg m/s | `momenta:R:3` | – | – | – |
//! | extra scalar `s` | its unit | `s:R:1` | `s` | `s` | `s_<unit>` |
//! | extra vector `v` | its unit | `v:R:3` | `v_x v_y v_z` | `v` | `v_x_<unit>` … |
//!
//! Species: ASE turns the `species` column into chemical elements and rejects anything else;
//! the one symbol that is not an element is `X` (ASE's dummy atom, atomic number 0). So every
//! particle is written as species [`SPECIES`] = `"X"` and the species index lives in the
//! numeric `type` column (1-based, as LAMMPS numbers atom types). No particle is mistaken for
//! an element ("P" would be phosphorus), and OVITO and ParaView colour by `type`.
//!
//! Velocities: OVITO reads `velo`; ASE keeps `velo` as a plain array and builds
//! `get_velocities()` from `momenta` / `masses`, so the extended XYZ file carries those too.
//!
//! Extra scalars are named so that no reader maps them to a vector property (`force_magnitude`,
//! not `force`); vectors are always three components.

mod lammps;
mod parquet;
mod vtk;
mod xyz;

pub use lammps::{lammps_dump, lammps_frames, read_lammps_dump, read_lammps_dump_frame};
pub use parquet::{read_particle_table, table, write_particle_table};
pub use vtk::{legacy_vtk, read_vtk};
pub use xyz::{extended_xyz, read_xyz, xyz_frame_count};

use std::path::Path;

use nalgebra::Vector3;

use super::atomic::write_atomic;
use crate::{Error, Result};

/// Species symbol of every particle: ASE's dummy element (see the module documentation).
pub const SPECIES: &str = "X";

/// The simulation cell or bounding box, m.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Corner of the cell, m.
    pub origin: Vector3<f64>,
    /// Lattice vectors a, b, c, m.
    pub vectors: [Vector3<f64>; 3],
    /// Periodic along a, b, c.
    pub pbc: [bool; 3],
}

impl Cell {
    /// Axis-aligned box from `lo` to `hi` (m), not periodic.
    pub fn aligned(lo: Vector3<f64>, hi: Vector3<f64>) -> Self {
        let d = hi - lo;
        Self {
            origin: lo,
            vectors: [
                Vector3::new(d.x, 0.0, 0.0),
                Vector3::new(0.0, d.y, 0.0),
                Vector3::new(0.0, 0.0, d.z),
            ],
            pbc: [false; 3],
        }
    }

    /// Bounding box of spheres at `position` with `radius` (m), not periodic; a unit box
    /// around the origin when there are no particles.
    pub fn bounding(position: &[Vector3<f64>], radius: &[f64]) -> Self {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (p, r) in position.iter().zip(radius) {
            lo = lo.inf(&p.add_scalar(-r));
            hi = hi.sup(&p.add_scalar(*r));
        }
        if position.is_empty() {
            (lo, hi) = (Vector3::repeat(-0.5), Vector3::repeat(0.5));
        }
        Self::aligned(lo, hi)
    }

    /// True if the lattice vectors lie along x, y and z.
    pub fn is_aligned(&self) -> bool {
        let [a, b, c] = self.vectors;
        a.y == 0.0 && a.z == 0.0 && b.x == 0.0 && b.z == 0.0 && c.x == 0.0 && c.y == 0.0
    }
}

/// Values of an extra per-particle column.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// One number per particle.
    Scalar(Vec<f64>),
    /// Three components per particle.
    Vector(Vec<Vector3<f64>>),
}

/// An extra per-particle column (model-specific).
#[derive(Debug, Clone, PartialEq)]
pub struct Property {
    /// Name (lower case, underscores; never a reader's vector name for a scalar).
    pub name: String,
    /// SI unit as a name suffix (`N`, `C_per_kg`, `rad_per_s`, `1` for dimensionless).
    pub unit: String,
    /// The values.
    pub values: Values,
}

impl Property {
    /// A scalar column.
    pub fn scalar(name: &str, unit: &str, values: Vec<f64>) -> Self {
        let values = Values::Scalar(values);
        Self::new(name, unit, values)
    }

    /// A 3-vector column.
    pub fn vector(name: &str, unit: &str, values: Vec<Vector3<f64>>) -> Self {
        Self::new(name, unit, Values::Vector(values))
    }

    fn new(name: &str, unit: &str, values: Values) -> Self {
        let (name, unit) = (name.to_string(), unit.to_string());
        Self { name, unit, values }
    }

    /// Number of components per particle (1 or 3).
    pub fn components(&self) -> usize {
        match self.values {
            Values::Scalar(_) => 1,
            Values::Vector(_) => 3,
        }
    }

    /// Component `k` of particle `i`.
    pub fn get(&self, i: usize, k: usize) -> f64 {
        match &self.values {
            Values::Scalar(v) => v[i],
            Values::Vector(v) => v[i][k],
        }
    }
}

/// One particle configuration (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleFrame {
    /// Time, s.
    pub time: f64,
    /// Cell (bed) or bounding box (unbounded clouds), m.
    pub cell: Cell,
    /// Particle ids, 1-based.
    pub id: Vec<u64>,
    /// Species symbols (see [`SPECIES`]).
    pub species: Vec<String>,
    /// Species index, 1-based.
    pub kind: Vec<u32>,
    /// Centres, m.
    pub position: Vec<Vector3<f64>>,
    /// Radii, m.
    pub radius: Vec<f64>,
    /// Velocities, m/s.
    pub velocity: Vec<Vector3<f64>>,
    /// Masses, kg (ASE derives velocities from `momenta` and `masses`).
    pub mass: Vec<f64>,
    /// Model-specific columns.
    pub extra: Vec<Property>,
}

impl ParticleFrame {
    /// A frame with ids 1…N, species [`SPECIES`] and the given 1-based types.
    pub fn new(time: f64, cell: Cell, kind: Vec<u32>) -> Self {
        let n = kind.len();
        Self {
            time,
            cell,
            id: (1..=n as u64).collect(),
            species: vec![SPECIES.to_string(); n],
            kind,
            position: vec![Vector3::zeros(); n],
            radius: vec![0.0; n],
            velocity: vec![Vector3::zeros(); n],
            mass: vec![0.0; n],
            extra: Vec::new(),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True if the frame holds no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Adds an extra column.
    pub fn with(mut self, property: Property) -> Self {
        self.extra.push(property);
        self
    }

    /// Writes `<dir>/<stem>.xyz`, `.dump` (LAMMPS), `.vtk` and `.parquet`, each atomically;
    /// creates `dir`.
    pub fn write_all(&self, dir: &Path, stem: &str) -> Result<()> {
        self.write_formats(dir, stem, 0, &Format::ALL).map(drop)
    }

    /// Writes `<dir>/<stem>.<ext>` in each of `formats`, each atomically (`step`: the LAMMPS
    /// timestep); creates `dir`. Returns the frame's extended XYZ text.
    pub fn write_formats(
        &self,
        dir: &Path,
        stem: &str,
        step: u64,
        formats: &[Format],
    ) -> Result<String> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let xyz = extended_xyz(self);
        for format in formats {
            let path = dir.join(format!("{stem}.{}", format.extension()));
            match format {
                Format::Xyz => write_atomic(&path, xyz.as_bytes())?,
                Format::Dump => write_atomic(&path, lammps_dump(self, step)?.as_bytes())?,
                Format::Vtk => write_atomic(&path, legacy_vtk(self).as_bytes())?,
                Format::Parquet => write_particle_table(&path, self)?,
            }
        }
        Ok(xyz)
    }
}

/// A particle file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Extended XYZ (OVITO, ASE).
    Xyz,
    /// LAMMPS `dump custom` (OVITO, LAMMPS tools).
    Dump,
    /// Legacy VTK POLYDATA (ParaView).
    Vtk,
    /// Parquet table (polars, pandas).
    Parquet,
}

impl Format {
    /// Every format, in the default order.
    pub const ALL: [Format; 4] = [Format::Xyz, Format::Dump, Format::Vtk, Format::Parquet];

    /// File extension (also the name used on the command line).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Xyz => "xyz",
            Format::Dump => "dump",
            Format::Vtk => "vtk",
            Format::Parquet => "parquet",
        }
    }

    /// Parses a comma-separated list of format names.
    pub fn parse_list(text: &str) -> std::result::Result<Vec<Format>, String> {
        let mut formats = Vec::new();
        for word in text.split(',').map(str::trim) {
            let format = Self::ALL
                .into_iter()
                .find(|f| f.extension() == word)
                .ok_or_else(|| {
                    format!("'{word}' is not a snapshot format (allowed: xyz, dump, vtk, parquet)")
                })?;
            if !formats.contains(&format) {
                formats.push(format);
            }
        }
        Ok(formats)
    }
}

/// Item `index` of a file's frames (negative: counted from the end, −1 the last).
fn pick_frame<T>(frames: &[T], index: isize) -> Result<&T> {
    let k = if index < 0 {
        frames.len() as isize + index
    } else {
        index
    };
    usize::try_from(k)
        .ok()
        .and_then(|k| frames.get(k))
        .ok_or_else(|| Error::input(format!("no frame {index} in {} frames", frames.len())))
}

/// Parses a float written by the text writers.
fn number(word: &str) -> Result<f64> {
    word.parse()
        .map_err(|_| Error::input(format!("not a number: '{word}'")))
}

/// Sets position, radius, velocity, mass and the extra columns of particle `i` from the
/// numbers of its row, in this order.
fn fill_numbers(frame: &mut ParticleFrame, i: usize, x: &[f64]) -> Result<()> {
    let width = 8 + frame.extra.iter().map(Property::components).sum::<usize>();
    if x.len() != width {
        let n = x.len();
        return Err(Error::input(format!(
            "row {}: {n} numbers, want {width}",
            i + 1
        )));
    }
    frame.position[i] = Vector3::new(x[0], x[1], x[2]);
    frame.radius[i] = x[3];
    frame.velocity[i] = Vector3::new(x[4], x[5], x[6]);
    frame.mass[i] = x[7];
    let mut at = 8;
    for prop in &mut frame.extra {
        match &mut prop.values {
            Values::Scalar(v) => v[i] = x[at],
            Values::Vector(v) => v[i] = Vector3::new(x[at], x[at + 1], x[at + 2]),
        }
        at += prop.components();
    }
    Ok(())
}

#[cfg(test)]
mod tests;
