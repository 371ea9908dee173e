//! Study files (TOML, spec studies.md): model, base parameters with units, swept parameters
//! (lists, linear or logarithmic ranges), replicates and master seed, metrics, and optionally
//! free parameters with bounds for optimization. Unknown keys are errors.
//!
//! ```toml
//! name = "tau-vs-field"
//! model = "align"
//! replicates = 4
//! seed = 1
//! metrics = ["alignment_time_s", "alignment_time_90_s"]
//! [base]
//! pressure = "0.5atm"
//! [sweep]
//! field = { log = ["5kOe", "100kOe", 8] }
//! friction = [0.0, 0.2, 0.5]
//! [optimize]                       # for `magopt optimize`
//! parameters = { field = ["5kOe", "100kOe"] }
//! metric = "alignment_time_s"
//! goal = "minimize"
//! ```

use serde::Deserialize;

use super::design_spec::{Design, DesignKind};
use super::domain::{self, DesignAxis};
use super::model::{ParamKind, ParamSpec, Schedule, StudyModel, Value};
use crate::output::snapshots::Format;
use crate::{Error, Result};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStudy {
    name: Option<String>,
    model: String,
    replicates: Option<i64>,
    seed: Option<i64>,
    metrics: Option<Vec<String>>,
    base: Option<toml::Table>,
    sweep: Option<toml::Table>,
    optimize: Option<RawOptimize>,
    snapshots: Option<RawSnapshots>,
    design: Option<RawDesign>,
    objectives: Option<super::objectives::RawObjectives>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDesign {
    method: String,
    samples: i64,
    levels: Option<i64>,
    bootstrap: Option<i64>,
    parameters: toml::Table,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSnapshots {
    every: Option<i64>,
    times: Option<Vec<String>>,
    formats: Option<Vec<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOptimize {
    metric: String,
    goal: Option<String>,
    parameters: toml::Table,
    scale: Option<String>,
    scan_points: Option<i64>,
    iterations: Option<i64>,
    band: Option<f64>,
    method: Option<String>,
    budget: Option<i64>,
    batch: Option<i64>,
    initial: Option<i64>,
    tolerance: Option<f64>,
    transform: Option<String>,
}

/// One swept parameter and its values (SI).
#[derive(Debug, Clone)]
pub struct Axis {
    /// The parameter.
    pub spec: &'static ParamSpec,
    /// Its values in sweep order.
    pub values: Vec<Value>,
    /// Whether the values were given as a log range (plots use a log axis).
    pub log: bool,
}

/// The `[optimize]` table.
#[derive(Debug, Clone)]
pub struct OptimizeSpec {
    /// Metric to optimize.
    pub metric: String,
    /// Maximize instead of minimize.
    pub maximize: bool,
    /// Free parameters with SI bounds.
    pub free: Vec<(&'static ParamSpec, f64, f64)>,
    /// Search in ln x (all bounds > 0) instead of x.
    pub log: bool,
    /// Scan points of the 1D bracket search.
    pub scan_points: usize,
    /// Brent (1D) or Nelder–Mead (several parameters) iterations.
    pub iterations: u64,
    /// Near-optimal band fraction.
    pub band: f64,
    /// The search method (`method = "brent" | "nelder-mead" | "bayes"`).
    pub method: OptimizeMethod,
}

/// How `magopt optimize` searches.
#[derive(Debug, Clone, PartialEq)]
pub enum OptimizeMethod {
    /// Log/linear scan + Brent (one parameter; the default for one).
    Brent,
    /// Nelder–Mead in the unit cube of the scaled bounds (the default for several).
    NelderMead,
    /// Bayesian optimization ([`crate::study::bayes`]).
    Bayes(BayesSpec),
}

impl OptimizeMethod {
    /// The name in study files.
    pub fn name(&self) -> &'static str {
        match self {
            OptimizeMethod::Brent => "brent",
            OptimizeMethod::NelderMead => "nelder-mead",
            OptimizeMethod::Bayes(_) => "bayes",
        }
    }
}

/// The keys of `method = "bayes"`.
#[derive(Debug, Clone, PartialEq)]
pub struct BayesSpec {
    /// Most evaluated points (initial design included).
    pub budget: usize,
    /// Points proposed (and run in parallel) per round.
    pub batch: usize,
    /// Points of the initial Latin-hypercube design.
    pub initial: usize,
    /// Stop when the best expected improvement is below this × the observed spread.
    pub tolerance: f64,
    /// Whether the surrogate models ln of the metric's replicate mean (a positive metric).
    pub log_metric: bool,
}

/// Most evaluated points of a Bayesian optimization (the surrogate costs O(n³) per fit).
pub const MAX_BAYES_BUDGET: usize = 500;

/// A parsed, validated study for model `M`.
#[derive(Debug, Clone)]
pub struct Study<M: StudyModel> {
    /// Study name (file stem if absent).
    pub name: String,
    /// Replicate seeds per point: seed, seed + 1, …
    pub replicates: usize,
    /// Master seed.
    pub seed: u64,
    /// Metrics recorded in tables.
    pub metrics: Vec<String>,
    /// Base parameters (defaults with `[base]` applied).
    pub base: M::Params,
    /// `[base]` as parsed values, in canonical (sorted) order: part of every run id.
    pub base_values: Vec<(String, Value)>,
    /// Swept parameters.
    pub axes: Vec<Axis>,
    /// The optimization, if any.
    pub optimize: Option<OptimizeSpec>,
    /// The `[design]` table, if the points come from a design instead of a grid.
    pub design: Option<Design>,
    /// The `[objectives]` table (multi-objective optimization by `magopt optimize`), if any.
    pub objectives: Option<super::objectives::ObjectivesSpec>,
    /// The `[snapshots]` table: every run writes its particle frames (its model's own moments
    /// and these) into `runs/<id>/snapshots/`.
    pub snapshots: Option<Schedule>,
    /// The file's text (copied into results).
    pub text: String,
}

/// One run of a study: a grid point and a replicate.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunSpec {
    /// Position in the run list.
    pub index: usize,
    /// Identifier derived from model, base, point values and seed (FNV-1a, hex).
    pub id: String,
    /// Grid point index.
    pub point: usize,
    /// Replicate index.
    pub replicate: usize,
    /// Seed of this run.
    pub seed: u64,
    /// Values of the swept parameters at this point.
    pub values: Vec<Value>,
    /// Everything the run depends on besides seed and code (the model's resolved parameters,
    /// materials and species included), as text.
    #[serde(default)]
    pub inputs: String,
}

/// The model a study file names (read before the model-specific parse).
pub fn model_name(text: &str, origin: &str) -> Result<String> {
    Ok(raw(text, origin)?.model)
}

fn raw(text: &str, origin: &str) -> Result<RawStudy> {
    toml::from_str(text)
        .map_err(|e| Error::input(format!("{origin}: {}", one_line(&e.to_string()))))
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl<M: StudyModel> Study<M> {
    /// Parses and validates a study file's text for model `M`; `origin` names it in errors.
    pub fn parse(model: &M, text: &str, origin: &str) -> Result<Self> {
        let at = |e: Error| Error::input(format!("{origin}: {e}"));
        let raw = raw(text, origin)?;
        if raw.model != model.name() {
            return Err(at(Error::input(format!(
                "model: '{}' is not '{}'",
                raw.model,
                model.name()
            ))));
        }
        let replicates = positive("replicates", raw.replicates.unwrap_or(1)).map_err(at)?;
        let seed = u64::try_from(raw.seed.unwrap_or(1)).map_err(|_| {
            at(Error::input(format!(
                "seed: {} is not allowed (need ≥ 0)",
                raw.seed.unwrap_or(1)
            )))
        })?;
        let metrics = metrics(model, raw.metrics).map_err(at)?;
        let (base, base_values) = base(model, raw.base.unwrap_or_default()).map_err(at)?;
        let axes = axes(model, raw.sweep.unwrap_or_default()).map_err(at)?;
        let optimize = raw
            .optimize
            .map(|o| optimize(model, o))
            .transpose()
            .map_err(at)?;
        let snapshots = raw.snapshots.map(snapshots).transpose().map_err(at)?;
        let objectives = raw
            .objectives
            .map(|o| super::objectives::parse(model, o))
            .transpose()
            .map_err(at)?;
        let design = match raw.design {
            Some(_) if !axes.is_empty() => {
                return Err(at(Error::input(
                    "design: a study has either [sweep] (a grid) or [design], not both",
                )));
            }
            Some(d) => Some(design(model, d, seed).map_err(at)?),
            None => None,
        };
        let axes = match &design {
            Some(d) => d.axes(),
            None => axes,
        };
        let name = match raw.name {
            Some(name) => plain_name(&name).map_err(at)?,
            None => std::path::Path::new(origin)
                .file_stem()
                .map_or("study".into(), |s| s.to_string_lossy().into_owned()),
        };
        if let Some(axis) = axes
            .iter()
            .find(|a| base_values.iter().any(|(k, _)| k == a.spec.name))
        {
            return Err(at(Error::input(format!(
                "sweep.{0}: {0} is also set in [base] (set it in one place)",
                axis.spec.name
            ))));
        }
        if let Some(free) = optimize.as_ref().and_then(|o| {
            o.free
                .iter()
                .find(|(s, ..)| design.is_some() && axes.iter().any(|a| a.spec.name == s.name))
        }) {
            return Err(at(Error::input(format!(
                "optimize.parameters.{0}: {0} is also a design parameter (the optimization is \
                 run at every design point: free it in one place)",
                free.0.name
            ))));
        }
        let study = Self {
            name,
            replicates,
            seed,
            metrics,
            base,
            base_values,
            axes,
            optimize,
            design,
            objectives,
            snapshots,
            text: text.to_string(),
        };
        let points = match &study.design {
            Some(d) => Some(d.points.len()),
            None => study
                .axes
                .iter()
                .try_fold(1usize, |n, a| n.checked_mul(a.values.len())),
        }
        .and_then(|n| n.checked_mul(study.replicates))
        .filter(|&n| n <= MAX_RUNS);
        if points.is_none() {
            return Err(at(Error::input(format!(
                "the grid × replicates has more than {MAX_RUNS} runs (split the study)"
            ))));
        }
        study.runs(model).map_err(at)?;
        Ok(study)
    }

    /// A study made from values given elsewhere (the command line): no sweep, optionally one
    /// free parameter. Its text is written first and parsed back, so the saved study.toml is
    /// exactly what ran and `magopt sweep`/`optimize` on it repeat the run. `origin` says in a
    /// comment where it came from.
    #[allow(clippy::too_many_arguments)]
    pub fn one_point(
        model: &M,
        values: &[(String, Value)],
        replicates: usize,
        seed: u64,
        optimize: Option<&OptimizeSpec>,
        snapshots: Option<&Schedule>,
        name: &str,
        origin: &str,
    ) -> Result<Self> {
        if i64::try_from(seed).is_err() {
            return Err(Error::input(format!(
                "seed: {seed} is not allowed (need 0..={})",
                i64::MAX
            )));
        }
        let is_free = |k: &str| optimize.is_some_and(|o| o.free.iter().any(|(s, ..)| s.name == k));
        let mut text = format!(
            "# written by `{}`\nname = \"{name}\"\nmodel = \"{}\"\nreplicates = {replicates}\n\
             seed = {seed}\n\n[base]\n",
            origin.replace('`', "'").replace('\n', " "),
            model.name()
        );
        for (k, v) in values.iter().filter(|(k, _)| !is_free(k)) {
            text += &format!("{k} = {}\n", model.spec(k)?.toml_literal(v));
        }
        if let Some(o) = optimize {
            let (spec, lo, hi) = o.free[0];
            text += &format!(
                "\n[optimize]\nparameters = {{ {} = [{}, {}] }}\nmetric = {:?}\nscan_points = {}\n\
                 iterations = {}\nband = {}\n",
                spec.name,
                spec.toml_literal(&Value::Number(lo)),
                spec.toml_literal(&Value::Number(hi)),
                o.metric,
                o.scan_points,
                o.iterations,
                o.band
            );
        }
        if let Some(schedule) = snapshots {
            text += &snapshots_toml(schedule);
        }
        Self::parse(model, &text, name)
    }

    /// Every point: the design's, or the grid's (cartesian product of the axes, the last axis
    /// fastest).
    pub fn points(&self) -> Vec<Vec<Value>> {
        if let Some(d) = &self.design {
            return d.points.clone();
        }
        self.axes.iter().fold(vec![Vec::new()], |acc, axis| {
            acc.iter()
                .flat_map(|prefix| {
                    axis.values
                        .iter()
                        .map(move |v| [prefix.clone(), vec![v.clone()]].concat())
                })
                .collect()
        })
    }

    /// The study without its grid or design, from `base` (a point's parameters): what an
    /// optimization at that point runs.
    pub fn at(&self, base: M::Params) -> Study<M> {
        Study {
            name: self.name.clone(),
            replicates: self.replicates,
            seed: self.seed,
            metrics: self.metrics.clone(),
            base,
            base_values: self.base_values.clone(),
            axes: Vec::new(),
            optimize: self.optimize.clone(),
            design: None,
            objectives: self.objectives.clone(),
            snapshots: self.snapshots.clone(),
            text: self.text.clone(),
        }
    }

    /// The study as `magopt optimize` runs it: without the grid axes of its free parameters
    /// (their values serve `magopt sweep` on the same file), so that the optimization runs at
    /// every point of the remaining axes (none: once, from the base).
    pub fn for_optimize(&self) -> Study<M> {
        let free = |name: &str| {
            self.optimize
                .as_ref()
                .is_some_and(|o| o.free.iter().any(|(s, ..)| s.name == name))
        };
        let mut study = self.at(self.base.clone());
        study.design = self.design.clone();
        study.axes = self
            .axes
            .iter()
            .filter(|a| self.design.is_some() || !free(a.spec.name))
            .cloned()
            .collect();
        study
    }

    /// Parameters at a grid point (checked).
    pub fn params_at(&self, model: &M, point: &[Value]) -> Result<M::Params> {
        let mut params = self.base.clone();
        for (axis, value) in self.axes.iter().zip(point) {
            let name = axis.spec.name;
            model.set(&mut params, name, value, &format!("sweep.{name}"))?;
        }
        model.check(&params).map_err(|e| {
            let at: Vec<String> = self
                .axes
                .iter()
                .zip(point)
                .map(|(a, v)| format!("{} = {}", a.spec.name, a.spec.user_text(v)))
                .collect();
            if at.is_empty() {
                e
            } else {
                Error::input(format!("at {}: {e}", at.join(", ")))
            }
        })?;
        Ok(params)
    }

    /// The run list: points × replicates, deterministic; replicate r has seed `seed + r` at
    /// every point (common random numbers). Each run's id covers everything it depends on (its
    /// resolved inputs, the code fingerprint, the seed); two points that resolve to the same
    /// inputs are an error.
    pub fn runs(&self, model: &M) -> Result<Vec<RunSpec>> {
        let points = self.points();
        let mut runs: Vec<RunSpec> = Vec::with_capacity(points.len() * self.replicates);
        let mut seen = std::collections::HashMap::new();
        for (p, values) in points.into_iter().enumerate() {
            let params = self.params_at(model, &values)?;
            let mut inputs = model.inputs(&params);
            if let Some(schedule) = &self.snapshots {
                model.check_schedule(&params, schedule)?;
                inputs += &format!(" snapshots: {schedule:?}");
            }
            if self.design.is_some() {
                // A design may draw the same values twice (levels, Saltelli's A and AB_i):
                // the k-th repeat is its own run.
                let base = inputs.clone();
                let mut k = 0;
                while seen.contains_key(&inputs) {
                    k += 1;
                    inputs = format!("{base} design repeat: {k}");
                }
            }
            if let Some(q) = seen.insert(inputs.clone(), p) {
                return Err(Error::input(format!(
                    "{}: grid points {q} and {p} are the same run (their values are equal after \
                     unit conversion): list each value once",
                    self.name
                )));
            }
            for r in 0..self.replicates {
                let seed = self.seed.wrapping_add(r as u64);
                runs.push(RunSpec {
                    index: runs.len(),
                    id: run_id(model, &inputs, seed),
                    point: p,
                    replicate: r,
                    seed,
                    values: values.clone(),
                    inputs: inputs.clone(),
                });
            }
        }
        Ok(runs)
    }
}

/// The id of a run: FNV-1a over the model, the seed, its code fingerprint and the run's
/// resolved inputs.
pub fn run_id<M: StudyModel>(model: &M, inputs: &str, seed: u64) -> String {
    let text = format!(
        "{}|seed={seed}|code={}|{inputs}",
        model.name(),
        model.code()
    );
    format!("{:016x}", fnv1a(&text))
}

/// FNV-1a, 64 bits: a stable hash of `text` (the same on every machine and build).
pub fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf29ce484222325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

/// The `[design]` table: method, samples and the parameters' domains; the points are drawn
/// from the study seed.
fn design<M: StudyModel>(model: &M, raw: RawDesign, seed: u64) -> Result<Design> {
    let fail = |e: String| Error::input(format!("design.{e}"));
    let mut axes: Vec<DesignAxis> = Vec::new();
    for (key, domain) in &raw.parameters {
        let spec = spec_of(model, "design.parameters", key)?;
        if axes.iter().any(|a| a.spec.name == spec.name) {
            return Err(fail(format!(
                "parameters.{key}: {} is given twice",
                spec.name
            )));
        }
        axes.push(domain::parse(spec, domain).map_err(|e| fail(format!("parameters.{e}")))?);
    }
    if axes.is_empty() {
        return Err(fail(
            "parameters: name at least one parameter with its domain".into(),
        ));
    }
    let kind =
        DesignKind::parse(&raw.method, raw.levels).map_err(|e| fail(format!("method: {e}")))?;
    let minimum = kind.minimum_samples();
    let samples = usize::try_from(raw.samples)
        .ok()
        .filter(|n| (minimum..=MAX_RUNS).contains(n))
        .ok_or_else(|| {
            fail(format!(
                "samples: {} is not allowed (need {minimum}..={MAX_RUNS} for {} with {} parameters)",
                raw.samples,
                raw.method,
                axes.len()
            ))
        })?;
    let bootstrap = match raw.bootstrap {
        None => 1000,
        Some(b) => usize::try_from(b)
            .ok()
            .filter(|b| *b <= 100_000)
            .ok_or_else(|| fail(format!("bootstrap: {b} is not allowed (need 0..=100000)")))?,
    };
    let unit = kind
        .unit_points(samples, axes.len(), seed)
        .map_err(|e| fail(format!("method: {e}")))?;
    if unit.len() > MAX_RUNS {
        return Err(fail(format!(
            "samples: {samples} gives {} runs per replicate (limit {MAX_RUNS})",
            unit.len()
        )));
    }
    let points = unit
        .iter()
        .map(|u| axes.iter().zip(u).map(|(a, x)| a.value(*x)).collect())
        .collect();
    Ok(Design {
        kind,
        samples,
        bootstrap,
        axes,
        unit,
        points,
    })
}

/// The `[snapshots]` table: `every` (steps ≥ 1), `times` (quantities), `formats` (xyz, dump,
/// vtk, parquet; all four if absent).
fn snapshots(raw: RawSnapshots) -> Result<Schedule> {
    let every = match raw.every {
        Some(k) if k >= 1 => Some(k as u64),
        Some(k) => {
            return Err(Error::input(format!(
                "snapshots.every: {k} is not allowed (need a step count ≥ 1)"
            )))
        }
        None => None,
    };
    let times = match raw.times {
        Some(list) => Schedule::parse_times(&list.join(","))
            .map_err(|e| Error::input(format!("snapshots.times: {e}")))?,
        None => Vec::new(),
    };
    let formats = match raw.formats {
        Some(list) if list.is_empty() => return Err(Error::input(
            "snapshots.formats: [] is not allowed (need one or more of xyz, dump, vtk, parquet)",
        )),
        Some(list) => Format::parse_list(&list.join(","))
            .map_err(|e| Error::input(format!("snapshots.formats: {e}")))?,
        None => Format::ALL.to_vec(),
    };
    Ok(Schedule {
        every,
        times,
        formats,
    })
}

/// A schedule as a `[snapshots]` table that [`snapshots`] reads back exactly.
fn snapshots_toml(schedule: &Schedule) -> String {
    let mut text = String::from("\n[snapshots]\n");
    if let Some(k) = schedule.every {
        text += &format!("every = {k}\n");
    }
    if !schedule.times.is_empty() {
        let times: Vec<String> = schedule
            .times
            .iter()
            .map(|t| format!("\"{t:?} s\""))
            .collect();
        text += &format!("times = [{}]\n", times.join(", "));
    }
    let formats: Vec<String> = schedule
        .formats
        .iter()
        .map(|f| format!("\"{}\"", f.extension()))
        .collect();
    text += &format!("formats = [{}]\n", formats.join(", "));
    text
}

/// Most runs one study may hold (grid points × replicates).
pub const MAX_RUNS: usize = 1_000_000;

/// Most replicates, scan points or iterations a study may ask for.
const MAX_REPEATS: i64 = 100_000;

fn positive(key: &str, n: i64) -> Result<usize> {
    if (1..=MAX_REPEATS).contains(&n) {
        Ok(n as usize)
    } else {
        Err(Error::input(format!(
            "{key}: {n} is not allowed (need 1..={MAX_REPEATS})"
        )))
    }
}

/// A study name that is a plain name, never a path (it names the default result directory).
fn plain_name(name: &str) -> Result<String> {
    let ok = !name.is_empty()
        && name != "."
        && name != ".."
        && name
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | '.' | '+'));
    if ok {
        Ok(name.to_string())
    } else {
        Err(Error::input(format!(
            "name: '{}' is not allowed (need a plain name of letters, digits, '-', '_', '.', \
             '+'; no paths)",
            name.escape_debug()
        )))
    }
}

fn metrics<M: StudyModel>(model: &M, wanted: Option<Vec<String>>) -> Result<Vec<String>> {
    let known = model.metrics();
    let Some(wanted) = wanted else {
        return Ok(known.iter().map(|s| s.to_string()).collect());
    };
    if wanted.is_empty() {
        return Err(Error::input(
            "metrics: the list is empty (name at least one, or leave the key out for all)",
        ));
    }
    for (k, m) in wanted.iter().enumerate() {
        if !known.contains(&m.as_str()) {
            return Err(Error::input(format!(
                "metrics: unknown metric '{m}' (known: {})",
                known.join(", ")
            )));
        }
        if wanted[..k].contains(m) {
            return Err(Error::input(format!("metrics: '{m}' is listed twice")));
        }
    }
    Ok(wanted)
}

/// Base parameters and their parsed values.
pub type Base<P> = (P, Vec<(String, Value)>);

/// The spec of a key, or an error naming the table.
fn spec_of<M: StudyModel>(model: &M, table: &str, key: &str) -> Result<&'static ParamSpec> {
    model
        .spec(key)
        .map_err(|e| Error::input(format!("{table}.{key}: {e}")))
}

