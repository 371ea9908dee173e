//! Acquisition for noisy objectives: expected improvement with plug-in (Picheny, Wagner &
//! Ginsbourger 2013, sec. 3.2), i.e. the expected improvement of Jones, Schonlau & Welch (1998)
//! of the latent function over the best posterior mean among the observed points (not over
//! the best noisy observation, which noise biases low). Batches of q points come from the
//! kriging believer (Ginsbourger, Le Riche & Carraro 2010): after each choice the process is
//! conditioned on its own posterior mean there, and the next point maximizes the expected
//! improvement of that fantasy. The inner maximization runs argmin's Nelder–Mead (on
//! log EI, which stays informative where EI underflows) from the best points of a seeded
//! Sobol' set and from the observed points with the best posterior means.

use argmin::core::CostFunction;

use super::gp::{nelder_mead, Gp};
use crate::numerics::special::normal_cdf;
use crate::study::design::{unit_points, Method};

/// Sobol' candidates scored before the local searches.
const CANDIDATES: usize = 512;
/// Local searches from the best candidates.
const SOBOL_STARTS: usize = 6;
/// Local searches from the observed points with the best posterior means.
const OBSERVED_STARTS: usize = 3;
/// Nelder–Mead iterations per local search.
const LOCAL_ITERATIONS: u64 = 200;

/// Expected improvement below `target` of a normal with mean `mu` and standard deviation
/// `sigma` (Jones et al. 1998, eq. 15): (T − μ) Φ(z) + σ φ(z), z = (T − μ)/σ.
pub fn expected_improvement(mu: f64, sigma: f64, target: f64) -> f64 {
    if sigma <= 0.0 || !sigma.is_finite() {
        return (target - mu).max(0.0);
    }
    let z = (target - mu) / sigma;
    sigma * h(z)
}

/// ln EI, accurate where EI underflows (−∞ only for σ = 0 and μ ≥ T).
pub fn log_expected_improvement(mu: f64, sigma: f64, target: f64) -> f64 {
    if sigma <= 0.0 || !sigma.is_finite() {
        return (target - mu).max(0.0).ln();
    }
    let z = (target - mu) / sigma;
    sigma.ln() + log_h(z)
}

/// h(z) = z Φ(z) + φ(z).
fn h(z: f64) -> f64 {
    z * normal_cdf(z) + phi(z)
}

fn phi(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// ln h(z): directly for z > −10, else by the asymptotic series of the Mills ratio,
/// h(z) = φ(z) (1/z² − 3/z⁴ + 15/z⁶ − 105/z⁸ + …).
fn log_h(z: f64) -> f64 {
    if z > -10.0 {
        return h(z).max(f64::MIN_POSITIVE).ln();
    }
    let w = 1.0 / (z * z);
    let series = w * (1.0 - 3.0 * w * (1.0 - 5.0 * w * (1.0 - 7.0 * w)));
    -0.5 * z * z - 0.5 * (2.0 * std::f64::consts::PI).ln() + series.ln()
}

/// The plug-in target: the smallest posterior mean among the process's observed points.
pub fn plug_in_target(gp: &Gp) -> f64 {
    gp.points()
        .iter()
        .map(|p| gp.predict(p).0)
        .fold(f64::INFINITY, f64::min)
}

/// EI with plug-in of `gp` at `z` (original units).
pub fn plug_in_ei(gp: &Gp, z: &[f64], target: f64) -> f64 {
    let (m, v) = gp.predict(z);
    expected_improvement(m, v.sqrt(), target)
}

/// Points of the unit cube clamped into [0, 1] and the squared distance moved.
fn clamp(z: &[f64]) -> (Vec<f64>, f64) {
    let c: Vec<f64> = z.iter().map(|v| v.clamp(0.0, 1.0)).collect();
    let d2 = z.iter().zip(&c).map(|(a, b)| (a - b).powi(2)).sum();
    (c, d2)
}

/// Minimizes `f` over the unit cube: scores `candidates`, then runs Nelder–Mead from the
/// best `SOBOL_STARTS` of them and from `extra` starts. Returns the best point (clamped).
fn minimize_over_cube(
    f: &dyn Fn(&[f64]) -> f64,
    candidates: &[Vec<f64>],
    extra: &[Vec<f64>],
) -> (Vec<f64>, f64) {
    struct Cost<'a>(&'a dyn Fn(&[f64]) -> f64);
    impl CostFunction for Cost<'_> {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, z: &Vec<f64>) -> Result<f64, argmin::core::Error> {
            let (c, d2) = clamp(z);
            Ok((self.0)(&c) + 1e3 * d2)
        }
    }
    let mut scored: Vec<(f64, &Vec<f64>)> = candidates.iter().map(|c| (f(c), c)).collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best: Option<(Vec<f64>, f64)> = None;
    let starts = scored
        .iter()
        .take(SOBOL_STARTS)
        .map(|s| s.1)
        .chain(extra.iter());
    for start in starts {
        let (p, _) = nelder_mead(&Cost(f), start, 0.05, LOCAL_ITERATIONS, 1e-12);
        let (p, _) = clamp(&p);
        let v = f(&p);
        if best.as_ref().is_none_or(|b| v < b.1) {
            best = Some((p, v));
        }
    }
    if let Some((v, c)) = scored.first() {
        if best.as_ref().is_none_or(|b| *v < b.1) {
            best = Some(((*c).clone(), *v));
        }
    }
    best.unwrap_or_else(|| (vec![0.5; extra.first().map_or(0, Vec::len)], f64::INFINITY))
}

