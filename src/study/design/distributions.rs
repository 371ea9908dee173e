//! Input distributions for uncertainty propagation: a unit-cube coordinate `u` becomes a
//! parameter value by the inverse CDF ([`Distribution::quantile`]), so stratified designs
//! (Sobol', Latin hypercube) stay stratified in probability.

use crate::numerics::special::{normal_cdf, normal_quantile};

/// The distribution of one uncertain parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// Normal with this mean and standard deviation.
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation (> 0).
        std: f64,
    },
    /// Log-normal: ln X is normal with mean ln(`median`) and standard deviation `sigma`.
    /// `median` is in the parameter's own units (so it converts like the parameter); the
    /// geometric standard deviation is e^sigma, and the mean is median · e^(sigma²/2).
    LogNormal {
        /// Median e^μ (> 0), in the parameter's units.
        median: f64,
        /// Standard deviation σ of ln X (> 0, dimensionless).
        sigma: f64,
    },
    /// Uniform on [`low`, `high`).
    Uniform {
        /// Lower bound.
        low: f64,
        /// Upper bound (> low).
        high: f64,
    },
}

/// The smallest probability [`Distribution::quantile`] maps: `u` is clamped to
/// `[U_MIN, 1 − U_MIN]`, so a point on the face of the unit cube gives a finite value
/// (±8.2 standard deviations for a normal).
pub const U_MIN: f64 = 1.0 / (1u64 << 53) as f64;

impl Distribution {
    /// The distribution's name in messages and study files.
    pub fn name(&self) -> &'static str {
        match self {
            Distribution::Normal { .. } => "normal",
            Distribution::LogNormal { .. } => "lognormal",
            Distribution::Uniform { .. } => "uniform",
        }
    }

    /// Checks the parameters: all finite, `std > 0`, `median > 0`, `sigma > 0`, `low < high`.
    /// The error is one line naming the offending value.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("{} {name} must be finite, not {v}", self.name()))
            }
        };
        let positive = |name: &str, v: f64| {
            finite(name, v)?;
            if v > 0.0 {
                Ok(())
            } else {
                Err(format!("{} {name} must be positive, not {v}", self.name()))
            }
        };
        match *self {
            Distribution::Normal { mean, std } => {
                finite("mean", mean)?;
                positive("std", std)
            }
            Distribution::LogNormal { median, sigma } => {
                positive("median", median)?;
                positive("sigma", sigma)
            }
            Distribution::Uniform { low, high } => {
                finite("low", low)?;
                finite("high", high)?;
                if low < high {
                    Ok(())
                } else {
                    Err(format!("uniform low ({low}) must be below high ({high})"))
                }
            }
        }
    }

    /// The inverse CDF at `u` (`u` clamped to `[U_MIN, 1 − U_MIN]`; NaN stays NaN). The
    /// normal quantile is Wichura's AS 241 (relative accuracy ~1e-16).
    pub fn quantile(&self, u: f64) -> f64 {
        let u = if u.is_nan() {
            u
        } else {
            u.clamp(U_MIN, 1.0 - U_MIN)
        };
        match *self {
            Distribution::Normal { mean, std } => mean + std * normal_quantile(u),
            Distribution::LogNormal { median, sigma } => {
                median * (sigma * normal_quantile(u)).exp()
            }
            Distribution::Uniform { low, high } => low + u * (high - low),
        }
    }

    /// The CDF at `x`.
    pub fn cdf(&self, x: f64) -> f64 {
        match *self {
            Distribution::Normal { mean, std } => normal_cdf((x - mean) / std),
            Distribution::LogNormal { median, sigma } => {
                if x <= 0.0 {
                    0.0
                } else {
                    normal_cdf((x / median).ln() / sigma)
                }
            }
            Distribution::Uniform { low, high } => ((x - low) / (high - low)).clamp(0.0, 1.0),
        }
    }

    /// The mean.
    pub fn mean(&self) -> f64 {
        match *self {
            Distribution::Normal { mean, .. } => mean,
            Distribution::LogNormal { median, sigma } => median * (sigma * sigma / 2.0).exp(),
            Distribution::Uniform { low, high } => (low + high) / 2.0,
        }
    }

    /// The standard deviation.
    pub fn std(&self) -> f64 {
        match *self {
            Distribution::Normal { std, .. } => std,
            Distribution::LogNormal { sigma, .. } => {
                self.mean() * ((sigma * sigma).exp_m1()).sqrt()
            }
            Distribution::Uniform { low, high } => (high - low) / 12f64.sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::design::sobol::sobol;

    const ALL: [Distribution; 3] = [
        Distribution::Normal {
            mean: 3.0,
            std: 0.5,
        },
        Distribution::LogNormal {
            median: 2e-6,
            sigma: 0.3,
        },
        Distribution::Uniform {
            low: -1.0,
            high: 4.0,
        },
    ];

    #[test]
    fn known_quantiles() {
        let n = Distribution::Normal {
            mean: 0.0,
            std: 1.0,
        };
        assert!((n.quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-15);
        assert_eq!(n.quantile(0.5), 0.0);
        let ln = ALL[1];
        assert!((ln.quantile(0.5) / 2e-6 - 1.0).abs() < 1e-15);
        assert!(
            (ln.quantile(0.975) / (2e-6 * (0.3 * 1.959_963_984_540_054f64).exp()) - 1.0).abs()
                < 1e-14
        );
        assert_eq!(ALL[2].quantile(0.25), 0.25);
        // Faces of the cube stay finite.
        assert!(n.quantile(0.0).is_finite() && n.quantile(1.0).is_finite());
        assert!(n.quantile(0.0) < -8.0);
    }

    #[test]
    fn quantile_inverts_the_cdf() {
        for d in ALL {
            d.validate().unwrap();
            for k in 1..200 {
                let u = f64::from(k) / 200.0;
                let x = d.quantile(u);
                assert!((d.cdf(x) - u).abs() < 1e-13, "{d:?} u {u}");
                let x = d.mean() + d.std() * (f64::from(k) / 40.0 - 2.5);
                if d.cdf(x) > 0.0 && d.cdf(x) < 1.0 {
                    let back = d.quantile(d.cdf(x));
                    assert!((back - x).abs() < 1e-10 * d.std(), "{d:?} x {x}: {back}");
                }
            }
        }
    }

    #[test]
    fn sobol_mapped_samples_have_the_right_moments() {
        let u = sobol(1 << 14, 3, Some(17)).unwrap();
        for (j, d) in ALL.iter().enumerate() {
            let x: Vec<f64> = u.iter().map(|p| d.quantile(p[j])).collect();
            let n = x.len() as f64;
            let mean = x.iter().sum::<f64>() / n;
            let std = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            assert!(
                (mean - d.mean()).abs() < 1e-3 * d.std(),
                "{d:?} mean {mean}"
            );
            assert!((std / d.std() - 1.0).abs() < 2e-3, "{d:?} std {std}");
        }
    }

    #[test]
    fn invalid_parameters_are_one_line_errors() {
        let bad = [
            Distribution::Normal {
                mean: 0.0,
                std: 0.0,
            },
            Distribution::Normal {
                mean: f64::NAN,
                std: 1.0,
            },
            Distribution::LogNormal {
                median: -1.0,
                sigma: 0.1,
            },
            Distribution::LogNormal {
                median: 1.0,
                sigma: f64::INFINITY,
            },
            Distribution::Uniform {
                low: 2.0,
                high: 2.0,
            },
        ];
        for d in bad {
            let e = d.validate().unwrap_err();
            assert!(e.starts_with(d.name()) && !e.contains('\n'), "{e}");
        }
    }
}
