//! Observables of a bed (pure functions of the state) and snapshot writers.
//!
//! Snapshot contract (read by `magopt analyze`): Parquet columns `x`, `y` (m), `diameter` (m),
//! `species` (integer index), `vx`, `vy` (m/s), `force` (N, magnitude of the non-friction force
//! F_T on the particle); the extended XYZ file carries the same per-particle properties
//! (OVITO reads it: `Properties=species:I:1:pos:R:3:diameter:R:1:velo:R:3:force:R:1`, with
//! `Radius` derivable from `diameter`).

use nalgebra::Vector2;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

use super::forces::ForceField;
use super::state::{Geometry, Particles, State};
use crate::output::atomic::write_atomic;
use crate::output::table::{write_parquet, ColumnData as C, Table};
use crate::Result;

/// Mean inter-particle distance D̂ = (1/(N(N−1))) Σ_i Σ_{j≠i} |r_i − r_j|, m. Exact O(N²),
/// gathered per particle and summed in index order (thread-count independent).
pub fn mean_distance(position: &[Vector2<f64>]) -> f64 {
    let n = position.len();
    if n < 2 {
        return 0.0;
    }
    let (x, y): (Vec<f64>, Vec<f64>) = position.iter().map(|p| (p.x, p.y)).unzip();
    let row = |i: usize| -> f64 {
        let distance = |(a, b): (&f64, &f64)| ((a - x[i]).powi(2) + (b - y[i]).powi(2)).sqrt();
        let (xs, ys) = (
            x[i + 1..].chunks_exact(LANES),
            y[i + 1..].chunks_exact(LANES),
        );
        let tail: f64 = xs
            .remainder()
            .iter()
            .zip(ys.remainder())
            .map(distance)
            .sum();
        // Partial sums per lane: independent additions the compiler vectorizes, where one
        // running sum would force one addition after the other.
        let mut lanes = [0.0; LANES];
        for (cx, cy) in xs.zip(ys) {
            for k in 0..LANES {
                lanes[k] += distance((&cx[k], &cy[k]));
            }
        }
        lanes.iter().sum::<f64>() + tail
    };
    let rows: Vec<f64> = if n >= 512 {
        (0..n).into_par_iter().map(row).collect()
    } else {
        (0..n).map(row).collect()
    };
    2.0 * rows.iter().sum::<f64>() / (n as f64 * (n as f64 - 1.0))
}

/// Lanes of the partial sums of [`mean_distance`].
const LANES: usize = 4;

/// Smallest distance between a particle centre and the piston face, m.
pub fn min_piston_distance(state: &State) -> f64 {
    state
        .position
        .iter()
        .map(|p| state.piston - p.y)
        .fold(f64::INFINITY, f64::min)
}

/// Smallest distance between a particle centre and a fixed wall (bottom, sides), m.
pub fn min_wall_distance(state: &State, geometry: &Geometry) -> f64 {
    state
        .position
        .iter()
        .map(|p| p.y.min(p.x).min(geometry.width - p.x))
        .fold(f64::INFINITY, f64::min)
}

/// A saved particle configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// What moment it is ("compression-start", "max-compression", "end", …).
    pub label: String,
    /// Time, s.
    pub time: f64,
    /// Piston height, m.
    pub piston: f64,
    /// Cell width, m.
    pub width: f64,
    /// Centres, m.
    pub position: Vec<Vector2<f64>>,
    /// Velocities, m/s.
    pub velocity: Vec<Vector2<f64>>,
    /// Diameters, m.
    pub diameter: Vec<f64>,
    /// Species indices.
    pub species: Vec<usize>,
    /// |F_T|, N.
    pub force: Vec<f64>,
}

impl Snapshot {
    /// The current configuration.
    pub fn take(
        label: &str,
        state: &State,
        particles: &Particles,
        field: &ForceField,
        geometry: &Geometry,
    ) -> Self {
        Self {
            label: label.to_string(),
            time: state.time,
            piston: state.piston,
            width: geometry.width,
            position: state.position.clone(),
            velocity: state.velocity.clone(),
            diameter: particles.diameter.clone(),
            species: particles.species.clone(),
            force: field.out.iter().map(|o| o.force.norm()).collect(),
        }
    }

    /// The per-particle table (the snapshot contract's columns).
    pub fn table(&self) -> Table {
        Table::new()
            .with("x", C::F64(self.position.iter().map(|p| p.x).collect()))
            .with("y", C::F64(self.position.iter().map(|p| p.y).collect()))
            .with("diameter", C::F64(self.diameter.clone()))
            .with(
                "species",
                C::I64(self.species.iter().map(|&s| s as i64).collect()),
            )
            .with("vx", C::F64(self.velocity.iter().map(|v| v.x).collect()))
            .with("vy", C::F64(self.velocity.iter().map(|v| v.y).collect()))
            .with("force", C::F64(self.force.clone()))
    }

    /// Extended XYZ text (one frame; z = 0; the cell spans W × piston height).
    pub fn extended_xyz(&self) -> String {
        let mut text = format!(
            "{}\nLattice=\"{:e} 0 0 0 {:e} 0 0 0 1\" Origin=\"0 0 -0.5\" pbc=\"F F F\" \
             Properties=species:I:1:pos:R:3:diameter:R:1:velo:R:3:force:R:1 \
             Time={:e} label={}\n",
            self.position.len(),
            self.width,
            self.piston,
            self.time,
            self.label
        );
        for i in 0..self.position.len() {
            let (p, v) = (self.position[i], self.velocity[i]);
            let _ = writeln!(
                text,
                "{} {:e} {:e} 0 {:e} {:e} {:e} 0 {:e}",
                self.species[i], p.x, p.y, self.diameter[i], v.x, v.y, self.force[i]
            );
        }
        text
    }

    /// Writes `<dir>/<stem>.parquet` and `<dir>/<stem>.xyz` atomically.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| crate::Error::io(dir, e))?;
        write_parquet(&dir.join(format!("{stem}.parquet")), &self.table())?;
        write_atomic(
            &dir.join(format!("{stem}.xyz")),
            self.extended_xyz().as_bytes(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_distance_matches_the_pair_sum() {
        let p: Vec<Vector2<f64>> = (0..23)
            .map(|k| Vector2::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos() * 2.0))
            .collect();
        let mut sum = 0.0;
        for i in 0..p.len() {
            for j in 0..p.len() {
                sum += (p[i] - p[j]).norm();
            }
        }
        let expected = sum / (p.len() * (p.len() - 1)) as f64;
        assert!((mean_distance(&p) - expected).abs() < 1e-14 * expected);
    }

    #[test]
    fn mean_distance_of_three_points() {
        let p = [
            Vector2::new(0.0, 0.0),
            Vector2::new(3.0, 0.0),
            Vector2::new(0.0, 4.0),
        ];
        assert!((mean_distance(&p) - (3.0 + 4.0 + 5.0) / 3.0).abs() < 1e-15);
    }
}
