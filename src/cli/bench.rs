//! `magopt bench <model>`: throughput and peak memory of a model's runs, one row per (N,
//! threads). One function per model; each prints a table and returns its rows as JSON, which
//! `--out DIR` writes to `DIR/bench-<model>.json` (results/bench/README.md).

use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

use super::count;
use crate::materials::MaterialDb;
use crate::models::align::dem::{self, Packing};
use crate::models::align::{AlignParams, RestMeasure};
use crate::output::atomic;
use crate::units::si_per_unit;
use crate::{Error, Result};

/// What to benchmark.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum Target {
    /// The DEM align model: settling, then alignment (Sr ferrite, 40 kOe, μ = 0.2,
    /// P = 0.5 atm) until A = 0.95 or --max-steps.
    Align,
}

/// `magopt bench` options.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to benchmark.
    #[arg(value_enum, default_value = "align")]
    target: Target,
    /// Particle counts, comma-separated.
    #[arg(long, default_value = "1000,10000", value_delimiter = ',')]
    particles: Vec<String>,
    /// Thread counts, comma-separated.
    #[arg(long, default_value = "1,2", value_delimiter = ',')]
    threads: Vec<String>,
    /// Cap on alignment steps per run (the run stops earlier at A = 0.95).
    #[arg(long, default_value_t = 1000)]
    max_steps: usize,
    /// Settling rest criterion (align): rms (root-mean-square net force; the model's default)
    /// or max (largest net force; its cost explodes with N).
    #[arg(long, value_enum, default_value = "rms")]
    rest: RestMeasure,
    /// Also write the rows as JSON to DIR/bench-<model>.json.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// Runs the benchmark, prints one line per (N, threads) and writes the JSON if asked.
pub fn run(db: &MaterialDb, args: &BenchArgs) -> Result<()> {
    let mut sizes = Vec::new();
    for text in &args.particles {
        sizes.push(count("particles", text)?);
    }
    let mut threads = Vec::new();
    for text in &args.threads {
        threads.push(count("threads", text)?);
    }
    if let Some(dir) = &args.out {
        atomic::prepare_output_dir(dir)?;
    }
    let (name, rows) = match args.target {
        Target::Align => ("align", bench_align(db, args, &sizes, &threads)?),
    };
    if let Some(dir) = &args.out {
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

/// The align model: for each (N, threads) a settled packing (seed 1), then the alignment stage.
/// Threads act inside the run: the packing's force loop and, from `parallel_from` particles on,
/// the coloured Gauss–Seidel sweep. (Sweeps and optimizations parallelize across replicates.)
fn bench_align(
    db: &MaterialDb,
    args: &BenchArgs,
    sizes: &[usize],
    threads: &[usize],
) -> Result<Vec<serde_json::Value>> {
    let material = db.get("srfe12o19")?.clone();
    println!(
        "align: Sr ferrite, 40 kOe, μ = 0.2, P = 0.5 atm, target A = 0.95, rest criterion {:?}",
        args.rest
    );
    println!(
        "{:>7} {:>3} {:>9} {:>8} {:>11} {:>6} {:>7} {:>9} {:>10} {:>8} {:>7}",
        "N",
        "thr",
        "settle s",
        "steps",
        "p-steps/s",
        "steps",
        "sweeps",
        "align s",
        "p-steps/s",
        "A_final",
        "MB"
    );
    let mut rows = Vec::new();
    for &n in sizes {
        for &t in threads {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::Output(format!("thread pool: {e}")))?;
            let mut params =
                AlignParams::paper_defaults(material.clone(), 40.0 * si_per_unit("kOe"));
            params.particles = n;
            params.numerics.rest_measure = args.rest;
            reset_peak_rss();
            let started = Instant::now();
            let packing = pool
                .install(|| Packing::generate(&params.packing(), 1))
                .map_err(Error::Output)?;
            let settle_s = started.elapsed().as_secs_f64();
            let settle_steps: usize = packing.steps.iter().sum();
            params.max_time = (args.max_steps as f64 - 0.5) * dem::time_step_s(&params, &packing);
            let outcome = pool.install(|| dem::align(&params, &packing));
            let settle_rate = (settle_steps * n) as f64 / settle_s;
            let align_rate = (outcome.steps * n) as f64 / outcome.wall_time_s;
            let peak_mb = peak_rss_mb();
            println!(
                "{n:>7} {t:>3} {settle_s:>9.1} {settle_steps:>8} {settle_rate:>11.3e} {:>6} {:>7} {:>9.2} {align_rate:>10.3e} {:>8.4} {peak_mb:>7.1}",
                outcome.steps,
                outcome.solver_sweeps,
                outcome.wall_time_s,
                outcome.final_alignment,
            );
            rows.push(json!({
                "particles": n,
                "threads": t,
                "rest_measure": args.rest,
                "settle_s": settle_s,
                "settle_steps": packing.steps,
                "settle_particle_steps_per_s": settle_rate,
                "align_steps": outcome.steps,
                "align_solver_sweeps": outcome.solver_sweeps,
                "align_s": outcome.wall_time_s,
                "align_particle_steps_per_s": align_rate,
                "alignment_time_s": outcome.alignment_time_s,
                "final_alignment": outcome.final_alignment,
                "packing_fraction": outcome.packing_fraction,
                "peak_rss_mb": peak_mb,
            }));
        }
    }
    Ok(rows)
}

/// Resets the kernel's peak-RSS mark of this process (Linux: "5" to /proc/self/clear_refs), so
/// the next `peak_rss_mb` is the peak of one configuration. Silently a no-op elsewhere.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Peak resident set size of this process since the last reset (VmHWM), MB; NaN where /proc is
/// unavailable.
fn peak_rss_mb() -> f64 {
    status_field("/proc/self/status", "VmHWM:").map_or(f64::NAN, |kb| kb / 1024.0)
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
