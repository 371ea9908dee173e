//! `magopt sweep`, `optimize`, `collect` and `plot`: study files in, result directories out.

use clap::Args;
use std::path::{Path, PathBuf};

use super::{command_line, threads};
use super::{progress, EXIT_INCOMPLETE};
use crate::materials::MaterialDb;
use crate::models::align::study::AlignModel;
use crate::models::analytic::study::AnalyticModel;
use crate::models::bed::study::BedModel;
use crate::models::blast::study::BlastModel;
use crate::output::atomic;
use crate::output::guard::{read_text_limited, MAX_TEXT_INPUT};
use crate::output::table::{read_parquet, write_parquet};
use crate::study::model::{ParamSpec, StudyModel, Value};
use crate::study::multi;
use crate::study::objectives::Target;
use crate::study::optimize::{history_table, optimize_sharded, optimum_json};
use crate::study::optimize_points;
use crate::study::optimize_shard::ShardWait;
use crate::study::records;
use crate::study::runner::{self, Shard, SweepOptions};
use crate::study::spec::{model_name, OptimizeMethod, Study};
use crate::{Error, Result};

/// `magopt sweep` options.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// The study file (TOML; see studies/ and README).
    study: PathBuf,
    /// Result directory [default: results/<study name>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Continue an interrupted or edited sweep: reuse the runs saved in --out whose inputs
    /// (parameters, material and species files, defaults) and code still match; recompute the
    /// rest, saying how many saved runs are stale and why.
    #[arg(long)]
    resume: bool,
    /// With --resume, keep stale runs (same point and seed, changed inputs or code) instead of
    /// recomputing them; recorded in provenance.json.
    #[arg(long, requires = "resume")]
    keep_stale: bool,
    /// Run only slice I of N (0 ≤ I < N) of the run list, for job arrays.
    #[arg(long, value_name = "I/N")]
    shard: Option<Shard>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
}

/// `magopt optimize` options.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// The study file with an [optimize] table.
    study: PathBuf,
    /// Result directory [default: results/<study name>-optimize]; finished runs there are reused.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Run as shard I of N processes in lockstep, all with the same --out on a shared file
    /// system (a Slurm array): each runs its share of every batch and reads the others'; all
    /// reach the same optimum, and shard 0 writes the results.
    #[arg(long, value_name = "I/N")]
    shard: Option<Shard>,
    /// With --shard: seconds a peer shard may be silent (its lock file untouched) before
    /// waiting for its runs fails.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 600.0,
        requires = "shard"
    )]
    shard_timeout: f64,
}

impl OptimizeArgs {
    /// The shard plan, checked.
    fn shard_wait(&self) -> Result<Option<ShardWait>> {
        if !(self.shard_timeout > 0.0 && self.shard_timeout.is_finite()) {
            return Err(Error::input(format!(
                "--shard-timeout: {} is not allowed (need a positive number of seconds)",
                self.shard_timeout
            )));
        }
        if self.shard.is_some() && self.out.is_none() {
            return Err(Error::input(
                "--shard: every shard needs the same --out directory (on a shared file system)",
            ));
        }
        Ok(self.shard.map(|shard| ShardWait {
            shard,
            timeout_s: self.shard_timeout,
        }))
    }

    /// Whether this process writes the result tables (the only process, or shard 0).
    fn writes(&self) -> bool {
        self.shard.is_none_or(|s| s.index == 0)
    }
}

/// `magopt collect` options.
#[derive(Debug, Args)]
pub struct CollectArgs {
    /// Result directories of the shards (same study).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Where the merged result goes [default: the first directory].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Accept a result with runs missing (exit 0 instead of 4).
    #[arg(long)]
    allow_partial: bool,
}

/// `magopt plot` options.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// A study result directory (from sweep or collect).
    dir: PathBuf,
}

fn read_study(path: &Path) -> Result<(String, String)> {
    let text = read_text_limited(path, MAX_TEXT_INPUT, "study file").map_err(|e| match e {
        Error::Io { path, source } => Error::input(format!(
            "cannot read study file '{}': {source}",
            path.display()
        )),
        other => other,
    })?;
    let origin = path.display().to_string();
    let model = model_name(&text, &origin)?;
    Ok((text, model))
}

