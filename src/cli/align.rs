//! `magopt align` and `magopt optimize-field`.

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

use super::{command_line, count};
use crate::materials::MaterialDb;
use crate::models::align::report;
use crate::models::align::study::{AlignModel, AlignSetup};
use crate::models::align::{ModelKind, PressureMode};
use crate::output::{atomic, plot};
use crate::study::model::{StudyModel, Value};
use crate::study::optimize::optimize;
use crate::study::records::{self, RunRecord};
use crate::study::spec::{OptimizeSpec, Study};
use crate::units::to_unit;
use crate::{Error, Result};

/// Physics options shared by `align` and `optimize-field`. Bare numbers are in the unit named
/// in each help text.
#[derive(Debug, Args)]
pub struct PhysicsArgs {
    /// Material name (see `magopt materials`).
    #[arg(long, allow_hyphen_values = true, default_value = "srfe12o19")]
    material: String,
    /// Model: dem (contacts, friction, pressure) or ensemble (non-interacting, milliseconds).
    #[arg(long, value_enum, default_value = "dem")]
    model: ModelKind,
    /// Coulomb friction coefficient μ between particles (dimensionless).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.2)]
    friction: f64,
    /// Friction coefficient with the die walls [default: same as --friction].
    #[arg(long, allow_hyphen_values = true)]
    wall_friction: Option<f64>,
    /// Punch pressure P (Pa, kPa, MPa, bar, atm; bare number: atm).
    #[arg(long, allow_hyphen_values = true, default_value = "0.5atm")]
    pressure: String,
    /// How P is applied: exposed-layer (π R² P on every particle with nothing above it) or
    /// source-layer (the source's rule: centres above 0.9 z_max).
    #[arg(long, value_enum, default_value = "exposed-layer")]
    pressure_mode: PressureMode,
    /// Number of particles N.
    #[arg(
        long,
        allow_hyphen_values = true,
        default_value = "1000",
        value_name = "N"
    )]
    particles: String,
    /// Mean particle diameter D_av (nm, um, mm, m; bare number: um).
    #[arg(long, allow_hyphen_values = true, default_value = "1um")]
    diameter: String,
    /// σ of ln D of the log-normal sizes (dimensionless).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.10)]
    diameter_sigma: f64,
    /// Damping γ = γ* (N·s/m).
    #[arg(long, allow_hyphen_values = true, default_value_t = 20.0)]
    damping: f64,
    /// Target alignment degree x of τ_x, in (0, 1).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.95)]
    target: f64,
    /// Time limit of the alignment stage (s, ms, min, h; bare number: s).
    #[arg(long, allow_hyphen_values = true, default_value = "20000s")]
    max_time: String,
    /// Rotation of the fastest particle per step, rad (sets the time step).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.05)]
    rotation_step: f64,
    /// Friction regularization v_ε as a fraction of the fastest magnetic surface speed.
    #[arg(long, allow_hyphen_values = true, default_value_t = 1e-2)]
    friction_regularization: f64,
    /// Seed (replicate r of optimize-field uses seed + r).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Directory for tables (Parquet), figures (PNG) and JSON.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

impl PhysicsArgs {
    /// (parameter, value) pairs as the study model names them.
    fn pairs(&self, field: &str) -> Vec<(&'static str, String)> {
        let mode = match self.pressure_mode {
            PressureMode::ExposedLayer => "exposed-layer",
            PressureMode::SourceLayer => "source-layer",
        };
        let mut pairs = vec![
            ("material", self.material.clone()),
            ("model", format!("{:?}", self.model).to_lowercase()),
            ("field", field.to_string()),
            ("friction", self.friction.to_string()),
            ("pressure", self.pressure.clone()),
            ("pressure_mode", mode.to_string()),
            ("particles", self.particles.clone()),
            ("diameter", self.diameter.clone()),
            ("diameter_sigma", self.diameter_sigma.to_string()),
            ("damping", self.damping.to_string()),
            ("target", self.target.to_string()),
            ("max_time", self.max_time.clone()),
            ("rotation_step", self.rotation_step.to_string()),
            (
                "friction_regularization",
                self.friction_regularization.to_string(),
            ),
        ];
        if let Some(w) = self.wall_friction {
            pairs.push(("wall_friction", w.to_string()));
        }
        pairs
    }

    /// The run setup and its parsed values (through the same parameter table as study files).
    fn setup(&self, model: &AlignModel, field: &str) -> Result<(AlignSetup, Vec<(String, Value)>)> {
        let mut setup = model.defaults();
        let mut values = Vec::new();
        for (name, text) in self.pairs(field) {
            let option = name.replace('_', "-");
            let value = model
                .spec(name)?
                .parse(&toml::Value::String(text))
                .map_err(|e| Error::input(format!("--{option}: {}", strip_name(&e, name))))?;
            model.set(&mut setup, name, &value)?;
            values.push((name.to_string(), value));
        }
        model.validate(&setup)?;
        values.sort_by(|a, b| a.0.cmp(&b.0));
        Ok((setup, values))
    }

