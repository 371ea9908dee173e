//! `magopt optimize`: drive a study's metric to its optimum over the free parameter(s) of its
//! `[optimize]` table, averaging replicates with common random numbers (the same seeds at every
//! point). `method = "brent"` (the default for one parameter): log/linear scan + argmin's Brent
//! (`crate::optimize`); `"nelder-mead"` (the default for several): argmin's Nelder–Mead in the
//! unit cube of the (log-)scaled bounds; `"bayes"`: Bayesian optimization
//! ([`crate::study::bayes`]) in that cube, whose batches run every (point, replicate) pair in
//! parallel. Every run is saved like a sweep's, so an interrupted optimization resumes by
//! re-running the same command (the Bayesian loop is deterministic given the seed and the
//! observations, so it re-proposes the same points and reloads their runs).

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use rayon::prelude::*;
use std::cell::RefCell;
use std::path::Path;

use super::bayes;
use super::model::{ParamKind, ParamSpec, RunContext, StudyModel, Value};
use super::optimize_shard::ShardWait;
use super::records::RunRecord;
use super::runner::load_or_run;
use super::spec::{run_id, BayesSpec, OptimizeMethod, OptimizeSpec, RunSpec, Study};
use crate::optimize::{minimize_1d, Optimum, Point, Settings};
use crate::output::table::{ColumnData, Table};
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
    /// `method = "bayes"`: the posterior optimum's interval, region and history.
    pub bayes: Option<BayesResult>,
}

/// What a Bayesian optimization adds to its optimum (`value` and `best` of [`StudyOptimum`]
/// are the posterior mean's minimizer and the posterior mean there).
#[derive(Debug, Clone)]
pub struct BayesResult {
    /// Posterior standard deviation of the metric's latent mean at the optimum (of its ln
    /// with a log metric: then a relative uncertainty).
    pub std: f64,
    /// 95 % credible interval of that mean (metric units).
    pub interval: (f64, f64),
    /// Near-optimal region: per free parameter [lo, hi] (SI) of the evaluated and sampled
    /// points whose posterior mean is within `band` of the optimum.
    pub region: Vec<(f64, f64)>,
    /// Rounds after the initial design.
    pub rounds: usize,
    /// Why it stopped: "budget" or "tolerance".
    pub stop: &'static str,
    /// The largest expected improvement of the last proposed batch (metric units; ln units
    /// with a log metric).
    pub last_ei: f64,
    /// Per evaluation: its round, and the posterior optimum after that round (value, point
    /// in SI).
    pub history: Vec<(usize, f64, Vec<f64>)>,
}

/// Evaluates points of the free parameters: runs (or reloads) every replicate in parallel.
struct Evaluator<'a, M: StudyModel> {
    model: &'a M,
    study: &'a Study<M>,
    spec: &'a OptimizeSpec,
    out: Option<&'a Path>,
    tick: &'a (dyn Fn() + Sync),
    /// Where this optimization sits in its study (see [`Place`]).
    place: &'a Place,
    /// This process's shard, if the optimization is split over processes.
    shard: Option<ShardWait>,
    records: RefCell<Vec<RunRecord>>,
    evaluations: RefCell<Vec<(Vec<f64>, Point)>>,
}

/// Where an optimization sits in its study: the values of the study's grid or design point it
/// optimizes at (empty without `[sweep]`/`[design]`; they lead every run's recorded values),
/// and the number of points evaluated before it (its runs' point indices follow on).
#[derive(Debug, Clone, Default)]
pub struct Place {
    /// The grid or design point's values, in `study.axes` order.
    pub values: Vec<Value>,
    /// Points evaluated by the optimizations before this one.
    pub offset: usize,
}

