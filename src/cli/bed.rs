//! `magopt bed` (one compression cycle) and `magopt damper` (one free-falling piston run).

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

use super::align::preset;
use super::command_line;
use crate::models::bed::report::cycle_figures;
use crate::models::bed::study::BedModel;
use crate::models::bed::{BedOutcome, BedParams, STRUCTURE_STAGES};
use crate::output::{atomic, plot};
use crate::study::model::{RunResult, StudyModel, Value};
use crate::study::records::{self, RunRecord};
use crate::{Error, Result};

/// Options shared by `bed` and `damper`. Bare numbers are in the unit named in each help text;
/// unset options keep the preset's default.
#[derive(Debug, Args)]
pub struct BedArgs {
    /// Geometry preset: mono (N = 368, D = 6 mm, W × H = 0.36 × 0.45 m) or bidisperse
    /// (N = 400, D1 = 5 mm, W = 66 D1, H = 0.445 m) [default: mono, or bidisperse when
    /// --mixing-ratio or --aspect-ratio is given].
    #[arg(long, value_parser = ["mono", "bidisperse"])]
    preset: Option<String>,
    /// Number of particles N; the cell scales by √(N/N_preset) [default: 368 mono, 400 bidisperse].
    #[arg(long, allow_hyphen_values = true, value_name = "N")]
    particles: Option<String>,
    /// Piston speed V_c (mm/s, m/s, um/s; bare number: mm/s) [default: 5.63 mm/s].
    #[arg(long, allow_hyphen_values = true)]
    velocity: Option<String>,
    /// Friction with the plates: dry (B4–B5), viscous (B3, τ_v), both, none [default: dry
    /// for bed, viscous for damper].
    #[arg(long, value_parser = ["dry", "viscous", "both", "none"])]
    friction: Option<String>,
    /// Switch gravity off (default g = 9.8 m/s² along −y).
    #[arg(long)]
    no_gravity: bool,
    /// Mixing ratio R = fraction of small particles, 0…1 (bidisperse) [default: 0].
    #[arg(long, allow_hyphen_values = true)]
    mixing_ratio: Option<String>,
    /// Aspect ratio a = D_small/D_big, 0 < a ≤ 1 (bidisperse) [default: 0.5].
    #[arg(long, allow_hyphen_values = true)]
    aspect_ratio: Option<String>,
    /// Big (reference) diameter D1 (mm, um, cm, m; bare number: mm) [default: 6 mm mono, 5 mm bidisperse].
    #[arg(long, allow_hyphen_values = true)]
    big_diameter: Option<String>,
    /// Species file (TOML: [[species]] tables with diameter = "5mm" and fraction = 0.6);
    /// the first species is the reference.
    #[arg(long, value_name = "FILE")]
    species: Option<String>,
    /// Neighbour handling: exact (all pairs), cells (cut-off list every step), verlet
    /// (list radius r_v, cut-off r_c) [default: verlet].
    #[arg(long, value_parser = ["exact", "cells", "verlet"])]
    neighbors: Option<String>,
    /// Cut-off r_c in units of D1 [default: 7.13].
    #[arg(long, allow_hyphen_values = true)]
    cutoff: Option<String>,
    /// Verlet list radius r_v in units of D1 (changes the speed, never the result) [default: 8; the source used 11.26].
    #[arg(long, allow_hyphen_values = true)]
    list_radius: Option<String>,
    /// Multiple time stepping: sum the pairs beyond --near-cutoff every K steps and hold them
    /// in between (verlet only) [default: 1, every pair every step].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    far_field_interval: Option<String>,
    /// Near cut-off r_s in units of D1 of the multiple time stepping [default: 3].
    #[arg(long, allow_hyphen_values = true)]
    near_cutoff: Option<String>,
    /// Packing fraction at maximum compression (sets H_f) [default: 0.34].
    #[arg(long, allow_hyphen_values = true)]
    packing_fraction: Option<String>,
    /// Packing fraction at the start of compression (sets H0) [default: 0.12].
    #[arg(long, allow_hyphen_values = true)]
    start_packing_fraction: Option<String>,
    /// Wall law: empirical (B2, w^-3.5), infinite-row (w^-3), finite-bar [default: empirical].
    #[arg(long, value_parser = ["empirical", "infinite-row", "finite-bar"])]
    wall_law: Option<String>,
    /// Order of the tilt torque in the normal force (B4): first, second [default: first].
    #[arg(long, value_parser = ["first", "second"])]
    tilt_order: Option<String>,
    /// Viscous time τ_v = m/γ (s, ms; bare number: s) [default: 0.1 s].
    #[arg(long, allow_hyphen_values = true)]
    viscous_time: Option<String>,
    /// Time-step factor: Δt = factor/ω_max at the closest approach [default: 0.2].
    #[arg(long, allow_hyphen_values = true)]
    time_step_factor: Option<String>,
    /// Rest after the expansion (s; bare number: s) [default: 0 s].
    #[arg(long, allow_hyphen_values = true)]
    final_rest: Option<String>,
    /// Interval of the recorded series (s, ms; bare number: s) [default: 0.05 s, × √(N/N_preset) above the preset's N].
    #[arg(long, allow_hyphen_values = true)]
    record_interval: Option<String>,
    /// Damper: piston mass (g, kg, mg; bare number: g) [default: 200 g].
    #[arg(long, allow_hyphen_values = true)]
    piston_mass: Option<String>,
    /// Damper: duration of the second free motion (s; bare number: s); the first ends at rest,
    /// within 20 times this [default: 2 s].
    #[arg(long, allow_hyphen_values = true)]
    damper_time: Option<String>,
    /// Damper: sampling interval of z(t) (s, ms; bare number: s) [default: 1 ms].
    #[arg(long, allow_hyphen_values = true)]
    damper_record_interval: Option<String>,
    /// Seed of the initial positions and velocities.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Directory for runs.parquet, series.parquet, snapshots/ (Parquet + extended XYZ).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

impl BedArgs {
    fn pairs(&self) -> Vec<(&'static str, String)> {
        let given = [
            ("particles", &self.particles),
            ("piston_speed", &self.velocity),
            ("friction", &self.friction),
            ("mixing_ratio", &self.mixing_ratio),
            ("aspect_ratio", &self.aspect_ratio),
            ("big_diameter", &self.big_diameter),
            ("species_file", &self.species),
            ("neighbors", &self.neighbors),
            ("cutoff", &self.cutoff),
            ("list_radius", &self.list_radius),
            ("far_field_interval", &self.far_field_interval),
            ("near_cutoff", &self.near_cutoff),
            ("max_packing_fraction", &self.packing_fraction),
            ("start_packing_fraction", &self.start_packing_fraction),
            ("wall_law", &self.wall_law),
            ("tilt_order", &self.tilt_order),
            ("viscous_time", &self.viscous_time),
            ("time_step_factor", &self.time_step_factor),
            ("final_rest", &self.final_rest),
            ("record_interval", &self.record_interval),
            ("piston_mass", &self.piston_mass),
            ("damper_time", &self.damper_time),
            ("damper_record_interval", &self.damper_record_interval),
        ];
        let bidisperse = self.mixing_ratio.is_some() || self.aspect_ratio.is_some();
        let preset = self
            .preset
            .clone()
            .unwrap_or_else(|| if bidisperse { "bidisperse" } else { "mono" }.into());
        let mut pairs = vec![("preset", preset)];
        pairs.extend(
            given
                .into_iter()
                .filter_map(|(n, v)| v.clone().map(|v| (n, v))),
        );
        if self.no_gravity {
            pairs.push(("gravity", "0".into()));
        }
        pairs
    }

