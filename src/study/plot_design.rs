//! Figures of a design study (part of `magopt plot DIR`):
//! - `sensitivity_{metric}.png`: Sobol' first-order and total indices per parameter with their
//!   bootstrap intervals (x = parameter number, named in the legend), or for Morris designs
//!   the μ*–σ plane (one point per parameter);
//! - `distribution_{metric}.png`: the histogram of the metric over the design's successful runs
//!   (the propagated uncertainty when the inputs are uncertain).

use std::path::{Path, PathBuf};

use crate::output::plot::{render_png, Figure, Series, SeriesStyle};
use crate::output::table::{read_parquet, ColumnData, Table};
use crate::Result;

/// Renders the design figures of the result directory `dir` into `out`.
pub fn design_figures(dir: &Path, out: &Path, metrics: &[String]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let sensitivity = dir.join("sensitivity.parquet");
    if sensitivity.is_file() {
        let t = read_parquet(&sensitivity)?;
        for metric in metrics {
            let path = out.join(format!("sensitivity_{metric}.png"));
            render_png(&path, &sensitivity_figure(&t, metric))?;
            written.push(path);
        }
    }
    let runs = read_parquet(&dir.join("runs.parquet"))?;
    for metric in metrics {
        let path = out.join(format!("distribution_{metric}.png"));
        render_png(&path, &histogram(&runs, metric))?;
        written.push(path);
    }
    Ok(written)
}

fn strings<'a>(t: &'a Table, name: &str) -> &'a [String] {
    match t.column(name) {
        Some(ColumnData::Str(v)) => v,
        _ => &[],
    }
}

/// The column as numbers (NaN for null or a missing column).
pub(crate) fn numbers(t: &Table, name: &str) -> Vec<f64> {
    match t.column(name) {
        Some(ColumnData::OptF64(v)) => v.iter().map(|x| x.unwrap_or(f64::NAN)).collect(),
        Some(ColumnData::F64(v)) => v.clone(),
        Some(ColumnData::OptI64(v)) => v.iter().map(|x| x.map_or(f64::NAN, |x| x as f64)).collect(),
        Some(ColumnData::I64(v)) => v.iter().map(|x| *x as f64).collect(),
        Some(ColumnData::U64(v)) => v.iter().map(|x| *x as f64).collect(),
        _ => vec![f64::NAN; t.n_rows()],
    }
}

fn sensitivity_figure(t: &Table, metric: &str) -> Figure {
    let rows: Vec<usize> = (0..t.n_rows())
        .filter(|&r| strings(t, "metric")[r] == metric)
        .collect();
    let names: Vec<String> = rows
        .iter()
        .enumerate()
        .map(|(k, &r)| format!("{} = {}", k + 1, strings(t, "parameter")[r]))
        .collect();
    if t.column("mu_star").is_some() {
        let (mu_star, sigma) = (numbers(t, "mu_star"), numbers(t, "sigma"));
        let series = rows
            .iter()
            .zip(&names)
            .map(|(&r, name)| Series {
                label: name.clone(),
                x: vec![mu_star[r]],
                y: vec![sigma[r]],
                y_err: None,
                style: SeriesStyle::Points,
            })
            .collect();
        return Figure {
            title: format!("Morris elementary effects of {metric}"),
            x_label: "μ* (mean |elementary effect|)".into(),
            y_label: "σ (spread of the elementary effects)".into(),
            series,
            ..Figure::default()
        };
    }
    let mut series = Vec::new();
    for (k, (key, shift)) in [("first", -0.1), ("total", 0.1)].iter().enumerate() {
        let (value, low, high) = (
            numbers(t, key),
            numbers(t, &format!("{key}_low")),
            numbers(t, &format!("{key}_high")),
        );
        let x: Vec<f64> = (1..=rows.len()).map(|i| i as f64 + shift).collect();
        let label = ["first-order S_i", "total S_Ti"][k];
        series.push(Series {
            label: format!("{label} (95 % bootstrap interval as bars)"),
            x: x.clone(),
            y: rows.iter().map(|&r| value[r]).collect(),
            y_err: None,
            style: SeriesStyle::Points,
        });
        for (i, &r) in rows.iter().enumerate() {
            series.push(Series {
                label: String::new(),
                x: vec![x[i], x[i]],
                y: vec![low[r], high[r]],
                y_err: None,
                style: SeriesStyle::Line,
            });
        }
    }
    Figure {
        title: format!("Sobol' indices of {metric}"),
        x_label: format!("parameter: {}", names.join(", ")),
        y_label: "share of the variance".into(),
        series,
        h_lines: vec![(0.0, String::new())],
        ..Figure::default()
    }
}

/// Histogram of a metric over the successful runs.
fn histogram(runs: &Table, metric: &str) -> Figure {
    let ok = strings(runs, "status");
    let v: Vec<f64> = numbers(runs, metric)
        .into_iter()
        .enumerate()
        .filter(|(r, _)| ok.get(*r).is_none_or(|s| s == "ok"))
        .map(|(_, x)| x)
        .collect();
    histogram_figure(&v, metric, "runs per bin")
}

/// Histogram of the finite values (√n bins, at least 5) as a step line, titled by their count.
pub(crate) fn histogram_figure(values: &[f64], label: &str, y_label: &str) -> Figure {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let bins = ((v.len() as f64).sqrt().ceil() as usize).max(5);
    let width = if hi > lo {
        (hi - lo) / bins as f64
    } else {
        1.0
    };
    let mut counts = vec![0usize; bins];
    for x in &v {
        counts[(((x - lo) / width) as usize).min(bins - 1)] += 1;
    }
    let (mut x, mut y) = (vec![lo], vec![0.0]);
    for (k, c) in counts.iter().enumerate() {
        let left = lo + k as f64 * width;
        x.extend([left, left + width]);
        y.extend([*c as f64, *c as f64]);
    }
    x.push(lo + bins as f64 * width);
    y.push(0.0);
    Figure {
        title: format!("{label}: {} values", v.len()),
        x_label: label.into(),
        y_label: y_label.into(),
        series: vec![Series {
            label: String::new(),
            x,
            y,
            y_err: None,
            style: SeriesStyle::Line,
        }],
        ..Figure::default()
    }
}