/// Dispatches on the study's model (the only place that lists the models): binds `$m` to the
/// model and evaluates `$body`, which is generic over [`StudyModel`].
macro_rules! with_model {
    ($db:expr, $model:expr, $origin:expr, |$m:ident| $body:expr) => {
        match $model {
            "align" => {
                let $m = &AlignModel::new($db);
                $body
            }
            "bed" => {
                let $m = &BedModel::cycle();
                $body
            }
            "damper" => {
                let $m = &BedModel::damper();
                $body
            }
            "blast" => {
                let $m = &BlastModel;
                $body
            }
            "analytic" => {
                let $m = &AnalyticModel;
                $body
            }
            other => Err(Error::input(format!(
                "{}: model: '{other}' is not available (available: {})",
                $origin,
                MODELS.join(", ")
            ))),
        }
    };
}

/// The models a study file may name.
const MODELS: &[&str] = &["align", "bed", "damper", "blast", "analytic"];

/// `magopt sweep`.
pub fn sweep(db: MaterialDb, args: &SweepArgs) -> Result<i32> {
    threads(args.threads)?;
    let (text, model) = read_study(&args.study)?;
    let origin = args.study.display().to_string();
    with_model!(db, model.as_str(), origin, |m| {
        let study = Study::parse(m, &text, &origin)?;
        let out = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(&study.name));
        let options = SweepOptions {
            out: out.clone(),
            resume: args.resume,
            keep_stale: args.keep_stale,
            shard: args.shard,
            command: command_line(),
        };
        let bar = progress::runs(0, false);
        let report = runner::sweep(m, &study, &options, |n| bar.set_length(n as u64), &|| {
            bar.inc(1)
        });
        bar.finish_and_clear();
        let report = report?;
        for line in &report.set_aside {
            eprintln!("magopt: run file {line}");
        }
        if !report.stale.is_empty() {
            let action = if args.keep_stale {
                "kept (--keep-stale)"
            } else {
                "recomputed"
            };
            eprintln!(
                "magopt: {} saved runs were stale and {action}: {}",
                report.stale.len(),
                summarize(&report.stale)
            );
        }
        println!(
            "{}: {} runs done now, {} were already done, {} failed or not reached (recorded as \
             data); results in {}",
            study.name,
            report.ran,
            report.skipped,
            report.unsuccessful,
            out.display()
        );
        if study.design.is_some() {
            print_design_tables(&out)?;
        }
        Ok(0)
    })
}

/// The sensitivity measures and metric distributions a design study wrote, as text.
fn print_design_tables(out: &Path) -> Result<()> {
    let path = out.join("sensitivity.parquet");
    if path.exists() {
        let t = read_parquet(&path)?;
        for line in crate::study::sensitivity_tables::sensitivity_lines(&t) {
            println!("{line}");
        }
    }
    let t = read_parquet(&out.join("distribution.parquet"))?;
    for line in crate::study::sensitivity_tables::distribution_lines(&t) {
        println!("{line}");
    }
    Ok(())
}

/// Reasons with their counts, most frequent first ("3 × code …; 1 × input …").
fn summarize(reasons: &[String]) -> String {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for r in reasons {
        match counts.iter_mut().find(|(x, _)| x == r) {
            Some((_, n)) => *n += 1,
            None => counts.push((r.clone(), 1)),
        }
    }
    counts.sort_by_key(|c| std::cmp::Reverse(c.1));
    let parts: Vec<String> = counts.iter().map(|(r, n)| format!("{n} × {r}")).collect();
    parts.join("; ")
}

