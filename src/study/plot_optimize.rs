//! Figures of an optimization's result directory (part of `magopt plot DIR`):
//! - `history_{metric}.png`: each evaluated point's replicate mean against the evaluation
//!   number, with the best so far (for a Bayesian optimization the posterior optimum after
//!   each round, from `history.parquet`; otherwise the best mean seen);
//! - `optimum_{column}.png` (from `optima.parquet`, an optimization at every grid or design
//!   point): the histogram of the optimum over a design, or the optimum against the first
//!   swept parameter over a grid;
//! - `front.png` (from `pareto.json`, two objectives): the Pareto front.

use std::path::{Path, PathBuf};

use serde_json::Value as J;

use super::plot_design::{histogram_figure, numbers};
use crate::output::plot::{render_png, Figure, Series, SeriesStyle};
use crate::output::table::{read_parquet, Table};
use crate::{Error, Result};

/// Whether `dir` holds an optimization's results (and no sweep summary).
pub fn is_optimization(dir: &Path) -> bool {
    dir.join("optimum.json").is_file() || dir.join("pareto.json").is_file()
}

/// Renders the figures of the optimization result directory `dir` into `out`.
pub fn optimization_figures(dir: &Path, out: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    if dir.join("pareto.json").is_file() {
        let path = out.join("front.png");
        render_png(&path, &front_figure(&read_json(&dir.join("pareto.json"))?)?)?;
        written.push(path);
        return Ok(written);
    }
    let summary = read_json(&dir.join("optimum.json"))?;
    let metric = summary["metric"].as_str().unwrap_or_default().to_string();
    if dir.join("optima.parquet").is_file() {
        let optima = read_parquet(&dir.join("optima.parquet"))?;
        let design = read_json(&dir.join("provenance.json"))?["design"].is_object();
        for column in optimum_columns(&optima, &metric) {
            let path = out.join(format!(
                "optimum_{}.png",
                column.trim_start_matches("optimum_")
            ));
            render_png(&path, &optima_figure(&optima, &column, design))?;
            written.push(path);
        }
        return Ok(written);
    }
    let evaluations = read_parquet(&dir.join("evaluations.parquet"))?;
    let history = dir.join("history.parquet");
    let history = history
        .is_file()
        .then(|| read_parquet(&history))
        .transpose()?;
    let maximize = summary["goal"] == "maximize";
    let path = out.join(format!("history_{metric}.png"));
    let figure = history_figure(&evaluations, history.as_ref(), &metric, maximize);
    render_png(&path, &figure)?;
    written.push(path);
    Ok(written)
}

fn read_json(path: &Path) -> Result<J> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| Error::input(format!("'{}' is not valid: {e}", path.display())))
}

/// Per evaluated point (the runs' `point` column, in order) the mean of its replicates.
fn point_means(evaluations: &Table, metric: &str) -> Vec<f64> {
    let (point, value) = (numbers(evaluations, "point"), numbers(evaluations, metric));
    let n = point.iter().fold(0.0f64, |a, &p| a.max(p + 1.0)) as usize;
    let mut sums = vec![(0.0, 0usize); n];
    for (&p, &v) in point.iter().zip(&value) {
        if p.is_finite() && v.is_finite() {
            sums[p as usize].0 += v;
            sums[p as usize].1 += 1;
        }
    }
    sums.iter()
        .map(|&(s, c)| if c > 0 { s / c as f64 } else { f64::NAN })
        .collect()
}