impl<M: StudyModel> Evaluator<'_, M> {
    /// Per-replicate metric values at x, signed so that smaller is better (the stored
    /// evaluations keep the plain values).
    fn evaluate(&self, x: &[f64]) -> Result<Vec<Option<f64>>> {
        Ok(self.evaluate_batch(&[x.to_vec()])?.remove(0))
    }

    /// Per-point, per-replicate metric values (signed so that smaller is better) of a batch:
    /// every (point, replicate) run of the batch runs (or is reloaded) in parallel; a run that
    /// two points of the batch share runs once. The parameters of every point are checked
    /// before any run starts.
    fn evaluate_batch(&self, xs: &[Vec<f64>]) -> Result<Vec<Vec<Option<f64>>>> {
        let (model, study, out, tick) = (self.model, self.study, self.out, self.tick);
        let first = self.place.offset + self.evaluations.borrow().len();
        let mut points = Vec::with_capacity(xs.len());
        for x in xs {
            let mut params = study.base.clone();
            let values: Vec<Value> = x.iter().map(|&v| Value::Number(v)).collect();
            for ((spec, ..), v) in self.spec.free.iter().zip(&values) {
                let at = format!("optimize.parameters.{}", spec.name);
                model.set(&mut params, spec.name, v, &at)?;
            }
            model.check(&params)?;
            let inputs = model.inputs(&params);
            let values = [self.place.values.clone(), values].concat();
            points.push((params, values, inputs));
        }
        let mut runs: Vec<(RunSpec, usize)> = Vec::new();
        let mut slot: Vec<usize> = Vec::with_capacity(xs.len() * study.replicates);
        for (k, (_, values, inputs)) in points.iter().enumerate() {
            let point = first + k;
            for r in 0..study.replicates {
                let seed = study.seed.wrapping_add(r as u64);
                let id = run_id(model, inputs, seed);
                if let Some(j) = runs.iter().position(|(run, _)| run.id == id) {
                    slot.push(j);
                    continue;
                }
                slot.push(runs.len());
                runs.push((
                    RunSpec {
                        index: point * study.replicates + r,
                        id,
                        point,
                        replicate: r,
                        seed,
                        values: values.clone(),
                        inputs: inputs.clone(),
                    },
                    k,
                ));
            }
        }
        let shard = self.shard;
        let mine = |j: usize| shard.is_none_or(|s| s.runs(j));
        let done: Vec<Result<Option<RunRecord>>> = runs
            .par_iter()
            .enumerate()
            .map(|(j, (run, k))| {
                if !mine(j) {
                    return Ok(None);
                }
                // a saved run keeps its result; its position is this evaluation's
                let record = load_or_run(model, run, &points[*k].0, out, true, &RunContext::QUIET)?;
                tick();
                Ok(Some(record))
            })
            .collect();
        let mut done_all = Vec::with_capacity(runs.len());
        for (j, record) in done.into_iter().enumerate() {
            let record = match (record?, self.shard, out) {
                (Some(r), ..) => r,
                (None, Some(shard), Some(dir)) => {
                    let r = shard.wait(dir, &runs[j].0, j)?;
                    tick();
                    r
                }
                (None, ..) => {
                    return Err(Error::input("--shard: a sharded optimization needs --out"))
                }
            };
            done_all.push(record);
        }
        let done = done_all;
        let sign = if self.spec.maximize { -1.0 } else { 1.0 };
        let mut signed = Vec::with_capacity(xs.len());
        for (k, x) in xs.iter().enumerate() {
            let fresh: Vec<&RunRecord> = (0..study.replicates)
                .map(|r| &done[slot[k * study.replicates + r]])
                .collect();
            let metric: Vec<Option<f64>> = fresh
                .iter()
                .map(|r| r.result.metric(&self.spec.metric))
                .collect();
            self.records.borrow_mut().extend(fresh.into_iter().cloned());
            self.evaluations.borrow_mut().push((
                x.clone(),
                Point {
                    x: x[0],
                    values: metric.clone(),
                },
            ));
            signed.push(metric.iter().map(|v| v.map(|v| sign * v)).collect());
        }
        Ok(signed)
    }
}

