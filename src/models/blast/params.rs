//! Parameters of a blast run (spec blast.md), SI inside, with the source's defaults and a
//! `validate()` that names the offending field, its value and the allowed range.

use nalgebra::Vector3;

pub use super::switches::{Interactions, INTERACTION_NAMES};
use crate::{Error, Result};

/// Most series samples a run may ask for.
pub const MAX_SAMPLES: usize = 100_000;

/// Most time steps a run may need (duration over the longest allowed step), and most step
/// attempts an adaptive run may take before it fails.
pub const MAX_STEPS: f64 = 1e8;

/// Highest volume fraction attempted: RSA of equal spheres jams near 0.384, and gets very slow
/// well before; beyond this the packing is reported impossible.
pub const MAX_VOLUME_FRACTION: f64 = 0.35;

/// Drag law (C3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DragLaw {
    /// Quadratic drag with the constant coefficient `drag_coefficient`.
    Quadratic,
    /// Quadratic drag with Chow's piecewise C_D(Re).
    Chow,
    /// Stokes drag c = 6π μ_f R.
    Stokes,
    /// No drag.
    None,
}

/// Time integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Boris for the non-interacting case, trapezoidal (C9, C10) for the interacting case.
    Auto,
    /// Strang splitting: half drift, exact half drag, Boris rotation, exact half drag, half
    /// drift (non-interacting only). Conserves |v| exactly under B alone.
    Boris,
    /// The source's forward-Euler update v ← v + Δt/m Ψ(t), r ← r + Δt v(t) (non-interacting).
    Euler,
    /// Generalized trapezoidal rule (C9) with fixed-point iterations and adaptive Δt (C10).
    Trapezoidal,
}

/// Contact, friction and bonding constants (C4–C7), SI.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactParams {
    /// K_p0, N/m² (C4).
    pub stiffness: f64,
    /// p_p (C4).
    pub exponent: f64,
    /// Softening rate a of K_p = max(K_p0 e^{−a(Θ/Θ*−1)}, K_p^lim).
    pub softening_rate: f64,
    /// Particle temperature Θ, K.
    pub temperature: f64,
    /// Reference temperature Θ*, K.
    pub reference_temperature: f64,
    /// Stiffness floor K_p^lim, N/m².
    pub stiffness_floor: f64,
    /// Damping c_cd, N·s/m³ (C5).
    pub damping: f64,
    /// Stick stiffness K_f, N·s⁻¹·m⁻³ (force K_f |Δv_τ| A Δt) (C6).
    pub friction_stiffness: f64,
    /// Static friction coefficient μ_s.
    pub static_friction: f64,
    /// Dynamic friction coefficient μ_d.
    pub dynamic_friction: f64,
    /// Bond stiffness K_nb, N/m² (C7).
    pub bond_stiffness: f64,
    /// Bond exponent p_b.
    pub bond_exponent: f64,
    /// Tangential bond stiffness K_rb (force K_rb |Δv_τ| A Δt).
    pub bond_tangential: f64,
    /// Bonding strain ε*: a pair bonds once its overlap strain δ/(R_i+R_j) reaches it. Not
    /// given by the source; 0.05 (a forceful impact, five per cent of the pair's radii sum).
    pub bond_strain: f64,
}

/// What the near-field coefficients scale with (C8, Zohdi 2016 Eq. (7.23) readings (a)–(d)):
/// α_k = ᾱ_k w_i w_j with w the particle's mass, surface area, volume or charge magnitude.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NearFieldBasis {
    /// w = m = ρ 4/3 π R³, kg (ᾱ in N·m^β/kg²).
    Mass,
    /// w = a = 4π R², m² (ᾱ in N·m^β/m⁴).
    Area,
    /// w = V = 4/3 π R³, m³ (ᾱ in N·m^β/m⁶).
    Volume,
    /// w = |q| = |q/m| m, C (ᾱ in N·m^β/C²).
    Charge,
}

