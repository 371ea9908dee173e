//! Stages 1–3 of a run (spec align.md, "Stages"): random start, overlap removal, settling.
//! The result, one `Packing` per replicate seed, serves every field, friction and pressure
//! (common random numbers).
//!
//! Both stages minimize a potential energy (no friction) with FIRE, a standard relaxation
//! method for granular packings: numerical devices whose product is a valid resting packing, not
//! dynamics that are measured. Rest is judged by the net forces, which in the overdamped model
//! are the speeds the particles would move at (γ = 1 in reduced units).
//! - Overlap removal: harmonic repulsion F = δ until the largest overlap < `overlap_tolerance`.
//! - Settling: Hertz contacts plus a downward `settling_force` until the largest (or, with
//!   `rest_measure = rms`, the root-mean-square) net force is below `rest_speed` × the settling
//!   force (an overdamped particle would move slower than that fraction of its free-fall
//!   speed); then the force is switched off and the overlaps relax under Hertz repulsion until
//!   the largest is below `overlap_tolerance`: by default without inertia, as the model moves
//!   (`release_scheme = overdamped`: backward-Euler steps, each solved by conjugate gradients;
//!   `release`), or by FIRE straight from the loaded bed (`inertial`, the default until
//!   2026-12-03).
//!
//! FIRE's time step is capped at 0.3/√k_max in every stage, with unit masses, except settling
//! from `large_bed_from` particles on, which uses `settling_step` and masses proportional to
//! each particle's summed contact stiffness (floored at `settling_mass_floor` × k_max): the
//! tail of settling is limited by the cap and by the softly loaded particles, and the
//! packings agree within the seed-to-seed spread (results/bench/README.md, "A longer FIRE
//! step for settling", "Stiffness-scaled masses for settling").
//!
//! `settling_scheme = source-dropped` replaces FIRE by the source's own dynamics (§2.1, §2.3,
//! §3): the spheres move overdamped (γ v = F, Heun's method) in all three stages and are
//! "dropped" by a force proportional to their mass (R³, scaled so that its mean is the
//! settling force), the same stop rules ending each stage.

use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use rayon::prelude::*;

use super::contacts::{ContactLaw, Container};
use crate::models::align::params::{PackingParams, ReleaseScheme, RestMeasure, SettlingScheme};
use crate::neighbor::{NeighborList, Spread, SpreadWatch};
use crate::rng::{run_stream, Purpose};

mod hertz_lanes;
mod local;
mod newton;
mod release;
pub mod store;

use release::StepSolver;

/// Largest displacement of any particle in one packing step, R_av.
const MAX_MOVE: f64 = 0.05;
/// Neighbour-list skin of the release, R_av.
const SKIN: f64 = 0.3;
/// Neighbour-list skin of the FIRE stages (overlap removal, settling), R_av: their falling
/// bed rebuilds its list every few steps, and a wider skin trades rebuilds for listed pairs.
/// 0.4–0.5 settled N = 3·10⁴ in the same time, 1.11–1.15× faster than 0.3 and 1.04× faster
/// than 0.6 (results/bench/README.md, "The list search: a box fitted to each query, the hits
/// written at once, a wider skin for FIRE").
const FLOW_SKIN: f64 = 0.45;
/// Step cap per packing stage (reported as a failure if hit).
const MAX_STEPS: usize = 2_000_000;
/// The most particles one task of a force evaluation takes. The work per particle varies
/// along the bed (in cell order index ranges are z-slabs; a settling bed is dense below and
/// loose above), and the pool's default split, about two pieces per thread, left one thread
/// waiting on the other's slabs (results/bench/README.md, "FIRE's passes").
const EVALUATE_PIECE: usize = 256;
/// FIRE's time-step cap in units of 1/√k_max (k_max: the largest summed contact stiffness of a
/// particle, unit masses) in overlap removal and relaxation, and in settling below
/// `Numerics::large_bed_from` particles.
const FIRE_STEP: f64 = 0.3;
/// Below `Numerics::large_bed_from` particles, each backward-Euler step of the overdamped
/// release is solved until its largest net force (contacts plus anchor) is below this fraction
/// of its value at the step's start.
const STEP_REDUCTION: f64 = 1e-2;

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
    /// Steps taken by overlap removal, settling and the release (diagnostics; the overdamped
    /// release counts its force evaluations).
    pub steps: [usize; 3],
}

