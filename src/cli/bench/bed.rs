//! `magopt bench bed`: one full compression cycle per (N, neighbour method, threads).

use serde_json::json;

use super::{count, counts, peak_rss_mb, pool, reset_peak_rss, BenchArgs};
use crate::models::bed::study::BedModel;
use crate::study::model::StudyModel;
use crate::Result;

/// `magopt bench bed`: one full cycle per (N, neighbour method, threads).
pub(super) fn run(args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
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
    let mut rows = Vec::new();
    for n in counts("particles", args.particles.as_deref(), &[368])? {
        for method in &args.neighbors {
            for t_text in &args.threads {
                let mut params = model.defaults();
                for (name, value) in [
                    ("particles", &n.to_string()),
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
                reset_peak_rss();
                let o = pool(threads)?.install(|| model.outcome(&params, 1, &|_| {}));
                let n = params.particle_count();
                println!(
                    "{n:>7} {method:>9} {threads:>7} {:>9} {:>10.2} {:>10.2} {:>16.3e} {:>11.3} {:>13.1}{}",
                    o.steps,
                    o.wall_time_s,
                    1e6 * o.wall_time_s / o.steps as f64,
                    (o.steps * n) as f64 / o.wall_time_s,
                    o.max_force.unwrap_or(f64::NAN),
                    peak_rss_mb(),
                    o.failure
                        .as_ref()
                        .map(|r| format!("  FAILED: {r}"))
                        .unwrap_or_default()
                );
                rows.push(json!({
                    "particles": n,
                    "neighbors": method,
                    "threads": threads,
                    "steps": o.steps,
                    "wall_s": o.wall_time_s,
                    "particle_steps_per_s": (o.steps * n) as f64 / o.wall_time_s,
                    "max_piston_force_N": o.max_force,
                    "failure": o.failure,
                    "peak_rss_mb": peak_rss_mb(),
                }));
            }
        }
    }
    Ok(rows)
}
