//! Sample statistics of replicate values.

/// Mean, sample standard deviation, count and 95 % confidence half-width of a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    /// Mean (NaN if empty).
    pub mean: f64,
    /// Sample standard deviation (NaN below two values).
    pub std: f64,
    /// Number of values.
    pub count: usize,
    /// t_{0.975, n−1} · std / √n (NaN below two values).
    pub ci95: f64,
}

impl Stats {
    /// Statistics of the values.
    pub fn of(values: impl Iterator<Item = f64>) -> Self {
        let v: Vec<f64> = values.collect();
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let (std, ci95) = if n >= 2 {
            let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
            (std, student_t_975(n - 1) * std / (n as f64).sqrt())
        } else {
            (f64::NAN, f64::NAN)
        };
        Self {
            mean,
            std,
            count: n,
            ci95,
        }
    }
}

/// Two-sided 95 % quantile of Student's t with `df` degrees of freedom (tabulated to 30, then
/// the normal value).
fn student_t_975(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    T.get(df.wrapping_sub(1)).copied().unwrap_or(1.960)
}

/// The probabilities of [`Description`]'s quantiles.
pub const DESCRIBE_PROBABILITIES: [f64; 5] = [0.05, 0.25, 0.5, 0.75, 0.95];

/// A summary of the distribution of a metric over a sample (e.g. the runs of an uncertainty
/// study).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Description {
    /// Number of values summarized (NaN values are left out).
    pub n: usize,
    /// Number of NaN values left out (failed runs).
    pub missing: usize,
    /// Mean (NaN if empty).
    pub mean: f64,
    /// Sample standard deviation, n − 1 in the denominator (NaN below two values).
    pub std: f64,
    /// Quantiles at [`DESCRIBE_PROBABILITIES`] (0.05, 0.25, 0.5, 0.75, 0.95), Hyndman & Fan
    /// type 7 ([`quantile_sorted`]); NaN if empty.
    pub quantiles: [f64; 5],
}

impl Description {
    /// The median (the 0.5 quantile).
    pub fn median(&self) -> f64 {
        self.quantiles[2]
    }
}

/// Count, mean, standard deviation and the 5, 25, 50, 75 and 95 % quantiles (Hyndman & Fan
/// type 7, the default of R and NumPy) of the values, NaN values left out and counted.
pub fn describe(values: &[f64]) -> Description {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    let stats = Stats::of(v.iter().copied());
    Description {
        n: v.len(),
        missing: values.len() - v.len(),
        mean: stats.mean,
        std: stats.std,
        quantiles: DESCRIBE_PROBABILITIES.map(|p| quantile_sorted(&v, p)),
    }
}

/// The `p` quantile of sorted values by Hyndman & Fan (1996) type 7: linear interpolation
/// between order statistics at h = (n − 1)·p (0-based). NaN if empty or `p` outside [0, 1].
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() || !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    let h = (sorted.len() - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_sample() {
        let s = Stats::of([1.0, 2.0, 3.0, 4.0].into_iter());
        assert_eq!(s.count, 4);
        assert!((s.mean - 2.5).abs() < 1e-15);
        assert!((s.std - (5.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((s.ci95 - 3.182 * s.std / 2.0).abs() < 1e-12);
        assert!(Stats::of([7.0].into_iter()).std.is_nan());
    }

    #[test]
    fn description_with_type_7_quantiles() {
        // R: quantile(c(1, 2, 4, 7, 11), c(0.05, 0.25, 0.5, 0.75, 0.95), type = 7).
        let d = describe(&[7.0, 1.0, f64::NAN, 11.0, 2.0, 4.0]);
        assert_eq!((d.n, d.missing), (5, 1));
        assert_eq!(d.mean, 5.0);
        assert!((d.std - 16.5f64.sqrt()).abs() < 1e-14);
        for (got, want) in d.quantiles.iter().zip([1.2, 2.0, 4.0, 7.0, 10.2]) {
            assert!((got - want).abs() < 1e-14, "{got} {want}");
        }
        assert_eq!(d.median(), 4.0);
        let one = describe(&[3.0]);
        assert_eq!(one.quantiles, [3.0; 5]);
        assert!(one.std.is_nan());
        assert!(describe(&[]).quantiles[0].is_nan());
        assert!(quantile_sorted(&[1.0], 1.5).is_nan());
    }
}
