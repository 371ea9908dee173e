//! `magopt optimize` on a study with `[objectives]`: the Pareto front of two or three
//! objectives over the free parameters by NSGA-II ([`super::pareto`]; Deb et al. 2002).
//!
//! Each generation's points are mapped from the unit cube onto the parameters' (log or
//! linear) bounds, and all their (point, replicate) runs go in parallel through
//! [`load_or_run`]: every run is saved the moment it finishes and a saved run is reused, so an
//! interrupted optimization resumes by repeating the command (the NSGA-II stream is seeded by
//! the study seed, and saved results read back bit for bit, so the same points come again).
//! An objective's value at a point is the mean over its replicates (seeds seed, seed + 1, …,
//! the same at every point); a metric missing in any replicate leaves the point without a
//! value, and such a point is dominated by every other. A free parameter as an objective
//! counts with its own value in display units.
//!
//! Outputs: `evaluations.parquet` (every run, with its generation), `series.parquet`,
//! `front.parquet` (the final non-dominated points: parameters in display units, each metric
//! objective's mean, std and count), `pareto.json` (the front, the hypervolume — Zitzler &
//! Thiele 1998 — w.r.t. the reference point `reference` or the front's nadir + 10 % of its
//! range, and, to show convergence, the hypervolume of the points non-dominated among
//! everything evaluated up to each generation — the archive, which may hold more points than
//! the final population's front), `front.png`, the
//! study file and the provenance.

use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

use super::model::{ParamSpec, RunContext, StudyModel, Value};
use super::objectives::{ObjectivesSpec, Target};
use super::pareto::{hypervolume, non_dominated, nsga2, Settings};
use super::records::{self, Columns, RunRecord};
use super::runner::load_or_run;
use super::spec::{run_id, RunSpec, Study, MAX_RUNS};
use crate::numerics::stats::Stats;
use crate::output::atomic::{write_atomic, write_json_atomic};
use crate::output::plot::{render_png, render_png_panels, Figure, Series, SeriesStyle};
use crate::output::table::{write_parquet, ColumnData as C, Table};
use crate::{Error, Result};

/// One evaluated point.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// The NSGA-II generation that made it (0: the initial population).
    pub generation: usize,
    /// The free parameters (SI), in `[objectives.parameters]` order.
    pub values: Vec<f64>,
    /// Per objective: the replicate mean (objective units, as given; None if missing).
    pub means: Vec<Option<f64>>,
    /// Per objective: the replicate standard deviation (None below two replicates).
    pub stds: Vec<Option<f64>>,
    /// Per objective: replicates that gave a value.
    pub counts: Vec<usize>,
    /// Why the point has no runs (its parameters were rejected by the model), if so.
    pub rejected: Option<String>,
}

/// What a multi-objective optimization found.
#[derive(Debug, Clone)]
pub struct ParetoResult {
    /// Every evaluated point, in evaluation order (point index = position).
    pub evaluations: Vec<Evaluation>,
    /// The final non-dominated points (indices into `evaluations`; each parameter set once).
    pub front: Vec<usize>,
    /// The hypervolume reference point (objective units).
    pub reference: Vec<f64>,
    /// Whether the reference was given in the study (else nadir + 10 % of the range).
    pub reference_given: bool,
    /// The front's hypervolume w.r.t. `reference`.
    pub hypervolume: f64,
    /// The hypervolume of the points non-dominated among everything evaluated up to each
    /// generation (same reference).
    pub hypervolume_by_generation: Vec<f64>,
    /// Every run, in evaluation order.
    pub records: Vec<RunRecord>,
}

impl ParetoResult {
    /// An evaluation's objectives, every one minimized (maximized ones negated); None if any
    /// is missing.
    fn minimized(spec: &ObjectivesSpec, e: &Evaluation) -> Option<Vec<f64>> {
        spec.objectives
            .iter()
            .zip(&e.means)
            .map(|(o, m)| m.map(|m| if o.maximize { -m } else { m }))
            .collect()
    }
}

