//! `magopt bed` (one compression cycle) and `magopt damper` (one free-falling piston run). Their
//! physics flags are made from the `bed` parameter declarations (`cli::params`).

use clap::{ArgMatches, Args};

use super::params::Given;
use super::run::{single, RunArgs};
use crate::models::bed::study::BedModel;
use crate::models::bed::{BedParams, STRUCTURE_METRICS, STRUCTURE_STAGES};
use crate::study::records::RunRecord;
use crate::Result;

/// Options of `bed` and `damper` besides the model parameters. Without --preset, giving
/// --mixing-ratio or --aspect-ratio selects the bidisperse preset.
#[derive(Debug, Args)]
pub struct BedArgs {
    /// Shorthand for --gravity 0.
    #[arg(long)]
    no_gravity: bool,
    #[command(flatten)]
    run: RunArgs,
}

/// `magopt bed` or `magopt damper`.
pub fn run(matches: &ArgMatches, args: &BedArgs, damper: bool) -> Result<i32> {
    let model = if damper {
        BedModel::damper()
    } else {
        BedModel::cycle()
    };
    let given = |id: &str| matches.try_contains_id(id).unwrap_or(false);
    let mut extra = Vec::new();
    if given("mixing_ratio") || given("aspect_ratio") {
        extra.push(Given::new("preset", "bidisperse"));
    }
    if args.no_gravity {
        extra.push(Given {
            flag: "--no-gravity".into(),
            ..Given::new("gravity", "0")
        });
    }
    single(&model, matches, &extra, &args.run, |p, record| {
        summary(p, record, damper)
    })
}

fn summary(p: &BedParams, record: &RunRecord, damper: bool) {
    let r = &record.result;
    let m = |name: &str| r.metric(name);
    let (w, h) = p.cell();
    println!(
        "{} particles in a {w:.3} m × {h:.3} m cell, friction {:?}, {} steps (mean Δt {:.2e} s), \
         {:.1} s wall",
        p.particle_count(),
        p.friction,
        m("steps").unwrap_or(0.0),
        m("mean_time_step_s").unwrap_or(f64::NAN),
        r.wall_time_s
    );
    let show = |label: &str, name: &str, unit: &str| {
        if let Some(v) = m(name) {
            println!("{label}: {v:.4} {unit}");
        }
    };
    if damper {
        show("piston rest height", "damper_rest_height_m", "m");
    } else {
        show("max piston force F_max", "max_piston_force_N", "N");
        show(
            "force at maximum compression",
            "piston_force_at_max_compression_N",
            "N",
        );
        println!(
            "stroke {:.4} m, packing fraction at H_f {:.3}",
            m("stroke_m").unwrap_or(f64::NAN),
            m("max_packing_fraction").unwrap_or(f64::NAN)
        );
        show(
            "mean distance D̂ at compression start",
            "mean_distance_start_D",
            "⟨D⟩",
        );
        show("smallest D̂ during the cycle", "mean_distance_min_D", "⟨D⟩");
        show("D̂ at the end", "mean_distance_end_D", "⟨D⟩");
        show("energy dissipated over the cycle", "cycle_work_J", "J");
        for (names, (_, label)) in STRUCTURE_METRICS.iter().zip(STRUCTURE_STAGES) {
            let v: Vec<Option<f64>> = names.iter().map(|n| m(n)).collect();
            if let [Some(n5), Some(n6), Some(n7), Some(psi6), Some(reg), _, Some(cells), Some(all)] =
                v[..]
            {
                println!(
                    "structure at {label}: n5 {n5:.3}, n6 {n6:.3}, n7 {n7:.3}, Ψ6 {psi6:.3} \
                     (all particles {all:.3}), hexagon regularity {reg:.3}, {cells} cells counted"
                );
            }
        }
    }
    println!(
        "closest pair {:.3} ⟨D⟩_pair, closest wall {:.2} mm, closest to piston {:.2} mm",
        m("closest_pair_D").unwrap_or(f64::NAN),
        m("min_wall_distance_m").unwrap_or(f64::NAN) * 1e3,
        m("min_piston_distance_m").unwrap_or(f64::NAN) * 1e3
    );
}
