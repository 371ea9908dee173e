//! Histograms with Knuth's bin rule, per-species force distributions and fluctuations, and
//! Pearson correlation (spec analysis.md, "Forces" and "2D structure").

use crate::numerics::special::ln_gamma;
use crate::{Error, Result};

/// Default largest bin count Knuth's rule considers.
pub const DEFAULT_MAX_BINS: usize = 1000;

/// A histogram on equal bins.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Histogram {
    /// Bin edges (M + 1 values, ascending).
    pub edges: Vec<f64>,
    /// Counts per bin (the last bin includes its upper edge).
    pub counts: Vec<usize>,
    /// Probability density per bin: count / (n · bin width), integrates to 1.
    pub density: Vec<f64>,
}

/// Checks that values are non-empty and finite.
fn check_values(what: &str, values: &[f64]) -> Result<()> {
    if values.is_empty() {
        return Err(Error::input(format!("{what}: no values")));
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(Error::input(format!(
            "{what}: value {i} is {}; all values must be finite",
            values[i]
        ))),
        None => Ok(()),
    }
}

/// Counts of `sorted` values in `m` equal bins of [lo, hi] (last bin closed).
fn counts_sorted(sorted: &[f64], lo: f64, hi: f64, m: usize) -> Vec<usize> {
    let width = (hi - lo) / m as f64;
    let below = |k: usize| sorted.partition_point(|v| *v < lo + k as f64 * width);
    let mut counts: Vec<usize> = (0..m).map(|k| below(k + 1) - below(k)).collect();
    counts[m - 1] = sorted.len() - below(m - 1);
    counts
}

/// Knuth's log posterior F(M) = n ln M + lnΓ(M/2) − M lnΓ(1/2) − lnΓ(n + M/2)
/// + Σ_k lnΓ(n_k + 1/2) for bin counts `counts` (M = counts.len()).
pub fn knuth_log_posterior(counts: &[usize]) -> f64 {
    let m = counts.len() as f64;
    let n = counts.iter().sum::<usize>() as f64;
    n * m.ln() + ln_gamma(m / 2.0) - m * ln_gamma(0.5) - ln_gamma(n + m / 2.0)
        + counts
            .iter()
            .map(|c| ln_gamma(*c as f64 + 0.5))
            .sum::<f64>()
}