/// The `[objectives]` of a study, checked against the rest of it before any run: no
/// `[sweep]`, `[design]` or `[optimize]` beside it, free parameters not also in `[base]`, the
/// run count within limits, and the model accepting the parameters at their bounds.
pub fn check<'a, M: StudyModel>(model: &M, study: &'a Study<M>) -> Result<&'a ObjectivesSpec> {
    let spec = study
        .objectives
        .as_ref()
        .ok_or_else(|| Error::input(format!("{}: no [objectives] table", study.name)))?;
    let fail = |why: String| Error::input(format!("{}: objectives: {why}", study.name));
    if study.design.is_some() {
        return Err(fail(
            "a study has either [design] or [objectives], not both".into(),
        ));
    }
    if !study.axes.is_empty() {
        return Err(fail(
            "a study has either [sweep] or [objectives], not both".into(),
        ));
    }
    if study.optimize.is_some() {
        return Err(fail(
            "a study has either [optimize] or [objectives], not both".into(),
        ));
    }
    for f in &spec.free {
        if study.base_values.iter().any(|(k, _)| k == f.spec.name) {
            return Err(Error::input(format!(
                "{study}: objectives.parameters.{name}: {name} is also set in [base] (set it in one \
                 place)",
                study = study.name,
                name = f.spec.name
            )));
        }
    }
    let runs = spec.points().checked_mul(study.replicates);
    if runs.is_none_or(|n| n > MAX_RUNS) {
        return Err(Error::input(format!(
            "{}: objectives.generations: population × (generations + 1) × replicates is more \
             than {MAX_RUNS} runs",
            study.name
        )));
    }
    for (side, u) in [("lower", 0.0), ("upper", 1.0)] {
        let values: Vec<f64> = spec.free.iter().map(|f| f.value(u)).collect();
        params_at(model, study, spec, &values).map_err(|e| {
            Error::input(format!(
                "{}: objectives.parameters: at the {side} bounds: {e}",
                study.name
            ))
        })?;
    }
    Ok(spec)
}

/// The study's base with the free parameters set to `values` (SI), checked.
fn params_at<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    spec: &ObjectivesSpec,
    values: &[f64],
) -> Result<M::Params> {
    let mut params = study.base.clone();
    for (f, &v) in spec.free.iter().zip(values) {
        let at = format!("objectives.parameters.{}", f.spec.name);
        model.set(&mut params, f.spec.name, &Value::Number(v), &at)?;
    }
    model.check(&params)?;
    Ok(params)
}

