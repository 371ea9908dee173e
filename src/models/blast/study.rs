//! `blast` as a study model: named parameters with units, metrics and series.

use nalgebra::Vector3;

use super::field::Drag;
use super::params::{
    BlastParams, DragLaw, Integrator, Interactions, NearFieldBasis, NearFieldPrecision, MAX_SAMPLES,
};
use super::theory::{stokes_ratio, turning_field, ChargedSphere};
use super::{run, BlastOutcome};
use crate::study::model::{
    Param, ParamKind as K, ParamSpec, RunContext, RunResult, RunSpan, RunStatus, StudyModel, Value,
};
use crate::study::param::{quantity as q, Bounds};
use crate::units::{Dimension as D, MU0};
use crate::{choice_param, number_param, Result};

/// The `blast` study model.
#[derive(Debug, Default)]
pub struct BlastModel;

type BlastParam = Param<BlastModel, BlastParams>;

const fn num(name: &'static str, doc: &'static str) -> ParamSpec {
    ParamSpec::new(name, K::Number, doc)
}

const POSITIVE: Bounds = Bounds::POSITIVE;
const NON_NEGATIVE: Bounds = Bounds::NON_NEGATIVE;

/// Every `blast` parameter, declared once.
static PARAMETERS: &[BlastParam] = &[
    Param {
        // B is entered as a field in tesla (μ0 H) and stored as B.
        spec: q(
            "field",
            D::MagneticField,
            "T",
            "Magnetic flux density |B| (as μ0·H)",
        ),
        get: |p| Some(Value::Number(p.field_strength / MU0)),
        set: |_, p, v| {
            p.field_strength = MU0 * v.as_number();
            Ok(())
        },
    },
    Param {
        spec: ParamSpec::new(
            "field_direction",
            K::Name,
            "Direction of B: x, y, z, -x, … or a vector \"a,b,c\"",
        ),
        get: |p| Some(Value::Text(direction_text(&p.field_direction))),
        set: |_, p, v| {
            p.field_direction = parse_direction(v.as_text())?;
            Ok(())
        },
    },
    number_param!(
        q(
            "electric_field",
            D::ElectricField,
            "V/m",
            "Electric field strength E"
        ),
        electric_strength
    ),
    Param {
        spec: ParamSpec::new(
            "electric_direction",
            K::Name,
            "Direction of E: \"field\" (along B) or x, y, z, -x, … or \"a,b,c\"",
        ),
        get: |p| {
            Some(Value::Text(
                p.electric_direction
                    .as_ref()
                    .map_or("field".into(), direction_text),
            ))
        },
        set: |_, p, v| {
            p.electric_direction = match v.as_text().trim() {
                "field" => None,
                t => Some(parse_direction(t)?),
            };
            Ok(())
        },
    },
    number_param!(
        q(
            "charge_per_mass",
            D::ChargePerMass,
            "C/kg",
            "Charge per mass q/m"
        ),
        charge_per_mass
    ),
    number_param!(
        num(
            "negative_fraction",
            "Fraction of particles carrying the opposite charge sign"
        )
        .within(Bounds::FRACTION),
        negative_fraction
    ),
    number_param!(
        q("energy", D::Energy, "kJ", "Detonation energy W (C1)").within(POSITIVE),
        energy
    ),
    number_param!(
        ParamSpec::new("particles", K::Count, "Number of particles N")
            .within(Bounds::closed(1.0, 1e6)),
        particles
    ),
    number_param!(
        q("radius", D::Length, "m", "Particle radius R").within(POSITIVE),
        radius
    ),
    number_param!(
        q("density", D::Density, "kg/m3", "Particle density ρ").within(POSITIVE),
        density
    ),
    number_param!(
        q("cloud_radius", D::Length, "m", "Initial cloud radius R_0").within(POSITIVE),
        cloud_radius
    ),
    number_param!(
        q("air_density", D::Density, "kg/m3", "Air density ρ_a").within(NON_NEGATIVE),
        air_density
    ),
    number_param!(
        q("air_viscosity", D::Viscosity, "Pa*s", "Air viscosity μ_f").within(POSITIVE),
        air_viscosity
    ),
    choice_param!(
        "drag",
        "Drag law (C3): quadratic (constant C_D), chow (C_D(Re)), stokes (6π μ_f R), none",
        drag,
        [
            ("quadratic", DragLaw::Quadratic),
            ("chow", DragLaw::Chow),
            ("stokes", DragLaw::Stokes),
            ("none", DragLaw::None)
        ]
    ),
    number_param!(
        num(
            "drag_coefficient",
            "Constant drag coefficient C_D of the quadratic law"
        )
        .within(NON_NEGATIVE),
        drag_coefficient
    ),
    number_param!(
        q("duration", D::Time, "s", "Duration of the run").within(POSITIVE),
        duration
    ),
    number_param!(
        ParamSpec::new(
            "samples",
            K::Count,
            "Series samples over the duration (besides t = 0)"
        )
        .within(Bounds::closed(1.0, MAX_SAMPLES as f64)),
        samples
    ),
    Param {
        spec: ParamSpec::new(
            "interactions",
            K::Name,
            "Interaction terms: none, all, or a list of contact, damping, friction, bonding, \
             near-field, rotation, thermal-softening",
        ),
        get: |p| Some(Value::Text(p.interactions.label())),
        set: |_, p, v| {
            p.interactions = Interactions::parse(v.as_text())?;
            Ok(())
        },
    },
    choice_param!(
        "integrator",
        "Integrator: auto (boris, or trapezoidal with interactions), boris, euler (the \
         source's forward Euler), trapezoidal (C9, C10)",
        step.integrator,
        [
            ("auto", Integrator::Auto),
            ("boris", Integrator::Boris),
            ("euler", Integrator::Euler),
            ("trapezoidal", Integrator::Trapezoidal)
        ]
    ),
    number_param!(
        q("dt", D::Time, "s", "Fixed time step of boris and euler").within(POSITIVE),
        step.dt
    ),
    number_param!(
        q(
            "dt_initial",
            D::Time,
            "s",
            "Initial time step Δt_0 of the trapezoidal scheme"
        )
        .within(POSITIVE),
        step.dt_initial
    ),
    number_param!(
        q(
            "dt_max",
            D::Time,
            "s",
            "Largest adaptive step Δt_max of the trapezoidal scheme (C10)"
        )
        .within(POSITIVE),
        step.dt_max
    ),
    number_param!(
        num(
            "phi",
            "Trapezoidal weight φ (C9): 0.5 trapezoid, 1 backward Euler"
        )
        .within(Bounds::FRACTION),
        step.phi
    ),
    number_param!(
        ParamSpec::new(
            "iterations",
            K::Count,
            "Desired fixed-point iterations per step K_d (C10)"
        ),
        step.iterations
    ),
    number_param!(
        num(
            "tolerance",
            "Relative tolerance TOL of the fixed-point iteration (C10)"
        )
        // ϖ_0 = 1 by construction: TOL ≥ 1 would accept any first iterate, and its Λ_K < 1
        // would shrink the step on acceptance without bound
        .within(Bounds::UNIT_OPEN),
        step.tolerance
    ),
    number_param!(
        q(
            "contact_stiffness",
            D::Pressure,
            "Pa",
            "Contact stiffness K_p0 (C4)"
        )
        .within(NON_NEGATIVE),
        contact.stiffness
    ),
    number_param!(
        num("contact_exponent", "Contact exponent p_p (C4)").within(POSITIVE),
        contact.exponent
    ),
    number_param!(
        q(
            "temperature",
            D::Temperature,
            "K",
            "Particle temperature Θ (C4)"
        )
        .within(POSITIVE),
        contact.temperature
    ),
    number_param!(
        q(
            "reference_temperature",
            D::Temperature,
            "K",
            "Reference temperature Θ* of the thermal softening (C4)"
        )
        .within(POSITIVE),
        contact.reference_temperature
    ),
    number_param!(
        num("softening_rate", "Softening rate a of K_p (C4)").within(NON_NEGATIVE),
        contact.softening_rate
    ),
    number_param!(
        q(
            "stiffness_floor",
            D::Pressure,
            "Pa",
            "Stiffness floor K_p^lim of the softening (C4)"
        )
        .within(NON_NEGATIVE),
        contact.stiffness_floor
    ),
    number_param!(
        num("contact_damping", "Contact damping c_cd, N·s/m³ (C5)").within(NON_NEGATIVE),
        contact.damping
    ),
    number_param!(
        num("friction_stiffness", "Stick stiffness K_f, N·s⁻¹·m⁻³ (C6)").within(NON_NEGATIVE),
        contact.friction_stiffness
    ),
    number_param!(
        num("static_friction", "Static friction coefficient μ_s (C6)").within(NON_NEGATIVE),
        contact.static_friction
    ),
    number_param!(
        num("dynamic_friction", "Dynamic friction coefficient μ_d (C6)").within(NON_NEGATIVE),
        contact.dynamic_friction
    ),
    number_param!(
        q(
            "bond_stiffness",
            D::Pressure,
            "Pa",
            "Bond stiffness K_nb (C7)"
        )
        .within(NON_NEGATIVE),
        contact.bond_stiffness
    ),
    number_param!(
        num("bond_exponent", "Bond exponent p_b (C7)").within(POSITIVE),
        contact.bond_exponent
    ),
    number_param!(
        num(
            "bond_tangential",
            "Tangential bond stiffness K_rb, N·s⁻¹·m⁻³ (C7)"
        )
        .within(NON_NEGATIVE),
        contact.bond_tangential
    ),
    number_param!(
        num(
            "bond_strain",
            "Bonding strain ε*: overlap δ/(R_i+R_j) at which a pair bonds (C7; not in the source)"
        )
        .within(POSITIVE),
        contact.bond_strain
    ),
    number_param!(
        num(
            "near_field_attraction",
            "Near-field attraction ᾱ1, N·m^β1/kg² (C8)"
        )
        .within(NON_NEGATIVE),
        near_field.attraction
    ),
    number_param!(
        num(
            "near_field_attraction_exponent",
            "Near-field attraction exponent β1 (C8)"
        )
        .within(NON_NEGATIVE),
        near_field.attraction_exponent
    ),
    number_param!(
        num(
            "near_field_repulsion",
            "Near-field repulsion ᾱ2, N·m^β2/kg² (C8)"
        )
        .within(NON_NEGATIVE),
        near_field.repulsion
    ),
    number_param!(
        num(
            "near_field_repulsion_exponent",
            "Near-field repulsion exponent β2 (C8)"
        )
        .within(NON_NEGATIVE),
        near_field.repulsion_exponent
    ),
    choice_param!(
        "near_field_basis",
        "What the near-field coefficients scale with (C8): mass, area (surface), volume, charge",
        near_field.basis,
        [
            ("mass", NearFieldBasis::Mass),
            ("area", NearFieldBasis::Area),
            ("volume", NearFieldBasis::Volume),
            ("charge", NearFieldBasis::Charge)
        ]
    ),
    choice_param!(
        "near_field_sign",
        "Sign factor of the near field (C8): none (the spec: the same law for every pair) or \
         charge (the source's c_i c_j: unlike charges flip the law)",
        near_field.charge_sign,
        [("none", false), ("charge", true)]
    ),
    number_param!(
        q(
            "near_field_cutoff",
            D::Length,
            "m",
            "Near-field cut-off distance (0: exact sum over all pairs)"
        )
        .within(NON_NEGATIVE),
        near_field.cutoff
    ),
    number_param!(
        num(
            "near_field_theta",
            "Barnes–Hut opening angle θ of the near field (0: exact sum over all pairs; \
             relative force error 8.5e-3 at 0.5, 6.3e-4 at 0.25)"
        )
        .within(NON_NEGATIVE),
        near_field.theta
    ),
    choice_param!(
        "near_field_precision",
        "Arithmetic of the all-pairs near-field sum: auto (single precision while the cloud \
         is at most 1000 particle diameters across, where its error is bounded below 1e-3 of \
         the pair forces; double beyond, or with a cut-off, a tree or other exponents), double \
         (exact to round-off) or single (single-precision lanes, double-precision tile sums, \
         at any extent; cut-off 0, theta 0, exponents (1, 2))",
        near_field.precision,
        [
            ("auto", NearFieldPrecision::Auto),
            ("double", NearFieldPrecision::Double),
            ("single", NearFieldPrecision::Single)
        ]
    ),
    number_param!(
        num(
            "target_aspect_ratio",
            "Wanted aspect ratio of the shape_error metric"
        )
        .within(NON_NEGATIVE),
        target_aspect_ratio
    ),
    number_param!(
        q(
            "target_turning_radius",
            D::Length,
            "m",
            "Wanted turning radius of the turning_radius_error metric (C13)"
        )
        .within(POSITIVE),
        target_turning_radius
    ),
    number_param!(
        q(
            "target_equatorial_radius",
            D::Length,
            "m",
            "Wanted equatorial radius (semi-axis across B) of the equatorial_error metric"
        )
        .within(NON_NEGATIVE),
        target_equatorial_radius
    ),
    number_param!(
        num(
            "stop_energy_fraction",
            "Stop at the first sample whose kinetic energy is at most this fraction of the \
             initial one (0: run the whole duration)"
        )
        .within(Bounds::FRACTION),
        stop_energy_fraction
    ),
];

