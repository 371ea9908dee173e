//! `bed` (one compression cycle) and `damper` (the free-falling piston) as study models:
//! named parameters with units, metrics and series.

use super::damper::run_damper;
use super::params::{
    BedParams, Friction, FrictionScheme, Neighbors, Preset, Species, TiltOrder, WallLaw,
};
use super::protocol::run_cycle;
use super::BedOutcome;
use crate::study::model::{ParamKind as K, ParamSpec, RunResult, StudyModel, Value};
use crate::units::{Dimension as D, MU0};
use crate::{Error, Result};

/// The `bed` or `damper` study model (same parameters; different protocol and defaults).
#[derive(Debug, Clone, Copy)]
pub struct BedModel {
    damper: bool,
}

impl BedModel {
    /// The compression-cycle model `bed`.
    pub fn cycle() -> Self {
        Self { damper: false }
    }

    /// The free-falling piston model `damper`.
    pub fn damper() -> Self {
        Self { damper: true }
    }

    /// One run as a full outcome (the CLI uses this for snapshots and JSON).
    pub fn outcome(&self, params: &BedParams, seed: u64, progress: &dyn Fn(f64)) -> BedOutcome {
        if self.damper {
            run_damper(params, seed, progress)
        } else {
            run_cycle(params, seed, progress)
        }
    }
}

macro_rules! spec {
    ($name:literal, $kind:expr) => {
        ParamSpec {
            name: $name,
            kind: $kind,
        }
    };
}

const fn q(dim: D, unit: &'static str) -> K {
    K::Quantity { dim, unit }
}

const PARAMETERS: &[ParamSpec] = &[
    spec!("preset", K::Choice(&["mono", "bidisperse"])),
    spec!("particles", K::Count),
    spec!("big_diameter", q(D::Length, "mm")),
    spec!("mixing_ratio", K::Number),
    spec!("aspect_ratio", K::Number),
    spec!("species_file", K::Name),
    spec!("width", q(D::Length, "m")),
    spec!("height", q(D::Length, "m")),
    spec!("gap", q(D::Length, "mm")),
    spec!("thickness", q(D::Length, "mm")),
    spec!("density", q(D::Density, "kg/m3")),
    spec!("remanence", q(D::MagneticField, "T")),
    spec!("static_friction", K::Number),
    spec!("dynamic_friction", K::Number),
    spec!("gravity", q(D::Acceleration, "m/s2")),
    spec!("friction", K::Choice(&["none", "viscous", "dry", "both"])),
    spec!("tilt_order", K::Choice(&["first", "second"])),
    spec!("viscous_time", q(D::Time, "s")),
    spec!("threshold_speed", q(D::Velocity, "m/s")),
    spec!("friction_scheme", K::Choice(&["semi-implicit", "explicit"])),
    spec!(
        "wall_law",
        K::Choice(&["empirical", "infinite-row", "finite-bar"])
    ),
    spec!("wall_strength", K::Number),
    spec!("piston_speed", q(D::Velocity, "mm/s")),
    spec!("start_packing_fraction", K::Number),
    spec!("max_packing_fraction", K::Number),
    spec!("relaxation_time", q(D::Time, "s")),
    spec!("piston_decay_time", q(D::Time, "s")),
    spec!("settle_time", q(D::Time, "s")),
    spec!("final_rest", q(D::Time, "s")),
    spec!("initial_speed", q(D::Velocity, "m/s")),
    spec!("neighbors", K::Choice(&["exact", "cells", "verlet"])),
    spec!("cutoff", K::Number),
    spec!("list_radius", K::Number),
    spec!("far_field_interval", K::Count),
    spec!("near_cutoff", K::Number),
    spec!("time_step_factor", K::Number),
    spec!("max_time_step", q(D::Time, "s")),
    spec!("record_interval", q(D::Time, "s")),
    spec!("min_distance_ratio", K::Number),
    spec!("piston_mass", q(D::Mass, "g")),
    spec!("damper_time", q(D::Time, "s")),
    spec!("damper_record_interval", q(D::Time, "s")),
];

/// Every metric of [`BedOutcome::metrics`], in its order (the structure metrics per stage
/// included), computed once.
fn metric_names() -> &'static [&'static str] {
    static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| {
        BedOutcome::default()
            .metrics()
            .into_iter()
            .map(|(n, _)| n)
            .collect()
    })
}

const SERIES: &[(&str, &str)] = &[
    ("piston_height", "piston height (m)"),
    ("stroke", "stroke H0 − y_P (m)"),
    ("piston_force", "piston force (N)"),
    ("packing_fraction", "packing fraction φ"),
    ("mean_distance", "mean inter-particle distance D̂ (m)"),
    ("mean_distance_D", "D̂ / ⟨D⟩"),
    ("min_piston_distance", "min particle–piston distance (m)"),
    ("kinetic_energy", "kinetic energy (J)"),
    ("piston_z", "damper piston height z (m)"),
    ("piston_displacement", "damper z − z_rest (m)"),
];

