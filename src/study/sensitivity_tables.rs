//! What a design study adds to its tables once its runs are in: `sensitivity.parquet` (Sobol'
//! indices with bootstrap intervals, or Morris μ, μ*, σ, per metric and parameter, with the
//! share of the metric's variance that is replicate noise) and `distribution.parquet` (mean,
//! std and quantiles of every metric over the design's runs: the propagated uncertainty when
//! the design samples uncertain inputs).
//!
//! The estimators use the replicate mean of each point; a point without a value (its runs
//! failed or did not reach the metric) leaves the indices of that metric null and says so in
//! `note`.

use super::design::sensitivity::{morris_effects, replicate_variance, sobol_indices};
use super::design_spec::{Design, DesignKind};
use super::records::RunRecord;
use crate::numerics::stats::{describe, Description};
use crate::output::table::{ColumnData as C, Table};

/// Confidence level of the Sobol' intervals.
const CONFIDENCE: f64 = 0.95;

/// The values of `metric` per point (replicates in seed order; NaN where a run has none).
fn by_point(records: &[RunRecord], metric: &str, points: usize) -> Vec<Vec<f64>> {
    let mut y = vec![Vec::new(); points];
    for r in records {
        let v = r.result.metric(metric).filter(|_| r.result.status.is_ok());
        y[r.run.point].push(v.unwrap_or(f64::NAN));
    }
    y
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// One (metric, parameter) row of the sensitivity table.
struct Row {
    metric: String,
    parameter: String,
    /// The measures, in the order of the table's columns (None: not available).
    values: Vec<Option<f64>>,
    noise: Option<f64>,
    note: Option<String>,
}

/// One row per (metric, parameter): the design's sensitivity measures. None for designs that
/// are not for sensitivity (lhs, sobol, halton, random).
pub fn sensitivity_table(
    design: &Design,
    metrics: &[String],
    records: &[RunRecord],
    seed: u64,
) -> Option<Table> {
    let dims = design.axes.len();
    let names = [
        "first",
        "first_low",
        "first_high",
        "total",
        "total_low",
        "total_high",
    ];
    let names = match design.kind {
        DesignKind::Saltelli => names.to_vec(),
        DesignKind::Morris { .. } => vec!["mu", "mu_star", "sigma", "mu_star_ci95"],
        DesignKind::Sample(_) => return None,
    };
    let mut rows: Vec<Row> = Vec::new();
    for metric in metrics {
        let y = by_point(records, metric, design.points.len());
        let noise = Some(replicate_variance(&y).share).filter(|s| s.is_finite());
        let means: Vec<f64> = y.iter().map(|g| mean(g)).collect();
        let missing = means.iter().filter(|m| !m.is_finite()).count();
        let values: Vec<Vec<f64>> = if missing > 0 {
            vec![vec![f64::NAN; names.len()]; dims]
        } else {
            measures(design, &means, seed)
        };
        let note = (missing > 0).then(|| format!("{missing} points without a value"));
        for (axis, v) in design.axes.iter().zip(values) {
            let v = v
                .into_iter()
                .map(|x| Some(x).filter(|x| x.is_finite()))
                .collect();
            rows.push(Row {
                metric: metric.clone(),
                parameter: axis.spec.name.to_string(),
                values: v,
                noise,
                note: note.clone(),
            });
        }
    }
    let mut t = Table::new()
        .with(
            "metric",
            C::Str(rows.iter().map(|r| r.metric.clone()).collect()),
        )
        .with(
            "parameter",
            C::Str(rows.iter().map(|r| r.parameter.clone()).collect()),
        )
        .with("method", C::Str(vec![design.kind.name(); rows.len()]));
    for (k, name) in names.iter().enumerate() {
        t.push_unit(
            name,
            C::OptF64(rows.iter().map(|r| r.values[k]).collect()),
            unit_of(design),
        );
    }
    t.push_unit(
        "replicate_noise_share",
        C::OptF64(rows.iter().map(|r| r.noise).collect()),
        "1",
    );
    t.push(
        "note",
        C::OptStr(rows.iter().map(|r| r.note.clone()).collect()),
    );
    Some(t)
}

/// Sobol' indices are fractions of the variance; Morris effects are in the metric's unit per
/// unit-cube coordinate, stated as such.
fn unit_of(design: &Design) -> &'static str {
    match design.kind {
        DesignKind::Morris { .. } => "metric unit per unit of the parameter's [0, 1] coordinate",
        _ => "1",
    }
}

