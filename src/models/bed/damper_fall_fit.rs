//! The damper's first fall fitted as the source fits it (de Paula 2025, §5.3.1, Eq. (5.12),
//! Fig. 5.12: z(0) = 1, z'(0) = 0, ω = 1.05, g0 = −1, α = 0.17):
//! z'' + 2α (z² − 2z) z' + ω² z = g0 in a normalized height and time.
//!
//! The source states no units. magopt reads them from the caption: height in units of the
//! piston's initial height z(0) (so z(0) = 1) and time in units of √(z(0)/g), the only time
//! unit in which free fall is z'' = −1, i.e. g0 = −1 is gravity itself. In these units the
//! piston moves between z = 1 and its rest z_r < 1, where z² − 2z = (z − 1)² − 1 changes from
//! −1 by (1 − z_r)²: the Van der Pol-like term is then distinguishable from a linear damper,
//! unlike in units of D_1 (`damper_fit`), where z ≈ 10–30 and the factor is nearly constant.
//! On 0 < z < 2 the factor is negative, so a positive α pumps energy in; Fig. 5.12's own rest,
//! g0/ω² = −0.91, is a negative height (docs/bed.md, "Damper").

use super::Series;
use crate::analysis::fit::oscillator::{
    fit_both_oscillators, integrate, Oscillator, OscillatorSettings,
};
use crate::analysis::fit::Fit;
use crate::output::plot::{Figure, Series as PlotSeries, SeriesStyle};
use crate::Result;

/// The series of the first fall: piston height (m) against time from the release (s).
pub const SERIES: &str = "piston_fall_z";

/// Most samples the first-fall fit uses (the motion is thinned to every k-th sample): the fall
/// spans a few periods, and the fit's cost grows with the sample count.
pub const FALL_FIT_SAMPLES: usize = 200;

/// The fitted motion ends a quarter after the last sample that is off the final height by more
/// than this fraction of the drop z(0) − z_end: the rest of the record sits at the rest height
/// and would outweigh the motion in the fit (and thin its sampling below the period).
pub const SETTLED: f64 = 0.02;

/// Number of leading samples that hold the motion (see [`SETTLED`]).
fn motion_len(z: &[f64]) -> usize {
    let Some(&end) = z.last() else { return 0 };
    let drop = (z[0] - end).abs();
    let last = z.iter().rposition(|h| (h - end).abs() > SETTLED * drop);
    last.map_or(z.len(), |k| (k + 1 + k / 4).min(z.len()))
}

/// Fig. 5.12's parameters in [`Oscillator::VanDerPol`]'s order: α, ω, g0, z(0), z'(0).
pub const SOURCE_FIG_5_12: [f64; 5] = [0.17, 1.05, -1.0, 1.0, 0.0];

/// Metric names of the first-fall fit, in the order of [`FallFit::values`] (normalized units).
pub const METRICS: [&str; 8] = [
    "damper_fall_vdp_alpha",
    "damper_fall_vdp_alpha_std_error",
    "damper_fall_vdp_omega",
    "damper_fall_vdp_g0",
    "damper_fall_vdp_rmse",
    "damper_fall_linear_rmse",
    "damper_fall_source_curve_rmse",
    "damper_fall_time_unit_s",
];

/// The fits of the first fall in the normalized units.
#[derive(Debug, Clone, PartialEq)]
pub struct FallFit {
    /// Height unit z(0), m.
    pub height_unit: f64,
    /// Time unit √(z(0)/g), s.
    pub time_unit: f64,
    /// Normalized sample times t/√(z(0)/g).
    pub time: Vec<f64>,
    /// Normalized heights z/z(0).
    pub height: Vec<f64>,
    /// Eq. (5.12): α, ω, g0, z(0), z'(0), all free.
    pub van_der_pol: Fit,
    /// Eq. (5.11), the same number of parameters: λ, ω, g, z(0), z'(0).
    pub linear: Fit,
    /// RMS distance of Fig. 5.12's curve ([`SOURCE_FIG_5_12`]) from the normalized samples.
    pub source_curve_rmse: f64,
}

