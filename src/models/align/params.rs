//! Parameters of one `align` run (spec align.md), SI units, with the documented defaults of the
//! source's setup, and the reduced unit system the DEM integrates in.

use serde::Serialize;

use crate::materials::Material;
use crate::{Error, Result};

/// How the pressure P is applied to the bed (spec align.md, "Pressure").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PressureMode {
    /// A rigid flat lid on the bed, pushed down by P L_x L_y and overdamped like a particle
    /// (drag γ), in contact with the particles like a wall: the die press itself.
    Punch,
    /// Each particle with no sphere above it gets π R² P downward (Σ π R² ≈ L_x L_y).
    ExposedLayer,
    /// The source's literal rule: particles with centre z > 0.9 z_max get π R² P each.
    SourceLayer,
}

/// Which Stoner–Wohlfarth branch a particle's moment follows (spec align.md, "Magnetic moment").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum MomentBranch {
    /// The global energy minimum, between the easy axis and the field: every moment is taken
    /// to have switched toward H at once (exact for h above the astroid, h ≥ 1).
    GlobalMinimum,
    /// Hysteresis: each moment starts along its body axis n = q·ẑ, which is isotropic, so the
    /// powder starts demagnetized (random ± along the axis, reproducible by the seed); a moment
    /// pointing away from H stays on its metastable branch until the field exceeds the
    /// switching field h_sw of its current angle, then switches for good.
    Metastable,
}

/// How the Coulomb friction (A5) enters the velocities (spec align.md, A5; issue 12 item 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum FrictionScheme {
    /// Regularized and solved implicitly with the velocities (the convex velocity problem).
    Implicit,
    /// The source's Eq. (8): the unregularized Coulomb force from the previous iterate's
    /// relative velocity, applied as a fixed force (no implicit solve).
    SourceExplicit,
    /// The unregularized law (v_ε = 0) solved implicitly: the convex but nonsmooth velocity
    /// problem by projected Gauss–Seidel on the contacts' friction forces.
    CoulombLimit,
}

/// How the three packing stages move the particles (spec align.md, "Stages"; issue 12 item 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum SettlingScheme {
    /// FIRE minimization under an equal settling force on every particle (a numerical device).
    Fire,
    /// The source's (§2.1, §2.3, §3): overdamped motion γ v = F by Heun's method, the spheres
    /// "dropped" by a force proportional to their mass (R³; its mean is the settling force).
    SourceDropped,
}

/// How the loaded bed is released when the settling force is switched off (spec align.md,
/// stage 3: "the device is switched off and overlaps relax").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ReleaseScheme {
    /// The overlaps relax by the model's own inertia-free motion γ ẋ = F (Eq. A6 without the
    /// settling force): backward-Euler steps of `release_step`/k_max, each solved by conjugate
    /// gradients (docs/align.md, "The release"). The default.
    Overdamped,
    /// FIRE minimization straight from the loaded bed (the default until 2026-12-03): its
    /// inertia carries the springing-back bed past jamming, and how many contacts survive is
    /// chance (results/bench/README.md, "The released bed").
    Inertial,
}

/// Which statistic of the net forces the settling rest criterion compares with `rest_speed` ×
/// the settling force (spec align.md, stage 3: "come to rest").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum RestMeasure {
    /// The largest net force: every particle at rest. Its settling cost grows faster than N
    /// (results/bench/README.md): the bed keeps rearranging in small events somewhere, and the
    /// chance that none is under way at a given step falls with N.
    Max,
    /// The root-mean-square net force: the bed at rest on average (intensive, any N).
    Rms,
}