impl Packing {
    /// Runs stages 1–3 for one seed. Errors (a stage that does not finish) are returned as a
    /// reason string: the caller records a failed run.
    pub fn generate(params: &PackingParams, seed: u64) -> Result<Self, String> {
        Self::generate_counted(params, seed).map(|(packing, _)| packing)
    }

    /// [`Self::generate`] with what each stage's contact sums cost (benchmarks).
    pub fn generate_counted(
        params: &PackingParams,
        seed: u64,
    ) -> Result<(Self, [ContactWork; 3]), String> {
        let n = &params.numerics;
        let (mut packing, stages, mut work) = Self::loaded(params, seed)?;
        let overdamped = n.release_scheme == ReleaseScheme::Overdamped;
        (packing.steps[2], work[2]) = timed(|| match stages.settling.scheme {
            SettlingScheme::Fire if overdamped => {
                let solve = if packing.radius.len() >= n.large_bed_from {
                    (n.release_reduction, StepSolver::Newton)
                } else {
                    (STEP_REDUCTION, StepSolver::ConjugateGradients)
                };
                packing.release(&stages, n.release_step, solve, n.overlap_tolerance)
            }
            // the source's Heun steps are the overdamped motion itself
            _ => packing.flow(&stages.law, &stages.settling, stages.relax, |s| {
                s.max_overlap < n.overlap_tolerance
            }),
        })?;
        Ok((packing, work))
    }

    /// A loaded bed (`Self::loaded`) of `particles` Sr-ferrite spheres with the paper's
    /// defaults, for the release's tests.
    #[cfg(test)]
    fn loaded_for_tests(particles: usize, seed: u64) -> (Self, Stages) {
        let material = crate::materials::MaterialDb::builtin()
            .get("srfe12o19")
            .unwrap()
            .clone();
        let mut params = crate::models::align::AlignParams::paper_defaults(material, 0.0);
        params.particles = particles;
        let (bed, stages, _) = Self::loaded(&params.packing(), seed).unwrap();
        (bed, stages)
    }

    /// Stages 1 and 2 and the settling of stage 3: the bed still pressed by the settling
    /// force, the die open; with the forces the release uses.
    fn loaded(
        params: &PackingParams,
        seed: u64,
    ) -> Result<(Self, Stages, [ContactWork; 3]), String> {
        let mut packing = random_start(params, seed);
        let law = ContactLaw {
            effective_modulus: 1.0 / (2.0 * (1.0 - params.poisson_ratio.powi(2))),
            friction: 0.0,
            wall_friction: 0.0,
            // explicit forces: only touching pairs matter
            skin: 0.0,
        };
        let n = &params.numerics;
        let settling = Settling::new(n.settling_scheme, &packing.radius);
        let mut work = [ContactWork::default(); 3];
        let relax = Stage {
            repulsion: Repulsion::Hertz,
            down_force: 0.0,
            fire_step: FIRE_STEP,
            mass_floor: 1.0,
        };
        let remove = Stage {
            repulsion: Repulsion::Harmonic,
            ..relax
        };
        (packing.steps[0], work[0]) = timed(|| {
            packing.flow(&law, &settling, remove, |s| {
                s.max_overlap < n.overlap_tolerance
            })
        })?;
        let f = n.settling_force;
        let large = packing.radius.len() >= n.large_bed_from;
        let settle = Stage {
            down_force: f,
            fire_step: if large { n.settling_step } else { FIRE_STEP },
            mass_floor: if large { n.settling_mass_floor } else { 1.0 },
            ..relax
        };
        (packing.steps[1], work[1]) = timed(|| {
            packing.flow(&law, &settling, settle, |s| {
                let speed = match n.rest_measure {
                    RestMeasure::Max => s.max_force,
                    RestMeasure::Rms => s.rms_force,
                };
                s.steps > 10 && speed < n.rest_speed * f
            })
        })?;
        packing.container.top = None;
        let stages = Stages {
            law,
            settling,
            relax,
        };
        Ok((packing, stages, work))
    }

    /// The same particles numbered in `order` (a permutation of their indices): particle k
    /// is this one's `order[k]`.
    pub fn renumbered(&self, order: &[usize]) -> Self {
        Self {
            radius: permuted(&self.radius, order),
            position: permuted(&self.position, order),
            orientation: permuted(&self.orientation, order),
            ..*self
        }
    }

    /// Solid volume over the volume of the die up to the highest sphere top.
    pub fn packing_fraction(&self) -> f64 {
        packing_fraction(&self.radius, &self.position, &self.container)
    }