/// Runs the optimization of `study.optimize` from `study.base`. Runs are saved into `out` (if
/// given) as they finish, and reused when already there.
pub fn optimize<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    tick: &(dyn Fn() + Sync),
) -> Result<StudyOptimum> {
    optimize_sharded(model, study, out, tick, None)
}

/// [`optimize`] as one shard of several processes (see [`super::optimize_shard`]); every
/// shard returns the same optimum.
pub fn optimize_sharded<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    tick: &(dyn Fn() + Sync),
    shard: Option<ShardWait>,
) -> Result<StudyOptimum> {
    let _lock = lock(out, shard, &shard_key(model, study))?;
    optimize_at(model, study, out, tick, &Place::default(), shard)
}

/// What holds an output directory: the lock of the whole directory, or a shard's own.
#[derive(Debug)]
pub(crate) enum Held {
    /// The directory's lock.
    Whole {
        /// Released on drop.
        _lock: crate::output::guard::DirLock,
    },
    /// A shard's lock and heartbeat.
    Shard {
        /// Released on drop.
        _lock: super::optimize_shard::ShardLock,
    },
}

/// What the shards of one optimization must share: the model's code and the study's text.
pub(crate) fn shard_key<M: StudyModel>(model: &M, study: &Study<M>) -> String {
    format!("{}\n{}", model.code(), study.text)
}

/// Prepares and locks the output directory (a shard takes its own lock, so that the shards of
/// one optimization share the directory, and records `key`, [`shard_key`]).
pub(crate) fn lock(
    out: Option<&Path>,
    shard: Option<ShardWait>,
    key: &str,
) -> Result<Option<Held>> {
    let Some(dir) = out else {
        return match shard {
            Some(_) => Err(Error::input("--shard: a sharded optimization needs --out")),
            None => Ok(None),
        };
    };
    crate::output::atomic::prepare_output_dir(dir)?;
    Ok(Some(match shard {
        Some(s) => Held::Shard {
            _lock: s.hold(dir, key)?,
        },
        None => Held::Whole {
            _lock: crate::output::guard::DirLock::acquire(dir)?,
        },
    }))
}

/// [`optimize`] at a `place` of the study (its `base` already holds the place's values).
pub(crate) fn optimize_at<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    tick: &(dyn Fn() + Sync),
    place: &Place,
    shard: Option<ShardWait>,
) -> Result<StudyOptimum> {
    let spec = study
        .optimize
        .as_ref()
        .ok_or_else(|| Error::input("the study has no [optimize] table"))?;
    let evaluator = Evaluator {
        model,
        study,
        spec,
        out,
        tick,
        place,
        shard,
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
    if let OptimizeMethod::Bayes(b) = &spec.method {
        return bayesian(&evaluator, b);
    }
    let one_dimensional = if spec.method == OptimizeMethod::Brent {
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
        // the scan's points run as one batch: every (field, replicate) run in parallel
        let guarded_batch = |xs: &[f64]| {
            let points: Vec<Vec<f64>> = xs.iter().map(|&x| vec![x]).collect();
            evaluator.evaluate_batch(&points).unwrap_or_else(|e| {
                failure.borrow_mut().get_or_insert(e);
                vec![vec![None; study.replicates]; xs.len()]
            })
        };
        Some(minimize_1d(&settings, PENALTY, guarded_batch))
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
        bayes: None,
    })
}

/// A point of the unit cube in SI: (log-)linear in each free parameter's bounds, counts
/// rounded.
fn from_unit(spec: &OptimizeSpec, z: &[f64]) -> Vec<f64> {
    z.iter()
        .zip(&spec.free)
        .map(|(&t, (s, lo, hi))| {
            let x = if spec.log {
                (lo.ln() + t * (hi.ln() - lo.ln())).exp()
            } else {
                lo + t * (hi - lo)
            };
            if matches!(s.kind, ParamKind::Count) {
                x.round()
            } else {
                x
            }
        })
        .collect()
}

/// Errors of the Bayesian loop: its own (a message) or the evaluator's.
enum Failure {
    Loop(String),
    Run(Error),
}

