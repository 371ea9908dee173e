//! Finished runs on disk and the tables built from them. Every finished run is one JSON file
//! `runs/<id>.json`, written atomically the moment it finishes: an interrupted sweep loses only
//! the runs in flight, `--resume` skips what is there, and shards merge by id.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use super::model::{ParamKind, RunResult, StudyModel, Value};
use super::sensitivity_tables::{distribution_table, sensitivity_table};
use super::spec::{RunSpec, Study};
use crate::numerics::stats::Stats;
use crate::output::atomic::{write_atomic, write_json_atomic};
use crate::output::table::{write_parquet, ColumnData as C, Table};
use crate::{Error, Result};

/// The magopt version recorded with every result.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// One finished run: what was run and what it gave.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The run (index, id, point, replicate, seed, swept values).
    #[serde(flatten)]
    pub run: RunSpec,
    /// What the run gave.
    pub result: RunResult,
    /// magopt version that ran it.
    pub magopt_version: String,
    /// Code fingerprint of its model that ran it ([`StudyModel::code`]; empty in records
    /// written before 0.2).
    #[serde(default)]
    pub code: String,
}

impl RunRecord {
    /// A record for a run spec, its result and the code fingerprint that computed it.
    pub fn new(run: &RunSpec, result: RunResult, code: String) -> Self {
        Self {
            run: run.clone(),
            result,
            magopt_version: VERSION.to_string(),
            code,
        }
    }
}

/// Where a run's record lives.
pub fn record_path(dir: &Path, id: &str) -> PathBuf {
    dir.join("runs").join(format!("{id}.json"))
}

/// Writes a finished run atomically.
pub fn save(dir: &Path, record: &RunRecord) -> Result<()> {
    let runs = dir.join("runs");
    std::fs::create_dir_all(&runs).map_err(|e| Error::io(runs, e))?;
    let value = serde_json::to_value(record)
        .map_err(|e| Error::Output(format!("run {}: {e}", record.run.id)))?;
    write_json_atomic(&record_path(dir, &record.run.id), &value)
}

/// Reads a run's record if it exists and is sound; a file that does not parse, or whose id
/// is not its name, is moved to `runs/unreadable/` (never deleted) and counts as missing. The
/// second value says what was set aside.
pub fn load(dir: &Path, id: &str) -> Result<(Option<RunRecord>, Option<String>)> {
    let path = record_path(dir, id);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((None, None)),
        Err(e) => return Err(Error::io(path, e)),
    };
    let why = match serde_json::from_str::<RunRecord>(&text) {
        Ok(record) if record.run.id == id => return Ok((Some(record), None)),
        Ok(record) => format!("holds run {}", record.run.id),
        Err(e) => format!("not a run record ({e})"),
    };
    Ok((None, Some(set_aside(dir, &path, "unreadable", &why)?)))
}

/// Moves a run file into `runs/<folder>/` and says so.
pub fn set_aside(dir: &Path, path: &Path, folder: &str, why: &str) -> Result<String> {
    let aside = dir.join("runs").join(folder);
    std::fs::create_dir_all(&aside).map_err(|e| Error::io(&aside, e))?;
    let name = path.file_name().unwrap_or_default();
    std::fs::rename(path, aside.join(name)).map_err(|e| Error::io(path, e))?;
    // The run's own files (runs/<id>/, snapshots) go with it.
    let files = path.with_extension("");
    if files.is_dir() {
        let to = aside.join(files.file_name().unwrap_or_default());
        std::fs::rename(&files, &to).map_err(|e| Error::io(&files, e))?;
    }
    Ok(format!(
        "{} {why}: moved to runs/{folder}/",
        name.to_string_lossy()
    ))
}