/// Knuth's rule: the bin count M in 1..=max_bins maximizing [`knuth_log_posterior`] (every M
/// is evaluated; the smallest wins a tie). All values equal: 1 bin.
///
/// # Errors
/// [`Error::Input`] for no values, a non-finite value or max_bins = 0.
pub fn knuth_bins(values: &[f64], max_bins: usize) -> Result<usize> {
    check_values("Knuth's rule", values)?;
    if max_bins == 0 {
        return Err(Error::input("Knuth's rule: max_bins must be ≥ 1"));
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (lo, hi) = (sorted[0], sorted[sorted.len() - 1]);
    if lo == hi {
        return Ok(1);
    }
    let mut best = (1, f64::NEG_INFINITY);
    for m in 1..=max_bins {
        let f = knuth_log_posterior(&counts_sorted(&sorted, lo, hi, m));
        if f > best.1 {
            best = (m, f);
        }
    }
    Ok(best.0)
}

/// Histogram of the values on `bins` equal bins spanning [min, max] (a single value gets one
/// bin of width 1 around it), normalized as a probability density.
///
/// # Errors
/// [`Error::Input`] for no values, a non-finite value or zero bins.
pub fn histogram(values: &[f64], bins: usize) -> Result<Histogram> {
    check_values("histogram", values)?;
    if bins == 0 {
        return Err(Error::input("histogram: the bin count must be ≥ 1"));
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (mut lo, mut hi) = (sorted[0], sorted[sorted.len() - 1]);
    if lo == hi {
        (lo, hi) = (lo - 0.5, hi + 0.5);
    }
    let counts = counts_sorted(&sorted, lo, hi, bins);
    let width = (hi - lo) / bins as f64;
    let n = values.len() as f64;
    Ok(Histogram {
        edges: (0..=bins).map(|k| lo + k as f64 * width).collect(),
        density: counts.iter().map(|c| *c as f64 / (n * width)).collect(),
        counts,
    })
}

/// Force distribution of one species.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpeciesForces {
    /// Species label.
    pub species: i64,
    /// Number of particles.
    pub count: usize,
    /// Mean force magnitude F̄_s (N).
    pub mean: f64,
    /// PDF of the force magnitude (N⁻¹ over N), bins by Knuth's rule.
    pub histogram: Histogram,
}

/// Per-species force-magnitude distributions (spec "Forces"): one Knuth-binned PDF per species,
/// species ascending.
///
/// # Errors
/// [`Error::Input`] for mismatched lengths, no particles, or a non-finite force.
pub fn force_distributions(forces: &[f64], species: &[i64]) -> Result<Vec<SpeciesForces>> {
    if forces.len() != species.len() {
        return Err(Error::input(format!(
            "{} forces for {} species labels",
            forces.len(),
            species.len()
        )));
    }
    check_values("force distribution", forces)?;
    let mut labels = species.to_vec();
    labels.sort_unstable();
    labels.dedup();
    labels
        .into_iter()
        .map(|s| {
            let f: Vec<f64> = (0..forces.len())
                .filter(|i| species[*i] == s)
                .map(|i| forces[i])
                .collect();
            let bins = knuth_bins(&f, DEFAULT_MAX_BINS.min(f.len()))?;
            Ok(SpeciesForces {
                species: s,
                count: f.len(),
                mean: f.iter().sum::<f64>() / f.len() as f64,
                histogram: histogram(&f, bins)?,
            })
        })
        .collect()
}

/// Relative force fluctuation per particle |F_k − F̄_s| / F̄_s, F̄_s the mean over the
/// particle's species (NaN where F̄_s = 0).
///
/// # Errors
/// As [`force_distributions`].
pub fn relative_fluctuations(forces: &[f64], species: &[i64]) -> Result<Vec<f64>> {
    let dists = force_distributions(forces, species)?;
    let mean_of = |s: i64| {
        dists
            .iter()
            .find(|d| d.species == s)
            .map_or(f64::NAN, |d| d.mean)
    };
    Ok(forces
        .iter()
        .zip(species)
        .map(|(f, s)| {
            let m = mean_of(*s);
            if m == 0.0 {
                f64::NAN
            } else {
                (f - m).abs() / m
            }
        })
        .collect())
}

/// Pearson correlation coefficient of paired observables (e.g. Ψ6 and n6 over runs).
///
/// # Errors
/// [`Error::Input`] for mismatched lengths, fewer than 2 pairs, a non-finite value, or a
/// constant series.
pub fn pearson(x: &[f64], y: &[f64]) -> Result<f64> {
    if x.len() != y.len() || x.len() < 2 {
        return Err(Error::input(format!(
            "Pearson correlation needs two series of equal length ≥ 2, got {} and {}",
            x.len(),
            y.len()
        )));
    }
    check_values("Pearson correlation", x)?;
    check_values("Pearson correlation", y)?;
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    if sxx == 0.0 || syy == 0.0 {
        return Err(Error::input(
            "Pearson correlation of a constant series is undefined",
        ));
    }
    Ok(sxy / (sxx * syy).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// ln Γ at integer or half-integer 2a/2 > 0 by exact recurrence from Γ(1) = 1 and
    /// Γ(1/2) = √π (independent of the Lanczos formula).
    fn ln_gamma_half(twice: usize) -> f64 {
        let (mut acc, mut x) = if twice.is_multiple_of(2) {
            (0.0, 1.0)
        } else {
            (0.5 * std::f64::consts::PI.ln(), 0.5)
        };
        while 2.0 * x < twice as f64 {
            acc += x.ln();
            x += 1.0;
        }
        acc
    }

    /// Brute force: bin every value by floor((v − lo)/w) and evaluate F(M) by recurrences.
    fn brute_force_f(values: &[f64], m: usize) -> f64 {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut counts = vec![0usize; m];
        for v in values {
            let k = (((v - lo) / (hi - lo)) * m as f64).floor() as usize;
            counts[k.min(m - 1)] += 1;
        }
        let n = values.len();
        n as f64 * (m as f64).ln() + ln_gamma_half(m)
            - m as f64 * ln_gamma_half(1)
            - ln_gamma_half(2 * n + m)
            + counts.iter().map(|c| ln_gamma_half(2 * c + 1)).sum::<f64>()
    }

    #[test]
    fn knuth_rule_matches_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let normal = Normal::new(2.0, 0.5).unwrap();
        for n in [20, 200, 2000] {
            let values: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
            let max_bins = 200;
            let brute: Vec<f64> = (1..=max_bins).map(|m| brute_force_f(&values, m)).collect();
            let best = 1
                + (0..max_bins)
                    .max_by(|a, b| brute[*a].total_cmp(&brute[*b]))
                    .unwrap();
            assert_eq!(knuth_bins(&values, max_bins).unwrap(), best, "n = {n}");
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            for m in [1, 2, 7, 50, 200] {
                let f = knuth_log_posterior(&counts_sorted(&sorted, sorted[0], sorted[n - 1], m));
                // F is a difference of terms of size lnΓ(n + M/2): compare on that scale.
                let scale = ln_gamma_half(2 * n + m);
                assert!((f - brute[m - 1]).abs() < 1e-12 * scale, "M = {m}");
            }
        }
    }

    #[test]
    fn histogram_is_a_density() {
        let values = [0.0, 0.1, 0.2, 0.5, 0.9, 1.0, 1.0];
        let h = histogram(&values, 4).unwrap();
        assert_eq!(h.counts, vec![3, 0, 1, 3]);
        let integral: f64 = h.density.iter().map(|d| d * 0.25).sum();
        assert!((integral - 1.0).abs() < 1e-12);
        assert_eq!(knuth_bins(&[3.0; 5], 10).unwrap(), 1);
        assert_eq!(histogram(&[3.0; 5], 1).unwrap().edges, vec![2.5, 3.5]);
        assert!(histogram(&[f64::NAN], 3).is_err() && knuth_bins(&[], 3).is_err());
    }

    #[test]
    fn species_means_and_fluctuations() {
        let forces = [1.0, 3.0, 10.0, 30.0, 20.0];
        let species = [1, 1, 2, 2, 2];
        let d = force_distributions(&forces, &species).unwrap();
        assert_eq!((d[0].species, d[0].count, d[0].mean), (1, 2, 2.0));
        assert_eq!((d[1].species, d[1].count, d[1].mean), (2, 3, 20.0));
        let fl = relative_fluctuations(&forces, &species).unwrap();
        assert_eq!(fl, vec![0.5, 0.5, 0.5, 0.5, 0.0]);
        assert!(force_distributions(&forces, &species[..2]).is_err());
    }

    #[test]
    fn pearson_known_values() {
        let x = [1.0, 2.0, 3.0, 4.0];
        assert!((pearson(&x, &[2.0, 4.0, 6.0, 8.0]).unwrap() - 1.0).abs() < 1e-15);
        assert!((pearson(&x, &[8.0, 6.0, 4.0, 2.0]).unwrap() + 1.0).abs() < 1e-15);
        // Symmetric parabola: uncorrelated.
        assert!(
            pearson(&[-2.0, -1.0, 1.0, 2.0], &[4.0, 1.0, 1.0, 4.0])
                .unwrap()
                .abs()
                < 1e-15
        );
        assert!(pearson(&x, &[1.0; 4]).is_err() && pearson(&x[..1], &x[..1]).is_err());
    }
}