    /// The packing copied `tiles` × `tiles` times side by side in x and y, in a die as many
    /// times as long and as wide (copy after copy, each in this packing's order). The copies
    /// meet at the flat side walls, so the bed keeps this one's packing fraction and contacts
    /// per particle: a bed of N = tiles² n for measuring the alignment stage at sizes whose
    /// settling would take hours (`magopt bench align --tiles`).
    pub fn tiled(&self, tiles: usize) -> Self {
        let c = self.container;
        let copies = tiles * tiles;
        let offset =
            |k: usize| Vector3::new((k % tiles) as f64 * c.lx, (k / tiles) as f64 * c.ly, 0.0);
        Self {
            radius: self.radius.repeat(copies),
            position: (0..copies)
                .flat_map(|k| self.position.iter().map(move |p| p + offset(k)))
                .collect(),
            orientation: self.orientation.repeat(copies),
            container: Container {
                lx: c.lx * tiles as f64,
                ly: c.ly * tiles as f64,
                ..c
            },
            steps: self.steps,
        }
    }

    /// Moves the particles (FIRE, or overdamped Heun steps for the source's scheme) until
    /// `done`; returns the step count and what the contact sums cost.
    fn flow(
        &mut self,
        law: &ContactLaw,
        settling: &Settling,
        stage: Stage,
        done: impl Fn(&FlowStatus) -> bool,
    ) -> Result<(usize, ContactWork), String> {
        let n = self.radius.len();
        // the bed falls onto its settled floor: a list rebuilt on the displacements' spread
        // lasts twice as long then; the sums test each listed pair, so the bits are the same
        // (and the same at any skin)
        let mut list = NeighborList::rebuilt_on_spread(FLOW_SKIN);
        let mut force = vec![(Vector3::zeros(), 0.0, 0.0, 0); n];
        let mut stepper = match settling.scheme {
            SettlingScheme::Fire => Stepper::Fire(Fire::new(n, stage.fire_step, stage.mass_floor)),
            SettlingScheme::SourceDropped => Stepper::Heun {
                trial: vec![Vector3::zeros(); n],
                trial_force: force.clone(),
            },
        };
        let mut work = ContactWork::default();
        let loads = Loads {
            law,
            repulsion: stage.repulsion,
            settling,
            down_force: stage.down_force,
            radius: &self.radius,
        };
        // what the last FIRE step's moves saw for the list's rebuild check
        let mut seen = None;
        for step in 0..MAX_STEPS {
            let [max_force, max_stiffness, max_overlap] = loads.evaluate_seen(
                (&self.position, seen),
                &self.container,
                &mut list,
                &mut force,
                &mut work,
            );
            if !max_force.is_finite() {
                return Err("packing: non-finite force (numerical blow-up)".into());
            }
            // Σ |F|² in one pass with FIRE's other sums, not in a serial pass of its own
            // (results/bench/README.md, "FIRE's passes"); summed in `SUM_CHUNK` chunks, so
            // term by term as a serial sum up to that many particles
            let sums = match &stepper {
                Stepper::Fire(fire) => fire_sums(&fire.velocity, &force),
                Stepper::Heun { .. } => ordered_sums(n, |i| [0.0, 0.0, force[i].0.norm_squared()]),
            };
            let status = FlowStatus {
                steps: step,
                max_overlap,
                max_force,
                rms_force: (sums[2] / n as f64).sqrt(),
            };
            if done(&status) {
                return Ok((step, work));
            }
            match &mut stepper {
                Stepper::Fire(fire) => {
                    let watch = list.spread_watch(n);
                    let forces = (&force[..], sums);
                    seen = fire.step(&mut self.position, forces, max_stiffness, max_force, watch)
                }
                Stepper::Heun { trial, trial_force } => {
                    // explicit on γ ẋ = F: stable for dt λ ≤ 2, and λ ≤ 2 k_max (Gershgorin)
                    let dt = (0.8 / max_stiffness)
                        .min(10.0)
                        .min(MAX_MOVE / max_force.max(f64::MIN_POSITIVE));
                    trial
                        .par_iter_mut()
                        .zip(&self.position)
                        .zip(&force)
                        .for_each(|((t, x), f)| *t = x + dt * f.0);
                    loads.evaluate(
                        trial,
                        &self.container,
                        &mut list,
                        trial_force,
                        &mut work,
                        as_gathered,
                    );
                    self.position
                        .par_iter_mut()
                        .zip(&force)
                        .zip(&*trial_force)
                        .for_each(|((x, f0), f1)| *x += 0.5 * dt * (f0.0 + f1.0));
                }
            }
        }
        Err(format!(
            "packing: a stage did not finish within {MAX_STEPS} steps"
        ))
    }
}