fn base<M: StudyModel>(model: &M, table: toml::Table) -> Result<Base<M::Params>> {
    let mut params = model.defaults();
    let mut values: Vec<(String, Value)> = Vec::new();
    for (key, raw) in &table {
        let name = spec_of(model, "base", key)?.name;
        if values.iter().any(|(k, _)| k == name) {
            return Err(Error::input(format!(
                "base.{key}: {name} is already set (under another of its names)"
            )));
        }
        let value = model.set_from(&mut params, name, raw, &format!("base.{key}"))?;
        values.push((name.to_string(), value));
    }
    values.sort_by(|a, b| a.0.cmp(&b.0));
    model
        .check(&params)
        .map_err(|e| Error::input(format!("base: {e}")))?;
    Ok((params, values))
}

fn axes<M: StudyModel>(model: &M, table: toml::Table) -> Result<Vec<Axis>> {
    let mut axes: Vec<Axis> = Vec::new();
    for (key, raw) in &table {
        let spec = spec_of(model, "sweep", key)?;
        if axes.iter().any(|a| a.spec.name == spec.name) {
            return Err(Error::input(format!(
                "sweep.{key}: {} is already swept (under another of its names)",
                spec.name
            )));
        }
        axes.push(axis(spec, raw).map_err(|e| Error::input(format!("sweep.{e}")))?);
    }
    Ok(axes)
}