/// The measures per parameter, in the order of the table's columns.
fn measures(design: &Design, y: &[f64], seed: u64) -> Vec<Vec<f64>> {
    let dims = design.axes.len();
    match design.kind {
        DesignKind::Saltelli => {
            let s = sobol_indices(y, design.samples, dims, design.bootstrap, seed, CONFIDENCE);
            (0..dims)
                .map(|i| {
                    let (f, t) = (s.first_ci[i], s.total_ci[i]);
                    vec![s.first[i], f[0], f[1], s.total[i], t[0], t[1]]
                })
                .collect()
        }
        DesignKind::Morris { .. } => morris_effects(&design.unit, y, dims)
            .into_iter()
            .map(|e| vec![e.mu, e.mu_star, e.sigma, e.mu_star_ci])
            .collect(),
        DesignKind::Sample(_) => Vec::new(),
    }
}

/// One row per metric: how it is distributed over all successful runs of the design (with
/// uncertain inputs: the propagated uncertainty).
pub fn distribution_table(metrics: &[String], records: &[RunRecord]) -> Table {
    let d: Vec<_> = metrics
        .iter()
        .map(|m| {
            let v: Vec<f64> = records
                .iter()
                .filter(|r| r.result.status.is_ok())
                .filter_map(|r| r.result.metric(m))
                .collect();
            describe(&v)
        })
        .collect();
    let mut t = Table::new().with("metric", C::Str(metrics.to_vec()));
    push_descriptions(&mut t, &d);
    t
}

/// Appends the columns count, mean, std and q05–q95 of one description per row (null where
/// a statistic is not finite).
pub fn push_descriptions(t: &mut Table, d: &[Description]) {
    let opt = |x: f64| Some(x).filter(|x| x.is_finite());
    t.push("count", C::I64(d.iter().map(|d| d.n as i64).collect()));
    t.push("mean", C::OptF64(d.iter().map(|d| opt(d.mean)).collect()));
    t.push("std", C::OptF64(d.iter().map(|d| opt(d.std)).collect()));
    for (k, p) in ["q05", "q25", "q50", "q75", "q95"].iter().enumerate() {
        t.push(
            p,
            C::OptF64(d.iter().map(|d| opt(d.quantiles[k])).collect()),
        );
    }
}

/// Text of a column at row `i` (numbers with 3 significant digits, "–" for null).
fn cell(t: &Table, name: &str, i: usize) -> String {
    match t.column(name) {
        Some(C::Str(v)) => v[i].clone(),
        Some(C::OptF64(v)) => v[i].map_or("–".into(), |x| format!("{x:.3}")),
        Some(C::F64(v)) => format!("{:.4}", v[i]),
        Some(C::I64(v)) => v[i].to_string(),
        _ => "–".into(),
    }
}

/// One line per (metric, parameter) of a `sensitivity.parquet` table.
pub fn sensitivity_lines(t: &Table) -> Vec<String> {
    let morris = t.column("mu_star").is_some();
    (0..t.n_rows())
        .map(|i| {
            let c = |n: &str| cell(t, n, i);
            let head = format!("{:>24} {:>16}", c("metric"), c("parameter"));
            if morris {
                format!(
                    "{head}  μ* {} ± {}  μ {}  σ {}",
                    c("mu_star"),
                    c("mu_star_ci95"),
                    c("mu"),
                    c("sigma")
                )
            } else {
                format!(
                    "{head}  S1 {} [{}, {}]  ST {} [{}, {}]  replicate noise {}",
                    c("first"),
                    c("first_low"),
                    c("first_high"),
                    c("total"),
                    c("total_low"),
                    c("total_high"),
                    c("replicate_noise_share")
                )
            }
        })
        .collect()
}

/// One line per metric of a `distribution.parquet` table.
pub fn distribution_lines(t: &Table) -> Vec<String> {
    (0..t.n_rows())
        .map(|i| {
            let c = |n: &str| cell(t, n, i);
            format!(
                "{:>24}  n {}  mean {}  std {}  5–50–95 % {} {} {}",
                c("metric"),
                c("count"),
                c("mean"),
                c("std"),
                c("q05"),
                c("q50"),
                c("q95")
            )
        })
        .collect()
}