/// Every sound run record saved in `dir` (a file that does not parse is left for [`load`]).
pub fn saved(dir: &Path) -> Vec<(PathBuf, RunRecord)> {
    let Ok(entries) = std::fs::read_dir(dir.join("runs")) else {
        return Vec::new();
    };
    let mut found: Vec<(PathBuf, RunRecord)> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .filter_map(|p| {
            let text = std::fs::read_to_string(&p).ok()?;
            serde_json::from_str(&text).ok().map(|r| (p, r))
        })
        .collect();
    found.sort_by(|a, b| a.0.cmp(&b.0));
    found
}

/// Number of run records in a directory.
pub fn count_saved(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("runs"))
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
                .count()
        })
        .unwrap_or(0)
}

/// Names for the table columns of a study's swept (or free) parameters.
pub struct Columns {
    /// (column name, parameter spec) per axis.
    pub axes: Vec<(String, &'static super::model::ParamSpec)>,
    /// Metrics.
    pub metrics: Vec<String>,
    /// Series observables and their units (from the model's axis labels).
    pub series_units: Vec<(String, String)>,
}

/// The values of one declared parameter that is not an axis, one per run (None: derived by
/// the model, or the run's parameters could not be rebuilt), in display units.
pub struct InputColumn {
    /// The parameter.
    pub spec: &'static super::model::ParamSpec,
    /// One value per run record.
    pub values: Vec<Option<Value>>,
}

/// The unit a parameter's values are shown in: the display unit of a quantity, `"1"` for a
/// plain number or a count, the reference length of a multiple (`"D1"`), none for text.
pub fn param_unit(spec: &super::model::ParamSpec) -> Option<String> {
    match spec.kind {
        ParamKind::Quantity { unit, .. } => Some(unit.to_string()),
        ParamKind::Number | ParamKind::Count => Some("1".to_string()),
        ParamKind::Multiple { of } => Some(of.to_string()),
        ParamKind::Choice(_) | ParamKind::Name => None,
    }
}

/// A column of parameter values (display units): integers for counts, numbers where every
/// value is a number, else text; a missing value is null. The second value is the unit
/// (none for text).
pub fn value_column(
    spec: &super::model::ParamSpec,
    values: &[Option<Value>],
) -> (ColumnData, Option<String>) {
    let text_kind = matches!(spec.kind, ParamKind::Choice(_) | ParamKind::Name);
    let numbers: Option<Vec<Option<f64>>> = values
        .iter()
        .map(|v| match v {
            None => Some(None),
            Some(Value::Number(x)) => Some(Some(*x)),
            Some(Value::Text(_)) => None,
        })
        .collect();
    let all_some = values.iter().all(Option::is_some);
    match numbers {
        Some(numbers) if !text_kind => {
            let data = if matches!(spec.kind, ParamKind::Count) {
                let ints: Vec<Option<i64>> = numbers.iter().map(|x| x.map(|x| x as i64)).collect();
                if all_some {
                    C::I64(ints.into_iter().flatten().collect())
                } else {
                    C::OptI64(ints)
                }
            } else if all_some {
                C::F64(numbers.into_iter().flatten().collect())
            } else {
                C::OptF64(numbers)
            };
            (data, param_unit(spec))
        }
        _ => {
            let texts: Vec<Option<String>> = values
                .iter()
                .map(|v| {
                    v.as_ref().map(|v| match v {
                        Value::Text(t) => t.clone(),
                        Value::Number(_) => spec.user_text(v),
                    })
                })
                .collect();
            let data = if all_some {
                C::Str(texts.into_iter().flatten().collect())
            } else {
                C::OptStr(texts)
            };
            (data, None)
        }
    }
}

/// The k-th swept value of each run, in display units (see [`value_column`]).
fn axis_column<'a>(
    spec: &super::model::ParamSpec,
    runs: impl Iterator<Item = &'a RunSpec>,
    k: usize,
) -> (ColumnData, Option<String>) {
    let shown: Vec<Option<Value>> = runs.map(|run| Some(spec.display(&run.values[k]))).collect();
    value_column(spec, &shown)
}

