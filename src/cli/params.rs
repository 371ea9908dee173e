//! Command-line flags made from a model's parameter declarations: one `--flag` per parameter,
//! its help text and default printed from the declaration and the model's defaults (never
//! copied by hand), and the values given turned into the same parsed values a study file gives.

use clap::{Arg, ArgMatches};

use crate::study::model::{ParamKind, ParamSpec, StudyModel};
use crate::study::spec::Base;
use crate::{Error, Result};

/// The flag of a parameter name (`max_time` → `max-time`).
pub fn flag(name: &str) -> String {
    name.replace('_', "-")
}

/// What a bare value means and which units it takes, for the help text.
fn units_note(spec: &ParamSpec) -> String {
    match spec.kind {
        ParamKind::Quantity { dim, unit } => {
            format!(" ({}; bare number: {unit})", dim.units().join(", "))
        }
        ParamKind::Multiple { of } => {
            format!(" (in units of {of}, or a length with its unit, e.g. 43mm)")
        }
        ParamKind::Choice(options) => format!(" (one of: {})", options.join(", ")),
        ParamKind::Count => " (a whole number)".into(),
        ParamKind::Number | ParamKind::Name => String::new(),
    }
}

/// The default shown in the help: the model's own value, in the display unit.
pub fn default_text<M: StudyModel>(model: &M, name: &str) -> Result<String> {
    let param = model.param(name)?;
    Ok(match (param.get)(&model.defaults()) {
        Some(value) => param.spec.user_text(&value),
        None => param.spec.derived.to_string(),
    })
}

/// The help line of a parameter: doc, units, range, default.
fn help<M: StudyModel>(model: &M, spec: &ParamSpec) -> String {
    let range = match spec.bounds {
        b if b == crate::study::param::Bounds::ANY => String::new(),
        b => format!("; allowed: {}", b.describe(spec.unit())),
    };
    let also = if spec.aliases.is_empty() {
        String::new()
    } else {
        let old: Vec<String> = spec
            .aliases
            .iter()
            .map(|a| format!("--{}", flag(a)))
            .collect();
        format!(" (also: {})", old.join(", "))
    };
    let default = default_text(model, spec.name).unwrap_or_default();
    format!(
        "{}{}{range}{also} [default: {default}]",
        spec.doc,
        units_note(spec)
    )
}

/// One flag per parameter of `model`, except those in `skip`, and one hidden flag per older
/// name (its own argument, so that a message can name the flag that was typed).
pub fn flags<M: StudyModel>(model: &M, skip: &[&str]) -> Vec<Arg> {
    let mut args = Vec::new();
    for spec in model.parameters().iter().map(|p| &p.spec) {
        if skip.contains(&spec.name) {
            continue;
        }
        args.push(
            Arg::new(spec.name)
                .long(flag(spec.name))
                .allow_hyphen_values(true)
                .value_name(value_name(spec))
                .help(help(model, spec))
                .help_heading("Model parameters"),
        );
        for alias in spec.aliases {
            args.push(
                Arg::new(alias_id(spec.name, alias))
                    .long(flag(alias))
                    .allow_hyphen_values(true)
                    .value_name(value_name(spec))
                    .hide(true),
            );
        }
    }
    args
}

/// The argument id of an older name of a parameter.
fn alias_id(name: &str, alias: &str) -> String {
    format!("{name}|{alias}")
}

fn value_name(spec: &ParamSpec) -> &'static str {
    match spec.kind {
        ParamKind::Quantity { .. } | ParamKind::Multiple { .. } => "QUANTITY",
        ParamKind::Count => "N",
        ParamKind::Number => "X",
        ParamKind::Choice(_) => "CHOICE",
        ParamKind::Name => "TEXT",
    }
}

/// A command-line text as the TOML value a study file would hold: numbers as numbers where
/// the kind takes numbers, everything else as a string.
pub fn toml_of(spec: &ParamSpec, text: &str) -> toml::Value {
    let numeric = matches!(
        spec.kind,
        ParamKind::Number | ParamKind::Count | ParamKind::Multiple { .. }
    );
    match text.trim().parse::<f64>() {
        Ok(x) if numeric => toml::Value::Float(x),
        _ => toml::Value::String(text.to_string()),
    }
}

/// A value given on the command line: the parameter, the flag typed, the text.
#[derive(Debug, Clone)]
pub struct Given {
    /// Parameter name.
    pub name: &'static str,
    /// The flag as typed (`--velocity` for `piston_speed`).
    pub flag: String,
    /// The text after it.
    pub text: String,
}

impl Given {
    /// A value under the parameter's own flag.
    pub fn new(name: &'static str, text: impl Into<String>) -> Self {
        Self {
            name,
            flag: format!("--{}", flag(name)),
            text: text.into(),
        }
    }
}

