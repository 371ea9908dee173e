//! One declaration per parameter: name, kind (physical dimension and display unit, or none),
//! allowed range, one-line doc and how to read and write it on a model's parameter struct.
//! From that one [`Param`] come the study-file parser, the setter, the range check (the message
//! names the key, the value and the allowed range) and the command-line flags with their help
//! text and defaults (`cli::params`). See ARCHITECTURE.md, "Adding a parameter".

use serde::{Deserialize, Serialize};

use crate::units::{parse_quantity, si_per_unit, to_unit, Dimension};

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

    /// The number (NaN for a text; the parameter kinds keep the two apart).
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

/// Largest count any parameter accepts (particles, samples, …): beyond it no run fits in memory.
pub const MAX_COUNT: f64 = 1e8;

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
    /// A length in multiples of a reference length named `of` (bare numbers), or an absolute
    /// length with a unit (kept as text "<metres> m" and resolved by the model).
    Multiple {
        /// The reference, e.g. "D1".
        of: &'static str,
    },
    /// A dimensionless finite number.
    Number,
    /// A whole number in 1..=[`MAX_COUNT`].
    Count,
    /// One of a fixed list of names.
    Choice(&'static [&'static str]),
    /// Free text (a material name, a file, a direction), checked by the setter.
    Name,
}

/// One end of an allowed range (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// No limit.
    Open,
    /// The value itself is allowed.
    Closed(f64),
    /// Values strictly beyond it only.
    Strict(f64),
}

/// The allowed range of a number (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower end.
    pub low: Bound,
    /// Upper end.
    pub high: Bound,
}

impl Bounds {
    /// Any finite value.
    pub const ANY: Bounds = Bounds {
        low: Bound::Open,
        high: Bound::Open,
    };
    /// x ≥ 0.
    pub const NON_NEGATIVE: Bounds = Bounds::at_least(0.0);
    /// x > 0.
    pub const POSITIVE: Bounds = Bounds::above(0.0);
    /// 0 ≤ x ≤ 1.
    pub const FRACTION: Bounds = Bounds::closed(0.0, 1.0);
    /// 0 < x < 1.
    pub const UNIT_OPEN: Bounds = Bounds {
        low: Bound::Strict(0.0),
        high: Bound::Strict(1.0),
    };

    /// x ≥ a.
    pub const fn at_least(a: f64) -> Self {
        Self {
            low: Bound::Closed(a),
            high: Bound::Open,
        }
    }

    /// x > a.
    pub const fn above(a: f64) -> Self {
        Self {
            low: Bound::Strict(a),
            high: Bound::Open,
        }
    }

    /// a ≤ x ≤ b.
    pub const fn closed(a: f64, b: f64) -> Self {
        Self {
            low: Bound::Closed(a),
            high: Bound::Closed(b),
        }
    }

    /// a < x ≤ b.
    pub const fn above_to(a: f64, b: f64) -> Self {
        Self {
            low: Bound::Strict(a),
            high: Bound::Closed(b),
        }
    }

    /// Whether x lies in the range.
    pub fn contains(&self, x: f64) -> bool {
        let low = match self.low {
            Bound::Open => true,
            Bound::Closed(a) => x >= a,
            Bound::Strict(a) => x > a,
        };
        let high = match self.high {
            Bound::Open => true,
            Bound::Closed(b) => x <= b,
            Bound::Strict(b) => x < b,
        };
        low && high
    }

    /// "≥ 0 kOe", "in (0, 1)", "any value", with the ends shown in `unit` (None: as is).
    pub fn describe(&self, unit: Option<&str>) -> String {
        let show = |x: f64| {
            let v = unit.map_or(x, |u| to_unit(x, u));
            format!("{}", round_display(v))
        };
        let suffix = unit.map_or(String::new(), |u| format!(" {u}"));
        match (self.low, self.high) {
            (Bound::Open, Bound::Open) => "any finite value".into(),
            (Bound::Closed(a), Bound::Open) => format!("≥ {}{suffix}", show(a)),
            (Bound::Strict(a), Bound::Open) => format!("> {}{suffix}", show(a)),
            (Bound::Open, Bound::Closed(b)) => format!("≤ {}{suffix}", show(b)),
            (Bound::Open, Bound::Strict(b)) => format!("< {}{suffix}", show(b)),
            (low, high) => {
                let (l, a) = match low {
                    Bound::Closed(a) => ('[', a),
                    Bound::Strict(a) => ('(', a),
                    Bound::Open => unreachable!("handled above"),
                };
                let (h, b) = match high {
                    Bound::Closed(b) => (']', b),
                    Bound::Strict(b) => (')', b),
                    Bound::Open => unreachable!("handled above"),
                };
                format!("in {l}{}, {}{h}{suffix}", show(a), show(b))
            }
        }
    }
}

