//! Stages 1–3 of a run (spec align.md, "Stages"): random start, overlap removal, settling.
//! The result, one `Packing` per replicate seed, serves every field, friction and pressure
//! (common random numbers).
//!
//! Both stages are overdamped gradient flows (v = F/γ, forward Euler, no friction): numerical
//! devices whose product is a valid resting packing, not physics that is measured. The step is
//! adaptive: dt = 0.9 / max_i Σ_c k_c (explicit stability of the stiffest particle, Gershgorin)
//! and no particle moves more than 0.05 R_av per step.
//! - Overlap removal: harmonic repulsion F = δ until the largest overlap < `overlap_tolerance`.
//! - Settling: Hertz contacts plus a downward `settling_force` until no particle moves faster
//!   than `rest_speed` × the free-fall speed; then the force is switched off and the overlaps
//!   relax under Hertz repulsion until the largest is below `overlap_tolerance`.

use nalgebra::{UnitQuaternion, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;

use super::contacts::{ContactLaw, ContactSet, Container};
use crate::models::align::params::PackingParams;
use crate::neighbor::NeighborList;
use crate::rng::{run_stream, Purpose};

/// Largest displacement of any particle in one packing step, R_av.
const MAX_MOVE: f64 = 0.05;
/// Neighbour-list skin, R_av.
const SKIN: f64 = 0.3;
/// Step cap per packing stage (reported as a failure if hit).
const MAX_STEPS: usize = 2_000_000;

/// A settled packing in reduced units (length R_av).
#[derive(Debug, Clone)]
pub struct Packing {
    /// Reduced radii R_i / R_av.
    pub radius: Vec<f64>,
    /// Centres.
    pub position: Vec<Vector3<f64>>,
    /// Orientations; easy axis n = q · ẑ, isotropic.
    pub orientation: Vec<UnitQuaternion<f64>>,
    /// The die (open top).
    pub container: Container,
    /// Steps taken by overlap removal and settling (diagnostics).
    pub steps: [usize; 3],
}

impl Packing {
    /// Runs stages 1–3 for one seed. Errors (a stage that does not finish) are returned as a
    /// reason string: the caller records a failed run.
    pub fn generate(params: &PackingParams, seed: u64) -> Result<Self, String> {
        let radius = sample_radii(params, seed);
        let solid: f64 = radius.iter().map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)).sum();
        let side = (solid / 0.6).cbrt().max(2.0 * radius.iter().cloned().fold(0.0, f64::max));
        let mut packing = Self {
            position: sample_positions(&radius, side, seed),
            orientation: sample_orientations(radius.len(), seed),
            radius,
            container: Container { lx: side, ly: side, top: Some(3.0 * side) },
            steps: [0; 3],
        };
        let law = ContactLaw {
            effective_modulus: 1.0 / (2.0 * (1.0 - params.poisson_ratio.powi(2))),
            friction: 0.0,
            wall_friction: 0.0,
            skin: SKIN,
        };
        let n = &params.numerics;
        packing.steps[0] = packing.flow(&law, Repulsion::Harmonic, 0.0, |s| s.max_overlap < n.overlap_tolerance)?;
        let f = n.settling_force;
        packing.steps[1] =
            packing.flow(&law, Repulsion::Hertz, f, |s| s.steps > 10 && s.max_speed < n.rest_speed * f)?;
        packing.container.top = None;
        packing.steps[2] = packing.flow(&law, Repulsion::Hertz, 0.0, |s| s.max_overlap < n.overlap_tolerance)?;
        Ok(packing)
    }

    /// A quick stand-in packing for benchmarks: a simple cubic lattice (spacing 2 r_max plus a
    /// 1 % gap, columns as tall as the die is wide), sizes and orientations drawn as in
    /// `generate`. Not a physical powder: use `generate` for results.
    pub fn lattice(params: &PackingParams, seed: u64) -> Self {
        let radius = sample_radii(params, seed);
        let spacing = 2.02 * radius.iter().cloned().fold(0.0, f64::max);
        let per_side = (params.particles as f64).cbrt().ceil() as usize;
        let per_layer = per_side * per_side;
        let position = (0..params.particles)
            .map(|k| {
                let (layer, cell) = (k / per_layer, k % per_layer);
                let at = |i: usize| (i as f64 + 0.5) * spacing;
                Vector3::new(at(cell % per_side), at(cell / per_side), at(layer))
            })
            .collect();
        let side = per_side as f64 * spacing;
        Self {
            position,
            orientation: sample_orientations(params.particles, seed),
            radius,
            container: Container { lx: side, ly: side, top: None },
            steps: [0; 3],
        }
    }

    /// Overdamped gradient flow until `done`; returns the step count.
    fn flow(
        &mut self,
        law: &ContactLaw,
        repulsion: Repulsion,
        down_force: f64,
        done: impl Fn(&FlowStatus) -> bool,
    ) -> Result<usize, String> {
        let n = self.radius.len();
        let mut list = NeighborList::new(SKIN);
        let mut contacts = ContactSet::default();
        let mut velocity = vec![Vector3::zeros(); n];
        for step in 0..MAX_STEPS {
            list.update(&self.position, &self.radius);
            contacts.rebuild(&self.position, &self.radius, &list, &self.container, law);
            let mut max_stiffness: f64 = 0.0;
            let mut max_speed: f64 = 0.0;
            for (i, v) in velocity.iter_mut().enumerate() {
                let mut force = Vector3::new(0.0, 0.0, -down_force);
                let mut stiffness = 0.0;
                for c in contacts.of(i) {
                    let (f, k) = repulsion.force_and_stiffness(c);
                    force -= f * c.normal;
                    stiffness += k;
                }
                *v = force;
                max_stiffness = max_stiffness.max(stiffness);
                max_speed = max_speed.max(force.norm());
            }
            if !max_speed.is_finite() {
                return Err("packing: non-finite velocity (numerical blow-up)".into());
            }
            let status = FlowStatus { steps: step, max_overlap: contacts.max_overlap(), max_speed };
            if done(&status) {
                return Ok(step);
            }
            let dt = (0.9 / max_stiffness.max(1e-300)).min(MAX_MOVE / max_speed.max(1e-300));
            for (p, v) in self.position.iter_mut().zip(&velocity) {
                *p += dt * v;
            }
        }
        Err(format!("packing: a stage did not finish within {MAX_STEPS} steps"))
    }
}

