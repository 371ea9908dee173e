//! Tables, figures and JSON of `align` runs and field searches (physical units throughout;
//! fields reported in kOe as well as A/m since that is what practitioners quote).

use serde_json::{json, Value};

use super::{AlignOutcome, AlignParams, ModelKind};
use crate::optimize::Optimum;
use crate::output::plot::{Figure, Series, SeriesStyle};
use crate::units::to_unit;

/// The magopt version recorded with every result.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// τ versus H with replicate error bars (standard deviation), the optimum and the band.
pub fn tau_figure(params: &AlignParams, model: ModelKind, optimum: &Optimum, band: f64) -> Figure {
    let koe = |x: f64| to_unit(x, "kOe");
    let points: Vec<_> = optimum.points.iter().filter(|p| p.complete()).collect();
    Figure {
        title: format!(
            "{}: τ_{} vs field ({}, μ = {}, P = {:.3} atm, N = {})",
            params.material.name,
            params.target,
            format!("{model:?}").to_lowercase(),
            params.friction,
            to_unit(params.pressure, "atm"),
            params.particles
        ),
        x_label: "applied field H (kOe)".into(),
        y_label: format!("alignment time τ_{} (s)", params.target),
        log_x: true,
        series: vec![Series {
            label: "replicate mean ± std".into(),
            x: points.iter().map(|p| koe(p.x)).collect(),
            y: points.iter().map(|p| p.mean()).collect(),
            y_err: Some(points.iter().map(|p| p.std()).collect()),
            style: SeriesStyle::LinePoints,
        }],
        x_band: Some((
            koe(optimum.band.0),
            koe(optimum.band.1),
            format!("τ within {} % of min", band * 100.0),
        )),
        v_lines: vec![(koe(optimum.x), format!("optimum {:.1} kOe", koe(optimum.x)))],
        ..Figure::default()
    }
}

/// The JSON summary of a field search (`optimize-field --json` and `optimum.json`).
pub fn optimum_json(
    params: &AlignParams,
    model: ModelKind,
    optimum: &Optimum,
    seeds: &[u64],
) -> Value {
    let o = optimum;
    let koe = |x: f64| to_unit(x, "kOe");
    let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    json!({
        "optimal_field_kOe": koe(o.x),
        "optimal_field_A_per_m": o.x,
        "optimal_field_uncertainty_kOe": finite(koe(o.uncertainty)),
        "band_kOe": [koe(o.band.0), koe(o.band.1)],
        "alignment_time_s": finite(o.value),
        "model": format!("{model:?}").to_lowercase(),
        "material": params.material.name,
        "anisotropy_field_kOe": koe(params.material.anisotropy_field()),
        "target": params.target,
        "friction": params.friction,
        "pressure_atm": to_unit(params.pressure, "atm"),
        "particles": params.particles,
        "seeds": seeds,
        "evaluations": o.points.iter().map(|p| json!({
            "field_kOe": koe(p.x),
            "tau_s_mean": finite(p.mean()),
            "tau_s_std": finite(p.std()),
            "replicates_reached": p.values.iter().flatten().count(),
            "replicates": p.values.len(),
        })).collect::<Vec<_>>(),
        "magopt_version": VERSION,
    })
}

fn reason(outcome: &AlignOutcome) -> String {
    match &outcome.status {
        super::Status::Failed(reason) => reason.clone(),
        _ => String::new(),
    }
}

/// The JSON summary of one run.
pub fn run_json(
    params: &AlignParams,
    model: ModelKind,
    seed: u64,
    outcome: &AlignOutcome,
) -> Value {
    json!({
        "alignment_time_s": outcome.alignment_time_s,
        "alignment_time_90_s": outcome.alignment_time_90_s,
        "final_alignment": outcome.final_alignment,
        "reached": outcome.alignment_time_s.is_some(),
        "status": outcome.status.label(),
        "reason": reason(outcome),
        "field_kOe": to_unit(params.field, "kOe"),
        "reduced_field": params.reduced_field(),
        "model": format!("{model:?}").to_lowercase(),
        "material": params.material.name,
        "seed": seed,
        "steps": outcome.steps,
        "time_step_s": outcome.time_step_s,
        "packing_fraction": outcome.packing_fraction,
        "contacts": outcome.contacts,
        "applied_force_N": outcome.applied_force_n,
        "nominal_force_N": outcome.nominal_force_n,
        "sticking_fraction": outcome.sticking_fraction,
        "wall_time_s": outcome.wall_time_s,
        "magopt_version": VERSION,
    })
}
