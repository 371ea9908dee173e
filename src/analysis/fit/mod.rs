//! Least-squares fits (spec analysis.md, "Fits"): the minimization is argmin's Nelder–Mead
//! (restarted from the best point until it stops improving); parameter standard errors come
//! from the Jacobian of the model at the optimum, cov = s² (JᵀJ)⁻¹ with s² = RSS / (n − p).
//!
//! - [`curves`]: linear (closed form) with R², power law y = a x^b, bi-exponential
//!   y = A e^{λ1 x} + B e^{λ2 x} (amplitudes by linear least squares for given rates);
//! - [`oscillator`]: the damper's Van der Pol-like ODE and the linear damped oscillator,
//!   integrated by fixed-step RK4 inside the objective.

pub mod curves;
pub mod oscillator;

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use nalgebra::DMatrix;

use crate::{Error, Result};

/// Controls of the Nelder–Mead minimization.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FitSettings {
    /// Iteration cap of one Nelder–Mead run (default 4000).
    pub max_iterations: u64,
    /// Restarts from the best point with a fresh simplex (default 6); restarting stops early
    /// once a restart improves the RSS by less than 1e-12 relative.
    pub restarts: usize,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            max_iterations: 4000,
            restarts: 6,
        }
    }
}

/// A fitted model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Fit {
    /// Parameter names, in the order of `params`.
    pub names: Vec<&'static str>,
    /// Best-fit parameters.
    pub params: Vec<f64>,
    /// Standard errors of the parameters (NaN if the Jacobian is singular or n ≤ p).
    pub std_errors: Vec<f64>,
    /// Residuals y_i − model(x_i).
    pub residuals: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Root-mean-square residual √(RSS / n).
    pub rmse: f64,
    /// Coefficient of determination 1 − RSS / Σ (y − ȳ)².
    pub r_squared: f64,
    /// Number of Nelder–Mead iterations (0 for closed forms).
    pub iterations: u64,
}

impl Fit {
    /// The parameter called `name`.
    ///
    /// # Panics
    /// If the fit has no such parameter (a programming error).
    pub fn param(&self, name: &str) -> f64 {
        let k = self.names.iter().position(|n| *n == name);
        self.params[k.unwrap_or_else(|| panic!("fit has no parameter '{name}'"))]
    }
}

/// Checks paired data: equal lengths, at least `min` points, all finite.
pub(crate) fn check_data(what: &str, x: &[f64], y: &[f64], min: usize) -> Result<()> {
    if x.len() != y.len() || x.len() < min {
        return Err(Error::input(format!(
            "{what} fit needs equally many x and y values, at least {min}; got {} and {}",
            x.len(),
            y.len()
        )));
    }
    if let Some(i) = (0..x.len()).find(|i| !(x[*i].is_finite() && y[*i].is_finite())) {
        return Err(Error::input(format!(
            "{what} fit: point {i} is ({}, {}); all values must be finite",
            x[i], y[i]
        )));
    }
    Ok(())
}

/// Builds the [`Fit`] at `params`: residuals, RSS, R² and standard errors from a central
/// finite-difference Jacobian of `predict` (which fills the model values at every x).
pub(crate) fn finish(
    names: Vec<&'static str>,
    params: Vec<f64>,
    y: &[f64],
    predict: &dyn Fn(&[f64], &mut [f64]),
    iterations: u64,
) -> Fit {
    let n = y.len();
    let mut model = vec![0.0; n];
    predict(&params, &mut model);
    let residuals: Vec<f64> = y.iter().zip(&model).map(|(a, b)| a - b).collect();
    let rss: f64 = residuals.iter().map(|r| r * r).sum();
    let mean = y.iter().sum::<f64>() / n as f64;
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let std_errors = std_errors(&params, n, rss, predict);
    Fit {
        names,
        params,
        std_errors,
        rmse: (rss / n as f64).sqrt(),
        r_squared: 1.0 - rss / tss,
        rss,
        residuals,
        iterations,
    }
}

/// √diag(s² (JᵀJ)⁻¹), J by central differences with steps 1e-6 · max(|p_j|, 1e-6).
fn std_errors(
    params: &[f64],
    n: usize,
    rss: f64,
    predict: &dyn Fn(&[f64], &mut [f64]),
) -> Vec<f64> {
    let p = params.len();
    if n <= p {
        return vec![f64::NAN; p];
    }
    let mut jac = DMatrix::<f64>::zeros(n, p);
    let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..p {
        let h = 1e-6 * params[j].abs().max(1e-6);
        let mut q = params.to_vec();
        q[j] = params[j] + h;
        predict(&q, &mut plus);
        q[j] = params[j] - h;
        predict(&q, &mut minus);
        for i in 0..n {
            jac[(i, j)] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    let s2 = rss / (n - p) as f64;
    match (jac.transpose() * &jac).try_inverse() {
        Some(inv) => (0..p).map(|j| (s2 * inv[(j, j)]).sqrt()).collect(),
        None => vec![f64::NAN; p],
    }
}

/// The objective as argmin sees it (NaN becomes +∞ so the simplex moves away from it).
struct Objective<'a> {
    cost: &'a dyn Fn(&[f64]) -> f64,
}

impl CostFunction for Objective<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let c = (self.cost)(p);
        Ok(if c.is_nan() { f64::INFINITY } else { c })
    }
}

/// Minimizes `cost` by Nelder–Mead from `start` with initial simplex steps `steps` (one per
/// parameter, non-zero), restarted from the best point; returns (best, cost, iterations).
pub(crate) fn minimize(
    cost: &dyn Fn(&[f64]) -> f64,
    start: Vec<f64>,
    steps: &[f64],
    settings: &FitSettings,
) -> (Vec<f64>, f64, u64) {
    let objective = |p: &[f64]| {
        let c = cost(p);
        if c.is_nan() {
            f64::INFINITY
        } else {
            c
        }
    };
    let mut best = (objective(&start), start);
    let mut iterations = 0;
    for _ in 0..=settings.restarts {
        let mut simplex = vec![best.1.clone()];
        for (j, s) in steps.iter().enumerate() {
            let mut v = best.1.clone();
            v[j] += s;
            simplex.push(v);
        }
        // Stop when the simplex's costs agree to ~1e-13 relative (far below any noise).
        let tolerance = if best.0.is_finite() {
            1e-13 * best.0.abs().max(f64::MIN_POSITIVE)
        } else {
            0.0
        };
        let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(tolerance) else {
            break;
        };
        let Ok(result) = Executor::new(Objective { cost: &objective }, solver)
            .configure(|s| s.max_iters(settings.max_iterations))
            .run()
        else {
            break;
        };
        let state = result.state();
        iterations += state.iter;
        let (Some(p), c) = (state.best_param.clone(), state.best_cost) else {
            break;
        };
        let improved = c < best.0 && (best.0 - c) > 1e-12 * best.0.abs();
        if c < best.0 {
            best = (c, p);
        }
        if !improved {
            break;
        }
    }
    (best.1, best.0, iterations)
}
