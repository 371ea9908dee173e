//! `magopt blast`: one blast run (spec blast.md). Its physics flags are made from the `blast`
//! parameter declarations (`cli::params`); defaults are the source's non-interacting example.

use clap::{ArgMatches, Args};

use super::params::Given;
use super::run::{single, RunArgs};
use crate::models::blast::study::BlastModel;
use crate::models::blast::BlastParams;
use crate::study::records::RunRecord;
use crate::Result;

/// `magopt blast` options besides the model parameters.
#[derive(Debug, Args)]
pub struct BlastArgs {
    /// Shorthand for --interactions all (the interacting model, integrated with the adaptive
    /// trapezoidal rule C9–C10); --interactions, when given, wins.
    #[arg(long)]
    interacting: bool,
    #[command(flatten)]
    run: RunArgs,
}

/// One blast run.
pub fn run_blast(matches: &ArgMatches, args: &BlastArgs) -> Result<i32> {
    let extra = if args.interacting {
        vec![Given {
            flag: "--interacting".into(),
            ..Given::new("interactions", "all")
        }]
    } else {
        Vec::new()
    };
    single(&BlastModel, matches, &extra, &args.run, print_summary)
}

fn print_summary(params: &BlastParams, record: &RunRecord) {
    let result = &record.result;
    let m = |name: &str| result.metric(name).unwrap_or(f64::NAN);
    println!(
        "blast: N = {}, |B| = {} T, q/m = {} C/kg, W = {} J, {} s, interactions: {}",
        params.particles,
        params.field_strength,
        params.charge_per_mass,
        params.energy,
        params.duration,
        params.interactions.label()
    );
    println!(
        "semi-axes (gyration): along B {:.4} m, across B {:.4} m, aspect ratio {:.3}",
        m("semi_axis_along_B_m"),
        m("semi_axis_across_B_m"),
        m("aspect_ratio")
    );
    println!(
        "extreme particles: along B {:.4} m, across B {:.4} m; mean radius {:.4} m",
        m("extent_along_B_m"),
        m("extent_across_B_m"),
        m("mean_radius_m")
    );
    println!(
        "kinetic energy {:.4e} J; {} steps ({} rejected), Δt {:.2e}–{:.2e} s; {:.2} s wall",
        m("kinetic_energy_J"),
        m("steps"),
        m("rejected_steps"),
        m("min_time_step_s"),
        m("max_time_step_s"),
        result.wall_time_s
    );
    if params.interactions.any() {
        println!(
            "bonds {}, clusters {}, largest cluster {} particles, {:.2} iterations per step",
            m("bonds"),
            m("clusters"),
            m("largest_cluster"),
            m("mean_iterations")
        );
    }
    if let Some(single) = result.metric("near_field_single_precision_fraction") {
        println!(
            "near field over all pairs: {:.1} % of its evaluations in single precision",
            100.0 * single
        );
    }
}
