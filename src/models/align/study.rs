//! `align` as a study model: named parameters with units, metrics and the A(t) series. Settled
//! packings are cached per (packing parameters, seed), so every field, friction and pressure of
//! a sweep or an optimization reuses the replicate's packing (common random numbers), and, with
//! a packing directory (`magopt align --packing-cache`), also kept on disk between processes.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};

use super::dem::packing::store;
use super::dem::{self, Packing};
use super::{
    run_ensemble, AlignOutcome, AlignParams, FrictionScheme, ModelKind, MomentBranch, PressureMode,
    ReleaseScheme, SettlingScheme, Status,
};
use crate::materials::MaterialDb;
use crate::study::model::{
    Param, ParamKind as K, ParamSpec, Recorder, RunContext, RunResult, RunSpan, RunStatus,
    StudyModel, Value,
};
use crate::study::param::Bounds;
use crate::units::{si_per_unit, Dimension as D};
use crate::{choice_param, number_param, Result};

/// Parameters of one `align` run as studies set them.
#[derive(Debug, Clone)]
pub struct AlignSetup {
    /// The physics.
    pub params: AlignParams,
    /// DEM or ensemble.
    pub model: ModelKind,
    /// Whether `wall_friction` was set explicitly (else it follows `friction`).
    pub wall_friction_set: bool,
    /// Whether `anisotropy_constant` was set explicitly (then it survives a later `material`).
    pub anisotropy_set: bool,
}

/// A packing computed once and shared by every run of its seed (or the reason it failed).
pub type SharedPacking = Arc<OnceLock<std::result::Result<Packing, String>>>;

/// The `align` study model with its material database and packing cache.
#[derive(Debug)]
pub struct AlignModel {
    materials: MaterialDb,
    packings: Mutex<HashMap<String, SharedPacking>>,
    /// Where settled packings are also kept between processes, if anywhere.
    packing_dir: Option<PathBuf>,
}

type AlignParam = Param<AlignModel, AlignSetup>;

