//! `[optimize]` beside `[sweep]` or `[design]`: the optimum at every point of the grid or the
//! design. A grid gives the optimum as a function of the swept parameters (the optimal field
//! at each friction); a design of uncertain inputs gives the distribution of the optimum (the
//! optimal field over sampled anisotropy constants) — uncertainty propagated through an
//! optimization, not only through a metric.
//!
//! Each point's optimization is the study's `[optimize]` from the study's base with the
//! point's values set; the points run one after another (each optimization runs its own
//! replicates and batches in parallel), every run is saved like a sweep's, and the run ids
//! cover the point's values, so an interrupted study resumes point by point.

use std::path::Path;

use super::model::{ParamSpec, StudyModel, Value};
use super::optimize::{lock, optimize_at, shard_key, Place, StudyOptimum};
use super::optimize_shard::ShardWait;
use super::records::{metric_unit, param_unit, value_column};
use super::sensitivity_tables::push_descriptions;
use super::spec::Study;
use crate::numerics::stats::describe;
use crate::output::table::{ColumnData as C, Table};
use crate::{Error, Result};

/// The optimization at one grid or design point.
#[derive(Debug, Clone)]
pub struct PointOptimum {
    /// The point's values (`study.axes` order).
    pub values: Vec<Value>,
    /// Its optimum, or why it has none (no evaluated point gave the metric on every
    /// replicate).
    pub optimum: std::result::Result<StudyOptimum, String>,
}

impl PointOptimum {
    /// The optimum, if the point has one.
    fn found(&self) -> Option<&StudyOptimum> {
        self.optimum.as_ref().ok()
    }
}

/// Runs the study's optimization at every point of its grid or design (all points' parameters
/// are checked before any run starts). A point without an optimum is recorded with its reason
/// and the study goes on; errors are input or file errors.
pub fn optimize_points<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    tick: &(dyn Fn() + Sync),
    shard: Option<ShardWait>,
) -> Result<Vec<PointOptimum>> {
    let points = study.points();
    let bases = points
        .iter()
        .map(|values| study.params_at(model, values))
        .collect::<Result<Vec<_>>>()?;
    let _lock = lock(out, shard, &shard_key(model, study))?;
    let mut offset = 0;
    let mut found = Vec::with_capacity(points.len());
    for (values, base) in points.into_iter().zip(bases) {
        let at = study.at(base);
        let place = Place {
            values: values.clone(),
            offset,
        };
        let optimum = match optimize_at(model, &at, out, tick, &place, shard) {
            Ok(o) if o.value.is_finite() => Ok(o),
            Ok(_) => Err(no_value(study)),
            Err(Error::Output(reason)) => Err(reason),
            Err(e) => return Err(e),
        };
        offset += optimum.as_ref().map_or(0, |o| o.evaluations.len());
        found.push(PointOptimum { values, optimum });
    }
    Ok(found)
}

fn no_value<M: StudyModel>(study: &Study<M>) -> String {
    let metric = study.optimize.as_ref().map_or("", |o| o.metric.as_str());
    format!("no evaluated point gave {metric} on every replicate")
}

/// The optimum's free parameters in display units, per point (None without an optimum).
fn optimum_column(points: &[PointOptimum], spec: &ParamSpec, k: usize) -> Vec<Option<f64>> {
    points
        .iter()
        .map(|p| {
            p.found()
                .map(|o| spec.display(&Value::Number(o.best[k])).as_number())
        })
        .collect()
}

/// The metric at each point's optimum (None without an optimum).
fn value_at_optimum(points: &[PointOptimum]) -> Vec<Option<f64>> {
    points.iter().map(|p| p.found().map(|o| o.value)).collect()
}

/// One free parameter's optimum standard error from the replicate optima, per point, in
/// display units (None without an optimum or a finite error).
fn uncertainty_column(points: &[PointOptimum], spec: &ParamSpec) -> Vec<Option<f64>> {
    let shown = |x: f64| spec.display(&Value::Number(x)).as_number();
    points
        .iter()
        .map(|p| {
            let o = p.found()?.one_dimensional.as_ref()?;
            Some(shown(o.x + o.uncertainty) - shown(o.x)).filter(|u| u.is_finite())
        })
        .collect()
}

/// The free parameters' names, specs and display columns of the optimum.
fn free_specs<M: StudyModel>(study: &Study<M>) -> Vec<&'static ParamSpec> {
    study
        .optimize
        .as_ref()
        .map_or_else(Vec::new, |o| o.free.iter().map(|(s, ..)| *s).collect())
}

/// `optima.parquet`: one row per grid or design point: its values, the optimum's free
/// parameters (`optimum_<column>`), the metric there, for one free parameter the optimum's
/// standard error from the replicate optima (`uncertainty_<column>`), the points evaluated,
/// and the reason of a point without an optimum.
pub fn optima_table<M: StudyModel>(study: &Study<M>, points: &[PointOptimum]) -> Table {
    let mut t = Table::new().with("point", C::I64((0..points.len() as i64).collect()));
    for (k, axis) in study.axes.iter().enumerate() {
        let values: Vec<Option<Value>> = points
            .iter()
            .map(|p| Some(axis.spec.display(&p.values[k])))
            .collect();
        match value_column(axis.spec, &values) {
            (data, Some(unit)) => t.push_unit(&axis.spec.column(), data, &unit),
            (data, None) => t.push(&axis.spec.column(), data),
        }
    }
    let free = free_specs(study);
    for (k, s) in free.iter().enumerate() {
        let unit = param_unit(s).unwrap_or_else(|| "1".into());
        let name = format!("optimum_{}", s.column());
        t.push_unit(&name, C::OptF64(optimum_column(points, s, k)), &unit);
    }
    let metric = study.optimize.as_ref().map_or("", |o| o.metric.as_str());
    t.push_unit(
        metric,
        C::OptF64(value_at_optimum(points)),
        metric_unit(metric),
    );
    if let [s] = free[..] {
        let unit = param_unit(s).unwrap_or_else(|| "1".into());
        let se = uncertainty_column(points, s);
        t.push_unit(&format!("uncertainty_{}", s.column()), C::OptF64(se), &unit);
    }
    let evaluations = points
        .iter()
        .map(|p| p.found().map_or(0, |o| o.evaluations.len() as i64))
        .collect();
    t.push("evaluations", C::I64(evaluations));
    let reason = points.iter().map(|p| p.optimum.clone().err()).collect();
    t.push("reason", C::OptStr(reason));
    t
}