/// Arithmetic of the exact all-pairs near-field sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NearFieldPrecision {
    /// Single precision wherever its error is bounded below 10⁻³ (the all-pairs sum with
    /// β = (1, 2) over a cloud at most [`super::single::EXTENT_LIMIT`] diameters across,
    /// decided at each evaluation), double precision elsewhere (the default).
    Auto,
    /// Double precision: the exact sum to round-off.
    Double,
    /// Single-precision lanes with double-precision tile sums at any extent: force error of
    /// order 10⁻⁷ of the exact sum on the source's clouds, about half its cost (β = (1, 2),
    /// no cut-off or tree).
    Single,
}

/// Near-field law (C8): α_k = ᾱ_k w_i w_j (times c_i c_j with the charge-sign factor).
#[derive(Debug, Clone, PartialEq)]
pub struct NearFieldParams {
    /// What α scales with (C8 readings (a)–(d)).
    pub basis: NearFieldBasis,
    /// Whether α carries the source's sign identifier c_i c_j (c = ±1 the charge sign), so
    /// that the law flips for unlike charges (C8). Off: the spec's reading, the same α for
    /// every pair.
    pub charge_sign: bool,
    /// ᾱ1, N·m^{β1}/kg² (attraction).
    pub attraction: f64,
    /// β1.
    pub attraction_exponent: f64,
    /// ᾱ2, N·m^{β2}/kg² (repulsion).
    pub repulsion: f64,
    /// β2.
    pub repulsion_exponent: f64,
    /// Cut-off distance, m; 0 means none. The 1/r attraction is long-ranged, so a cut-off
    /// drops most of the collective pull (measured in tests/blast_interactions.rs).
    pub cutoff: f64,
    /// Barnes–Hut opening angle θ (cells with size < θ · distance act from their centre of
    /// mass); 0 means the exact all-pairs sum (the default).
    pub theta: f64,
    /// Arithmetic of the all-pairs sum (theta 0, no cut-off).
    pub precision: NearFieldPrecision,
}

/// Time stepping (C9, C10).
#[derive(Debug, Clone, PartialEq)]
pub struct StepParams {
    /// Integrator.
    pub integrator: Integrator,
    /// Fixed step of the explicit schemes, s.
    pub dt: f64,
    /// Initial step Δt_0 of the trapezoidal scheme, s.
    pub dt_initial: f64,
    /// Step cap Δt_max, s.
    pub dt_max: f64,
    /// Trapezoidal weight φ ∈ [0, 1].
    pub phi: f64,
    /// Desired iteration count K_d.
    pub iterations: usize,
    /// Relative tolerance TOL of the fixed-point iteration.
    pub tolerance: f64,
    /// Smallest step before the run is declared failed, s.
    pub dt_min: f64,
}

/// Everything one blast run needs.
#[derive(Debug, Clone, PartialEq)]
pub struct BlastParams {
    /// Magnetic flux density |B| along `field_direction`, T (uniform, static; may be 0).
    pub field_strength: f64,
    /// Unit vector of B (also the axis of the "along B" observables when B = 0).
    pub field_direction: Vector3<f64>,
    /// Electric field strength along `electric_direction`, V/m (uniform, static).
    pub electric_strength: f64,
    /// Unit vector of E; None: along B.
    pub electric_direction: Option<Vector3<f64>>,
    /// Charge per mass q/m, C/kg.
    pub charge_per_mass: f64,
    /// Fraction of particles with the opposite charge sign (0 = all of one sign).
    pub negative_fraction: f64,
    /// Detonation energy W, J (C1).
    pub energy: f64,
    /// Number of particles N.
    pub particles: usize,
    /// Particle radius R, m.
    pub radius: f64,
    /// Particle density ρ, kg/m³.
    pub density: f64,
    /// Initial cloud radius R_0, m.
    pub cloud_radius: f64,
    /// Air density ρ_a, kg/m³.
    pub air_density: f64,
    /// Air viscosity μ_f, Pa·s.
    pub air_viscosity: f64,
    /// Drag law.
    pub drag: DragLaw,
    /// Constant C_D of the quadratic law.
    pub drag_coefficient: f64,
    /// Duration, s.
    pub duration: f64,
    /// Number of series samples over the duration (plus t = 0).
    pub samples: usize,
    /// Interaction terms.
    pub interactions: Interactions,
    /// Contact constants.
    pub contact: ContactParams,
    /// Near-field constants.
    pub near_field: NearFieldParams,
    /// Time stepping.
    pub step: StepParams,
    /// Wanted aspect ratio of the `shape_error` metric.
    pub target_aspect_ratio: f64,
    /// Wanted turning radius of the `turning_radius_error` metric, m (Zohdi 2016 Eq. (2.6)).
    pub target_turning_radius: f64,
    /// Wanted equatorial radius (semi-axis across B) of `equatorial_error`, m.
    pub target_equatorial_radius: f64,
    /// Terminal-state stop: the run ends at the first sample where the kinetic energy is at
    /// most this fraction of its initial value (0: run the whole duration, the time budget).
    pub stop_energy_fraction: f64,
}

