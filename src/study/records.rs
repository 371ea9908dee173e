//! Finished runs on disk and the tables built from them. Every finished run is one JSON file
//! `runs/<id>.json`, written atomically the moment it finishes: an interrupted sweep loses only
//! the runs in flight, `--resume` skips what is there, and shards merge by id.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use super::model::{RunResult, StudyModel, Value};
use super::spec::{RunSpec, Study};
use crate::numerics::stats::Stats;
use crate::output::atomic::{write_atomic, write_json_atomic};
use crate::output::table::{write_parquet, ColumnData as C, Table};
use crate::{Error, Result};

/// The magopt version recorded with every result.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The code fingerprint recorded with every run and part of its id: the version and a hash of
/// every source file that can change what a run computes (see build.rs).
pub const CODE: &str = concat!(env!("CARGO_PKG_VERSION"), "+", env!("MAGOPT_PHYSICS_HASH"));

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
    /// Code fingerprint that ran it ([`CODE`]; empty in records written before 0.2).
    #[serde(default)]
    pub code: String,
}

impl RunRecord {
    /// A record for a run spec and its result.
    pub fn new(run: &RunSpec, result: RunResult) -> Self {
        Self {
            run: run.clone(),
            result,
            magopt_version: VERSION.to_string(),
            code: CODE.to_string(),
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
}

/// The k-th swept value of each run, as numbers where all are numbers, else as text.
fn axis_column<'a>(
    spec: &super::model::ParamSpec,
    runs: impl Iterator<Item = &'a RunSpec>,
    k: usize,
) -> ColumnData {
    let shown: Vec<Value> = runs.map(|run| spec.display(&run.values[k])).collect();
    if shown.iter().all(|v| matches!(v, Value::Number(_))) {
        C::F64(
            shown
                .iter()
                .map(|v| {
                    if let Value::Number(x) = v {
                        *x
                    } else {
                        f64::NAN
                    }
                })
                .collect(),
        )
    } else {
        C::Str(
            shown
                .iter()
                .map(|v| match v {
                    Value::Text(t) => t.clone(),
                    Value::Number(x) => x.to_string(),
                })
                .collect(),
        )
    }
}

use crate::output::table::ColumnData;

/// One row per run: index, id, point, replicate, seed, swept parameters (display units), status,
/// reason (of a failure), notes (warnings of a run that counts), metrics, wall time, version,
/// model.
pub fn runs_table(model: &str, columns: &Columns, records: &[RunRecord]) -> Table {
    let mut t = Table::new()
        .with(
            "run_index",
            C::U64(records.iter().map(|r| r.run.index as u64).collect()),
        )
        .with(
            "run_id",
            C::Str(records.iter().map(|r| r.run.id.clone()).collect()),
        )
        .with(
            "point",
            C::U64(records.iter().map(|r| r.run.point as u64).collect()),
        )
        .with(
            "replicate",
            C::U64(records.iter().map(|r| r.run.replicate as u64).collect()),
        )
        .with("seed", C::U64(records.iter().map(|r| r.run.seed).collect()));
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        t.push(name, axis_column(spec, records.iter().map(|r| &r.run), k));
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
        C::Str(
            records
                .iter()
                .map(|r| r.result.status.reason().unwrap_or_default().to_string())
                .collect(),
        ),
    );
    t.push(
        "notes",
        C::Str(records.iter().map(|r| r.result.notes.join("; ")).collect()),
    );
    for m in &columns.metrics {
        t.push(
            m,
            C::OptF64(records.iter().map(|r| r.result.metric(m)).collect()),
        );
    }
    t.push(
        "wall_time_s",
        C::F64(records.iter().map(|r| r.result.wall_time_s).collect()),
    );
    t.push(
        "magopt_version",
        C::Str(records.iter().map(|r| r.magopt_version.clone()).collect()),
    );
    t.push("model", C::Str(vec![model.to_string(); records.len()]));
    t
}

/// Long-format series: run, point, replicate, swept parameters, observable, time, value.
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
        .with(
            "run_index",
            C::U64(rows.iter().map(|(r, ..)| r.run.index as u64).collect()),
        )
        .with(
            "point",
            C::U64(rows.iter().map(|(r, ..)| r.run.point as u64).collect()),
        )
        .with(
            "replicate",
            C::U64(rows.iter().map(|(r, ..)| r.run.replicate as u64).collect()),
        );
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        t.push(
            name,
            axis_column(spec, rows.iter().map(|(r, ..)| &r.run), k),
        );
    }
    t.push(
        "observable",
        C::Str(rows.iter().map(|(_, o, ..)| o.to_string()).collect()),
    );
    t.push(
        "time_s",
        C::F64(rows.iter().map(|(_, _, t, _)| *t).collect()),
    );
    t.push("value", C::F64(rows.iter().map(|(.., v)| *v).collect()));
    t
}

/// Per point: swept parameters, then for each metric mean, std, count and the 95 % confidence
/// half-width of the mean (Student t).
pub fn summary_table(columns: &Columns, records: &[RunRecord]) -> Table {
    let mut points: Vec<usize> = records.iter().map(|r| r.run.point).collect();
    points.sort_unstable();
    points.dedup();
    let firsts: Vec<&RunSpec> = points
        .iter()
        .map(|p| &records.iter().find(|r| r.run.point == *p).unwrap().run)
        .collect();
    let mut t = Table::new().with("point", C::U64(points.iter().map(|&p| p as u64).collect()));
    for (k, (name, spec)) in columns.axes.iter().enumerate() {
        t.push(name, axis_column(spec, firsts.iter().copied(), k));
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
        t.push(
            &format!("{m}_mean"),
            C::F64(stats.iter().map(|s| s.mean).collect()),
        );
        t.push(
            &format!("{m}_std"),
            C::F64(stats.iter().map(|s| s.std).collect()),
        );
        t.push(
            &format!("{m}_count"),
            C::U64(stats.iter().map(|s| s.count as u64).collect()),
        );
        t.push(
            &format!("{m}_ci95"),
            C::F64(stats.iter().map(|s| s.ci95).collect()),
        );
    }
    t
}

/// Table columns of a study's axes and metrics.
pub fn columns<M: StudyModel>(study: &Study<M>) -> Columns {
    Columns {
        axes: study
            .axes
            .iter()
            .map(|a| (a.spec.column(), a.spec))
            .collect(),
        metrics: study.metrics.clone(),
    }
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
    let cols = columns(study);
    write_parquet(&dir.join("summary.parquet"), &summary_table(&cols, records))?;
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
    let cols = Columns {
        axes: free.iter().map(|(s, ..)| (s.column(), *s)).collect(),
        metrics: study.metrics.clone(),
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
    write_parquet(
        &dir.join(runs_file),
        &runs_table(model.name(), cols, records),
    )?;
    write_parquet(&dir.join("series.parquet"), &series_table(cols, records))?;
    write_atomic(&dir.join("study.toml"), study.text.as_bytes())?;
    write_json_atomic(&dir.join("provenance.json"), provenance)
}

/// Version, command, date, seeds, swept parameters (for `magopt plot`), metrics.
pub fn provenance<M: StudyModel>(model: &M, study: &Study<M>, command: &str) -> serde_json::Value {
    serde_json::json!({
        "magopt_version": VERSION,
        "code": CODE,
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
