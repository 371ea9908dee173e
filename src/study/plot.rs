//! Standard figures of a study result directory (the backend of `magopt plot DIR`).
//!
//! Reads `provenance.json`, `summary.parquet` and (if present) `series.parquet` as written
//! by the study runner and renders PNGs into `DIR/plots/`:
//! - `{metric}_vs_{param}.png`: the metric's mean ± standard deviation against the first
//!   numeric swept parameter, one line per combination of the other swept parameters; with
//!   two or more numeric swept parameters also against the second one (roles swapped);
//! - `series_{observable}.png`: the time series of every run, one colour per grid point
//!   (at most [`MAX_SERIES_POINTS`] evenly chosen points).
//!
//! Text-valued swept parameters only ever label lines, never form an x axis. A design study
//! adds its sensitivity and distribution figures (`plot_design`); an optimization's directory
//! (`optimum.json` or `pareto.json`, no summary) gets its history, optima or front
//! (`plot_optimize`).

use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::output::plot::{render_png, Figure, Series, SeriesStyle};
use crate::output::table::{read_parquet, ColumnData, Table};
use crate::{Error, Result};

/// Most grid points drawn in one time-series figure. Equal to the size of the figure
/// palette, so that every drawn point keeps its own colour.
pub const MAX_SERIES_POINTS: usize = 10;

/// One swept parameter, as recorded in `provenance.json`.
#[derive(Debug, Clone, Deserialize)]
struct SweptParam {
    name: String,
    column: String,
    #[serde(default)]
    label: String,
    #[serde(default)]
    log: bool,
}

impl SweptParam {
    /// Axis/legend label: the recorded label, or the name if the label is empty.
    fn display(&self) -> &str {
        if self.label.is_empty() {
            &self.name
        } else {
            &self.label
        }
    }
}

/// The parts of `provenance.json` the figures need (other keys are ignored).
#[derive(Debug, Clone, Deserialize)]
struct Provenance {
    #[serde(default)]
    study: String,
    #[serde(default)]
    metrics: Vec<String>,
    #[serde(default)]
    swept: Vec<SweptParam>,
    #[serde(default)]
    series_label: Option<BTreeMap<String, String>>,
    /// The design's method, samples and points, for a design study.
    #[serde(default)]
    design: Option<serde_json::Value>,
}

/// The values of one swept parameter in the rows of a table.
#[derive(Debug, Clone)]
enum ParamValues {
    /// Numeric: may serve as an x axis.
    Num(Vec<f64>),
    /// Text (or boolean): only labels lines.
    Text(Vec<String>),
}

impl ParamValues {
    /// The value of row `r` as legend text.
    fn text(&self, r: usize) -> String {
        match self {
            ParamValues::Num(v) => fmt_num(v[r]),
            ParamValues::Text(v) => v[r].clone(),
        }
    }

    /// Orders two rows by this parameter (numbers by value, text alphabetically).
    fn cmp_rows(&self, a: usize, b: usize) -> Ordering {
        match self {
            ParamValues::Num(v) => v[a].total_cmp(&v[b]),
            ParamValues::Text(v) => v[a].cmp(&v[b]),
        }
    }
}

/// A loaded study result directory.
struct Study {
    prov: Provenance,
    /// Study name for titles (the provenance's, else the directory's name).
    name: String,
    summary: Table,
    /// The swept parameters' values in the summary rows, in `prov.swept` order.
    params: Vec<ParamValues>,
    summary_path: PathBuf,
}

