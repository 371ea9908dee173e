//! `magopt sweep` and `magopt collect`: expand a study into runs, execute them in parallel,
//! persist each as it finishes, and build the tables.

use rayon::prelude::*;
use std::path::{Path, PathBuf};

use super::awake::with_workers_awake;
use super::model::{RunContext, Schedule, StudyModel};
use super::records::{self, RunRecord};
use super::spec::{RunSpec, Study};
use crate::output::atomic::prepare_output_dir;
use crate::output::guard::DirLock;
use crate::output::snapshots::check_writable;
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
    /// Reuse runs already saved in `out` whose inputs and code still match.
    pub resume: bool,
    /// With `resume`, also reuse saved runs of the same point and seed whose inputs or code
    /// changed (recorded in the provenance), instead of recomputing them.
    pub keep_stale: bool,
    /// Run only this slice.
    pub shard: Option<Shard>,
    /// The command line (provenance).
    pub command: String,
}

/// What a sweep did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SweepReport {
    /// Runs executed now.
    pub ran: usize,
    /// Runs found finished and reused.
    pub skipped: usize,
    /// Runs (of this shard) that failed or did not reach their target.
    pub unsuccessful: usize,
    /// Saved runs of a current point and seed whose inputs or code no longer match, with why
    /// (recomputed, or kept with `keep_stale`).
    pub stale: Vec<String>,
    /// Run files that did not parse or held another run: set aside in runs/unreadable/.
    pub set_aside: Vec<String>,
}

/// Why a saved run of the same point and seed is not the current run: the code changed, or
/// the first input that differs.
fn why_stale(saved: &RunRecord, run: &RunSpec, code: &str) -> String {
    if saved.code != code {
        return format!(
            "code {} is now {}",
            if saved.code.is_empty() {
                "(before 0.2)"
            } else {
                &saved.code
            },
            code
        );
    }
    let split = |t: &str| -> Vec<String> {
        t.split([',', '{', '}', '(', ')'])
            .map(|x| x.trim().to_string())
            .collect()
    };
    let (old, new) = (split(&saved.run.inputs), split(&run.inputs));
    match old.iter().zip(&new).find(|(a, b)| a != b) {
        Some((a, b)) => format!("input `{a}` is now `{b}`"),
        None => "inputs changed".into(),
    }
}

/// The runs of a shard that still have to run, and those already saved (placed at their
/// current position in the grid, which comes from the study, never from the record); `code`
/// is the model's current fingerprint (named when a saved run is stale because of it).
pub fn pending(
    runs: &[RunSpec],
    shard: Option<Shard>,
    dir: &Path,
    keep_stale: bool,
    code: &str,
) -> Result<(Vec<RunSpec>, Vec<RunRecord>, SweepReport)> {
    let mut report = SweepReport::default();
    let mut todo = Vec::new();
    let mut done = Vec::new();
    let mine: Vec<&RunSpec> = runs
        .iter()
        .filter(|r| shard.is_none_or(|s| r.index % s.count == s.index))
        .collect();
    for run in &mine {
        let (saved, aside) = records::load(dir, &run.id)?;
        report.set_aside.extend(aside);
        match saved {
            Some(saved) => done.push(RunRecord {
                run: (*run).clone(),
                ..saved
            }),
            None => todo.push((*run).clone()),
        }
    }
    let still = claim_stale(runs, todo, dir, keep_stale, code, &mut done, &mut report)?;
    Ok((still, done, report))
}

