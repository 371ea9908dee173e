//! Gaussian-process regression on the unit cube (Rasmussen & Williams 2006, ch. 2 and 5):
//! Matérn 5/2 kernel with one length scale per dimension (ARD), constant mean, heteroscedastic
//! noise (a known variance per observation plus a fitted homoscedastic nugget), outputs
//! standardized to mean 0 and standard deviation 1.
//!
//! The observations are `y_i = f(x_i) + ε_i` with `ε_i ~ N(0, s_i² + σ_n²)`: `s_i²` is given
//! (for a replicate mean, the replicates' sample variance over their count), the nugget `σ_n²`
//! is a hyperparameter. The constant mean is the generalized-least-squares estimate for the
//! current kernel (profiled out of the likelihood). The hyperparameters (signal variance
//! `σ_f²`, length scales `ℓ_j`, nugget `σ_n²`) maximize the log marginal likelihood (R&W
//! eq. 2.30) over a box, by argmin's Nelder–Mead from a fixed start and a seeded Sobol' set of
//! starts in the box's (log-)coordinates, so a fit depends only on the data and the seed.

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use crate::study::design::{unit_points, Method};

/// Box of the signal variance (standardized outputs).
pub const SIGNAL: (f64, f64) = (1e-2, 1e2);
/// Box of the length scales (unit cube).
pub const LENGTH: (f64, f64) = (1e-2, 1e1);
/// Box of the nugget (standardized outputs).
pub const NUGGET: (f64, f64) = (1e-8, 2.0);
/// Relative jitter added to the diagonal for numerical stability.
const JITTER: f64 = 1e-10;
/// Starts of the likelihood maximization (the box centre and Sobol' points).
const FIT_STARTS: usize = 6;
/// Nelder–Mead iterations per start.
const FIT_ITERATIONS: u64 = 400;

/// Kernel and noise hyperparameters, in standardized output units on the unit cube.
#[derive(Debug, Clone, PartialEq)]
pub struct Hyper {
    /// Signal variance σ_f².
    pub signal: f64,
    /// Length scales ℓ_j, one per dimension.
    pub lengths: Vec<f64>,
    /// Homoscedastic nugget σ_n² (added to every observation's known noise).
    pub nugget: f64,
}

impl Hyper {
    /// Hyperparameters from unconstrained coordinates θ: each maps through a logistic onto its
    /// box in log space (θ = 0 is the box's geometric centre).
    fn from_theta(theta: &[f64]) -> Self {
        let map = |t: f64, (lo, hi): (f64, f64)| {
            let s = 1.0 / (1.0 + (-t).exp());
            (lo.ln() + s * (hi.ln() - lo.ln())).exp()
        };
        let d = theta.len() - 2;
        Hyper {
            signal: map(theta[0], SIGNAL),
            lengths: theta[1..=d].iter().map(|&t| map(t, LENGTH)).collect(),
            nugget: map(theta[d + 1], NUGGET),
        }
    }
}

/// Matérn 5/2 correlation at scaled distance r.
fn matern52(r: f64) -> f64 {
    let s = 5f64.sqrt() * r;
    (1.0 + s + s * s / 3.0) * (-s).exp()
}

/// A fitted (or given-hyperparameter) Gaussian process.
#[derive(Debug, Clone)]
pub struct Gp {
    x: Vec<Vec<f64>>,
    /// Standardized observations.
    y: Vec<f64>,
    /// Standardized known noise variances.
    noise: Vec<f64>,
    hyper: Hyper,
    /// y_standardized = (y − shift) / scale.
    shift: f64,
    scale: f64,
    /// Constant mean (standardized).
    mean: f64,
    chol: Cholesky<f64, Dyn>,
    /// K⁻¹ (y − mean).
    alpha: DVector<f64>,
    lml: f64,
}

/// Shift and scale that standardize `y` (scale 1 when the values do not vary).
pub fn standardization(y: &[f64]) -> (f64, f64) {
    let n = y.len() as f64;
    if y.is_empty() {
        return (0.0, 1.0);
    }
    let shift = y.iter().sum::<f64>() / n;
    let var = y.iter().map(|v| (v - shift).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let scale = var.sqrt();
    (
        shift,
        if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        },
    )
}