/// Pushes a column with its unit, if it has one.
fn push(t: &mut Table, name: &str, (data, unit): (ColumnData, Option<String>)) {
    match unit {
        Some(unit) => t.push_unit(name, data, &unit),
        None => t.push(name, data),
    }
}

/// Columns of the runs table after the parameters.
const FIXED_AFTER_INPUTS: &[&str] = &[
    "status",
    "reason",
    "notes",
    "wall_time_s",
    "magopt_version",
    "model",
];

/// The runs-table column of a parameter that is not swept: [`ParamSpec::column`], or
/// `input_<column>` where that is the name of a metric (`max_packing_fraction` is both a bed
/// parameter, where to stop, and a metric, what was reached) or another column.
///
/// [`ParamSpec::column`]: super::model::ParamSpec::column
pub fn input_column_name(spec: &super::model::ParamSpec, columns: &Columns) -> String {
    let name = spec.column();
    let taken = columns.metrics.contains(&name)
        || columns.axes.iter().any(|(c, _)| *c == name)
        || FIXED_AFTER_INPUTS.contains(&name.as_str())
        || ["run_index", "run_id", "point", "replicate", "seed"].contains(&name.as_str());
    if taken {
        format!("input_{name}")
    } else {
        name
    }
}

/// Metrics that count something (steps, contacts, cells, bonds): integer columns.
const COUNT_METRICS: &[&str] = &[
    "steps",
    "contacts",
    "solver_sweeps",
    "unconverged_solves",
    "list_builds",
    "cells_start",
    "cells_max",
    "cells_end",
    "bonds",
    "clusters",
    "largest_cluster",
    "rejected_steps",
];

/// Whether a metric counts something (its values are whole numbers).
pub fn is_count_metric(name: &str) -> bool {
    COUNT_METRICS.contains(&name)
}

/// The SI unit of a metric, from its name's unit suffix (`_s`, `_N`, `_J`, `_m`,
/// `_m_per_s`, `_per_s`, `_rad_per_s`); `"1"` for counts, fractions and ratios (including
/// lengths in mean diameters, `_D`).
pub fn metric_unit(name: &str) -> &'static str {
    const SUFFIXES: &[(&str, &str)] = &[
        ("_rad_per_s", "rad/s"),
        ("_m_per_s", "m/s"),
        ("_per_s", "1/s"),
        ("_s", "s"),
        ("_N", "N"),
        ("_J", "J"),
        ("_m", "m"),
    ];
    SUFFIXES
        .iter()
        .find(|(suffix, _)| name.ends_with(suffix))
        .map_or("1", |(_, unit)| unit)
}

/// The unit of a series observable from its axis label: the text in the last parentheses
/// when it is a unit ("piston force (N)" → "N"), else "1".
pub fn label_unit(label: &str) -> String {
    let unit = label
        .trim_end()
        .strip_suffix(')')
        .and_then(|l| l.rsplit_once('('))
        .map(|(_, u)| u.trim());
    match unit {
        Some(u) if is_unit(u) => u.to_string(),
        _ => "1".to_string(),
    }
}

/// Whether a text is a unit symbol: a product or quotient of SI symbols with powers (`m`,
/// `N`, `J`, `m/s`, `kg*m2`); "particles" is not.
fn is_unit(text: &str) -> bool {
    const SYMBOLS: &[&str] = &[
        "m", "s", "kg", "g", "N", "J", "W", "Pa", "rad", "K", "C", "A", "T", "V", "mm", "um", "nm",
    ];
    let known = |u: &str| {
        let base = u.trim_end_matches(|c: char| c.is_ascii_digit() || "²³⁻¹^-".contains(c));
        SYMBOLS.contains(&base)
    };
    !text.is_empty() && text.split(['/', '*', '·']).all(known)
}

use crate::output::table::ColumnData;

