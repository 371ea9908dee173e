//! `magopt bench <model>`: throughput and peak memory of a model's runs, one row per
//! configuration. One file per model; each prints a table and returns its rows as JSON, which
//! `--out DIR` writes to `DIR/bench-<model>.json` (results/bench/README.md).

mod align;
mod analyze;
mod bed;
mod blast;

use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::PathBuf;

use super::{count, heap};
use crate::materials::MaterialDb;
use crate::models::align::{ReleaseScheme, RestMeasure};
use crate::output::atomic;
use crate::{Error, Result};

/// What to benchmark.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum Target {
    /// The DEM align model: settling, then alignment (Sr ferrite, 40 kOe, μ = 0.2,
    /// P = 0.5 atm) until A = 0.95 or --max-steps.
    Align,
    /// The 2D structure analysis (Voronoi, n5/n6/n7, Ψ6, regularity) of --points jittered
    /// lattice points.
    Analyze,
    /// One full compression cycle of the mono-disperse bed (dry friction, defaults).
    Bed,
    /// The blast model: the source's non-interacting and interacting examples.
    Blast,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Target::Align => "align",
            Target::Analyze => "analyze",
            Target::Bed => "bed",
            Target::Blast => "blast",
        }
    }
}

/// `magopt bench` options.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to benchmark.
    #[arg(value_enum, default_value = "align")]
    target: Target,
    /// Particle counts, comma-separated [default: 1000,10000 for align, 368 for bed, 2000 for
    /// blast].
    #[arg(long, value_delimiter = ',')]
    particles: Option<Vec<String>>,
    /// Thread counts, comma-separated.
    #[arg(long, default_value = "1,2", value_delimiter = ',')]
    threads: Vec<String>,
    /// align: cap on alignment steps per run (the run stops earlier at A = 0.95).
    #[arg(long, default_value_t = 1000)]
    max_steps: usize,
    /// align: settle a die of ⌈N/K²⌉ particles and run the alignment stage on K × K copies of
    /// it laid side by side (its memory and cost at N whose settling would take hours; the
    /// settling columns are the one die's).
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    tiles: u32,
    /// align: settling rest criterion: rms (root-mean-square net force; the model's default)
    /// or max (largest net force; its cost explodes with N).
    #[arg(long, value_enum, default_value = "rms")]
    rest: RestMeasure,
    /// align: how the settled bed is released: overdamped (the model's default) or inertial
    /// (the default until 2026-12-03; docs/align.md, "The release").
    #[arg(long, value_enum, default_value = "overdamped")]
    release: ReleaseScheme,
    /// analyze: point counts, comma-separated.
    #[arg(long, default_value = "10000,100000", value_delimiter = ',')]
    points: Vec<String>,
    /// bed: neighbour methods, comma-separated (exact, cells, verlet).
    #[arg(long, default_value = "verlet,exact", value_delimiter = ',')]
    neighbors: Vec<String>,
    /// bed: piston speed (bare number: mm/s); faster means fewer steps per cycle.
    #[arg(long, default_value = "5.63mm/s")]
    velocity: String,
    /// bed: far-field intervals K of the multiple time stepping, comma-separated (1 = every
    /// pair every step; K > 1 applies to verlet rows only).
    #[arg(long, default_value = "1", value_delimiter = ',')]
    far_field_interval: Vec<String>,
    /// bed: cut-off r_c of the pair sums in units of D1 [default: the model's].
    #[arg(long)]
    cutoff: Option<String>,
    /// bed: Verlet list radius r_v in units of D1 [default: the model's].
    #[arg(long)]
    list_radius: Option<String>,
    /// bed: time-step factor (Δt = factor/ω_max) [default: the model's].
    #[arg(long)]
    time_step_factor: Option<String>,
    /// bed: upper bound on the time step (s, ms; bare number: s) [default: the model's].
    #[arg(long)]
    max_time_step: Option<String>,
    /// bed: the tail beyond the cut-off (auto, none, mean-field) [default: the model's, auto:
    /// mean-field with verlet and cells].
    #[arg(long)]
    tail_correction: Option<String>,
    /// blast: simulated time of the interacting example (s, ms; bare number: s).
    #[arg(long, default_value = "1s")]
    interacting_duration: String,
    /// blast: Barnes–Hut opening angle of the interacting example's near field (0 = exact).
    #[arg(long, default_value_t = 0.0)]
    near_field_theta: f64,
    /// blast: keep the source's packing fraction and blast energy per particle at every N:
    /// the cloud radius grows as (N/2000)^(1/3) from 1 m and the energy as N/2000 from 10 kJ
    /// (without it every N shares the source's cloud, which holds about 2000 particles).
    #[arg(long)]
    scale_cloud: bool,
    /// blast: arithmetic of the interacting example's all-pairs near field, comma-separated
    /// (auto, double, single); each row reports its error against the exact double-precision sum
    /// on the run's final cloud.
    #[arg(long, default_value = "auto", value_delimiter = ',')]
    near_field_precision: Vec<String>,
    /// Also write the rows as JSON to DIR/bench-<model>.json.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// Runs the benchmark, prints one line per configuration and writes the JSON if asked.