/// A number as a person would write it (drops the float noise of unit conversions).
fn round_display(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let digits = 12 - x.abs().log10().ceil() as i32;
    if !(0..=300).contains(&digits) {
        return x;
    }
    let scale = 10f64.powi(digits);
    (x * scale).round() / scale
}

/// Everything about a parameter except how a model stores it.
#[derive(Debug, Clone, Copy)]
pub struct ParamSpec {
    /// Name in study files (snake_case); the command-line flag is the same with dashes.
    pub name: &'static str,
    /// Older names still accepted in study files and (with dashes) on the command line.
    pub aliases: &'static [&'static str],
    /// Value kind.
    pub kind: ParamKind,
    /// Allowed range of numbers (SI).
    pub bounds: Bounds,
    /// One-line description, with the unit a bare number is in.
    pub doc: &'static str,
    /// Shown as the default when the model derives it from other parameters.
    pub derived: &'static str,
}

impl ParamSpec {
    /// A parameter of any value of its kind.
    pub const fn new(name: &'static str, kind: ParamKind, doc: &'static str) -> Self {
        Self {
            name,
            aliases: &[],
            kind,
            bounds: Bounds::ANY,
            doc,
            derived: "",
        }
    }

    /// A physical quantity with a display unit.
    pub const fn quantity(
        name: &'static str,
        dim: Dimension,
        unit: &'static str,
        doc: &'static str,
    ) -> Self {
        Self::new(name, ParamKind::Quantity { dim, unit }, doc)
    }

    /// The same, allowed only within `bounds` (SI).
    pub const fn within(self, bounds: Bounds) -> Self {
        Self { bounds, ..self }
    }

    /// The same, also accepted under older names.
    pub const fn aliases(self, aliases: &'static [&'static str]) -> Self {
        Self { aliases, ..self }
    }

    /// The same, with a default the model derives from other parameters (described).
    pub const fn derived(self, derived: &'static str) -> Self {
        Self { derived, ..self }
    }

    /// Whether `key` names this parameter (its name or an alias).
    pub fn is_named(&self, key: &str) -> bool {
        self.name == key || self.aliases.contains(&key)
    }

    /// The unit bare numbers are in and values are shown in (None: dimensionless or text).
    pub fn unit(&self) -> Option<&'static str> {
        match self.kind {
            ParamKind::Quantity { unit, .. } => Some(unit),
            _ => None,
        }
    }

    /// Parses a study-file or command-line value and checks its range. The error is the bare
    /// reason; the caller names where the value came from (`base.field`, `--field`).
    pub fn parse(&self, value: &toml::Value) -> Result<Value, String> {
        let parsed = self.parse_kind(value)?;
        self.check(&parsed)?;
        Ok(parsed)
    }

    /// Checks that a number is a normal float (or zero) within the allowed range.
    pub fn check(&self, value: &Value) -> Result<(), String> {
        let Value::Number(x) = *value else {
            return Ok(());
        };
        if x != 0.0 && !x.is_normal() {
            return Err(format!(
                "{x:e} (SI) is too small to compute with (not a normal floating-point number)"
            ));
        }
        if !self.bounds.contains(x) {
            let shown = self.unit().map_or(x, |u| to_unit(x, u));
            let unit = self.unit().map_or(String::new(), |u| format!(" {u}"));
            return Err(format!(
                "{}{unit} is not allowed (need {})",
                round_display(shown),
                self.bounds.describe(self.unit())
            ));
        }
        Ok(())
    }

    fn parse_kind(&self, value: &toml::Value) -> Result<Value, String> {
        match (self.kind, value) {
            (ParamKind::Quantity { dim, unit }, toml::Value::String(s)) => {
                parse_quantity(s, dim, unit).map(Value::Number)
            }
            (ParamKind::Quantity { unit, .. }, v) => {
                let si = number(v)? * si_per_unit(unit);
                finite(si).map(Value::Number)
            }
            (ParamKind::Multiple { .. }, toml::Value::String(s))
                if s.trim().parse::<f64>().is_err() =>
            {
                let metres = parse_quantity(s, Dimension::Length, "m")?;
                if metres > 0.0 {
                    Ok(Value::Text(format!("{metres:?} m")))
                } else {
                    Err(format!("'{s}' is not allowed (need a length > 0)"))
                }
            }
            (ParamKind::Multiple { .. } | ParamKind::Number, v) => number(v).map(Value::Number),
            (ParamKind::Count, v) => {
                let x = number(v)?;
                if x >= 1.0 && x.fract() == 0.0 && x <= MAX_COUNT {
                    Ok(Value::Number(x))
                } else {
                    Err(format!(
                        "{x} is not allowed (need a whole number in 1..={MAX_COUNT:e})"
                    ))
                }
            }
            (ParamKind::Choice(options), toml::Value::String(s))
                if options.contains(&s.as_str()) =>
            {
                Ok(Value::Text(s.clone()))
            }
            (ParamKind::Choice(options), v) => {
                Err(format!("{} is not one of {}", shown(v), options.join(", ")))
            }
            (ParamKind::Name, toml::Value::String(s)) => Ok(Value::Text(s.clone())),
            (ParamKind::Name, v) => Err(format!("{v} is not a name (need a string)")),
        }
    }

    /// Column name of the value in display units (`field_kOe`, `pressure_atm`, `friction`).
    pub fn column(&self) -> String {
        match self.unit() {
            Some(unit) => format!(
                "{}_{}",
                self.name,
                unit.replace('/', "_per_").replace('*', "_")
            ),
            None => self.name.to_string(),
        }
    }

    /// Axis label with unit.
    pub fn label(&self) -> String {
        match self.unit() {
            Some(unit) => format!("{} ({unit})", self.name.replace('_', " ")),
            None => self.name.replace('_', " "),
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

    /// Text a user could type for `value`: the number in the display unit with the unit
    /// (`40 kOe`), or the name.
    pub fn user_text(&self, value: &Value) -> String {
        match (self.unit(), value) {
            (Some(unit), Value::Number(x)) => {
                format!("{} {unit}", round_display(to_unit(*x, unit)))
            }
            (None, Value::Number(x)) => format!("{}", round_display(*x)),
            (_, Value::Text(t)) => t.clone(),
        }
    }

    /// A value in display units (numbers) or as text.
    pub fn display(&self, value: &Value) -> Value {
        match (self.unit(), value) {
            (Some(unit), Value::Number(x)) => Value::Number(to_unit(*x, unit)),
            (_, v) => v.clone(),
        }
    }
}

/// Shorthand for [`ParamSpec::quantity`] in the models' parameter tables.
pub const fn quantity(
    name: &'static str,
    dim: Dimension,
    unit: &'static str,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec::quantity(name, dim, unit, doc)
}

/// A TOML value quoted for a message (strings with their quotes).
fn shown(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => format!("'{s}'"),
        other => other.to_string(),
    }
}