/// A direction as `parse_direction` reads it back ("x", "-z" or "a,b,c").
fn direction_text(v: &Vector3<f64>) -> String {
    let axes = [
        ("x", Vector3::x()),
        ("y", Vector3::y()),
        ("z", Vector3::z()),
    ];
    for (name, axis) in axes {
        if *v == axis {
            return name.into();
        }
        if *v == -axis {
            return format!("-{name}");
        }
    }
    format!("{:?},{:?},{:?}", v.x, v.y, v.z)
}

const METRICS: &[&str] = &[
    "semi_axis_along_B_m",
    "semi_axis_across_B_m",
    "aspect_ratio",
    "shape_error",
    "extent_along_B_m",
    "extent_across_B_m",
    "mean_radius_m",
    "kinetic_energy_J",
    "bonds",
    "clusters",
    "largest_cluster",
    "steps",
    "rejected_steps",
    "mean_iterations",
    "near_field_single_precision_fraction",
    "min_time_step_s",
    "max_time_step_s",
    "terminal_time_s",
    "envelope_settled_time_s",
    "equatorial_error",
    "turning_radius_m",
    "turning_radius_initial_m",
    "turning_radius_error",
    "turning_field_T",
    "force_ratio_initial",
    "force_ratio_end",
    "force_ratio_bound_initial",
    "parity_field_T",
    "stokes_ratio_initial",
    "spin_positive_Js",
    "spin_negative_Js",
];