impl Gp {
    /// Fits the hyperparameters by maximum marginal likelihood. `x`: points in the unit cube,
    /// `y`: observed values, `noise`: their known noise variances (≥ 0, original units).
    /// Returns None when there is no data.
    pub fn fit(x: &[Vec<f64>], y: &[f64], noise: &[f64], seed: u64) -> Option<Gp> {
        let d = x.first()?.len();
        let (shift, scale) = standardization(y);
        let ys: Vec<f64> = y.iter().map(|v| (v - shift) / scale).collect();
        let ns: Vec<f64> = noise.iter().map(|v| v.max(0.0) / (scale * scale)).collect();
        let diffs = Diffs::new(x);
        struct Cost<'a> {
            diffs: &'a Diffs,
            y: &'a [f64],
            noise: &'a [f64],
        }
        impl CostFunction for Cost<'_> {
            type Param = Vec<f64>;
            type Output = f64;
            fn cost(&self, theta: &Vec<f64>) -> Result<f64, argmin::core::Error> {
                let hyper = Hyper::from_theta(theta);
                Ok(match factor(self.diffs, self.y, self.noise, &hyper, None) {
                    Some(f) => -f.lml,
                    None => 1e30,
                })
            }
        }
        let p = d + 2;
        let mut starts = vec![vec![0.0; p]];
        if let Ok(points) = unit_points(Method::Sobol, FIT_STARTS - 1, p, seed ^ 0x0067_7066_6974) {
            starts.extend(
                points
                    .into_iter()
                    .map(|u| u.into_iter().map(|t| 6.0 * (t - 0.5)).collect()),
            );
        }
        let cost = Cost {
            diffs: &diffs,
            y: &ys,
            noise: &ns,
        };
        let mut best: Option<(f64, Vec<f64>)> = None;
        for start in starts {
            let (theta, value) = nelder_mead(&cost, &start, 1.0, FIT_ITERATIONS, 1e-9);
            if best.as_ref().is_none_or(|(b, _)| value < *b) {
                best = Some((value, theta));
            }
        }
        let (_, theta) = best?;
        Self::with_hyper(x, y, noise, Hyper::from_theta(&theta))
    }

    /// A process with the given hyperparameters (standardized units), standardizing `y`.
    pub fn with_hyper(x: &[Vec<f64>], y: &[f64], noise: &[f64], hyper: Hyper) -> Option<Gp> {
        let (shift, scale) = standardization(y);
        let ys: Vec<f64> = y.iter().map(|v| (v - shift) / scale).collect();
        let ns: Vec<f64> = noise.iter().map(|v| v.max(0.0) / (scale * scale)).collect();
        let f = factor(&Diffs::new(x), &ys, &ns, &hyper, None)?;
        Some(Gp {
            x: x.to_vec(),
            y: ys,
            noise: ns,
            hyper,
            shift,
            scale,
            mean: f.mean,
            chol: f.chol,
            alpha: f.alpha,
            lml: f.lml,
        })
    }

    /// The process with one more observation (`value` and known `noise` variance in original
    /// units), keeping hyperparameters, standardization and constant mean: the fantasy of the
    /// kriging believer.
    pub fn condition(&self, z: &[f64], value: f64, noise: f64) -> Option<Gp> {
        let mut x = self.x.clone();
        x.push(z.to_vec());
        let mut y = self.y.clone();
        y.push((value - self.shift) / self.scale);
        let mut ns = self.noise.clone();
        ns.push(noise.max(0.0) / (self.scale * self.scale));
        let f = factor(&Diffs::new(&x), &y, &ns, &self.hyper, Some(self.mean))?;
        Some(Gp {
            x,
            y,
            noise: ns,
            hyper: self.hyper.clone(),
            chol: f.chol,
            alpha: f.alpha,
            lml: f.lml,
            ..*self
        })
    }

    /// Posterior mean and variance of the latent f at `z` (original units; the variance
    /// excludes observation noise).
    pub fn predict(&self, z: &[f64]) -> (f64, f64) {
        let k = DVector::from_iterator(self.x.len(), self.x.iter().map(|xi| self.kernel(xi, z)));
        let mean = self.mean + k.dot(&self.alpha);
        let v = self
            .chol
            .l_dirty()
            .solve_lower_triangular(&k)
            .unwrap_or_else(|| DVector::zeros(k.len()));
        let var = (self.hyper.signal - v.dot(&v)).max(0.0);
        (
            mean * self.scale + self.shift,
            var * self.scale * self.scale,
        )
    }

    fn kernel(&self, a: &[f64], b: &[f64]) -> f64 {
        let r2: f64 = a
            .iter()
            .zip(b)
            .zip(&self.hyper.lengths)
            .map(|((p, q), l)| ((p - q) / l).powi(2))
            .sum();
        self.hyper.signal * matern52(r2.sqrt())
    }

    /// The hyperparameters (standardized units).
    pub fn hyper(&self) -> &Hyper {
        &self.hyper
    }

    /// Log marginal likelihood of the standardized data.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Output scale of the standardization (original units per standardized unit).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The observed points.
    pub fn points(&self) -> &[Vec<f64>] {
        &self.x
    }
}

