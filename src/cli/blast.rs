//! `magopt blast`: one blast run (spec blast.md). Options go through the `blast` study
//! model's parameter table, so units and checks are the same as in study files.

use clap::Args;
use std::path::PathBuf;

use super::align::{preset, strip_name};
use super::command_line;
use crate::models::blast::study::BlastModel;
use crate::models::blast::{run, snapshot, BlastParams};
use crate::output::atomic;
use crate::study::model::StudyModel;
use crate::study::records::{self, RunRecord};
use crate::units::parse_quantity;
use crate::units::Dimension;
use crate::{Error, Result};

/// `magopt blast` options. Bare numbers are in the unit named in each help text; defaults are
/// the source's non-interacting example.
#[derive(Debug, Args)]
pub struct BlastArgs {
    /// Magnetic flux density |B| (T, mT; also Oe, kOe, A/m as μ0·H; bare number: T).
    #[arg(long, allow_hyphen_values = true, default_value = "10T")]
    field: String,
    /// Direction of B: x, y, z, -x, … or a vector "a,b,c" (dimensionless).
    #[arg(long, allow_hyphen_values = true, default_value = "x")]
    field_direction: String,
    /// Electric field strength E (V/m, kV/m, MV/m; bare number: V/m).
    #[arg(long, allow_hyphen_values = true, default_value = "0V/m")]
    electric_field: String,
    /// Direction of E: "field" (along B) or x, y, z, -x, … or "a,b,c".
    #[arg(long, allow_hyphen_values = true, default_value = "field")]
    electric_direction: String,
    /// Charge per mass q/m (C/kg, mC/kg, uC/kg; bare number: C/kg).
    #[arg(long, allow_hyphen_values = true, default_value = "10C/kg")]
    charge_per_mass: String,
    /// Fraction of particles carrying the opposite charge sign, in [0, 1].
    #[arg(long, allow_hyphen_values = true, default_value = "0")]
    negative_fraction: String,
    /// Detonation energy W (J, kJ, MJ; bare number: kJ).
    #[arg(long, allow_hyphen_values = true, default_value = "10kJ")]
    energy: String,
    /// Number of particles N.
    #[arg(long, allow_hyphen_values = true, default_value = "2000")]
    particles: String,
    /// Particle radius R (nm, um, mm, cm, m; bare number: m).
    #[arg(long, allow_hyphen_values = true, default_value = "0.05m")]
    radius: String,
    /// Particle density ρ (kg/m3, g/cm3; bare number: kg/m3).
    #[arg(long, allow_hyphen_values = true, default_value = "7000kg/m3")]
    density: String,
    /// Initial cloud radius R_0 (nm, um, mm, cm, m; bare number: m).
    #[arg(long, allow_hyphen_values = true, default_value = "1m")]
    cloud_radius: String,
    /// Air density ρ_a (kg/m3, g/cm3; bare number: kg/m3).
    #[arg(long, allow_hyphen_values = true, default_value = "1.225kg/m3")]
    air_density: String,
    /// Air viscosity μ_f (Pa*s, mPa*s; bare number: Pa*s).
    #[arg(long, allow_hyphen_values = true, default_value = "1.8e-5Pa*s")]
    air_viscosity: String,
    /// Drag law: quadratic (constant C_D), chow (C_D(Re)), stokes (6π μ_f R), none.
    #[arg(long, default_value = "chow", value_parser = ["quadratic", "chow", "stokes", "none"])]
    drag: String,
    /// Constant drag coefficient C_D of --drag quadratic (dimensionless).
    #[arg(long, allow_hyphen_values = true, default_value = "0.5")]
    drag_coefficient: String,
    /// Interacting model: switch on the interactions of --interactions, integrate with the
    /// adaptive trapezoidal rule (C9, C10) from Δt_0 = --dt (default then 1e-5 s).
    #[arg(long)]
    interacting: bool,
    /// Interaction terms with --interacting: "all" or a list of contact, damping, friction,
    /// bonding, near-field, rotation, thermal-softening.
    #[arg(long, default_value = "all")]
    interactions: String,
    /// Near-field cut-off distance (m, cm, mm; bare number: m); 0 = exact sum over all pairs.
    #[arg(long, allow_hyphen_values = true, default_value = "0m")]
    near_field_cutoff: String,
    /// Barnes–Hut opening angle θ of the near field (dimensionless); 0 = exact sum over all
    /// pairs. Relative force error on a blasted cloud of 500: 8.5e-3 at θ = 0.5, 6.3e-4 at 0.25.
    #[arg(long, allow_hyphen_values = true, default_value = "0")]
    near_field_theta: String,
    /// Integrator: auto (boris, or trapezoidal with --interacting), boris, euler (the source's
    /// forward Euler), trapezoidal.
    #[arg(long, default_value = "auto", value_parser = ["auto", "boris", "euler", "trapezoidal"])]
    integrator: String,
    /// Duration (s, ms, min; bare number: s).
    #[arg(long, allow_hyphen_values = true, default_value = "1s")]
    duration: String,
    /// Time step: fixed Δt of boris/euler [default: 1e-4 s], initial Δt_0 of trapezoidal
    /// [default: 1e-5 s] (s, ms, us; bare number: s).
    #[arg(long, allow_hyphen_values = true)]
    dt: Option<String>,
    /// Largest adaptive step Δt_max of trapezoidal (s, ms, us; bare number: s).
    #[arg(long, allow_hyphen_values = true, default_value = "2.5e-4s")]
    dt_max: String,
    /// Series samples over the duration (besides t = 0).
    #[arg(long, allow_hyphen_values = true, default_value = "50")]
    samples: String,
    /// Wanted aspect ratio of the shape_error metric (dimensionless).
    #[arg(long, allow_hyphen_values = true, default_value = "2")]
    target_aspect_ratio: String,
    /// Snapshot times with --out, comma-separated (s, ms; bare number: s) [default: start,
    /// middle and end of the run].
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',')]
    snapshot_times: Vec<String>,
    /// Seed of positions and charge signs.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Directory for tables (Parquet), snapshots (extended XYZ + Parquet) and JSON.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