/// Parses a direction: "x", "y", "z", "-x"… or "a,b,c" (normalized).
pub fn parse_direction(text: &str) -> std::result::Result<Vector3<f64>, String> {
    let t = text.trim();
    let (sign, axis) = t.strip_prefix('-').map_or((1.0, t), |a| (-1.0, a));
    let v = match axis {
        "x" => Vector3::x(),
        "y" => Vector3::y(),
        "z" => Vector3::z(),
        _ => {
            let parts: Vec<f64> = t
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| format!("'{t}' is not a direction (x, y, z, -x… or a,b,c)"))?;
            if parts.len() != 3 {
                return Err(format!("'{t}' is not a direction (x, y, z, -x… or a,b,c)"));
            }
            return Vector3::new(parts[0], parts[1], parts[2])
                .try_normalize(0.0)
                .filter(|v| v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| format!("'{t}' is not a direction (need a nonzero finite vector)"));
        }
    };
    Ok(sign * v)
}

/// The fraction of all-pairs near-field evaluations done in single precision; none where
/// the near field was not summed over all pairs.
fn single_precision_fraction((all, single): (usize, usize)) -> Option<f64> {
    (all > 0).then(|| single as f64 / all as f64)
}

impl BlastModel {
    /// The run as a study result.
    pub fn result(params: &BlastParams, outcome: &BlastOutcome) -> RunResult {
        let s = outcome.last();
        let e = &s.envelope;
        let stats = &outcome.stats;
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        let interacting = params.interactions.any();
        let metrics = vec![
            ("semi_axis_along_B_m", finite(e.along)),
            ("semi_axis_across_B_m", finite(e.across)),
            ("aspect_ratio", finite(e.aspect_ratio())),
            (
                "shape_error",
                finite((e.aspect_ratio() - params.target_aspect_ratio).abs()),
            ),
            ("extent_along_B_m", finite(e.extent_along)),
            ("extent_across_B_m", finite(e.extent_across)),
            ("mean_radius_m", finite(e.mean_radius)),
            ("kinetic_energy_J", finite(s.kinetic_energy)),
            ("bonds", interacting.then_some(s.bonds as f64)),
            ("clusters", interacting.then_some(s.clusters as f64)),
            (
                "largest_cluster",
                interacting.then_some(s.largest_cluster as f64),
            ),
            ("steps", Some(stats.steps as f64)),
            ("rejected_steps", Some(stats.rejected as f64)),
            (
                "mean_iterations",
                interacting.then(|| stats.iterations as f64 / stats.steps.max(1) as f64),
            ),
            (
                "near_field_single_precision_fraction",
                single_precision_fraction(stats.all_pairs_evaluations),
            ),
            ("min_time_step_s", finite(stats.dt_min)),
            ("max_time_step_s", finite(stats.dt_max)),
            ("terminal_time_s", outcome.terminal_time),
            ("envelope_settled_time_s", outcome.envelope_settled_time()),
            (
                "equatorial_error",
                finite((e.across - params.target_equatorial_radius).abs()),
            ),
        ];
        let metrics = metrics
            .into_iter()
            .chain(Self::paper_metrics(params, outcome));
        let series_of = |f: &dyn Fn(&super::Sample) -> f64| -> Vec<(f64, f64)> {
            outcome.samples.iter().map(|s| (s.time, f(s))).collect()
        };
        let mut series = vec![
            (
                "semi_axis_along_B".to_string(),
                series_of(&|s| s.envelope.along),
            ),
            (
                "semi_axis_across_B".into(),
                series_of(&|s| s.envelope.across),
            ),
            (
                "aspect_ratio".into(),
                series_of(&|s| s.envelope.aspect_ratio()),
            ),
            ("mean_radius".into(), series_of(&|s| s.envelope.mean_radius)),
            ("kinetic_energy".into(), series_of(&|s| s.kinetic_energy)),
            (
                "spin_positive".into(),
                series_of(&|s| s.motion.spin_positive),
            ),
            (
                "spin_negative".into(),
                series_of(&|s| s.motion.spin_negative),
            ),
            ("speed_along_B".into(), series_of(&|s| s.motion.speed_along)),
            (
                "speed_across_B".into(),
                series_of(&|s| s.motion.speed_across),
            ),
            (
                "turning_radius".into(),
                series_of(&|s| s.motion.turning_radius),
            ),
            ("force_ratio".into(), series_of(&|s| s.motion.force_ratio)),
        ];
        if interacting {
            series.push(("bonds".into(), series_of(&|s| s.bonds as f64)));
            series.push((
                "largest_cluster".into(),
                series_of(&|s| s.largest_cluster as f64),
            ));
        }
        // a state that is not finite is a failed run, never an "ok" with missing numbers
        let broken = [s.kinetic_energy, e.along, e.across, e.mean_radius]
            .iter()
            .any(|x| !x.is_finite())
            .then(|| {
                format!(
                    "non-finite state at t = {} s (kinetic energy {} J, semi-axes {} m, {} m)",
                    s.time, s.kinetic_energy, e.along, e.across
                )
            });
        RunResult {
            status: match outcome.failure.clone().or(broken) {
                Some(reason) => RunStatus::Failed(reason),
                None => RunStatus::Ok,
            },
            notes: Vec::new(),
            metrics: metrics.map(|(n, v)| (n.to_string(), v)).collect(),
            series,
            wall_time_s: outcome.wall_time_s,
        }
    }
}