/// The SI unit symbol of a dimension (as the unit parser spells it).
pub fn si_unit(dim: Dimension) -> &'static str {
    dim.units()
        .iter()
        .copied()
        .find(|u| si_per_unit(u) == 1.0)
        .expect("every dimension has its SI unit")
}

fn finite(x: f64) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{x} is not a finite number"))
    }
}

/// A finite number from a TOML number. Text is refused, also when it reads as a number
/// (`particles = "300"` in a study file is a mistake worth naming; the command line turns
/// numeric text into numbers before it gets here).
fn number(value: &toml::Value) -> Result<f64, String> {
    let x = match value {
        toml::Value::Float(x) => *x,
        toml::Value::Integer(i) => *i as f64,
        toml::Value::String(s) if s.trim().parse::<f64>().is_ok() => {
            return Err(format!(
                "'{s}' is text, not a number (write it without quotes)"
            ))
        }
        toml::Value::String(s) => return Err(format!("'{s}' is not a number")),
        other => return Err(format!("{other} is not a number")),
    };
    finite(x)
}

/// A parameter of a model `M` whose parameters are a `P`: its spec and how to read and write
/// it. Both functions see the typed struct; `set` receives a value already parsed and
/// range-checked by the spec.
pub struct Param<M: ?Sized, P> {
    /// Name, kind, range and doc.
    pub spec: ParamSpec,
    /// The current value (None: derived by the model from other parameters).
    pub get: fn(&P) -> Option<Value>,
    /// Stores a value; the error is the bare reason (e.g. an unknown material).
    pub set: fn(&M, &mut P, &Value) -> Result<(), String>,
}

/// A choice parameter's value from its name: the names and the values are one table.
pub fn choose<T: Copy>(table: &[(&str, T)], value: &Value) -> Result<T, String> {
    table
        .iter()
        .find(|(n, _)| *n == value.as_text())
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            format!("'{}' is not one of {}", value.as_text(), names.join(", "))
        })
}

