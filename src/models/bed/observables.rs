//! Observables of a bed (pure functions of the state) and snapshot writers.
//!
//! Snapshots are written through [`crate::output::particles`] (extended XYZ, LAMMPS dump,
//! legacy VTK, Parquet with `x_m`, `y_m`, `radius_m`, `type`, `force_magnitude_N`, …; read by
//! `magopt analyze`): discs at z = 0, type = species index + 1, extra columns
//! `magnetic_force` (N, vector: the pair forces (B1) plus the wall forces (B2) on the particle,
//! without gravity and friction, the force the source maps in its Figs. 4.20–4.24) and
//! `force_magnitude` (N, its magnitude).

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;
use std::path::Path;

use super::forces::ForceField;
use super::state::{Geometry, Particles, State};
use crate::output::particles::{Cell, ParticleFrame, Property};
use crate::Result;

/// Mean inter-particle distance D̂ = (1/(N(N−1))) Σ_i Σ_{j≠i} |r_i − r_j|, m. Exact O(N²),
/// gathered per particle and summed in index order (thread-count independent).
///
/// Each distance is the square root of its r² (in double precision) taken in single
/// precision: relative error below 2⁻²³ per distance and so in D̂, far below anything D̂ is
/// read for, at about a third of the time of double-precision roots, whose throughput bounded
/// this sum (a tenth of a 10⁴-disc cycle: results/bench/README.md, "Bed: D̂ in single
/// precision, and the 2 ms cap measured again").
pub fn mean_distance(position: &[Vector2<f64>]) -> f64 {
    let n = position.len();
    if n < 2 {
        return 0.0;
    }
    let (x, y): (Vec<f64>, Vec<f64>) = position.iter().map(|p| (p.x, p.y)).unzip();
    let form = row_distances();
    let row = |i: usize| form(&x[i + 1..], &y[i + 1..], (x[i], y[i]));
    let rows: Vec<f64> = if n >= 512 {
        (0..n).into_par_iter().map(row).collect()
    } else {
        (0..n).map(row).collect()
    };
    2.0 * rows.iter().sum::<f64>() / (n as f64 * (n as f64 - 1.0))
}

/// Lanes of the partial sums of [`mean_distance`].
const LANES: usize = 16;

/// A row's sum of distances, Σ_j |r_j − r_i| over the points (xs, ys) from the centre r_i, in
/// the widest vector instructions the processor has (chosen once per D̂): the same operations
/// in the same order in every form, so the same bits.
type RowSum = fn(&[f64], &[f64], (f64, f64)) -> f64;