/// Runs the NSGA-II optimization of `study.objectives`, saving every run into `out` as it
/// finishes and reusing the runs already there. `tick` is called after every run.
pub fn optimize<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: &Path,
    tick: &(dyn Fn() + Sync),
) -> Result<ParetoResult> {
    let spec = check(model, study)?;
    crate::output::atomic::prepare_output_dir(out)?;
    let _lock = crate::output::guard::DirLock::acquire(out)?;
    let m = spec.objectives.len();
    let mut evaluations: Vec<Evaluation> = Vec::with_capacity(spec.points());
    let mut records: Vec<RunRecord> = Vec::new();
    let mut saved: HashMap<String, RunRecord> = HashMap::new();
    let mut failure: Option<Error> = None;
    let settings = Settings::new(spec.population, spec.generations, study.seed);
    let outcome = nsga2(spec.free.len(), m, &settings, |xs: &[Vec<f64>]| {
        let generation = evaluations.len() / spec.population;
        let first = evaluations.len();
        // the points, their parameters and their runs
        let mut points: Vec<(Vec<f64>, Result<M::Params>)> = Vec::with_capacity(xs.len());
        for u in xs {
            let values: Vec<f64> = spec.free.iter().zip(u).map(|(f, &u)| f.value(u)).collect();
            let params = params_at(model, study, spec, &values);
            points.push((values, params));
        }
        let mut runs: Vec<(RunSpec, usize)> = Vec::new();
        for (k, (values, params)) in points.iter().enumerate() {
            let Ok(params) = params else { continue };
            let inputs = model.inputs(params);
            for r in 0..study.replicates {
                let seed = study.seed.wrapping_add(r as u64);
                let point = first + k;
                runs.push((
                    RunSpec {
                        index: point * study.replicates + r,
                        id: run_id(model, &inputs, seed),
                        point,
                        replicate: r,
                        seed,
                        values: values.iter().map(|&v| Value::Number(v)).collect(),
                        inputs: inputs.clone(),
                    },
                    k,
                ));
            }
        }
        // each distinct run once (a point may come again), in parallel
        let mut todo: Vec<&(RunSpec, usize)> = Vec::new();
        for job in &runs {
            if !saved.contains_key(&job.0.id) && !todo.iter().any(|t| t.0.id == job.0.id) {
                todo.push(job);
            }
        }
        if failure.is_none() {
            let fresh: Vec<Result<RunRecord>> = todo
                .par_iter()
                .map(|(run, k)| {
                    let params = points[*k].1.as_ref().expect("a run has parameters");
                    let record =
                        load_or_run(model, run, params, Some(out), true, &RunContext::QUIET)?;
                    tick();
                    Ok(record)
                })
                .collect();
            for record in fresh {
                match record {
                    Ok(record) => {
                        saved.insert(record.run.id.clone(), record);
                    }
                    Err(e) => {
                        failure.get_or_insert(e);
                    }
                }
            }
        }
        // records in evaluation order, and each point's objectives
        let mut rows = Vec::with_capacity(xs.len());
        for (k, (values, params)) in points.into_iter().enumerate() {
            let mine: Vec<RunRecord> = runs
                .iter()
                .filter(|(_, j)| *j == k)
                .filter_map(|(run, _)| {
                    saved.get(&run.id).map(|s| RunRecord {
                        run: run.clone(),
                        ..s.clone()
                    })
                })
                .collect();
            let complete = mine.len() == study.replicates && params.is_ok();
            let mut means = Vec::with_capacity(m);
            let mut stds = Vec::with_capacity(m);
            let mut counts = Vec::with_capacity(m);
            for o in &spec.objectives {
                match &o.target {
                    Target::Parameter(j) => {
                        let f = &spec.free[*j];
                        means.push(complete.then(|| f.shown(values[*j])));
                        stds.push(complete.then_some(0.0));
                        counts.push(if complete { study.replicates } else { 0 });
                    }
                    Target::Metric(name) => {
                        let got: Vec<f64> = mine
                            .iter()
                            .filter_map(|r| r.result.metric(name))
                            .filter(|v| v.is_finite())
                            .collect();
                        let stats = Stats::of(got.iter().copied());
                        let all = complete && got.len() == study.replicates;
                        means.push(all.then_some(stats.mean));
                        stds.push((all && got.len() >= 2).then_some(stats.std));
                        counts.push(got.len());
                    }
                }
            }
            records.extend(mine);
            let e = Evaluation {
                generation,
                values,
                means,
                stds,
                counts,
                rejected: params.err().map(|e| e.to_string()),
            };
            rows.push(
                spec.objectives
                    .iter()
                    .zip(&e.means)
                    .map(|(o, v)| v.map(|v| if o.maximize { -v } else { v }))
                    .collect(),
            );
            evaluations.push(e);
        }
        for _ in 0..runs.len().saturating_sub(todo.len()) {
            tick();
        }
        rows
    });
    if let Some(e) = failure {
        return Err(e);
    }
    let mut front: Vec<usize> = Vec::new();
    for i in outcome.front {
        if !front
            .iter()
            .any(|&j| evaluations[j].values == evaluations[i].values)
        {
            front.push(i);
        }
    }
    let minimized: Vec<Option<Vec<f64>>> = evaluations
        .iter()
        .map(|e| ParetoResult::minimized(spec, e))
        .collect();
    let front_values: Vec<Vec<f64>> = front.iter().filter_map(|&i| minimized[i].clone()).collect();
    let (reference_min, reference_given) = match &spec.reference {
        Some(r) => (
            spec.objectives
                .iter()
                .zip(r)
                .map(|(o, &v)| if o.maximize { -v } else { v })
                .collect::<Vec<f64>>(),
            true,
        ),
        None => (default_reference(&front_values, m), false),
    };
    let hv = hypervolume(&front_values, &reference_min);
    // the hypervolume of everything found up to each generation, from a running archive
    let mut archive: Vec<Vec<f64>> = Vec::new();
    let mut by_generation = Vec::with_capacity(spec.generations + 1);
    for chunk in minimized.chunks(spec.population) {
        let candidates: Vec<Option<Vec<f64>>> = archive
            .iter()
            .cloned()
            .map(Some)
            .chain(chunk.iter().cloned())
            .collect();
        archive = non_dominated(&candidates)
            .into_iter()
            .filter_map(|i| candidates[i].clone())
            .collect();
        by_generation.push(hypervolume(&archive, &reference_min));
    }
    let reference = spec
        .objectives
        .iter()
        .zip(&reference_min)
        .map(|(o, &v)| if o.maximize { -v } else { v })
        .collect();
    Ok(ParetoResult {
        evaluations,
        front,
        reference,
        reference_given,
        hypervolume: hv,
        hypervolume_by_generation: by_generation,
        records,
    })
}

