//! Where a design parameter may lie: the entries of `[design.parameters]`, and the map from a
//! point of the unit cube (a design's coordinate) to a parameter value.
//!
//! ```toml
//! [design.parameters]
//! field = { log = ["5kOe", "100kOe"] }       # uniform in ln H
//! friction = { range = [0, 0.5] }            # uniform in μ
//! model = ["dem", "ensemble"]                # levels, each with probability 1/k
//! anisotropy = { normal = ["3.5e6 erg/cm3", "5%"] }   # uncertain: mean, std (or % of mean)
//! diameter = { lognormal = ["1um", 0.2] }    # median, σ of ln
//! damping = { uniform = ["10 N*s/m", "30 N*s/m"] }
//! ```
//!
//! Counts are rounded to whole numbers; every value is range-checked by the parameter's own
//! declaration when the run's parameters are built.

use super::design::distributions::Distribution;
use super::model::{ParamKind, ParamSpec, Value};
use crate::{Error, Result};

/// The domain of one design parameter.
#[derive(Debug, Clone, PartialEq)]
pub enum Domain {
    /// Uniform in x on [lo, hi].
    Linear(f64, f64),
    /// Uniform in ln x on [lo, hi], 0 < lo.
    Log(f64, f64),
    /// One of these values, each with probability 1/k (discrete or categorical).
    Levels(Vec<Value>),
    /// An uncertain input with this distribution (SI).
    Random(Distribution),
}

/// One parameter of a design and its domain.
#[derive(Debug, Clone)]
pub struct DesignAxis {
    /// The parameter.
    pub spec: &'static ParamSpec,
    /// Where it may lie.
    pub domain: Domain,
}

impl DesignAxis {
    /// The value at unit coordinate `u` ∈ [0, 1).
    pub fn value(&self, u: f64) -> Value {
        let x = match &self.domain {
            Domain::Linear(lo, hi) => lo + u * (hi - lo),
            Domain::Log(lo, hi) => (lo.ln() + u * (hi.ln() - lo.ln())).exp(),
            Domain::Levels(levels) => {
                let k = ((u * levels.len() as f64) as usize).min(levels.len() - 1);
                return levels[k].clone();
            }
            Domain::Random(d) => d.quantile(u), // clamps u off the cube's faces itself
        };
        Value::Number(if matches!(self.spec.kind, ParamKind::Count) {
            x.round()
        } else {
            x
        })
    }

    /// Whether plots should use a log axis for it.
    pub fn is_log(&self) -> bool {
        matches!(
            self.domain,
            Domain::Log(..) | Domain::Random(Distribution::LogNormal { .. })
        )
    }
}

/// Parses a `[design.parameters]` entry; errors name `name` and what is allowed.
pub fn parse(spec: &'static ParamSpec, raw: &toml::Value) -> Result<DesignAxis> {
    let name = spec.name;
    let fail = |why: String| Error::input(format!("{name}: {why}"));
    let number = |v: &toml::Value| match spec.parse(v).map_err(&fail)? {
        Value::Number(x) => Ok(x),
        Value::Text(t) => Err(fail(format!("'{t}' is not a number"))),
    };
    let domain = match raw {
        toml::Value::Array(items) if !items.is_empty() => Domain::Levels(
            items
                .iter()
                .map(|v| spec.parse(v).map_err(&fail))
                .collect::<Result<_>>()?,
        ),
        toml::Value::Table(t) if t.len() == 1 => {
            let (kind, args) = t.iter().next().expect("one entry");
            let pair = args
                .as_array()
                .filter(|a| a.len() == 2)
                .ok_or_else(|| fail(format!("{kind} needs two values [a, b], got {args}")))?;
            match kind.as_str() {
                "range" | "log" => {
                    let (lo, hi) = (number(&pair[0])?, number(&pair[1])?);
                    let shown = |x: f64| spec.user_text(&Value::Number(x));
                    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
                        return Err(fail(format!(
                            "need low < high (got {}, {})",
                            shown(lo),
                            shown(hi)
                        )));
                    }
                    if kind == "log" && lo <= 0.0 {
                        return Err(fail(format!(
                            "a log range needs low > 0 (got {})",
                            shown(lo)
                        )));
                    }
                    if kind == "log" {
                        Domain::Log(lo, hi)
                    } else {
                        Domain::Linear(lo, hi)
                    }
                }
                "normal" => {
                    let mean = number(&pair[0])?;
                    let std = match pair[1].as_str().and_then(|s| s.trim().strip_suffix('%')) {
                        Some(pct) => {
                            let p: f64 = pct
                                .trim()
                                .parse()
                                .map_err(|_| fail(format!("'{}' is not a percentage", pair[1])))?;
                            p / 100.0 * mean.abs()
                        }
                        None => number(&pair[1])?,
                    };
                    random(Distribution::Normal { mean, std }, &fail)?
                }
                "lognormal" => {
                    let median = number(&pair[0])?;
                    let sigma = pair[1]
                        .as_float()
                        .or(pair[1].as_integer().map(|i| i as f64));
                    let sigma = sigma.ok_or_else(|| {
                        fail(format!(
                            "lognormal σ (of ln x) must be a plain number, got {}",
                            pair[1]
                        ))
                    })?;
                    random(Distribution::LogNormal { median, sigma }, &fail)?
                }
                "uniform" => {
                    let (low, high) = (number(&pair[0])?, number(&pair[1])?);
                    random(Distribution::Uniform { low, high }, &fail)?
                }
                other => return Err(fail(format!("'{other}' is not a domain ({ALLOWED})"))),
            }
        }
        other => return Err(fail(format!("{other} is not a domain ({ALLOWED})"))),
    };
    Ok(DesignAxis { spec, domain })
}

const ALLOWED: &str = "use a list of values, { range = [lo, hi] }, { log = [lo, hi] }, \
                       { normal = [mean, std or \"p%\"] }, { lognormal = [median, σ] } or \
                       { uniform = [lo, hi] }";

fn random(d: Distribution, fail: &dyn Fn(String) -> Error) -> Result<Domain> {
    d.validate().map_err(fail)?;
    Ok(Domain::Random(d))
}
