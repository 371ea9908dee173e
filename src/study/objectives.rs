//! The `[objectives]` table of a study: two or three objectives to minimize or maximize
//! together — metrics of the model, or free parameters themselves (a parameter's cost, such
//! as the field) — over free parameters with bounds. `magopt optimize` finds their Pareto
//! front by NSGA-II ([`crate::study::multi`]).
//!
//! ```toml
//! [objectives]
//! minimize = ["alignment_time_s", "field"]   # metrics or free parameters; 2 or 3 in all
//! maximize = []
//! parameters = { field = ["5kOe", "100kOe"], friction = { range = [0, 0.5] } }
//! scale = "log"           # of the plain [low, high] bounds: "log" (default) or "linear"
//! population = 24         # even, ≥ 4
//! generations = 10        # population × (generations + 1) points in all
//! reference = [60, 110]   # optional hypervolume reference, one per objective (front.parquet
//!                         # units); default: the front's nadir + 10 % of its range
//! ```
//!
//! A bound pair `[low, high]` follows `scale`; `{ log = [low, high] }` or `{ range = [low,
//! high] }` sets one parameter's scale. The NSGA-II seed is the study's `seed`.

use serde::Deserialize;

use super::model::{ParamKind, ParamSpec, StudyModel, Value};
use crate::{Error, Result};

/// Most points per generation and generations.
const MAX_POPULATION: i64 = 10_000;
const MAX_GENERATIONS: i64 = 100_000;

/// The `[objectives]` table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawObjectives {
    minimize: Option<Vec<String>>,
    maximize: Option<Vec<String>>,
    parameters: Option<toml::Table>,
    scale: Option<String>,
    population: Option<i64>,
    generations: Option<i64>,
    reference: Option<Vec<toml::Value>>,
}

/// What an objective measures.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A metric of the model (mean over replicates).
    Metric(String),
    /// A free parameter's own value (display units): its index in [`ObjectivesSpec::free`].
    Parameter(usize),
}

/// One objective.
#[derive(Debug, Clone, PartialEq)]
pub struct Objective {
    /// As named in the study file (a parameter by its canonical name).
    pub name: String,
    /// What it measures.
    pub target: Target,
    /// Maximize instead of minimize.
    pub maximize: bool,
}

/// A free parameter and its bounds (SI).
#[derive(Debug, Clone)]
pub struct FreeParameter {
    /// The parameter.
    pub spec: &'static ParamSpec,
    /// Lower bound (SI).
    pub low: f64,
    /// Upper bound (SI).
    pub high: f64,
    /// Searched in ln x instead of x.
    pub log: bool,
}

impl FreeParameter {
    /// The value (SI) at unit coordinate `u` ∈ [0, 1] (counts rounded).
    pub fn value(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let x = if self.log {
            (self.low.ln() + u * (self.high.ln() - self.low.ln())).exp()
        } else {
            self.low + u * (self.high - self.low)
        };
        let x = x.clamp(self.low, self.high);
        if matches!(self.spec.kind, ParamKind::Count) {
            x.round()
        } else {
            x
        }
    }

    /// A value in display units.
    pub fn shown(&self, x: f64) -> f64 {
        self.spec.display(&Value::Number(x)).as_number()
    }
}

/// The parsed `[objectives]` table.
#[derive(Debug, Clone)]
pub struct ObjectivesSpec {
    /// The objectives: `minimize` ones first, then `maximize` ones, each in file order.
    pub objectives: Vec<Objective>,
    /// The free parameters.
    pub free: Vec<FreeParameter>,
    /// NSGA-II population (even, ≥ 4).
    pub population: usize,
    /// NSGA-II generations after the initial population.
    pub generations: usize,
    /// The hypervolume reference point (objective units, one per objective), if given.
    pub reference: Option<Vec<f64>>,
}

impl ObjectivesSpec {
    /// Points evaluated in all: population × (generations + 1).
    pub fn points(&self) -> usize {
        self.population * (self.generations + 1)
    }

