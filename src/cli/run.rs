//! The one path of the single-run commands (`align`, `bed`, `damper`, `blast`): the flags
//! given become a one-point study, run by the study runner like any sweep's run, printed as a
//! summary or as JSON, with an exit code that says how the run ended.

use clap::{ArgMatches, Args};
use std::path::PathBuf;

use super::params::{self, Given};
use super::{command_line, progress, EXIT_RUN_UNSUCCESSFUL};
use crate::output::snapshots::{Format, Schedule};
use crate::study::model::{RunStatus, StudyModel};
use crate::study::records::{RunRecord, VERSION};
use crate::study::runner;
use crate::study::spec::Study;
use crate::{Error, Result};

/// Options of every single run besides the model's parameters.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Seed of the run's random start (packing, positions, charge signs).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1)]
    pub seed: u64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Directory for runs.parquet, series.parquet, summary.parquet, study.toml,
    /// provenance.json and the run's own files (snapshots, figures).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// With --out: also write a particle frame every K steps (step 0 included) into
    /// DIR/snapshots/frame.<k>.* (at most 10000 frames).
    #[arg(long, allow_hyphen_values = true, value_name = "K")]
    pub snapshot_every: Option<String>,
    /// With --out: also write particle frames at these simulated times, comma-separated
    /// (s, ms, us, min, h; bare number: s), each at the first step at or after it.
    #[arg(long, allow_hyphen_values = true, value_name = "TIMES")]
    pub snapshot_times: Option<String>,
    /// With --out: formats of every particle frame, comma-separated: xyz (extended XYZ), dump
    /// (LAMMPS), vtk (legacy VTK), parquet [default: all four].
    #[arg(long, value_name = "FORMATS")]
    pub snapshot_format: Option<String>,
}

impl RunArgs {
    /// The snapshot schedule the flags ask for (None: no snapshot flag given).
    fn schedule(&self) -> Result<Option<Schedule>> {
        let given = [
            &self.snapshot_every,
            &self.snapshot_times,
            &self.snapshot_format,
        ];
        let Some(flag) = given.iter().position(|g| g.is_some()) else {
            return Ok(None);
        };
        if self.out.is_none() {
            let name = ["--snapshot-every", "--snapshot-times", "--snapshot-format"][flag];
            return Err(Error::input(format!(
                "{name}: snapshots need --out DIR (where the frames go)"
            )));
        }
        let mut schedule = Schedule::default();
        if let Some(k) = &self.snapshot_every {
            schedule.every = Some(
                k.trim()
                    .parse::<u64>()
                    .ok()
                    .filter(|k| *k >= 1)
                    .ok_or_else(|| {
                        Error::input(format!(
                            "--snapshot-every: '{k}' is not allowed (need a step count ≥ 1)"
                        ))
                    })?,
            );
        }
        if let Some(t) = &self.snapshot_times {
            schedule.times = Schedule::parse_times(t)
                .map_err(|e| Error::input(format!("--snapshot-times: {e}")))?;
        }
        if let Some(f) = &self.snapshot_format {
            schedule.formats = Format::parse_list(f)
                .map_err(|e| Error::input(format!("--snapshot-format: {e}")))?;
        }
        Ok(Some(schedule))
    }
}

/// Runs the model with the parameters given in `matches` (plus `extra`, from shorthand
/// flags), prints the summary (or JSON) and returns the exit code: 0 when the run succeeded,
/// [`EXIT_RUN_UNSUCCESSFUL`] when it failed or did not reach its target.
pub fn single<M: StudyModel>(
    model: &M,
    matches: &ArgMatches,
    extra: &[Given],
    args: &RunArgs,
    summary: impl Fn(&M::Params, &RunRecord),
) -> Result<i32> {
    let mut given = params::given(model, matches)?;
    for e in extra {
        if !given.iter().any(|g| g.name == e.name) {
            given.push(e.clone());
        }
    }
    let (params, values) = params::setup(model, &given)?;
    let command = command_line();
    let schedule = args.schedule()?;
    let study = Study::one_point(
        model,
        &values,
        1,
        args.seed,
        None,
        schedule.as_ref(),
        model.name(),
        &command,
    )?;
    let bar = progress::run();
    let record = runner::single(
        model,
        &study,
        args.out.as_deref(),
        &|f| progress::set_fraction(&bar, f),
        &command,
    );
    bar.finish_and_clear();
    let record = record?;
    if args.json {
        println!("{}", json(model, &params, &record));
    } else {
        summary(&params, &record);
        if let RunStatus::Failed(reason) = &record.result.status {
            println!("run failed: {reason}");
        }
        for note in &record.result.notes {
            println!("warning: {note}");
        }
    }
    Ok(match record.result.status {
        RunStatus::Ok => 0,
        _ => EXIT_RUN_UNSUCCESSFUL,
    })
}

/// One run as JSON: model, status, reason (null unless failed), seed, every parameter in its
/// display unit (keyed by its table column, null where derived), every metric, notes, wall
/// time, version.
pub fn json<M: StudyModel>(model: &M, params: &M::Params, record: &RunRecord) -> serde_json::Value {
    let number = |x: Option<f64>| x.filter(|x| x.is_finite()).map(serde_json::Value::from);
    let parameters: serde_json::Map<String, serde_json::Value> = model
        .parameters()
        .iter()
        .map(|p| {
            let value = (p.get)(params).map(|v| p.spec.display(&v));
            let json = match value {
                Some(crate::study::model::Value::Number(x)) => number(Some(x)),
                Some(crate::study::model::Value::Text(t)) => Some(t.into()),
                None => None,
            };
            (p.spec.column(), json.unwrap_or(serde_json::Value::Null))
        })
        .collect();
    let r = &record.result;
    let mut map = serde_json::Map::new();
    map.insert("model".into(), model.name().into());
    map.insert("status".into(), r.status.label().into());
    map.insert("reason".into(), r.status.reason().into());
    map.insert("seed".into(), record.run.seed.into());
    map.insert("parameters".into(), parameters.into());
    for (name, value) in &r.metrics {
        let v = number(*value).unwrap_or(serde_json::Value::Null);
        map.insert(name.clone(), v);
    }
    map.insert("notes".into(), r.notes.clone().into());
    map.insert("wall_time_s".into(), r.wall_time_s.into());
    map.insert("magopt_version".into(), VERSION.into());
    serde_json::Value::Object(map)
}