    fn setup(&self, model: &BedModel) -> Result<(BedParams, Vec<(String, Value)>)> {
        let mut params = model.defaults();
        let mut values = Vec::new();
        for (name, text) in self.pairs() {
            let option = option_of(name);
            let value = model
                .spec(name)?
                .parse(&toml::Value::String(text))
                .and_then(|v| model.set(&mut params, name, &v).map(|()| v))
                .map_err(|e| {
                    let text = e.to_string();
                    let text = text
                        .strip_prefix(&format!("{name}: "))
                        .unwrap_or(&text)
                        .to_string();
                    Error::input(format!("--{option}: {text}"))
                })?;
            values.push((name.to_string(), value));
        }
        model.validate(&params).map_err(|e| {
            let text = e.to_string();
            match text.split_once(": ") {
                Some((field, rest)) if OPTION_FIELDS.contains(&field) => {
                    Error::input(format!("--{} ({field}): {rest}", option_of(field)))
                }
                _ => e,
            }
        })?;
        values.sort_by(|a, b| a.0.cmp(&b.0));
        Ok((params, values))
    }
}

/// Parameters that have a command-line option (validation messages name the option).
const OPTION_FIELDS: &[&str] = &[
    "particles",
    "piston_speed",
    "mixing_ratio",
    "aspect_ratio",
    "big_diameter",
    "cutoff",
    "list_radius",
    "far_field_interval",
    "near_cutoff",
    "max_packing_fraction",
    "start_packing_fraction",
    "viscous_time",
    "time_step_factor",
    "final_rest",
    "record_interval",
    "piston_mass",
    "damper_time",
    "damper_record_interval",
];

/// The command-line option of a parameter (`piston_speed` → `velocity`).
fn option_of(name: &str) -> String {
    match name {
        "piston_speed" => "velocity",
        "max_packing_fraction" => "packing-fraction",
        "species_file" => "species",
        other => other,
    }
    .replace('_', "-")
}

/// `magopt bed` or `magopt damper`.
pub fn run(args: &BedArgs, damper: bool) -> Result<()> {
    let model = if damper {
        BedModel::damper()
    } else {
        BedModel::cycle()
    };
    let (params, values) = args.setup(&model)?;
    if let Some(dir) = &args.out {
        atomic::prepare_output_dir(dir)?;
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {msg} (ETA {eta})")
            .expect("static template"),
    );
    let total = simulated_time(&params, damper);
    let outcome = model.outcome(&params, args.seed, &|t| {
        bar.set_position((1000.0 * t / total).min(1000.0) as u64);
        bar.set_message(format!("t = {t:.2} s of {total:.1} s"));
    });
    bar.finish_and_clear();
    if let Some(dir) = &args.out {
        let study = preset(&model, &values, 1, args.seed, None, model.name())?;
        let run = study.runs(&model).remove(0);
        let result = RunResult {
            status: outcome.status().into(),
            reason: outcome.reason(),
            metrics: outcome
                .metrics()
                .into_iter()
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            series: outcome.series.0.clone(),
            wall_time_s: outcome.wall_time_s,
        };
        let record = RunRecord::new(&run, result);
        records::save(dir, &record)?;
        records::write_results(&model, &study, dir, &[record], &command_line())?;
        for s in &outcome.snapshots {
            s.write(&dir.join("snapshots"), &s.label)?;
        }
        if let Some(fits) = &outcome.damper_fits {
            atomic::write_json_atomic(&dir.join("damper_fits.json"), &fits.json())?;
            plot::render_png(&dir.join("damper_fits.png"), &fits.figure())?;
        }
        if !damper && outcome.failure.is_none() {
            for (stem, figure) in cycle_figures(&outcome) {
                plot::render_png(&dir.join(format!("{stem}.png")), &figure)?;
            }
        }
    }
    if args.json {
        println!("{}", json(&outcome, &params, args.seed, model.name()));
    } else {
        summary(&outcome, &params, damper);
    }
    Ok(())
}

/// Simulated time of a run, s (for the progress bar).
fn simulated_time(p: &BedParams, damper: bool) -> f64 {
    let g = crate::models::bed::state::Geometry::of(p);
    let stages = p.relaxation_time + p.settle_time;
    if damper {
        stages + 2.0 * p.damper_time
    } else {
        stages + 2.0 * (g.start_height - g.final_height) / p.piston_speed + p.final_rest
    }
}

fn json(o: &BedOutcome, p: &BedParams, seed: u64, model: &str) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("model".into(), model.into());
    map.insert("status".into(), o.status().into());
    map.insert("reason".into(), o.reason().into());
    map.insert("seed".into(), seed.into());
    map.insert("particles".into(), p.particle_count().into());
    for (name, value) in o.metrics() {
        map.insert(
            name.into(),
            value.map_or(serde_json::Value::Null, |v| serde_json::json!(v)),
        );
    }
    if let Some(fits) = &o.damper_fits {
        map.insert("damper_fits".into(), fits.json());
    }
    map.insert("wall_time_s".into(), o.wall_time_s.into());
    map.insert("magopt_version".into(), records::VERSION.into());
    serde_json::Value::Object(map)
}