    fn prepare_out(&self) -> Result<Option<&Path>> {
        if let Some(dir) = &self.out {
            atomic::prepare_output_dir(dir)?;
        }
        Ok(self.out.as_deref())
    }
}

/// A parameter error's message without its leading "name: ".
pub(super) fn strip_name(e: &Error, name: &str) -> String {
    let text = e.to_string();
    text.strip_prefix(&format!("{name}: "))
        .unwrap_or(&text)
        .to_string()
}

/// `magopt align` options.
#[derive(Debug, Args)]
pub struct AlignArgs {
    /// Applied field H along +z (Oe, kOe, T, mT, A/m, kA/m; bare number: kOe).
    #[arg(long, allow_hyphen_values = true, default_value = "40kOe")]
    field: String,
    #[command(flatten)]
    physics: PhysicsArgs,
}

/// `magopt optimize-field` options.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// Lower end of the field search (bare number: kOe).
    #[arg(long, allow_hyphen_values = true, default_value = "5kOe")]
    field_min: String,
    /// Upper end of the field search (bare number: kOe).
    #[arg(long, allow_hyphen_values = true, default_value = "100kOe")]
    field_max: String,
    /// Replicate packings (seeds seed, seed+1, …), run in parallel.
    #[arg(long, allow_hyphen_values = true, default_value = "4")]
    replicates: String,
    /// Near-optimal band: fields whose mean τ is within this fraction of the minimum.
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.02)]
    band: f64,
    /// Log-spaced fields of the initial scan.
    #[arg(long, allow_hyphen_values = true, default_value = "7")]
    scan_points: String,
    /// Brent refinement iterations after the scan.
    #[arg(long, allow_hyphen_values = true, default_value_t = 6)]
    brent_iterations: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    #[command(flatten)]
    physics: PhysicsArgs,
}

/// One run.
pub fn run_align(db: &MaterialDb, args: &AlignArgs) -> Result<()> {
    let model = AlignModel::new(db.clone());
    let (setup, values) = args.physics.setup(&model, &args.field)?;
    let out = args.physics.prepare_out()?;
    let seed = args.physics.seed;
    let study = preset(&model, &values, 1, seed, None, "align")?;
    let outcome = model.outcome(&setup, seed);
    if let Some(dir) = out {
        let run = study.runs(&model).remove(0);
        let record = RunRecord::new(&run, model.run(&setup, seed));
        records::save(dir, &record)?;
        records::write_results(&model, &study, dir, &[record], &command_line())?;
    }
    let (params, o) = (&setup.params, &outcome);
    if args.physics.json {
        println!("{}", report::run_json(params, setup.model, seed, o));
        return Ok(());
    }
    println!(
        "{} at {:.2} kOe (h = H/H_K = {:.3}), {} model, seed {seed}",
        params.material.name,
        to_unit(params.field, "kOe"),
        params.reduced_field(),
        format!("{:?}", setup.model).to_lowercase()
    );
    match o.alignment_time_s {
        Some(t) => println!("alignment time τ_{} = {t:.3} s", params.target),
        None => println!(
            "target A = {} not reached ({}); final A = {:.4}",
            params.target,
            o.status.label(),
            o.final_alignment
        ),
    }
    if let crate::models::align::Status::Failed(reason) = &o.status {
        println!("run failed: {reason}");
    }
    if let Some(t) = o.alignment_time_90_s {
        println!("τ_0.90 = {t:.3} s");
    }
    println!(
        "final alignment A = {:.4} after {} steps ({:.2} s wall)",
        o.final_alignment, o.steps, o.wall_time_s
    );
    if let Some(f) = o.sticking_fraction {
        println!(
            "friction-loaded contacts sticking at the end: {:.0} %",
            100.0 * f
        );
        if f > 0.5 {
            println!("note: creep regime: τ at high targets depends on --friction-regularization; compare τ_0.90");
        }
    }
    Ok(())
}

/// A study built from command-line options: no sweep, optionally one free parameter. Its text
/// is written first and parsed back, so the saved study.toml is exactly what ran and
/// `magopt sweep`/`optimize` on it repeat the run.
pub(super) fn preset<M: StudyModel>(
    model: &M,
    values: &[(String, Value)],
    replicates: usize,
    seed: u64,
    optimize: Option<&OptimizeSpec>,
    name: &str,
) -> Result<Study<M>> {
    let is_free = |k: &str| optimize.is_some_and(|o| o.free.iter().any(|(s, ..)| s.name == k));
    let mut text = format!(
        "# written by `{}`\nname = \"{name}\"\nmodel = \"{}\"\nreplicates = {replicates}\nseed = {seed}\n\n[base]\n",
        command_line(),
        model.name()
    );
    for (k, v) in values.iter().filter(|(k, _)| !is_free(k)) {
        text += &format!("{k} = {}\n", model.spec(k)?.toml_literal(v));
    }
    if let Some(o) = optimize {
        let (spec, lo, hi) = o.free[0];
        text += &format!(
            "\n[optimize]\nparameters = {{ {} = [{}, {}] }}\nmetric = {:?}\nscan_points = {}\niterations = {}\nband = {}\n",
            spec.name,
            spec.toml_literal(&Value::Number(lo)),
            spec.toml_literal(&Value::Number(hi)),
            o.metric,
            o.scan_points,
            o.iterations,
            o.band
        );
    }
    Study::parse(model, &text, name)
}