/// Numerical choices left open by the spec, each a named parameter with a tested default.
#[derive(Debug, Clone, Serialize)]
pub struct Numerics {
    /// Largest rotation of the fastest free particle in one alignment step, rad. Sets the
    /// alignment time step (contacts are implicit, so stiffness does not limit it). 0.05 rad.
    pub rotation_step: f64,
    /// Friction regularization v_ε as a fraction of the fastest magnetic surface speed
    /// R ω_max: |F_t| = μ F_n |v_t| / √(|v_t|² + v_ε²). 1e-2 (τ_0.95 within 0.3 % of 1e-3).
    pub friction_regularization: f64,
    /// Gauss–Seidel stops when no velocity changes by more than this fraction of the magnetic
    /// surface-speed scale in one sweep. 1e-4 (τ within 0.02 % of 1e-6).
    pub solver_tolerance: f64,
    /// Cap on Gauss–Seidel sweeps per velocity solve (reported when hit). 200.
    pub max_sweeps: usize,
    /// How friction enters the velocities: implicit (default) or the source's explicit Eq. (8).
    pub friction_scheme: FrictionScheme,
    /// From this many particles on, the velocity sweeps run in parallel inside a run (coloured
    /// cells; the result is the same at any thread count). 1000 (results/bench/README.md:
    /// the alignment 1.4–1.6× faster at N = 1000–3000 on 2 threads than from 4000).
    pub parallel_from: usize,
    /// How the packing stages move the particles: FIRE (default) or the source's overdamped drop.
    pub settling_scheme: SettlingScheme,
    /// Settling force per particle (stage 3), in units of E R_av². A numerical device: real
    /// gravity is ~1e-12 of the contact scale and would never settle the bed. 1e-3.
    pub settling_force: f64,
    /// Settling ends when the particles (`rest_measure`: the largest or the root-mean-square
    /// net force) move slower than this fraction of the free-fall speed of the settling force.
    /// 1e-2.
    pub rest_speed: f64,
    /// The force statistic of the rest criterion: `rms` (the bed at rest on average; its cost
    /// grows like the bed height) or `max` (every particle at rest; the cost explodes with N).
    /// Both give the same packing fraction within 1/4 of the gap between two seeds, and so does
    /// rms at 3e-3 (test `settled_packing_fraction_converges_in_the_rest_criterion`). rms.
    pub rest_measure: RestMeasure,
    /// How the loaded bed is released after settling (FIRE settling only; the source's
    /// scheme relaxes by its own overdamped Heun steps). Overdamped, as the model moves (Eq.
    /// A6): every seed keeps its contact network, where the inertial release (FIRE, the
    /// default until 2026-12-03) keeps it or loses it by chance (τ_0.95 about 13 % shorter on
    /// average at N = 1000). Its cost grows about as the bed height to the 1.8th power
    /// (results/bench/README.md, "An overdamped release").
    pub release_scheme: ReleaseScheme,
    /// The overdamped release's backward-Euler step in units of 1/k_max (k_max: the largest
    /// summed contact stiffness of a particle at the step's start; γ = 1). A numerical device
    /// of the path: at N = 1000 (8 paired seeds) 10³ gives τ_0.95 within 0.23 ± 0.31 s of the
    /// plain overdamped relaxation (Heun steps of 0.8/k_max); with FIRE solving each step,
    /// 10⁴ gave 0.08 ± 0.27 s, 10⁵ 0.26 ± 0.13 s above it, and 10⁶ fell back to the inertial
    /// kind of bed (results/bench/README.md, "An overdamped release"). From
    /// `large_bed_from` particles on, h is also at most 0.05 R_av / F_max (F_max the largest
    /// net force at the step's start), which shortens the loaded bed's first steps
    /// (results/bench/README.md, "The release's early steps"). 10³.
    pub release_step: f64,
    /// From `large_bed_from` particles on, each backward-Euler step of the overdamped release
    /// is solved until its largest net force is below this fraction of its value at the
    /// step's start; smaller beds solve to 10⁻². A numerical device of the path: over 8
    /// paired seeds at N = 1000 0.1 moves τ_0.95 by −0.04 ± 0.13 s and 0.3 by −0.25 ± 0.21 s
    /// (seed sd 1.2 s), and at N = 10⁴ 0.1 takes 1.7× fewer release force evaluations
    /// (results/bench/README.md, "The release's solves"). 0.1.
    pub release_reduction: f64,
    /// Overlap removal (stage 2) and relaxation after settling end when the largest overlap is
    /// below this fraction of R_av. 1e-5.
    pub overlap_tolerance: f64,
    /// From this many particles on, the random start is numbered in cell order (z slowest,
    /// cells one mean diameter wide) before it moves, so that neighbours lie near each other
    /// in memory. Radii, centres and orientations are drawn independently, so the renumbering
    /// leaves the ensemble of packings the same; a run's bits change (summation order). A
    /// settling step 1.0–1.3× and an alignment step 1.1–1.5× faster at N = 1e4, 1.25× and
    /// 1.18× at 3e4 on 2 threads (results/bench/README.md, "Particle order"). From the same
    /// size on, the alignment stage numbers the settled packing in its Gauss–Seidel order
    /// (colour by colour, cell by cell), so that each sweep reads the particles' own data in
    /// memory order; its frames name the particles by their index in the packing
    /// (results/bench/README.md, "The alignment stage in sweep order"). 10 000: every shipped
    /// result (N ≤ 2000) keeps its packings and its bits.
    pub cell_order_from: usize,
    /// FIRE's time-step cap in the settling stage, in units of 1/√k_max (k_max: the largest
    /// summed contact stiffness of a particle; stable below √2), from `large_bed_from`
    /// particles on; smaller beds and the other packing stages use 0.3. A numerical device
    /// of the path to rest. 1.0: at N = 1e4 settling ends in 2.5× fewer FIRE steps. Over 16
    /// paired seeds the loaded coordination, the packing fraction and the sticking fraction
    /// differ by less than one seed-to-seed sd, and τ_0.95 is 0.28 % higher, under half of
    /// it (results/bench/README.md, "A longer FIRE step for settling").
    pub settling_step: f64,
    /// FIRE's masses in the settling stage from `large_bed_from` particles on: each
    /// particle's summed contact stiffness over the largest, k_i/k_max, floored at this value
    /// (diagonal preconditioning: every particle, on soft contacts or stiff ones, relaxes on
    /// the same time scale, and the step bound √2/√k_max still holds, by Gershgorin on M⁻¹K).
    /// In (0, 1]; 1 gives unit masses. A numerical device of the path to rest. 0.05: at
    /// N = 1e4 settling ends in 1.41× fewer FIRE steps than with unit masses; over 16 paired
    /// seeds the packing fraction, τ and the sticking fraction differ by under 0.2 seed sd,
    /// the loaded coordination by 0.7; at N = 3e4 (4 seeds) τ_0.95 is 0.16 % higher, about
    /// half a seed sd (results/bench/README.md, "Stiffness-scaled masses for settling").
    pub settling_mass_floor: f64,
    /// From this many particles on, settling uses `settling_step` and the masses of
    /// `settling_mass_floor`; smaller beds use 0.3 and unit masses. 10 000: every shipped
    /// result (N ≤ 2000) keeps its packings.
    pub large_bed_from: usize,
}