    /// The column of an objective in the result tables: the parameter's display column, or
    /// the metric's name.
    pub fn column(&self, objective: &Objective) -> String {
        match &objective.target {
            Target::Metric(m) => m.clone(),
            Target::Parameter(k) => self.free[*k].spec.column(),
        }
    }

    /// An axis label for an objective.
    pub fn label(&self, objective: &Objective) -> String {
        match &objective.target {
            Target::Metric(m) => {
                let unit = super::records::metric_unit(m);
                if unit == "1" {
                    m.clone()
                } else {
                    format!("{m} ({unit})")
                }
            }
            Target::Parameter(k) => self.free[*k].spec.label(),
        }
    }

    /// The unit of an objective's values.
    pub fn unit(&self, objective: &Objective) -> String {
        match &objective.target {
            Target::Metric(m) => super::records::metric_unit(m).to_string(),
            Target::Parameter(k) => {
                super::records::param_unit(self.free[*k].spec).unwrap_or_else(|| "1".into())
            }
        }
    }

    /// The metrics among the objectives.
    pub fn metrics(&self) -> Vec<&str> {
        self.objectives
            .iter()
            .filter_map(|o| match &o.target {
                Target::Metric(m) => Some(m.as_str()),
                Target::Parameter(_) => None,
            })
            .collect()
    }
}

/// Parses and checks an `[objectives]` table; errors are one line naming the key
/// (`objectives.parameters.field: …`).
pub fn parse<M: StudyModel>(model: &M, raw: RawObjectives) -> Result<ObjectivesSpec> {
    let fail = |key: &str, why: String| Error::input(format!("objectives.{key}: {why}"));
    let default_log = match raw.scale.as_deref().unwrap_or("log") {
        "log" => true,
        "linear" => false,
        other => return Err(fail("scale", format!("'{other}' is not log or linear"))),
    };
    let mut free: Vec<FreeParameter> = Vec::new();
    for (key, bounds) in raw.parameters.iter().flatten() {
        let at = format!("parameters.{key}");
        let spec = model.spec(key).map_err(|e| fail(&at, e.to_string()))?;
        if free.iter().any(|f| f.spec.name == spec.name) {
            return Err(fail(&at, format!("{} is given twice", spec.name)));
        }
        free.push(free_parameter(spec, bounds, default_log).map_err(|why| fail(&at, why))?);
    }
    if free.is_empty() {
        return Err(fail(
            "parameters",
            "name at least one free parameter with its bounds, e.g. { field = [\"5kOe\", \
             \"100kOe\"] }"
                .into(),
        ));
    }
    let mut objectives: Vec<Objective> = Vec::new();
    for (key, names, maximize) in [
        ("minimize", raw.minimize.unwrap_or_default(), false),
        ("maximize", raw.maximize.unwrap_or_default(), true),
    ] {
        for name in names {
            let target = target(model, &free, &name).map_err(|why| fail(key, why))?;
            if let Some(o) = objectives.iter().find(|o| o.target == target) {
                return Err(fail(
                    key,
                    format!(
                        "'{name}' is already an objective (to {})",
                        if o.maximize { "maximize" } else { "minimize" }
                    ),
                ));
            }
            let name = match &target {
                Target::Parameter(k) => free[*k].spec.name.to_string(),
                Target::Metric(_) => name,
            };
            objectives.push(Objective {
                name,
                target,
                maximize,
            });
        }
    }
    if !(2..=3).contains(&objectives.len()) {
        let names: Vec<&str> = objectives.iter().map(|o| o.name.as_str()).collect();
        return Err(fail(
            "minimize",
            format!(
                "{} objective(s) [{}] is not allowed (need 2 or 3 in minimize and maximize \
                 together)",
                objectives.len(),
                names.join(", ")
            ),
        ));
    }
    let population = match raw.population.unwrap_or(24) {
        p if (4..=MAX_POPULATION).contains(&p) && p % 2 == 0 => p as usize,
        p => {
            return Err(fail(
                "population",
                format!("{p} is not allowed (need an even number in 4..={MAX_POPULATION})"),
            ))
        }
    };
    let generations = match raw.generations.unwrap_or(10) {
        g if (1..=MAX_GENERATIONS).contains(&g) => g as usize,
        g => {
            return Err(fail(
                "generations",
                format!("{g} is not allowed (need 1..={MAX_GENERATIONS})"),
            ))
        }
    };
    let reference = match raw.reference {
        None => None,
        Some(values) => {
            if values.len() != objectives.len() {
                return Err(fail(
                    "reference",
                    format!(
                        "need one value per objective ({}), got {}",
                        objectives.len(),
                        values.len()
                    ),
                ));
            }
            let numbers = values
                .iter()
                .map(|v| {
                    v.as_float()
                        .or(v.as_integer().map(|i| i as f64))
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| {
                            fail(
                                "reference",
                                format!(
                                    "{v} is not a number (give plain numbers in the units of \
                                     front.parquet)"
                                ),
                            )
                        })
                })
                .collect::<Result<Vec<f64>>>()?;
            Some(numbers)
        }
    };
    Ok(ObjectivesSpec {
        objectives,
        free,
        population,
        generations,
        reference,
    })
}

