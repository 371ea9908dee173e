//! How the study runner sees a model: parameters in (by name, with units), metrics and series
//! out. Every model implements [`StudyModel`]; the runner never touches model internals.

use serde::{Deserialize, Serialize};
use std::path::Path;

pub use super::param::{Param, ParamKind, ParamSpec, Value};
pub use crate::output::snapshots::{Recorder, RunSpan, Schedule};
use crate::{Error, Result};

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "StatusFields", into = "StatusFields")]
pub enum RunStatus {
    /// It ran to the end (and reached its target, where it has one).
    Ok,
    /// It ran to its time limit without reaching its target.
    NotReached,
    /// It broke down (a blow-up, a degenerate state); the reason says how.
    Failed(String),
}

/// The on-disk form of a status: `status` ("ok", "not-reached", "failed") and `reason` (null
/// unless failed; records written before 0.2 hold "" instead of null).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct StatusFields {
    status: String,
    #[serde(default)]
    reason: Option<String>,
}

impl TryFrom<StatusFields> for RunStatus {
    type Error = String;
    fn try_from(f: StatusFields) -> std::result::Result<Self, String> {
        match f.status.as_str() {
            "ok" => Ok(RunStatus::Ok),
            "not-reached" => Ok(RunStatus::NotReached),
            "failed" => Ok(RunStatus::Failed(f.reason.unwrap_or_default())),
            other => Err(format!("unknown run status '{other}'")),
        }
    }
}

impl From<RunStatus> for StatusFields {
    fn from(s: RunStatus) -> Self {
        let status = s.label().to_string();
        let reason = match s {
            RunStatus::Failed(r) => Some(r),
            _ => None,
        };
        StatusFields { status, reason }
    }
}

impl RunStatus {
    /// "ok", "not-reached" or "failed".
    pub fn label(&self) -> &'static str {
        match self {
            RunStatus::Ok => "ok",
            RunStatus::NotReached => "not-reached",
            RunStatus::Failed(_) => "failed",
        }
    }

    /// Why it failed.
    pub fn reason(&self) -> Option<&str> {
        match self {
            RunStatus::Failed(r) => Some(r),
            _ => None,
        }
    }

    /// Whether the run succeeded.
    pub fn is_ok(&self) -> bool {
        *self == RunStatus::Ok
    }
}

/// What a run may use besides its parameters: a progress report, a directory for the files
/// it writes itself (snapshots, figures) and the particle frames it writes there.
#[derive(Clone, Copy)]
pub struct RunContext<'a> {
    /// Called now and then with the fraction of the run done, in [0, 1].
    pub progress: &'a (dyn Fn(f64) + Sync),
    /// Where the run writes its own files, if anywhere.
    pub artifacts: Option<&'a Path>,
    /// Frames to write besides the model's own moments, and the formats of all of them.
    pub snapshots: &'a Schedule,
}

impl RunContext<'static> {
    /// No progress report, no files: what sweeps and optimizations use.
    pub const QUIET: RunContext<'static> = RunContext {
        progress: &|_| {},
        artifacts: None,
        snapshots: &Schedule::NONE,
    };
}

impl RunContext<'_> {
    /// A snapshot recorder when the run writes files.
    pub fn recorder(&self) -> Option<Recorder<'_>> {
        self.artifacts.map(|dir| Recorder::new(dir, self.snapshots))
    }
}

/// What one run reports to the runner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// How it ended (serialized as `status` and `reason`).
    #[serde(flatten)]
    pub status: RunStatus,
    /// Warnings of a run that still counts (e.g. a structure analysis that could not be done).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Scalar metrics by name (None: not available in this run).
    pub metrics: Vec<(String, Option<f64>)>,
    /// Time series by observable name: (time in s, value).
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// Wall-clock time, s.
    pub wall_time_s: f64,
}

impl RunResult {
    /// The value of one metric.
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics
            .iter()
            .find(|(n, _)| n == name)
            .and_then(|(_, v)| *v)
    }
}