/// One row per run: index, id, point, replicate, seed, swept parameters (display units), every
/// other declared parameter (display units; null where the model derives it), status, reason
/// (of a failure; null otherwise), notes (warnings of a run that counts; null if none),
/// metrics (integers for counts), wall time, version, model. Every numeric column carries
/// its unit.
pub fn runs_table(
    model: &str,
    columns: &Columns,
    inputs: &[InputColumn],
    records: &[RunRecord],
) -> Table {
    let mut t = Table::new()
        .with_unit(
            "run_index",
            C::U64(records.iter().map(|r| r.run.index as u64).collect()),
            "1",
        )
        .with(
            "run_id",
            C::Str(records.iter().map(|r| r.run.id.clone()).collect()),
        )
        .with_unit(
            "point",
            C::U64(records.iter().map(|r| r.run.point as u64).collect()),
            "1",
        )
        .with_unit(
            "replicate",
            C::U64(records.iter().map(|r| r.run.replicate as u64).collect()),
            "1",
        )
        .with_unit(
            "seed",
            C::U64(records.iter().map(|r| r.run.seed).collect()),
            "1",
        );
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        push(
            &mut t,
            name,
            axis_column(spec, records.iter().map(|r| &r.run), k),
        );
    }
    for input in inputs {
        assert_eq!(input.values.len(), records.len(), "one value per run");
        push(
            &mut t,
            &input_column_name(input.spec, columns),
            value_column(input.spec, &input.values),
        );
    }
    t.push(
        "status",
        C::Str(
            records
                .iter()
                .map(|r| r.result.status.label().to_string())
                .collect(),
        ),
    );
    t.push(
        "reason",
        C::OptStr(
            records
                .iter()
                .map(|r| r.result.status.reason().map(str::to_string))
                .collect(),
        ),
    );
    t.push(
        "notes",
        C::OptStr(
            records
                .iter()
                .map(|r| Some(r.result.notes.join("; ")).filter(|n| !n.is_empty()))
                .collect(),
        ),
    );
    for m in &columns.metrics {
        let values = records.iter().map(|r| r.result.metric(m));
        let data = if is_count_metric(m) {
            C::OptI64(values.map(|v| v.map(|v| v as i64)).collect())
        } else {
            C::OptF64(values.collect())
        };
        t.push_unit(m, data, metric_unit(m));
    }
    t.push_unit(
        "wall_time_s",
        C::F64(records.iter().map(|r| r.result.wall_time_s).collect()),
        "s",
    );
    t.push(
        "magopt_version",
        C::Str(records.iter().map(|r| r.magopt_version.clone()).collect()),
    );
    t.push("model", C::Str(vec![model.to_string(); records.len()]));
    t
}

/// Long-format series: run, point, replicate, swept parameters, observable, its unit, time,
/// value.
pub fn series_table(columns: &Columns, records: &[RunRecord]) -> Table {
    let rows: Vec<(&RunRecord, &str, f64, f64)> = records
        .iter()
        .flat_map(|r| {
            r.result
                .series
                .iter()
                .flat_map(move |(name, s)| s.iter().map(move |&(t, v)| (r, name.as_str(), t, v)))
        })
        .collect();
    let mut t = Table::new()
        .with_unit(
            "run_index",
            C::U64(rows.iter().map(|(r, ..)| r.run.index as u64).collect()),
            "1",
        )
        .with_unit(
            "point",
            C::U64(rows.iter().map(|(r, ..)| r.run.point as u64).collect()),
            "1",
        )
        .with_unit(
            "replicate",
            C::U64(rows.iter().map(|(r, ..)| r.run.replicate as u64).collect()),
            "1",
        );
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        push(
            &mut t,
            name,
            axis_column(spec, rows.iter().map(|(r, ..)| &r.run), k),
        );
    }
    t.push(
        "observable",
        C::Str(rows.iter().map(|(_, o, ..)| o.to_string()).collect()),
    );
    let unit_of = |o: &str| {
        columns
            .series_units
            .iter()
            .find(|(name, _)| name == o)
            .map_or_else(|| "1".to_string(), |(_, u)| u.clone())
    };
    t.push(
        "unit",
        C::Str(rows.iter().map(|(_, o, ..)| unit_of(o)).collect()),
    );
    t.push_unit(
        "time_s",
        C::F64(rows.iter().map(|(_, _, t, _)| *t).collect()),
        "s",
    );
    // the values of different observables have different units: see the `unit` column
    t.push("value", C::F64(rows.iter().map(|(.., v)| *v).collect()));
    t
}