/// Reads a species file: `[[species]]` tables with `diameter` (with unit; bare: mm) and
/// `fraction` (number fraction; normalized).
pub fn load_species(path: &str) -> Result<Vec<Species>> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        species: Vec<Entry>,
    }
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Entry {
        diameter: toml::Value,
        fraction: f64,
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::input(format!("species file '{path}': {e}")))?;
    let file: File = toml::from_str(&text)
        .map_err(|e| Error::input(format!("species file '{path}': {}", e.message())))?;
    let diameter = ParamSpec {
        name: "diameter",
        kind: q(D::Length, "mm"),
    };
    file.species
        .iter()
        .map(|e| {
            Ok(Species {
                diameter: diameter
                    .parse(&e.diameter)
                    .map_err(|err| Error::input(format!("species file '{path}': {err}")))?
                    .as_number(),
                fraction: e.fraction,
            })
        })
        .collect()
}

fn choice<T: Copy>(value: &Value, options: &[(&str, T)]) -> T {
    options
        .iter()
        .find(|(n, _)| *n == value.as_text())
        .map_or(options[0].1, |(_, t)| *t)
}

impl StudyModel for BedModel {
    type Params = BedParams;

    fn name(&self) -> &'static str {
        if self.damper {
            "damper"
        } else {
            "bed"
        }
    }

    fn parameters(&self) -> &'static [ParamSpec] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        metric_names()
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        SERIES
    }

    /// The spec's mono-disperse defaults; the damper uses viscous friction.
    fn defaults(&self) -> BedParams {
        let mut p = BedParams::defaults();
        if self.damper {
            p.friction = Friction::Viscous;
        }
        p
    }

    fn set(&self, p: &mut BedParams, name: &str, value: &Value) -> Result<()> {
        let x = value.as_number();
        match name {
            "preset" => {
                p.preset = choice(
                    value,
                    &[("mono", Preset::Mono), ("bidisperse", Preset::Bidisperse)],
                )
            }
            "particles" => p.particles = Some(x as usize),
            "big_diameter" => p.big_diameter = Some(x),
            "mixing_ratio" => p.mixing_ratio = x,
            "aspect_ratio" => p.aspect_ratio = x,
            "species_file" => p.species = Some(load_species(value.as_text())?),
            "width" => p.width = Some(x),
            "height" => p.height = Some(x),
            "gap" => p.gap = x,
            "thickness" => p.thickness = x,
            "density" => p.density = x,
            "remanence" => p.remanence = MU0 * x,
            "static_friction" => p.static_friction = x,
            "dynamic_friction" => p.dynamic_friction = x,
            "gravity" => p.gravity = x,
            "friction" => {
                p.friction = choice(
                    value,
                    &[
                        ("none", Friction::None),
                        ("viscous", Friction::Viscous),
                        ("dry", Friction::Dry),
                        ("both", Friction::Both),
                    ],
                )
            }
            "tilt_order" => {
                p.tilt_order = choice(
                    value,
                    &[("first", TiltOrder::First), ("second", TiltOrder::Second)],
                )
            }
            "viscous_time" => p.viscous_time = x,
            "threshold_speed" => p.threshold_speed = x,
            "friction_scheme" => {
                p.friction_scheme = choice(
                    value,
                    &[
                        ("semi-implicit", FrictionScheme::SemiImplicit),
                        ("explicit", FrictionScheme::Explicit),
                    ],
                )
            }
            "wall_law" => {
                p.wall_law = choice(
                    value,
                    &[
                        ("empirical", WallLaw::Empirical),
                        ("infinite-row", WallLaw::InfiniteRow),
                        ("finite-bar", WallLaw::FiniteBar),
                    ],
                )
            }
            "wall_strength" => p.wall_strength = Some(x),
            "piston_speed" => p.piston_speed = x,
            "start_packing_fraction" => p.start_packing_fraction = x,
            "max_packing_fraction" => p.max_packing_fraction = x,
            "relaxation_time" => p.relaxation_time = x,
            "piston_decay_time" => p.piston_decay_time = x,
            "settle_time" => p.settle_time = x,
            "final_rest" => p.final_rest = x,
            "initial_speed" => p.initial_speed = x,
            "neighbors" => {
                p.neighbors = choice(
                    value,
                    &[
                        ("exact", Neighbors::Exact),
                        ("cells", Neighbors::Cells),
                        ("verlet", Neighbors::Verlet),
                    ],
                )
            }
            "cutoff" => p.cutoff = x,
            "list_radius" => p.list_radius = x,
            "far_field_interval" => p.far_field_interval = x as usize,
            "near_cutoff" => p.near_cutoff = x,
            "time_step_factor" => p.time_step_factor = x,
            "max_time_step" => p.max_time_step = x,
            "record_interval" => p.record_interval = Some(x),
            "min_distance_ratio" => p.min_distance_ratio = x,
            "piston_mass" => p.piston_mass = x,
            "damper_time" => p.damper_time = x,
            "damper_record_interval" => p.damper_record_interval = x,
            other => {
                return Err(self
                    .spec(other)
                    .err()
                    .unwrap_or_else(|| Error::input(other.to_string())))
            }
        }
        Ok(())
    }

    fn validate(&self, p: &BedParams) -> Result<()> {
        p.validate()
    }

    fn run(&self, p: &BedParams, seed: u64) -> RunResult {
        let mut p = p.clone();
        p.snapshots = false;
        let o = self.outcome(&p, seed, &|_| {});
        RunResult {
            status: o.status().to_string(),
            reason: o.reason(),
            metrics: o
                .metrics()
                .into_iter()
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            series: o.series.0,
            wall_time_s: o.wall_time_s,
        }
    }
}