fn history_figure(evaluations: &Table, history: Option<&Table>, metric: &str, max: bool) -> Figure {
    let means = point_means(evaluations, metric);
    let x: Vec<f64> = (1..=means.len()).map(|k| k as f64).collect();
    let (best, label) = match history {
        Some(h) => (numbers(h, "best"), "posterior optimum after the round"),
        None => {
            let mut best = f64::NAN;
            let running = means
                .iter()
                .map(|&m| {
                    if best.is_nan() || (m.is_finite() && (m > best) == max) {
                        best = m;
                    }
                    best
                })
                .collect();
            (running, "best mean so far")
        }
    };
    // a positive metric spanning a decade or more reads better on a log axis
    let (lo, hi) = means
        .iter()
        .filter(|m| m.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(a, b), &m| (a.min(m), b.max(m)));
    Figure {
        title: format!("{metric}: {} evaluated points", means.len()),
        x_label: "evaluation".into(),
        y_label: metric.into(),
        log_y: lo > 0.0 && hi > 10.0 * lo && best.iter().all(|&b| b > 0.0),
        series: vec![
            Series {
                label: "replicate mean of the point".into(),
                x: x.clone(),
                y: means,
                y_err: None,
                style: SeriesStyle::Points,
            },
            Series {
                label: label.into(),
                x: x[..best.len().min(x.len())].to_vec(),
                y: best[..best.len().min(x.len())].to_vec(),
                y_err: None,
                style: SeriesStyle::Line,
            },
        ],
        ..Figure::default()
    }
}

/// The `optimum_*` columns of `optima.parquet` and the metric at the optimum.
fn optimum_columns(optima: &Table, metric: &str) -> Vec<String> {
    optima
        .columns
        .iter()
        .map(|c| c.name.clone())
        .filter(|n| n.starts_with("optimum_") || n == metric)
        .collect()
}

/// A design: the histogram of the column; a grid: the column against the first swept
/// parameter (the column after `point`).
fn optima_figure(optima: &Table, column: &str, design: bool) -> Figure {
    let y = numbers(optima, column);
    if design {
        return histogram_figure(&y, column, "points of the design per bin");
    }
    let axis = optima.columns.get(1).map_or("point", |c| c.name.as_str());
    Figure {
        title: format!("{column} at each grid point"),
        x_label: axis.into(),
        y_label: column.into(),
        series: vec![Series {
            label: String::new(),
            x: numbers(optima, axis),
            y,
            y_err: None,
            style: SeriesStyle::LinePoints,
        }],
        ..Figure::default()
    }
}

/// The front of two objectives from `pareto.json` (three: the first two), sorted along the
/// first objective.
fn front_figure(pareto: &J) -> Result<Figure> {
    let objectives = pareto["objectives"].as_array().cloned().unwrap_or_default();
    if objectives.len() < 2 {
        return Err(Error::input("pareto.json names fewer than two objectives"));
    }
    let name = |k: usize| {
        objectives[k]["name"]
            .as_str()
            .unwrap_or_default()
            .to_string()
    };
    let axis = |k: usize| {
        let o = &objectives[k];
        format!(
            "{} ({}), {}d",
            o["column"].as_str().unwrap_or_default(),
            o["unit"].as_str().unwrap_or("1"),
            o["goal"].as_str().unwrap_or_default()
        )
    };
    let mut points: Vec<(f64, f64)> = pareto["front"]
        .as_array()
        .map(|f| {
            f.iter()
                .filter_map(|p| {
                    let mean = |k: usize| p["objectives"][name(k)]["mean"].as_f64();
                    Some((mean(0)?, mean(1)?))
                })
                .collect()
        })
        .unwrap_or_default();
    points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    Ok(Figure {
        title: format!(
            "{}: Pareto front ({} points), hypervolume {:.4e}",
            pareto["study"].as_str().unwrap_or_default(),
            points.len(),
            pareto["hypervolume"].as_f64().unwrap_or(f64::NAN)
        ),
        x_label: axis(0),
        y_label: axis(1),
        series: vec![Series {
            label: "Pareto front".into(),
            x: points.iter().map(|p| p.0).collect(),
            y: points.iter().map(|p| p.1).collect(),
            y_err: None,
            style: SeriesStyle::LinePoints,
        }],
        ..Figure::default()
    })
}