/// The front's nadir plus 10 % of its range in each objective (minimized); where the range is
/// zero, 10 % of the value's size (or 1 at zero).
fn default_reference(front: &[Vec<f64>], m: usize) -> Vec<f64> {
    (0..m)
        .map(|k| {
            let hi = front.iter().map(|f| f[k]).fold(f64::NEG_INFINITY, f64::max);
            let lo = front.iter().map(|f| f[k]).fold(f64::INFINITY, f64::min);
            if !hi.is_finite() {
                return 0.0;
            }
            let range = hi - lo;
            let pad = if range > 0.0 {
                0.1 * range
            } else if hi != 0.0 {
                0.1 * hi.abs()
            } else {
                1.0
            };
            hi + pad
        })
        .collect()
}

/// The metrics recorded in the tables: the study's and the objectives'.
fn metrics<M: StudyModel>(study: &Study<M>, spec: &ObjectivesSpec) -> Vec<String> {
    let mut metrics = study.metrics.clone();
    for m in spec.metrics() {
        if !metrics.iter().any(|x| x == m) {
            metrics.push(m.to_string());
        }
    }
    metrics
}

/// Writes `evaluations.parquet`, `series.parquet`, `front.parquet`, `pareto.json`,
/// `front.png`, the study file and the provenance into `out`; returns the summary (the
/// contents of `pareto.json`).
pub fn write_results<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: &Path,
    result: &ParetoResult,
    command: &str,
) -> Result<serde_json::Value> {
    let spec = study
        .objectives
        .as_ref()
        .ok_or_else(|| Error::input("the study has no [objectives] table"))?;
    let cols = Columns {
        axes: spec
            .free
            .iter()
            .map(|f| (f.spec.column(), f.spec))
            .collect(),
        metrics: metrics(study, spec),
        series_units: model
            .series_labels()
            .iter()
            .map(|(name, label)| (name.to_string(), records::label_unit(label)))
            .collect(),
    };
    let inputs = records::input_columns(model, study, &cols, &result.records);
    let mut runs = records::runs_table(model.name(), &cols, &inputs, &result.records);
    runs.push_unit(
        "generation",
        C::U64(
            result
                .records
                .iter()
                .map(|r| result.evaluations[r.run.point].generation as u64)
                .collect(),
        ),
        "1",
    );
    write_parquet(&out.join("evaluations.parquet"), &runs)?;
    write_parquet(
        &out.join("series.parquet"),
        &records::series_table(&cols, &result.records),
    )?;
    write_parquet(&out.join("front.parquet"), &front_table(spec, result))?;
    write_atomic(&out.join("study.toml"), study.text.as_bytes())?;
    let mut provenance = records::provenance(model, study, command);
    provenance["metrics"] = serde_json::json!(cols.metrics);
    write_json_atomic(&out.join("provenance.json"), &provenance)?;
    let summary = pareto_json(model, study, spec, result);
    write_json_atomic(&out.join("pareto.json"), &summary)?;
    plot_front(study, spec, result, &out.join("front.png"))?;
    Ok(summary)
}