fn axis(spec: &'static ParamSpec, raw: &toml::Value) -> Result<Axis> {
    let name = spec.name;
    let (values, log) = match raw {
        toml::Value::Array(items) => (
            items
                .iter()
                .map(|v| spec.parse(v).map_err(|r| Error::input(format!("{name}: {r}"))))
                .collect::<Result<Vec<_>>>()?,
            false,
        ),
        toml::Value::Table(t) if t.len() == 1 && (t.contains_key("range") || t.contains_key("log")) => {
            let log = t.contains_key("log");
            let bounds = t.values().next().expect("one entry");
            (range(spec, bounds, log)?, log)
        }
        other => {
            return Err(Error::input(format!(
                "{name}: {other} is not a sweep (use a list [a, b, …], {{ range = [lo, hi, n] }} or {{ log = [lo, hi, n] }})"
            )))
        }
    };
    if values.is_empty() {
        return Err(Error::input(format!("{name}: empty list of values")));
    }
    Ok(Axis { spec, values, log })
}

fn range(spec: &'static ParamSpec, bounds: &toml::Value, log: bool) -> Result<Vec<Value>> {
    let name = spec.name;
    let parts = bounds.as_array().filter(|a| a.len() == 3).ok_or_else(|| {
        Error::input(format!(
            "{name}: a range needs [low, high, count], got {bounds}"
        ))
    })?;
    let number = |v: &toml::Value| match spec
        .parse(v)
        .map_err(|r| Error::input(format!("{name}: {r}")))?
    {
        Value::Number(x) => Ok(x),
        Value::Text(t) => Err(Error::input(format!(
            "{name}: '{t}' cannot be a range bound"
        ))),
    };
    let (lo, hi) = (number(&parts[0])?, number(&parts[1])?);
    let n = parts[2]
        .as_integer()
        .filter(|&n| (1..=100_000).contains(&n))
        .ok_or_else(|| {
            Error::input(format!(
                "{name}: range count {} is not allowed (need a whole number in 1..=100000)",
                parts[2]
            ))
        })? as usize;
    if log && !(lo > 0.0 && hi > 0.0) {
        return Err(Error::input(format!(
            "{name}: a log range needs positive bounds (got {}, {})",
            spec.user_text(&Value::Number(lo)),
            spec.user_text(&Value::Number(hi))
        )));
    }
    let at = |k: usize| {
        let t = if n == 1 {
            0.0
        } else {
            k as f64 / (n - 1) as f64
        };
        let x = if log {
            (lo.ln() + t * (hi.ln() - lo.ln())).exp()
        } else {
            lo + t * (hi - lo)
        };
        if matches!(spec.kind, ParamKind::Count) {
            x.round()
        } else {
            x
        }
    };
    let mut values: Vec<f64> = (0..n).map(at).collect();
    values.dedup();
    Ok(values.into_iter().map(Value::Number).collect())
}

