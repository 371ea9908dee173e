//! `magopt bench bed`: one full compression cycle per (N, neighbour method, far-field interval,
//! threads). Besides particle-steps per second each row gives what the pair sums cost:
//! `pairs_per_particle`, the step-mean number of partners closer than the cut-off r_c (N − 1
//! for exact sums); `list_entries_per_particle`, the partners the kernel loops over (list
//! skin included; each unordered pair is evaluated from both sides, the lists being full);
//! `pair_evaluations_per_s`, unordered pairs inside r_c summed per second, each counted once
//! (N × pairs_per_particle / 2 per step: the count LAMMPS with Newton's third law on
//! evaluates, bench/lammps/bed-pairs.sh); `kernel_pair_terms_per_s`, the ordered list entries
//! the kernel evaluated per second; and per-CPU-second rates (per core on a loaded machine).
//! A method printed with `+t` has the mean-field tail beyond r_c (the default with lists).

use serde_json::json;

use super::super::params::Given;
use super::{
    count, counts, cpu_seconds, heap, peak_rss_mb, pool, reset_peak_rss, run_on, BenchArgs,
};
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
        "{:>7} {:>9} {:>3} {:>7} {:>9} {:>10} {:>10} {:>16} {:>8} {:>10} {:>11} {:>13}",
        "N",
        "neighbors",
        "K",
        "threads",
        "steps",
        "wall (s)",
        "μs/step",
        "particle-steps/s",
        "pairs/p",
        "pairs/s",
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
                        ("cutoff", &args.cutoff),
                        ("list_radius", &args.list_radius),
                        ("time_step_factor", &args.time_step_factor),
                        ("max_time_step", &args.max_time_step),
                        ("tail_correction", &args.tail_correction),
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
    let cpu_start = cpu_seconds();
    let o = run_on(&pool(threads)?, || model.outcome(&params, 1, &|_| {}));
    let cpu_s = cpu_seconds() - cpu_start;
    let n = params.particle_count();
    let tail = params.tail_correction.applies(params.neighbors);
    let (method, k) = (
        format!("{:?}", params.neighbors).to_lowercase(),
        params.far_field_interval,
    );
    let work = &o.pair_work;
    let per_particle = |sum: u64| sum as f64 / (work.steps as f64 * n as f64);
    // unordered pairs inside r_c, each once
    let pair_evaluations = 0.5 * work.pairs_within_cutoff as f64;
    println!(
        "{n:>7} {:>9} {k:>3} {threads:>7} {:>9} {:>10.2} {:>10.2} {:>16.3e} {:>8.2} {:>10.3e} {:>11.3} {:>13.1}{}",
        if tail { format!("{method}+t") } else { method.clone() },
        o.steps,
        o.wall_time_s,
        1e6 * o.wall_time_s / o.steps as f64,
        (o.steps * n) as f64 / o.wall_time_s,
        per_particle(work.pairs_within_cutoff),
        pair_evaluations / o.wall_time_s,
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
        "tail_correction": tail,
        "cutoff_D": params.cutoff.diameters(params.reference_diameter()),
        "list_radius_D": params.list_radius.diameters(params.reference_diameter()),
        "cell_width_D": params.cell().0 / params.reference_diameter(),
        "time_step_factor": params.time_step_factor(),
        "max_time_step_s": params.max_time_step,
        "threads": threads,
        "steps": o.steps,
        "wall_s": o.wall_time_s,
        "particle_steps_per_s": (o.steps * n) as f64 / o.wall_time_s,
        "cpu_s": cpu_s,
        "particle_steps_per_cpu_s": (o.steps * n) as f64 / cpu_s,
        "list_builds": o.list_builds,
        "mean_packing_fraction": work.mean_packing_fraction(),
        "pairs_per_particle": per_particle(work.pairs_within_cutoff),
        "list_entries_per_particle": per_particle(work.pair_terms),
        "pair_evaluations_per_s": pair_evaluations / o.wall_time_s,
        "pair_evaluations_per_cpu_s": pair_evaluations / cpu_s,
        "kernel_pair_terms_per_s": work.pair_terms as f64 / o.wall_time_s,
        "max_piston_force_N": o.max_force,
        "cycle_work_J": o.cycle_work,
        "failure": o.failure,
        "peak_rss_mb": peak_rss_mb(),
        "peak_heap_mb": heap::peak_mb(),
    }))
}