/// The front: point, generation, parameters (display units), then per metric objective its
/// mean, std and count (a parameter objective is its parameter's column).
fn front_table(spec: &ObjectivesSpec, result: &ParetoResult) -> Table {
    let front: Vec<&Evaluation> = result
        .front
        .iter()
        .map(|&i| &result.evaluations[i])
        .collect();
    let mut t = Table::new()
        .with_unit(
            "point",
            C::U64(result.front.iter().map(|&i| i as u64).collect()),
            "1",
        )
        .with_unit(
            "generation",
            C::U64(front.iter().map(|e| e.generation as u64).collect()),
            "1",
        );
    for (k, f) in spec.free.iter().enumerate() {
        let shown: Vec<Option<Value>> = front
            .iter()
            .map(|e| Some(f.spec.display(&Value::Number(e.values[k]))))
            .collect();
        let (data, unit) = records::value_column(f.spec, &shown);
        match unit {
            Some(unit) => t.push_unit(&f.spec.column(), data, &unit),
            None => t.push(&f.spec.column(), data),
        }
    }
    for (k, o) in spec.objectives.iter().enumerate() {
        let Target::Metric(name) = &o.target else {
            continue;
        };
        let unit = spec.unit(o);
        t.push_unit(
            &format!("{name}_mean"),
            C::OptF64(front.iter().map(|e| e.means[k]).collect()),
            &unit,
        );
        t.push_unit(
            &format!("{name}_std"),
            C::OptF64(front.iter().map(|e| e.stds[k]).collect()),
            &unit,
        );
        t.push_unit(
            &format!("{name}_count"),
            C::U64(front.iter().map(|e| e.counts[k] as u64).collect()),
            "1",
        );
    }
    t
}

fn finite(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// `pareto.json` and `--json`: objectives, parameters, settings, reference, hypervolume (also
/// by generation), the front, the seeds and the version.
pub fn pareto_json<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    spec: &ObjectivesSpec,
    result: &ParetoResult,
) -> serde_json::Value {
    let shown = |s: &ParamSpec, x: f64| finite(s.display(&Value::Number(x)).as_number());
    let front: Vec<serde_json::Value> = result
        .front
        .iter()
        .map(|&i| {
            let e = &result.evaluations[i];
            let parameters: serde_json::Map<String, serde_json::Value> = spec
                .free
                .iter()
                .zip(&e.values)
                .map(|(f, &v)| (f.spec.column(), shown(f.spec, v)))
                .collect();
            let objectives: serde_json::Map<String, serde_json::Value> = spec
                .objectives
                .iter()
                .enumerate()
                .map(|(k, o)| {
                    (
                        o.name.clone(),
                        serde_json::json!({
                            "mean": e.means[k].map(finite),
                            "std": e.stds[k].map(finite),
                        }),
                    )
                })
                .collect();
            serde_json::json!({
                "point": i, "generation": e.generation,
                "parameters": parameters, "objectives": objectives,
            })
        })
        .collect();
    let rejected = result
        .evaluations
        .iter()
        .filter(|e| e.rejected.is_some())
        .count();
    serde_json::json!({
        "study": study.name,
        "model": model.name(),
        "method": "nsga2",
        "objectives": spec.objectives.iter().map(|o| serde_json::json!({
            "name": o.name,
            "goal": if o.maximize { "maximize" } else { "minimize" },
            "column": spec.column(o),
            "unit": spec.unit(o),
            "kind": match o.target { Target::Metric(_) => "metric", Target::Parameter(_) => "parameter" },
        })).collect::<Vec<_>>(),
        "parameters": spec.free.iter().map(|f| serde_json::json!({
            "name": f.spec.name, "column": f.spec.column(),
            "low": shown(f.spec, f.low), "high": shown(f.spec, f.high),
            "scale": if f.log { "log" } else { "linear" },
        })).collect::<Vec<_>>(),
        "population": spec.population,
        "generations": spec.generations,
        "evaluations": result.evaluations.len(),
        "runs": result.records.len(),
        "rejected_points": rejected,
        "reference": result.reference.iter().map(|&x| finite(x)).collect::<Vec<_>>(),
        "reference_rule": if result.reference_given { "given" } else { "nadir + 10 % of the front's range" },
        "hypervolume": finite(result.hypervolume),
        "archive_hypervolume_by_generation": result.hypervolume_by_generation.iter().map(|&x| finite(x)).collect::<Vec<_>>(),
        "front": front,
        "seed": study.seed,
        "seeds": (0..study.replicates).map(|r| study.seed.wrapping_add(r as u64)).collect::<Vec<_>>(),
        "magopt_version": records::VERSION,
    })
}