fn optimize<M: StudyModel>(model: &M, raw: RawOptimize) -> Result<OptimizeSpec> {
    let at = |e: Error| Error::input(format!("optimize.{e}"));
    if !model.metrics().contains(&raw.metric.as_str()) {
        return Err(at(Error::input(format!(
            "metric: unknown metric '{}' (known: {})",
            raw.metric,
            model.metrics().join(", ")
        ))));
    }
    let maximize = match raw.goal.as_deref().unwrap_or("minimize") {
        "minimize" => false,
        "maximize" => true,
        other => {
            return Err(at(Error::input(format!(
                "goal: '{other}' is not minimize or maximize"
            ))))
        }
    };
    let mut free = Vec::new();
    for (name, bounds) in &raw.parameters {
        let spec = spec_of(model, "parameters", name).map_err(at)?;
        let pair = bounds.as_array().filter(|a| a.len() == 2).ok_or_else(|| {
            at(Error::input(format!(
                "parameters.{name}: need [low, high], got {bounds}"
            )))
        })?;
        let bound = |v| match spec.parse(v) {
            Ok(Value::Number(x)) => Ok(x),
            Ok(Value::Text(t)) => Err(at(Error::input(format!(
                "parameters.{name}: '{t}' is not a number"
            )))),
            Err(r) => Err(at(Error::input(format!("parameters.{name}: {r}")))),
        };
        let (lo, hi) = (bound(&pair[0])?, bound(&pair[1])?);
        if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
            return Err(at(Error::input(format!(
                "parameters.{name}: need low < high (got {}, {})",
                spec.user_text(&Value::Number(lo)),
                spec.user_text(&Value::Number(hi))
            ))));
        }
        free.push((spec, lo, hi));
    }
    if free.is_empty() {
        return Err(at(Error::input(
            "parameters: name at least one free parameter with [low, high]",
        )));
    }
    let log = match raw.scale.as_deref().unwrap_or("log") {
        "log" => true,
        "linear" => false,
        other => {
            return Err(at(Error::input(format!(
                "scale: '{other}' is not log or linear"
            ))))
        }
    };
    if log {
        if let Some((spec, lo, hi)) = free.iter().find(|(_, lo, _)| *lo <= 0.0) {
            return Err(at(Error::input(format!(
                "parameters.{}: scale = \"log\" needs positive bounds (got {}, {}; use scale = \"linear\")",
                spec.name,
                spec.user_text(&Value::Number(*lo)),
                spec.user_text(&Value::Number(*hi))
            ))));
        }
    }
    let band = raw.band.unwrap_or(0.02);
    if !(band > 0.0 && band < 1.0) {
        return Err(at(Error::input(format!(
            "band: {band} is not allowed (need 0 < band < 1)"
        ))));
    }
    let method = optimize_method(&raw, free.len()).map_err(at)?;
    Ok(OptimizeSpec {
        metric: raw.metric,
        maximize,
        free,
        log,
        scan_points: positive("scan_points", raw.scan_points.unwrap_or(7))
            .map_err(at)?
            .max(3),
        iterations: positive("iterations", raw.iterations.unwrap_or(8)).map_err(at)? as u64,
        band,
        method,
    })
}

