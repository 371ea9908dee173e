//! How the study runner sees a model: parameters in (by name, with units), metrics and series
//! out. Every model implements [`StudyModel`]; the runner never touches model internals.

use serde::{Deserialize, Serialize};

use crate::units::{parse_quantity, si_per_unit, to_unit, Dimension};
use crate::{Error, Result};

/// A parameter value after unit conversion: numbers are SI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Value {
    /// A number in SI units (or dimensionless).
    Number(f64),
    /// A name or a choice.
    Text(String),
}

impl Value {
    /// The text of a name or choice ("" for a number).
    pub fn as_text(&self) -> &str {
        match self {
            Value::Text(t) => t,
            Value::Number(_) => "",
        }
    }

    /// The number (NaN for a text; the parameter specs keep the two apart).
    pub fn as_number(&self) -> f64 {
        match self {
            Value::Number(x) => *x,
            Value::Text(_) => f64::NAN,
        }
    }

    /// Canonical text for run ids: exact (round-trip) for numbers.
    pub fn canonical(&self) -> String {
        match self {
            Value::Number(x) => format!("{x:?}"),
            Value::Text(t) => format!("{t:?}"),
        }
    }
}

/// What kind of value a parameter takes.
#[derive(Debug, Clone, Copy)]
pub enum ParamKind {
    /// A physical quantity: strings with units, bare numbers in `unit` (also the display unit).
    Quantity {
        /// Dimension accepted.
        dim: Dimension,
        /// Default and display unit.
        unit: &'static str,
    },
    /// A dimensionless finite number.
    Number,
    /// A whole number ≥ 1.
    Count,
    /// One of a fixed list of names.
    Choice(&'static [&'static str]),
    /// Free text (e.g. a material name, checked by the model).
    Name,
}

/// One parameter a model accepts.
#[derive(Debug, Clone, Copy)]
pub struct ParamSpec {
    /// Name in study files (snake_case) and, with dashes, on the command line.
    pub name: &'static str,
    /// Value kind.
    pub kind: ParamKind,
}

impl ParamSpec {
    /// Parses a study-file or command-line value.
    pub fn parse(&self, value: &toml::Value) -> Result<Value> {
        let bad = |what: String| Error::input(format!("{}: {what}", self.name));
        match (self.kind, value) {
            (ParamKind::Quantity { dim, unit }, toml::Value::String(s)) => {
                parse_quantity(s, dim, unit).map(Value::Number).map_err(bad)
            }
            (ParamKind::Quantity { unit, .. }, v) => {
                Ok(Value::Number(number(v).map_err(bad)? * si_per_unit(unit)))
            }
            (ParamKind::Number, v) => Ok(Value::Number(number(v).map_err(bad)?)),
            (ParamKind::Count, v) => {
                let x = number(v).map_err(bad)?;
                if x >= 1.0 && x.fract() == 0.0 && x <= 1e12 {
                    Ok(Value::Number(x))
                } else {
                    Err(bad(format!("{x} is not allowed (need a whole number ≥ 1)")))
                }
            }
            (ParamKind::Choice(options), toml::Value::String(s))
                if options.contains(&s.as_str()) =>
            {
                Ok(Value::Text(s.clone()))
            }
            (ParamKind::Choice(options), v) => {
                Err(bad(format!("{v} is not one of {}", options.join(", "))))
            }
            (ParamKind::Name, toml::Value::String(s)) => Ok(Value::Text(s.clone())),
            (ParamKind::Name, v) => Err(bad(format!("{v} is not a name (need a string)"))),
        }
    }

    /// Column name of the value in display units (`field_kOe`, `pressure_atm`, `friction`).
    pub fn column(&self) -> String {
        match self.kind {
            ParamKind::Quantity { unit, .. } => {
                format!(
                    "{}_{}",
                    self.name,
                    unit.replace('/', "_per_").replace('*', "_")
                )
            }
            _ => self.name.to_string(),
        }
    }

    /// Axis label with unit.
    pub fn label(&self) -> String {
        match self.kind {
            ParamKind::Quantity { unit, .. } => format!("{} ({unit})", self.name.replace('_', " ")),
            _ => self.name.replace('_', " "),
        }
    }

    /// A TOML literal that parses back to exactly `value` (quantities carry their SI unit,
    /// since a bare number means the display unit).
    pub fn toml_literal(&self, value: &Value) -> String {
        match (self.kind, value) {
            (ParamKind::Quantity { dim, .. }, Value::Number(x)) => {
                format!("\"{x:?} {}\"", si_unit(dim))
            }
            (ParamKind::Count, Value::Number(x)) => format!("{}", *x as u64),
            (_, Value::Number(x)) => format!("{x:?}"),
            (_, Value::Text(t)) => format!("{t:?}"),
        }
    }