/// The contact law, the settling scheme and the force-free stage that release a loaded bed.
struct Stages {
    law: ContactLaw,
    settling: Settling,
    relax: Stage,
}

impl Stages {
    /// The release's forces on particles of these radii: the relaxation's repulsion, no
    /// settling force.
    fn release_loads<'a>(&'a self, radius: &'a [f64]) -> Loads<'a> {
        Loads {
            law: &self.law,
            repulsion: self.relax.repulsion,
            settling: &self.settling,
            down_force: 0.0,
            radius,
        }
    }
}

/// How a packing stage pushes the particles down and moves them.
struct Settling {
    scheme: SettlingScheme,
    /// Each particle's share of the settling force: 1 (FIRE's device) or R³/⟨R³⟩ (a weight).
    share: Vec<f64>,
}

impl Settling {
    fn new(scheme: SettlingScheme, radius: &[f64]) -> Self {
        let share = match scheme {
            SettlingScheme::Fire => vec![1.0; radius.len()],
            SettlingScheme::SourceDropped => {
                let mean = radius.iter().map(|r| r.powi(3)).sum::<f64>() / radius.len() as f64;
                radius.iter().map(|r| r.powi(3) / mean).collect()
            }
        };
        Self { scheme, share }
    }
}

/// What one packing stage applies and how far FIRE may step.
#[derive(Clone, Copy)]
struct Stage {
    repulsion: Repulsion,
    /// Downward force per particle (its mean with the source's R³ shares), reduced units.
    down_force: f64,
    /// FIRE's step cap in units of 1/√k_max.
    fire_step: f64,
    /// FIRE's masses: k_i/k_max floored at this (1: unit masses).
    mass_floor: f64,
}

/// The stage's force law: contacts (in `repulsion`) plus the downward force.
struct Loads<'a> {
    law: &'a ContactLaw,
    repulsion: Repulsion,
    settling: &'a Settling,
    down_force: f64,
    radius: &'a [f64],
}

impl Loads<'_> {
    /// Every particle's load at `position` (one parallel gather; no contact list is stored),
    /// with `then` finishing each particle's load (the release's anchor; [`as_gathered`]
    /// elsewhere) before its largest values are taken; returns the largest net force, summed
    /// stiffness and overlap (exact at any thread count). Why one pass: the gather, the
    /// contact count and the largest values each cost a fork and a join on the pool, which on
    /// 2 threads cost more than the count and the maxima themselves (results/bench/README.md,
    /// "Two threads on an Intel Xeon VM").
    fn evaluate(
        &self,
        position: &[Vector3<f64>],
        container: &Container,
        list: &mut NeighborList<3>,
        force: &mut [Load],
        work: &mut ContactWork,
        then: impl Fn(usize, &mut Load) + Sync,
    ) -> [f64; 3] {
        let built = list.update(position, self.radius);
        self.gathered(position, container, list, (force, built), work, then)
    }

    /// [`Self::evaluate`] after moves that ran the list's spread watch over every particle
    /// and saw `seen` (None: no watch ran), with no `then`.
    fn evaluate_seen(
        &self,
        (position, seen): (&[Vector3<f64>], Option<Spread<3>>),
        container: &Container,
        list: &mut NeighborList<3>,
        force: &mut [Load],
        work: &mut ContactWork,
    ) -> [f64; 3] {
        let built = match seen {
            Some(seen) => list.update_seen(position, self.radius, seen),
            None => list.update(position, self.radius),
        };
        self.gathered(position, container, list, (force, built), work, as_gathered)
    }

    /// [`Self::evaluate`] on an up-to-date list (`built`: whether it was built for it).
    fn gathered(
        &self,
        position: &[Vector3<f64>],
        container: &Container,
        list: &NeighborList<3>,
        (force, built): (&mut [Load], bool),
        work: &mut ContactWork,
        then: impl Fn(usize, &mut Load) + Sync,
    ) -> [f64; 3] {
        let (largest, contacts) = force
            .par_iter_mut()
            .enumerate()
            .with_max_len(EVALUATE_PIECE)
            .map(|(i, slot)| {
                *slot = (
                    Vector3::new(0.0, 0.0, -self.down_force * self.settling.share[i]),
                    0.0,
                    0.0,
                    0,
                );
                let (law, radius, repulsion) = (self.law, self.radius, self.repulsion);
                match repulsion {
                    Repulsion::Hertz => {
                        hertz_lanes::add_particle_contacts(law, i, position, radius, list, slot)
                    }
                    Repulsion::Harmonic => {
                        law.particle_contacts_of(i, position, radius, list, |_, c| {
                            gather(repulsion, slot, &c)
                        })
                    }
                }
                law.wall_contacts_of(i, position, radius, container, |_, c| {
                    gather(repulsion, slot, &c)
                });
                then(i, slot);
                ([slot.0.norm(), slot.1, slot.2], slot.3 as usize)
            })
            .reduce(
                || ([0.0; 3], 0),
                |(a, m), (b, n)| ([0, 1, 2].map(|k| f64::max(a[k], b[k])), m + n),
            );
        work.add(list.len(), contacts, built);
        largest
    }
}