fn row_distances() -> RowSum {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: only called where the processor has AVX-512F.
            return |xs, ys, centre| unsafe { row_distances_avx512(xs, ys, centre) };
        }
        if crate::numerics::has_avx() {
            // SAFETY: only called where the processor has AVX.
            return |xs, ys, centre| unsafe { row_distances_avx(xs, ys, centre) };
        }
    }
    row_distances_lanes
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn row_distances_avx512(xs: &[f64], ys: &[f64], centre: (f64, f64)) -> f64 {
    row_distances_lanes(xs, ys, centre)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn row_distances_avx(xs: &[f64], ys: &[f64], centre: (f64, f64)) -> f64 {
    row_distances_lanes(xs, ys, centre)
}

/// The portable form, compiled again inside each `target_feature` form above (which the
/// compiler then vectorizes with that form's instructions).
#[inline(always)]
fn row_distances_lanes(xs: &[f64], ys: &[f64], (xi, yi): (f64, f64)) -> f64 {
    let distance = |a: f64, b: f64| {
        let (dx, dy) = (a - xi, b - yi);
        f64::from(((dx * dx + dy * dy) as f32).sqrt())
    };
    let (cx, cy) = (xs.chunks_exact(LANES), ys.chunks_exact(LANES));
    let tail: f64 = cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .map(|(&a, &b)| distance(a, b))
        .sum();
    // Partial sums per lane: independent additions the compiler vectorizes, where one
    // running sum would force one addition after the other.
    let mut lanes = [0.0; LANES];
    for (cx, cy) in cx.zip(cy) {
        for k in 0..LANES {
            lanes[k] += distance(cx[k], cy[k]);
        }
    }
    lanes.iter().sum::<f64>() + tail
}

/// Number of equal horizontal bands of the local area fraction profile.
pub const AREA_FRACTION_BANDS: usize = 10;

/// Series names of the profile, band 0 at the floor.
pub const AREA_FRACTION_SERIES: [&str; AREA_FRACTION_BANDS] = [
    "area_fraction_band_0",
    "area_fraction_band_1",
    "area_fraction_band_2",
    "area_fraction_band_3",
    "area_fraction_band_4",
    "area_fraction_band_5",
    "area_fraction_band_6",
    "area_fraction_band_7",
    "area_fraction_band_8",
    "area_fraction_band_9",
];

/// Local area fraction in [`AREA_FRACTION_BANDS`] equal horizontal bands between the floor and
/// the piston: Σ π D_i²/4 of the discs whose centre lies in the band over W × band height (the
/// profiles of de Paula 2025, Fig. 3.2, with the density inversion near the piston at maximum
/// compression). A centre below the floor or above the piston counts in the nearest band, so
/// the mean over the bands is φ.
pub fn area_fraction_profile(
    state: &State,
    diameter: &[f64],
    width: f64,
) -> [f64; AREA_FRACTION_BANDS] {
    let band = state.piston / AREA_FRACTION_BANDS as f64;
    let mut area = [0.0; AREA_FRACTION_BANDS];
    for (p, d) in state.position.iter().zip(diameter) {
        let k = ((p.y / band).floor().max(0.0) as usize).min(AREA_FRACTION_BANDS - 1);
        area[k] += std::f64::consts::PI * d * d / 4.0;
    }
    area.map(|a| a / (width * band))
}

/// Smallest distance between a particle centre and the piston face, m.
pub fn min_piston_distance(state: &State) -> f64 {
    state
        .position
        .iter()
        .map(|p| state.piston - p.y)
        .fold(f64::INFINITY, f64::min)
}

/// What the run checks look at after a step (found in the step's last pass: see
/// [`super::integrator::StepScan`]).
#[derive(Debug, Clone, Copy)]
pub struct Extremes {
    /// Largest closeness of the last force evaluation ([`super::forces::ParticleForce::closeness`]).
    pub closeness: f64,
    /// Smallest distance between a particle centre and a fixed wall (bottom, sides), m.
    pub wall: f64,
    /// Smallest distance between a particle centre and the piston, m.
    pub piston: f64,
    /// Whether every position and velocity is finite.
    pub finite: bool,
}

impl Extremes {
    /// The extremes of no particle (the start of a merge).
    pub const NONE: Self = Self {
        closeness: 0.0,
        wall: f64::INFINITY,
        piston: f64::INFINITY,
        finite: true,
    };

    /// Those of one disc at `p` with velocity `v` and the closeness of its force evaluation,
    /// the piston face at height `piston`.
    pub fn of_disc(
        p: Vector2<f64>,
        v: Vector2<f64>,
        closeness: f64,
        geometry: &Geometry,
        piston: f64,
    ) -> Self {
        Self {
            closeness,
            wall: p.y.min(p.x).min(geometry.width - p.x),
            piston: piston - p.y,
            finite: p.x.is_finite() && p.y.is_finite() && v.x.is_finite() && v.y.is_finite(),
        }
    }

    /// The extremes of two disjoint sets of discs together.
    pub fn merge(self, other: Self) -> Self {
        Self {
            closeness: self.closeness.max(other.closeness),
            wall: self.wall.min(other.wall),
            piston: self.piston.min(other.piston),
            finite: self.finite && other.finite,
        }
    }
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
    /// Masses, kg.
    pub mass: Vec<f64>,
    /// F_pp + F_pw (B1, B2: the magnetic force, without gravity and friction), N.
    pub magnetic_force: Vec<Vector2<f64>>,
}

impl Snapshot {
    /// The current configuration; `gravity` (m/s²) is taken off the non-friction force F_T
    /// to leave the magnetic force.
    pub fn take(
        label: &str,
        state: &State,
        particles: &Particles,
        field: &ForceField,
        (geometry, gravity): (&Geometry, f64),
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
            mass: particles.mass.clone(),
            magnetic_force: field
                .out
                .iter()
                .zip(&particles.mass)
                .map(|(o, m)| o.force + Vector2::new(0.0, m * gravity))
                .collect(),
        }
    }

    /// |F_pp + F_pw| per particle, N.
    pub fn force_magnitude(&self) -> Vec<f64> {
        self.magnetic_force.iter().map(|f| f.norm()).collect()
    }

    /// The configuration as a particle frame: discs in the plane z = 0 (vz = 0), type =
    /// species index + 1, cell W × piston height × the largest diameter (centred on z = 0),
    /// not periodic; extra columns `magnetic_force` (N, in the plane) and `force_magnitude`
    /// (its magnitude, N).
    pub fn frame(&self) -> ParticleFrame {
        let thickness = self.diameter.iter().fold(0.0, |a: f64, d| a.max(*d));
        let lo = Vector3::new(0.0, 0.0, -thickness / 2.0);
        let hi = Vector3::new(self.width, self.piston, thickness / 2.0);
        let kind = self.species.iter().map(|s| *s as u32 + 1).collect();
        let mut frame = ParticleFrame::new(self.time, Cell::aligned(lo, hi), kind);
        frame.position = self.position.iter().map(|p| p.push(0.0)).collect();
        frame.velocity = self.velocity.iter().map(|v| v.push(0.0)).collect();
        frame.radius = self.diameter.iter().map(|d| d / 2.0).collect();
        frame.mass = self.mass.clone();
        let force = &self.magnetic_force;
        frame
            .with(Property::vector(
                "magnetic_force",
                "N",
                force.iter().map(|f| f.push(0.0)).collect(),
            ))
            .with(Property::scalar(
                "force_magnitude",
                "N",
                self.force_magnitude(),
            ))
    }

    /// Writes `<dir>/<stem>.xyz`, `.dump`, `.vtk` and `.parquet` atomically (see
    /// [`crate::output::particles`]); creates `dir`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        self.frame().write_all(dir, stem)
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
        // single-precision roots: within 2⁻²³ of the double-precision sum
        assert!((mean_distance(&p) - expected).abs() < 1.2e-7 * expected);
    }

    #[test]
    fn every_form_of_the_distance_sum_gives_the_same_bits() {
        // rows of every remainder modulo the lanes, on points spread over a bed-sized cell
        let xs: Vec<f64> = (0..3 * LANES + 5)
            .map(|k| (k as f64 * 0.37).sin().abs() * 0.36)
            .collect();
        let ys: Vec<f64> = (0..3 * LANES + 5)
            .map(|k| (k as f64 * 0.91).cos().abs() * 0.45)
            .collect();
        for len in 0..xs.len() {
            let (a, b, c) = (&xs[..len], &ys[..len], (0.1, 0.2));
            let portable = row_distances_lanes(a, b, c).to_bits();
            assert_eq!(row_distances()(a, b, c).to_bits(), portable, "{len} points");
            #[cfg(target_arch = "x86_64")]
            if crate::numerics::has_avx() {
                // SAFETY: the processor has AVX.
                assert_eq!(unsafe { row_distances_avx(a, b, c) }.to_bits(), portable);
            }
        }
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

    #[test]
    fn area_fraction_profile_sits_in_its_bands_and_averages_to_phi() {
        // piston at 1 m: bands of 0.1 m; discs of 0.1 m in bands 0, 0, 3 and 9 (one above)
        let y = [0.05, 0.0, 0.35, 1.2];
        let state = State {
            position: y.iter().map(|&y| Vector2::new(0.5, y)).collect(),
            velocity: vec![Vector2::zeros(); 4],
            piston: 1.0,
            time: 0.0,
        };
        let disc = std::f64::consts::PI * 0.01 / 4.0;
        let profile = area_fraction_profile(&state, &[0.1; 4], 2.0);
        let band = |k: usize| profile[k] * 2.0 * 0.1 / disc;
        assert!((band(0) - 2.0).abs() < 1e-12 && (band(3) - 1.0).abs() < 1e-12);
        assert!((band(9) - 1.0).abs() < 1e-12 && band(5) == 0.0);
        let phi = 4.0 * disc / (2.0 * 1.0);
        let mean = profile.iter().sum::<f64>() / AREA_FRACTION_BANDS as f64;
        assert!((mean - phi).abs() < 1e-12 * phi);
    }
}
