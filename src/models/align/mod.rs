//! Model `align`: field alignment of hard-magnetic particles in a compacted powder
//! (spec align.md; source: Erokhin & Berkov, phys. stat. sol. (b) 2020).
//!
//! Two implementations of the same observable A(t) = ⟨|n·Ĥ|⟩:
//! - [`ensemble`]: the non-interacting isotropic ensemble (milliseconds per field);
//! - [`dem`]: the 3D overdamped DEM with Hertz contacts, friction and pressure.

pub mod dem;
pub mod diagnostics;
pub mod ensemble;
pub mod params;
pub mod report;
pub mod stoner_wohlfarth;
pub mod study;

use serde::Serialize;

pub use params::{
    AlignParams, FrictionScheme, MomentBranch, Numerics, PressureMode, ReleaseScheme, RestMeasure,
    SettlingScheme,
};

/// Which implementation evaluates a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// The DEM (contacts, friction, pressure).
    Dem,
    /// The non-interacting ensemble.
    Ensemble,
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", content = "reason", rename_all = "kebab-case")]
pub enum Status {
    /// A reached the target.
    Reached,
    /// The time limit came first: no alignment time is reported.
    NotReached,
    /// The simulation broke down (NaN, runaway overlap, a stage that never finished).
    Failed(String),
}

impl Status {
    /// Short label: "ok", "not-reached" or "failed".
    pub fn label(&self) -> &'static str {
        match self {
            Status::Reached => "ok",
            Status::NotReached => "not-reached",
            Status::Failed(_) => "failed",
        }
    }
}

/// Everything one alignment run reports (physical units).
#[derive(Debug, Clone, Serialize)]
pub struct AlignOutcome {
    /// How the run ended.
    pub status: Status,
    /// τ_x at the target x, s (None if not reached).
    pub alignment_time_s: Option<f64>,
    /// τ_0.90, s: independent of the friction regularization in the creep regime.
    pub alignment_time_90_s: Option<f64>,
    /// A at the end of the run.
    pub final_alignment: f64,
    /// A(t) samples (t in s).
    pub series: Vec<(f64, f64)>,
    /// Integrator steps of the alignment stage.
    pub steps: usize,
    /// Time step, s.
    pub time_step_s: f64,
    /// Packing fraction at the end (DEM only).
    pub packing_fraction: Option<f64>,
    /// Touching contacts at the end (DEM only).
    pub contacts: Option<usize>,
    /// Final bed height, m (DEM only).
    pub bed_height_m: Option<f64>,
    /// Pressure force actually applied, N (DEM only): the sum of the loads on the particles, or
    /// in `punch` mode the force the particles exert on the lid at the end of the run.
    pub applied_force_n: Option<f64>,
    /// How far the punch's lid moved down during alignment, m (`punch` mode only).
    pub lid_travel_m: Option<f64>,
    /// P L_x L_y, the force the punch should apply, N (DEM only).
    pub nominal_force_n: Option<f64>,
    /// Gauss–Seidel sweeps in all velocity solves.
    pub solver_sweeps: usize,
    /// Velocity solves that hit the sweep cap.
    pub unconverged_solves: usize,
    /// At the end of the run, the fraction of friction-loaded contacts slipping slower than
    /// 3 v_ε. Near 1 the run is in the creep regime: τ at high targets then depends on the
    /// friction regularization (compare τ_0.90, which depends less). DEM with friction only.
    pub sticking_fraction: Option<f64>,
    /// Wall-clock time of the run, s.
    pub wall_time_s: f64,
}

impl AlignOutcome {
    /// A run that failed before or during alignment.
    pub fn failed(reason: &str) -> AlignOutcome {
        Self::without_dem(
            Status::Failed(reason.to_string()),
            None,
            None,
            Vec::new(),
            0.0,
        )
    }

    /// An outcome with no DEM diagnostics (ensemble runs and failures).
    fn without_dem(
        status: Status,
        tau: Option<f64>,
        tau90: Option<f64>,
        series: Vec<(f64, f64)>,
        wall_time_s: f64,
    ) -> AlignOutcome {
        AlignOutcome {
            status,
            alignment_time_s: tau,
            alignment_time_90_s: tau90,
            final_alignment: series.last().map_or(f64::NAN, |s| s.1),
            series,
            steps: 0,
            time_step_s: 0.0,
            packing_fraction: None,
            contacts: None,
            bed_height_m: None,
            applied_force_n: None,
            lid_travel_m: None,
            nominal_force_n: None,
            solver_sweeps: 0,
            unconverged_solves: 0,
            sticking_fraction: None,
            wall_time_s,
        }
    }
}

/// Evaluates the ensemble model for a parameter set (deterministic; no seed).
pub fn run_ensemble(params: &AlignParams) -> AlignOutcome {
    let started = std::time::Instant::now();
    let model = ensemble::Ensemble::new(
        params.reduced_field(),
        params.material.anisotropy_constant,
        params.mean_diameter,
        params.diameter_sigma,
        params.damping,
    );
    let tau = model.alignment_time(params.target, params.max_time);
    let tau90 = model.alignment_time(0.9, params.max_time);
    let end = tau.unwrap_or(params.max_time).max(tau90.unwrap_or(0.0));
    let series: Vec<(f64, f64)> = (0..=200)
        .map(|k| {
            let t = end * k as f64 / 200.0;
            (t, model.alignment(t))
        })
        .collect();
    let status = if tau.is_some() {
        Status::Reached
    } else {
        Status::NotReached
    };
    AlignOutcome::without_dem(status, tau, tau90, series, started.elapsed().as_secs_f64())
}
