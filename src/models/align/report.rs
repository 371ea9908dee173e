//! Tables, figures and JSON of `align` runs and field searches (physical units throughout;
//! fields reported in kOe as well as A/m since that is what practitioners quote).

use serde_json::{json, Value};

use super::field_search::{FieldSearchResult, RunRecord};
use super::{AlignOutcome, AlignParams, ModelKind};
use crate::optimize::Optimum;
use crate::output::plot::{Figure, Series, SeriesStyle};
use crate::output::table::{ColumnData as C, Table};
use crate::units::to_unit;

/// The magopt version recorded with every result.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// One row per run: parameters, seed, status, every scalar result, version.
pub fn runs_table(params: &AlignParams, model: ModelKind, records: &[RunRecord]) -> Table {
    let col = |f: &dyn Fn(&RunRecord) -> f64| C::F64(records.iter().map(f).collect());
    let opt = |f: &dyn Fn(&AlignOutcome) -> Option<f64>| {
        C::OptF64(records.iter().map(|r| f(&r.outcome)).collect())
    };
    let text = |s: String| C::Str(vec![s; records.len()]);
    Table::new()
        .with("field_A_per_m", col(&|r| r.field))
        .with("field_kOe", col(&|r| to_unit(r.field, "kOe")))
        .with(
            "replicate",
            C::U64(records.iter().map(|r| r.replicate as u64).collect()),
        )
        .with("seed", C::U64(records.iter().map(|r| r.seed).collect()))
        .with(
            "status",
            C::Str(
                records
                    .iter()
                    .map(|r| r.outcome.status.label().to_string())
                    .collect(),
            ),
        )
        .with(
            "reason",
            C::Str(records.iter().map(|r| reason(&r.outcome)).collect()),
        )
        .with("alignment_time_s", opt(&|o| o.alignment_time_s))
        .with("alignment_time_90_s", opt(&|o| o.alignment_time_90_s))
        .with("final_alignment", col(&|r| r.outcome.final_alignment))
        .with(
            "steps",
            C::U64(records.iter().map(|r| r.outcome.steps as u64).collect()),
        )
        .with("time_step_s", col(&|r| r.outcome.time_step_s))
        .with("packing_fraction", opt(&|o| o.packing_fraction))
        .with("contacts", opt(&|o| o.contacts.map(|c| c as f64)))
        .with("bed_height_m", opt(&|o| o.bed_height_m))
        .with("applied_force_N", opt(&|o| o.applied_force_n))
        .with("nominal_force_N", opt(&|o| o.nominal_force_n))
        .with(
            "solver_sweeps",
            C::U64(
                records
                    .iter()
                    .map(|r| r.outcome.solver_sweeps as u64)
                    .collect(),
            ),
        )
        .with(
            "unconverged_solves",
            C::U64(
                records
                    .iter()
                    .map(|r| r.outcome.unconverged_solves as u64)
                    .collect(),
            ),
        )
        .with("sticking_fraction", opt(&|o| o.sticking_fraction))
        .with("wall_time_s", col(&|r| r.outcome.wall_time_s))
        .with("model", text(format!("{model:?}").to_lowercase()))
        .with("material", text(params.material.name.clone()))
        .with("friction", C::F64(vec![params.friction; records.len()]))
        .with("pressure_Pa", C::F64(vec![params.pressure; records.len()]))
        .with(
            "particles",
            C::U64(vec![params.particles as u64; records.len()]),
        )
        .with("target", C::F64(vec![params.target; records.len()]))
        .with("magopt_version", text(VERSION.to_string()))
}

fn reason(outcome: &AlignOutcome) -> String {
    match &outcome.status {
        super::Status::Failed(reason) => reason.clone(),
        _ => String::new(),
    }
}

/// Long-format A(t) series: field, replicate, time, alignment.
pub fn series_table(records: &[RunRecord]) -> Table {
    let rows: Vec<(&RunRecord, f64, f64)> = records
        .iter()
        .flat_map(|r| r.outcome.series.iter().map(move |&(t, a)| (r, t, a)))
        .collect();
    Table::new()
        .with(
            "field_kOe",
            C::F64(
                rows.iter()
                    .map(|(r, _, _)| to_unit(r.field, "kOe"))
                    .collect(),
            ),
        )
        .with(
            "replicate",
            C::U64(rows.iter().map(|(r, _, _)| r.replicate as u64).collect()),
        )
        .with("time_s", C::F64(rows.iter().map(|(_, t, _)| *t).collect()))
        .with(
            "alignment",
            C::F64(rows.iter().map(|(_, _, a)| *a).collect()),
        )
}

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

/// The JSON summary of a field search.
pub fn optimum_json(
    params: &AlignParams,
    model: ModelKind,
    search: &FieldSearchResult,
    seeds: &[u64],
) -> Value {
    let o = &search.optimum;
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