/// Adds contact `c`'s repulsion to a load: its force along the normal, its stiffness, its
/// overlap to the largest, and a particle contact to the count.
fn gather(repulsion: Repulsion, load: &mut Load, c: &super::contacts::Contact) {
    let (f, k) = repulsion.force_and_stiffness(c);
    load.0 -= f * c.normal;
    load.1 += k;
    load.2 = f64::max(load.2, c.overlap);
    load.3 += u32::from(c.particle().is_some());
}

/// A load as the contacts and the settling force make it (no anchor).
fn as_gathered(_: usize, _: &mut Load) {}

/// The packing stages' integrators.
enum Stepper {
    Fire(Fire),
    /// Heun's method on the overdamped motion (the source's §2.3), with its trial step.
    Heun {
        trial: Vec<Vector3<f64>>,
        trial_force: Vec<Load>,
    },
}

/// Solid volume of spheres (radius, centre) over the volume of the die up to the highest
/// sphere top.
pub fn packing_fraction(radius: &[f64], position: &[Vector3<f64>], container: &Container) -> f64 {
    let top = bed_top(position, radius);
    let solid: f64 = radius
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .sum();
    solid / (container.lx * container.ly * top)
}

/// Height of the highest sphere top (centre z + radius).
pub fn bed_top(position: &[Vector3<f64>], radius: &[f64]) -> f64 {
    position
        .iter()
        .zip(radius)
        .map(|(p, r)| p.z + r)
        .fold(0.0, f64::max)
}

/// Net force on a particle, its summed contact stiffness, its largest overlap and its number
/// of particle contacts.
type Load = (Vector3<f64>, f64, f64, u32);

/// What a packing stage's contact sums cost, summed over its force evaluations (benchmarks).
#[derive(Debug, Clone, Copy, Default)]
pub struct ContactWork {
    /// Force evaluations.
    pub evaluations: u64,
    /// Ordered neighbour-list entries (i, j) checked for contact: each unordered pair twice,
    /// the lists being full.
    pub list_entries: u64,
    /// Ordered touching particle pairs (i, j) whose contact force was evaluated: each contact
    /// twice, once from either side.
    pub contacts: u64,
    /// The ordered touching pairs of the last evaluation, at the stage's final positions:
    /// over N, the mean particle contacts per particle the stage ends with (overlap > 0).
    pub final_contacts: u64,
    /// The stage's wall time, s.
    pub seconds: f64,
    /// Neighbour-list builds in the stage's force evaluations (the Newton release's local
    /// corrections reuse the list of the evaluation before them).
    pub list_builds: u64,
    /// The Newton release's parts (zero in other stages and releases).
    pub newton: NewtonWork,
}

/// What the Newton release's parts cost (benchmarks: where its time goes without a profiler).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct NewtonWork {
    /// Newton steps.
    pub steps: u64,
    /// Linear conjugate-gradient iterations, over all Newton steps.
    pub linear_iterations: u64,
    /// Local corrections made (the calls that found the residual too spread to correct are
    /// not counted, their time is).
    pub corrections: u64,
    /// Particle visits of the local corrections.
    pub correction_visits: u64,
    /// Wall time storing the contact stiffnesses, s.
    pub linearize_s: f64,
    /// Wall time of the linear solves, s.
    pub solve_s: f64,
    /// Wall time of the local corrections (the force evaluations after them not included), s.
    pub corrections_s: f64,
}

/// A stage's (steps, work) with its wall time in the work.
fn timed(
    stage: impl FnOnce() -> Result<(usize, ContactWork), String>,
) -> Result<(usize, ContactWork), String> {
    let started = Instant::now();
    let (steps, mut work) = stage()?;
    work.seconds = started.elapsed().as_secs_f64();
    Ok((steps, work))
}