/// Per point: swept parameters, then for each metric mean, std, count and the 95 % confidence
/// half-width of the mean (Student t). The mean is null without values, std and ci95 with
/// fewer than two.
pub fn summary_table(columns: &Columns, records: &[RunRecord]) -> Table {
    let mut points: Vec<usize> = records.iter().map(|r| r.run.point).collect();
    points.sort_unstable();
    points.dedup();
    let firsts: Vec<&RunSpec> = points
        .iter()
        .map(|p| &records.iter().find(|r| r.run.point == *p).unwrap().run)
        .collect();
    let mut t = Table::new().with_unit(
        "point",
        C::U64(points.iter().map(|&p| p as u64).collect()),
        "1",
    );
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        push(&mut t, name, axis_column(spec, firsts.iter().copied(), k));
    }
    for m in &columns.metrics {
        let stats: Vec<Stats> = points
            .iter()
            .map(|&p| {
                Stats::of(
                    records
                        .iter()
                        .filter(|r| r.run.point == p)
                        .filter_map(|r| r.result.metric(m)),
                )
            })
            .collect();
        let unit = metric_unit(m);
        let with_count = |least: usize, value: fn(&Stats) -> f64| {
            C::OptF64(
                stats
                    .iter()
                    .map(|s| (s.count >= least).then(|| value(s)))
                    .collect(),
            )
        };
        t.push_unit(&format!("{m}_mean"), with_count(1, |s| s.mean), unit);
        t.push_unit(&format!("{m}_std"), with_count(2, |s| s.std), unit);
        t.push_unit(
            &format!("{m}_count"),
            C::U64(stats.iter().map(|s| s.count as u64).collect()),
            "1",
        );
        t.push_unit(&format!("{m}_ci95"), with_count(2, |s| s.ci95), unit);
    }
    t
}

/// Table columns of a study's axes and metrics.
pub fn columns<M: StudyModel>(model: &M, study: &Study<M>) -> Columns {
    Columns {
        axes: study
            .axes
            .iter()
            .map(|a| (a.spec.column(), a.spec))
            .collect(),
        metrics: study.metrics.clone(),
        series_units: series_units(model),
    }
}

/// Each series observable's unit, from the model's axis labels.
fn series_units<M: StudyModel>(model: &M) -> Vec<(String, String)> {
    model
        .series_labels()
        .iter()
        .map(|(name, label)| (name.to_string(), label_unit(label)))
        .collect()
}

/// Every declared parameter that is not an axis, with each run's value (display units): the
/// study's base with the run's axis values set, as the run had them.
pub fn input_columns<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    columns: &Columns,
    records: &[RunRecord],
) -> Vec<InputColumn> {
    let params: Vec<Option<M::Params>> = records
        .iter()
        .map(|r| {
            let mut params = study.base.clone();
            for ((_, spec), value) in columns.axes.iter().zip(&r.run.values) {
                model.set(&mut params, spec.name, value, spec.name).ok()?;
            }
            Some(params)
        })
        .collect();
    model
        .parameters()
        .iter()
        .filter(|p| !columns.axes.iter().any(|(_, s)| s.name == p.spec.name))
        .map(|p| InputColumn {
            spec: &p.spec,
            values: params
                .iter()
                .map(|params| {
                    params
                        .as_ref()
                        .and_then(|params| (p.get)(params))
                        .map(|v| p.spec.display(&v))
                })
                .collect(),
        })
        .collect()
}