/// Squared coordinate differences of every pair, per dimension (reused across likelihood
/// evaluations).
struct Diffs {
    n: usize,
    /// per dimension, n × n (row-major)
    sq: Vec<Vec<f64>>,
}

impl Diffs {
    fn new(x: &[Vec<f64>]) -> Self {
        let n = x.len();
        let d = x.first().map_or(0, Vec::len);
        let sq = (0..d)
            .map(|j| {
                let mut m = vec![0.0; n * n];
                for a in 0..n {
                    for b in 0..n {
                        m[a * n + b] = (x[a][j] - x[b][j]).powi(2);
                    }
                }
                m
            })
            .collect();
        Diffs { n, sq }
    }
}

struct Factor {
    mean: f64,
    chol: Cholesky<f64, Dyn>,
    alpha: DVector<f64>,
    lml: f64,
}

/// Cholesky factor of the covariance of the observations, the constant mean (given, or the
/// GLS estimate) and the log marginal likelihood. None when not positive definite.
fn factor(
    diffs: &Diffs,
    y: &[f64],
    noise: &[f64],
    hyper: &Hyper,
    mean: Option<f64>,
) -> Option<Factor> {
    let n = diffs.n;
    if n == 0 {
        return None;
    }
    let inv: Vec<f64> = hyper.lengths.iter().map(|l| 1.0 / (l * l)).collect();
    let mut k = DMatrix::<f64>::zeros(n, n);
    for a in 0..n {
        for b in 0..=a {
            let r2: f64 = diffs
                .sq
                .iter()
                .zip(&inv)
                .map(|(m, w)| m[a * n + b] * w)
                .sum();
            let v = hyper.signal * matern52(r2.sqrt());
            k[(a, b)] = v;
            k[(b, a)] = v;
        }
        k[(a, a)] += noise[a] + hyper.nugget + JITTER * hyper.signal;
    }
    let chol = Cholesky::new(k)?;
    let yv = DVector::from_column_slice(y);
    let mean = match mean {
        Some(m) => m,
        None => {
            let ones = DVector::from_element(n, 1.0);
            let kinv_one = chol.solve(&ones);
            let denom = kinv_one.sum();
            if denom > 0.0 {
                kinv_one.dot(&yv) / denom
            } else {
                0.0
            }
        }
    };
    let r = yv.add_scalar(-mean);
    let alpha = chol.solve(&r);
    let log_det: f64 = chol.l_dirty().diagonal().iter().map(|v| v.ln()).sum();
    let lml = -0.5 * r.dot(&alpha) - log_det - 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
    lml.is_finite().then_some(Factor {
        mean,
        chol,
        alpha,
        lml,
    })
}

