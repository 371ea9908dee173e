//! `magopt align` and `magopt optimize-field`.

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

use super::{count, number, quantity};
use crate::materials::MaterialDb;
use crate::models::align::field_search::{run_once, FieldSearch, FieldSearchResult, RunRecord};
use crate::models::align::report;
use crate::models::align::{AlignParams, ModelKind, PressureMode};
use crate::optimize::Settings;
use crate::output::{atomic, plot, table};
use crate::units::{to_unit, Dimension};
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
    fn params(&self, db: &MaterialDb, field: f64) -> Result<AlignParams> {
        let mut p = AlignParams::paper_defaults(db.get(&self.material)?.clone(), field);
        p.friction = number("friction", self.friction)?;
        p.wall_friction = number("wall-friction", self.wall_friction.unwrap_or(self.friction))?;
        p.pressure = quantity("pressure", &self.pressure, Dimension::Pressure, "atm")?;
        p.pressure_mode = self.pressure_mode;
        p.particles = count("particles", &self.particles)?;
        p.mean_diameter = quantity("diameter", &self.diameter, Dimension::Length, "um")?;
        p.diameter_sigma = number("diameter-sigma", self.diameter_sigma)?;
        p.damping = number("damping", self.damping)?;
        p.target = number("target", self.target)?;
        p.max_time = quantity("max-time", &self.max_time, Dimension::Time, "s")?;
        p.numerics.rotation_step = number("rotation-step", self.rotation_step)?;
        p.numerics.friction_regularization =
            number("friction-regularization", self.friction_regularization)?;
        p.validate()?;
        Ok(p)
    }

    fn prepare_out(&self) -> Result<Option<&Path>> {
        if let Some(dir) = &self.out {
            atomic::prepare_output_dir(dir)?;
        }
        Ok(self.out.as_deref())
    }
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
    let field = quantity("field", &args.field, Dimension::MagneticField, "kOe")?;
    let params = args.physics.params(db, field)?;
    let out = args.physics.prepare_out()?;
    let seed = args.physics.seed;
    let outcome = run_once(&params, args.physics.model, seed);
    let record = RunRecord {
        field,
        replicate: 0,
        seed,
        outcome,
    };
    if let Some(dir) = out {
        let records = std::slice::from_ref(&record);
        table::write_parquet(
            &dir.join("runs.parquet"),
            &report::runs_table(&params, args.physics.model, records),
        )?;
        table::write_parquet(&dir.join("series.parquet"), &report::series_table(records))?;
    }
    let o = &record.outcome;
    if args.physics.json {
        println!("{}", report::run_json(&params, args.physics.model, seed, o));
        return Ok(());
    }
    println!(
        "{} at {:.2} kOe (h = H/H_K = {:.3}), {} model, seed {seed}",
        params.material.name,
        to_unit(field, "kOe"),
        params.reduced_field(),
        format!("{:?}", args.physics.model).to_lowercase()
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
        println!("friction-loaded contacts sticking at the end: {:.0} %", 100.0 * f);
        if f > 0.5 {
            println!("note: creep regime: τ at high targets depends on --friction-regularization; compare τ_0.90");
        }
    }
    Ok(())
}

/// The field optimization.
pub fn run_optimize(db: &MaterialDb, args: &OptimizeArgs) -> Result<()> {
    let lower = quantity(
        "field-min",
        &args.field_min,
        Dimension::MagneticField,
        "kOe",
    )?;
    let upper = quantity(
        "field-max",
        &args.field_max,
        Dimension::MagneticField,
        "kOe",
    )?;
    if !(lower > 0.0 && lower < upper) {
        return Err(Error::input(format!(
            "--field-min {} and --field-max {}: need 0 < field-min < field-max",
            args.field_min, args.field_max
        )));
    }
    let band = number("band", args.band)?;
    if !(band > 0.0 && band < 1.0) {
        return Err(Error::input(format!(
            "--band: {band} is not allowed (need 0 < band < 1)"
        )));
    }
    let params = args.physics.params(db, lower)?;
    let scan_points = count("scan-points", &args.scan_points)?.max(3);
    let search = FieldSearch {
        base: params.clone(),
        model: args.physics.model,
        replicates: count("replicates", &args.replicates)?,
        seed: args.physics.seed,
        settings: Settings {
            lower,
            upper,
            scan_points,
            brent_iterations: args.brent_iterations,
            rel_tolerance: 1e-3,
            band,
        },
    };
    if let Some(threads) = args.threads {
        if threads == 0 {
            return Err(Error::input("--threads: 0 is not allowed (need ≥ 1)"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .ok();
    }
    let out = args.physics.prepare_out()?;
    let bar = progress_bar(search.expected_work());
    let mut write_error = None;
    let result = search.run(&|| bar.inc(1), |runs| {
        if let Some(dir) = out {
            if let Err(e) = write_runs(dir, &params, search.model, runs) {
                write_error.get_or_insert(e);
            }
        }
    });
    bar.finish_and_clear();
    if let Some(e) = write_error {
        return Err(e);
    }
    let seeds: Vec<u64> = (0..search.replicates)
        .map(|r| search.replicate_seed(r))
        .collect();
    let summary = report::optimum_json(&params, search.model, &result, &seeds);
    if let Some(dir) = out {
        atomic::write_json_atomic(&dir.join("optimum.json"), &summary)?;
        let figure = report::tau_figure(&params, search.model, &result.optimum, band);
        plot::render_png(&dir.join("tau_vs_field.png"), &figure)?;
    }
    if args.physics.json {
        println!("{summary}");
    } else {
        print_summary(&params, &search, &result);
    }
    Ok(())
}

fn write_runs(
    dir: &Path,
    params: &AlignParams,
    model: ModelKind,
    runs: &[RunRecord],
) -> Result<()> {
    table::write_parquet(
        &dir.join("evaluations.parquet"),
        &report::runs_table(params, model, runs),
    )?;
    table::write_parquet(&dir.join("series.parquet"), &report::series_table(runs))
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

fn print_summary(params: &AlignParams, search: &FieldSearch, result: &FieldSearchResult) {
    let o = &result.optimum;
    let koe = |x: f64| to_unit(x, "kOe");
    println!(
        "{} ({} model, μ = {}, P = {:.3} atm, N = {}, {} replicate(s)); H_K = {:.2} kOe",
        params.material.name,
        format!("{:?}", search.model).to_lowercase(),
        params.friction,
        to_unit(params.pressure, "atm"),
        params.particles,
        if search.model == ModelKind::Dem {
            search.replicates
        } else {
            1
        },
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
        search.settings.band * 100.0,
        koe(o.band.0),
        koe(o.band.1)
    );
}