/// Fits the first fall (series [`SERIES`]) under gravity `gravity` (m/s², > 0), up to where it
/// has settled ([`SETTLED`]), thinned to at most `max_samples` samples.
///
/// # Errors
/// Too few or bad samples (see [`fit_both_oscillators`]), or a non-positive z(0) or gravity.
pub fn fit_first_fall(series: &Series, gravity: f64, max_samples: usize) -> Result<FallFit> {
    let samples = series.get(SERIES);
    let start = samples.first().map_or(f64::NAN, |s| s.1);
    if !(start > 0.0 && gravity > 0.0) {
        return Err(crate::Error::input(format!(
            "first-fall fit needs z(0) > 0 and g > 0; got {start} m and {gravity} m/s²"
        )));
    }
    let time_unit = (start / gravity).sqrt();
    let heights: Vec<f64> = samples.iter().map(|s| s.1).collect();
    let samples = &samples[..motion_len(&heights)];
    let every = samples.len().div_ceil(max_samples.max(1)).max(1);
    let (time, height): (Vec<f64>, Vec<f64>) = samples
        .iter()
        .step_by(every)
        .map(|&(t, z)| (t / time_unit, z / start))
        .unzip();
    let settings = OscillatorSettings::default();
    let (linear, van_der_pol) = fit_both_oscillators(&time, &height, &settings)?;
    let mut source = vec![0.0; time.len()];
    integrate(
        Oscillator::VanDerPol,
        &SOURCE_FIG_5_12,
        &time,
        settings.substeps,
        &mut source,
    );
    let source_curve_rmse = (source
        .iter()
        .zip(&height)
        .map(|(s, z)| (s - z).powi(2))
        .sum::<f64>()
        / time.len() as f64)
        .sqrt();
    Ok(FallFit {
        height_unit: start,
        time_unit,
        time,
        height,
        van_der_pol,
        linear,
        source_curve_rmse,
    })
}

impl FallFit {
    /// The scalar results named by [`METRICS`], in its order.
    pub fn values(&self) -> [f64; 8] {
        let v = &self.van_der_pol;
        [
            v.param("alpha"),
            v.std_errors[0],
            v.param("omega"),
            v.param("g0"),
            v.rmse,
            self.linear.rmse,
            self.source_curve_rmse,
            self.time_unit,
        ]
    }

    /// Parameters, standard errors and residuals of both fits and the source's curve, as JSON.
    pub fn json(&self) -> serde_json::Value {
        let fit = |f: &Fit| {
            let pairs = |v: &[f64]| {
                f.names
                    .iter()
                    .zip(v)
                    .map(|(n, p)| (n.to_string(), serde_json::json!(p)))
                    .collect::<serde_json::Map<_, _>>()
            };
            serde_json::json!({
                "parameters": pairs(&f.params),
                "std_errors": pairs(&f.std_errors),
                "rmse": f.rmse,
                "r_squared": f.r_squared,
            })
        };
        serde_json::json!({
            "height_unit_m": self.height_unit,
            "time_unit_s": self.time_unit,
            "samples": self.time.len(),
            "span": self.time.last(),
            "van_der_pol": fit(&self.van_der_pol),
            "linear": fit(&self.linear),
            "source_fig_5_12": {"alpha": SOURCE_FIG_5_12[0], "omega": SOURCE_FIG_5_12[1],
                "g0": SOURCE_FIG_5_12[2], "rmse": self.source_curve_rmse},
        })
    }
}