/// Argmin's Nelder–Mead from `start` with an axis-aligned initial simplex of size `step`:
/// the best parameters and cost (the start's when the solver fails).
pub(crate) fn nelder_mead<C>(
    cost: &C,
    start: &[f64],
    step: f64,
    iterations: u64,
    tol: f64,
) -> (Vec<f64>, f64)
where
    C: CostFunction<Param = Vec<f64>, Output = f64>,
{
    let p = start.len();
    let simplex: Vec<Vec<f64>> = (0..=p)
        .map(|k| {
            let mut v = start.to_vec();
            if k > 0 {
                v[k - 1] += step;
            }
            v
        })
        .collect();
    let fallback = || {
        let c = cost.cost(&start.to_vec()).unwrap_or(f64::INFINITY);
        (start.to_vec(), c)
    };
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(tol) else {
        return fallback();
    };
    struct By<'a, C>(&'a C);
    impl<C: CostFunction<Param = Vec<f64>, Output = f64>> CostFunction for By<'_, C> {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
            self.0.cost(p)
        }
    }
    match Executor::new(By(cost), solver)
        .configure(|s| s.max_iters(iterations))
        .run()
    {
        Ok(res) => match res.state.best_param {
            Some(p) => (p, res.state.best_cost),
            None => fallback(),
        },
        Err(_) => fallback(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn grid(n: usize) -> Vec<Vec<f64>> {
        (0..n).map(|i| vec![i as f64 / (n - 1) as f64]).collect()
    }

    #[test]
    fn interpolates_noise_free_data() {
        let x: Vec<Vec<f64>> = unit_points(Method::Sobol, 16, 2, 3).unwrap();
        let f = |p: &[f64]| (3.0 * p[0]).sin() + p[1] * p[1] * 2.0 + 5.0;
        let y: Vec<f64> = x.iter().map(|p| f(p)).collect();
        let gp = Gp::fit(&x, &y, &vec![0.0; y.len()], 1).unwrap();
        for (p, v) in x.iter().zip(&y) {
            let (m, var) = gp.predict(p);
            assert!((m - v).abs() < 1e-3, "{m} vs {v}");
            assert!(var < 1e-4, "variance {var} at an observed point");
        }
        // and it predicts in between
        let (m, _) = gp.predict(&[0.5, 0.5]);
        assert!((m - f(&[0.5, 0.5])).abs() < 0.05, "{m}");
    }

    #[test]
    fn posterior_variance_at_observed_points_is_about_the_noise() {
        // isolated points (short length scale): the posterior variance of f at an observed
        // point is σ_f² τ² / (σ_f² + τ²) ≈ τ² for τ² ≪ σ_f²
        let x = grid(5);
        let y = vec![1.0, -1.0, 0.5, 2.0, -0.5];
        let (_, scale) = standardization(&y);
        let tau2 = [0.01, 0.02, 0.04, 0.01, 0.03].map(|t: f64| t * scale * scale);
        let hyper = Hyper {
            signal: 1.0,
            lengths: vec![0.01],
            nugget: 1e-8,
        };
        let gp = Gp::with_hyper(&x, &y, &tau2, hyper).unwrap();
        for (p, t) in x.iter().zip(tau2) {
            let (_, var) = gp.predict(p);
            let expected = scale * scale * t / (scale * scale + t);
            assert!((var / expected - 1.0).abs() < 1e-3, "{var} vs {expected}");
            assert!((var / t - 1.0).abs() < 0.05);
        }
        // far from data: the prior variance
        let (_, var) = gp.predict(&[0.125]);
        assert!((var / (scale * scale) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn fit_recovers_a_known_length_scale() {
        // a draw from a GP with ℓ = 0.2 at 60 points in 1D
        let n = 60;
        let x = grid(n);
        let truth = Hyper {
            signal: 1.0,
            lengths: vec![0.2],
            nugget: 1e-6,
        };
        let f = factor(
            &Diffs::new(&x),
            &vec![0.0; n],
            &vec![0.0; n],
            &truth,
            Some(0.0),
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let z = DVector::from_iterator(n, (0..n).map(|_| StandardNormal.sample(&mut rng)));
        let draw = f.chol.l() * z;
        let y: Vec<f64> = draw.iter().map(|v| 3.0 * v + 10.0).collect();
        let gp = Gp::fit(&x, &y, &vec![0.0; n], 2).unwrap();
        let l = gp.hyper().lengths[0];
        assert!((0.1..0.4).contains(&l), "length scale {l}");
        // the fit is at least as likely as the truth
        let at_truth = Gp::with_hyper(&x, &y, &vec![0.0; n], {
            let (_, s) = standardization(&y);
            Hyper {
                signal: 9.0 / (s * s),
                ..truth
            }
        })
        .unwrap();
        assert!(gp.log_marginal_likelihood() >= at_truth.log_marginal_likelihood() - 1e-6);
    }

    #[test]
    fn standardization_makes_predictions_affine_equivariant() {
        let x: Vec<Vec<f64>> = unit_points(Method::LatinHypercube, 12, 2, 4).unwrap();
        let y: Vec<f64> = x
            .iter()
            .map(|p| (p[0] - 0.3).powi(2) + 0.5 * p[1])
            .collect();
        let noise = vec![1e-4; y.len()];
        let (a, b) = (250.0, -7.0);
        let y2: Vec<f64> = y.iter().map(|v| a * v + b).collect();
        let noise2: Vec<f64> = noise.iter().map(|v| v * a * a).collect();
        let g1 = Gp::fit(&x, &y, &noise, 9).unwrap();
        let g2 = Gp::fit(&x, &y2, &noise2, 9).unwrap();
        let (shift, scale) = standardization(&y2);
        let ys: Vec<f64> = y2.iter().map(|v| (v - shift) / scale).collect();
        let mean = ys.iter().sum::<f64>() / ys.len() as f64;
        let sd =
            (ys.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (ys.len() - 1) as f64).sqrt();
        assert!(mean.abs() < 1e-12 && (sd - 1.0).abs() < 1e-12);
        for hyper in [g1.hyper(), g2.hyper()] {
            assert!(hyper.lengths.iter().all(|l| l.is_finite()));
        }
        for p in [[0.1, 0.9], [0.5, 0.5], [0.8, 0.2]] {
            let (m1, v1) = g1.predict(&p);
            let (m2, v2) = g2.predict(&p);
            assert!((a * m1 + b - m2).abs() < 1e-6 * a, "{m1} {m2}");
            assert!(
                (a * a * v1 - v2).abs() < 1e-6 * a * a + 1e-9 * v2,
                "{v1} {v2}"
            );
        }
    }
}