/// The name of a choice parameter's value.
pub fn choice_name<T: PartialEq>(table: &[(&'static str, T)], value: &T) -> Option<Value> {
    table
        .iter()
        .find(|(_, t)| t == value)
        .map(|(n, _)| Value::Text((*n).to_string()))
}

/// Declares a [`Param`] stored in a plain numeric field (f64, or usize for counts):
/// `number_param!(spec, params.field)`.
#[macro_export]
macro_rules! number_param {
    ($spec:expr, $($field:ident).+) => {
        $crate::study::param::Param {
            spec: $spec,
            get: |p| Some($crate::study::param::Value::Number(p.$($field).+ as f64)),
            set: |_, p, v| {
                p.$($field).+ = v.as_number() as _;
                Ok(())
            },
        }
    };
}

/// Declares a [`Param`] stored in an `Option` numeric field (None: derived by the model).
#[macro_export]
macro_rules! optional_param {
    ($spec:expr, $($field:ident).+) => {
        $crate::study::param::Param {
            spec: $spec,
            get: |p| p.$($field).+.map(|x| $crate::study::param::Value::Number(x as f64)),
            set: |_, p, v| {
                p.$($field).+ = Some(v.as_number() as _);
                Ok(())
            },
        }
    };
}

/// Declares a choice [`Param`] from one table of (name, value) pairs:
/// `choice_param!("drag", "doc", params.drag, [("chow", DragLaw::Chow), …])`.
#[macro_export]
macro_rules! choice_param {
    ($name:literal $(aliases $aliases:expr)?, $doc:literal, $($field:ident).+, [$(($key:literal, $value:expr)),+ $(,)?]) => {
        $crate::study::param::Param {
            spec: $crate::study::param::ParamSpec::new(
                $name,
                $crate::study::param::ParamKind::Choice(&[$($key),+]),
                $doc,
            )$(.aliases($aliases))?,
            get: |p| $crate::study::param::choice_name(&[$(($key, $value)),+], &p.$($field).+),
            set: |_, p, v| {
                p.$($field).+ = $crate::study::param::choose(&[$(($key, $value)),+], v)?;
                Ok(())
            },
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_literals_parse_back_exactly() {
        let specs = [
            ParamSpec::quantity("field", Dimension::MagneticField, "kOe", ""),
            ParamSpec::quantity("pressure", Dimension::Pressure, "atm", ""),
            ParamSpec::quantity("diameter", Dimension::Length, "um", ""),
            ParamSpec::new("particles", ParamKind::Count, ""),
            ParamSpec::new("friction", ParamKind::Number, ""),
            ParamSpec::new("material", ParamKind::Name, ""),
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

    #[test]
    fn user_text_parses_back() {
        let field = ParamSpec::quantity("field", Dimension::MagneticField, "kOe", "");
        let v = field.parse(&toml::Value::String("40kOe".into())).unwrap();
        assert_eq!(field.user_text(&v), "40 kOe");
        let back = field
            .parse(&toml::Value::String(field.user_text(&v)))
            .unwrap();
        assert!((back.as_number() / v.as_number() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn range_messages_name_value_and_range_in_the_display_unit() {
        let field = ParamSpec::quantity("field", Dimension::MagneticField, "kOe", "")
            .within(Bounds::NON_NEGATIVE);
        let e = field
            .parse(&toml::Value::String("-3kOe".into()))
            .unwrap_err();
        assert_eq!(e, "-3 kOe is not allowed (need ≥ 0 kOe)");
        let target = ParamSpec::new("target", ParamKind::Number, "").within(Bounds::UNIT_OPEN);
        assert_eq!(
            target.parse(&toml::Value::Float(1.0)).unwrap_err(),
            "1 is not allowed (need in (0, 1))"
        );
        let e = field
            .parse(&toml::Value::String("1e-320 A/m".into()))
            .unwrap_err();
        assert!(e.contains("not a normal"), "{e}");
        let wrong = field.parse(&toml::Value::String("40m".into())).unwrap_err();
        assert!(
            wrong.contains("unknown unit 'm' for a magnetic field"),
            "{wrong}"
        );
    }

    #[test]
    fn multiples_take_a_bare_number_or_a_length() {
        let cutoff = ParamSpec::new("cutoff", ParamKind::Multiple { of: "D1" }, "");
        assert_eq!(
            cutoff.parse(&toml::Value::Float(7.13)).unwrap(),
            Value::Number(7.13)
        );
        assert_eq!(
            cutoff.parse(&toml::Value::String("43mm".into())).unwrap(),
            Value::Text(format!("{:?} m", 43.0 * 1e-3))
        );
        assert!(cutoff.parse(&toml::Value::String("43 s".into())).is_err());
    }

    #[test]
    fn choices_list_the_allowed_names() {
        let table = [("dem", 1), ("ensemble", 2)];
        assert_eq!(choose(&table, &Value::Text("ensemble".into())), Ok(2));
        assert_eq!(
            choose(&table, &Value::Text("abc".into())).unwrap_err(),
            "'abc' is not one of dem, ensemble"
        );
    }
}
