//! Fits of the damper's piston height z(t) (spec analysis.md, "Fits"):
//! - Van der Pol-like: z'' + 2α (z² − 2z) z' + ω² z = g0, parameters α, ω, g0, z(t0), z'(t0);
//! - linear damped oscillator: z'' + 2λ z' + ω² z = g, parameters λ, ω, g, z(t0), z'(t0).
//!
//! The ODE is integrated inside the objective by classical RK4 with a fixed number of steps per
//! sample interval ([`OscillatorSettings::substeps`]); its error is O((ω h)⁴).

use super::{check_data, finish, minimize, Fit, FitSettings};
use crate::{Error, Result};

/// Default RK4 steps per sample interval.
pub const DEFAULT_SUBSTEPS: usize = 8;

/// Numerical settings of the oscillator fits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OscillatorSettings {
    /// RK4 steps per interval between consecutive samples (≥ 1; default
    /// [`DEFAULT_SUBSTEPS`]). With samples every 1/20 of a period the default gives a relative
    /// trajectory error ~1e-7.
    pub substeps: usize,
    /// Nelder–Mead controls.
    pub fit: FitSettings,
}

impl Default for OscillatorSettings {
    fn default() -> Self {
        Self {
            substeps: DEFAULT_SUBSTEPS,
            fit: FitSettings::default(),
        }
    }
}

/// Which oscillator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Oscillator {
    /// z'' + 2α (z² − 2z) z' + ω² z = g0; parameters [α, ω, g0, z0, v0].
    VanDerPol,
    /// z'' + 2λ z' + ω² z = g; parameters [λ, ω, g, z0, v0].
    Linear,
}

impl Oscillator {
    /// Acceleration z'' at (z, z') for parameters p = [damping, ω, g, …].
    fn acceleration(self, p: &[f64], z: f64, v: f64) -> f64 {
        let damping = match self {
            Oscillator::VanDerPol => 2.0 * p[0] * (z * z - 2.0 * z) * v,
            Oscillator::Linear => 2.0 * p[0] * v,
        };
        p[2] - p[1] * p[1] * z - damping
    }

    /// Parameter names.
    fn names(self) -> Vec<&'static str> {
        match self {
            Oscillator::VanDerPol => vec!["alpha", "omega", "g0", "z0", "v0"],
            Oscillator::Linear => vec!["lambda", "omega", "g", "z0", "v0"],
        }
    }
}

/// Integrates the oscillator from (z0, v0) at t[0] by RK4 with `substeps` steps per sample
/// interval and writes z at every sample time into `out` (NaN from the first non-finite state
/// on).
pub fn integrate(kind: Oscillator, p: &[f64], t: &[f64], substeps: usize, out: &mut [f64]) {
    trajectory(kind, p, t, substeps, |k, z| out[k] = z);
}

/// Residual sum of squares of the oscillator against samples z(t), without allocating.
fn rss(kind: Oscillator, p: &[f64], t: &[f64], z: &[f64], substeps: usize) -> f64 {
    let mut sum = 0.0;
    trajectory(kind, p, t, substeps, |k, m| sum += (m - z[k]).powi(2));
    sum
}

/// RK4 from (z0, v0) at t[0]; `visit(k, z(t_k))` for every sample (NaN after a blow-up).
fn trajectory(
    kind: Oscillator,
    p: &[f64],
    t: &[f64],
    substeps: usize,
    mut visit: impl FnMut(usize, f64),
) {
    let (mut z, mut v) = (p[3], p[4]);
    let a = |z: f64, v: f64| kind.acceleration(p, z, v);
    visit(0, z);
    for k in 1..t.len() {
        let h = (t[k] - t[k - 1]) / substeps as f64;
        for _ in 0..substeps {
            let (k1z, k1v) = (v, a(z, v));
            let (k2z, k2v) = (v + 0.5 * h * k1v, a(z + 0.5 * h * k1z, v + 0.5 * h * k1v));
            let (k3z, k3v) = (v + 0.5 * h * k2v, a(z + 0.5 * h * k2z, v + 0.5 * h * k2v));
            let (k4z, k4v) = (v + h * k3v, a(z + h * k3z, v + h * k3v));
            z += h / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        }
        if !(z.is_finite() && v.is_finite()) {
            (k..t.len()).for_each(|j| visit(j, f64::NAN));
            return;
        }
        visit(k, z);
    }
}