/// `magopt optimize`.
pub fn optimize(db: MaterialDb, args: &OptimizeArgs) -> Result<i32> {
    threads(args.threads)?;
    let (text, model) = read_study(&args.study)?;
    let origin = args.study.display().to_string();
    with_model!(db, model.as_str(), origin, |m| {
        let study = Study::parse(m, &text, &origin)?.for_optimize();
        let shard = args.shard_wait()?;
        if study.objectives.is_some() {
            if args.shard.is_some() {
                return Err(Error::input(
                    "--shard: a Pareto optimization ([objectives]) runs in one process",
                ));
            }
            return pareto(m, &study, args);
        }
        let spec = study.optimize.clone().ok_or_else(|| {
            Error::input(format!("{origin}: no [optimize] or [objectives] table"))
        })?;
        let out = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(format!("{}-optimize", study.name)));
        // a Bayesian optimization evaluates at most its budget of points
        let points = match &spec.method {
            OptimizeMethod::Bayes(b) => b.budget as u64,
            _ => spec.scan_points as u64 + spec.iterations,
        };
        if !study.axes.is_empty() {
            return optimize_at_points(m, &study, args, &out, points, shard);
        }
        let bar = progress::runs(points * study.replicates as u64, true);
        let result = optimize_sharded(m, &study, Some(&out), &|| bar.inc(1), shard);
        bar.finish_and_clear();
        let result = result?;
        if !args.writes() {
            println!(
                "{}: shard done (optimum {:.6}); shard 0 writes the results into {}",
                study.name,
                result.value,
                out.display()
            );
            return Ok(0);
        }
        records::write_optimize_results(m, &study, &out, &result.records, &command_line())?;
        if let Some(history) = history_table(&study, &result) {
            write_parquet(&out.join("history.parquet"), &history)?;
        }
        let summary = optimum_json(m, &study, &result);
        atomic::write_json_atomic(&out.join("optimum.json"), &summary)?;
        if args.json {
            println!("{summary}");
        } else {
            print_optimum(&study, &result, &out);
        }
        Ok(0)
    })
}

/// `magopt optimize` on a study with `[sweep]` or `[design]` beside `[optimize]`: the optimum
/// at every point, and its distribution.
fn optimize_at_points<M: StudyModel>(
    m: &M,
    study: &Study<M>,
    args: &OptimizeArgs,
    out: &Path,
    per_point: u64,
    shard: Option<ShardWait>,
) -> Result<i32> {
    let n = study.points().len() as u64;
    let bar = progress::runs(n * per_point * study.replicates as u64, true);
    let found = optimize_points::optimize_points(m, study, Some(out), &|| bar.inc(1), shard);
    bar.finish_and_clear();
    let found = found?;
    if !args.writes() {
        println!("{}: shard done; shard 0 writes the results", study.name);
        return Ok(0);
    }
    let summary = optimize_points::write_results(m, study, out, &found, &command_line())?;
    if args.json {
        println!("{summary}");
        return Ok(0);
    }
    let metric = study.optimize.as_ref().map_or("", |o| o.metric.as_str());
    println!(
        "{}: optimum of {metric} at each of {} points ({} with an optimum)",
        study.name,
        found.len(),
        summary["with_optimum"]
    );
    for line in optimize_points::distribution_lines(study, &found) {
        println!("  {line}");
    }
    println!("results in {}", out.display());
    let failed = found.iter().filter(|p| p.optimum.is_err()).count();
    if failed > 0 {
        eprintln!("magopt: {failed} points have no optimum (reasons in optima.parquet)");
    }
    Ok(0)
}

/// `magopt optimize` on a study with `[objectives]`: the Pareto front by NSGA-II.
fn pareto<M: StudyModel>(m: &M, study: &Study<M>, args: &OptimizeArgs) -> Result<i32> {
    let spec = multi::check(m, study)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(format!("{}-optimize", study.name)));
    let bar = progress::runs((spec.points() * study.replicates) as u64, true);
    let result = multi::optimize(m, study, &out, &|| bar.inc(1));
    bar.finish_and_clear();
    let result = result?;
    let summary = multi::write_results(m, study, &out, &result, &command_line())?;
    if args.json {
        println!("{summary}");
        return Ok(0);
    }
    let names: Vec<String> = spec
        .objectives
        .iter()
        .map(|o| format!("{} {}", if o.maximize { "max" } else { "min" }, o.name))
        .collect();
    println!(
        "{}: Pareto front of {} — {} points from {} evaluations ({} runs)",
        study.name,
        names.join(", "),
        result.front.len(),
        result.evaluations.len(),
        result.records.len()
    );
    // parameter objectives are their parameter's column
    let shown: Vec<usize> = (0..spec.objectives.len())
        .filter(|&k| matches!(spec.objectives[k].target, Target::Metric(_)))
        .collect();
    let mut header: Vec<String> = spec.free.iter().map(|f| f.spec.label()).collect();
    header.extend(shown.iter().map(|&k| spec.label(&spec.objectives[k])));
    println!("  {}", header.join(" | "));
    for &i in &result.front {
        let e = &result.evaluations[i];
        let mut row: Vec<String> = spec
            .free
            .iter()
            .zip(&e.values)
            .map(|(f, &v)| format!("{:.4}", f.shown(v)))
            .collect();
        row.extend(
            shown
                .iter()
                .map(|&k| e.means[k].map_or("-".into(), |v| format!("{v:.6}"))),
        );
        println!("  {}", row.join(" | "));
    }
    let reference: Vec<String> = result.reference.iter().map(|r| format!("{r:.6}")).collect();
    println!(
        "hypervolume {:.6e} w.r.t. ({}); results in {}",
        result.hypervolume,
        reference.join(", "),
        out.display()
    );
    let rejected = result
        .evaluations
        .iter()
        .filter(|e| e.rejected.is_some())
        .count();
    if rejected > 0 {
        eprintln!(
            "magopt: {rejected} points were rejected by the model (no runs; see pareto.json)"
        );
    }
    Ok(0)
}