/// Renders the standard figures of a study result directory into DIR/plots/ and returns the
/// written paths.
///
/// # Errors
/// [`Error::Input`] if `dir` holds no `summary.parquet` or `provenance.json`, the
/// provenance is not valid JSON of the expected shape, or a column it announces is missing;
/// [`Error::Io`] / [`Error::Output`] if a file cannot be read or a figure cannot be written.
pub fn plot_study(dir: &Path) -> Result<Vec<PathBuf>> {
    let out = dir.join("plots");
    if !dir.join("summary.parquet").is_file() && super::plot_optimize::is_optimization(dir) {
        std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
        return super::plot_optimize::optimization_figures(dir, &out);
    }
    let study = load_study(dir)?;
    std::fs::create_dir_all(&out).map_err(|e| Error::io(&out, e))?;
    let mut written = metric_figures(&study, &out)?;
    if study.prov.design.is_some() {
        written.extend(super::plot_design::design_figures(
            dir,
            &out,
            &study.prov.metrics,
        )?);
    }
    let series_path = dir.join("series.parquet");
    // Series are optional: a study may have recorded only scalar metrics.
    if series_path.is_file() {
        let series = read_parquet(&series_path)?;
        written.extend(series_figures(&study, &series, &series_path, &out)?);
    }
    Ok(written)
}

/// Reads the provenance and the summary table, checking the swept parameters' columns.
fn load_study(dir: &Path) -> Result<Study> {
    let summary_path = dir.join("summary.parquet");
    if !summary_path.is_file() {
        return Err(Error::input(format!(
            "'{}' is not a study result directory (no summary.parquet; run `magopt sweep` or \
             `magopt collect` first)",
            dir.display()
        )));
    }
    let prov = read_provenance(dir)?;
    let summary = read_parquet(&summary_path)?;
    let params = prov
        .swept
        .iter()
        .map(|p| param_values(&summary, &summary_path, &p.column))
        .collect::<Result<Vec<_>>>()?;
    let name = if prov.study.is_empty() {
        dir.file_name()
            .map_or_else(|| "study".to_string(), |n| n.to_string_lossy().into_owned())
    } else {
        prov.study.clone()
    };
    Ok(Study {
        prov,
        name,
        summary,
        params,
        summary_path,
    })
}

/// Parses `DIR/provenance.json`.
fn read_provenance(dir: &Path) -> Result<Provenance> {
    let path = dir.join("provenance.json");
    if !path.is_file() {
        return Err(Error::input(format!(
            "'{}' is not a complete study result directory (no provenance.json)",
            dir.display()
        )));
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| Error::input(format!("'{}' is not valid: {e}", path.display())))
}

/// The error for a column the provenance announces but the table lacks or mistypes.
fn column_error(file: &Path, column: &str, what: &str) -> Error {
    Error::input(format!(
        "'{}': column '{column}' {what}; the file does not match its provenance.json",
        file.display()
    ))
}

/// The column `name` as floats (integers converted, missing values as NaN).
fn numeric_column(table: &Table, file: &Path, name: &str) -> Result<Vec<f64>> {
    match table.column(name) {
        Some(ColumnData::F64(v)) => Ok(v.clone()),
        Some(ColumnData::OptF64(v)) => Ok(v.iter().map(|x| x.unwrap_or(f64::NAN)).collect()),
        Some(ColumnData::I64(v)) => Ok(v.iter().map(|x| *x as f64).collect()),
        Some(ColumnData::OptI64(v)) => {
            Ok(v.iter().map(|x| x.map_or(f64::NAN, |x| x as f64)).collect())
        }
        Some(ColumnData::U64(v)) => Ok(v.iter().map(|x| *x as f64).collect()),
        Some(other) => Err(column_error(
            file,
            name,
            &format!("is {} but must be numeric", other.kind()),
        )),
        None => Err(column_error(file, name, "is missing")),
    }
}

/// The column `name` as unsigned integers (ids and indices).
fn id_column(table: &Table, file: &Path, name: &str) -> Result<Vec<u64>> {
    match table.column(name) {
        Some(ColumnData::U64(v)) => Ok(v.clone()),
        Some(ColumnData::I64(v)) => Ok(v.iter().map(|x| (*x).max(0) as u64).collect()),
        Some(other) => Err(column_error(
            file,
            name,
            &format!("is {} but must be an integer", other.kind()),
        )),
        None => Err(column_error(file, name, "is missing")),
    }
}

