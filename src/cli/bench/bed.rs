//! `magopt bench bed`: one full compression cycle per (N, neighbour method, far-field interval,
//! threads).

use serde_json::json;

use super::super::params::Given;
use super::{count, counts, peak_rss_mb, pool, reset_peak_rss, BenchArgs};
use crate::models::bed::study::BedModel;
use crate::Result;

/// `magopt bench bed`: one full cycle per (N, neighbour method, far-field interval, threads).
pub(super) fn run(args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
    let model = BedModel::cycle();
    println!(
        "bed: mono-disperse cycle (dry friction, the source protocol's heights: docs/bed-protocol.md), piston {}",
        args.velocity
    );
    println!(
        "{:>7} {:>9} {:>3} {:>7} {:>9} {:>10} {:>10} {:>16} {:>11} {:>13}",
        "N",
        "neighbors",
        "K",
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
            for k in &args.far_field_interval {
                if method != "verlet" && k != "1" {
                    continue;
                }
                for t_text in &args.threads {
                    let mut settings = vec![
                        ("particles", n.to_string()),
                        ("neighbors", method.clone()),
                        ("piston_speed", args.velocity.clone()),
                        ("far_field_interval", k.clone()),
                    ];
                    for (name, value) in [
                        ("list_radius", &args.list_radius),
                        ("time_step_factor", &args.time_step_factor),
                    ] {
                        if let Some(v) = value {
                            settings.push((name, v.clone()));
                        }
                    }
                    rows.push(row(&model, &settings, count("threads", t_text)?)?);
                }
            }
        }
    }
    Ok(rows)
}

/// One cycle with these settings on a pool of `threads`: printed, and returned as JSON.
fn row(
    model: &BedModel,
    settings: &[(&'static str, String)],
    threads: usize,
) -> Result<serde_json::Value> {
    let given: Vec<Given> = settings.iter().map(|(n, t)| Given::new(n, t)).collect();
    let (mut params, _) = super::super::params::setup(model, &given)?;
    params.snapshots = false;
    reset_peak_rss();
    let o = pool(threads)?.install(|| model.outcome(&params, 1, &|_| {}));
    let n = params.particle_count();
    let (method, k) = (
        format!("{:?}", params.neighbors).to_lowercase(),
        params.far_field_interval,
    );
    println!(
        "{n:>7} {:>9} {k:>3} {threads:>7} {:>9} {:>10.2} {:>10.2} {:>16.3e} {:>11.3} {:>13.1}{}",
        method,
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
    Ok(json!({
        "particles": n,
        "neighbors": method,
        "far_field_interval": k,
        "list_radius_D": params.list_radius.diameters(params.reference_diameter()),
        "time_step_factor": params.time_step_factor,
        "threads": threads,
        "steps": o.steps,
        "wall_s": o.wall_time_s,
        "particle_steps_per_s": (o.steps * n) as f64 / o.wall_time_s,
        "max_piston_force_N": o.max_force,
        "cycle_work_J": o.cycle_work,
        "failure": o.failure,
        "peak_rss_mb": peak_rss_mb(),
    }))
}
