//! `bed` (one compression cycle) and `damper` (the free-falling piston) as study models:
//! named parameters with units, metrics and series.

use super::damper::{damper, REST_LIMIT};
use std::path::Path;

use super::params::{
    BedParams, Friction, FrictionScheme, Heights, Neighbors, Preset, Reach, Species,
    TailCorrection, TiltOrder, WallLaw,
};
use super::protocol::{cycle, recorded};
use super::report::cycle_figures;
use super::BedOutcome;
use crate::output::guard::{read_text_limited, MAX_TEXT_INPUT};
use crate::output::{atomic, plot};
use crate::study::model::{
    Param, ParamKind as K, ParamSpec, Recorder, RunContext, RunResult, RunSpan, RunStatus,
    StudyModel, Value,
};
use crate::study::param::{quantity as q, Bounds};
use crate::units::{Dimension as D, MU0};
use crate::{choice_param, number_param, optional_param, Error, Result};

/// The `bed` or `damper` study model (same parameters; different protocol and defaults).
#[derive(Debug, Clone, Copy)]
pub struct BedModel {
    damper: bool,
}

impl BedModel {
    /// The compression-cycle model `bed`.
    pub fn cycle() -> Self {
        Self { damper: false }
    }

    /// The free-falling piston model `damper`.
    pub fn damper() -> Self {
        Self { damper: true }
    }

    /// Simulated time of a run, s (progress is reported as a fraction of it).
    fn simulated_time(&self, p: &BedParams) -> f64 {
        let g = super::state::Geometry::of(p);
        let stages = p.relaxation_time + p.settle_time;
        if self.damper {
            stages + 2.0 * p.damper_time
        } else {
            stages + 2.0 * (g.start_height - g.final_height) / p.piston_speed + p.final_rest
        }
    }

    /// Latest simulated time a run can reach, s: the cycle's, or the damper's with its first
    /// fall at its limit.
    fn end_time(&self, p: &BedParams) -> f64 {
        if self.damper {
            p.relaxation_time + p.settle_time + (REST_LIMIT + 1.0) * p.damper_time
        } else {
            self.simulated_time(p)
        }
    }

    /// The damper fits (second motion, first fall) and the cycle figures (the particle frames are written as the run goes).
    fn write_artifacts(&self, o: &BedOutcome, dir: &Path) -> Result<()> {
        if let Some(fits) = &o.damper_fits {
            atomic::write_json_atomic(&dir.join("damper_fits.json"), &fits.json())?;
            plot::render_png(&dir.join("damper_fits.png"), &fits.figure())?;
        }
        if let Some(fall) = &o.damper_fall_fit {
            atomic::write_json_atomic(&dir.join("damper_fall_fit.json"), &fall.json())?;
            plot::render_png(&dir.join("damper_fall_fit.png"), &fall.figure())?;
        }
        if !self.damper && o.failure.is_none() {
            for (stem, figure) in cycle_figures(o) {
                plot::render_png(&dir.join(format!("{stem}.png")), &figure)?;
            }
        }
        Ok(())
    }

    /// One run as a full outcome (tests and benchmarks use this directly).
    pub fn outcome(&self, params: &BedParams, seed: u64, progress: &dyn Fn(f64)) -> BedOutcome {
        self.recorded(params, seed, progress, None).0
    }

    /// One run whose particle frames `recorder` writes as it goes.
    pub fn recorded<'a>(
        &self,
        params: &'a BedParams,
        seed: u64,
        progress: &'a dyn Fn(f64),
        recorder: Option<Recorder<'a>>,
    ) -> (BedOutcome, Option<Recorder<'a>>) {
        let protocol = if self.damper { damper } else { cycle };
        recorded(params, seed, progress, recorder, protocol)
    }
}

type BedParam = Param<BedModel, BedParams>;

/// The damper's default time-step factor (see [`BedModel::defaults`]).
const DAMPER_TIME_STEP_FACTOR: f64 = 0.2;

/// A reach in units of D_1, or an absolute length.
const fn reach(name: &'static str, doc: &'static str) -> ParamSpec {
    ParamSpec::new(name, K::Multiple { of: "D1" }, doc).within(Bounds::POSITIVE)
}

fn reach_value(r: Reach) -> Option<Value> {
    Some(match r {
        Reach::Diameters(x) => Value::Number(x),
        Reach::Length(l) => Value::Text(format!("{l:?} m")),
    })
}

fn reach_of(v: &Value) -> Reach {
    match v {
        Value::Number(x) => Reach::Diameters(*x),
        Value::Text(t) => Reach::Length(
            t.trim_end_matches(" m")
                .parse()
                .expect("the parser writes \"<metres> m\""),
        ),
    }
}

