//! `magopt bench align`: throughput of the DEM alignment stage in particle-steps per second,
//! for several N and thread counts, and the process's peak memory. With T threads, T replicate
//! runs proceed concurrently (the parallelism magopt uses); the figure is total particle-steps
//! over wall time. The packing is a lattice stand-in (`Packing::lattice`) so that settling,
//! which is not what is measured, does not dominate at large N.

use clap::{Args, ValueEnum};
use rayon::prelude::*;
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
    /// Alignment steps per run.
    #[arg(long, default_value = "10")]
    steps: String,
}

/// Runs the benchmark and prints one line per (N, threads).
pub fn run(db: &MaterialDb, args: &BenchArgs) -> Result<()> {
    let Target::Align = args.target;
    let steps = count("steps", &args.steps)?;
    let material = db.get("srfe12o19")?.clone();
    println!("target: align (DEM alignment stage, Sr ferrite, 40 kOe, μ = 0.2, P = 0.5 atm, lattice packing)");
    println!("{:>9} {:>8} {:>16} {:>12} {:>14}", "N", "threads", "particle-steps/s", "wall (s)", "peak RSS (MB)");
    for n_text in &args.particles {
        let n = count("particles", n_text)?;
        for t_text in &args.threads {
            let threads = count("threads", t_text)?;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| Error::Output(format!("thread pool: {e}")))?;
            let mut params = AlignParams::paper_defaults(material.clone(), 40.0 * si_per_unit("kOe"));
            params.particles = n;
            let packings: Vec<Packing> = (0..threads).map(|r| Packing::lattice(&params.packing(), r as u64 + 1)).collect();
            params.max_time = (steps as f64 - 0.5) * dem::time_step_s(&params, &packings[0]);
            let started = Instant::now();
            let total: usize = pool.install(|| packings.par_iter().map(|p| dem::align(&params, p).steps * n).sum());
            let wall = started.elapsed().as_secs_f64();
            println!("{n:>9} {threads:>8} {:>16.3e} {wall:>12.2} {:>14.1}", total as f64 / wall, peak_rss_mb());
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
