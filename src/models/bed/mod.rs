//! The `bed` model (spec bed.md): a 2D bed of repelling disc magnets in a Hele-Shaw cell,
//! compressed by a piston (one cycle) or loaded by a free-falling piston (the damper).
//!
//! - `params`: parameters with units and defaults, presets; `validate`: their checks;
//! - `state`: per-particle constants, geometry, the initial perturbed grid;
//! - `forces`: B1 pairs, B2 walls, gravity, the B4 normal force (exact, cell or Verlet lists);
//! - `integrator`: Störmer–Verlet with exact viscous and semi-implicit dry friction, Δt rule;
//! - `protocol`: relaxation, compression, expansion; `damper`: the free-falling piston;
//!   `damper_fit`, `damper_fall_fit`: its oscillator fits;
//! - `observables`: φ, D̂, distances, snapshots (particle files); `report`: figures;
//! - `study`: `bed` and `damper` as study models.

pub mod damper;
pub mod damper_fall_fit;
pub mod damper_fit;
mod exact;
mod far_field;
pub mod forces;
pub mod integrator;
mod kick_lanes;
mod list_gather;
mod list_pairs;
pub mod observables;
pub mod pair_work;
pub mod params;
pub mod protocol;
pub mod report;
pub mod state;
pub mod study;
mod tail;
mod tail_lanes;
mod validate;
mod walls;

pub use params::BedParams;

use crate::analysis::structure::StructureMetrics;
use observables::Snapshot;
use protocol::Simulation;

/// Named time series: (observable, [(time s, value SI)]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series(pub Vec<(String, Vec<(f64, f64)>)>);

impl Series {
    /// Appends a point to the named series (created on first use).
    pub fn push(&mut self, name: &str, t: f64, value: f64) {
        match self.0.iter_mut().find(|(n, _)| n == name) {
            Some((_, points)) => points.push((t, value)),
            None => self.0.push((name.to_string(), vec![(t, value)])),
        }
    }

    /// The points of one series (empty if absent).
    pub fn get(&self, name: &str) -> &[(f64, f64)] {
        self.0
            .iter()
            .find(|(n, _)| n == name)
            .map_or(&[], |(_, p)| p.as_slice())
    }
}

/// What one cycle or damper run gives. Scalars are None when the run failed before them.
#[derive(Debug, Clone, Default)]
pub struct BedOutcome {
    /// None if the run completed, else why it failed.
    pub failure: Option<String>,
    /// Largest piston force over compression and expansion (damper: after the release), N.
    pub max_force: Option<f64>,
    /// Piston force at maximum compression, N.
    pub force_at_max_compression: Option<f64>,
    /// ∮ F dy over the cycle: energy the bed dissipates (hysteresis), J.
    pub cycle_work: Option<f64>,
    /// D̂ at the start of compression, in ⟨D⟩.
    pub mean_distance_start: Option<f64>,
    /// Smallest recorded D̂ from the start of compression on, in ⟨D⟩.
    pub mean_distance_min: Option<f64>,
    /// D̂ at the end, in ⟨D⟩.
    pub mean_distance_end: Option<f64>,
    /// Largest particle speed at the end of the relaxation (before zeroing), m/s.
    pub relaxation_speed: Option<f64>,
    /// Packing fraction at the end of the run.
    pub final_packing_fraction: f64,
    /// Packing fraction at H_f.
    pub max_packing_fraction: f64,
    /// Stroke H0 − H_f, m.
    pub stroke: f64,
    /// Realized fraction of particles of species other than the reference.
    pub small_fraction: f64,
    /// Smallest pair distance over the run in units of the pair's mean diameter.
    pub closest_pair: f64,
    /// Smallest centre–fixed-wall distance, m.
    pub closest_wall: f64,
    /// Smallest centre–piston distance, m.
    pub closest_piston: f64,
    /// Steps taken.
    pub steps: usize,
    /// Neighbour-list builds.
    pub list_builds: usize,
    /// Pair terms and pairs inside the cut-off over the run's steps (benchmarks).
    pub pair_work: pair_work::PairWork,
    /// Mean Δt, s.
    pub mean_time_step: f64,
    /// Damper: rest height of the loaded piston before the nudge, m.
    pub damper_rest_height: Option<f64>,
    /// Time series.
    pub series: Series,
    /// Snapshots (compression start, maximum compression, end).
    pub snapshots: Vec<Snapshot>,
    /// Structure (analysis.md) of the particle centres at each [`STRUCTURE_STAGES`] moment;
    /// None if the run did not get there or the analysis failed (then see `warnings`).
    pub structure: [Option<StructureMetrics>; 3],
    /// Damper: both oscillator fits of the second motion (None for a cycle, a failed run or a
    /// failed fit, then see `warnings`).
    pub damper_fits: Option<damper_fit::DamperFits>,
    /// Damper: the first fall fitted in the source's normalization (None as `damper_fits`).
    pub damper_fall_fit: Option<damper_fall_fit::FallFit>,
    /// Problems that leave the run valid (e.g. a structure analysis that failed).
    pub warnings: Vec<String>,
    /// Wall-clock time, s.
    pub wall_time_s: f64,
}

impl BedOutcome {
    /// An empty outcome with the geometry of the simulation.
    pub fn new(sim: &Simulation) -> Self {
        let n = sim.particles.len() as f64;
        Self {
            max_packing_fraction: sim
                .geometry
                .packing_fraction(sim.particles.disc_area(), sim.geometry.final_height),
            stroke: sim.geometry.start_height - sim.geometry.final_height,
            small_fraction: sim.particles.species.iter().filter(|&&s| s != 0).count() as f64 / n,
            ..Self::default()
        }
    }