/// Start values from the data: z0, v0 from the first samples, the equilibrium from the mean
/// of the last quarter, ω from the mean spacing of crossings of that equilibrium.
fn start_values(t: &[f64], z: &[f64]) -> (f64, f64, f64, f64) {
    let n = z.len();
    let tail = &z[3 * n / 4..];
    let z_eq = tail.iter().sum::<f64>() / tail.len() as f64;
    let crossings: Vec<f64> = (1..n)
        .filter(|k| (z[k - 1] - z_eq) * (z[*k] - z_eq) < 0.0)
        .map(|k| t[k])
        .collect();
    let span = t[n - 1] - t[0];
    let omega = if crossings.len() >= 2 {
        let half_period =
            (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        std::f64::consts::PI / half_period
    } else {
        2.0 * std::f64::consts::PI / span
    };
    let v0 = (z[1] - z[0]) / (t[1] - t[0]);
    (z[0], v0, z_eq, omega)
}

/// Fits one oscillator to samples z(t) (t strictly increasing). The linear oscillator starts
/// from data-based values and a few damping ratios; the Van der Pol-like one starts from the
/// linear fit, with α matched to the linearized damping at the equilibrium z* = g/ω².
///
/// # Errors
/// [`Error::Input`] for fewer than 8 samples, non-finite values, t not strictly increasing or
/// substeps = 0.
pub fn fit_oscillator(
    kind: Oscillator,
    t: &[f64],
    z: &[f64],
    settings: &OscillatorSettings,
) -> Result<Fit> {
    match kind {
        Oscillator::Linear => fit_checked_linear(t, z, settings),
        Oscillator::VanDerPol => Ok(fit_both_oscillators(t, z, settings)?.1),
    }
}

/// Both fits of the same samples, (linear, Van der Pol-like), the linear one computed once
/// (it is the Van der Pol-like fit's start). Errors as [`fit_oscillator`].
pub fn fit_both_oscillators(
    t: &[f64],
    z: &[f64],
    settings: &OscillatorSettings,
) -> Result<(Fit, Fit)> {
    let linear = fit_checked_linear(t, z, settings)?;
    let van_der_pol = fit_van_der_pol(t, z, settings, &linear);
    Ok((linear, van_der_pol))
}

/// Checks the samples and settings, then fits the linear oscillator.
fn fit_checked_linear(t: &[f64], z: &[f64], settings: &OscillatorSettings) -> Result<Fit> {
    check_data("oscillator", t, z, 8)?;
    if let Some(k) = (1..t.len()).find(|k| t[*k] <= t[k - 1]) {
        return Err(Error::input(format!(
            "oscillator fit: t[{k}] = {} does not follow t[{}] = {} (need increasing times)",
            t[k],
            k - 1,
            t[k - 1]
        )));
    }
    if settings.substeps == 0 {
        return Err(Error::input("oscillator fit: substeps must be ≥ 1"));
    }
    Ok(fit_linear_oscillator(t, z, settings))
}

fn fit_linear_oscillator(t: &[f64], z: &[f64], settings: &OscillatorSettings) -> Fit {
    let (z0, v0, z_eq, omega) = start_values(t, z);
    let kind = Oscillator::Linear;
    let cost = |p: &[f64]| rss(kind, p, t, z, settings.substeps);
    let predict = |p: &[f64], out: &mut [f64]| integrate(kind, p, t, settings.substeps, out);
    let amplitude = z
        .iter()
        .map(|v| (v - z_eq).abs())
        .fold(0.0, f64::max)
        .max(1e-12);
    let steps = [
        0.1 * omega,
        0.1 * omega,
        0.2 * omega * omega * amplitude,
        0.1 * amplitude,
        0.1 * amplitude * omega,
    ];
    let mut best = (f64::INFINITY, Vec::new(), 0);
    for ratio in [0.02, 0.1, 0.3, 1.0] {
        let start = vec![ratio * omega, omega, omega * omega * z_eq, z0, v0];
        let (p, c, it) = minimize(&cost, start, &steps, &settings.fit);
        if c < best.0 {
            best = (c, p, best.2 + it);
        } else {
            best.2 += it;
        }
    }
    finish(Oscillator::Linear.names(), best.1, z, &predict, best.2)
}

fn fit_van_der_pol(t: &[f64], z: &[f64], settings: &OscillatorSettings, linear: &Fit) -> Fit {
    let [lambda, omega, g, z0, v0] = linear.params[..] else {
        unreachable!("the linear oscillator has five parameters")
    };
    let z_eq = g / (omega * omega);
    // Linearized damping at z*: 2α (z*² − 2 z*) = 2λ.
    let slope = z_eq * z_eq - 2.0 * z_eq;
    let alpha = if slope.abs() > 1e-3 {
        lambda / slope
    } else {
        lambda
    };
    let kind = Oscillator::VanDerPol;
    let cost = |p: &[f64]| rss(kind, p, t, z, settings.substeps);
    let predict = |p: &[f64], out: &mut [f64]| integrate(kind, p, t, settings.substeps, out);
    let scale = |v: f64| 0.1 * v.abs().max(1e-3 * omega.abs().max(1e-12));
    let steps = [scale(alpha), scale(omega), scale(g), scale(z0), scale(v0)];
    let (p, _, iterations) = minimize(&cost, vec![alpha, omega, g, z0, v0], &steps, &settings.fit);
    finish(Oscillator::VanDerPol.names(), p, z, &predict, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::fit::curves::tests::{assert_recovers, noise};

    /// Exact solution of the underdamped linear oscillator.
    fn exact_linear(p: &[f64], t: f64) -> f64 {
        let [lambda, omega, g, z0, v0] = p[..] else {
            unreachable!()
        };
        let z_eq = g / (omega * omega);
        let wd = (omega * omega - lambda * lambda).sqrt();
        let (a, b) = (z0 - z_eq, (v0 + lambda * (z0 - z_eq)) / wd);
        z_eq + (-lambda * t).exp() * (a * (wd * t).cos() + b * (wd * t).sin())
    }

    #[test]
    fn rk4_converges_at_fourth_order() {
        let p = [0.3, 2.0, 4.0, 0.0, 1.0];
        let t: Vec<f64> = (0..=40).map(|k| f64::from(k) * 0.25).collect();
        let error = |substeps: usize| {
            let mut out = vec![0.0; t.len()];
            integrate(Oscillator::Linear, &p, &t, substeps, &mut out);
            t.iter()
                .zip(&out)
                .map(|(s, z)| (z - exact_linear(&p, *s)).abs())
                .fold(0.0, f64::max)
        };
        let (e1, e2, e4) = (error(2), error(4), error(8));
        for ratio in [e1 / e2, e2 / e4] {
            assert!((ratio.log2() - 4.0).abs() < 0.3, "order {}", ratio.log2());
        }
    }

    /// Samples of an oscillator at 200 times over `span`, with noise.
    fn synthetic(
        kind: Oscillator,
        p: &[f64],
        span: f64,
        sigma: f64,
        seed: u64,
    ) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..200).map(|k| span * f64::from(k) / 199.0).collect();
        let mut z = vec![0.0; t.len()];
        integrate(kind, p, &t, 64, &mut z);
        for (v, e) in z.iter_mut().zip(noise(t.len(), sigma, seed)) {
            *v += e;
        }
        (t, z)
    }

    #[test]
    fn linear_oscillator_recovers_parameters() {
        let truth = [0.25, 3.0, 9.0, 0.2, 0.0];
        let (t, z) = synthetic(Oscillator::Linear, &truth, 10.0, 0.01, 21);
        let fit =
            fit_oscillator(Oscillator::Linear, &t, &z, &OscillatorSettings::default()).unwrap();
        assert_recovers(&fit, &truth, 0.01);
    }

    #[test]
    fn van_der_pol_recovers_parameters_and_beats_linear() {
        // Equilibrium z* = g0/ω² = 2.5, outside (0, 2): positive damping 2α(z² − 2z) there.
        let truth = [0.08, 2.0, 10.0, 1.0, 0.0];
        let (t, z) = synthetic(Oscillator::VanDerPol, &truth, 12.0, 0.01, 22);
        let settings = OscillatorSettings::default();
        let fit = fit_oscillator(Oscillator::VanDerPol, &t, &z, &settings).unwrap();
        assert_recovers(&fit, &truth, 0.01);
        let linear = fit_oscillator(Oscillator::Linear, &t, &z, &settings).unwrap();
        assert!(linear.rss > 2.0 * fit.rss, "{} vs {}", linear.rss, fit.rss);
        // The integrator inside the objective is converged: doubling the steps moves every
        // parameter by far less than its standard error.
        let fine = OscillatorSettings {
            substeps: 2 * settings.substeps,
            ..settings
        };
        let refit = fit_oscillator(Oscillator::VanDerPol, &t, &z, &fine).unwrap();
        for k in 0..5 {
            assert!(
                (refit.params[k] - fit.params[k]).abs() < 0.05 * fit.std_errors[k],
                "{k}"
            );
        }
    }

    #[test]
    fn bad_samples_are_an_error() {
        let t = [0.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let s = OscillatorSettings::default();
        assert!(fit_oscillator(Oscillator::Linear, &t, &[0.0; 8], &s).is_err());
        assert!(fit_oscillator(Oscillator::Linear, &t[..4], &[0.0; 4], &s).is_err());
    }
}
