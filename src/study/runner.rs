//! `magopt sweep` and `magopt collect`: expand a study into runs, execute them in parallel,
//! persist each as it finishes, and build the tables.

use rayon::prelude::*;
use std::path::{Path, PathBuf};

use super::model::{RunContext, StudyModel};
use super::records::{self, RunRecord};
use super::spec::{RunSpec, Study};
use crate::output::atomic::prepare_output_dir;
use crate::{Error, Result};

/// A slice of the run list for job arrays: runs with index % count == index_of_shard.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 0-based.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// Parses "I/N" with 0 ≤ I < N (Slurm: `--shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`
    /// with `--array=0-(N-1)`).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || format!("'{s}' is not a shard I/N with 0 ≤ I < N (e.g. 0/4)");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

/// Options of a sweep.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Result directory.
    pub out: PathBuf,
    /// Skip runs already saved in `out`.
    pub resume: bool,
    /// Run only this slice.
    pub shard: Option<Shard>,
    /// The command line (provenance).
    pub command: String,
}

/// What a sweep did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SweepReport {
    /// Runs executed now.
    pub ran: usize,
    /// Runs found finished and skipped.
    pub skipped: usize,
    /// Runs (of this shard) that failed or did not reach their target.
    pub unsuccessful: usize,
}

/// The runs of a shard that still have to run, and those already saved.
pub fn pending(
    runs: &[RunSpec],
    shard: Option<Shard>,
    dir: &Path,
) -> Result<(Vec<RunSpec>, Vec<RunRecord>)> {
    let mut todo = Vec::new();
    let mut done = Vec::new();
    for run in runs
        .iter()
        .filter(|r| shard.is_none_or(|s| r.index % s.count == s.index))
    {
        match records::load(dir, &run.id)? {
            Some(record) => done.push(record),
            None => todo.push(run.clone()),
        }
    }
    Ok((todo, done))
}

/// The one load-or-run of sweeps, optimizations and single runs: with `reuse`, the record of
/// `run` saved in `dir` (placed at `run`'s position), else the run itself, saved into `dir`
/// the moment it finishes.
pub fn load_or_run<M: StudyModel>(
    model: &M,
    run: &RunSpec,
    params: &M::Params,
    dir: Option<&Path>,
    reuse: bool,
    context: &RunContext,
) -> Result<RunRecord> {
    if let (true, Some(dir)) = (reuse, dir) {
        if let Some(saved) = records::load(dir, &run.id)? {
            return Ok(RunRecord {
                run: run.clone(),
                ..saved
            });
        }
    }
    let record = RunRecord::new(run, model.run(params, run.seed, context)?);
    if let Some(dir) = dir {
        records::save(dir, &record)?;
    }
    Ok(record)
}

/// A one-point study's single run (the `align`, `bed`, `damper` and `blast` commands): run
/// with a progress report, and with `out`, the run's own files and the tables written there.
pub fn single<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    out: Option<&Path>,
    progress: &(dyn Fn(f64) + Sync),
    command: &str,
) -> Result<RunRecord> {
    let run = study
        .runs(model)
        .into_iter()
        .next()
        .ok_or_else(|| Error::input("the study has no run"))?;
    let params = study.params_at(model, &run.values)?;
    if let Some(dir) = out {
        prepare_output_dir(dir)?;
    }
    let context = RunContext {
        progress,
        artifacts: out,
    };
    let record = load_or_run(model, &run, &params, out, false, &context)?;
    if let Some(dir) = out {
        records::write_results(model, study, dir, std::slice::from_ref(&record), command)?;
    }
    Ok(record)
}

/// Runs a study's grid. `tick` is called after every finished run; `total` is told the number
/// of runs to do before the first starts.
pub fn sweep<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    options: &SweepOptions,
    total: impl FnOnce(usize),
    tick: &(impl Fn() + Sync),
) -> Result<SweepReport> {
    prepare_output_dir(&options.out)?;
    let saved = records::count_saved(&options.out);
    if saved > 0 && !options.resume {
        return Err(Error::input(format!(
            "'{}' already holds {saved} finished runs: add --resume to continue, or choose another --out",
            options.out.display()
        )));
    }
    let runs = study.runs(model);
    let (todo, mut done) = pending(&runs, options.shard, &options.out)?;
    let skipped = done.len();
    total(todo.len());
    let fresh: Vec<Result<RunRecord>> = todo
        .par_iter()
        .map(|run| {
            let params = study.params_at(model, &run.values)?;
            let out = Some(options.out.as_path());
            let record = load_or_run(model, run, &params, out, false, &RunContext::QUIET)?;
            tick();
            Ok(record)
        })
        .collect();
    let ran = fresh.len();
    for record in fresh {
        done.push(record?);
    }
    done.sort_by_key(|r| r.run.index);
    let unsuccessful = done.iter().filter(|r| !r.result.status.is_ok()).count();
    records::write_results(model, study, &options.out, &done, &options.command)?;
    Ok(SweepReport {
        ran,
        skipped,
        unsuccessful,
    })
}

/// Merges the runs saved in several result directories of the same study (shards) into `out`.
/// Returns the number of runs collected.
pub fn collect<M: StudyModel>(
    model: &M,
    study: &Study<M>,
    dirs: &[PathBuf],
    out: &Path,
    command: &str,
) -> Result<usize> {
    prepare_output_dir(out)?;
    let mut found = Vec::new();
    for run in study.runs(model) {
        if let Some(record) = dirs
            .iter()
            .find_map(|d| records::load(d, &run.id).transpose())
            .transpose()?
        {
            if out
                != dirs
                    .iter()
                    .find(|d| records::record_path(d, &run.id).exists())
                    .map(PathBuf::as_path)
                    .unwrap_or(out)
            {
                records::save(out, &record)?;
            }
            found.push(record);
        }
    }
    records::write_results(model, study, out, &found, command)?;
    Ok(found.len())
}

/// Reads the study file saved in a result directory.
pub fn saved_study_text(dir: &Path) -> Result<String> {
    let path = dir.join("study.toml");
    std::fs::read_to_string(&path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => Error::input(format!(
            "'{}' is not a study result directory (no study.toml)",
            dir.display()
        )),
        _ => Error::io(path, e),
    })
}
