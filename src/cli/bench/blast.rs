//! `magopt bench blast`: the source's non-interacting example (Boris–Strang, 10⁴ steps) and
//! the interacting example (adaptive trapezoidal rule; near field exact or Barnes–Hut) per
//! particle count and thread count: wall time, steps and particle-steps per second, and for
//! the exact near field the pairs summed per second (N(N − 1)/2 per force evaluation), also
//! per CPU second (per core on a loaded machine).

use serde_json::json;

use super::{count, counts, cpu_seconds, peak_rss_mb, pool, reset_peak_rss, BenchArgs};
use crate::models::blast::{run as run_blast, BlastParams, Interactions};
use crate::units::{parse_quantity, Dimension};
use crate::{Error, Result};

pub(super) fn run(args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
    let duration = parse_quantity(&args.interacting_duration, Dimension::Time, "s")
        .map_err(|e| Error::input(format!("--interacting-duration: {e}")))?;
    println!(
        "blast: the source's examples (B = 10 T along x, 10 C/kg, W = 10 kJ, R_0 = 1 m, R = 0.05 m); near field θ = {}",
        args.near_field_theta
    );
    println!(
        "{:>6} {:>7} {:>12} {:>9} {:>8} {:>9} {:>8} {:>10} {:>16} {:>12} {:>13}",
        "N",
        "threads",
        "model",
        "time (s)",
        "steps",
        "rejected",
        "evals",
        "wall (s)",
        "particle-steps/s",
        "pairs/s",
        "peak RSS (MB)"
    );
    let mut rows = Vec::new();
    for n in counts("particles", args.particles.as_deref(), &[2000])? {
        for t_text in &args.threads {
            let threads = count("threads", t_text)?;
            let pool = pool(threads)?;
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
                reset_peak_rss();
                let cpu_start = cpu_seconds();
                let o = pool.install(|| run_blast(&p, 1, &|_| {}, None))?;
                let cpu_s = cpu_seconds() - cpu_start;
                let label = if interacting { "interacting" } else { "free" };
                let rate = (o.stats.steps * n) as f64 / o.wall_time_s;
                let exact = interacting && p.near_field.theta == 0.0;
                let pair_count = (o.stats.evaluations * n * (n - 1) / 2) as f64;
                let pairs = exact.then_some(pair_count / o.wall_time_s);
                println!(
                    "{n:>6} {threads:>7} {label:>12} {:>9} {:>8} {:>9} {:>8} {:>10.3} {rate:>16.3e} {:>12} {:>13.1}{}",
                    p.duration,
                    o.stats.steps,
                    o.stats.rejected,
                    o.stats.evaluations,
                    o.wall_time_s,
                    pairs.map_or("–".into(), |r| format!("{r:.3e}")),
                    peak_rss_mb(),
                    o.failure
                        .as_ref()
                        .map_or(String::new(), |f| format!("  failed: {f}"))
                );
                rows.push(json!({
                    "particles": n,
                    "threads": threads,
                    "model": label,
                    "simulated_s": p.duration,
                    "steps": o.stats.steps,
                    "rejected": o.stats.rejected,
                    "wall_s": o.wall_time_s,
                    "particle_steps_per_s": rate,
                    "force_evaluations": o.stats.evaluations,
                    "near_field_pairs_per_s": pairs,
                    "cpu_s": cpu_s,
                    "near_field_pairs_per_cpu_s": exact.then_some(pair_count / cpu_s),
                    "failure": o.failure,
                    "peak_rss_mb": peak_rss_mb(),
                }));
            }
        }
    }
    Ok(rows)
}