/// The observed points of `gp` with the smallest posterior means, best first.
fn best_observed(gp: &Gp, k: usize) -> Vec<Vec<f64>> {
    let mut by: Vec<(f64, &Vec<f64>)> = gp.points().iter().map(|p| (gp.predict(p).0, p)).collect();
    by.sort_by(|a, b| a.0.total_cmp(&b.0));
    by.into_iter().take(k).map(|(_, p)| p.clone()).collect()
}

/// Seeded Sobol' candidates in `dims` dimensions.
pub fn candidates(dims: usize, seed: u64) -> Vec<Vec<f64>> {
    unit_points(Method::Sobol, CANDIDATES, dims, seed).unwrap_or_default()
}

/// One proposal of a batch and its expected improvement (original units, under the
/// process conditioned on the batch's earlier proposals).
#[derive(Debug, Clone)]
pub struct Proposal {
    /// Point in the unit cube.
    pub x: Vec<f64>,
    /// Its expected improvement with plug-in.
    pub ei: f64,
}

/// A batch of `q` points by the kriging believer. `noise`: the noise variance (original
/// units) assumed for the fantasy observations; `seed` keys the Sobol' candidates.
pub fn propose_batch(gp: &Gp, q: usize, noise: f64, seed: u64) -> Vec<Proposal> {
    let dims = gp.points().first().map_or(0, Vec::len);
    let cands = candidates(dims, seed);
    let mut current = gp.clone();
    let mut out = Vec::with_capacity(q);
    for _ in 0..q {
        let target = plug_in_target(&current);
        let score = |z: &[f64]| {
            let (m, v) = current.predict(z);
            -log_expected_improvement(m, v.sqrt(), target).max(-1e4)
        };
        let extra = best_observed(&current, OBSERVED_STARTS);
        let (x, _) = minimize_over_cube(&score, &cands, &extra);
        let ei = plug_in_ei(&current, &x, target);
        let (m, _) = current.predict(&x);
        out.push(Proposal { x: x.clone(), ei });
        match current.condition(&x, m, noise) {
            Some(next) => current = next,
            None => break,
        }
    }
    out
}

/// The minimizer of the posterior mean over the unit cube: (point, mean, latent variance).
pub fn minimize_posterior_mean(gp: &Gp, seed: u64) -> (Vec<f64>, f64, f64) {
    let dims = gp.points().first().map_or(0, Vec::len);
    let cands = candidates(dims, seed);
    let extra = best_observed(gp, OBSERVED_STARTS + 2);
    let mean = |z: &[f64]| gp.predict(z).0;
    let (x, _) = minimize_over_cube(&mean, &cands, &extra);
    let (m, v) = gp.predict(&x);
    (x, m, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expected_improvement_limits() {
        // σ → 0: the plain improvement
        assert_eq!(expected_improvement(1.0, 0.0, 3.0), 2.0);
        assert_eq!(expected_improvement(3.0, 0.0, 1.0), 0.0);
        // at μ = T: σ φ(0)
        let e = expected_improvement(2.0, 0.5, 2.0);
        assert!((e - 0.5 * 0.398_942_280_401_432_7).abs() < 1e-12);
        // log EI agrees where EI is representable, and is finite far below
        for z in [-9.9, -5.0, -1.0, 0.0, 2.0] {
            let (e, l) = (
                expected_improvement(0.0, 1.0, z),
                log_expected_improvement(0.0, 1.0, z),
            );
            assert!((e.ln() - l).abs() < 1e-6 * l.abs().max(1.0), "{z}: {e} {l}");
        }
        let near = log_expected_improvement(0.0, 1.0, -10.0 - 1e-9);
        let at = expected_improvement(0.0, 1.0, -10.0).ln();
        assert!((near - at).abs() < 1e-3, "{near} vs {at}");
        assert!(log_expected_improvement(0.0, 1.0, -60.0).is_finite());
    }
}
