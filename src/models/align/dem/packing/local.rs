//! Local corrections between the release's Newton steps (docs/align.md, "The release").
//!
//! Why: a Newton step's linear model holds the touching contacts only, so a particle that
//! closes a gap in the step overshoots into its new partner (Hertz stiffness is zero at touch)
//! and the largest net force jumps 5–300-fold; the global Newton steps that brought it back
//! took most of the release (results/bench/README.md, "The release's passes on two threads").
//! Those overshoots are local: one-particle Newton steps, Gauss–Seidel over the particles
//! that still feel the step's target force and over their partners as they move, remove them
//! at a small fraction of a global step's cost. The stop rule is unchanged (the true forces
//! of a full evaluation below the target), so the step's minimizer is the same to its
//! tolerance.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::release::Anchor;
use super::{Load, Loads, MAX_MOVE};
use crate::models::align::dem::contacts::{Contact, Container};
use crate::neighbor::NeighborList;

/// Corrections are made only when at most this share of the particles feel the target force
/// or more: more than that is a global residual, which the next Newton step removes more
/// cheaply (at N = 10⁴, in a trial build visiting down to 0.95 of the target: with 1 % the
/// release took 2.1× the Newton steps of 10 %; with no limit 0.9× of them, but 1.7× the
/// particle visits, and no faster).
const MOST: f64 = 0.1;

/// Gauss–Seidel rounds of one correction, at most (at N = 10⁴, in a trial build, a correction
/// took 39 rounds on average; with at most 30 the release took 1.16× the Newton steps of
/// 100).
const ROUNDS: usize = 100;

/// A particle is visited while its net force is at least this fraction of the step's target.
/// Over 24 paired seeds at N = 10⁴ the released beds then keep τ_0.95, τ_0.90, the contacts
/// and the sticking fraction of Newton steps alone within one standard error, and φ within
/// 2.1 (−0.00035 ± 0.00017, a ninth of the seeds' sd); a trial build visiting down to 0.95
/// of the target from the particles above it made 4.6× fewer visits but ended with 39 ± 12
/// fewer contacts over 12 seeds (results/bench/README.md, "Local corrections in the
/// release").
const VISIT: f64 = 0.5;

/// What the corrections keep between Newton steps (no allocation per correction).
#[derive(Debug, Default)]
pub(super) struct Corrections {
    /// Particles to visit in this round, ascending.
    active: Vec<usize>,
    /// Particles whose force this round changed, ascending once sorted.
    touched: Vec<usize>,
    /// `stamp` for a particle already in `touched` this round.
    mark: Vec<u32>,
    stamp: u32,
    /// Each touching partner's force on the visited particle, before and after its move.
    before: Vec<(usize, Vector3<f64>)>,
    after: Vec<(usize, Vector3<f64>)>,
}

impl Corrections {
    /// Corrects `position` where some but at most `MOST` of the particles feel `target` or
    /// more in `force` (the net forces at `position`, anchor included; `list` up to date
    /// there): Gauss–Seidel rounds, in index order, of one-particle Newton steps (each
    /// particle moved to where its linearized net force vanishes, its partners held, by at
    /// most `MAX_MOVE`) over the particles at `VISIT` × `target` or more, with `force` kept
    /// pair by pair as they move, until none is left or for `ROUNDS` rounds. Returns whether
    /// it ran (then `force` holds approximate values: the caller evaluates again).
    /// Serial and in index order: the same bits at any thread count.
    pub(super) fn correct(
        &mut self,
        position: &mut [Vector3<f64>],
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
        force: &mut [Load],
        target: f64,
    ) -> bool {
        let visit = VISIT * target;
        self.active.clear();
        self.active.par_extend(
            (force.par_iter().enumerate())
                .filter(|(_, f)| f.0.norm() >= visit)
                .map(|(i, _)| i),
        );
        let above = (self.active.iter())
            .filter(|&&i| force[i].0.norm() >= target)
            .count();
        if above == 0 || above as f64 > MOST * position.len() as f64 {
            return false;
        }
        self.mark.resize(position.len(), 0);
        for _ in 0..ROUNDS {
            self.stamp = self.stamp.wrapping_add(1);
            self.touched.clear();
            for k in 0..self.active.len() {
                self.visit(self.active[k], position, problem, list, force);
            }
            self.touched.sort_unstable();
            let (active, touched) = (&mut self.active, &self.touched);
            active.clear();
            active.extend(touched.iter().filter(|&&j| force[j].0.norm() >= visit));
            if active.is_empty() {
                break;
            }
        }
        true
    }

    /// Moves particle i by one Newton step on its own net force and updates the forces on it
    /// and on its partners.
    fn visit(
        &mut self,
        i: usize,
        position: &mut [Vector3<f64>],
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
        force: &mut [Load],
    ) {
        let stiffness = particle_load(i, position, problem, list, &mut self.before).1;
        let Some(step) = stiffness.cholesky().map(|c| c.solve(&force[i].0)) else {
            return;
        };
        position[i] += step * (MAX_MOVE / step.norm()).min(1.0);
        force[i].0 = particle_load(i, position, problem, list, &mut self.after).0;
        // each partner feels the reaction: −(its force on i)
        for &(j, g) in &self.before {
            force[j].0 += g;
        }
        for &(j, g) in &self.after {
            force[j].0 -= g;
        }
        let partners = self.before.iter().chain(&self.after).map(|p| p.0);
        for j in std::iter::once(i).chain(partners) {
            if self.mark[j] != self.stamp {
                self.mark[j] = self.stamp;
                self.touched.push(j);
            }
        }
    }
}

