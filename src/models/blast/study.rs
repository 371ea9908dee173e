//! `blast` as a study model: named parameters with units, metrics and series.

use nalgebra::Vector3;

use super::params::{BlastParams, DragLaw, Integrator, Interactions};
use super::{run, BlastOutcome};
use crate::study::model::{ParamKind as K, ParamSpec, RunResult, StudyModel, Value};
use crate::units::{Dimension as D, MU0};
use crate::{Error, Result};

/// The `blast` study model.
#[derive(Debug, Default)]
pub struct BlastModel;

const fn q(name: &'static str, dim: D, unit: &'static str) -> ParamSpec {
    ParamSpec {
        name,
        kind: K::Quantity { dim, unit },
    }
}

const fn num(name: &'static str) -> ParamSpec {
    ParamSpec {
        name,
        kind: K::Number,
    }
}

const PARAMETERS: &[ParamSpec] = &[
    q("field", D::MagneticField, "T"),
    ParamSpec {
        name: "field_direction",
        kind: K::Name,
    },
    q("electric_field", D::ElectricField, "V/m"),
    ParamSpec {
        name: "electric_direction",
        kind: K::Name,
    },
    q("charge_per_mass", D::ChargePerMass, "C/kg"),
    num("negative_fraction"),
    q("energy", D::Energy, "kJ"),
    ParamSpec {
        name: "particles",
        kind: K::Count,
    },
    q("radius", D::Length, "m"),
    q("density", D::Density, "kg/m3"),
    q("cloud_radius", D::Length, "m"),
    q("air_density", D::Density, "kg/m3"),
    q("air_viscosity", D::Viscosity, "Pa*s"),
    ParamSpec {
        name: "drag",
        kind: K::Choice(&["quadratic", "chow", "stokes", "none"]),
    },
    num("drag_coefficient"),
    q("duration", D::Time, "s"),
    ParamSpec {
        name: "samples",
        kind: K::Count,
    },
    ParamSpec {
        name: "interactions",
        kind: K::Name,
    },
    ParamSpec {
        name: "integrator",
        kind: K::Choice(&["auto", "boris", "euler", "trapezoidal"]),
    },
    q("dt", D::Time, "s"),
    q("dt_initial", D::Time, "s"),
    q("dt_max", D::Time, "s"),
    num("phi"),
    ParamSpec {
        name: "iterations",
        kind: K::Count,
    },
    num("tolerance"),
    q("contact_stiffness", D::Pressure, "Pa"),
    num("contact_exponent"),
    num("temperature"),
    num("reference_temperature"),
    num("softening_rate"),
    q("stiffness_floor", D::Pressure, "Pa"),
    num("contact_damping"),
    num("friction_stiffness"),
    num("static_friction"),
    num("dynamic_friction"),
    q("bond_stiffness", D::Pressure, "Pa"),
    num("bond_exponent"),
    num("bond_tangential"),
    num("bond_strain"),
    num("near_field_attraction"),
    num("near_field_attraction_exponent"),
    num("near_field_repulsion"),
    num("near_field_repulsion_exponent"),
    q("near_field_cutoff", D::Length, "m"),
    num("near_field_theta"),
    num("target_aspect_ratio"),
];

const METRICS: &[&str] = &[
    "semi_axis_along_B_m",
    "semi_axis_across_B_m",
    "aspect_ratio",
    "shape_error",
    "extent_along_B_m",
    "extent_across_B_m",
    "mean_radius_m",
    "kinetic_energy_J",
    "bonds",
    "clusters",
    "largest_cluster",
    "steps",
    "rejected_steps",
    "mean_iterations",
    "min_time_step_s",
    "max_time_step_s",
];