impl BlastParams {
    /// The source's non-interacting example: B = (10, 0, 0) T, E = 0, 10 C/kg, 1 s with
    /// Δt = 1e-4 s, W = 10 kJ, ρ_a = 1.225 kg/m³, R_0 = 1 m, N = 2000, R = 0.05 m,
    /// ρ = 7000 kg/m³; Chow's drag law; the interacting constants of the spec's example.
    pub fn source_example() -> Self {
        Self {
            field_strength: 10.0,
            field_direction: Vector3::x(),
            electric_strength: 0.0,
            electric_direction: None,
            charge_per_mass: 10.0,
            negative_fraction: 0.0,
            energy: 1e4,
            particles: 2000,
            radius: 0.05,
            density: 7000.0,
            cloud_radius: 1.0,
            air_density: 1.225,
            air_viscosity: 1.8e-5,
            drag: DragLaw::Chow,
            drag_coefficient: 0.5,
            duration: 1.0,
            samples: 50,
            interactions: Interactions::default(),
            contact: ContactParams {
                stiffness: 1e7,
                exponent: 2.0,
                softening_rate: 1.0,
                temperature: 300.0,
                reference_temperature: 500.0,
                stiffness_floor: 1e6,
                damping: 1e5,
                friction_stiffness: 1e7,
                static_friction: 0.4,
                dynamic_friction: 0.3,
                bond_stiffness: 1e6,
                bond_exponent: 2.0,
                bond_tangential: 1e3,
                bond_strain: 0.05,
            },
            near_field: NearFieldParams {
                basis: NearFieldBasis::Mass,
                charge_sign: false,
                attraction: 0.5,
                attraction_exponent: 1.0,
                repulsion: 0.01,
                repulsion_exponent: 2.0,
                cutoff: 0.0,
                theta: 0.0,
                precision: NearFieldPrecision::Auto,
            },
            step: StepParams {
                integrator: Integrator::Auto,
                dt: 1e-4,
                dt_initial: 1e-5,
                dt_max: 2.5e-4,
                phi: 0.5,
                iterations: 10,
                tolerance: 5e-4,
                dt_min: 1e-12,
            },
            target_aspect_ratio: 2.0,
            target_turning_radius: 0.1,
            target_equatorial_radius: 1.0,
            stop_energy_fraction: 0.0,
        }
    }

    /// The integrator actually used.
    pub fn integrator(&self) -> Integrator {
        match self.step.integrator {
            Integrator::Auto if self.interactions.any() => Integrator::Trapezoidal,
            Integrator::Auto => Integrator::Boris,
            other => other,
        }
    }

    /// Mass of one particle m = ρ 4/3 π R³, kg.
    pub fn particle_mass(&self) -> f64 {
        self.density * 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }

    /// Unit vector along B: the axis of "along B" observables.
    pub fn field_axis(&self) -> Vector3<f64> {
        self.field_direction
    }