/// The parameters given on the command line, in declaration order; a parameter given under
/// two of its names is an error.
pub fn given<M: StudyModel>(model: &M, matches: &ArgMatches) -> Result<Vec<Given>> {
    let text = |id: &str| matches.try_get_one::<String>(id).ok().flatten().cloned();
    let mut given = Vec::new();
    for spec in model.parameters().iter().map(|p| &p.spec) {
        let names = std::iter::once((spec.name.to_string(), spec.name))
            .chain(spec.aliases.iter().map(|a| (alias_id(spec.name, a), *a)));
        let typed: Vec<Given> = names
            .filter_map(|(id, name)| {
                text(&id).map(|text| Given {
                    name: spec.name,
                    flag: format!("--{}", flag(name)),
                    text,
                })
            })
            .collect();
        if typed.len() > 1 {
            return Err(Error::input(format!(
                "{} and {}: the same parameter given twice",
                typed[0].flag, typed[1].flag
            )));
        }
        given.extend(typed);
    }
    Ok(given)
}

/// The model's defaults with the given values set (each parsed, range-checked and named by its
/// flag on error), then checked as a whole. Returns the parameters and the parsed values in
/// name order (the base of the one-point study that runs them).
pub fn setup<M: StudyModel>(model: &M, given: &[Given]) -> Result<Base<M::Params>> {
    let mut params = model.defaults();
    let mut values = Vec::new();
    for g in given {
        let raw = toml_of(model.spec(g.name)?, &g.text);
        let value = model.set_from(&mut params, g.name, &raw, &g.flag)?;
        values.push((g.name.to_string(), value));
    }
    model
        .check(&params)
        .map_err(|e| Error::input(format!("invalid parameters: {e}")))?;
    values.sort_by(|a, b| a.0.cmp(&b.0));
    Ok((params, values))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;
    use crate::models::align::study::AlignModel;
    use crate::models::bed::study::BedModel;
    use crate::models::blast::study::BlastModel;
    use crate::study::model::Value;

    /// The `[default: …]` of every flag's help, read back through the parameter's own parser,
    /// is the model's default (derived defaults print the declared description).
    fn help_defaults_are_the_model_defaults<M: StudyModel>(model: &M) {
        let defaults = model.defaults();
        let args = flags(model, &[]);
        let shown_args = args.iter().filter(|a| !a.is_hide_set());
        for (param, arg) in model.parameters().iter().zip(shown_args) {
            let help = arg.get_help().expect("every flag has help").to_string();
            let shown = help
                .rsplit_once("[default: ")
                .and_then(|(_, d)| d.strip_suffix(']'))
                .unwrap_or_else(|| panic!("{}: no default in '{help}'", param.spec.name));
            match (param.get)(&defaults) {
                None => assert_eq!(shown, param.spec.derived, "{}", param.spec.name),
                Some(Value::Text(t)) => assert_eq!(shown, t, "{}", param.spec.name),
                Some(Value::Number(x)) => {
                    let back = param
                        .spec
                        .parse(&toml_of(&param.spec, shown))
                        .unwrap_or_else(|e| panic!("{}: '{shown}': {e}", param.spec.name))
                        .as_number();
                    assert!(
                        back == x || (back - x).abs() <= 1e-12 * x.abs(),
                        "{}: help says {shown} = {back}, the model's default is {x}",
                        param.spec.name
                    );
                }
            }
        }
    }

    #[test]
    fn every_help_default_is_the_model_default() {
        help_defaults_are_the_model_defaults(&AlignModel::new(MaterialDb::builtin()));
        help_defaults_are_the_model_defaults(&BedModel::cycle());
        help_defaults_are_the_model_defaults(&BedModel::damper());
        help_defaults_are_the_model_defaults(&BlastModel);
    }

    #[test]
    fn dimensional_flags_take_units_and_refuse_other_dimensions() {
        let align = AlignModel::new(MaterialDb::builtin());
        let ok = [
            ("damping", "20N*s/m"),
            ("rotation_step", "0.05rad"),
            ("rotation_step", "2 deg"),
            ("field", "3.2T"),
        ];
        for (name, text) in ok {
            setup(&align, &[Given::new(name, text)]).unwrap();
        }
        setup(&BedModel::cycle(), &[Given::new("cutoff", "43mm")]).unwrap();
        let e = setup(&align, &[Given::new("field", "40m")]).unwrap_err();
        assert!(
            e.to_string().starts_with("--field: '40m': unknown unit"),
            "{e}"
        );
    }

    #[test]
    fn unknown_choices_list_the_allowed_values() {
        let e = setup(&BlastModel, &[Given::new("drag", "abc")]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--drag: 'abc' is not one of quadratic, chow, stokes, none"
        );
        let e = setup(&BlastModel, &[Given::new("interactions", "abc")]).unwrap_err();
        assert!(e.to_string().starts_with("--interactions: "), "{e}");
    }
}