/// One quantity of the optimum's distribution.
struct Quantity {
    name: String,
    unit: String,
    values: Vec<f64>,
    /// The root-mean-square of the points' replicate-optima standard errors (one free
    /// parameter).
    replicate_se: Option<f64>,
}

fn quantities<M: StudyModel>(study: &Study<M>, points: &[PointOptimum]) -> Vec<Quantity> {
    let free = free_specs(study);
    let present = |v: Vec<Option<f64>>| v.into_iter().flatten().collect::<Vec<f64>>();
    let mut q: Vec<Quantity> = free
        .iter()
        .enumerate()
        .map(|(k, s)| {
            // replicate optima give a standard error for one free parameter only
            let se = match free.len() {
                1 => present(uncertainty_column(points, s)),
                _ => Vec::new(),
            };
            Quantity {
                name: format!("optimum_{}", s.column()),
                unit: param_unit(s).unwrap_or_else(|| "1".into()),
                values: present(optimum_column(points, s, k)),
                replicate_se: (!se.is_empty()).then(|| describe_rms(&se)),
            }
        })
        .collect();
    let metric = study.optimize.as_ref().map_or("", |o| o.metric.as_str());
    q.push(Quantity {
        name: metric.to_string(),
        unit: metric_unit(metric).to_string(),
        values: present(value_at_optimum(points)),
        replicate_se: None,
    });
    q
}

fn describe_rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// `optimum_distribution.parquet`: per free parameter of the optimum and for the metric
/// there, over the points with an optimum: count, mean, standard deviation, 5–95 %
/// quantiles, and for one free parameter `replicate_se`, the root-mean-square of the points'
/// standard errors from their replicate optima: the part of the spread that is replicate noise
/// rather than the inputs' (the inputs' share is √(std² − replicate_se²) when the two are
/// independent). It does not include the objective's own resolution (τ is read off a sampled
/// A(t)), which a deterministic objective still has.
pub fn optimum_distribution_table<M: StudyModel>(
    study: &Study<M>,
    points: &[PointOptimum],
) -> Table {
    let q = quantities(study, points);
    let d: Vec<_> = q.iter().map(|q| describe(&q.values)).collect();
    let mut t = Table::new()
        .with(
            "quantity",
            C::Str(q.iter().map(|q| q.name.clone()).collect()),
        )
        .with("unit", C::Str(q.iter().map(|q| q.unit.clone()).collect()));
    push_descriptions(&mut t, &d);
    t.push(
        "replicate_se",
        C::OptF64(q.iter().map(|q| q.replicate_se).collect()),
    );
    t
}

/// One line per quantity of [`optimum_distribution_table`] for the terminal.
pub fn distribution_lines<M: StudyModel>(study: &Study<M>, points: &[PointOptimum]) -> Vec<String> {
    quantities(study, points)
        .iter()
        .map(|q| {
            let d = describe(&q.values);
            let noise = q.replicate_se.map_or(String::new(), |e| {
                format!("; replicate standard error ±{e:.4}")
            });
            format!(
                "{} ({}): {:.4} ± {:.4} (n = {}; 5–95 % {:.4}–{:.4}){noise}",
                q.name, q.unit, d.mean, d.std, d.n, d.quantiles[0], d.quantiles[4]
            )
        })
        .collect()
}

/// Writes the results of [`optimize_points`] into `dir`: `evaluations.parquet` (every run,
/// with its point's values and the free parameters), `series.parquet`, the study file and the
/// provenance, `optima.parquet`, `optimum_distribution.parquet` and `optimum.json` (the
/// optimum per point and the distribution, as JSON); returns that JSON.
pub fn write_results<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    dir: &Path,
    points: &[PointOptimum],
    command: &str,
) -> Result<serde_json::Value> {
    let records: Vec<_> = points
        .iter()
        .filter_map(PointOptimum::found)
        .flat_map(|o| o.records.iter().cloned())
        .collect();
    super::records::write_optimize_results(model, study, dir, &records, command)?;
    let optima = optima_table(study, points);
    crate::output::table::write_parquet(&dir.join("optima.parquet"), &optima)?;
    let distribution = optimum_distribution_table(study, points);
    let path = dir.join("optimum_distribution.parquet");
    crate::output::table::write_parquet(&path, &distribution)?;
    let summary = serde_json::json!({
        "study": study.name,
        "model": model.name(),
        "metric": study.optimize.as_ref().map(|o| o.metric.clone()),
        "method": study.optimize.as_ref().map(|o| o.method.name()),
        "points": points.len(),
        "with_optimum": points.iter().filter(|p| p.found().is_some()).count(),
        "optima": optima.to_json_rows(),
        "distribution": distribution.to_json_rows(),
        "seeds": (0..study.replicates).map(|r| study.seed.wrapping_add(r as u64)).collect::<Vec<_>>(),
        "magopt_version": super::records::VERSION,
    });
    crate::output::atomic::write_json_atomic(&dir.join("optimum.json"), &summary)?;
    Ok(summary)
}