impl ContactWork {
    fn add(&mut self, list_entries: usize, contacts: usize, built: bool) {
        self.evaluations += 1;
        self.list_builds += u64::from(built);
        self.list_entries += list_entries as u64;
        self.contacts += contacts as u64;
        self.final_contacts = contacts as u64;
    }
}

/// FIRE, the fast inertial relaxation engine (Bitzek et al., PRL 97, 170201, 2006), with its
/// standard constants and masses m_i = max(k_i/k_max, `mass_floor`) (k_i: particle i's summed
/// contact stiffness; a floor of 1 gives unit masses). The step is capped by the stiffest
/// particle (dt ≤ `max_step`/√k_max, inside the explicit limit: by Gershgorin on M⁻¹K each
/// row sums to at most 2 k_i/m_i ≤ 2 k_max, so the step is stable below √2/√k_max) and by
/// `MAX_MOVE`.
struct Fire {
    velocity: Vec<Vector3<f64>>,
    dt: f64,
    alpha: f64,
    downhill: usize,
    /// The step cap in units of 1/√k_max.
    max_step: f64,
    /// The masses' floor in units of k_max (1: unit masses).
    mass_floor: f64,
}

impl Fire {
    const ALPHA0: f64 = 0.1;

    fn new(n: usize, max_step: f64, mass_floor: f64) -> Self {
        Self {
            velocity: vec![Vector3::zeros(); n],
            dt: 0.01,
            alpha: Self::ALPHA0,
            downhill: 0,
            max_step,
            mass_floor,
        }
    }

    /// One step from the forces `force` at `position`, `sums` their `fire_sums` with the
    /// velocities; returns what `watch` (a neighbour list's rebuild check) saw of the moved
    /// particles, in the same pass.
    fn step(
        &mut self,
        position: &mut [Vector3<f64>],
        (force, [power, v_squared, f_squared]): (&[Load], [f64; 3]),
        max_stiffness: f64,
        max_force: f64,
        watch: Option<SpreadWatch<3>>,
    ) -> Option<Spread<3>> {
        let floor = self.mass_floor;
        let mass = |f: &Load| (f.1 / max_stiffness).max(floor);
        let (v_norm, f_norm) = (v_squared.sqrt(), f_squared.sqrt());
        let dt_max = (self.max_step / max_stiffness.sqrt()).min(10.0);
        // the velocities' mix (or their reset) and the fastest trial speed in one pass
        let (keep, mix) = if power > 0.0 {
            let mix = self.alpha * v_norm / f_norm.max(f64::MIN_POSITIVE);
            let keep = 1.0 - self.alpha;
            self.downhill += 1;
            if self.downhill > 5 {
                self.dt = (1.1 * self.dt).min(dt_max);
                self.alpha *= 0.99;
            }
            (Some(keep), mix)
        } else {
            self.dt *= 0.5;
            self.alpha = Self::ALPHA0;
            self.downhill = 0;
            (None, 0.0)
        };
        let guess = self.dt;
        let speed = (self.velocity.par_iter_mut().zip(force))
            .map(|(v, f)| {
                *v = keep.map_or(Vector3::zeros(), |keep| keep * *v + mix * f.0);
                (*v + guess / mass(f) * f.0).norm()
            })
            .reduce(|| max_force * guess, f64::max);
        let dt = self
            .dt
            .min(dt_max)
            .min(MAX_MOVE / speed.max(f64::MIN_POSITIVE));
        // in pieces, each a plain loop that keeps what the watch saw in registers (an
        // iterator's map and reduce per particle made the pass slower than the walks saved)
        let seen = (position.par_chunks_mut(EVALUATE_PIECE))
            .zip(self.velocity.par_chunks_mut(EVALUATE_PIECE))
            .enumerate()
            .map(|(c, (x, v))| {
                let start = c * EVALUATE_PIECE;
                let f = &force[start..start + x.len()];
                let mut seen = Spread::none();
                for (k, ((x, v), f)) in x.iter_mut().zip(v).zip(f).enumerate() {
                    *v += dt / mass(f) * f.0;
                    *x += dt * *v;
                    if let Some(watch) = &watch {
                        watch.see(&mut seen, start + k, x);
                    }
                }
                seen
            })
            .reduce(Spread::none, Spread::merge);
        watch.map(|_| seen)
    }
}

/// Σ v·F, Σ |v|², Σ |F|² (the same at any thread count: `ordered_sums`).
fn fire_sums(velocity: &[Vector3<f64>], force: &[Load]) -> [f64; 3] {
    ordered_sums(velocity.len(), |i| {
        let (v, f) = (velocity[i], force[i].0);
        [v.dot(&f), v.norm_squared(), f.norm_squared()]
    })
}

