//! Curve fits: linear with R², power law, bi-exponential.

use super::{check_data, finish, minimize, Fit, FitSettings};
use crate::{Error, Result};

/// Straight line y = intercept + slope · x by ordinary least squares (closed form); R² in
/// [`Fit::r_squared`]. Parameters: `intercept`, `slope`.
///
/// # Errors
/// [`Error::Input`] for fewer than 2 points, a non-finite value or all x equal.
pub fn linear(x: &[f64], y: &[f64]) -> Result<Fit> {
    check_data("linear", x, y, 2)?;
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    if sxx == 0.0 {
        return Err(Error::input("linear fit: all x values are equal"));
    }
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let slope = sxy / sxx;
    let predict = |p: &[f64], out: &mut [f64]| {
        for (o, v) in out.iter_mut().zip(x) {
            *o = p[0] + p[1] * v;
        }
    };
    Ok(finish(
        vec!["intercept", "slope"],
        vec![my - slope * mx, slope],
        y,
        &predict,
        0,
    ))
}

/// Power law y = a x^b (x > 0), least squares in y. For a given b the amplitude a is linear and
/// solved exactly, so Nelder–Mead searches b alone, starting from the log–log line where all
/// y > 0. Parameters: `a`, `b`.
///
/// # Errors
/// [`Error::Input`] for fewer than 3 points, a non-finite value or some x ≤ 0.
pub fn power_law(x: &[f64], y: &[f64], settings: &FitSettings) -> Result<Fit> {
    check_data("power-law", x, y, 3)?;
    if let Some(i) = x.iter().position(|v| *v <= 0.0) {
        return Err(Error::input(format!(
            "power-law fit: x[{i}] = {} is not allowed (need x > 0)",
            x[i]
        )));
    }
    let start = if y.iter().all(|v| *v > 0.0) {
        let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
        let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
        linear(&lx, &ly).map_or(1.0, |f| f.param("slope"))
    } else {
        1.0
    };
    // Least-squares amplitude for a given exponent: a = Σ y x^b / Σ x^{2b}.
    let amplitude = |b: f64| {
        let (mut num, mut den) = (0.0, 0.0);
        for (v, w) in x.iter().zip(y) {
            let f = v.powf(b);
            num += w * f;
            den += f * f;
        }
        num / den
    };
    let rss_of = |p: &[f64]| {
        let a = amplitude(p[0]);
        x.iter()
            .zip(y)
            .map(|(v, w)| (w - a * v.powf(p[0])).powi(2))
            .sum::<f64>()
    };
    let (best, _, iterations) = minimize(&rss_of, vec![start], &[0.1], settings);
    let b = best[0];
    let a = amplitude(b);
    let predict = |p: &[f64], out: &mut [f64]| {
        for (o, v) in out.iter_mut().zip(x) {
            *o = p[0] * v.powf(p[1]);
        }
    };
    Ok(finish(vec!["a", "b"], vec![a, b], y, &predict, iterations))
}

/// Amplitudes (A, B) of y ≈ A e^{λ1 x} + B e^{λ2 x} by linear least squares (2×2 normal
/// equations); None if they are singular (λ1 ≈ λ2).
fn bi_exponential_amplitudes(x: &[f64], y: &[f64], l1: f64, l2: f64) -> Option<(f64, f64)> {
    let (mut s11, mut s12, mut s22, mut s1y, mut s2y) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (v, w) in x.iter().zip(y) {
        let (e1, e2) = ((l1 * v).exp(), (l2 * v).exp());
        s11 += e1 * e1;
        s12 += e1 * e2;
        s22 += e2 * e2;
        s1y += e1 * w;
        s2y += e2 * w;
    }
    let det = s11 * s22 - s12 * s12;
    if det.is_nan() || det.abs() <= 1e-12 * s11 * s22 {
        return None;
    }
    Some(((s22 * s1y - s12 * s2y) / det, (s11 * s2y - s12 * s1y) / det))
}