/// Every `align` parameter, declared once (study key, CLI flag, kind, range, doc, storage).
static PARAMETERS: &[AlignParam] = &[
    Param {
        spec: ParamSpec::new(
            "material",
            K::Name,
            "Material name (see `magopt materials`)",
        ),
        get: |s| Some(Value::Text(s.params.material.name.clone())),
        set: |m, s, v| {
            let k = s.params.material.anisotropy_constant;
            s.params.material = m
                .materials
                .get(v.as_text())
                .map_err(|e| e.to_string())?
                .clone();
            if s.anisotropy_set {
                s.params.material.anisotropy_constant = k;
            }
            Ok(())
        },
    },
    Param {
        spec: ParamSpec::quantity(
            "anisotropy_constant",
            D::EnergyDensity,
            "kJ/m3",
            "First uniaxial anisotropy constant K of the particles, in place of the material's \
             (an uncertain or varied K; H_K = 2K/(μ0 M_s))",
        )
        .within(Bounds::POSITIVE)
        .derived("the material's"),
        get: |s| {
            s.anisotropy_set
                .then_some(Value::Number(s.params.material.anisotropy_constant))
        },
        set: |_, s, v| {
            s.params.material.anisotropy_constant = v.as_number();
            s.anisotropy_set = true;
            Ok(())
        },
    },
    choice_param!(
        "model",
        "Model: dem (contacts, friction, pressure) or ensemble (non-interacting, milliseconds)",
        model,
        [("dem", ModelKind::Dem), ("ensemble", ModelKind::Ensemble)]
    ),
    number_param!(
        ParamSpec::quantity("field", D::MagneticField, "kOe", "Applied field H along +z")
            .within(Bounds::NON_NEGATIVE),
        params.field
    ),
    number_param!(
        ParamSpec::quantity("pressure", D::Pressure, "atm", "Punch pressure P")
            .within(Bounds::NON_NEGATIVE),
        params.pressure
    ),
    choice_param!(
        "pressure_mode",
        "How P is applied: punch (a rigid lid pushed by P L_x L_y), exposed-layer (π R² P on \
         every particle with nothing above it) or source-layer (the source's rule: centres \
         above 0.9 z_max)",
        params.pressure_mode,
        [
            ("punch", PressureMode::Punch),
            ("exposed-layer", PressureMode::ExposedLayer),
            ("source-layer", PressureMode::SourceLayer)
        ]
    ),
    choice_param!(
        "moment_branch",
        "Stoner–Wohlfarth branch of the moments: global-minimum (all switched toward H) or \
         metastable (a demagnetized start; a moment switches only above its h_sw; DEM only)",
        params.moment_branch,
        [
            ("global-minimum", MomentBranch::GlobalMinimum),
            ("metastable", MomentBranch::Metastable)
        ]
    ),
    choice_param!(
        "friction_scheme",
        "How friction enters the velocities: implicit (regularized, solved with them) or \
         source-explicit (the source's Eq. (8) from the previous iterate's velocities) or \
         coulomb-limit (v_ε = 0, solved implicitly)",
        params.numerics.friction_scheme,
        [
            ("implicit", FrictionScheme::Implicit),
            ("source-explicit", FrictionScheme::SourceExplicit),
            ("coulomb-limit", FrictionScheme::CoulombLimit)
        ]
    ),
    choice_param!(
        "settling_scheme",
        "How the packing is made: fire (FIRE minimization under an equal settling force) or \
         source-dropped (the source's overdamped Heun steps, spheres dropped by a force ∝ R³)",
        params.numerics.settling_scheme,
        [
            ("fire", SettlingScheme::Fire),
            ("source-dropped", SettlingScheme::SourceDropped)
        ]
    ),
    choice_param!(
        "release_scheme",
        "How the settled bed is released when the settling force is switched off: overdamped \
         (the overlaps relax by the inertia-free motion γ ẋ = F, backward-Euler steps) or \
         inertial (FIRE straight from the loaded bed: the default until 2026-12-03)",
        params.numerics.release_scheme,
        [
            ("overdamped", ReleaseScheme::Overdamped),
            ("inertial", ReleaseScheme::Inertial)
        ]
    ),
    Param {
        spec: ParamSpec::new(
            "friction",
            K::Number,
            "Coulomb friction coefficient μ between particles (also with the walls unless \
             wall_friction is set)",
        )
        .within(Bounds::NON_NEGATIVE),
        get: |s| Some(Value::Number(s.params.friction)),
        set: |_, s, v| {
            s.params.friction = v.as_number();
            if !s.wall_friction_set {
                s.params.wall_friction = s.params.friction;
            }
            Ok(())
        },
    },
    Param {
        spec: ParamSpec::new(
            "wall_friction",
            K::Number,
            "Friction coefficient between particles and die walls",
        )
        .within(Bounds::NON_NEGATIVE)
        .derived("same as friction"),
        get: |s| {
            s.wall_friction_set
                .then_some(Value::Number(s.params.wall_friction))
        },
        set: |_, s, v| {
            s.params.wall_friction = v.as_number();
            s.wall_friction_set = true;
            Ok(())
        },
    },
    number_param!(
        ParamSpec::new(
            "particles",
            K::Count,
            "Number of particles N (at most 1e7: about 0.6-0.75 kB of memory each)"
        )
        .within(Bounds::closed(1.0, 1e7)),
        params.particles
    ),
    number_param!(
        ParamSpec::quantity("diameter", D::Length, "um", "Mean particle diameter D_av")
            .within(Bounds::POSITIVE),
        params.mean_diameter
    ),
    number_param!(
        ParamSpec::new(
            "diameter_sigma",
            K::Number,
            "σ of ln D of the log-normal particle sizes"
        )
        .within(Bounds::FRACTION),
        params.diameter_sigma
    ),
    number_param!(
        ParamSpec::quantity(
            "damping",
            D::Damping,
            "N*s/m",
            "Translational and rotational damping γ = γ*"
        )
        .within(Bounds::POSITIVE),
        params.damping
    ),
    number_param!(
        ParamSpec::new("target", K::Number, "Target alignment degree x of τ_x")
            .within(Bounds::UNIT_OPEN),
        params.target
    ),
    number_param!(
        ParamSpec::quantity(
            "max_time",
            D::Time,
            "s",
            "Time limit of the alignment stage (a run not at the target by then is not reached)"
        )
        .within(Bounds::POSITIVE),
        params.max_time
    ),
    number_param!(
        ParamSpec::quantity(
            "rotation_step",
            D::Angle,
            "rad",
            "Rotation of the fastest particle per step (sets the time step)"
        )
        .within(Bounds::above_to(0.0, 0.5)),
        params.numerics.rotation_step
    ),
    number_param!(
        ParamSpec::new(
            "friction_regularization",
            K::Number,
            "Friction regularization v_ε as a fraction of the fastest magnetic surface speed"
        )
        .within(Bounds::above_to(0.0, 1.0)),
        params.numerics.friction_regularization
    ),
    number_param!(
        ParamSpec::new(
            "solver_tolerance",
            K::Number,
            "Velocity solves stop when no velocity changes by more than this fraction of the \
             fastest magnetic surface speed in a sweep"
        )
        .within(Bounds::above_to(0.0, 1.0)),
        params.numerics.solver_tolerance
    ),
    number_param!(
        ParamSpec::new(
            "max_sweeps",
            K::Count,
            "Cap on Gauss–Seidel sweeps per velocity solve (solves that hit it are counted in \
             unconverged_solves)"
        )
        .within(Bounds::closed(1.0, 1e6)),
        params.numerics.max_sweeps
    ),
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
    "lid_travel_m",
    "solver_sweeps",
    "unconverged_solves",
];