/// The column `name` as text (only string columns qualify).
fn text_column<'a>(table: &'a Table, file: &Path, name: &str) -> Result<&'a [String]> {
    match table.column(name) {
        Some(ColumnData::Str(v)) => Ok(v),
        Some(other) => Err(column_error(
            file,
            name,
            &format!("is {} but must be text", other.kind()),
        )),
        None => Err(column_error(file, name, "is missing")),
    }
}

/// A swept parameter's column: numeric unless stored as text or booleans.
fn param_values(table: &Table, file: &Path, column: &str) -> Result<ParamValues> {
    match table.column(column) {
        Some(ColumnData::Str(v)) => Ok(ParamValues::Text(v.clone())),
        Some(ColumnData::Bool(v)) => Ok(ParamValues::Text(
            v.iter().map(ToString::to_string).collect(),
        )),
        _ => numeric_column(table, file, column).map(ParamValues::Num),
    }
}

/// Compact legend text for a parameter value: six significant digits at most (hides
/// round-off from unit conversions such as 0.30000000000000004), exponent form outside
/// 1e-4..1e6.
fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let rounded: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    let a = rounded.abs();
    if a == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}

/// File-name-safe version of `s`: anything but letters, digits, '_', '-' and '.' becomes '_'.
fn safe_name(s: &str) -> String {
    let cleaned: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if cleaned.is_empty() {
        "unnamed".to_string()
    } else {
        cleaned
    }
}

/// Y-axis label of a metric: its name plus the unit its suffix announces, if any.
fn metric_axis_label(metric: &str) -> String {
    let unit = [("_s", "s"), ("_N", "N"), ("_m", "m")]
        .iter()
        .find(|(suffix, _)| metric.ends_with(suffix))
        .map(|(_, unit)| *unit);
    match unit {
        Some(u) => format!("{metric} ({u})"),
        None => metric.to_string(),
    }
}