/// Bi-exponential y = A e^{λ1 x} + B e^{λ2 x} (variable projection: for given rates the
/// amplitudes are linear and solved exactly). The rates start from the best pair of a grid of
/// ±{0.1, 0.3, 1, 3, 10} / (x range) and 0, then Nelder–Mead refines them. Parameters `A`,
/// `lambda1`, `B`, `lambda2` with λ1 < λ2.
///
/// # Errors
/// [`Error::Input`] for fewer than 5 points, a non-finite value or all x equal.
pub fn bi_exponential(x: &[f64], y: &[f64], settings: &FitSettings) -> Result<Fit> {
    check_data("bi-exponential", x, y, 5)?;
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi == lo {
        return Err(Error::input("bi-exponential fit: all x values are equal"));
    }
    let rss_of = |p: &[f64]| match bi_exponential_amplitudes(x, y, p[0], p[1]) {
        Some((a, b)) => x
            .iter()
            .zip(y)
            .map(|(v, w)| (w - a * (p[0] * v).exp() - b * (p[1] * v).exp()).powi(2))
            .sum::<f64>(),
        None => f64::INFINITY,
    };
    let scale = 1.0 / (hi - lo);
    let mut grid = vec![0.0];
    for m in [0.1, 0.3, 1.0, 3.0, 10.0] {
        grid.extend([m * scale, -m * scale]);
    }
    let mut start = (f64::INFINITY, vec![grid[0], grid[1]]);
    for (i, l1) in grid.iter().enumerate() {
        for l2 in &grid[i + 1..] {
            let c = rss_of(&[*l1, *l2]);
            if c < start.0 {
                start = (c, vec![*l1, *l2]);
            }
        }
    }
    let steps = [0.2 * scale, 0.2 * scale];
    let (mut rates, _, iterations) = minimize(&rss_of, start.1, &steps, settings);
    rates.sort_by(f64::total_cmp);
    let (a, b) = bi_exponential_amplitudes(x, y, rates[0], rates[1])
        .ok_or_else(|| Error::input("bi-exponential fit: the two rates coincide"))?;
    let predict = |p: &[f64], out: &mut [f64]| {
        for (o, v) in out.iter_mut().zip(x) {
            *o = p[0] * (p[1] * v).exp() + p[2] * (p[3] * v).exp();
        }
    };
    Ok(finish(
        vec!["A", "lambda1", "B", "lambda2"],
        vec![a, rates[0], b, rates[1]],
        y,
        &predict,
        iterations,
    ))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// Gaussian noise of standard deviation `sigma` from a fixed seed.
    pub(crate) fn noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let d = Normal::new(0.0, sigma).unwrap();
        (0..n).map(|_| d.sample(&mut rng)).collect()
    }

    /// Every parameter within 4 standard errors of the truth (a 4σ event has probability
    /// ~6e-5 per parameter), the standard errors finite and the RMS residual consistent with
    /// the noise (χ² with n − p dof: relative spread √(1/(2n)) ≈ 5 % at n = 200).
    pub(crate) fn assert_recovers(fit: &Fit, truth: &[f64], sigma: f64) {
        for ((name, p), (se, t)) in fit
            .names
            .iter()
            .zip(&fit.params)
            .zip(fit.std_errors.iter().zip(truth))
        {
            assert!(se.is_finite() && *se > 0.0, "{name}: se = {se}");
            assert!((p - t).abs() < 4.0 * se, "{name}: {p} vs {t} (se {se})");
        }
        let n = fit.residuals.len() as f64;
        let s = (fit.rss / (n - truth.len() as f64)).sqrt();
        assert!(
            (s / sigma - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
            "s = {s}, σ = {sigma}"
        );
    }

    #[test]
    fn linear_recovers_line() {
        let x: Vec<f64> = (0..200).map(|i| f64::from(i) * 0.05).collect();
        let e = noise(200, 0.2, 11);
        let y: Vec<f64> = x.iter().zip(&e).map(|(v, n)| 1.5 - 0.7 * v + n).collect();
        let fit = linear(&x, &y).unwrap();
        assert_recovers(&fit, &[1.5, -0.7], 0.2);
        // The Jacobian-based standard error equals the textbook s / √Σ(x − x̄)².
        let mean = x.iter().sum::<f64>() / 200.0;
        let sxx: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
        let s = (fit.rss / 198.0).sqrt();
        assert!((fit.std_errors[1] / (s / sxx.sqrt()) - 1.0).abs() < 1e-6);
        assert!(fit.r_squared > 0.95);
        // Exact data: R² = 1.
        let exact = linear(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]).unwrap();
        assert!((exact.r_squared - 1.0).abs() < 1e-15 && exact.rss < 1e-25);
        assert!(linear(&[1.0, 1.0], &[0.0, 1.0]).is_err());
    }

    #[test]
    fn power_law_recovers_exponent() {
        let x: Vec<f64> = (1..=200).map(|i| f64::from(i) * 50.0).collect();
        let e = noise(200, 0.5, 12);
        let y: Vec<f64> = x
            .iter()
            .zip(&e)
            .map(|(v, n)| 2e-3 * v.powf(1.3) + n)
            .collect();
        let fit = power_law(&x, &y, &FitSettings::default()).unwrap();
        assert_recovers(&fit, &[2e-3, 1.3], 0.5);
        assert!(power_law(&[0.0, 1.0, 2.0], &[1.0, 2.0, 3.0], &FitSettings::default()).is_err());
    }

    #[test]
    fn bi_exponential_recovers_rates() {
        let x: Vec<f64> = (0..200).map(|i| f64::from(i) / 199.0).collect();
        let e = noise(200, 0.01, 13);
        let truth = [1.0, -4.0, 0.5, 1.5];
        let y: Vec<f64> = x
            .iter()
            .zip(&e)
            .map(|(v, n)| truth[0] * (truth[1] * v).exp() + truth[2] * (truth[3] * v).exp() + n)
            .collect();
        let fit = bi_exponential(&x, &y, &FitSettings::default()).unwrap();
        assert_recovers(&fit, &truth, 0.01);
    }
}