/// `front.png`: two objectives, every evaluation and the front as a line; three, the three
/// pairwise projections side by side. Free parameters as objectives go on the x axis first.
fn plot_front<M: StudyModel>(
    study: &Study<M>,
    spec: &ObjectivesSpec,
    result: &ParetoResult,
    path: &Path,
) -> Result<()> {
    let mut order: Vec<usize> = (0..spec.objectives.len()).collect();
    order.sort_by_key(|&k| !matches!(spec.objectives[k].target, Target::Parameter(_)));
    let log = |k: usize| match spec.objectives[k].target {
        Target::Parameter(j) => spec.free[j].log,
        Target::Metric(_) => false,
    };
    let figure = |a: usize, b: usize, line: bool| {
        let complete: Vec<&Evaluation> = result
            .evaluations
            .iter()
            .filter(|e| e.means[a].is_some() && e.means[b].is_some())
            .collect();
        let mut front: Vec<(f64, f64)> = result
            .front
            .iter()
            .filter_map(|&i| {
                let e = &result.evaluations[i];
                Some((e.means[a]?, e.means[b]?))
            })
            .collect();
        front.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1)));
        let goal = |k: usize| {
            let o = &spec.objectives[k];
            format!(
                "{}, {}",
                spec.label(o),
                if o.maximize { "maximized" } else { "minimized" }
            )
        };
        Figure {
            title: if line {
                format!(
                    "{}: Pareto front ({} points), hypervolume {:.4e}",
                    study.name,
                    result.front.len(),
                    result.hypervolume
                )
            } else {
                String::new()
            },
            x_label: goal(a),
            y_label: goal(b),
            log_x: log(a),
            log_y: log(b),
            series: vec![
                Series {
                    label: format!("evaluations ({})", complete.len()),
                    x: complete
                        .iter()
                        .map(|e| e.means[a].unwrap_or(f64::NAN))
                        .collect(),
                    y: complete
                        .iter()
                        .map(|e| e.means[b].unwrap_or(f64::NAN))
                        .collect(),
                    y_err: None,
                    style: SeriesStyle::Points,
                },
                Series {
                    label: "Pareto front".into(),
                    x: front.iter().map(|p| p.0).collect(),
                    y: front.iter().map(|p| p.1).collect(),
                    y_err: None,
                    style: if line {
                        SeriesStyle::LinePoints
                    } else {
                        SeriesStyle::Points
                    },
                },
            ],
            ..Figure::default()
        }
    };
    if order.len() == 2 {
        render_png(path, &figure(order[0], order[1], true))
    } else {
        let mut figs = [
            figure(order[0], order[1], false),
            figure(order[0], order[2], false),
            figure(order[1], order[2], false),
        ];
        figs[0].title = format!(
            "{}: {} front points, hypervolume {:.4e}",
            study.name,
            result.front.len(),
            result.hypervolume
        );
        render_png_panels(path, &figs, 2100, 700)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_reference_pads_the_nadir() {
        let front = vec![vec![1.0, 5.0], vec![3.0, 2.0]];
        assert_eq!(default_reference(&front, 2), vec![3.2, 5.3]);
        assert_eq!(default_reference(&[vec![2.0, 0.0]], 2), vec![2.2, 1.0]);
    }
}