/// The field optimization: a preset of `magopt optimize` (one free parameter, the field).
pub fn run_optimize(db: &MaterialDb, args: &OptimizeArgs) -> Result<()> {
    let model = AlignModel::new(db.clone());
    let (setup, values) = args.physics.setup(&model, &args.field_min)?;
    let field = model.spec("field")?;
    let parse = |option: &str, text: &str| match field.parse(&toml::Value::String(text.to_string()))
    {
        Ok(Value::Number(x)) => Ok(x),
        Ok(Value::Text(_)) => Err(Error::input(format!("--{option}: '{text}' is not a field"))),
        Err(e) => Err(Error::input(format!(
            "--{option}: {}",
            strip_name(&e, "field")
        ))),
    };
    let lower = parse("field-min", &args.field_min)?;
    let upper = parse("field-max", &args.field_max)?;
    if !(lower > 0.0 && lower < upper) {
        return Err(Error::input(format!(
            "--field-min {} and --field-max {}: need 0 < field-min < field-max",
            args.field_min, args.field_max
        )));
    }
    if !(args.band > 0.0 && args.band < 1.0) {
        return Err(Error::input(format!(
            "--band: {} is not allowed (need 0 < band < 1)",
            args.band
        )));
    }
    let replicates = match setup.model {
        ModelKind::Dem => count("replicates", &args.replicates)?,
        ModelKind::Ensemble => 1, // deterministic: one evaluation per field suffices
    };
    let spec = OptimizeSpec {
        metric: "alignment_time_s".into(),
        maximize: false,
        free: vec![(field, lower, upper)],
        log: true,
        scan_points: count("scan-points", &args.scan_points)?.max(3),
        iterations: args.brent_iterations,
        band: args.band,
    };
    let seed = args.physics.seed;
    let study = preset(
        &model,
        &values,
        replicates,
        seed,
        Some(&spec),
        "optimize-field",
    )?;
    super::threads(args.threads)?;
    let out = args.physics.prepare_out()?;
    let bar = progress_bar((spec.scan_points as u64 + spec.iterations) * replicates as u64);
    let result = optimize(&model, &study, out, &|| bar.inc(1));
    bar.finish_and_clear();
    let result = result?;
    let optimum = result.one_dimensional.clone().expect("one free parameter");
    let seeds: Vec<u64> = (0..replicates).map(|r| seed + r as u64).collect();
    let summary = report::optimum_json(&setup.params, setup.model, &optimum, &seeds);
    if let Some(dir) = out {
        records::write_optimize_results(&model, &study, dir, &result.records, &command_line())?;
        atomic::write_json_atomic(&dir.join("optimum.json"), &summary)?;
        let figure = report::tau_figure(&setup.params, setup.model, &optimum, args.band);
        plot::render_png(&dir.join("tau_vs_field.png"), &figure)?;
    }
    if args.physics.json {
        println!("{summary}");
    } else {
        print_summary(&setup, replicates, args.band, &optimum);
    }
    Ok(())
}

fn progress_bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/~{len} runs (ETA {eta})",
        )
        .expect("static template"),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

fn print_summary(setup: &AlignSetup, replicates: usize, band: f64, o: &crate::optimize::Optimum) {
    let params = &setup.params;
    let koe = |x: f64| to_unit(x, "kOe");
    println!(
        "{} ({} model, μ = {}, P = {:.3} atm, N = {}, {} replicate(s)); H_K = {:.2} kOe",
        params.material.name,
        format!("{:?}", setup.model).to_lowercase(),
        params.friction,
        to_unit(params.pressure, "atm"),
        params.particles,
        replicates,
        koe(params.material.anisotropy_field())
    );
    println!(
        "   field (kOe)   τ_{} mean (s)   std (s)   reached",
        params.target
    );
    for p in &o.points {
        println!(
            "   {:10.2}   {:14.3}   {:8.3}   {}/{}",
            koe(p.x),
            p.mean(),
            p.std(),
            p.values.iter().flatten().count(),
            p.values.len()
        );
    }
    let unc = if o.uncertainty.is_finite() {
        format!(" ± {:.1}", koe(o.uncertainty))
    } else {
        String::new()
    };
    println!(
        "optimal field: {:.1}{unc} kOe (τ_{} = {:.3} s)",
        koe(o.x),
        params.target,
        o.value
    );
    println!(
        "fields within {} % of the fastest: {:.1}–{:.1} kOe (the lowest is the cheapest nearly-optimal choice)",
        band * 100.0,
        koe(o.band.0),
        koe(o.band.1)
    );
}