impl From<String> for Failure {
    fn from(message: String) -> Self {
        Failure::Loop(message)
    }
}

/// A point's sample for the surrogate from its signed replicate values: the replicate mean
/// m with noise s²/r, or with `log` (a positive metric) s·ln|m| with the delta-method noise
/// s²/(r m²); None unless every replicate gave a value (and, with `log`, m > 0).
fn bayes_sample(signed: &[Option<f64>], sign: f64, log: bool) -> bayes::Sample {
    let p = Point {
        x: 0.0,
        values: signed.iter().map(|v| v.map(|v| sign * v)).collect(),
    };
    let r = signed.len() as f64;
    let (m, noise) = (p.mean(), p.std().powi(2) / r);
    let complete = p.complete() && m.is_finite();
    let (mean, noise) = match (complete, log) {
        (false, _) => (None, 0.0),
        (true, false) => (Some(sign * m), noise),
        (true, true) if m > 0.0 => (Some(sign * m.ln()), noise / (m * m)),
        (true, true) => (None, 0.0),
    };
    bayes::Sample { mean, noise }
}

/// `method = "bayes"`: the loop of [`bayes::minimize`] on the unit cube, each batch evaluated
/// by [`Evaluator::evaluate_batch`]; a point's sample is [`bayes_sample`]. With a log metric
/// the posterior values are mapped back by exp (the interval's ends too: a quantile maps to
/// the quantile).
fn bayesian<M: StudyModel>(evaluator: &Evaluator<'_, M>, b: &BayesSpec) -> Result<StudyOptimum> {
    let (spec, study) = (evaluator.spec, evaluator.study);
    let sign = if spec.maximize { -1.0 } else { 1.0 };
    // the surrogate's value z back in metric units
    let metric = |z: f64| {
        if b.log_metric {
            (sign * z).exp()
        } else {
            sign * z
        }
    };
    let settings = bayes::Settings {
        budget: b.budget,
        batch: b.batch,
        initial: b.initial,
        tolerance: b.tolerance,
        band: spec.band,
        ..bayes::Settings::defaults(spec.free.len(), study.seed)
    };
    let outcome = bayes::minimize(&settings, |batch: &[Vec<f64>]| {
        let xs: Vec<Vec<f64>> = batch.iter().map(|z| from_unit(spec, z)).collect();
        let values = evaluator.evaluate_batch(&xs).map_err(Failure::Run)?;
        Ok::<_, Failure>(
            values
                .iter()
                .map(|v| bayes_sample(v, sign, b.log_metric))
                .collect(),
        )
    })
    .map_err(|f| match f {
        Failure::Run(e) => e,
        Failure::Loop(m) => Error::input(format!("optimize: {m}")),
    })?;
    let evaluations = evaluator.evaluations.take();
    if !evaluations.iter().any(|(_, p)| p.complete()) {
        return Err(Error::Output(format!(
            "optimize: no evaluated point gave {} on every replicate",
            spec.metric
        )));
    }
    let (lo, hi) = (metric(outcome.interval.0), metric(outcome.interval.1));
    let interval = (lo.min(hi), lo.max(hi));
    let corners = |f: fn(&(f64, f64)) -> f64| -> Vec<f64> {
        from_unit(spec, &outcome.region.iter().map(f).collect::<Vec<_>>())
    };
    let (low, high) = (corners(|r| r.0), corners(|r| r.1));
    Ok(StudyOptimum {
        best: from_unit(spec, &outcome.x),
        value: metric(outcome.value),
        one_dimensional: None,
        evaluations,
        records: evaluator.records.take(),
        bayes: Some(BayesResult {
            std: outcome.std,
            interval,
            region: low.into_iter().zip(high).collect(),
            rounds: outcome.rounds,
            stop: outcome.stop.name(),
            last_ei: outcome.last_ei,
            history: outcome
                .evaluations
                .iter()
                .map(|e| (e.round, metric(e.best), from_unit(spec, &e.best_x)))
                .collect(),
        }),
    })
}