/// Particle i's net force (contacts, surfaces, anchor) and the negative of its derivative in
/// x_i, Σ k n nᵀ + c I (positive definite: c > 0); `pairs` gets each touching partner's force
/// on i.
fn particle_load(
    i: usize,
    position: &[Vector3<f64>],
    (loads, container, anchor): (&Loads, &Container, &Anchor),
    list: &NeighborList<3>,
    pairs: &mut Vec<(usize, Vector3<f64>)>,
) -> (Vector3<f64>, Matrix3<f64>) {
    pairs.clear();
    let mut force = -anchor.stiffness * (position[i] - anchor.position[i]);
    let mut stiffness = Matrix3::identity() * anchor.stiffness;
    let (law, radius, repulsion) = (loads.law, loads.radius, loads.repulsion);
    let mut add = |c: &Contact| {
        let (f, k) = repulsion.force_and_stiffness(c);
        stiffness += k * c.normal * c.normal.transpose();
        -f * c.normal
    };
    law.particle_contacts_of(i, position, radius, list, |j, c| {
        let g = add(&c);
        force += g;
        pairs.push((j as usize, g));
    });
    law.wall_contacts_of(i, position, radius, container, |_, c| force += add(&c));
    (force, stiffness)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::contacts::ContactLaw;
    use crate::models::align::dem::packing::{ContactWork, Repulsion, Settling, SKIN};
    use crate::models::align::SettlingScheme;

    /// Spheres of R = 1 in a wide die, each anchored at its start (c = 0.25): a pair pressed
    /// together by 0.05, and `free` more far from everything. `check` gets the loads, the
    /// die and the anchor (its positions: the start).
    fn with_pressed_pair(free: usize, check: impl FnOnce(&Loads, &Container, &Anchor)) {
        let mut start = vec![
            Vector3::new(20.0, 20.0, 5.0),
            Vector3::new(21.95, 20.0, 5.0),
        ];
        start.extend((0..free).map(|k| Vector3::new(4.0 + 4.0 * k as f64, 4.0, 5.0)));
        let container = Container {
            lx: 80.0,
            ly: 40.0,
            top: None,
        };
        let radius = vec![1.0; start.len()];
        let law = ContactLaw {
            effective_modulus: 0.55,
            friction: 0.0,
            wall_friction: 0.0,
            skin: 0.0,
        };
        let settling = Settling::new(SettlingScheme::Fire, &radius);
        let loads = Loads {
            law: &law,
            repulsion: Repulsion::Hertz,
            settling: &settling,
            down_force: 0.0,
            radius: &radius,
        };
        let anchor = Anchor::new(start, 0.25);
        check(&loads, &container, &anchor);
    }

    /// Net forces (contacts and anchor) at `x` into `force`; returns the largest.
    fn evaluate(
        problem: (&Loads, &Container, &Anchor),
        x: &[Vector3<f64>],
        list: &mut NeighborList<3>,
        force: &mut Vec<Load>,
    ) -> f64 {
        let (loads, container, anchor) = problem;
        force.resize(x.len(), (Vector3::zeros(), 0.0, 0.0, 0));
        let mut work = ContactWork::default();
        anchor.net_forces((loads, container), x, (list, force), &mut work)
    }

    /// The pair alone feels a force (2 of 20 spheres): one correction brings every net force
    /// below the target, which makes it the backward-Euler step's root; the pair moves apart
    /// symmetrically, and the free spheres stay where they were.
    #[test]
    fn a_correction_finds_the_backward_euler_step_of_a_pressed_pair() {
        with_pressed_pair(18, |loads, container, anchor| {
            let problem = (loads, container, anchor);
            let (start, mut position) = (&anchor.position, anchor.position.clone());
            let (mut list, mut force) = (NeighborList::rebuilt_on_spread(SKIN), Vec::new());
            let target = 1e-9 * evaluate(problem, &position, &mut list, &mut force);
            let mut corrections = Corrections::default();
            assert!(corrections.correct(&mut position, problem, &list, &mut force, target));
            let left = evaluate(problem, &position, &mut list, &mut force);
            assert!(left < target, "{left} against {target}");
            let (out0, out1) = (start[0].x - position[0].x, position[1].x - start[1].x);
            assert!(out0 > 1e-3 && (out0 - out1).abs() < 1e-9, "{out0} {out1}");
            assert_eq!(position[2..], start[2..]);
        });
    }

    /// With both spheres of two feeling the force, the residual is the whole bed's: no
    /// correction is made (the next Newton step's job), and nothing moves.
    #[test]
    fn a_residual_spread_over_many_particles_is_left_to_newton() {
        with_pressed_pair(0, |loads, container, anchor| {
            let problem = (loads, container, anchor);
            let mut position = anchor.position.clone();
            let (mut list, mut force) = (NeighborList::rebuilt_on_spread(SKIN), Vec::new());
            let pressed = evaluate(problem, &position, &mut list, &mut force);
            let mut corrections = Corrections::default();
            let target = 0.5 * pressed;
            assert!(!corrections.correct(&mut position, problem, &list, &mut force, target));
            assert_eq!(position, anchor.position);
        });
    }
}
