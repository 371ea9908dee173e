//! `magopt optimize`: drive a study's metric to its optimum over the free parameter(s) of its
//! `[optimize]` table, averaging replicates with common random numbers (the same seeds at every
//! point). One parameter: log/linear scan + argmin's Brent (`crate::optimize`); several: argmin's
//! Nelder–Mead in the unit cube of the (log-)scaled bounds. Every run is saved like a sweep's,
//! so an interrupted optimization resumes by re-running the same command.

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use rayon::prelude::*;
use std::cell::RefCell;
use std::path::Path;

use super::model::{ParamSpec, RunContext, StudyModel, Value};
use super::records::RunRecord;
use super::runner::load_or_run;
use super::spec::{run_id, OptimizeSpec, RunSpec, Study};
use crate::optimize::{minimize_1d, Optimum, Point, Settings};
use crate::{Error, Result};

/// Score of a point whose replicates did not all give the metric (never a candidate).
const PENALTY: f64 = 1e100;

/// The result of an optimization.
#[derive(Debug, Clone)]
pub struct StudyOptimum {
    /// Best free-parameter values (SI), in `[optimize]` order.
    pub best: Vec<f64>,
    /// Mean metric there.
    pub value: f64,
    /// One parameter: the scan/Brent details (uncertainty, band, points with x in SI).
    pub one_dimensional: Option<Optimum>,
    /// Every evaluation: parameter values (SI) and per-replicate metric values.
    pub evaluations: Vec<(Vec<f64>, Point)>,
    /// Every run, in evaluation order.
    pub records: Vec<RunRecord>,
}

/// Evaluates points of the free parameters: runs (or reloads) every replicate in parallel.
struct Evaluator<'a, M: StudyModel> {
    model: &'a M,
    study: &'a Study<M>,
    spec: &'a OptimizeSpec,
    out: Option<&'a Path>,
    tick: &'a (dyn Fn() + Sync),
    records: RefCell<Vec<RunRecord>>,
    evaluations: RefCell<Vec<(Vec<f64>, Point)>>,
}

impl<M: StudyModel> Evaluator<'_, M> {
    /// Per-replicate metric values at x, signed so that smaller is better (the stored
    /// evaluations keep the plain values).
    fn evaluate(&self, x: &[f64]) -> Result<Vec<Option<f64>>> {
        let mut params = self.study.base.clone();
        let values: Vec<Value> = x.iter().map(|&v| Value::Number(v)).collect();
        for ((spec, ..), v) in self.spec.free.iter().zip(&values) {
            let at = format!("optimize.parameters.{}", spec.name);
            self.model.set(&mut params, spec.name, v, &at)?;
        }
        self.model.check(&params)?;
        let point = self.evaluations.borrow().len();
        let inputs = self.model.inputs(&params);
        let (model, study, out, tick) = (self.model, self.study, self.out, self.tick);
        let fresh: Vec<Result<RunRecord>> = (0..study.replicates)
            .into_par_iter()
            .map(|r| {
                let seed = study.seed.wrapping_add(r as u64);
                let run = RunSpec {
                    index: point * study.replicates + r,
                    id: run_id(model.name(), &inputs, seed),
                    point,
                    replicate: r,
                    seed,
                    values: values.clone(),
                    inputs: inputs.clone(),
                };
                // a saved run keeps its result; its position is this evaluation's
                let record = load_or_run(model, &run, &params, out, true, &RunContext::QUIET)?;
                tick();
                Ok(record)
            })
            .collect();
        let fresh = fresh.into_iter().collect::<Result<Vec<_>>>()?;
        let metric: Vec<Option<f64>> = fresh
            .iter()
            .map(|r| r.result.metric(&self.spec.metric))
            .collect();
        self.records.borrow_mut().extend(fresh);
        self.evaluations.borrow_mut().push((
            x.to_vec(),
            Point {
                x: x[0],
                values: metric.clone(),
            },
        ));
        let sign = if self.spec.maximize { -1.0 } else { 1.0 };
        Ok(metric.iter().map(|v| v.map(|v| sign * v)).collect())
    }
}