impl BlastModel {
    /// The source's single-particle measures (C11–C13) and the swirl (C15): the blast speed
    /// |δv| = √(2W/M) sets the bound λ, the field for parity and the Stokes ratio; the drag
    /// coefficient of λ is the run's law at that speed (C_D for quadratic and Chow, 24/Re for
    /// Stokes); the Stokes ratio uses the constant C_D as the source's Eq. (4.15) does.
    fn paper_metrics(
        params: &BlastParams,
        outcome: &BlastOutcome,
    ) -> Vec<(&'static str, Option<f64>)> {
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        let (first, last) = (&outcome.samples[0].motion, &outcome.last().motion);
        let mass = params.particle_mass() * params.particles as f64;
        let speed = (2.0 * params.energy / mass).sqrt();
        let sphere = ChargedSphere {
            charge_per_mass: params.charge_per_mass,
            density: params.density,
            radius: params.radius,
            drag_coefficient: Drag::new(params).effective_coefficient(speed),
            fluid_density: params.air_density,
        };
        let stokes = stokes_ratio(
            params.air_viscosity,
            params.air_density,
            params.drag_coefficient,
            params.radius,
            speed,
        );
        vec![
            ("turning_radius_m", finite(last.turning_radius)),
            ("turning_radius_initial_m", finite(first.turning_radius)),
            (
                "turning_radius_error",
                finite((last.turning_radius - params.target_turning_radius).abs()),
            ),
            (
                "turning_field_T",
                finite(turning_field(
                    speed,
                    params.charge_per_mass,
                    params.target_turning_radius,
                )),
            ),
            ("force_ratio_initial", finite(first.force_ratio)),
            ("force_ratio_end", finite(last.force_ratio)),
            (
                "force_ratio_bound_initial",
                finite(sphere.force_ratio_bound(
                    params.electric_strength.abs(),
                    params.field_strength.abs(),
                    speed,
                )),
            ),
            (
                "parity_field_T",
                finite(sphere.parity_magnetic_field(speed)),
            ),
            ("stokes_ratio_initial", finite(stokes)),
            ("spin_positive_Js", finite(last.spin_positive)),
            ("spin_negative_Js", finite(last.spin_negative)),
        ]
    }
}

