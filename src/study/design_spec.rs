//! The `[design]` of a study: which points of the parameters' domains its runs take.
//!
//! ```toml
//! [design]
//! method = "sobol"     # lhs, sobol, halton, random; saltelli or morris for sensitivity
//! samples = 64         # points (saltelli: base samples N, N (d + 2) points; morris: trajectories)
//! levels = 4           # morris only: grid levels p (default 4)
//! bootstrap = 1000     # saltelli only: bootstrap resamples of the intervals
//! [design.parameters]
//! field = { log = ["5kOe", "100kOe"] }
//! friction = { range = [0, 0.5] }
//! ```
//!
//! Every point is a run like a grid point (saved, resumable, shardable); replicates repeat
//! each point at seeds seed, seed + 1, …. The points are drawn from the study seed, so the
//! same file gives the same points.

use super::design::sensitivity::{morris_points, saltelli_points};
use super::design::{unit_points, Method};
use super::domain::{DesignAxis, Domain};
use super::model::Value;
use super::spec::Axis;

/// How the unit-cube points are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DesignKind {
    /// A space-filling or random sample.
    Sample(Method),
    /// Saltelli's sample for Sobol' indices.
    Saltelli,
    /// Morris trajectories on a grid of `levels` levels.
    Morris {
        /// Grid levels p.
        levels: usize,
    },
}

impl DesignKind {
    /// Parses `method` (and `levels`, for morris).
    pub fn parse(method: &str, levels: Option<i64>) -> Result<Self, String> {
        let kind = match method {
            "saltelli" => Self::Saltelli,
            "morris" => {
                let p = levels.unwrap_or(4);
                let levels = usize::try_from(p)
                    .ok()
                    .filter(|p| (2..=1000).contains(p) && p % 2 == 0)
                    .ok_or_else(|| {
                        format!("levels = {p} is not allowed (need an even 2..=1000)")
                    })?;
                Self::Morris { levels }
            }
            other => Self::Sample(other.parse::<Method>().map_err(|_| {
                format!(
                    "'{other}' is not a design (allowed: lhs, sobol, halton, random, saltelli, \
                     morris)"
                )
            })?),
        };
        if levels.is_some() && !matches!(kind, Self::Morris { .. }) {
            return Err("levels is for method = \"morris\" only".into());
        }
        Ok(kind)
    }

    /// The smallest `samples` the design accepts with `dims` parameters.
    pub fn minimum_samples(self) -> usize {
        match self {
            Self::Sample(_) => 2,
            Self::Saltelli => 4,
            Self::Morris { .. } => 2,
        }
    }

    /// The design's points in the unit cube.
    pub fn unit_points(
        self,
        samples: usize,
        dims: usize,
        seed: u64,
    ) -> Result<Vec<Vec<f64>>, String> {
        match self {
            Self::Sample(method) => unit_points(method, samples, dims, seed),
            Self::Saltelli => Ok(saltelli_points(samples, dims, seed)),
            Self::Morris { levels } => Ok(morris_points(samples, dims, levels, seed)),
        }
    }

    /// The name in study files.
    pub fn name(self) -> String {
        match self {
            Self::Sample(m) => m.to_string(),
            Self::Saltelli => "saltelli".into(),
            Self::Morris { .. } => "morris".into(),
        }
    }
}

/// A parsed design: its kind, parameters and points.
#[derive(Debug, Clone)]
pub struct Design {
    /// How the points were made.
    pub kind: DesignKind,
    /// `samples` as given.
    pub samples: usize,
    /// Bootstrap resamples of the Sobol' intervals.
    pub bootstrap: usize,
    /// The parameters and their domains.
    pub axes: Vec<DesignAxis>,
    /// The points in the unit cube (what the sensitivity estimators need).
    pub unit: Vec<Vec<f64>>,
    /// The points as parameter values.
    pub points: Vec<Vec<Value>>,
}

impl Design {
    /// The design's parameters as study axes (for table columns and labels; their values
    /// are the points', not a grid).
    pub fn axes(&self) -> Vec<Axis> {
        self.axes
            .iter()
            .map(|a| Axis {
                spec: a.spec,
                values: Vec::new(),
                log: a.is_log(),
            })
            .collect()
    }

    /// Whether any parameter is an uncertain input (a distribution).
    pub fn is_uncertain(&self) -> bool {
        self.axes
            .iter()
            .any(|a| matches!(a.domain, Domain::Random(_)))
    }
}
