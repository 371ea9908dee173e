//! The figure of `align` field searches (fields in kOe, since that is what practitioners
//! quote).

use super::{AlignParams, ModelKind};
use crate::optimize::Optimum;
use crate::output::plot::{Figure, Series, SeriesStyle};
use crate::units::to_unit;

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