    /// Copies the run's final data and the failure, if any.
    pub fn finish(&mut self, sim: &Simulation, result: Result<(), String>, wall_time_s: f64) {
        self.failure = result.err();
        self.final_packing_fraction = sim.packing_fraction();
        self.closest_pair = sim.closest_pair;
        self.closest_wall = sim.closest_wall;
        self.closest_piston = sim.closest_piston;
        self.steps = sim.steps;
        self.list_builds = sim.field.list_builds();
        self.pair_work = sim.pair_work;
        self.mean_time_step = sim.state.time / sim.steps.max(1) as f64;
        self.series = sim.series.clone();
        self.wall_time_s = wall_time_s;
    }

    /// Analyses the centres at stage `k` of [`STRUCTURE_STAGES`]; a failure (degenerate
    /// centres) leaves the metrics None and is recorded as a warning, never a failed run.
    pub fn record_structure(&mut self, k: usize, position: &[nalgebra::Vector2<f64>]) {
        match crate::analysis::structure::analyze(position) {
            Ok(m) => self.structure[k] = Some(m),
            Err(e) => self.warnings.push(format!(
                "structure at {} not analysed: {e}",
                STRUCTURE_STAGES[k].1
            )),
        }
    }

    /// Every scalar metric by name (the `metrics` of the study model and `--json`).
    pub fn metrics(&self) -> Vec<(&'static str, Option<f64>)> {
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        let mut metrics = vec![
            ("max_piston_force_N", self.max_force),
            (
                "piston_force_at_max_compression_N",
                self.force_at_max_compression,
            ),
            ("cycle_work_J", self.cycle_work),
            (
                "final_packing_fraction",
                finite(self.final_packing_fraction),
            ),
            ("max_packing_fraction", finite(self.max_packing_fraction)),
            ("stroke_m", finite(self.stroke)),
            ("mean_distance_start_D", self.mean_distance_start),
            ("mean_distance_min_D", self.mean_distance_min),
            ("mean_distance_end_D", self.mean_distance_end),
            ("closest_pair_D", finite(self.closest_pair)),
            ("min_wall_distance_m", finite(self.closest_wall)),
            ("min_piston_distance_m", finite(self.closest_piston)),
            ("relaxation_speed_m_per_s", self.relaxation_speed),
            ("small_fraction", finite(self.small_fraction)),
            ("damper_rest_height_m", self.damper_rest_height),
            ("steps", Some(self.steps as f64)),
            ("mean_time_step_s", finite(self.mean_time_step)),
            ("list_builds", Some(self.list_builds as f64)),
        ];
        let fits = self
            .damper_fits
            .as_ref()
            .map(damper_fit::DamperFits::values);
        for (j, name) in damper_fit::METRICS.iter().enumerate() {
            metrics.push((*name, fits.and_then(|f| finite(f[j]))));
        }
        let fall = self
            .damper_fall_fit
            .as_ref()
            .map(damper_fall_fit::FallFit::values);
        for (j, name) in damper_fall_fit::METRICS.iter().enumerate() {
            metrics.push((*name, fall.and_then(|f| finite(f[j]))));
        }
        for (k, names) in STRUCTURE_METRICS.iter().enumerate() {
            let m = self.structure[k].as_ref();
            let values = m.map(|m| {
                [
                    m.n5,
                    m.n6,
                    m.n7,
                    m.psi6,
                    m.hexagon_regularity_mean,
                    m.hexagon_regularity_std,
                    m.cells_counted as f64,
                    m.psi6_all,
                ]
            });
            for (j, name) in names.iter().enumerate() {
                metrics.push((*name, values.and_then(|v| finite(v[j]))));
            }
        }
        metrics
    }
}

/// The moments at which a cycle analyses its structure: (metric suffix, snapshot label).
pub const STRUCTURE_STAGES: [(&str, &str); 3] = [
    ("start", "compression-start"),
    ("max", "max-compression"),
    ("end", "end"),
];

/// Structure metric names per stage: n5, n6, n7 (fractions of counted Voronoi cells with ≤ 5,
/// 6, ≥ 7 sides), Ψ6, hexagon regularity mean and std, cells counted (analysis.md), and Ψ6
/// over every particle (the source's average, de Paula 2025, Eq. (4.28)).
pub const STRUCTURE_METRICS: [[&str; 8]; 3] = [
    [
        "n5_start",
        "n6_start",
        "n7_start",
        "psi6_start",
        "regularity_start",
        "regularity_std_start",
        "cells_start",
        "psi6_all_start",
    ],
    [
        "n5_max",
        "n6_max",
        "n7_max",
        "psi6_max",
        "regularity_max",
        "regularity_std_max",
        "cells_max",
        "psi6_all_max",
    ],
    [
        "n5_end",
        "n6_end",
        "n7_end",
        "psi6_end",
        "regularity_end",
        "regularity_std_end",
        "cells_end",
        "psi6_all_end",
    ],
];

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn a_failed_structure_analysis_is_a_warning_not_a_failure() {
        let mut out = BedOutcome::default();
        let collinear: Vec<_> = (0..5).map(|i| Vector2::new(f64::from(i), 0.0)).collect();
        out.record_structure(1, &collinear);
        assert!(out.structure[1].is_none());
        assert!(out.failure.is_none());
        assert!(
            out.warnings[0].contains("max-compression"),
            "{:?}",
            out.warnings
        );
        let metrics = out.metrics();
        assert!(STRUCTURE_METRICS[1]
            .iter()
            .all(|name| metrics.iter().any(|(n, v)| n == name && v.is_none())));
    }
}