/// Writes runs/series/summary tables, the study file and the provenance into `dir`; `resume`
/// (what a resumed sweep reused, found stale or set aside) goes into the provenance.
pub fn write_results<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    dir: &Path,
    records: &[RunRecord],
    command: &str,
    resume: Option<serde_json::Value>,
) -> Result<()> {
    let cols = columns(model, study);
    write_parquet(&dir.join("summary.parquet"), &summary_table(&cols, records))?;
    if let Some(design) = &study.design {
        let metrics = &study.metrics;
        if let Some(t) = sensitivity_table(design, metrics, records, study.seed) {
            write_parquet(&dir.join("sensitivity.parquet"), &t)?;
        }
        let distribution = distribution_table(metrics, records);
        write_parquet(&dir.join("distribution.parquet"), &distribution)?;
    }
    let mut prov = provenance(model, study, command);
    if let Some(resume) = resume {
        prov["resume"] = resume;
    }
    write_run_tables(model, study, dir, "runs.parquet", &cols, records, &prov)
}

/// Writes an optimization's runs: `evaluations.parquet` (one row per evaluated point and
/// replicate), `series.parquet`, the study file and the provenance.
pub fn write_optimize_results<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    dir: &Path,
    records: &[RunRecord],
    command: &str,
) -> Result<()> {
    let free = study.optimize.as_ref().map_or(&[][..], |o| &o.free[..]);
    // a run's values: its grid or design point's (if any), then the free parameters'
    let axes = study.axes.iter().map(|a| a.spec);
    let cols = Columns {
        axes: axes
            .chain(free.iter().map(|(s, ..)| *s))
            .map(|s| (s.column(), s))
            .collect(),
        metrics: study.metrics.clone(),
        series_units: series_units(model),
    };
    let prov = provenance(model, study, command);
    write_run_tables(
        model,
        study,
        dir,
        "evaluations.parquet",
        &cols,
        records,
        &prov,
    )
}

/// The per-run table (named `runs_file`), the series, the study file and the provenance.
fn write_run_tables<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    dir: &Path,
    runs_file: &str,
    cols: &Columns,
    records: &[RunRecord],
    provenance: &serde_json::Value,
) -> Result<()> {
    let inputs = input_columns(model, study, cols, records);
    write_parquet(
        &dir.join(runs_file),
        &runs_table(model.name(), cols, &inputs, records),
    )?;
    write_parquet(&dir.join("series.parquet"), &series_table(cols, records))?;
    write_atomic(&dir.join("study.toml"), study.text.as_bytes())?;
    write_json_atomic(&dir.join("provenance.json"), provenance)
}

/// Version, command, date, seeds, swept parameters (for `magopt plot`), metrics.
pub fn provenance<M: StudyModel>(model: &M, study: &Study<M>, command: &str) -> serde_json::Value {
    serde_json::json!({
        "magopt_version": VERSION,
        "code": model.code(),
        "model": model.name(),
        "study": study.name,
        "command": command,
        "date_utc": utc_now(),
        "seeds": (0..study.replicates).map(|r| study.seed.wrapping_add(r as u64)).collect::<Vec<_>>(),
        "metrics": study.metrics,
        "swept": study.axes.iter().map(|a| serde_json::json!({
            "name": a.spec.name, "column": a.spec.column(), "label": a.spec.label(), "log": a.log,
        })).collect::<Vec<_>>(),
        "series_label": model.series_labels().iter().map(|(k, v)| (k.to_string(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
        "design": study.design.as_ref().map(|d| serde_json::json!({
            "method": d.kind.name(), "samples": d.samples, "points": d.points.len(),
        })),
    })
}

/// The current UTC time as ISO 8601 (civil-from-days; no time-zone database needed).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}