const POSITIVE: Bounds = Bounds::POSITIVE;
const NON_NEGATIVE: Bounds = Bounds::NON_NEGATIVE;

/// Every `bed` and `damper` parameter, declared once.
static PARAMETERS: &[BedParam] = &[
    choice_param!(
        "preset",
        "Geometry preset: mono (N = 368, D = 6 mm, W × H = 0.36 × 0.45 m) or bidisperse \
         (N = 400, D1 = 5 mm, W = 66 D1, H = 0.445 m)",
        preset,
        [("mono", Preset::Mono), ("bidisperse", Preset::Bidisperse)]
    ),
    optional_param!(
        ParamSpec::new(
            "particles",
            K::Count,
            "Number of particles N; the cell scales by √(N/N_preset)"
        )
        .within(Bounds::closed(1.0, 1e6))
        .derived("368 mono, 400 bidisperse"),
        particles
    ),
    optional_param!(
        q(
            "big_diameter",
            D::Length,
            "mm",
            "Big (reference) diameter D1"
        )
        .within(POSITIVE)
        .derived("6 mm mono, 5 mm bidisperse, or the first species"),
        big_diameter
    ),
    number_param!(
        ParamSpec::new(
            "mixing_ratio",
            K::Number,
            "Mixing ratio R = number fraction of small particles (bidisperse)"
        )
        .within(Bounds::FRACTION),
        mixing_ratio
    ),
    number_param!(
        ParamSpec::new(
            "aspect_ratio",
            K::Number,
            "Aspect ratio a = D_small/D_big (bidisperse)"
        )
        .within(Bounds::above_to(0.0, 1.0)),
        aspect_ratio
    ),
    Param {
        spec: ParamSpec::new(
            "species_file",
            K::Name,
            "Species file (TOML: [[species]] tables with diameter = \"5mm\" and fraction = 0.6); \
             the first species is the reference",
        )
        .aliases(&["species"])
        .derived("the preset's species"),
        get: |_| None,
        set: |_, p, v| {
            p.species = Some(load_species(v.as_text()).map_err(|e| e.to_string())?);
            Ok(())
        },
    },
    optional_param!(
        q("width", D::Length, "m", "Cell width W at the preset's N")
            .within(POSITIVE)
            .derived("0.36 m mono, 66 D1 bidisperse"),
        width
    ),
    optional_param!(
        q("height", D::Length, "m", "Cell height H at the preset's N")
            .within(POSITIVE)
            .derived("0.45 m mono, 0.445 m bidisperse"),
        height
    ),
    number_param!(
        q("gap", D::Length, "mm", "Gap E between the glass plates").within(POSITIVE),
        gap
    ),
    number_param!(
        q("thickness", D::Length, "mm", "Disc thickness ε").within(POSITIVE),
        thickness
    ),
    number_param!(
        q("density", D::Density, "kg/m3", "Disc density ρ").within(POSITIVE),
        density
    ),
    Param {
        spec: q(
            "remanence",
            D::MagneticField,
            "T",
            "Remanence B_r of the discs (as μ0·H)",
        )
        .within(POSITIVE),
        get: |p| Some(Value::Number(p.remanence / MU0)),
        set: |_, p, v| {
            p.remanence = MU0 * v.as_number();
            Ok(())
        },
    },
    number_param!(
        ParamSpec::new(
            "static_friction",
            K::Number,
            "Static friction coefficient μ_s with the plates"
        )
        .within(NON_NEGATIVE),
        static_friction
    ),
    number_param!(
        ParamSpec::new(
            "dynamic_friction",
            K::Number,
            "Dynamic friction coefficient μ_d with the plates"
        )
        .within(NON_NEGATIVE),
        dynamic_friction
    ),
    number_param!(
        q(
            "gravity",
            D::Acceleration,
            "m/s2",
            "Gravity g along −y (0 switches it off)"
        )
        .within(NON_NEGATIVE),
        gravity
    ),
    choice_param!(
        "friction_model" aliases &["friction"],
        "Friction with the plates: dry (B4–B5), viscous (B3, τ_v), both, none",
        friction,
        [
            ("none", Friction::None),
            ("viscous", Friction::Viscous),
            ("dry", Friction::Dry),
            ("both", Friction::Both)
        ]
    ),
    choice_param!(
        "tilt_order",
        "Order of the tilt torque in the plate normal force (B4): first, second",
        tilt_order,
        [("first", TiltOrder::First), ("second", TiltOrder::Second)]
    ),
    number_param!(
        q("viscous_time", D::Time, "s", "Viscous time τ_v = m/γ (B3)").within(POSITIVE),
        viscous_time
    ),
    number_param!(
        q(
            "threshold_speed",
            D::Velocity,
            "m/s",
            "Speed below which dry friction sticks (B5)"
        )
        .within(POSITIVE),
        threshold_speed
    ),
    choice_param!(
        "friction_scheme",
        "Dry-friction integration: semi-implicit (stick rule + backward Euler) or explicit \
         (forward-Euler B5, the small-step reference)",
        friction_scheme,
        [
            ("semi-implicit", FrictionScheme::SemiImplicit),
            ("explicit", FrictionScheme::Explicit)
        ]
    ),
    choice_param!(
        "wall_law",
        "Wall law: empirical (B2, w^-3.5), infinite-row (w^-3), finite-bar",
        wall_law,
        [
            ("empirical", WallLaw::Empirical),
            ("infinite-row", WallLaw::InfiniteRow),
            ("finite-bar", WallLaw::FiniteBar)
        ]
    ),
    optional_param!(
        ParamSpec::new(
            "wall_strength",
            K::Number,
            "Wall strength M_w of the empirical law (B2), A·m^1.5"
        )
        .within(POSITIVE)
        .derived("2 μ_1/√D_1"),
        wall_strength
    ),
    number_param!(
        q("piston_speed", D::Velocity, "mm/s", "Piston speed V_c")
            .within(POSITIVE)
            .aliases(&["velocity"]),
        piston_speed
    ),
    choice_param!(
        "heights" aliases &["protocol"],
        "Piston heights: source (H0 = the cell height H, H_f at max_packing_fraction; \
         docs/bed-protocol.md) or packing-fractions (H0 at start_packing_fraction)",
        heights,
        [
            ("source", Heights::Source),
            ("packing-fractions", Heights::PackingFractions)
        ]
    ),
    number_param!(
        ParamSpec::new(
            "start_packing_fraction",
            K::Number,
            "Packing fraction at the start of compression (sets H0 with heights = \
             packing-fractions)"
        )
        .within(Bounds::UNIT_OPEN),
        start_packing_fraction
    ),
    optional_param!(
        ParamSpec::new(
            "max_packing_fraction",
            K::Number,
            "Packing fraction at maximum compression (sets H_f)"
        )
        .within(Bounds::UNIT_OPEN)
        .aliases(&["packing_fraction"])
        .derived("0.2307 mono with heights = source (docs/bed-protocol.md), else 0.34"),
        max_packing_fraction
    ),
    optional_param!(
        ParamSpec::new(
            "target_force",
            K::Number,
            "Piston force, N, at which the compression stops (H_f stays the lowest height)"
        )
        .within(POSITIVE)
        .derived("none: compress to H_f"),
        target_force
    ),
    number_param!(
        q(
            "relaxation_time",
            D::Time,
            "s",
            "Damped relaxation before the piston is placed"
        )
        .within(NON_NEGATIVE),
        relaxation_time
    ),
    number_param!(
        q(
            "piston_decay_time",
            D::Time,
            "s",
            "Decay time of the piston's approach to the bed"
        )
        .within(POSITIVE),
        piston_decay_time
    ),
    number_param!(
        q(
            "settle_time",
            D::Time,
            "s",
            "Settling under the piston before compression"
        )
        .within(NON_NEGATIVE),
        settle_time
    ),
    number_param!(
        q("final_rest", D::Time, "s", "Rest after the expansion").within(NON_NEGATIVE),
        final_rest
    ),
    number_param!(
        q(
            "initial_speed",
            D::Velocity,
            "m/s",
            "Speed scale of the random initial velocities"
        )
        .within(NON_NEGATIVE),
        initial_speed
    ),
    choice_param!(
        "neighbors",
        "Neighbour handling: exact (all pairs), cells (cut-off list every step), verlet (list \
         radius r_v, cut-off r_c), source-verlet (the source's: every pair of the r_v list \
         summed, rebuilt after a displacement of rebuild_skin), tree (no cut-off: a list \
         inside near_cutoff, a Barnes-Hut quadtree beyond it)",
        neighbors,
        [
            ("exact", Neighbors::Exact),
            ("cells", Neighbors::Cells),
            ("verlet", Neighbors::Verlet),
            ("source-verlet", Neighbors::SourceVerlet),
            ("tree", Neighbors::Tree)
        ]
    ),
    Param {
        spec: reach("cutoff", "Cut-off r_c of the pair sums"),
        get: |p| reach_value(p.cutoff),
        set: |_, p, v| {
            p.cutoff = reach_of(v);
            Ok(())
        },
    },
    Param {
        spec: reach(
            "list_radius",
            "Verlet list radius r_v (changes the speed, never the result; the source used 11.26)",
        ),
        get: |p| reach_value(p.list_radius),
        set: |_, p, v| {
            p.list_radius = reach_of(v);
            Ok(())
        },
    },
    Param {
        spec: reach(
            "rebuild_skin",
            "Skin r_s of source-verlet: its list is rebuilt once a disc has moved r_s (source: 4.13)",
        ),
        get: |p| reach_value(p.rebuild_skin),
        set: |_, p, v| {
            p.rebuild_skin = reach_of(v);
            Ok(())
        },
    },
    number_param!(
        ParamSpec::new(
            "far_field_interval",
            K::Count,
            "Multiple time stepping: sum the pairs beyond near_cutoff every K steps and hold \
             them in between (verlet and tree only; 1: every pair every step)"
        ),
        far_field_interval
    ),
    Param {
        spec: reach(
            "near_cutoff",
            "Near cut-off r_s of the multiple time stepping and of tree",
        ),
        get: |p| reach_value(p.near_cutoff),
        set: |_, p, v| {
            p.near_cutoff = reach_of(v);
            Ok(())
        },
    },
    choice_param!(
        "tail_correction",
        "What stands for the pairs beyond the cut-off of verlet and cells: auto (mean-field with \
         verlet and cells, none with the other neighbour modes), none (truncated sums) or \
         mean-field (the discs beyond r_c spread evenly within height bands of r_c/2: \
         closed-form tails of the pair-force and plate-normal sums)",
        tail_correction,
        [
            ("auto", TailCorrection::Auto),
            ("none", TailCorrection::None),
            ("mean-field", TailCorrection::MeanField)
        ]
    ),
    number_param!(
        ParamSpec::new(
            "opening_angle",
            K::Number,
            "Opening angle θ of tree: a group acts through its multipoles when its extent is \
             below θ times its gap (0 sums every pair exactly)"
        )
        .within(Bounds::FRACTION),
        opening_angle
    ),
    optional_param!(
        ParamSpec::new(
            "time_step_factor",
            K::Number,
            "Time-step factor: Δt = factor/ω_max at the closest approach"
        )
        .within(Bounds::above_to(0.0, 1.0))
        .derived("0.4 with dry friction, 0.2 without it"),
        time_step_factor
    ),
    number_param!(
        q(
            "max_time_step",
            D::Time,
            "s",
            "Upper bound on the time step"
        )
        .within(POSITIVE),
        max_time_step
    ),
    optional_param!(
        q(
            "record_interval",
            D::Time,
            "s",
            "Interval of the recorded series"
        )
        .within(POSITIVE)
        .derived("0.05 s, × √(N/N_preset) above the preset's N"),
        record_interval
    ),
    number_param!(
        ParamSpec::new(
            "min_distance_ratio",
            K::Number,
            "Flag a run when two discs come closer than this fraction of their mean diameter"
        )
        .within(Bounds::UNIT_OPEN),
        min_distance_ratio
    ),
    number_param!(
        ParamSpec::new(
            "max_steps",
            K::Count,
            "Step budget: a run that needs more steps fails with its reason instead of going on"
        ),
        max_steps
    ),
    number_param!(
        q("piston_mass", D::Mass, "g", "Damper: piston mass").within(POSITIVE),
        piston_mass
    ),
    number_param!(
        q(
            "damper_time",
            D::Time,
            "s",
            "Damper: duration of the second free motion (the first ends at rest, within 20 \
             times this)"
        )
        .within(POSITIVE),
        damper_time
    ),
    number_param!(
        q(
            "damper_record_interval",
            D::Time,
            "s",
            "Damper: sampling interval of z(t)"
        )
        .within(POSITIVE),
        damper_record_interval
    ),
];
/// Every metric of [`BedOutcome::metrics`], in its order (the structure metrics per stage
/// included), computed once.
fn metric_names() -> &'static [&'static str] {
    static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| {
        BedOutcome::default()
            .metrics()
            .into_iter()
            .map(|(n, _)| n)
            .collect()
    })
}