/// `history.parquet` of a Bayesian optimization: per evaluation its index, round, point
/// (display units), replicate mean and standard deviation of the metric, and the posterior
/// optimum after its round (value and point). None for the other methods.
pub fn history_table<M: StudyModel>(study: &Study<M>, result: &StudyOptimum) -> Option<Table> {
    let spec = study.optimize.as_ref()?;
    let bayes = result.bayes.as_ref()?;
    let n = result.evaluations.len();
    let mut t = Table::new().with("evaluation", ColumnData::I64((0..n as i64).collect()));
    t.push(
        "round",
        ColumnData::I64(bayes.history.iter().map(|h| h.0 as i64).collect()),
    );
    let unit = super::records::metric_unit(&spec.metric);
    let column = |k: usize, x: &dyn Fn(usize) -> f64| {
        let (s, ..) = spec.free[k];
        let values: Vec<Option<Value>> = (0..n).map(|i| Some(Value::Number(x(i)))).collect();
        super::records::value_column(
            s,
            &values
                .iter()
                .map(|v| v.as_ref().map(|v| s.display(v)))
                .collect::<Vec<_>>(),
        )
    };
    for (k, (s, ..)) in spec.free.iter().enumerate() {
        let (data, u) = column(k, &|i| result.evaluations[i].0[k]);
        match u {
            Some(u) => t.push_unit(&s.column(), data, &u),
            None => t.push(&s.column(), data),
        }
    }
    let mean: Vec<Option<f64>> = result
        .evaluations
        .iter()
        .map(|(_, p)| p.complete().then(|| p.mean()))
        .collect();
    let std: Vec<Option<f64>> = result
        .evaluations
        .iter()
        .map(|(_, p)| p.complete().then(|| p.std()))
        .collect();
    t.push_unit("mean", ColumnData::OptF64(mean), unit);
    t.push_unit("std", ColumnData::OptF64(std), unit);
    t.push_unit(
        "best",
        ColumnData::F64(bayes.history.iter().map(|h| h.1).collect()),
        unit,
    );
    for (k, (s, ..)) in spec.free.iter().enumerate() {
        let (data, u) = column(k, &|i| bayes.history[i].2[k]);
        let name = format!("best_{}", s.column());
        match u {
            Some(u) => t.push_unit(&name, data, &u),
            None => t.push(&name, data),
        }
    }
    Some(t)
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
/// evaluation, the seeds and the version; the method, and for `method = "bayes"` (null
/// otherwise) the 95 % credible interval of the mean metric at the optimum, the near-optimal
/// region per parameter and `bayes` (settings, rounds, why it stopped, the last expected
/// improvement, the posterior standard deviation at the optimum, and the history of the
/// posterior optimum per evaluation).
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
        "method": spec.method.name(),
        "credible_interval": result.bayes.as_ref().map(|b| serde_json::json!([finite(b.interval.0), finite(b.interval.1)])),
        "near_optimal_region": result.bayes.as_ref().map(|b| spec.free.iter().zip(&b.region).map(|((s, ..), &(lo, hi))| {
            (s.column(), serde_json::json!([finite(shown(s, lo)), finite(shown(s, hi))]))
        }).collect::<serde_json::Map<_, _>>()),
        "bayes": match (&spec.method, result.bayes.as_ref()) {
            (OptimizeMethod::Bayes(settings), Some(b)) => serde_json::json!({
                "budget": settings.budget,
                "batch": settings.batch,
                "initial": settings.initial,
                "tolerance": settings.tolerance,
                "transform": if settings.log_metric { "log" } else { "none" },
                "rounds": b.rounds,
                "stop": b.stop,
                "last_expected_improvement": finite(b.last_ei),
                "posterior_std": finite(b.std),
                "history": b.history.iter().enumerate().map(|(k, (round, value, x))| serde_json::json!({
                    "evaluation": k, "round": round, "best": finite(*value), "optimum": named(x),
                })).collect::<Vec<_>>(),
            }),
            _ => serde_json::Value::Null,
        },
    })
}