/// What a flow stage's stop rule sees.
struct FlowStatus {
    steps: usize,
    max_overlap: f64,
    max_speed: f64,
}

#[derive(Clone, Copy)]
enum Repulsion {
    /// F = δ (overlap removal: bounded, soft).
    Harmonic,
    /// The material's Hertz law.
    Hertz,
}

impl Repulsion {
    fn force_and_stiffness(self, c: &super::contacts::Contact) -> (f64, f64) {
        match self {
            Repulsion::Harmonic if c.overlap > 0.0 => (c.overlap, 1.0),
            Repulsion::Harmonic => (0.0, 0.0),
            Repulsion::Hertz => (c.normal_force_at(c.overlap), c.stiffness_at(c.overlap)),
        }
    }
}

/// Log-normal radii with mean 1 (D_av is the mean diameter): r = exp(σ z − σ²/2).
fn sample_radii(params: &PackingParams, seed: u64) -> Vec<f64> {
    let mut rng = run_stream(seed, Purpose::Sizes);
    let s = params.diameter_sigma;
    (0..params.particles)
        .map(|_| {
            let z: f64 = rng.sample(StandardNormal);
            (s * z - 0.5 * s * s).exp()
        })
        .collect()
}

/// Uniform random centres in the initial box (container side × 3 × side high).
fn sample_positions(radius: &[f64], side: f64, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = run_stream(seed, Purpose::Positions);
    radius
        .iter()
        .map(|&r| {
            let span = (side - 2.0 * r).max(0.0);
            Vector3::new(
                r + span * rng.random::<f64>(),
                r + span * rng.random::<f64>(),
                r + (3.0 * side - 2.0 * r) * rng.random::<f64>(),
            )
        })
        .collect()
}

/// Uniformly random rotations (Shoemake's method), hence isotropic easy axes.
fn sample_orientations(n: usize, seed: u64) -> Vec<UnitQuaternion<f64>> {
    let mut rng = run_stream(seed, Purpose::Orientations);
    (0..n)
        .map(|_| {
            let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
            let tau = 2.0 * std::f64::consts::PI;
            let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                a * (tau * u2).sin(),
                a * (tau * u2).cos(),
                b * (tau * u3).sin(),
                b * (tau * u3).cos(),
            ))
        })
        .collect()
}
