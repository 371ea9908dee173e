//! `magopt align` and `magopt optimize-field`. Their physics flags are made from the `align`
//! parameter declarations (`cli::params`).

use clap::{ArgMatches, Args};
use std::path::PathBuf;

use super::run::{single, RunArgs};
use super::{command_line, count, params, progress};
use crate::materials::MaterialDb;
use crate::models::align::report;
use crate::models::align::study::{AlignModel, AlignSetup};
use crate::models::align::ModelKind;
use crate::optimize::Optimum;
use crate::output::{atomic, plot};
use crate::study::model::StudyModel;
use crate::study::optimize::{optimize, optimum_json};
use crate::study::records::{self, RunRecord};
use crate::study::spec::{OptimizeMethod, OptimizeSpec, Study};
use crate::units::to_unit;
use crate::{Error, Result};

/// `magopt align` options besides the model parameters.
#[derive(Debug, Args)]
pub struct AlignArgs {
    #[command(flatten)]
    run: RunArgs,
    /// Keep settled packings in DIR (created if missing) and reuse them: a run whose packing
    /// (code fingerprint, seed, packing parameters) is stored there loads it instead of
    /// settling again, with the same bits (studies/reproduce-align.sh runs every case this way)
    #[arg(long, value_name = "DIR")]
    packing_cache: Option<PathBuf>,
}

/// `magopt optimize-field` options besides the model parameters (all but `--field`).
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// Lower end of the field search (Oe, kOe, T, mT, A/m, kA/m, MA/m; bare number: kOe).
    #[arg(long, allow_hyphen_values = true, default_value = "5kOe")]
    field_min: String,
    /// Upper end of the field search (bare number: kOe).
    #[arg(long, allow_hyphen_values = true, default_value = "100kOe")]
    field_max: String,
    /// Replicate packings (seeds seed, seed+1, …), run in parallel (the ensemble model is
    /// deterministic and uses one).
    #[arg(long, allow_hyphen_values = true, default_value = "4")]
    replicates: String,
    /// Near-optimal band: fields whose mean τ is within this fraction of the minimum.
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.02)]
    band: f64,
    /// Log-spaced fields of the initial scan (at least 3).
    #[arg(long, allow_hyphen_values = true, default_value = "7")]
    scan_points: String,
    /// Brent refinement iterations after the scan.
    #[arg(long, allow_hyphen_values = true, default_value = "6")]
    brent_iterations: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of the first replicate (replicate r uses seed + r).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object on stdout (the schema of optimum.json) instead of the summary.
    #[arg(long)]
    json: bool,
    /// Directory for evaluations.parquet, series.parquet, optimum.json and tau_vs_field.png.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// One run.
pub fn run_align(db: &MaterialDb, matches: &ArgMatches, args: &AlignArgs) -> Result<i32> {
    let mut model = AlignModel::new(db.clone());
    if let Some(dir) = &args.packing_cache {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        model = model.with_packing_dir(dir.clone());
    }
    single(&model, matches, &[], &args.run, summary)
}

fn model_label(kind: ModelKind) -> String {
    format!("{kind:?}").to_lowercase()
}

fn summary(setup: &AlignSetup, record: &RunRecord) {
    let (p, r) = (&setup.params, &record.result);
    let metric = |name: &str| r.metric(name);
    println!(
        "{} at {:.2} kOe (h = H/H_K = {:.3}), {} model, seed {}",
        p.material.name,
        to_unit(p.field, "kOe"),
        p.reduced_field(),
        model_label(setup.model),
        record.run.seed
    );
    let final_alignment = metric("final_alignment").unwrap_or(f64::NAN);
    match metric("alignment_time_s") {
        Some(t) => println!("alignment time τ_{} = {t:.3} s", p.target),
        None => println!(
            "target A = {} not reached ({}); final A = {final_alignment:.4}",
            p.target,
            r.status.label()
        ),
    }
    if let Some(t) = metric("alignment_time_90_s") {
        println!("τ_0.90 = {t:.3} s");
    }
    println!(
        "final alignment A = {final_alignment:.4} after {} steps ({:.2} s wall)",
        metric("steps").unwrap_or(0.0),
        r.wall_time_s
    );
    if let Some(f) = metric("sticking_fraction") {
        println!(
            "friction-loaded contacts sticking at the end: {:.0} %",
            100.0 * f
        );
        if f > 0.5 {
            println!(
                "note: creep regime: τ at high targets depends on --friction-regularization; \
                 compare τ_0.90"
            );
        }
    }
}

/// The field optimization: a one-point study with the field free, run by `magopt optimize`'s
/// code (log scan + Brent).
pub fn run_optimize(db: &MaterialDb, matches: &ArgMatches, args: &OptimizeArgs) -> Result<i32> {
    let model = AlignModel::new(db.clone());
    let (setup, values) = params::setup(&model, &params::given(&model, matches)?)?;
    let field = model.spec("field")?;
    let bound = |option: &str, text: &str| {
        field
            .parse(&params::toml_of(field, text))
            .map(|v| v.as_number())
            .map_err(|reason| Error::input(format!("--{option}: {reason}")))
    };
    let lower = bound("field-min", &args.field_min)?;
    let upper = bound("field-max", &args.field_max)?;
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
        iterations: count("brent-iterations", &args.brent_iterations)? as u64,
        band: args.band,
        method: OptimizeMethod::Brent,
    };
    let command = command_line();
    let study = Study::one_point(
        &model,
        &values,
        replicates,
        args.seed,
        Some(&spec),
        None,
        "optimize-field",
        &command,
    )?;
    super::threads(args.threads)?;
    let out = args.out.as_deref();
    if let Some(dir) = out {
        atomic::prepare_output_dir(dir)?;
    }
    let evaluations = (spec.scan_points as u64 + spec.iterations) * replicates as u64;
    let bar = progress::runs(evaluations, true);
    let result = optimize(&model, &study, out, &|| bar.inc(1));
    bar.finish_and_clear();
    let result = result?;
    let optimum = result
        .one_dimensional
        .clone()
        .ok_or_else(|| Error::Output("the field search has one free parameter".into()))?;
    let json = optimum_json(&model, &study, &result);
    if let Some(dir) = out {
        records::write_optimize_results(&model, &study, dir, &result.records, &command)?;
        atomic::write_json_atomic(&dir.join("optimum.json"), &json)?;
        let figure = report::tau_figure(&setup.params, setup.model, &optimum, args.band);
        plot::render_png(&dir.join("tau_vs_field.png"), &figure)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_optimum(&setup, replicates, args.band, &optimum);
    }
    Ok(0)
}

fn print_optimum(setup: &AlignSetup, replicates: usize, band: f64, o: &Optimum) {
    let params = &setup.params;
    let koe = |x: f64| to_unit(x, "kOe");
    println!(
        "{} ({} model, μ = {}, P = {:.3} atm, N = {}, {} replicate(s)); H_K = {:.2} kOe",
        params.material.name,
        model_label(setup.model),
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
        "fields within {} % of the fastest: {:.1}–{:.1} kOe (the lowest is the cheapest \
         nearly-optimal choice)",
        band * 100.0,
        koe(o.band.0),
        koe(o.band.1)
    );
}