    /// B, T.
    pub fn field(&self) -> Vector3<f64> {
        self.field_direction * self.field_strength
    }

    /// E, V/m.
    pub fn electric_field(&self) -> Vector3<f64> {
        self.electric_direction.unwrap_or(self.field_direction) * self.electric_strength
    }

    /// Checks the values against each other (each one's own range is part of its declaration
    /// in `study.rs`); the error names the fields and what is allowed.
    pub fn validate(&self) -> Result<()> {
        let vectors = [
            ("field", self.field()),
            ("electric_field", self.electric_field()),
        ];
        for (name, v) in vectors {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(Error::input(format!("{name}: {v:?} is not finite")));
            }
        }
        let n = &self.near_field;
        let s = &self.step;
        if n.cutoff > 0.0 && n.theta > 0.0 {
            return Err(Error::input(format!(
                "near_field_cutoff {} m and near_field_theta {}: choose one (the other must be 0)",
                n.cutoff, n.theta
            )));
        }
        let all_pairs = n.cutoff == 0.0 && n.theta == 0.0;
        let source_exponents = (n.attraction_exponent, n.repulsion_exponent) == (1.0, 2.0);
        if n.precision == NearFieldPrecision::Single && !(all_pairs && source_exponents) {
            return Err(Error::input(format!(
                "near_field_precision single with near_field_cutoff {} m, near_field_theta {}, \
                 exponents ({}, {}): single precision is for the all-pairs sum (cut-off 0, \
                 theta 0) with the source's exponents (1, 2)",
                n.cutoff, n.theta, n.attraction_exponent, n.repulsion_exponent
            )));
        }
        let fewest_step = if self.interactions.any() || s.integrator == Integrator::Trapezoidal {
            s.dt_max
        } else {
            s.dt
        };
        if self.duration / fewest_step > MAX_STEPS {
            return Err(Error::input(format!(
                "duration {} s with steps of {} s needs {:.1e} steps (allowed: at most {MAX_STEPS:.0e}); use a longer step or a shorter duration",
                self.duration,
                fewest_step,
                self.duration / fewest_step
            )));
        }
        if n.theta > 0.0 && n.charge_sign && self.negative_fraction > 0.0 {
            return Err(Error::input(format!(
                "near_field_theta {} with near_field_sign charge and negative_fraction {}: the \
                 Barnes–Hut tree sums like charges only; use the exact sum (theta 0)",
                n.theta, self.negative_fraction
            )));
        }
        if s.dt_initial > s.dt_max {
            return Err(Error::input(format!(
                "dt_initial: {} s is not allowed (need ≤ dt_max = {} s)",
                s.dt_initial, s.dt_max
            )));
        }
        if self.interactions.any() && matches!(s.integrator, Integrator::Boris | Integrator::Euler)
        {
            return Err(Error::input(format!(
                "integrator: {:?} is for the non-interacting model only (interactions: {}); use trapezoidal or auto",
                s.integrator,
                self.interactions.label()
            )));
        }
        check_packing(self)
    }
}

/// Rejects a cloud that cannot hold its particles: centres must lie within R_0 − R and the
/// volume fraction N R³/(R_0 − R)³ must stay below [`MAX_VOLUME_FRACTION`].
pub fn check_packing(params: &BlastParams) -> Result<()> {
    let room = params.cloud_radius - params.radius;
    let fraction = params.particles as f64 * (params.radius / room).powi(3);
    if room <= 0.0 || fraction.is_nan() || fraction > MAX_VOLUME_FRACTION {
        return Err(Error::input(format!(
            "cloud too small for its particles: {} spheres of radius {} m in a cloud of radius {} m \
             (volume fraction {:.3}; need R < R_0 and N R³/(R_0 − R)³ ≤ {MAX_VOLUME_FRACTION})",
            params.particles,
            params.radius,
            params.cloud_radius,
            if room > 0.0 { fraction } else { f64::INFINITY }
        )));
    }
    Ok(())
}