/// Legend text of summary row `r` for the parameters `which`: "label = value, …".
fn params_label(study: &Study, which: &[usize], r: usize) -> String {
    which
        .iter()
        .map(|&j| {
            let p = &study.prov.swept[j];
            format!("{} = {}", p.display(), study.params[j].text(r))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// All `{metric}_vs_{param}.png` figures: per metric, against the first numeric swept
/// parameter and, if there is one, the second.
fn metric_figures(study: &Study, out: &Path) -> Result<Vec<PathBuf>> {
    let numeric: Vec<usize> = (0..study.params.len())
        .filter(|&j| matches!(study.params[j], ParamValues::Num(_)))
        .collect();
    let mut written = Vec::new();
    for metric in &study.prov.metrics {
        for &x in numeric.iter().take(2) {
            let fig = metric_figure(study, metric, x)?;
            let file = format!("{metric}_vs_{}.png", study.prov.swept[x].name);
            let path = out.join(safe_name(&file));
            render_png(&path, &fig)?;
            written.push(path);
        }
    }
    Ok(written)
}

/// One metric against swept parameter `x`: one line per combination of the other swept
/// parameters, points sorted by x, error bars = standard deviation over replicates.
fn metric_figure(study: &Study, metric: &str, x: usize) -> Result<Figure> {
    let file = &study.summary_path;
    let mean = numeric_column(&study.summary, file, &format!("{metric}_mean"))?;
    let std = numeric_column(&study.summary, file, &format!("{metric}_std"))?;
    let ParamValues::Num(xs) = &study.params[x] else {
        unreachable!("only numeric parameters are chosen as x axes");
    };
    let others: Vec<usize> = (0..study.params.len()).filter(|&j| j != x).collect();
    // A design's points share no values of the other parameters: one cloud of points.
    let groups = if study.prov.design.is_some() {
        vec![(0..xs.len()).collect()]
    } else {
        line_groups(study, &others, xs)
    };
    let design = study.prov.design.is_some();
    let series = groups
        .into_iter()
        .filter_map(|rows| {
            // NaN means (no run reached the metric) would only break the line: leave out.
            let rows: Vec<usize> = rows.into_iter().filter(|&r| mean[r].is_finite()).collect();
            let first = *rows.first()?;
            Some(Series {
                label: if design {
                    "design points (mean ± std over replicates)".into()
                } else {
                    params_label(study, &others, first)
                },
                x: rows.iter().map(|&r| xs[r]).collect(),
                y: rows.iter().map(|&r| mean[r]).collect(),
                y_err: Some(rows.iter().map(|&r| std[r]).collect()),
                style: if design {
                    SeriesStyle::Points
                } else {
                    SeriesStyle::LinePoints
                },
            })
        })
        .collect();
    let param = &study.prov.swept[x];
    Ok(Figure {
        title: format!("{}: {metric} vs {}", study.name, param.display()),
        x_label: param.display().to_string(),
        y_label: metric_axis_label(metric),
        log_x: param.log,
        series,
        ..Figure::default()
    })
}

/// Summary rows split into lines: rows with equal values of the `others` parameters form
/// one line (lines ordered by those values), each sorted by `xs`.
fn line_groups(study: &Study, others: &[usize], xs: &[f64]) -> Vec<Vec<usize>> {
    let key_cmp = |a: usize, b: usize| {
        others
            .iter()
            .map(|&j| study.params[j].cmp_rows(a, b))
            .find(|o| o.is_ne())
            .unwrap_or(Ordering::Equal)
    };
    let mut rows: Vec<usize> = (0..study.summary.n_rows()).collect();
    rows.sort_by(|&a, &b| key_cmp(a, b).then(xs[a].total_cmp(&xs[b])));
    rows.chunk_by(|&a, &b| key_cmp(a, b).is_eq())
        .map(<[usize]>::to_vec)
        .collect()
}

/// All `series_{observable}.png` figures, one per observable in order of appearance.
fn series_figures(study: &Study, series: &Table, file: &Path, out: &Path) -> Result<Vec<PathBuf>> {
    let observable = text_column(series, file, "observable")?;
    let mut seen = BTreeSet::new();
    let names: Vec<&str> = observable
        .iter()
        .map(String::as_str)
        .filter(|o| seen.insert(*o))
        .collect();
    let labels = point_labels(study)?;
    let mut written = Vec::new();
    for name in names {
        let fig = observable_figure(study, series, file, name, &labels)?;
        let path = out.join(safe_name(&format!("series_{name}.png")));
        render_png(&path, &fig)?;
        written.push(path);
    }
    Ok(written)
}

/// Legend text of each grid point, from the summary (which holds every point once).
fn point_labels(study: &Study) -> Result<HashMap<u64, String>> {
    let all: Vec<usize> = (0..study.params.len()).collect();
    let points = id_column(&study.summary, &study.summary_path, "point")?;
    Ok(points
        .iter()
        .enumerate()
        .map(|(r, &p)| (p, params_label(study, &all, r)))
        .collect())
}

/// Time series of one observable: one series per grid point holding all its runs, so that
/// the replicates of a point share a colour and a single legend entry.
fn observable_figure(
    study: &Study,
    table: &Table,
    file: &Path,
    name: &str,
    labels: &HashMap<u64, String>,
) -> Result<Figure> {
    let runs = runs_of(table, file, name)?;
    let all_points: Vec<u64> = runs
        .keys()
        .map(|(p, _, _)| *p)
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let chosen = pick_evenly(&all_points, MAX_SERIES_POINTS);
    let series = chosen
        .iter()
        .map(|&p| point_series(&runs, p, labels, all_points.len()))
        .collect();
    let mut title = format!("{}: {name}", study.name);
    if chosen.len() < all_points.len() {
        title.push_str(&format!(
            " ({} of {} grid points shown)",
            chosen.len(),
            all_points.len()
        ));
    }
    let y_label = study.prov.series_label.as_ref().and_then(|m| m.get(name));
    Ok(Figure {
        title,
        x_label: "time (s)".to_string(),
        y_label: y_label.map_or_else(|| name.to_string(), Clone::clone),
        series,
        ..Figure::default()
    })
}

/// The samples of one observable per run: (point, replicate, run_index) → (time, value)
/// sorted by time.
type Runs = BTreeMap<(u64, u64, u64), Vec<(f64, f64)>>;

/// Collects the `(time_s, value)` samples of observable `name`, run by run.
fn runs_of(table: &Table, file: &Path, name: &str) -> Result<Runs> {
    let observable = text_column(table, file, "observable")?;
    let run = id_column(table, file, "run_index")?;
    let point = id_column(table, file, "point")?;
    let replicate = id_column(table, file, "replicate")?;
    let time = numeric_column(table, file, "time_s")?;
    let value = numeric_column(table, file, "value")?;
    let mut runs = Runs::new();
    for r in (0..table.n_rows()).filter(|&r| observable[r] == name) {
        runs.entry((point[r], replicate[r], run[r]))
            .or_default()
            .push((time[r], value[r]));
    }
    for samples in runs.values_mut() {
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    Ok(runs)
}

/// All runs of grid point `p` as one line series, runs separated by a NaN sample (which
/// breaks the line) so that no segment joins the end of one run to the start of the next.
fn point_series(runs: &Runs, p: u64, labels: &HashMap<u64, String>, n_points: usize) -> Series {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for samples in runs
        .range((p, 0, 0)..=(p, u64::MAX, u64::MAX))
        .map(|(_, s)| s)
    {
        if !x.is_empty() {
            x.push(f64::NAN);
            y.push(f64::NAN);
        }
        x.extend(samples.iter().map(|s| s.0));
        y.extend(samples.iter().map(|s| s.1));
    }
    let label = match labels.get(&p) {
        Some(l) if !l.is_empty() => l.clone(),
        // Without swept values a single point needs no legend; several need telling apart.
        _ if n_points > 1 => format!("point {p}"),
        _ => String::new(),
    };
    Series {
        label,
        x,
        y,
        y_err: None,
        style: SeriesStyle::Line,
    }
}

/// At most `k` items of `items`, evenly spread and always including the first and last.
fn pick_evenly(items: &[u64], k: usize) -> Vec<u64> {
    let n = items.len();
    if n <= k {
        return items.to_vec();
    }
    if k < 2 {
        return items[..k].to_vec();
    }
    // Index i * (n - 1) / (k - 1), rounded to nearest; distinct because n > k.
    (0..k)
        .map(|i| items[(2 * i * (n - 1) + (k - 1)) / (2 * (k - 1))])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::atomic::tests::test_dir;
    use crate::output::table::write_parquet;

    /// A swept parameter of a synthetic study: (name, column, label, log, values).
    type Swept<'a> = (&'a str, &'a str, &'a str, bool, Vec<f64>);

    /// Grid points (row-major over `swept`, the last parameter varying fastest).
    fn grid(swept: &[Swept]) -> Vec<Vec<f64>> {
        swept.iter().fold(vec![vec![]], |acc, s| {
            acc.iter()
                .flat_map(|pt| {
                    s.4.iter().map(move |v| {
                        let mut next = pt.clone();
                        next.push(*v);
                        next
                    })
                })
                .collect()
        })
    }

    /// Writes provenance.json, summary.parquet and series.parquet (2 replicates, two
    /// observables) of a synthetic study; metrics named in `nan_metrics` have no values.
    fn write_study(dir: &Path, swept: &[Swept], metrics: &[&str], nan_metrics: &[&str]) {
        let prov = serde_json::json!({
            "magopt_version": "0.1.0", "model": "align", "study": "synthetic",
            "command": "magopt sweep test", "date_utc": "2025-01-01T00:00:00Z",
            "seeds": [1, 2], "metrics": metrics,
            "swept": swept.iter().map(|s| serde_json::json!(
                {"name": s.0, "column": s.1, "label": s.2, "log": s.3})).collect::<Vec<_>>(),
            "series_label": {"alignment": "alignment degree A"},
        });
        std::fs::write(dir.join("provenance.json"), prov.to_string()).unwrap();
        let pts = grid(swept);
        // A smooth positive response: faster for larger parameter values.
        let resp = |pt: &[f64]| 1.0 / (1.0 + pt.iter().sum::<f64>());
        let mut summary =
            Table::new().with("point", ColumnData::U64((0..pts.len() as u64).collect()));
        for (j, s) in swept.iter().enumerate() {
            summary.push(s.1, ColumnData::F64(pts.iter().map(|p| p[j]).collect()));
        }
        for (k, m) in metrics.iter().enumerate() {
            let nan = nan_metrics.contains(m);
            let mean: Vec<f64> = pts
                .iter()
                .map(|p| {
                    if nan {
                        f64::NAN
                    } else {
                        (k + 1) as f64 * resp(p)
                    }
                })
                .collect();
            let std: Vec<f64> = mean.iter().map(|v| 0.1 * v).collect();
            summary.push(
                &format!("{m}_ci95"),
                ColumnData::F64(std.iter().map(|v| 1.4 * v).collect()),
            );
            summary.push(&format!("{m}_mean"), ColumnData::F64(mean));
            summary.push(&format!("{m}_std"), ColumnData::F64(std));
            summary.push(
                &format!("{m}_count"),
                ColumnData::U64(vec![if nan { 0 } else { 2 }; pts.len()]),
            );
        }
        write_parquet(&dir.join("summary.parquet"), &summary).unwrap();
        write_parquet(
            &dir.join("series.parquet"),
            &series_table(swept, &pts, resp),
        )
        .unwrap();
    }

    /// Long-format series of every run: 2 replicates per point, observables
    /// "alignment" and "speed", 30 samples each.
    fn series_table(swept: &[Swept], pts: &[Vec<f64>], resp: impl Fn(&[f64]) -> f64) -> Table {
        let mut cols: (Vec<u64>, Vec<u64>, Vec<u64>, Vec<usize>) = Default::default();
        let (mut obs, mut time, mut value) = (Vec::new(), Vec::new(), Vec::new());
        for (p, pt) in pts.iter().enumerate() {
            for rep in 0..2u64 {
                let run = 2 * p as u64 + rep;
                for (o, name) in ["alignment", "speed"].iter().enumerate() {
                    for i in 0..30 {
                        let t = 0.1 * i as f64;
                        let tau = resp(pt) * (1.0 + 0.1 * rep as f64);
                        let v = if o == 0 {
                            1.0 - (-t / tau).exp()
                        } else {
                            (-t / tau).exp() / tau
                        };
                        cols.0.push(run);
                        cols.1.push(p as u64);
                        cols.2.push(rep);
                        cols.3.push(p);
                        obs.push(name.to_string());
                        time.push(t);
                        value.push(v);
                    }
                }
            }
        }
        let mut t = Table::new()
            .with("run_index", ColumnData::U64(cols.0))
            .with("point", ColumnData::U64(cols.1))
            .with("replicate", ColumnData::U64(cols.2));
        for (j, s) in swept.iter().enumerate() {
            t.push(
                s.1,
                ColumnData::F64(cols.3.iter().map(|&p| pts[p][j]).collect()),
            );
        }
        t.with("observable", ColumnData::Str(obs))
            .with("time_s", ColumnData::F64(time))
            .with("value", ColumnData::F64(value))
    }

    fn field() -> Swept<'static> {
        (
            "field",
            "field_kOe",
            "field (kOe)",
            true,
            vec![0.5, 1.0, 2.0, 5.0, 10.0],
        )
    }

    fn friction() -> Swept<'static> {
        (
            "friction",
            "friction",
            "friction μ",
            false,
            vec![0.1, 0.2, 0.4],
        )
    }

    fn assert_png(path: &Path) {
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{} is not a PNG",
            path.display()
        );
    }

    fn names(paths: &[PathBuf]) -> Vec<String> {
        paths
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect()
    }

    #[test]
    fn two_swept_params_two_metrics() {
        let dir = test_dir("study-plot-two");
        write_study(
            &dir,
            &[field(), friction()],
            &["alignment_time_s", "final_alignment"],
            &[],
        );
        let written = plot_study(&dir).unwrap();
        let expected = [
            "alignment_time_s_vs_field.png",
            "alignment_time_s_vs_friction.png",
            "final_alignment_vs_field.png",
            "final_alignment_vs_friction.png",
            "series_alignment.png",
            "series_speed.png",
        ];
        assert_eq!(names(&written), expected);
        for name in expected {
            let path = dir.join("plots").join(name);
            assert!(written.contains(&path));
            assert_png(&path);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn metric_figure_has_one_sorted_line_per_other_value() {
        let dir = test_dir("study-plot-fig");
        write_study(&dir, &[field(), friction()], &["alignment_time_s"], &[]);
        let study = load_study(&dir).unwrap();
        let fig = metric_figure(&study, "alignment_time_s", 0).unwrap();
        assert_eq!(fig.title, "synthetic: alignment_time_s vs field (kOe)");
        assert_eq!(
            (fig.x_label.as_str(), fig.y_label.as_str()),
            ("field (kOe)", "alignment_time_s (s)")
        );
        assert!(fig.log_x);
        let labels: Vec<&str> = fig.series.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            ["friction μ = 0.1", "friction μ = 0.2", "friction μ = 0.4"]
        );
        for s in &fig.series {
            assert_eq!(s.x, [0.5, 1.0, 2.0, 5.0, 10.0]);
            assert_eq!(s.y_err.as_ref().unwrap().len(), 5);
        }
        // Roles swapped: friction on a linear x axis, one line per field value.
        let fig = metric_figure(&study, "alignment_time_s", 1).unwrap();
        assert!(!fig.log_x);
        assert_eq!(fig.series.len(), 5);
        assert_eq!(fig.series[4].label, "field (kOe) = 10");
        assert_eq!(fig.series[0].x, [0.1, 0.2, 0.4]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn zero_swept_params_gives_series_plots_only() {
        let dir = test_dir("study-plot-none");
        write_study(&dir, &[], &["alignment_time_s"], &[]);
        let written = plot_study(&dir).unwrap();
        assert_eq!(
            names(&written),
            ["series_alignment.png", "series_speed.png"]
        );
        written.iter().for_each(|p| assert_png(p));
        let study = load_study(&dir).unwrap();
        let series = read_parquet(&dir.join("series.parquet")).unwrap();
        let fig = observable_figure(
            &study,
            &series,
            &dir,
            "alignment",
            &point_labels(&study).unwrap(),
        )
        .unwrap();
        // One point: one series holding both replicates, split by a NaN, and no legend.
        assert_eq!(fig.series.len(), 1);
        assert_eq!(fig.series[0].x.len(), 61);
        assert!(fig.series[0].x[30].is_nan());
        assert_eq!(fig.series[0].label, "");
        assert_eq!(fig.y_label, "alignment degree A");
        assert_eq!(fig.x_label, "time (s)");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_summary_is_an_input_error_naming_the_dir() {
        let dir = test_dir("study-plot-missing");
        let err = plot_study(&dir).unwrap_err();
        let dir_text = dir.display().to_string();
        assert!(
            matches!(err, Error::Input(ref m) if m.contains(&dir_text) && m.contains("summary.parquet")),
            "{err:?}"
        );
        assert!(!dir.join("plots").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn all_nan_metric_renders_without_panic() {
        let dir = test_dir("study-plot-nan");
        write_study(
            &dir,
            &[field(), friction()],
            &["alignment_time_90_s", "ok_m"],
            &["alignment_time_90_s"],
        );
        let written = plot_study(&dir).unwrap();
        assert_eq!(written.len(), 6);
        written.iter().for_each(|p| assert_png(p));
        let study = load_study(&dir).unwrap();
        assert!(metric_figure(&study, "alignment_time_90_s", 0)
            .unwrap()
            .series
            .is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_series_file_is_skipped() {
        let dir = test_dir("study-plot-noseries");
        write_study(&dir, &[field()], &["alignment_time_s"], &[]);
        std::fs::remove_file(dir.join("series.parquet")).unwrap();
        assert_eq!(
            names(&plot_study(&dir).unwrap()),
            ["alignment_time_s_vs_field.png"]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn text_param_labels_lines_but_is_never_an_x_axis() {
        let dir = test_dir("study-plot-text");
        write_study(&dir, &[field()], &["alignment_time_s"], &[]);
        // Add a text-valued "material" parameter to the provenance and the summary.
        let mut prov: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("provenance.json")).unwrap())
                .unwrap();
        prov["swept"].as_array_mut().unwrap().insert(
            0,
            serde_json::json!({"name": "material", "column": "material", "label": "material", "log": false}),
        );
        std::fs::write(dir.join("provenance.json"), prov.to_string()).unwrap();
        let path = dir.join("summary.parquet");
        let mut summary = read_parquet(&path).unwrap();
        let mats = [
            "magnetite",
            "maghemite",
            "magnetite",
            "maghemite",
            "magnetite",
        ];
        summary.push("material", ColumnData::Str(mats.map(String::from).to_vec()));
        write_parquet(&path, &summary).unwrap();
        let written = plot_study(&dir).unwrap();
        assert_eq!(names(&written)[0], "alignment_time_s_vs_field.png");
        assert!(!names(&written).iter().any(|n| n.contains("vs_material")));
        let study = load_study(&dir).unwrap();
        let fig = metric_figure(&study, "alignment_time_s", 1).unwrap();
        let labels: Vec<&str> = fig.series.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(labels, ["material = maghemite", "material = magnetite"]);
        assert_eq!(fig.series[1].x, [0.5, 2.0, 10.0]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn many_points_are_subsampled_and_said_so() {
        let dir = test_dir("study-plot-many");
        let many: Swept = (
            "field",
            "field_kOe",
            "field (kOe)",
            true,
            (1..=15).map(f64::from).collect(),
        );
        write_study(&dir, &[many], &["alignment_time_s"], &[]);
        let study = load_study(&dir).unwrap();
        let series = read_parquet(&dir.join("series.parquet")).unwrap();
        let fig = observable_figure(
            &study,
            &series,
            &dir,
            "speed",
            &point_labels(&study).unwrap(),
        )
        .unwrap();
        assert_eq!(fig.series.len(), MAX_SERIES_POINTS);
        assert!(
            fig.title.ends_with("(10 of 15 grid points shown)"),
            "{}",
            fig.title
        );
        assert_eq!(fig.series[0].label, "field (kOe) = 1");
        assert_eq!(fig.series[9].label, "field (kOe) = 15");
        assert_eq!(fig.y_label, "speed");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn helpers() {
        assert_eq!(fmt_num(0.30000000000000004), "0.3");
        assert_eq!(fmt_num(5.0), "5");
        assert_eq!(fmt_num(1.5e-7), "1.5e-7");
        assert_eq!(fmt_num(2.0e8), "2e8");
        assert_eq!(safe_name("series_a b/μ.png"), "series_a_b__.png");
        assert_eq!(safe_name(""), "unnamed");
        assert_eq!(
            metric_axis_label("alignment_time_90_s"),
            "alignment_time_90_s (s)"
        );
        assert_eq!(metric_axis_label("peak_force_N"), "peak_force_N (N)");
        assert_eq!(metric_axis_label("chain_length_m"), "chain_length_m (m)");
        assert_eq!(metric_axis_label("final_alignment"), "final_alignment");
        let items: Vec<u64> = (0..15).collect();
        assert_eq!(pick_evenly(&items, 10), [0, 2, 3, 5, 6, 8, 9, 11, 12, 14]);
        assert_eq!(pick_evenly(&items[..4], 10), [0, 1, 2, 3]);
    }
}
