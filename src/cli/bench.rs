//! `magopt bench align`: one full DEM run (settling, then alignment to the target) per particle
//! count and thread count, reporting the settling time, the alignment stage's throughput in
//! particle-steps per second, and the process's peak memory. Threads act inside the run: the
//! packing's force loop and, from `parallel_from` particles on, the coloured Gauss–Seidel sweep.
//! (Sweeps and optimizations parallelize across replicates instead.)

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
    /// The 2D structure analysis (Voronoi, n5/n6/n7, Ψ6, regularity) of --points jittered
    /// lattice points.
    Analyze,
    /// One full compression cycle of the mono-disperse bed (dry friction, defaults).
    Bed,
}

/// `magopt bench` options.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to benchmark.
    #[arg(value_enum, default_value = "align")]
    target: Target,
    /// Particle counts, comma-separated [default: 1000,10000 for align, 368 for bed].
    #[arg(long, value_delimiter = ',')]
    particles: Option<Vec<String>>,
    /// Thread counts, comma-separated.
    #[arg(long, default_value = "1,2", value_delimiter = ',')]
    threads: Vec<String>,
    /// Cap on alignment steps per run (the run stops earlier at A = 0.95).
    #[arg(long, default_value_t = 1000)]
    max_steps: usize,
    /// `bench analyze`: point counts, comma-separated.
    #[arg(long, default_value = "10000,100000", value_delimiter = ',')]
    points: Vec<String>,
    /// bed: neighbour methods, comma-separated (exact, cells, verlet).
    #[arg(long, default_value = "verlet,exact", value_delimiter = ',')]
    neighbors: Vec<String>,
    /// bed: piston speed (bare number: mm/s); faster means fewer steps per cycle.
    #[arg(long, default_value = "5.63mm/s")]
    velocity: String,
}

/// Runs the benchmark and prints one line per (N, threads).
pub fn run(db: &MaterialDb, args: &BenchArgs) -> Result<()> {
    match args.target {
        Target::Analyze => return run_analyze(args),
        Target::Bed => return bed(args),
        Target::Align => {}
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
    let default = ["1000".to_string(), "10000".to_string()];
    for n_text in args.particles.as_deref().unwrap_or(&default) {
        let n = count("particles", n_text)?;
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

/// `magopt bench bed`: one full cycle per (N, neighbour method, threads).
fn bed(args: &BenchArgs) -> Result<()> {
    use crate::models::bed::study::BedModel;
    use crate::study::model::StudyModel;
    let model = BedModel::cycle();
    println!(
        "bed: mono-disperse cycle (dry friction, φ 0.12 → 0.34 → 0.12), piston {}",
        args.velocity
    );
    println!(
        "{:>7} {:>9} {:>7} {:>9} {:>10} {:>10} {:>16} {:>11} {:>13}",
        "N",
        "neighbors",
        "threads",
        "steps",
        "wall (s)",
        "μs/step",
        "particle-steps/s",
        "F_max (N)",
        "peak RSS (MB)"
    );
    let default = ["368".to_string()];
    for n_text in args.particles.as_deref().unwrap_or(&default) {
        for method in &args.neighbors {
            for t_text in &args.threads {
                let mut params = model.defaults();
                for (name, value) in [
                    ("particles", n_text),
                    ("neighbors", method),
                    ("piston_speed", &args.velocity),
                ] {
                    let v = model
                        .spec(name)?
                        .parse(&toml::Value::String(value.clone()))?;
                    model.set(&mut params, name, &v)?;
                }
                params.snapshots = false;
                model.validate(&params)?;
                let threads = count("threads", t_text)?;
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| Error::Output(format!("thread pool: {e}")))?;
                let o = pool.install(|| model.outcome(&params, 1, &|_| {}));
                let n = params.particle_count();
                println!(
                    "{n:>7} {method:>9} {threads:>7} {:>9} {:>10.2} {:>10.2} {:>16.3e} {:>11.3} {:>13.1}{}",
                    o.steps,
                    o.wall_time_s,
                    1e6 * o.wall_time_s / o.steps as f64,
                    (o.steps * n) as f64 / o.wall_time_s,
                    o.max_force.unwrap_or(f64::NAN),
                    peak_rss_mb(),
                    o.failure.map(|r| format!("  FAILED: {r}")).unwrap_or_default()
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

/// `magopt bench analyze`: wall time of `structure::analyze` (tessellation, side counts, Ψ6,
/// regularity) on a triangular lattice with 10 % jitter, best of three runs.
fn run_analyze(args: &BenchArgs) -> Result<()> {
    use nalgebra::Vector2;
    use rand::{RngExt, SeedableRng};
    println!("analyze: triangular lattice, uniform jitter ±0.1 spacing, best of 3 runs");
    println!(
        "{:>9} {:>13} {:>8} {:>13}",
        "points", "cells counted", "n6", "analyze (s)"
    );
    for text in &args.points {
        let n = count("points", text)?;
        let side = (n as f64).sqrt().ceil() as usize;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let points: Vec<Vector2<f64>> = (0..n)
            .map(|k| {
                let (r, c) = ((k / side) as f64, (k % side) as f64);
                let jitter = Vector2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                Vector2::new(c + 0.5 * (r % 2.0), r * 0.75f64.sqrt()) + 0.2 * jitter
            })
            .collect();
        let mut best = f64::INFINITY;
        let mut metrics = None;
        for _ in 0..3 {
            let started = Instant::now();
            metrics = Some(crate::analysis::structure::analyze(&points)?);
            best = best.min(started.elapsed().as_secs_f64());
        }
        let m = metrics.expect("three runs");
        println!("{n:>9} {:>13} {:>8.4} {best:>13.3}", m.cells_counted, m.n6);
    }
    Ok(())
}
