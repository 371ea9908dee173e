//! `analytic` as a study model: the function, its inputs x1…x6 and the noise level in; the
//! objectives out (`value`, and `f1`, `f2` for a two-objective function). No series.

use std::time::Instant;

use super::{AnalyticParams, Function};
use crate::study::model::{
    Param, ParamKind as K, ParamSpec, RunContext, RunResult, RunSpan, RunStatus, StudyModel,
};
use crate::study::param::Bounds;
use crate::{choice_param, number_param, Error, Result};

/// The `analytic` study model.
#[derive(Debug, Default)]
pub struct AnalyticModel;

type AnalyticParam = Param<AnalyticModel, AnalyticParams>;

const fn input(name: &'static str, doc: &'static str) -> ParamSpec {
    ParamSpec::new(name, K::Number, doc)
}

/// Every `analytic` parameter, declared once.
static PARAMETERS: &[AnalyticParam] = &[
    choice_param!(
        "function",
        "Test function: ishigami (x1–x3 in [-π, π], a = 7, b = 0.1), branin (x1 in [-5, 10], \
         x2 in [0, 15]), hartmann6 (x1–x6 in [0, 1]), zdt1 (two objectives, x1–x6 in [0, 1])",
        function,
        [
            ("ishigami", Function::Ishigami),
            ("branin", Function::Branin),
            ("hartmann6", Function::Hartmann6),
            ("zdt1", Function::Zdt1)
        ]
    ),
    number_param!(
        input(
            "x1",
            "Input x1 (ishigami [-π, π], branin [-5, 10], hartmann6 and zdt1 [0, 1])"
        ),
        x1
    ),
    number_param!(
        input(
            "x2",
            "Input x2 (ishigami [-π, π], branin [0, 15], hartmann6 and zdt1 [0, 1])"
        ),
        x2
    ),
    number_param!(
        input(
            "x3",
            "Input x3 (ishigami [-π, π], hartmann6 and zdt1 [0, 1]; unused by branin)"
        ),
        x3
    ),
    number_param!(
        input(
            "x4",
            "Input x4 (hartmann6 and zdt1 [0, 1]; unused by ishigami and branin)"
        ),
        x4
    ),
    number_param!(
        input(
            "x5",
            "Input x5 (hartmann6 and zdt1 [0, 1]; unused by ishigami and branin)"
        ),
        x5
    ),
    number_param!(
        input(
            "x6",
            "Input x6 (hartmann6 and zdt1 [0, 1]; unused by ishigami and branin)"
        ),
        x6
    ),
    number_param!(
        input(
            "noise",
            "Standard deviation of Gaussian noise added to every objective (drawn from the \
             run's seed; 0: exact)"
        )
        .within(Bounds::NON_NEGATIVE),
        noise
    ),
];

/// Every metric: `value` (the function; f1 for ZDT1), `f1` and `f2` (ZDT1 only; null
/// otherwise).
pub const METRICS: &[&str] = &["value", "f1", "f2"];

impl StudyModel for AnalyticModel {
    type Params = AnalyticParams;
    const SOURCES: &'static str = "analytic";

    fn name(&self) -> &'static str {
        "analytic"
    }

    fn parameters(&self) -> &'static [AnalyticParam] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        METRICS
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        &[]
    }

    /// Ishigami at (0.5, …, 0.5) without noise.
    fn defaults(&self) -> AnalyticParams {
        AnalyticParams::default()
    }

    fn validate(&self, params: &AnalyticParams) -> Result<()> {
        params.validate().map_err(Error::input)
    }

    fn run_span(&self, _params: &AnalyticParams) -> std::result::Result<RunSpan, String> {
        Err("the analytic model has no particles to snapshot".into())
    }

    fn run(&self, params: &AnalyticParams, seed: u64, context: &RunContext) -> Result<RunResult> {
        let start = Instant::now();
        let objectives = params.evaluate(seed);
        (context.progress)(1.0);
        let (f1, f2) = objectives.pair.unzip();
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        Ok(RunResult {
            status: RunStatus::Ok,
            notes: Vec::new(),
            metrics: vec![
                ("value".to_string(), finite(objectives.value)),
                ("f1".to_string(), f1.and_then(finite)),
                ("f2".to_string(), f2.and_then(finite)),
            ],
            series: Vec::new(),
            wall_time_s: start.elapsed().as_secs_f64(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(params: &mut AnalyticParams, key: &str, raw: toml::Value) -> Result<()> {
        AnalyticModel
            .set_from(params, key, &raw, &format!("base.{key}"))
            .map(|_| ())
    }

    #[test]
    fn parameters_set_and_check() {
        let m = AnalyticModel;
        let mut p = m.defaults();
        assert!(m.check(&p).is_ok());
        set(&mut p, "function", toml::Value::String("branin".into())).unwrap();
        set(&mut p, "x1", toml::Value::Float(9.5)).unwrap();
        set(&mut p, "x2", toml::Value::Integer(14)).unwrap();
        assert_eq!((p.function, p.x1, p.x2), (Function::Branin, 9.5, 14.0));
        assert!(m.check(&p).is_ok());
        set(&mut p, "x1", toml::Value::Integer(11)).unwrap();
        assert_eq!(
            m.check(&p).unwrap_err().to_string(),
            "x1: 11 is outside the domain of branin (need x1 in [-5, 10])"
        );
        let e = set(&mut p, "function", toml::Value::String("sphere".into())).unwrap_err();
        assert_eq!(
            e.to_string(),
            "base.function: 'sphere' is not one of ishigami, branin, hartmann6, zdt1"
        );
        let e = set(&mut p, "noise", toml::Value::Float(-1.0)).unwrap_err();
        assert_eq!(e.to_string(), "base.noise: -1 is not allowed (need ≥ 0)");
    }

    #[test]
    fn runs_report_value_and_the_pair() {
        let m = AnalyticModel;
        let p = AnalyticParams {
            function: Function::Branin,
            x1: 0.0,
            x2: 0.0,
            ..m.defaults()
        };
        let r = m.run(&p, 1, &RunContext::QUIET).unwrap();
        assert!(r.status.is_ok());
        assert_eq!(r.metric("value"), Some(super::super::branin(0.0, 0.0)));
        assert_eq!((r.metric("f1"), r.metric("f2")), (None, None));
        assert_eq!(r.metrics.len(), METRICS.len());
        let z = AnalyticParams {
            function: Function::Zdt1,
            x1: 0.25,
            x2: 0.0,
            x3: 0.0,
            x4: 0.0,
            x5: 0.0,
            x6: 0.0,
            ..m.defaults()
        };
        let r = m.run(&z, 1, &RunContext::QUIET).unwrap();
        assert_eq!(r.metric("value"), Some(0.25));
        assert_eq!(r.metric("f1"), Some(0.25));
        assert_eq!(r.metric("f2"), Some(0.5));
        assert!(r.series.is_empty());
    }

    #[test]
    fn inputs_differ_between_functions_and_noise() {
        let m = AnalyticModel;
        let a = m.defaults();
        let b = AnalyticParams {
            noise: 0.1,
            ..a.clone()
        };
        assert_ne!(m.inputs(&a), m.inputs(&b));
        assert!(m.run_span(&a).is_err());
    }
}
