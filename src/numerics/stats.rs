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
}