fn display(spec: &ParamSpec, x: f64) -> f64 {
    spec.display(&Value::Number(x)).as_number()
}

fn print_optimum<M: StudyModel>(
    study: &Study<M>,
    result: &crate::study::optimize::StudyOptimum,
    out: &Path,
) {
    let spec = study.optimize.as_ref().expect("optimize");
    let goal = if spec.maximize { "maximum" } else { "minimum" };
    let at: Vec<String> = spec
        .free
        .iter()
        .zip(&result.best)
        .map(|((s, ..), &v)| format!("{} = {:.4}", s.label(), display(s, v)))
        .collect();
    println!(
        "{}: {goal} of {} = {:.6} at {}",
        study.name,
        spec.metric,
        result.value,
        at.join(", ")
    );
    if let Some(o) = &result.one_dimensional {
        let (s, ..) = spec.free[0];
        if o.uncertainty.is_finite() {
            println!(
                "uncertainty (replicate optima, standard error): ±{:.4}",
                display(s, o.x + o.uncertainty) - display(s, o.x)
            );
        }
        println!(
            "within {} % of the optimum: {:.4}–{:.4} {}",
            spec.band * 100.0,
            display(s, o.band.0),
            display(s, o.band.1),
            s.label()
        );
    }
    if let Some(b) = &result.bayes {
        println!(
            "posterior mean there (Bayesian optimization): 95 % credible interval {:.6}–{:.6}",
            b.interval.0, b.interval.1
        );
        let region: Vec<String> = spec
            .free
            .iter()
            .zip(&b.region)
            .map(|((s, ..), &(lo, hi))| {
                format!("{} {:.4}–{:.4}", s.label(), display(s, lo), display(s, hi))
            })
            .collect();
        println!(
            "posterior mean within {} % of the optimum: {}",
            spec.band * 100.0,
            region.join(", ")
        );
        println!(
            "{} rounds after the initial design; stopped by {}",
            b.rounds, b.stop
        );
    }
    println!(
        "{} evaluations; results in {}",
        result.evaluations.len(),
        out.display()
    );
}

/// `magopt collect`.
pub fn collect(db: MaterialDb, args: &CollectArgs) -> Result<i32> {
    let first = &args.dirs[0];
    let text = runner::saved_study_text(first)?;
    for dir in &args.dirs[1..] {
        if runner::saved_study_text(dir)? != text {
            return Err(Error::input(format!(
                "'{}' holds a different study than '{}': only shards of one study can be collected",
                dir.display(),
                first.display()
            )));
        }
    }
    let origin = first.join("study.toml").display().to_string();
    let model = model_name(&text, &origin)?;
    with_model!(db, model.as_str(), origin, |m| {
        let study = Study::parse(m, &text, &origin)?;
        let out = args.out.clone().unwrap_or_else(|| first.clone());
        let n = runner::collect(m, &study, &args.dirs, &out, &command_line())?;
        let total = study.runs(m)?.len();
        println!(
            "{}: collected {n} of {total} runs into {}",
            study.name,
            out.display()
        );
        if n < total && !args.allow_partial {
            eprintln!(
                "magopt: {} of {total} runs are missing (run the missing shards, or accept a \
                 partial result with --allow-partial)",
                total - n
            );
            return Ok(EXIT_INCOMPLETE);
        }
        Ok(0)
    })
}

/// `magopt plot`.
pub fn plot(args: &PlotArgs) -> Result<i32> {
    let written = crate::study::plot::plot_study(&args.dir)?;
    for path in written {
        println!("{}", path.display());
    }
    Ok(0)
}
