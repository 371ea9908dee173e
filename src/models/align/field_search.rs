//! The optimal aligning field (spec align.md, "Studies"): minimize τ_x(H) averaged over
//! replicate packings with common random numbers. Each replicate's settled packing is computed
//! once and reused for every field; replicates run in parallel (rayon).

use rayon::prelude::*;

use super::dem::{self, Packing};
use super::{run_ensemble, AlignOutcome, AlignParams, ModelKind, Status};
use crate::optimize::{minimize_log_scale, Optimum, Settings};

/// One run of the search: a field, a replicate, its outcome.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunRecord {
    /// Field H, A/m.
    pub field: f64,
    /// Replicate index.
    pub replicate: usize,
    /// The replicate's seed.
    pub seed: u64,
    /// What the run gave.
    pub outcome: AlignOutcome,
}

/// A field optimization: base parameters (their `field` is ignored), model, replicates.
#[derive(Debug, Clone)]
pub struct FieldSearch {
    /// Parameters of every run.
    pub base: AlignParams,
    /// DEM or ensemble.
    pub model: ModelKind,
    /// Replicate packings (DEM); the ensemble is deterministic and uses one.
    pub replicates: usize,
    /// Master seed: replicate r uses seed + r.
    pub seed: u64,
    /// Search controls (fields in A/m).
    pub settings: Settings,
}

/// The outcome of a field search.
#[derive(Debug, Clone)]
pub struct FieldSearchResult {
    /// Optimum, uncertainty, band, all points (x = field in A/m, values = τ in s).
    pub optimum: Optimum,
    /// Every run, in evaluation order.
    pub runs: Vec<RunRecord>,
}

impl FieldSearch {
    /// Seed of replicate r.
    pub fn replicate_seed(&self, r: usize) -> u64 {
        self.seed.wrapping_add(r as u64)
    }

    fn replicate_count(&self) -> usize {
        match self.model {
            ModelKind::Dem => self.replicates,
            ModelKind::Ensemble => 1,
        }
    }

    /// Settles the replicate packings (DEM only), in parallel. A packing that fails is kept as
    /// its failure reason: that replicate's runs are recorded as failed.
    pub fn packings(&self, tick: &(impl Fn() + Sync)) -> Vec<Result<Packing, String>> {
        if self.model == ModelKind::Ensemble {
            return Vec::new();
        }
        let packing_params = self.base.packing();
        (0..self.replicates)
            .into_par_iter()
            .map(|r| {
                let p = Packing::generate(&packing_params, self.replicate_seed(r));
                tick();
                p
            })
            .collect()
    }

    /// Runs every replicate at one field (in parallel).
    pub fn evaluate(
        &self,
        field: f64,
        packings: &[Result<Packing, String>],
        tick: &(impl Fn() + Sync),
    ) -> Vec<RunRecord> {
        let mut params = self.base.clone();
        params.field = field;
        (0..self.replicate_count())
            .into_par_iter()
            .map(|r| {
                let outcome = match self.model {
                    ModelKind::Ensemble => run_ensemble(&params),
                    ModelKind::Dem => match &packings[r] {
                        Ok(packing) => dem::align(&params, packing),
                        Err(reason) => failed(reason),
                    },
                };
                tick();
                RunRecord {
                    field,
                    replicate: r,
                    seed: self.replicate_seed(r),
                    outcome,
                }
            })
            .collect()
    }

    /// Runs the whole search. `tick` is called after every packing and run; `on_runs` after
    /// every field with all runs so far (to write results as they finish).
    pub fn run(
        &self,
        tick: &(impl Fn() + Sync),
        mut on_runs: impl FnMut(&[RunRecord]),
    ) -> FieldSearchResult {
        let packings = self.packings(tick);
        let mut runs: Vec<RunRecord> = Vec::new();
        let optimum = minimize_log_scale(&self.settings, self.base.max_time, |field| {
            let records = self.evaluate(field, &packings, tick);
            let taus = records.iter().map(|r| r.outcome.alignment_time_s).collect();
            runs.extend(records);
            on_runs(&runs);
            taus
        });
        FieldSearchResult { optimum, runs }
    }

    /// Upper bound on the number of runs (for a progress bar): packings plus runs per field
    /// times scan points and Brent iterations (Brent stops early more often than not).
    pub fn expected_work(&self) -> u64 {
        let packings = if self.model == ModelKind::Dem {
            self.replicates
        } else {
            0
        };
        let fields = self.settings.scan_points as u64 + self.settings.brent_iterations;
        packings as u64 + fields * self.replicate_count() as u64
    }
}

fn failed(reason: &str) -> AlignOutcome {
    AlignOutcome {
        status: Status::Failed(reason.to_string()),
        alignment_time_s: None,
        alignment_time_90_s: None,
        final_alignment: f64::NAN,
        series: Vec::new(),
        steps: 0,
        time_step_s: 0.0,
        packing_fraction: None,
        contacts: None,
        bed_height_m: None,
        applied_force_n: None,
        nominal_force_n: None,
        solver_sweeps: 0,
        unconverged_solves: 0,
        sticking_fraction: None,
        wall_time_s: 0.0,
    }
}

/// One complete run (packing + alignment for the DEM) for one seed.
pub fn run_once(params: &AlignParams, model: ModelKind, seed: u64) -> AlignOutcome {
    match model {
        ModelKind::Ensemble => run_ensemble(params),
        ModelKind::Dem => match Packing::generate(&params.packing(), seed) {
            Ok(packing) => dem::align(params, &packing),
            Err(reason) => failed(&reason),
        },
    }
}