impl AlignModel {
    /// The model over a material database.
    pub fn new(materials: MaterialDb) -> Self {
        Self {
            materials,
            packings: Mutex::new(HashMap::new()),
            packing_dir: None,
        }
    }

    /// The model keeping its settled packings in `dir` too (which must exist): a packing
    /// stored there under the same code fingerprint, seed and packing parameters is loaded
    /// instead of settled again (the same bits), and a settled one is stored.
    pub fn with_packing_dir(self, dir: PathBuf) -> Self {
        Self {
            packing_dir: Some(dir),
            ..self
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
            .entry(key.clone())
            .or_default()
            .clone();
        cell.get_or_init(|| match &self.packing_dir {
            None => Packing::generate(&packing_params, seed),
            Some(dir) => stored(dir, &key, &packing_params, seed),
        });
        cell
    }

    /// One run as an outcome (the CLI's `align` and the tests use this directly).
    pub fn outcome(&self, setup: &AlignSetup, seed: u64) -> AlignOutcome {
        self.recorded(setup, seed, None)
    }

    /// One run whose particle frames `recorder` writes (DEM only: the ensemble model has no
    /// particles).
    pub fn recorded(
        &self,
        setup: &AlignSetup,
        seed: u64,
        recorder: Option<&mut Recorder>,
    ) -> AlignOutcome {
        match setup.model {
            ModelKind::Ensemble => run_ensemble(&setup.params),
            ModelKind::Dem => match self
                .packing(&setup.params, seed)
                .get()
                .expect("initialized")
            {
                Ok(packing) => dem::align(&setup.params, packing, recorder),
                Err(reason) => AlignOutcome::failed(reason),
            },
        }
    }
}

/// The packing of `seed` from `dir`, or settled and stored there (a failed store costs only
/// the time to settle it again: the run goes on, with a warning).
fn stored(
    dir: &std::path::Path,
    key: &str,
    params: &super::params::PackingParams,
    seed: u64,
) -> std::result::Result<Packing, String> {
    // the in-memory key under the code that settled it
    let code = crate::study::fingerprint::code(<AlignModel as StudyModel>::SOURCES);
    let key = format!("{code}|{key}");
    let path = store::path_in(dir, &key);
    if let Some(packing) = store::load(&path, &key, params.particles) {
        return Ok(packing);
    }
    let packing = Packing::generate(params, seed)?;
    if let Err(e) = store::save(&path, &key, &packing) {
        eprintln!("warning: packing cache: {e} (the packing was settled and is used)");
    }
    Ok(packing)
}

impl StudyModel for AlignModel {
    type Params = AlignSetup;
    const SOURCES: &'static str = "align";

    fn name(&self) -> &'static str {
        "align"
    }

    fn parameters(&self) -> &'static [AlignParam] {
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
            anisotropy_set: false,
        }
    }

    fn validate(&self, setup: &AlignSetup) -> Result<()> {
        if setup.model == ModelKind::Ensemble
            && setup.params.moment_branch == MomentBranch::Metastable
        {
            return Err(crate::Error::input(
                "moment_branch: metastable is not allowed with model = ensemble (it needs dem)",
            ));
        }
        setup.params.validate()
    }

    fn run_span(&self, setup: &AlignSetup) -> std::result::Result<RunSpan, String> {
        match setup.model {
            ModelKind::Dem => Ok(RunSpan {
                end: Some(setup.params.max_time),
                steps: None,
            }),
            ModelKind::Ensemble => {
                Err("the ensemble model has no particles (particle frames need model = dem)".into())
            }
        }
    }

    fn run(&self, setup: &AlignSetup, seed: u64, context: &RunContext) -> Result<RunResult> {
        let mut recorder = match setup.model {
            ModelKind::Dem => context.recorder(),
            ModelKind::Ensemble => None,
        };
        let o = self.recorded(setup, seed, recorder.as_mut());
        let notes = match recorder {
            Some(recorder) => recorder.finish()?,
            None => Vec::new(),
        };
        Ok(RunResult {
            status: match &o.status {
                Status::Reached => RunStatus::Ok,
                Status::NotReached => RunStatus::NotReached,
                Status::Failed(r) => RunStatus::Failed(r.clone()),
            },
            notes,
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
                ("lid_travel_m".into(), o.lid_travel_m),
                ("solver_sweeps".into(), Some(o.solver_sweeps as f64)),
                (
                    "unconverged_solves".into(),
                    Some(o.unconverged_solves as f64),
                ),
            ],
            series: vec![("alignment".into(), o.series)],
            wall_time_s: o.wall_time_s,
        })
    }
}
