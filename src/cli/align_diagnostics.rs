//! `magopt align-diagnostics`: the source's single-particle figures (E&B 2020, Figs. 2 and 3)
//! for one material, as Parquet tables and PNGs (`models::align::diagnostics`).

use clap::Args;
use std::path::PathBuf;

use crate::materials::MaterialDb;
use crate::models::align::diagnostics;
use crate::output::table::write_parquet;
use crate::output::{atomic, plot};
use crate::units::si_per_unit;
use crate::{Error, Result};

/// `magopt align-diagnostics` options.
#[derive(Debug, Args)]
pub struct DiagnosticsArgs {
    /// Material name (see `magopt materials`).
    #[arg(long, default_value = "srfe12o19")]
    material: String,
    /// Fields of the ψ(θ) curves in kOe, comma-separated (default: 0.25, 0.5, 1, 2, 5 H_K).
    #[arg(long, value_name = "KOE,…")]
    fields: Option<String>,
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Writes psi_vs_theta, torque_vs_field and max_torque_field (.parquet and .png) into --out.
pub fn run(db: &MaterialDb, args: &DiagnosticsArgs) -> Result<i32> {
    let material = db.get(&args.material)?;
    let fields = match &args.fields {
        Some(text) => parse_fields(text)?,
        None => diagnostics::default_fields(material),
    };
    atomic::prepare_output_dir(&args.out)?;
    let outputs = [
        ("psi_vs_theta", diagnostics::psi_vs_theta(material, &fields)),
        ("torque_vs_field", diagnostics::torque_vs_field(material)),
        (
            "max_torque_field",
            diagnostics::maximum_torque_field(material),
        ),
    ];
    for (name, (table, figure)) in &outputs {
        write_parquet(&args.out.join(format!("{name}.parquet")), table)?;
        plot::render_png(&args.out.join(format!("{name}.png")), figure)?;
    }
    println!(
        "{}: H_K = {:.2} kOe; wrote {} tables and figures to {}",
        material.name,
        material.anisotropy_field() / si_per_unit("kOe"),
        outputs.len(),
        args.out.display()
    );
    Ok(0)
}

fn parse_fields(text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|f| match f.trim().parse::<f64>() {
            Ok(v) if v > 0.0 && v.is_finite() => Ok(v * si_per_unit("kOe")),
            _ => Err(Error::input(format!(
                "--fields: '{f}' is not allowed (positive numbers in kOe, comma-separated)"
            ))),
        })
        .collect()
}
