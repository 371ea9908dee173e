//! `align` as a study model: named parameters with units, metrics and the A(t) series. Settled
//! packings are cached per (packing parameters, seed), so every field, friction and pressure of
//! a sweep or an optimization reuses the replicate's packing (common random numbers).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use super::dem::{self, Packing};
use super::{run_ensemble, AlignOutcome, AlignParams, ModelKind, PressureMode, Status};
use crate::materials::MaterialDb;
use crate::study::model::{ParamKind as K, ParamSpec, RunResult, StudyModel, Value};
use crate::units::{si_per_unit, Dimension as D};
use crate::{Error, Result};

/// Parameters of one `align` run as studies set them.
#[derive(Debug, Clone)]
pub struct AlignSetup {
    /// The physics.
    pub params: AlignParams,
    /// DEM or ensemble.
    pub model: ModelKind,
    /// Whether `wall_friction` was set explicitly (else it follows `friction`).
    pub wall_friction_set: bool,
}

/// A packing computed once and shared by every run of its seed (or the reason it failed).
pub type SharedPacking = Arc<OnceLock<std::result::Result<Packing, String>>>;

/// The `align` study model with its material database and packing cache.
#[derive(Debug)]
pub struct AlignModel {
    materials: MaterialDb,
    packings: Mutex<HashMap<String, SharedPacking>>,
}

const PARAMETERS: &[ParamSpec] = &[
    ParamSpec {
        name: "material",
        kind: K::Name,
    },
    ParamSpec {
        name: "model",
        kind: K::Choice(&["dem", "ensemble"]),
    },
    ParamSpec {
        name: "field",
        kind: K::Quantity {
            dim: D::MagneticField,
            unit: "kOe",
        },
    },
    ParamSpec {
        name: "pressure",
        kind: K::Quantity {
            dim: D::Pressure,
            unit: "atm",
        },
    },
    ParamSpec {
        name: "pressure_mode",
        kind: K::Choice(&["exposed-layer", "source-layer"]),
    },
    ParamSpec {
        name: "friction",
        kind: K::Number,
    },
    ParamSpec {
        name: "wall_friction",
        kind: K::Number,
    },
    ParamSpec {
        name: "particles",
        kind: K::Count,
    },
    ParamSpec {
        name: "diameter",
        kind: K::Quantity {
            dim: D::Length,
            unit: "um",
        },
    },
    ParamSpec {
        name: "diameter_sigma",
        kind: K::Number,
    },
    ParamSpec {
        name: "damping",
        kind: K::Number,
    },
    ParamSpec {
        name: "target",
        kind: K::Number,
    },
    ParamSpec {
        name: "max_time",
        kind: K::Quantity {
            dim: D::Time,
            unit: "s",
        },
    },
    ParamSpec {
        name: "rotation_step",
        kind: K::Number,
    },
    ParamSpec {
        name: "friction_regularization",
        kind: K::Number,
    },
];

const METRICS: &[&str] = &[
    "alignment_time_s",
    "alignment_time_90_s",
    "final_alignment",
    "packing_fraction",
    "contacts",
    "applied_force_N",
    "sticking_fraction",
    "steps",
    "time_step_s",
    "bed_height_m",
    "nominal_force_N",
    "solver_sweeps",
    "unconverged_solves",
];

impl AlignModel {
    /// The model over a material database.
    pub fn new(materials: MaterialDb) -> Self {
        Self {
            materials,
            packings: Mutex::new(HashMap::new()),
        }
    }

    /// Every metric name, owned (for studies built in code).
    pub fn metric_names() -> Vec<String> {
        METRICS.iter().map(|m| m.to_string()).collect()
    }

    /// The replicate's settled packing, computed once per (packing parameters, seed).
    pub fn packing(&self, params: &AlignParams, seed: u64) -> SharedPacking {
        let packing_params = params.packing();
        let key = format!("{seed}|{packing_params:?}");
        let cell = self
            .packings
            .lock()
            .expect("packing cache")
            .entry(key)
            .or_default()
            .clone();
        cell.get_or_init(|| Packing::generate(&packing_params, seed));
        cell
    }