/// The chunk of [`ordered_sums`] and [`ordered_update`]: their sums' order, so their bits.
const SUM_CHUNK: usize = 2048;

/// Adds K sums term by term.
fn add_sums<const K: usize>(a: [f64; K], b: [f64; K]) -> [f64; K] {
    std::array::from_fn(|k| a[k] + b[k])
}

/// K sums Σ terms(i) over 0..n at once, summed in fixed chunks (in parallel) and then in chunk
/// order, so the result does not depend on the number of threads.
fn ordered_sums<const K: usize>(n: usize, terms: impl Fn(usize) -> [f64; K] + Sync) -> [f64; K] {
    let partial: Vec<[f64; K]> = (0..n.div_ceil(SUM_CHUNK))
        .into_par_iter()
        .map(|c| {
            (c * SUM_CHUNK..((c + 1) * SUM_CHUNK).min(n))
                .fold([0.0; K], |acc, i| add_sums(acc, terms(i)))
        })
        .collect();
    partial.into_iter().fold([0.0; K], add_sums)
}

/// One pass that updates each item in place (`term(i, item)`) and returns the K sums of the
/// terms it gives, summed as [`ordered_sums`] sums them (the same bits), and the largest of
/// the values it gives beside them: an update and the sums over its result in one fork and
/// join on the pool instead of two or three.
fn ordered_update<T: Send, const K: usize>(
    items: &mut [T],
    term: impl Fn(usize, &mut T) -> ([f64; K], f64) + Sync,
) -> ([f64; K], f64) {
    ordered_update_in(SUM_CHUNK, items, term)
}

/// [`ordered_update`] with its sums' chunk `size` (the chunk fixes the bits).
fn ordered_update_in<T: Send, const K: usize>(
    size: usize,
    items: &mut [T],
    term: impl Fn(usize, &mut T) -> ([f64; K], f64) + Sync,
) -> ([f64; K], f64) {
    let partial: Vec<([f64; K], f64)> = items
        .par_chunks_mut(size)
        .enumerate()
        .map(|(c, chunk)| {
            (chunk.iter_mut().enumerate()).fold(([0.0; K], 0.0), |(acc, top), (k, item)| {
                let (terms, value) = term(c * size + k, item);
                (add_sums(acc, terms), f64::max(top, value))
            })
        })
        .collect();
    (partial.into_iter()).fold(([0.0; K], 0.0), |(a, x), (b, y)| {
        (add_sums(a, b), f64::max(x, y))
    })
}