impl Default for Numerics {
    fn default() -> Self {
        Self {
            rotation_step: 0.05,
            friction_regularization: 1e-2,
            solver_tolerance: 1e-4,
            max_sweeps: 200,
            friction_scheme: FrictionScheme::Implicit,
            parallel_from: 1000,
            settling_scheme: SettlingScheme::Fire,
            settling_force: 1e-3,
            rest_speed: 1e-2,
            rest_measure: RestMeasure::Rms,
            release_scheme: ReleaseScheme::Overdamped,
            release_step: 1e3,
            release_reduction: 0.1,
            overlap_tolerance: 1e-5,
            cell_order_from: 10_000,
            settling_step: 1.0,
            settling_mass_floor: 0.05,
            large_bed_from: 10_000,
        }
    }
}

/// The packing of one replicate depends only on these (common random numbers: every field,
/// friction and pressure reuses it).
#[derive(Debug, Clone, Serialize)]
pub struct PackingParams {
    /// Number of particles N (1000).
    pub particles: usize,
    /// Mean particle diameter D_av, m (1 µm). D_av is the *mean* of the log-normal law.
    pub mean_diameter: f64,
    /// σ of the underlying normal of ln D (0.10).
    pub diameter_sigma: f64,
    /// Young's modulus E of particles and walls, Pa.
    pub youngs_modulus: f64,
    /// Poisson ratio ν of particles and walls.
    pub poisson_ratio: f64,
    /// Numerical controls of the packing stages.
    pub numerics: Numerics,
}