impl FallFit {
    /// Normalized z(t) with the fitted Eq. (5.12) and Fig. 5.12's curve (the source's figure
    /// side by side).
    pub fn figure(&self) -> Figure {
        let mut source = vec![0.0; self.time.len()];
        integrate(
            Oscillator::VanDerPol,
            &SOURCE_FIG_5_12,
            &self.time,
            OscillatorSettings::default().substeps,
            &mut source,
        );
        let fitted = self
            .height
            .iter()
            .zip(&self.van_der_pol.residuals)
            .map(|(z, r)| z - r)
            .collect();
        let curve = |label: String, y: Vec<f64>, style| PlotSeries {
            label,
            x: self.time.clone(),
            y,
            y_err: None,
            style,
        };
        let v = &self.van_der_pol;
        Figure {
            title: "damper: first fall in the source's units (Fig. 5.12)".into(),
            x_label: format!("t / √(z(0)/g), unit {:.4} s", self.time_unit),
            y_label: format!("z / z(0), z(0) = {:.4} m", self.height_unit),
            series: vec![
                curve(
                    "simulation".into(),
                    self.height.clone(),
                    SeriesStyle::Points,
                ),
                curve(
                    format!(
                        "Eq. (5.12) fit: α = {:.3}, ω = {:.3}, g0 = {:.3}",
                        v.param("alpha"),
                        v.param("omega"),
                        v.param("g0")
                    ),
                    fitted,
                    SeriesStyle::Line,
                ),
                curve(
                    "Fig. 5.12: α = 0.17, ω = 1.05, g0 = −1".into(),
                    source,
                    SeriesStyle::Line,
                ),
            ],
            ..Figure::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples per fit in these tests: the synthetic curves are exact, and the fit's cost grows
    /// with the sample count.
    const SAMPLES: usize = 60;

    /// A first fall in SI from Eq. (5.12) in normalized units `p`, starting at `z0` metres
    /// under gravity `g`, sampled at 2000 times over `span` normalized time units.
    fn fall_in_si(p: &[f64; 5], z0: f64, g: f64, span: f64) -> Series {
        let t: Vec<f64> = (0..2000).map(|k| span * f64::from(k) / 1999.0).collect();
        let mut z = vec![0.0; t.len()];
        integrate(Oscillator::VanDerPol, p, &t, 32, &mut z);
        let unit = (z0 / g).sqrt();
        let mut series = Series::default();
        for (t, z) in t.iter().zip(&z) {
            series.push(SERIES, t * unit, z * z0);
        }
        series
    }

    #[test]
    fn recovers_the_source_parameters_through_the_normalization() {
        // Fig. 5.12's own curve, written out in metres and seconds (z(0) = 0.45 m, g = 9.8).
        let series = fall_in_si(&SOURCE_FIG_5_12, 0.45, 9.8, 12.0);
        let fit = fit_first_fall(&series, 9.8, SAMPLES).unwrap();
        assert!((fit.height_unit - 0.45).abs() < 1e-12);
        assert!((fit.time_unit - (0.45f64 / 9.8).sqrt()).abs() < 1e-12);
        for (k, truth) in SOURCE_FIG_5_12.iter().enumerate() {
            let got = fit.van_der_pol.params[k];
            assert!(
                (got - truth).abs() < 1e-3,
                "parameter {k}: {got} vs {truth}"
            );
        }
        assert!(fit.source_curve_rmse < 1e-6, "{}", fit.source_curve_rmse);
        assert!(fit.van_der_pol.rmse < 1e-4 && fit.linear.rmse > 10.0 * fit.van_der_pol.rmse);
    }

    #[test]
    fn recovers_a_damped_fall_to_a_positive_rest() {
        // A bed-like fall: rest at g0/ω² = 0.6 z(0), damping (α < 0 on 0 < z < 2).
        let truth = [-0.3, 3.0, 5.4, 1.0, 0.0];
        let fit = fit_first_fall(&fall_in_si(&truth, 0.3, 9.8, 6.0), 9.8, SAMPLES).unwrap();
        for (k, t) in truth.iter().enumerate() {
            let got = fit.van_der_pol.params[k];
            assert!(
                (got - t).abs() < 1e-3 * (1.0 + t.abs()),
                "{k}: {got} vs {t}"
            );
        }
        let [alpha, se] = [fit.values()[0], fit.values()[1]];
        assert!(alpha.abs() > 10.0 * se, "α = {alpha} ± {se}: identifiable");
    }

    #[test]
    fn the_fit_ends_where_the_motion_has_settled() {
        // Drop 1 → 0.5; the last sample off 0.5 by more than 2 % of the drop is index 3.
        let z = [
            1.0, 0.4, 0.55, 0.52, 0.505, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5,
        ];
        assert_eq!(motion_len(&z), 4);
        let long: Vec<f64> = (0..100).map(|k| if k < 40 { 1.0 } else { 0.5 }).collect();
        assert_eq!(motion_len(&long), 40 + 39 / 4);
    }

    #[test]
    fn no_fall_is_an_error() {
        assert!(fit_first_fall(&Series::default(), 9.8, SAMPLES).is_err());
    }
}