    /// A value in display units (numbers) or as text.
    pub fn display(&self, value: &Value) -> Value {
        match (self.kind, value) {
            (ParamKind::Quantity { unit, .. }, Value::Number(x)) => {
                Value::Number(to_unit(*x, unit))
            }
            (_, v) => v.clone(),
        }
    }
}

/// The SI unit symbol of a dimension (as the unit parser spells it).
fn si_unit(dim: Dimension) -> &'static str {
    match dim {
        Dimension::MagneticField | Dimension::Magnetization => "A/m",
        Dimension::EnergyDensity => "J/m3",
        Dimension::Pressure => "Pa",
        Dimension::Density => "kg/m3",
        Dimension::Length => "m",
        Dimension::Time => "s",
        Dimension::Velocity => "m/s",
        Dimension::Acceleration => "m/s2",
        Dimension::Mass => "kg",
        Dimension::Energy => "J",
        Dimension::ElectricField => "V/m",
        Dimension::ChargePerMass => "C/kg",
        Dimension::Viscosity => "Pa*s",
    }
}

/// A finite number from a TOML number or a numeric string.
fn number(value: &toml::Value) -> std::result::Result<f64, String> {
    let x = match value {
        toml::Value::Float(x) => *x,
        toml::Value::Integer(i) => *i as f64,
        toml::Value::String(s) => s
            .trim()
            .parse::<f64>()
            .map_err(|_| format!("'{s}' is not a number"))?,
        other => return Err(format!("{other} is not a number")),
    };
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{x} is not a finite number"))
    }
}

/// What one run reports to the runner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// "ok", "not-reached" or "failed".
    pub status: String,
    /// Why it failed (empty otherwise).
    pub reason: String,
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
pub trait StudyModel: Sync {
    /// Typed parameters of one run.
    type Params: Clone + Send + Sync;
    /// Name in study files.
    fn name(&self) -> &'static str;
    /// Every parameter it accepts.
    fn parameters(&self) -> &'static [ParamSpec];
    /// Every scalar metric it reports.
    fn metrics(&self) -> &'static [&'static str];
    /// Axis labels of its series observables.
    fn series_labels(&self) -> &'static [(&'static str, &'static str)];
    /// The documented defaults.
    fn defaults(&self) -> Self::Params;
    /// Sets one parameter (already unit-converted).
    fn set(&self, params: &mut Self::Params, name: &str, value: &Value) -> Result<()>;
    /// Checks a complete parameter set (names the offending value).
    fn validate(&self, params: &Self::Params) -> Result<()>;
    /// Runs one (parameters, seed). Blow-ups are failed results, not errors.
    fn run(&self, params: &Self::Params, seed: u64) -> RunResult;

    /// The spec of a parameter, or an error listing the known ones.
    fn spec(&self, name: &str) -> Result<&'static ParamSpec> {
        self.parameters()
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| {
                let known: Vec<&str> = self.parameters().iter().map(|p| p.name).collect();
                Error::input(format!(
                    "unknown {} parameter '{name}' (known: {})",
                    self.name(),
                    known.join(", ")
                ))
            })
    }

    /// Parses and sets one parameter from a study-file value.
    fn set_from(&self, params: &mut Self::Params, name: &str, value: &toml::Value) -> Result<()> {
        let parsed = self.spec(name)?.parse(value)?;
        self.set(params, name, &parsed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_literals_parse_back_exactly() {
        let specs = [
            ParamSpec {
                name: "field",
                kind: ParamKind::Quantity {
                    dim: Dimension::MagneticField,
                    unit: "kOe",
                },
            },
            ParamSpec {
                name: "pressure",
                kind: ParamKind::Quantity {
                    dim: Dimension::Pressure,
                    unit: "atm",
                },
            },
            ParamSpec {
                name: "diameter",
                kind: ParamKind::Quantity {
                    dim: Dimension::Length,
                    unit: "um",
                },
            },
            ParamSpec {
                name: "particles",
                kind: ParamKind::Count,
            },
            ParamSpec {
                name: "friction",
                kind: ParamKind::Number,
            },
            ParamSpec {
                name: "material",
                kind: ParamKind::Name,
            },
        ];
        let values = [
            Value::Number(3.183098861837907e6),
            Value::Number(50662.5),
            Value::Number(1.1e-6),
            Value::Number(1000.0),
            Value::Number(0.1 + 0.2),
            Value::Text("sr\"fe".into()),
        ];
        for (spec, value) in specs.iter().zip(&values) {
            let literal = spec.toml_literal(value);
            let parsed: toml::Table = toml::from_str(&format!("x = {literal}")).unwrap();
            assert_eq!(&spec.parse(&parsed["x"]).unwrap(), value, "{literal}");
        }
    }
}