const SERIES: &[(&str, &str)] = &[
    ("piston_height", "piston height (m)"),
    ("stroke", "stroke H0 − y_P (m)"),
    ("piston_force", "piston force (N)"),
    ("packing_fraction", "packing fraction φ"),
    ("mean_distance", "mean inter-particle distance D̂ (m)"),
    ("mean_distance_D", "D̂ / ⟨D⟩"),
    ("min_piston_distance", "min particle–piston distance (m)"),
    ("kinetic_energy", "kinetic energy (J)"),
    (
        "area_fraction_band_0",
        "local area fraction, band 1 of 10 from the floor",
    ),
    (
        "area_fraction_band_1",
        "local area fraction, band 2 of 10 from the floor",
    ),
    (
        "area_fraction_band_2",
        "local area fraction, band 3 of 10 from the floor",
    ),
    (
        "area_fraction_band_3",
        "local area fraction, band 4 of 10 from the floor",
    ),
    (
        "area_fraction_band_4",
        "local area fraction, band 5 of 10 from the floor",
    ),
    (
        "area_fraction_band_5",
        "local area fraction, band 6 of 10 from the floor",
    ),
    (
        "area_fraction_band_6",
        "local area fraction, band 7 of 10 from the floor",
    ),
    (
        "area_fraction_band_7",
        "local area fraction, band 8 of 10 from the floor",
    ),
    (
        "area_fraction_band_8",
        "local area fraction, band 9 of 10 from the floor",
    ),
    (
        "area_fraction_band_9",
        "local area fraction, band 10 of 10 from the floor",
    ),
    ("piston_z", "damper piston height z (m)"),
    (
        "piston_fall_z",
        "damper piston height z in the first fall (m)",
    ),
    ("piston_displacement", "damper z − z_rest (m)"),
];