/// Everything that determines one alignment run besides the seed.
#[derive(Debug, Clone, Serialize)]
pub struct AlignParams {
    /// The particle material.
    pub material: Material,
    /// Applied field H along +z, A/m.
    pub field: f64,
    /// Punch pressure P, Pa (0.5 atm).
    pub pressure: f64,
    /// How P is applied.
    pub pressure_mode: PressureMode,
    /// Which Stoner–Wohlfarth branch the moments follow (global minimum).
    pub moment_branch: MomentBranch,
    /// Coulomb friction coefficient μ between particles (0.2).
    pub friction: f64,
    /// Friction coefficient between particles and walls (default: μ).
    pub wall_friction: f64,
    /// Number of particles N (1000).
    pub particles: usize,
    /// Mean diameter D_av, m (1 µm).
    pub mean_diameter: f64,
    /// σ of ln D (0.10).
    pub diameter_sigma: f64,
    /// Translational and rotational damping γ = γ*, N·s/m (20, the source's value).
    pub damping: f64,
    /// Target alignment degree x of τ_x (0.95).
    pub target: f64,
    /// Time limit of the alignment stage, s (a run not at the target by then is "not reached").
    pub max_time: f64,
    /// Numerical controls.
    pub numerics: Numerics,
}

impl AlignParams {
    /// The source's setup for a material and a field: N = 1000, D_av = 1 µm, σ = 0.10, μ = 0.2,
    /// P = 0.5 atm (exposed layer), γ = 20 N·s/m, x = 0.95, 20 000 s limit.
    pub fn paper_defaults(material: Material, field: f64) -> Self {
        Self {
            material,
            field,
            pressure: 0.5 * 101_325.0,
            pressure_mode: PressureMode::ExposedLayer,
            moment_branch: MomentBranch::GlobalMinimum,
            friction: 0.2,
            wall_friction: 0.2,
            particles: 1000,
            mean_diameter: 1e-6,
            diameter_sigma: 0.10,
            damping: 20.0,
            target: 0.95,
            max_time: 20_000.0,
            numerics: Numerics::default(),
        }
    }

