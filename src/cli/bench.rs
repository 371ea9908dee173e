//! `magopt bench align`: one full DEM run (settling, then alignment to the target) per particle
//! count and thread count, reporting the settling time, the alignment stage's throughput in
//! particle-steps per second, and the process's peak memory. Threads act inside the run: the
//! packing's force loop and, from `parallel_from` particles on, the coloured Gauss–Seidel sweep.
//! (Sweeps and optimizations parallelize across replicates instead.)
//!
//! `magopt bench blast`: the source's non-interacting example (Boris–Strang, 10⁴ steps) and
//! the interacting example (adaptive trapezoidal rule, exact all-pairs near field) per particle
//! count and thread count: wall time, steps and particle-steps per second.

use clap::{Args, ValueEnum};
use std::time::Instant;

use super::count;
use crate::materials::MaterialDb;
use crate::models::align::dem::{self, Packing};
use crate::models::align::AlignParams;
use crate::units::si_per_unit;
use crate::{Error, Result};

/// What to benchmark.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum Target {
    /// The DEM alignment stage (Sr ferrite, 40 kOe, μ = 0.2, P = 0.5 atm).
    Align,
    /// The blast model: non-interacting and interacting examples.
    Blast,
}

/// `magopt bench` options.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to benchmark.
    #[arg(value_enum, default_value = "align")]
    target: Target,
    /// Particle counts, comma-separated [default: 1000,10000 for align, 2000 for blast].
    #[arg(long, value_delimiter = ',')]
    particles: Vec<String>,
    /// Thread counts, comma-separated.
    #[arg(long, default_value = "1,2", value_delimiter = ',')]
    threads: Vec<String>,
    /// Cap on alignment steps per run (the run stops earlier at A = 0.95).
    #[arg(long, default_value_t = 1000)]
    max_steps: usize,
    /// Simulated time of the interacting blast example (s, ms; bare number: s).
    #[arg(long, default_value = "1s")]
    interacting_duration: String,
    /// Barnes–Hut opening angle of the interacting blast example's near field (0 = exact).
    #[arg(long, default_value_t = 0.0)]
    near_field_theta: f64,
}

/// Runs the benchmark and prints one line per (N, threads).
pub fn run(db: &MaterialDb, args: &BenchArgs) -> Result<()> {
    if let Target::Blast = args.target {
        return blast(args);
    }
    let material = db.get("srfe12o19")?.clone();
    println!("align: Sr ferrite, 40 kOe, μ = 0.2, P = 0.5 atm, target A = 0.95, settled packing");
    println!(
        "{:>8} {:>7} {:>11} {:>12} {:>7} {:>8} {:>11} {:>16} {:>13}",
        "N",
        "threads",
        "settle (s)",
        "settle steps",
        "steps",
        "sweeps",
        "align (s)",
        "particle-steps/s",
        "peak RSS (MB)"
    );
    for n_text in particle_counts(args, &["1000", "10000"]) {
        let n = count("particles", &n_text)?;
        for t_text in &args.threads {
            let threads = count("threads", t_text)?;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| Error::Output(format!("thread pool: {e}")))?;
            let mut params =
                AlignParams::paper_defaults(material.clone(), 40.0 * si_per_unit("kOe"));
            params.particles = n;
            params.max_time = args.max_steps as f64 * 1e9; // bounded by --max-steps below
            let started = Instant::now();
            let packing = pool
                .install(|| Packing::generate(&params.packing(), 1))
                .map_err(Error::Output)?;
            let settle = started.elapsed().as_secs_f64();
            params.max_time = (args.max_steps as f64 - 0.5) * dem::time_step_s(&params, &packing);
            let outcome = pool.install(|| dem::align(&params, &packing));
            let rate = (outcome.steps * n) as f64 / outcome.wall_time_s;
            println!(
                "{n:>8} {threads:>7} {settle:>11.2} {:>12} {:>7} {:>8} {:>11.2} {rate:>16.3e} {:>13.1}",
                packing.steps.iter().sum::<usize>(),
                outcome.steps,
                outcome.solver_sweeps,
                outcome.wall_time_s,
                peak_rss_mb()
            );
        }
    }
    Ok(())
}

/// The --particles list, or the target's default.
fn particle_counts(args: &BenchArgs, default: &[&str]) -> Vec<String> {
    if args.particles.is_empty() {
        default.iter().map(|s| s.to_string()).collect()
    } else {
        args.particles.clone()
    }
}

/// `magopt bench blast`.
fn blast(args: &BenchArgs) -> Result<()> {
    use crate::models::blast::{run, BlastParams, Interactions};
    let duration = crate::units::parse_quantity(
        &args.interacting_duration,
        crate::units::Dimension::Time,
        "s",
    )
    .map_err(|e| Error::input(format!("--interacting-duration: {e}")))?;
    println!(
        "blast: the source's examples (B = 10 T along x, 10 C/kg, W = 10 kJ, R_0 = 1 m, R = 0.05 m); near field θ = {}",
        args.near_field_theta
    );
    println!(
        "{:>6} {:>7} {:>12} {:>9} {:>8} {:>9} {:>10} {:>16} {:>13}",
        "N",
        "threads",
        "model",
        "time (s)",
        "steps",
        "rejected",
        "wall (s)",
        "particle-steps/s",
        "peak RSS (MB)"
    );
    for n_text in particle_counts(args, &["2000"]) {
        let n = count("particles", &n_text)?;
        for t_text in &args.threads {
            let threads = count("threads", t_text)?;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| Error::Output(format!("thread pool: {e}")))?;
            for interacting in [false, true] {
                let mut p = BlastParams::source_example();
                p.particles = n;
                p.samples = 10;
                if interacting {
                    p.interactions = Interactions::all();
                    p.duration = duration;
                    p.near_field.theta = args.near_field_theta;
                }
                p.validate()?;
                let o = pool.install(|| run(&p, 1, &[]))?;
                let label = if interacting { "interacting" } else { "free" };
                println!(
                    "{n:>6} {threads:>7} {label:>12} {:>9} {:>8} {:>9} {:>10.3} {:>16.3e} {:>13.1}{}",
                    p.duration,
                    o.stats.steps,
                    o.stats.rejected,
                    o.wall_time_s,
                    (o.stats.steps * n) as f64 / o.wall_time_s,
                    peak_rss_mb(),
                    o.failure.map_or(String::new(), |f| format!("  failed: {f}"))
                );
            }
        }
    }
    Ok(())
}

/// Peak resident set size of this process (VmHWM), MB; NaN where /proc is unavailable.
fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}