/// Runs the optimization of `study.optimize`. Runs are saved into `out` (if given) as they
/// finish, and reused when already there.
pub fn optimize<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    tick: &(dyn Fn() + Sync),
) -> Result<StudyOptimum> {
    let spec = study
        .optimize
        .as_ref()
        .ok_or_else(|| Error::input("the study has no [optimize] table"))?;
    let _lock = match out {
        Some(dir) => {
            crate::output::atomic::prepare_output_dir(dir)?;
            Some(crate::output::guard::DirLock::acquire(dir)?)
        }
        None => None,
    };
    let evaluator = Evaluator {
        model,
        study,
        spec,
        out,
        tick,
        records: RefCell::new(Vec::new()),
        evaluations: RefCell::new(Vec::new()),
    };
    let failure = RefCell::new(None);
    let guarded = |x: &[f64]| match evaluator.evaluate(x) {
        Ok(v) => v,
        Err(e) => {
            failure.borrow_mut().get_or_insert(e);
            vec![None; study.replicates]
        }
    };
    let one_dimensional = if spec.free.len() == 1 {
        let (_, lower, upper) = spec.free[0];
        let settings = Settings {
            lower,
            upper,
            scan_points: spec.scan_points,
            brent_iterations: spec.iterations,
            rel_tolerance: 1e-3,
            band: spec.band,
            log: spec.log,
        };
        Some(minimize_1d(&settings, PENALTY, |x| guarded(&[x])))
    } else {
        nelder_mead(spec, &guarded);
        None
    };
    if let Some(e) = failure.into_inner() {
        return Err(e);
    }
    let sign = if spec.maximize { -1.0 } else { 1.0 };
    let evaluations = evaluator.evaluations.into_inner();
    let score = |p: &Point| {
        if p.complete() {
            sign * p.mean()
        } else {
            PENALTY
        }
    };
    let best = evaluations
        .iter()
        .min_by(|a, b| score(&a.1).total_cmp(&score(&b.1)))
        .ok_or_else(|| Error::Output("no evaluation".into()))?;
    let one_dimensional = one_dimensional.map(|o| Optimum {
        value: sign * o.value,
        points: o
            .points
            .into_iter()
            .map(|p| Point {
                values: p.values.iter().map(|v| v.map(|v| sign * v)).collect(),
                ..p
            })
            .collect(),
        ..o
    });
    Ok(StudyOptimum {
        best: one_dimensional
            .as_ref()
            .map_or(best.0.clone(), |o| vec![o.x]),
        value: one_dimensional.as_ref().map_or(best.1.mean(), |o| o.value),
        one_dimensional,
        evaluations,
        records: evaluator.records.into_inner(),
    })
}

/// Nelder–Mead over the unit cube of the scaled bounds (points outside score the penalty).
fn nelder_mead(spec: &OptimizeSpec, evaluate: &dyn Fn(&[f64]) -> Vec<Option<f64>>) {
    struct Cost<'a> {
        spec: &'a OptimizeSpec,
        evaluate: &'a dyn Fn(&[f64]) -> Vec<Option<f64>>,
    }
    impl CostFunction for Cost<'_> {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, z: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
            if z.iter().any(|&t| !(0.0..=1.0).contains(&t)) {
                return Ok(PENALTY);
            }
            let x: Vec<f64> = z
                .iter()
                .zip(&self.spec.free)
                .map(|(&t, (_, lo, hi))| {
                    if self.spec.log {
                        (lo.ln() + t * (hi.ln() - lo.ln())).exp()
                    } else {
                        lo + t * (hi - lo)
                    }
                })
                .collect();
            let values = (self.evaluate)(&x);
            let complete: Vec<f64> = values.iter().flatten().copied().collect();
            Ok(if complete.len() == values.len() {
                complete.iter().sum::<f64>() / complete.len() as f64
            } else {
                PENALTY
            })
        }
    }
    let d = spec.free.len();
    let simplex: Vec<Vec<f64>> = (0..=d)
        .map(|k| {
            (0..d)
                .map(|j| if j + 1 == k { 0.75 } else { 0.5 })
                .collect()
        })
        .collect();
    if let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(1e-4) {
        let _ = Executor::new(Cost { spec, evaluate }, solver)
            .configure(|s| s.max_iters(spec.iterations))
            .run();
    }
}

/// `optimum.json` and `--json` of `magopt optimize` and `magopt optimize-field` (one schema):
/// the optimum per free parameter in display units (columns such as `field_kOe`), the mean
/// metric there, for one free parameter the uncertainty and the near-optimal band, every
/// evaluation, the seeds and the version.
pub fn optimum_json<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    result: &StudyOptimum,
) -> serde_json::Value {
    let Some(spec) = study.optimize.as_ref() else {
        return serde_json::Value::Null;
    };
    let finite = |x: f64| {
        if x.is_finite() {
            serde_json::json!(x)
        } else {
            serde_json::Value::Null
        }
    };
    let shown = |s: &ParamSpec, x: f64| s.display(&Value::Number(x)).as_number();
    let named = |x: &[f64]| -> serde_json::Map<String, serde_json::Value> {
        spec.free
            .iter()
            .zip(x)
            .map(|((s, ..), &v)| (s.column(), finite(shown(s, v))))
            .collect()
    };
    let one = result.one_dimensional.as_ref();
    let (s0, ..) = spec.free[0];
    let single = |f: &dyn Fn(&Optimum) -> serde_json::Value| {
        one.map(|o| serde_json::json!({ s0.column(): f(o) }))
    };
    serde_json::json!({
        "study": study.name,
        "model": model.name(),
        "metric": spec.metric,
        "goal": if spec.maximize { "maximize" } else { "minimize" },
        "optimum": named(&result.best),
        "value": finite(result.value),
        "uncertainty": single(&|o| finite(shown(s0, o.x + o.uncertainty) - shown(s0, o.x))),
        "band": single(&|o| serde_json::json!([shown(s0, o.band.0), shown(s0, o.band.1)])),
        "evaluations": result.evaluations.iter().map(|(x, p)| serde_json::json!({
            "parameters": named(x), "mean": finite(p.mean()), "std": finite(p.std()),
            "replicates_with_value": p.values.iter().flatten().count(),
            "replicates": p.values.len(),
        })).collect::<Vec<_>>(),
        "seeds": (0..study.replicates).map(|r| study.seed.wrapping_add(r as u64)).collect::<Vec<_>>(),
        "magopt_version": super::records::VERSION,
    })
}