/// Reads a species file: `[[species]]` tables with `diameter` (with unit; bare: mm) and
/// `fraction` (number fraction; normalized).
pub fn load_species(path: &str) -> Result<Vec<Species>> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        species: Vec<Entry>,
    }
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Entry {
        diameter: toml::Value,
        fraction: f64,
    }
    let text = read_text_limited(std::path::Path::new(path), MAX_TEXT_INPUT, "species file")?;
    let file: File = toml::from_str(&text)
        .map_err(|e| Error::input(format!("species file '{path}': {}", e.message())))?;
    if file.species.is_empty() {
        return Err(Error::input(format!(
            "species file '{path}': no [[species]] (need at least one)"
        )));
    }
    let diameter = q("diameter", D::Length, "mm", "").within(POSITIVE);
    file.species
        .iter()
        .map(|e| {
            Ok(Species {
                diameter: diameter
                    .parse(&e.diameter)
                    .map_err(|err| Error::input(format!("species file '{path}': diameter: {err}")))?
                    .as_number(),
                fraction: e.fraction,
            })
        })
        .collect()
}

impl StudyModel for BedModel {
    type Params = BedParams;
    const SOURCES: &'static str = "bed";

    fn name(&self) -> &'static str {
        if self.damper {
            "damper"
        } else {
            "bed"
        }
    }

    fn parameters(&self) -> &'static [BedParam] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        metric_names()
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        SERIES
    }

    /// The spec's mono-disperse defaults; the damper uses viscous friction and the time-step
    /// factor 0.2 whatever its friction: its fitted first fall moves with the step (α by +0.07
    /// from factor 0.2 to 0.4, 17 standard errors over 8 seeds; docs/bed.md, "Integration").
    fn defaults(&self) -> BedParams {
        let mut p = BedParams::defaults();
        if self.damper {
            p.friction = Friction::Viscous;
            p.time_step_factor = Some(DAMPER_TIME_STEP_FACTOR);
        }
        p
    }

    fn validate(&self, p: &BedParams) -> Result<()> {
        p.validate()
    }

    fn run_span(&self, p: &BedParams) -> std::result::Result<RunSpan, String> {
        Ok(RunSpan {
            end: Some(self.end_time(p)),
            steps: None,
        })
    }

    fn run(&self, p: &BedParams, seed: u64, context: &RunContext) -> Result<RunResult> {
        let mut p = p.clone();
        p.snapshots = context.artifacts.is_some();
        let total = self.simulated_time(&p);
        let progress = |t: f64| (context.progress)((t / total).min(1.0));
        let (o, recorder) = self.recorded(&p, seed, &progress, context.recorder());
        let mut notes = o.warnings.clone();
        if let Some(recorder) = recorder {
            notes.extend(recorder.finish()?);
        }
        if let Some(dir) = context.artifacts {
            self.write_artifacts(&o, dir)?;
        }
        Ok(RunResult {
            status: match &o.failure {
                Some(reason) => RunStatus::Failed(reason.clone()),
                None => RunStatus::Ok,
            },
            notes,
            metrics: o
                .metrics()
                .into_iter()
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            series: o.series.0,
            wall_time_s: o.wall_time_s,
        })
    }
}