/// What an objective's name refers to: a free parameter (by name or alias), else a metric.
fn target<M: StudyModel>(
    model: &M,
    free: &[FreeParameter],
    name: &str,
) -> std::result::Result<Target, String> {
    if let Some(k) = free.iter().position(|f| f.spec.is_named(name)) {
        return Ok(Target::Parameter(k));
    }
    if model.metrics().contains(&name) {
        return Ok(Target::Metric(name.to_string()));
    }
    let free_names: Vec<&str> = free.iter().map(|f| f.spec.name).collect();
    let hint = if model.spec(name).is_ok() {
        format!(" ({name} is a parameter but not free: give its bounds in objectives.parameters)")
    } else {
        String::new()
    };
    Err(format!(
        "'{name}' is neither a metric of {} nor a free parameter{hint} (metrics: {}; free \
         parameters: {})",
        model.name(),
        model.metrics().join(", "),
        free_names.join(", ")
    ))
}

/// One `[objectives.parameters]` entry: `[low, high]` on the table's scale, or `{ log = [low,
/// high] }` / `{ range = [low, high] }`.
fn free_parameter(
    spec: &'static ParamSpec,
    raw: &toml::Value,
    default_log: bool,
) -> std::result::Result<FreeParameter, String> {
    const FORMS: &str = "use [low, high], { log = [low, high] } or { range = [low, high] }";
    let (pair, log, explicit) = match raw {
        toml::Value::Array(items) => (items, default_log, false),
        toml::Value::Table(t) if t.len() == 1 => {
            let (kind, value) = t.iter().next().expect("one entry");
            let log = match kind.as_str() {
                "log" => true,
                "range" => false,
                other => return Err(format!("'{other}' is not a scale ({FORMS})")),
            };
            match value {
                toml::Value::Array(items) => (items, log, true),
                other => return Err(format!("{other} is not [low, high] ({FORMS})")),
            }
        }
        other => return Err(format!("{other} is not a pair of bounds ({FORMS})")),
    };
    if pair.len() != 2 {
        return Err(format!("need [low, high], got {raw}"));
    }
    if matches!(spec.kind, ParamKind::Choice(_) | ParamKind::Name) {
        return Err(format!(
            "{} is not a number, so it cannot be free",
            spec.name
        ));
    }
    let number = |v: &toml::Value| match spec.parse(v)? {
        Value::Number(x) => Ok(x),
        Value::Text(t) => Err(format!("'{t}' is not a number")),
    };
    let (low, high) = (number(&pair[0])?, number(&pair[1])?);
    let shown = |x: f64| spec.user_text(&Value::Number(x));
    if low.partial_cmp(&high) != Some(std::cmp::Ordering::Less) {
        return Err(format!(
            "need low < high (got {}, {})",
            shown(low),
            shown(high)
        ));
    }
    if log && low <= 0.0 {
        let fix = if explicit {
            "use { range = [low, high] }"
        } else {
            "use { range = [low, high] } or scale = \"linear\""
        };
        return Err(format!(
            "a log scale needs low > 0 (got {}; {fix})",
            shown(low)
        ));
    }
    Ok(FreeParameter {
        spec,
        low,
        high,
        log,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;
    use crate::models::align::study::AlignModel;

    fn parse_text(text: &str) -> Result<ObjectivesSpec> {
        let raw: RawObjectives = toml::from_str(text).map_err(|e| Error::input(e.to_string()))?;
        parse(&AlignModel::new(MaterialDb::builtin()), raw)
    }

    #[test]
    fn parses_metrics_and_parameters_as_objectives() {
        let spec = parse_text(
            r#"
            minimize = ["alignment_time_s", "field"]
            parameters = { field = ["5kOe", "100kOe"], friction = { range = [0, 0.5] } }
            population = 8
            generations = 3
            reference = [100, 110.5]
            "#,
        )
        .unwrap();
        assert_eq!(spec.objectives.len(), 2);
        assert_eq!(
            spec.objectives[0].target,
            Target::Metric("alignment_time_s".into())
        );
        let k = spec
            .free
            .iter()
            .position(|f| f.spec.name == "field")
            .unwrap();
        assert_eq!(spec.objectives[1].target, Target::Parameter(k));
        assert!(spec.free[k].log);
        let f = spec
            .free
            .iter()
            .find(|f| f.spec.name == "friction")
            .unwrap();
        assert!(!f.log && f.low == 0.0 && f.high == 0.5);
        assert_eq!(spec.points(), 32);
        assert_eq!(spec.reference, Some(vec![100.0, 110.5]));
        assert_eq!(spec.column(&spec.objectives[1]), "field_kOe");
        // log scale maps the ends and the geometric midpoint
        let field = &spec.free[k];
        assert!((field.shown(field.value(0.0)) - 5.0).abs() < 1e-9);
        assert!((field.shown(field.value(1.0)) - 100.0).abs() < 1e-9);
        assert!((field.shown(field.value(0.5)) - 500f64.sqrt()).abs() < 1e-9);
    }

    /// Cases beyond those `tests/pareto.rs` checks end to end (exit 2 before any run).
    #[test]
    fn bad_input_names_the_key() {
        let cases = [
            (
                r#"minimize = ["alignment_time_s", "field", "final_alignment", "steps"]
                parameters = { field = ["5kOe", "100kOe"] }"#,
                "objectives.minimize: 4 objective",
            ),
            (
                r#"minimize = ["alignment_time_s", "speed"]
                parameters = { field = ["5kOe", "100kOe"] }"#,
                "objectives.minimize: 'speed' is neither",
            ),
            (
                r#"minimize = ["alignment_time_s", "friction"]
                parameters = { field = ["5kOe", "100kOe"] }"#,
                "not free",
            ),
            (
                r#"minimize = ["alignment_time_s", "field"]
                parameters = { field = ["5kOe", "100kOe"] }
                population = 5"#,
                "objectives.population: 5 is not allowed",
            ),
            (
                r#"minimize = ["alignment_time_s", "field"]
                maximize = ["field"]
                parameters = { field = ["5kOe", "100kOe"] }"#,
                "objectives.maximize: 'field' is already",
            ),
            (
                r#"minimize = ["alignment_time_s", "field"]
                parameters = { field = ["5kOe", "100kOe"] }
                reference = [1]"#,
                "objectives.reference: need one value per objective",
            ),
            (
                r#"minimize = ["alignment_time_s", "field"]
                parameters = { field = { cube = ["5kOe", "100kOe"] } }"#,
                "objectives.parameters.field: 'cube'",
            ),
            (
                r#"minimize = ["alignment_time_s", "field"]
                scale = "ln"
                parameters = { field = ["5kOe", "100kOe"] }"#,
                "objectives.scale",
            ),
        ];
        for (text, expected) in cases {
            let e = parse_text(text).unwrap_err().to_string();
            assert!(e.contains(expected), "{e} (expected {expected})");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