fn summary(o: &BedOutcome, p: &BedParams, damper: bool) {
    let (w, h) = p.cell();
    println!(
        "{} particles in a {:.3} m × {:.3} m cell, friction {:?}, {} steps (mean Δt {:.2e} s), {:.1} s wall",
        p.particle_count(),
        w,
        h,
        p.friction,
        o.steps,
        o.mean_time_step,
        o.wall_time_s
    );
    if let Some(reason) = &o.failure {
        println!("run failed: {reason}");
    }
    let show = |label: &str, v: Option<f64>, unit: &str| {
        if let Some(v) = v {
            println!("{label}: {v:.4} {unit}");
        }
    };
    if damper {
        show("piston rest height", o.damper_rest_height, "m");
    } else {
        show("max piston force F_max", o.max_force, "N");
        show(
            "force at maximum compression",
            o.force_at_max_compression,
            "N",
        );
        println!(
            "stroke {:.4} m, packing fraction at H_f {:.3}",
            o.stroke, o.max_packing_fraction
        );
        show(
            "mean distance D̂ at compression start",
            o.mean_distance_start,
            "⟨D⟩",
        );
        show("smallest D̂ during the cycle", o.mean_distance_min, "⟨D⟩");
        show("D̂ at the end", o.mean_distance_end, "⟨D⟩");
        show("energy dissipated over the cycle", o.cycle_work, "J");
        for (k, (_, label)) in STRUCTURE_STAGES.iter().enumerate() {
            if let Some(m) = &o.structure[k] {
                println!(
                    "structure at {label}: n5 {:.3}, n6 {:.3}, n7 {:.3}, Ψ6 {:.3}, hexagon \
                     regularity {:.3}, {} cells counted",
                    m.n5, m.n6, m.n7, m.psi6, m.hexagon_regularity_mean, m.cells_counted
                );
            }
        }
    }
    for warning in &o.warnings {
        println!("warning: {warning}");
    }
    println!(
        "closest pair {:.3} ⟨D⟩_pair, closest wall {:.2} mm, closest to piston {:.2} mm",
        o.closest_pair,
        o.closest_wall * 1e3,
        o.closest_piston * 1e3
    );
}