/// A model as the study runner sees it.
pub trait StudyModel: Sync + Sized + 'static {
    /// Typed parameters of one run.
    type Params: Clone + Send + Sync + std::fmt::Debug + 'static;
    /// Name in study files.
    fn name(&self) -> &'static str;
    /// Its source directory under `src/models/`, whose code fingerprint its runs record
    /// ([`code`](Self::code)).
    const SOURCES: &'static str;

    /// Every parameter it accepts, each declared once.
    fn parameters(&self) -> &'static [Param<Self, Self::Params>];
    /// Every scalar metric it reports.
    fn metrics(&self) -> &'static [&'static str];
    /// Axis labels of its series observables.
    fn series_labels(&self) -> &'static [(&'static str, &'static str)];
    /// The documented defaults.
    fn defaults(&self) -> Self::Params;
    /// Checks a complete parameter set across parameters (each value's own range is checked
    /// when it is parsed); the message names the parameters.
    fn validate(&self, params: &Self::Params) -> Result<()>;
    /// Runs one (parameters, seed). Blow-ups are failed results; an error is only a file the
    /// run could not write into `context.artifacts`.
    fn run(&self, params: &Self::Params, seed: u64, context: &RunContext) -> Result<RunResult>;

    /// The code fingerprint of its physics: recorded with every run and part of its id.
    fn code(&self) -> String {
        super::fingerprint::code(Self::SOURCES)
    }

    /// Everything a run with these parameters depends on besides its seed and the code, as
    /// text: the run id hashes it, and resume compares it. The typed parameters hold the
    /// resolved values, the defaults and the contents of the files they name (materials,
    /// species), so their debug text is complete.
    fn inputs(&self, params: &Self::Params) -> String {
        format!("{params:?}")
    }

    /// What is known before a run starts about its end time and step count, to check a
    /// snapshot schedule against; Err (why) if the run has no particles to snapshot.
    fn run_span(&self, _params: &Self::Params) -> std::result::Result<RunSpan, String> {
        Ok(RunSpan::default())
    }

    /// Checks a snapshot schedule against a run before it starts (one-line error naming the
    /// schedule and what is allowed).
    fn check_schedule(&self, params: &Self::Params, schedule: &Schedule) -> Result<()> {
        if schedule.is_empty() {
            return Ok(());
        }
        self.run_span(params)
            .and_then(|span| schedule.check(&span))
            .map_err(|e| Error::input(format!("snapshots: {e}")))
    }

    /// Checks a complete parameter set: every declared value within its range, then the
    /// model's cross-parameter [`validate`](Self::validate).
    fn check(&self, params: &Self::Params) -> Result<()> {
        for p in self.parameters() {
            if let Some(value) = (p.get)(params) {
                p.spec
                    .check(&value)
                    .map_err(|reason| Error::input(format!("{}: {reason}", p.spec.name)))?;
            }
        }
        self.validate(params)
    }

    /// The declaration of a parameter (by name or alias), or an error listing the known ones.
    fn param(&self, key: &str) -> Result<&'static Param<Self, Self::Params>> {
        self.parameters()
            .iter()
            .find(|p| p.spec.is_named(key))
            .ok_or_else(|| {
                let known: Vec<&str> = self.parameters().iter().map(|p| p.spec.name).collect();
                Error::input(format!(
                    "unknown {} parameter (known: {})",
                    self.name(),
                    known.join(", ")
                ))
            })
    }

    /// The spec of a parameter (by name or alias).
    fn spec(&self, key: &str) -> Result<&'static ParamSpec> {
        self.param(key).map(|p| &p.spec)
    }

    /// Sets a parsed value; `at` names where it came from (`base.field`, `--field`) in the
    /// error.
    fn set(&self, params: &mut Self::Params, key: &str, value: &Value, at: &str) -> Result<()> {
        let param = self.param(key)?;
        (param.set)(self, params, value).map_err(|reason| Error::input(format!("{at}: {reason}")))
    }

    /// Parses, range-checks and sets a study-file or command-line value.
    fn set_from(
        &self,
        params: &mut Self::Params,
        key: &str,
        raw: &toml::Value,
        at: &str,
    ) -> Result<Value> {
        let value = self
            .spec(key)?
            .parse(raw)
            .map_err(|reason| Error::input(format!("{at}: {reason}")))?;
        self.set(params, key, &value, at)?;
        Ok(value)
    }
}