    /// Checks every value; the error names the parameter, its value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.material.validate()?;
        check(self.field, "field", "≥ 0 A/m", |v| v >= 0.0)?;
        check(self.pressure, "pressure", "≥ 0 Pa", |v| v >= 0.0)?;
        check(self.friction, "friction", "≥ 0", |v| v >= 0.0)?;
        check(self.wall_friction, "wall friction", "≥ 0", |v| v >= 0.0)?;
        check(self.mean_diameter, "mean diameter", "> 0 m", |v| v > 0.0)?;
        check(self.diameter_sigma, "diameter sigma", "in [0, 1]", |v| {
            (0.0..=1.0).contains(&v)
        })?;
        check(self.damping, "damping", "> 0 N·s/m", |v| v > 0.0)?;
        check(self.target, "target", "in (0, 1)", |v| v > 0.0 && v < 1.0)?;
        check(self.max_time, "max time", "> 0 s", |v| v > 0.0)?;
        if self.particles == 0 {
            return Err(Error::input("particles: 0 is not allowed (need ≥ 1)"));
        }
        let n = &self.numerics;
        check(n.rotation_step, "rotation step", "in (0, 0.5] rad", |v| {
            v > 0.0 && v <= 0.5
        })?;
        check(
            n.friction_regularization,
            "friction regularization",
            "in (0, 1]",
            |v| v > 0.0 && v <= 1.0,
        )?;
        check(
            n.settling_step,
            "settling step",
            "in (0, √2) (FIRE's stable range)",
            |v| v > 0.0 && v < std::f64::consts::SQRT_2,
        )?;
        check(
            n.settling_mass_floor,
            "settling mass floor",
            "in (0, 1] (1: unit masses)",
            |v| v > 0.0 && v <= 1.0,
        )?;
        check(
            n.release_reduction,
            "release reduction",
            "in (0, 1) (a fraction of each step's starting force)",
            |v| v > 0.0 && v < 1.0,
        )?;
        check(
            n.release_step,
            "release step",
            "> 0 (in units of 1/k_max)",
            |v| v > 0.0,
        )?;
        Ok(())
    }

    /// Reduced field h = H/H_K.
    pub fn reduced_field(&self) -> f64 {
        self.field / self.material.anisotropy_field()
    }

    /// The packing-relevant part of these parameters.
    pub fn packing(&self) -> PackingParams {
        PackingParams {
            particles: self.particles,
            mean_diameter: self.mean_diameter,
            diameter_sigma: self.diameter_sigma,
            youngs_modulus: self.material.youngs_modulus,
            poisson_ratio: self.material.poisson_ratio,
            numerics: self.numerics.clone(),
        }
    }

    /// The reduced unit system of this run.
    pub fn scales(&self) -> Scales {
        Scales::new(
            self.mean_diameter,
            self.material.youngs_modulus,
            self.damping,
        )
    }
}

fn check(value: f64, name: &str, allowed: &str, ok: impl Fn(f64) -> bool) -> Result<()> {
    if value.is_finite() && ok(value) {
        Ok(())
    } else {
        Err(Error::input(format!(
            "{name}: {value} is not allowed ({allowed})"
        )))
    }
}

/// Reduced units: length R_av = D_av/2, force E R_av², time t_char = γ/(E R_av). In them the
/// translational drag coefficient is 1 and the rotational one of a particle of radius r is r².
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Scales {
    /// Length unit R_av, m.
    pub length: f64,
    /// Force unit E R_av², N.
    pub force: f64,
    /// Time unit t_char = γ/(E R_av), s.
    pub time: f64,
}

impl Scales {
    /// Scales for mean diameter D_av (m), Young's modulus E (Pa) and damping γ (N·s/m).
    pub fn new(mean_diameter: f64, youngs_modulus: f64, damping: f64) -> Self {
        let length = 0.5 * mean_diameter;
        Self {
            length,
            force: youngs_modulus * length * length,
            time: damping / (youngs_modulus * length),
        }
    }

    /// Stress unit E, Pa (force / length²).
    pub fn stress(&self) -> f64 {
        self.force / (self.length * self.length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;

    /// FIRE's settling step must lie in its stable range (0, √2), the settling masses'
    /// floor in (0, 1] and the release's reduction in (0, 1); the error names the value.
    #[test]
    fn a_settling_step_mass_floor_or_release_reduction_outside_its_range_is_refused() {
        let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        let defaults = AlignParams::paper_defaults(material, 0.0);
        assert!(defaults.validate().is_ok());
        type Setter = fn(&mut Numerics, f64);
        let cases: [(Setter, &str, [f64; 4]); 3] = [
            (
                |n, v| n.settling_step = v,
                "settling step",
                [0.0, -1.0, 1.5, f64::NAN],
            ),
            (
                |n, v| n.settling_mass_floor = v,
                "settling mass floor",
                [0.0, -0.1, 1.5, f64::NAN],
            ),
            (
                |n, v| n.release_reduction = v,
                "release reduction",
                [0.0, -0.1, 1.0, f64::NAN],
            ),
        ];
        for (set, name, bad_values) in cases {
            for bad in bad_values {
                let mut params = defaults.clone();
                set(&mut params.numerics, bad);
                let error = params.validate().unwrap_err().to_string();
                assert!(error.contains(name), "{name} {bad}: {error}");
            }
        }
    }
}