pub fn run(db: &MaterialDb, args: &BenchArgs) -> Result<()> {
    if let Some(dir) = &args.out {
        atomic::prepare_output_dir(dir)?;
    }
    let rows = match args.target {
        Target::Align => align::run(db, args)?,
        Target::Analyze => analyze::run(args)?,
        Target::Bed => bed::run(args)?,
        Target::Blast => blast::run(args)?,
    };
    if let Some(dir) = &args.out {
        let name = args.target.name();
        let report = json!({
            "model": name,
            "machine": machine(),
            "command": std::env::args().collect::<Vec<_>>().join(" "),
            "rows": rows,
        });
        atomic::write_json_atomic(&dir.join(format!("bench-{name}.json")), &report)?;
    }
    Ok(())
}

/// Parses comma-separated counts, or the model's defaults when none were given.
fn counts(name: &str, given: Option<&[String]>, default: &[usize]) -> Result<Vec<usize>> {
    match given {
        Some(texts) => texts.iter().map(|t| count(name, t)).collect(),
        None => Ok(default.to_vec()),
    }
}

/// A rayon pool of `threads` threads (the run's parallel loops use it via `install`).
fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Output(format!("thread pool: {e}")))
}

/// Runs `run` on `pool` as the CLI runs a single run: on one of its workers, the others kept
/// awake (`study::awake`), so that a benchmark times what a user's run costs.
fn run_on<R: Send>(pool: &rayon::ThreadPool, run: impl FnOnce() -> R + Send) -> R {
    pool.install(|| crate::study::awake::with_workers_awake(run))
}

/// Resets the kernel's peak-RSS mark of this process (Linux: "5" to /proc/self/clear_refs) and
/// the heap's peak count, so the next `peak_rss_mb` and `heap::peak_mb` are the peaks of one
/// configuration. The first is silently a no-op elsewhere.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    heap::reset_peak();
}

/// Peak resident set size of this process since the last reset (VmHWM), MB; NaN where /proc is
/// unavailable.
fn peak_rss_mb() -> f64 {
    status_field("/proc/self/status", "VmHWM:").map_or(f64::NAN, |kb| kb / 1024.0)
}

/// CPU time this process has used so far (user + system, all threads), s; NaN where /proc
/// is unavailable. Rates per CPU second are per-core rates even on a loaded machine, where
/// wall-clock rates fall with the share of the cores the run gets.
fn cpu_seconds() -> f64 {
    // /proc/self/stat: fields 14 and 15 (utime, stime) in clock ticks of 1/100 s (USER_HZ on
    // Linux); the fields are counted after the parenthesized command name.
    let ticks = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|t| {
            let rest = &t[t.rfind(')')? + 1..];
            let mut fields = rest.split_whitespace().skip(11);
            let user: f64 = fields.next()?.parse().ok()?;
            let system: f64 = fields.next()?.parse().ok()?;
            Some(user + system)
        });
    ticks.map_or(f64::NAN, |t| t / 100.0)
}

/// A "key: number ..." line of a /proc file.
fn status_field(path: &str, key: &str) -> Option<f64> {
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    line[key.len()..].split_whitespace().next()?.parse().ok()
}

/// The CPU model and logical core count, for the record.
fn machine() -> serde_json::Value {
    let cpu = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split(':').nth(1))
            .map(|s| s.trim().to_string())
    });
    json!({
        "cpu": cpu,
        "logical_cores": std::thread::available_parallelism().map(|n| n.get()).ok(),
    })
}