/// Of the runs still to do, those with a saved run of the same point values and seed under
/// another id (changed inputs or code): named in the report, then kept (`keep_stale`, placed
/// at the current position with their own inputs) or moved to `runs/stale/` and left to run.
/// Returns the runs still to do.
fn claim_stale(
    runs: &[RunSpec],
    todo: Vec<RunSpec>,
    dir: &Path,
    keep_stale: bool,
    code: &str,
    done: &mut Vec<RunRecord>,
    report: &mut SweepReport,
) -> Result<Vec<RunSpec>> {
    let current: std::collections::HashSet<&str> = runs.iter().map(|r| r.id.as_str()).collect();
    let key = |values: &[super::model::Value], seed: u64| {
        let v: Vec<String> = values.iter().map(|v| v.canonical()).collect();
        format!("{}|{seed}", v.join("|"))
    };
    let mut others: std::collections::HashMap<String, (PathBuf, RunRecord)> = records::saved(dir)
        .into_iter()
        .filter(|(_, r)| !current.contains(r.run.id.as_str()))
        .map(|(p, r)| (key(&r.run.values, r.run.seed), (p, r)))
        .collect();
    let mut still = Vec::new();
    for run in todo {
        let Some((path, saved)) = others.remove(&key(&run.values, run.seed)) else {
            still.push(run);
            continue;
        };
        report.stale.push(why_stale(&saved, &run, code));
        if keep_stale {
            let inputs = saved.run.inputs.clone();
            done.push(RunRecord {
                run: RunSpec { inputs, ..run },
                ..saved
            });
        } else {
            records::set_aside(dir, &path, "stale", "is stale")?;
            still.push(run);
        }
    }
    Ok(still)
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
        if let (Some(saved), _) = records::load(dir, &run.id)? {
            return Ok(RunRecord {
                run: run.clone(),
                ..saved
            });
        }
    }
    let record = RunRecord::new(run, model.run(params, run.seed, context)?, model.code());
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
        .runs(model)?
        .into_iter()
        .next()
        .ok_or_else(|| Error::input("the study has no run"))?;
    let params = study.params_at(model, &run.values)?;
    let _lock = match out {
        Some(dir) => {
            prepare_output_dir(dir)?;
            if model.run_span(&params).is_ok() {
                check_writable(&dir.join("snapshots"))?;
            }
            Some(DirLock::acquire(dir)?)
        }
        None => None,
    };
    let all_formats = Schedule::default();
    let context = RunContext {
        progress,
        artifacts: out,
        snapshots: study.snapshots.as_ref().unwrap_or(&all_formats),
    };
    // On a worker of the pool: the run's parallel loops, called from outside the pool, would
    // each be handed to it and waited for (a thread wake-up per loop, every step), which at
    // a few hundred particles costs more than the loop; on a worker they run inline on one
    // thread and by work stealing on more, the other workers kept awake between them. The
    // results do not depend on where they run.
    let record = with_workers_awake(|| load_or_run(model, &run, &params, out, false, &context))?;
    if let Some(dir) = out {
        records::write_results(
            model,
            study,
            dir,
            std::slice::from_ref(&record),
            command,
            None,
        )?;
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
    let _lock = DirLock::acquire(&options.out)?;
    let saved = records::count_saved(&options.out);
    if saved > 0 && !options.resume {
        return Err(Error::input(format!(
            "'{}' already holds {saved} finished runs: add --resume to continue, or choose another --out",
            options.out.display()
        )));
    }
    let runs = study.runs(model)?;
    let (todo, mut done, mut report) = pending(
        &runs,
        options.shard,
        &options.out,
        options.keep_stale,
        &model.code(),
    )?;
    report.skipped = done.len();
    total(todo.len());
    let fresh: Vec<Result<RunRecord>> = todo
        .par_iter()
        .map(|run| {
            let params = study.params_at(model, &run.values)?;
            let out = Some(options.out.as_path());
            let artifacts = run_files(&options.out, run);
            let context = match &study.snapshots {
                Some(schedule) => RunContext {
                    artifacts: Some(&artifacts),
                    snapshots: schedule,
                    ..RunContext::QUIET
                },
                None => RunContext::QUIET,
            };
            let record = load_or_run(model, run, &params, out, false, &context)?;
            tick();
            Ok(record)
        })
        .collect();
    report.ran = fresh.len();
    for record in fresh {
        done.push(record?);
    }
    done.sort_by_key(|r| r.run.index);
    report.unsuccessful = done.iter().filter(|r| !r.result.status.is_ok()).count();
    let resume = serde_json::json!({
        "reused": report.skipped,
        "stale": report.stale,
        "stale_kept": options.keep_stale && !report.stale.is_empty(),
        "set_aside": report.set_aside,
    });
    records::write_results(
        model,
        study,
        &options.out,
        &done,
        &options.command,
        Some(resume),
    )?;
    Ok(report)
}

/// Where a sweep's run writes its own files (snapshots): `runs/<id>/`.
pub fn run_files(out: &Path, run: &RunSpec) -> PathBuf {
    out.join("runs").join(&run.id)
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
    let _lock = DirLock::acquire(out)?;
    let mut found = Vec::new();
    for run in study.runs(model)? {
        let mut saved = None;
        for dir in dirs {
            if let (Some(record), _) = records::load(dir, &run.id)? {
                saved = Some(record);
                break;
            }
        }
        if let Some(record) = saved {
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
    records::write_results(model, study, out, &found, command, None)?;
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