impl StudyModel for BlastModel {
    type Params = BlastParams;
    const SOURCES: &'static str = "blast";

    fn name(&self) -> &'static str {
        "blast"
    }

    fn parameters(&self) -> &'static [BlastParam] {
        PARAMETERS
    }

    fn metrics(&self) -> &'static [&'static str] {
        METRICS
    }

    fn series_labels(&self) -> &'static [(&'static str, &'static str)] {
        &[
            ("semi_axis_along_B", "semi-axis along B (m)"),
            ("semi_axis_across_B", "semi-axis across B (m)"),
            ("aspect_ratio", "aspect ratio along/across B"),
            ("mean_radius", "mean distance from centre (m)"),
            ("kinetic_energy", "kinetic energy (J)"),
            (
                "spin_positive",
                "angular momentum about B, positive charges (J·s)",
            ),
            (
                "spin_negative",
                "angular momentum about B, negative charges (J·s)",
            ),
            ("speed_along_B", "RMS velocity along B (m/s)"),
            ("speed_across_B", "RMS velocity across B (m/s)"),
            ("turning_radius", "mean turning radius |v⊥|/(|q/m| B) (m)"),
            ("force_ratio", "force ratio Σ|Lorentz| / Σ|drag|"),
            ("bonds", "bonded pairs"),
            ("largest_cluster", "largest cluster (particles)"),
        ]
    }

    /// The source's non-interacting example.
    fn defaults(&self) -> BlastParams {
        BlastParams::source_example()
    }

    fn validate(&self, params: &BlastParams) -> Result<()> {
        params.validate()
    }

    fn run_span(&self, params: &BlastParams) -> std::result::Result<RunSpan, String> {
        let steps = match params.integrator() {
            Integrator::Trapezoidal => None,
            _ => Some((params.duration / params.step.dt).ceil() as u64),
        };
        Ok(RunSpan {
            end: Some(params.duration),
            steps,
        })
    }

    fn run(&self, params: &BlastParams, seed: u64, context: &RunContext) -> Result<RunResult> {
        let mut recorder = context.recorder();
        Ok(
            match run(params, seed, context.progress, recorder.as_mut()) {
                Ok(outcome) => {
                    let mut result = Self::result(params, &outcome);
                    if let Some(recorder) = recorder {
                        result.notes.extend(recorder.finish()?);
                    }
                    result
                }
                Err(e) => RunResult {
                    status: RunStatus::Failed(e.to_string()),
                    notes: Vec::new(),
                    metrics: METRICS.iter().map(|m| (m.to_string(), None)).collect(),
                    series: Vec::new(),
                    wall_time_s: 0.0,
                },
            },
        )
    }
}
