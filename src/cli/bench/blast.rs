//! `magopt bench blast`: the source's non-interacting example (Boris–Strang, 10⁴ steps) and
//! the interacting example (adaptive trapezoidal rule; near field exact or Barnes–Hut) per
//! particle count and thread count: wall time, steps and particle-steps per second, and for
//! the exact near field the pairs summed per second (N(N − 1)/2 per force evaluation), also
//! per CPU second (per core on a loaded machine). Each interacting row also gives its near
//! field's error against the exact double-precision sum on the run's final cloud, and the
//! wall time of each force stage (contacts, near field, bonds, gather, bond formation; the
//! rest is the integrator's own work), so a thread count's speed-up can be read stage by
//! stage. `--scale-cloud` grows the cloud and the blast energy with N, so that counts beyond
//! the source's 2000 keep its packing fraction and energy per particle.

use serde_json::json;

use super::{
    count, counts, cpu_seconds, heap, peak_rss_mb, pool, reset_peak_rss, run_on, BenchArgs,
};
use crate::models::blast::interact::{near_field_error, StageTimes};
use crate::models::blast::study::BlastModel;
use crate::models::blast::{run as run_blast, BlastParams, Interactions, NearFieldPrecision};
use crate::study::model::StudyModel;
use crate::units::{parse_quantity, Dimension};
use crate::{Error, Result};

pub(super) fn run(args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
    let duration = parse_quantity(&args.interacting_duration, Dimension::Time, "s")
        .map_err(|e| Error::input(format!("--interacting-duration: {e}")))?;
    let precisions = args
        .near_field_precision
        .iter()
        .map(|t| precision(t))
        .collect::<Result<Vec<_>>>()?;
    let cloud = if args.scale_cloud {
        "W = 5 J per particle, R_0 = (N/2000)^(1/3) m: the source's density and energy per particle"
    } else {
        "W = 10 kJ, R_0 = 1 m"
    };
    println!(
        "blast: the source's examples (B = 10 T along x, 10 C/kg, {cloud}, R = 0.05 m); near field θ = {}",
        args.near_field_theta
    );
    println!(
        "{:>6} {:>7} {:>19} {:>9} {:>8} {:>9} {:>8} {:>10} {:>16} {:>12} {:>13} {:>10}",
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
        "peak RSS (MB)",
        "NF error"
    );
    let mut rows = Vec::new();
    for n in counts("particles", args.particles.as_deref(), &[2000])? {
        for t_text in &args.threads {
            let threads = count("threads", t_text)?;
            let pool = pool(threads)?;
            let cases = std::iter::once(None).chain(precisions.iter().map(Some));
            for case in cases {
                let mut p = BlastParams::source_example();
                p.particles = n;
                p.samples = 10;
                if args.scale_cloud {
                    scale_cloud(&mut p);
                }
                let label = match case {
                    None => "free".to_string(),
                    Some(&(name, precision)) => {
                        p.interactions = Interactions::all();
                        p.duration = duration;
                        p.near_field.theta = args.near_field_theta;
                        p.near_field.precision = precision;
                        format!("interacting {name}")
                    }
                };
                rows.push(measure(&pool, &p, threads, &label)?);
            }
        }
    }
    Ok(rows)
}

/// One run of `p`: prints its line and returns its JSON row.
fn measure(
    pool: &rayon::ThreadPool,
    p: &BlastParams,
    threads: usize,
    label: &str,
) -> Result<serde_json::Value> {
    p.validate()?;
    let n = p.particles;
    reset_peak_rss();
    let cpu_start = cpu_seconds();
    let o = run_on(pool, || run_blast(p, 1, &|_| {}, None))?;
    let cpu_s = cpu_seconds() - cpu_start;
    let peak = peak_rss_mb();
    let interacting = p.interactions.near_field;
    let rate = (o.stats.steps * n) as f64 / o.wall_time_s;
    let exact = interacting && p.near_field.theta == 0.0;
    let pair_count = (o.stats.evaluations * n * (n - 1) / 2) as f64;
    let pairs = exact.then_some(pair_count / o.wall_time_s);
    let error = interacting.then(|| pool.install(|| near_field_error(p, &o.cloud)));
    println!(
        "{n:>6} {threads:>7} {label:>19} {:>9} {:>8} {:>9} {:>8} {:>10.3} {rate:>16.3e} {:>12} {peak:>13.1} {:>10}{}",
        p.duration,
        o.stats.steps,
        o.stats.rejected,
        o.stats.evaluations,
        o.wall_time_s,
        pairs.map_or("–".into(), |r| format!("{r:.3e}")),
        error.map_or("–".into(), |(_, rms)| format!("{rms:.1e}")),
        o.failure
            .as_ref()
            .map_or(String::new(), |f| format!("  failed: {f}"))
    );
    let stages = interacting.then(|| stage_row(&o.stage_times, o.wall_time_s));
    if let Some(stages) = &stages {
        let text: Vec<String> = stages
            .iter()
            .map(|(k, s)| format!("{} {s:.2}", k.replace('_', " ")))
            .collect();
        println!("{:>15} stages (s): {}", "", text.join(", "));
    }
    Ok(json!({
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
        "near_field_error_largest": error.map(|e| e.0),
        "near_field_error_rms": error.map(|e| e.1),
        "failure": o.failure,
        "peak_rss_mb": peak,
        "peak_heap_mb": heap::peak_mb(),
        "stage_wall_s": stages.map(|s| {
            s.into_iter()
                .map(|(k, s)| (k.to_string(), json!(s)))
                .collect::<serde_json::Map<_, _>>()
        }),
    }))
}

/// The force stages' wall times and the rest of `wall`, s, named as the JSON rows name them.
fn stage_row(t: &StageTimes, wall: f64) -> Vec<(&'static str, f64)> {
    let stages = t.named();
    let rest = wall - stages.iter().map(|(_, s)| s).sum::<f64>();
    stages.into_iter().chain([("rest", rest)]).collect()
}

/// Scales the source's cloud radius and blast energy to `p.particles`, keeping its packing
/// fraction and energy per particle (`--scale-cloud`).
fn scale_cloud(p: &mut BlastParams) {
    let source = BlastParams::source_example();
    let ratio = p.particles as f64 / source.particles as f64;
    p.cloud_radius = source.cloud_radius * ratio.cbrt();
    p.energy = source.energy * ratio;
}

/// The `--near-field-precision` value `text` with its name, parsed by the parameter's own
/// declaration (`near_field_precision` in the blast study model).
fn precision(text: &str) -> Result<(&str, NearFieldPrecision)> {
    let mut p = BlastParams::source_example();
    let raw = toml::Value::String(text.trim().to_string());
    BlastModel.set_from(
        &mut p,
        "near_field_precision",
        &raw,
        "--near-field-precision",
    )?;
    Ok((text.trim(), p.near_field.precision))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The source's own N keeps its cloud; eight times the particles fill twice the radius
    /// with eight times the energy (the same packing fraction and energy per particle).
    #[test]
    fn a_scaled_cloud_keeps_the_sources_density_and_energy_per_particle() {
        let source = BlastParams::source_example();
        let mut p = source.clone();
        scale_cloud(&mut p);
        assert_eq!(
            (p.cloud_radius, p.energy),
            (source.cloud_radius, source.energy)
        );
        p.particles = 8 * source.particles;
        scale_cloud(&mut p);
        assert_eq!(p.cloud_radius, 2.0 * source.cloud_radius);
        assert_eq!(p.energy, 8.0 * source.energy);
    }
}