/// Parses a direction: "x", "y", "z", "-x"… or "a,b,c" (normalized).
pub fn parse_direction(text: &str) -> std::result::Result<Vector3<f64>, String> {
    let t = text.trim();
    let (sign, axis) = t.strip_prefix('-').map_or((1.0, t), |a| (-1.0, a));
    let v = match axis {
        "x" => Vector3::x(),
        "y" => Vector3::y(),
        "z" => Vector3::z(),
        _ => {
            let parts: Vec<f64> = t
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| format!("'{t}' is not a direction (x, y, z, -x… or a,b,c)"))?;
            if parts.len() != 3 {
                return Err(format!("'{t}' is not a direction (x, y, z, -x… or a,b,c)"));
            }
            return Vector3::new(parts[0], parts[1], parts[2])
                .try_normalize(0.0)
                .filter(|v| v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| format!("'{t}' is not a direction (need a nonzero finite vector)"));
        }
    };
    Ok(sign * v)
}

impl BlastModel {
    /// The run as a study result.
    pub fn result(params: &BlastParams, outcome: &BlastOutcome) -> RunResult {
        let s = outcome.last();
        let e = &s.envelope;
        let stats = &outcome.stats;
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        let interacting = params.interactions.any();
        let metrics = vec![
            ("semi_axis_along_B_m", finite(e.along)),
            ("semi_axis_across_B_m", finite(e.across)),
            ("aspect_ratio", finite(e.aspect_ratio())),
            (
                "shape_error",
                finite((e.aspect_ratio() - params.target_aspect_ratio).abs()),
            ),
            ("extent_along_B_m", finite(e.extent_along)),
            ("extent_across_B_m", finite(e.extent_across)),
            ("mean_radius_m", finite(e.mean_radius)),
            ("kinetic_energy_J", finite(s.kinetic_energy)),
            ("bonds", interacting.then_some(s.bonds as f64)),
            ("clusters", interacting.then_some(s.clusters as f64)),
            (
                "largest_cluster",
                interacting.then_some(s.largest_cluster as f64),
            ),
            ("steps", Some(stats.steps as f64)),
            ("rejected_steps", Some(stats.rejected as f64)),
            (
                "mean_iterations",
                interacting.then(|| stats.iterations as f64 / stats.steps.max(1) as f64),
            ),
            ("min_time_step_s", finite(stats.dt_min)),
            ("max_time_step_s", finite(stats.dt_max)),
        ];
        let series_of = |f: &dyn Fn(&super::Sample) -> f64| -> Vec<(f64, f64)> {
            outcome.samples.iter().map(|s| (s.time, f(s))).collect()
        };
        let mut series = vec![
            (
                "semi_axis_along_B".to_string(),
                series_of(&|s| s.envelope.along),
            ),
            (
                "semi_axis_across_B".into(),
                series_of(&|s| s.envelope.across),
            ),
            (
                "aspect_ratio".into(),
                series_of(&|s| s.envelope.aspect_ratio()),
            ),
            ("mean_radius".into(), series_of(&|s| s.envelope.mean_radius)),
            ("kinetic_energy".into(), series_of(&|s| s.kinetic_energy)),
        ];
        if interacting {
            series.push(("bonds".into(), series_of(&|s| s.bonds as f64)));
            series.push((
                "largest_cluster".into(),
                series_of(&|s| s.largest_cluster as f64),
            ));
        }
        RunResult {
            status: if outcome.failure.is_some() {
                "failed"
            } else {
                "ok"
            }
            .into(),
            reason: outcome.failure.clone().unwrap_or_default(),
            metrics: metrics
                .into_iter()
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            series,
            wall_time_s: outcome.wall_time_s,
        }
    }
}

impl StudyModel for BlastModel {
    type Params = BlastParams;

