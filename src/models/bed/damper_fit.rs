//! Fits of the damper's second motion z(t) (spec bed.md "Damper", analysis.md "Fits"): the
//! Van der Pol-like z'' + 2α (z² − 2z) z' + ω² z = g0 and the linear damped oscillator
//! z'' + 2λ z' + ω² z = g, both by [`fit_both_oscillators`] (RK4 inside the objective).
//!
//! Length unit: the Van der Pol-like equation is not dimensionally homogeneous (z² − 2z), and
//! the source does not state its unit, so both fits take z in units of the reference diameter
//! D_1 and t in seconds (λ, ω in SI whatever the unit; α in 1/(s·D_1²), g in D_1/s²). The
//! residuals are reported in metres. With z ≈ 10–30 D_1 and a swing of 0.2 D_1 the factor
//! z² − 2z varies by a few per cent over the motion: the Van der Pol-like fit is then close to
//! a linear damper, which the two residuals show.

use super::Series;
use crate::analysis::fit::oscillator::{fit_both_oscillators, OscillatorSettings};
use crate::analysis::fit::Fit;
use crate::output::plot::{Figure, Series as PlotSeries, SeriesStyle};
use crate::Result;

/// Metric names of a damper run's fits, in the order of [`DamperFits::values`]: amplitude and
/// RMS residuals in m, λ and ω in SI, α in 1/(s·D_1²).
pub const METRICS: [&str; 7] = [
    "damper_amplitude_m",
    "damper_linear_lambda_per_s",
    "damper_linear_omega_rad_per_s",
    "damper_linear_rmse_m",
    "damper_vdp_alpha",
    "damper_vdp_omega_rad_per_s",
    "damper_vdp_rmse_m",
];

/// Both fits of one damper run.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperFits {
    /// Length unit of z in the fits (D_1), m.
    pub length_unit: f64,
    /// Largest |z − z_rest| of the fitted motion, m.
    pub amplitude: f64,
    /// Sample times from the second release, s.
    pub time: Vec<f64>,
    /// Piston height z(t), m.
    pub height: Vec<f64>,
    /// Linear damped oscillator: λ (1/s), ω (rad/s), g, z0, v0 (z in D_1).
    pub linear: Fit,
    /// Van der Pol-like oscillator: α, ω (rad/s), g0, z0, v0 (z in D_1).
    pub van_der_pol: Fit,
}

/// Most samples of z(t) a fit uses: a longer record is thinned to every k-th sample. At the
/// default 1 ms sampling of a 2 s motion that is one sample per 5 ms, over 50 per period for
/// the periods seen (0.3–0.45 s); the fit's cost is proportional to the sample count
/// (`tests/bed_analysis.rs` checks that the full record gives the same ω and λ).
pub const FIT_SAMPLES: usize = 400;

/// Fits the series `piston_z` (time from the second release) of a damper run with rest height
/// `rest` (m), thinned to at most `max_samples` samples; z is taken in units of
/// `length_unit` (m).
///
/// # Errors
/// Too few or bad samples (see [`fit_both_oscillators`]).
pub fn fit_damper(
    series: &Series,
    rest: f64,
    length_unit: f64,
    max_samples: usize,
) -> Result<DamperFits> {
    let samples = series.get("piston_z");
    let every = samples.len().div_ceil(max_samples.max(1)).max(1);
    let (time, height): (Vec<f64>, Vec<f64>) = samples.iter().step_by(every).copied().unzip();
    let z: Vec<f64> = height.iter().map(|h| h / length_unit).collect();
    let (linear, van_der_pol) = fit_both_oscillators(&time, &z, &OscillatorSettings::default())?;
    let amplitude = height.iter().map(|h| (h - rest).abs()).fold(0.0, f64::max);
    Ok(DamperFits {
        length_unit,
        amplitude,
        time,
        height,
        linear,
        van_der_pol,
    })
}

impl DamperFits {
    /// The scalar results named by [`METRICS`], in its order.
    pub fn values(&self) -> [f64; 7] {
        let (l, v) = (&self.linear, &self.van_der_pol);
        [
            self.amplitude,
            l.param("lambda"),
            l.param("omega"),
            l.rmse * self.length_unit,
            v.param("alpha"),
            v.param("omega"),
            v.rmse * self.length_unit,
        ]
    }

    /// Parameters, standard errors and residuals of both fits as JSON.
    pub fn json(&self) -> serde_json::Value {
        let fit = |f: &Fit| {
            serde_json::json!({
                "parameters": f.names.iter().zip(&f.params).map(|(n, p)| (n.to_string(), serde_json::json!(p))).collect::<serde_json::Map<_, _>>(),
                "std_errors": f.names.iter().zip(&f.std_errors).map(|(n, p)| (n.to_string(), serde_json::json!(p))).collect::<serde_json::Map<_, _>>(),
                "rmse_m": f.rmse * self.length_unit,
                "rmse_over_amplitude": f.rmse * self.length_unit / self.amplitude,
                "r_squared": f.r_squared,
                "iterations": f.iterations,
            })
        };
        serde_json::json!({
            "length_unit_m": self.length_unit,
            "samples": self.time.len(),
            "amplitude_m": self.amplitude,
            "linear": fit(&self.linear),
            "van_der_pol": fit(&self.van_der_pol),
        })
    }

    /// z(t) with both fitted curves (model = data − residual), in mm.
    pub fn figure(&self) -> Figure {
        let curve = |label: &str, fit: Option<&Fit>, style| PlotSeries {
            label: label.into(),
            x: self.time.clone(),
            y: self
                .height
                .iter()
                .enumerate()
                .map(|(k, h)| 1e3 * (h - fit.map_or(0.0, |f| f.residuals[k] * self.length_unit)))
                .collect(),
            y_err: None,
            style,
        };
        let rel = |f: &Fit| f.rmse * self.length_unit / self.amplitude;
        Figure {
            title: "damper: second motion of the piston".into(),
            x_label: "time since release t (s)".into(),
            y_label: "piston height z (mm)".into(),
            series: vec![
                curve("simulation", None, SeriesStyle::Points),
                curve(
                    &format!(
                        "linear damped (rms {:.1} % of amplitude)",
                        100.0 * rel(&self.linear)
                    ),
                    Some(&self.linear),
                    SeriesStyle::Line,
                ),
                curve(
                    &format!(
                        "Van der Pol-like (rms {:.1} %)",
                        100.0 * rel(&self.van_der_pol)
                    ),
                    Some(&self.van_der_pol),
                    SeriesStyle::Line,
                ),
            ],
            ..Figure::default()
        }
    }
}