/// What a flow stage's stop rule sees.
struct FlowStatus {
    steps: usize,
    max_overlap: f64,
    /// Largest net force: the overdamped speed a particle would have (γ = 1).
    max_force: f64,
    /// Root-mean-square net force.
    rms_force: f64,
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

/// Stage 1: radii, orientations and centres in the initial box (the die's cross-section, 3
/// sides high), numbered in cell order from `cell_order_from` particles on.
fn random_start(params: &PackingParams, seed: u64) -> Packing {
    let radius = sample_radii(params, seed);
    let solid: f64 = radius
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .sum();
    let side = (solid / 0.6)
        .cbrt()
        .max(2.0 * radius.iter().cloned().fold(0.0, f64::max));
    let position = sample_positions(&radius, side, seed);
    let orientation = sample_orientations(radius.len(), seed);
    let start = Packing {
        radius,
        position,
        orientation,
        container: Container {
            lx: side,
            ly: side,
            top: Some(3.0 * side),
        },
        steps: [0; 3],
    };
    if start.radius.len() >= params.numerics.cell_order_from {
        // cells one mean diameter (2 R_av) wide
        return start.renumbered(&cell_order(&start.position, 2.0));
    }
    start
}

/// The indices of `position` sorted by the cell of side `cell` they lie in (z slowest, then y,
/// then x; ties in index order): neighbours in space become neighbours in memory.
fn cell_order(position: &[Vector3<f64>], cell: f64) -> Vec<usize> {
    let key = |p: &Vector3<f64>| [p.z, p.y, p.x].map(|c| (c / cell).floor() as i64);
    let mut order: Vec<usize> = (0..position.len()).collect();
    order.sort_by_key(|&i| key(&position[i]));
    order
}

/// `values` in the order `order` (a permutation of its indices).
fn permuted<T: Copy>(values: &[T], order: &[usize]) -> Vec<T> {
    order.iter().map(|&i| values[i]).collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The packing parameters of Sr ferrite at the model's defaults.
    fn sr_ferrite() -> PackingParams {
        let material = crate::materials::MaterialDb::builtin()
            .get("srfe12o19")
            .unwrap()
            .clone();
        crate::models::align::AlignParams::paper_defaults(material, 0.0).packing()
    }

    /// Tiles are copies side by side: N and the die grow by tiles², every sphere stays in the
    /// die, the packing fraction is the die's, and spheres of neighbouring copies overlap at
    /// most as much as two spheres each touching the shared wall may (the relaxation's
    /// overlap tolerance on either side).
    #[test]
    fn tiled_packings_are_side_by_side_copies() {
        let mut params = sr_ferrite();
        params.particles = 150;
        let die = Packing::generate(&params, 2).unwrap();
        let bed = die.tiled(3);
        let n = die.radius.len();
        assert_eq!(bed.radius.len(), 9 * n);
        assert_eq!(bed.container.lx, 3.0 * die.container.lx);
        assert_eq!(bed.container.ly, 3.0 * die.container.ly);
        let relative =
            (bed.packing_fraction() - die.packing_fraction()).abs() / die.packing_fraction();
        assert!(relative < 1e-12, "packing fraction off by {relative:e}");
        let tolerance = 2.0 * params.numerics.overlap_tolerance;
        for (i, (p, r)) in bed.position.iter().zip(&bed.radius).enumerate() {
            assert!(p.x - r > -tolerance && p.x + r < bed.container.lx + tolerance);
            assert!(p.y - r > -tolerance && p.y + r < bed.container.ly + tolerance);
            assert_eq!(bed.radius[i % n], die.radius[i % n]);
            for j in (i + 1)..bed.radius.len() {
                if i / n != j / n {
                    let gap = (bed.position[j] - p).norm() - r - bed.radius[j];
                    assert!(
                        gap > -tolerance,
                        "copies of {i} and {j} overlap by {}",
                        -gap
                    );
                }
            }
        }
    }

    /// The relaxation's final contact count is the packing's: every pair of spheres that
    /// overlaps at all, counted from both sides (a brute-force count over all pairs).
    #[test]
    fn the_released_contact_count_is_the_packings() {
        let mut params = sr_ferrite();
        params.particles = 300;
        let (bed, work) = Packing::generate_counted(&params, 5).unwrap();
        let n = bed.radius.len();
        let touching = (0..n)
            .flat_map(|i| ((i + 1)..n).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                (bed.position[j] - bed.position[i]).norm() < bed.radius[i] + bed.radius[j]
            })
            .count();
        assert_eq!(work[2].final_contacts, 2 * touching as u64);
        assert!(
            work[1].final_contacts > work[2].final_contacts,
            "loading adds contacts"
        );
    }

    #[test]
    fn cell_order_is_a_permutation_sorted_by_cell() {
        let position = sample_positions(&[0.5; 500], 10.0, 7);
        let order = cell_order(&position, 2.0);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..500).collect::<Vec<_>>());
        let cell = |i: usize| [2, 1, 0].map(|a| (position[i][a] / 2.0).floor() as i64);
        assert!(order.windows(2).all(|w| cell(w[0]) <= cell(w[1])));
        assert!(order
            .windows(2)
            .all(|w| cell(w[0]) < cell(w[1]) || w[0] < w[1]));
    }

    /// The ordered start is the drawn start relabelled: every particle keeps its own radius,
    /// centre and orientation.
    #[test]
    fn cell_ordered_start_is_the_drawn_start_relabelled() {
        let mut params = sr_ferrite();
        params.particles = 2000;
        let mut start = |cell_order_from: usize| {
            params.numerics.cell_order_from = cell_order_from;
            let start = random_start(&params, 3);
            let particles: Vec<[f64; 8]> = (0..start.radius.len())
                .map(|i| {
                    let (p, q) = (start.position[i], start.orientation[i].coords);
                    [start.radius[i], p.x, p.y, p.z, q.x, q.y, q.z, q.w]
                })
                .collect();
            (particles, start.container.lx)
        };
        let (drawn, side) = start(usize::MAX);
        let (ordered, ordered_side) = start(0);
        assert_eq!(side, ordered_side);
        assert_ne!(drawn, ordered, "the numbering changed");
        let sorted = |mut v: Vec<[f64; 8]>| {
            v.sort_by(|a, b| a.partial_cmp(b).unwrap());
            v
        };
        assert_eq!(sorted(drawn), sorted(ordered));
    }
}