    fn name(&self) -> &'static str {
        "blast"
    }

    fn parameters(&self) -> &'static [ParamSpec] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        METRICS
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        &[
            ("semi_axis_along_B", "semi-axis along B (m)"),
            ("semi_axis_across_B", "semi-axis across B (m)"),
            ("aspect_ratio", "aspect ratio along/across B"),
            ("mean_radius", "mean distance from centre (m)"),
            ("kinetic_energy", "kinetic energy (J)"),
            ("bonds", "bonded pairs"),
            ("largest_cluster", "largest cluster (particles)"),
        ]
    }

    /// The source's non-interacting example.
    fn defaults(&self) -> BlastParams {
        BlastParams::source_example()
    }

    fn set(&self, p: &mut BlastParams, name: &str, value: &Value) -> Result<()> {
        let x = value.as_number();
        let bad = |e: String| Error::input(format!("{name}: {e}"));
        let (c, nf, s) = (&mut p.contact, &mut p.near_field, &mut p.step);
        match name {
            // B is entered as a field in tesla (μ0 H) and stored as B.
            "field" => p.field_strength = MU0 * x,
            "field_direction" => {
                p.field_direction = parse_direction(value.as_text()).map_err(bad)?
            }
            "electric_field" => p.electric_strength = x,
            "electric_direction" => {
                p.electric_direction = match value.as_text().trim() {
                    "field" => None,
                    t => Some(parse_direction(t).map_err(bad)?),
                }
            }
            "charge_per_mass" => p.charge_per_mass = x,
            "negative_fraction" => p.negative_fraction = x,
            "energy" => p.energy = x,
            "particles" => p.particles = x as usize,
            "radius" => p.radius = x,
            "density" => p.density = x,
            "cloud_radius" => p.cloud_radius = x,
            "air_density" => p.air_density = x,
            "air_viscosity" => p.air_viscosity = x,
            "drag" => {
                p.drag = match value.as_text() {
                    "quadratic" => DragLaw::Quadratic,
                    "stokes" => DragLaw::Stokes,
                    "none" => DragLaw::None,
                    _ => DragLaw::Chow,
                }
            }
            "drag_coefficient" => p.drag_coefficient = x,
            "duration" => p.duration = x,
            "samples" => p.samples = x as usize,
            "interactions" => p.interactions = Interactions::parse(value.as_text()).map_err(bad)?,
            "integrator" => {
                s.integrator = match value.as_text() {
                    "boris" => Integrator::Boris,
                    "euler" => Integrator::Euler,
                    "trapezoidal" => Integrator::Trapezoidal,
                    _ => Integrator::Auto,
                }
            }
            "dt" => s.dt = x,
            "dt_initial" => s.dt_initial = x,
            "dt_max" => s.dt_max = x,
            "phi" => s.phi = x,
            "iterations" => s.iterations = x as usize,
            "tolerance" => s.tolerance = x,
            "contact_stiffness" => c.stiffness = x,
            "contact_exponent" => c.exponent = x,
            "temperature" => c.temperature = x,
            "reference_temperature" => c.reference_temperature = x,
            "softening_rate" => c.softening_rate = x,
            "stiffness_floor" => c.stiffness_floor = x,
            "contact_damping" => c.damping = x,
            "friction_stiffness" => c.friction_stiffness = x,
            "static_friction" => c.static_friction = x,
            "dynamic_friction" => c.dynamic_friction = x,
            "bond_stiffness" => c.bond_stiffness = x,
            "bond_exponent" => c.bond_exponent = x,
            "bond_tangential" => c.bond_tangential = x,
            "bond_strain" => c.bond_strain = x,
            "near_field_attraction" => nf.attraction = x,
            "near_field_attraction_exponent" => nf.attraction_exponent = x,
            "near_field_repulsion" => nf.repulsion = x,
            "near_field_repulsion_exponent" => nf.repulsion_exponent = x,
            "near_field_cutoff" => nf.cutoff = x,
            "near_field_theta" => nf.theta = x,
            "target_aspect_ratio" => p.target_aspect_ratio = x,
            other => {
                return Err(self
                    .spec(other)
                    .err()
                    .unwrap_or_else(|| Error::input(other)))
            }
        }
        Ok(())
    }

    fn validate(&self, params: &BlastParams) -> Result<()> {
        params.validate()
    }

    fn run(&self, params: &BlastParams, seed: u64) -> RunResult {
        match run(params, seed, &[]) {
            Ok(outcome) => Self::result(params, &outcome),
            Err(e) => RunResult {
                status: "failed".into(),
                reason: e.to_string(),
                metrics: METRICS.iter().map(|m| (m.to_string(), None)).collect(),
                series: Vec::new(),
                wall_time_s: 0.0,
            },
        }
    }
}
