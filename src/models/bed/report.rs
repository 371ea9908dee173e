//! Figures of one cycle: piston force versus packing fraction (log scale, where the roughly
//! exponential growth is a straight line) and F/F_max versus y_P/y_F, compression and
//! expansion branches apart (the gap is the hysteresis).

use super::BedOutcome;
use crate::output::plot::{Figure, Series, SeriesStyle};

/// The compression and expansion branches of (x observable, piston force): points from the
/// start of compression (first point after the relaxation where the stroke is ≥ 0) split at
/// the maximum stroke.
fn branches(o: &BedOutcome, x_name: &str) -> [(Vec<f64>, Vec<f64>); 2] {
    let stroke = o.series.get("stroke");
    let x = o.series.get(x_name);
    let force = o.series.get("piston_force");
    let start = o.snapshots.first().map_or(0.0, |s| s.time);
    let t_max = stroke
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(f64::INFINITY, |p| p.0);
    let mut out = [(Vec::new(), Vec::new()), (Vec::new(), Vec::new())];
    for k in 0..force.len().min(x.len()) {
        let t = force[k].0;
        if t + 1e-12 < start {
            continue;
        }
        let branch = usize::from(t > t_max);
        out[branch].0.push(x[k].1);
        out[branch].1.push(force[k].1);
        if (t - t_max).abs() < 1e-12 {
            out[1].0.push(x[k].1);
            out[1].1.push(force[k].1);
        }
    }
    out
}

fn figure(
    title: &str,
    x_label: &str,
    y_label: &str,
    data: [(Vec<f64>, Vec<f64>); 2],
    log_y: bool,
) -> Figure {
    let [(xc, yc), (xe, ye)] = data;
    let series = |label: &str, x, y| Series {
        label: label.into(),
        x,
        y,
        y_err: None,
        style: SeriesStyle::Line,
    };
    Figure {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        log_y,
        series: vec![series("compression", xc, yc), series("expansion", xe, ye)],
        ..Figure::default()
    }
}

/// F versus φ (log F) and F/F_max versus y_P/y_F, as (file stem, figure).
pub fn cycle_figures(o: &BedOutcome) -> Vec<(&'static str, Figure)> {
    let f_max = o.max_force.unwrap_or(f64::NAN);
    let mut by_stroke = branches(o, "stroke");
    for (x, y) in by_stroke.iter_mut() {
        x.iter_mut().for_each(|s| *s /= o.stroke);
        y.iter_mut().for_each(|f| *f /= f_max);
    }
    vec![
        (
            "force_vs_packing_fraction",
            figure(
                "piston force versus packing fraction",
                "packing fraction φ",
                "piston force F (N)",
                branches(o, "packing_fraction"),
                true,
            ),
        ),
        (
            "force_vs_stroke",
            figure(
                "normalized piston force versus stroke",
                "y_P / y_F",
                "F / F_max",
                by_stroke,
                false,
            ),
        ),
    ]
}