impl BlastArgs {
    /// (parameter, value) pairs as the study model names them.
    fn pairs(&self) -> Vec<(&'static str, String)> {
        let interactions = if self.interacting {
            self.interactions.clone()
        } else {
            "none".into()
        };
        let mut pairs = vec![
            ("field", self.field.clone()),
            ("field_direction", self.field_direction.clone()),
            ("electric_field", self.electric_field.clone()),
            ("electric_direction", self.electric_direction.clone()),
            ("charge_per_mass", self.charge_per_mass.clone()),
            ("negative_fraction", self.negative_fraction.clone()),
            ("energy", self.energy.clone()),
            ("particles", self.particles.clone()),
            ("radius", self.radius.clone()),
            ("density", self.density.clone()),
            ("cloud_radius", self.cloud_radius.clone()),
            ("air_density", self.air_density.clone()),
            ("air_viscosity", self.air_viscosity.clone()),
            ("drag", self.drag.clone()),
            ("drag_coefficient", self.drag_coefficient.clone()),
            ("interactions", interactions),
            ("near_field_cutoff", self.near_field_cutoff.clone()),
            ("near_field_theta", self.near_field_theta.clone()),
            ("integrator", self.integrator.clone()),
            ("duration", self.duration.clone()),
            ("dt_max", self.dt_max.clone()),
            ("samples", self.samples.clone()),
            ("target_aspect_ratio", self.target_aspect_ratio.clone()),
        ];
        if let Some(dt) = &self.dt {
            let implicit =
                self.integrator == "trapezoidal" || (self.integrator == "auto" && self.interacting);
            pairs.push((if implicit { "dt_initial" } else { "dt" }, dt.clone()));
        }
        pairs
    }
}

/// One blast run.
pub fn run_blast(args: &BlastArgs) -> Result<()> {
    let model = BlastModel;
    let mut params = model.defaults();
    let mut values = Vec::new();
    for (name, text) in args.pairs() {
        let option = name.replace('_', "-");
        let value = model
            .spec(name)?
            .parse(&toml::Value::String(text))
            .map_err(|e| Error::input(format!("--{option}: {}", strip_name(&e, name))))?;
        model
            .set(&mut params, name, &value)
            .map_err(|e| Error::input(format!("--{option}: {}", strip_name(&e, name))))?;
        values.push((name.to_string(), value));
    }
    model.validate(&params)?;
    let snapshot_times = snapshot_times(args, &params)?;
    if let Some(dir) = &args.out {
        atomic::prepare_output_dir(dir)?;
    }
    let outcome = run(&params, args.seed, &snapshot_times)?;
    let result = BlastModel::result(&params, &outcome);
    if let Some(dir) = &args.out {
        values.sort_by(|a, b| a.0.cmp(&b.0));
        let study = preset(&model, &values, 1, args.seed, None, "blast")?;
        let run_spec = study.runs(&model).remove(0);
        let record = RunRecord::new(&run_spec, result.clone());
        records::save(dir, &record)?;
        records::write_results(&model, &study, dir, &[record], &command_line())?;
        let snaps = dir.join("snapshots");
        std::fs::create_dir_all(&snaps).map_err(|e| Error::io(&snaps, e))?;
        for (k, (t, cloud)) in outcome.snapshots.iter().enumerate() {
            snapshot::write(&snaps, k, *t, cloud, &params.field_axis())?;
        }
    }
    let json = summary_json(&params, args.seed, &result);
    if args.json {
        println!("{json}");
    } else {
        print_summary(&params, &result);
    }
    Ok(())
}

fn snapshot_times(args: &BlastArgs, params: &BlastParams) -> Result<Vec<f64>> {
    if args.snapshot_times.is_empty() {
        return Ok(vec![0.0, 0.5 * params.duration, params.duration]);
    }
    args.snapshot_times
        .iter()
        .map(|t| {
            parse_quantity(t, Dimension::Time, "s")
                .map_err(|e| Error::input(format!("--snapshot-times: {e}")))
                .and_then(|x| {
                    if (0.0..=params.duration).contains(&x) {
                        Ok(x)
                    } else {
                        Err(Error::input(format!(
                            "--snapshot-times: {x} s is not allowed (need 0 ≤ t ≤ duration = {} s)",
                            params.duration
                        )))
                    }
                })
        })
        .collect()
}

/// The JSON summary: status, parameters that identify the run, every metric.
fn summary_json(
    params: &BlastParams,
    seed: u64,
    result: &crate::study::model::RunResult,
) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("status".into(), result.status.clone().into());
    map.insert("reason".into(), result.reason.clone().into());
    map.insert("seed".into(), seed.into());
    map.insert("field_T".into(), params.field_strength.into());
    map.insert("interactions".into(), params.interactions.label().into());
    map.insert("particles".into(), params.particles.into());
    map.insert("duration_s".into(), params.duration.into());
    for (name, value) in &result.metrics {
        map.insert(
            name.clone(),
            value.map_or(serde_json::Value::Null, Into::into),
        );
    }
    map.insert("wall_time_s".into(), result.wall_time_s.into());
    serde_json::Value::Object(map)
}

fn print_summary(params: &BlastParams, result: &crate::study::model::RunResult) {
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
    if result.status != "ok" {
        println!("run failed: {}", result.reason);
    }
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
}