    /// One run as an outcome (the CLI's `align` and the tests use this directly).
    pub fn outcome(&self, setup: &AlignSetup, seed: u64) -> AlignOutcome {
        match setup.model {
            ModelKind::Ensemble => run_ensemble(&setup.params),
            ModelKind::Dem => match self
                .packing(&setup.params, seed)
                .get()
                .expect("initialized")
            {
                Ok(packing) => dem::align(&setup.params, packing),
                Err(reason) => AlignOutcome::failed(reason),
            },
        }
    }
}

impl StudyModel for AlignModel {
    type Params = AlignSetup;

    fn name(&self) -> &'static str {
        "align"
    }

    fn parameters(&self) -> &'static [ParamSpec] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        METRICS
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        &[("alignment", "alignment degree A = ⟨|cos θ|⟩")]
    }

    /// The source's setup for Sr ferrite at 40 kOe (DEM).
    fn defaults(&self) -> AlignSetup {
        let material = self.materials.get("srfe12o19").expect("built-in").clone();
        AlignSetup {
            params: AlignParams::paper_defaults(material, 40.0 * si_per_unit("kOe")),
            model: ModelKind::Dem,
            wall_friction_set: false,
        }
    }

    fn set(&self, setup: &mut AlignSetup, name: &str, value: &Value) -> Result<()> {
        let p = &mut setup.params;
        match name {
            "material" => p.material = self.materials.get(value.as_text())?.clone(),
            "model" => {
                setup.model = if value.as_text() == "ensemble" {
                    ModelKind::Ensemble
                } else {
                    ModelKind::Dem
                }
            }
            "field" => p.field = value.as_number(),
            "pressure" => p.pressure = value.as_number(),
            "pressure_mode" => {
                p.pressure_mode = if value.as_text() == "source-layer" {
                    PressureMode::SourceLayer
                } else {
                    PressureMode::ExposedLayer
                }
            }
            "friction" => {
                p.friction = value.as_number();
                if !setup.wall_friction_set {
                    p.wall_friction = p.friction;
                }
            }
            "wall_friction" => {
                p.wall_friction = value.as_number();
                setup.wall_friction_set = true;
            }
            "particles" => p.particles = value.as_number() as usize,
            "diameter" => p.mean_diameter = value.as_number(),
            "diameter_sigma" => p.diameter_sigma = value.as_number(),
            "damping" => p.damping = value.as_number(),
            "target" => p.target = value.as_number(),
            "max_time" => p.max_time = value.as_number(),
            "rotation_step" => p.numerics.rotation_step = value.as_number(),
            "friction_regularization" => p.numerics.friction_regularization = value.as_number(),
            other => {
                return Err(self
                    .spec(other)
                    .err()
                    .unwrap_or_else(|| Error::input(other.to_string())))
            }
        }
        Ok(())
    }

    fn validate(&self, setup: &AlignSetup) -> Result<()> {
        setup.params.validate()
    }

    fn run(&self, setup: &AlignSetup, seed: u64) -> RunResult {
        let o = self.outcome(setup, seed);
        RunResult {
            status: o.status.label().to_string(),
            reason: match &o.status {
                Status::Failed(r) => r.clone(),
                _ => String::new(),
            },
            metrics: vec![
                ("alignment_time_s".into(), o.alignment_time_s),
                ("alignment_time_90_s".into(), o.alignment_time_90_s),
                (
                    "final_alignment".into(),
                    Some(o.final_alignment).filter(|a| a.is_finite()),
                ),
                ("packing_fraction".into(), o.packing_fraction),
                ("contacts".into(), o.contacts.map(|c| c as f64)),
                ("applied_force_N".into(), o.applied_force_n),
                ("sticking_fraction".into(), o.sticking_fraction),
                ("steps".into(), Some(o.steps as f64)),
                ("time_step_s".into(), Some(o.time_step_s)),
                ("bed_height_m".into(), o.bed_height_m),
                ("nominal_force_N".into(), o.nominal_force_n),
                ("solver_sweeps".into(), Some(o.solver_sweeps as f64)),
                (
                    "unconverged_solves".into(),
                    Some(o.unconverged_solves as f64),
                ),
            ],
            series: vec![("alignment".into(), o.series)],
            wall_time_s: o.wall_time_s,
        }
    }
}