/// `transform`: "log" (the surrogate models ln of the replicate mean, for a positive metric)
/// or "none"; by default "log" for durations (metrics in s, such as τ_0.95, whose noise grows
/// with their size and whose values a Gaussian surrogate could otherwise extrapolate below 0),
/// "none" otherwise.
fn log_metric(raw: &RawOptimize) -> Result<bool> {
    match raw.transform.as_deref() {
        None => Ok(super::records::metric_unit(&raw.metric) == "s"),
        Some("log") => Ok(true),
        Some("none") => Ok(false),
        Some(other) => Err(Error::input(format!(
            "transform: '{other}' is not log or none"
        ))),
    }
}

/// `method` and its keys: brent (one parameter) or nelder-mead (several) by default; bayes
/// with `budget`, `batch`, `initial`, `tolerance`, `transform` (defaults from
/// [`crate::study::bayes::Settings::defaults`]). Errors name the key (without `optimize.`).
fn optimize_method(raw: &RawOptimize, dims: usize) -> Result<OptimizeMethod> {
    let default = if dims == 1 { "brent" } else { "nelder-mead" };
    let name = raw.method.as_deref().unwrap_or(default);
    let bayes_keys = [
        ("budget", raw.budget.is_some()),
        ("batch", raw.batch.is_some()),
        ("initial", raw.initial.is_some()),
        ("tolerance", raw.tolerance.is_some()),
        ("transform", raw.transform.is_some()),
    ];
    if name != "bayes" {
        if let Some((key, _)) = bayes_keys.iter().find(|(_, given)| *given) {
            return Err(Error::input(format!(
                "{key}: only used with method = \"bayes\" (method is \"{name}\")"
            )));
        }
    }
    match name {
        "brent" if dims == 1 => Ok(OptimizeMethod::Brent),
        "brent" => Err(Error::input(format!(
            "method: \"brent\" optimizes one parameter, not {dims} (use \"nelder-mead\" or \"bayes\")"
        ))),
        "nelder-mead" => Ok(OptimizeMethod::NelderMead),
        "bayes" => {
            for (key, given) in [
                ("scan_points", raw.scan_points.is_some()),
                ("iterations", raw.iterations.is_some()),
            ] {
                if given {
                    return Err(Error::input(format!(
                        "{key}: not used by method = \"bayes\" (set budget, batch, initial)"
                    )));
                }
            }
            let defaults = crate::study::bayes::Settings::defaults(dims, 0);
            let count = |key: &str, value: Option<i64>, default: usize, least: usize| match value {
                None => Ok(default),
                Some(n) => usize::try_from(n)
                    .ok()
                    .filter(|n| (least..=MAX_BAYES_BUDGET).contains(n))
                    .ok_or_else(|| {
                        Error::input(format!(
                            "{key}: {n} is not allowed (need {least}..={MAX_BAYES_BUDGET})"
                        ))
                    }),
            };
            let initial = count("initial", raw.initial, defaults.initial, 2)?;
            let budget = count("budget", raw.budget, defaults.budget.max(initial), 1)?;
            let batch = count("batch", raw.batch, defaults.batch.min(budget), 0)?;
            let settings = crate::study::bayes::Settings {
                budget,
                batch,
                initial,
                tolerance: raw.tolerance.unwrap_or(defaults.tolerance),
                ..defaults
            };
            settings.check().map_err(Error::input)?;
            Ok(OptimizeMethod::Bayes(BayesSpec {
                budget,
                batch,
                initial,
                tolerance: settings.tolerance,
                log_metric: log_metric(raw)?,
            }))
        }
        other => Err(Error::input(format!(
            "method: '{other}' is not brent, nelder-mead or bayes"
        ))),
    }
}
