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

use std::marker::PhantomData;
use std::ops::Index;

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::release::Anchor;
use super::{Load, Loads, MAX_MOVE, SKIN};
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

/// The rounds visit horizontal slabs in this many colours, slab k in colour k mod `COLOURS`:
/// a slab is 2 R_max + 2 skin high, so a listed pair spans at most two neighbouring slabs, and
/// two slabs of one colour, three apart, share no particle that either's visits read or write.
const COLOURS: usize = 3;

/// A colour's slabs are visited on the pool from this many visits on (a round of fewer is
/// shorter than the pool's fork and join).
const PARALLEL_VISITS: usize = 192;

/// What the corrections keep between Newton steps (their vectors reused from one to the next).
#[derive(Debug)]
pub(super) struct Corrections {
    /// `PARALLEL_VISITS` (a test sets others).
    parallel_visits: usize,
    /// Each slab's visits of the round and its room.
    slabs: Vec<Slab>,
    /// Each particle's slab, by its height at the correction's start.
    slab_of: Vec<u32>,
    /// The particles to visit next (all slabs), ascending.
    next: Vec<usize>,
    /// Whether a particle's force changed in this round (so far).
    touched: Vec<bool>,
}

/// One slab's particles to visit in this round (ascending), the particles whose force its
/// visits changed, and each touching partner's force on the visited particle before and
/// after its move.
#[derive(Debug, Default)]
struct Slab {
    active: Vec<usize>,
    touched: Vec<usize>,
    before: Vec<(usize, Vector3<f64>)>,
    after: Vec<(usize, Vector3<f64>)>,
}

impl Default for Corrections {
    fn default() -> Self {
        Self {
            parallel_visits: PARALLEL_VISITS,
            slabs: Vec::new(),
            slab_of: Vec::new(),
            next: Vec::new(),
            touched: Vec::new(),
        }
    }
}

impl Corrections {
    /// Corrects `position` where some but at most `MOST` of the particles feel `target` or
    /// more in `force` (the net forces at `position`, anchor included; `list` up to date
    /// there): Gauss–Seidel rounds of one-particle Newton steps (each particle moved to where
    /// its linearized net force vanishes, its partners held, by at most `MAX_MOVE`) over the
    /// particles at `VISIT` × `target` or more, with `force` kept pair by pair as they move,
    /// until none is left or for `ROUNDS` rounds. Returns whether it ran (then `force` holds
    /// approximate values: the caller evaluates again).
    ///
    /// A round visits the slabs of one colour after another (`COLOURS`), each slab's particles
    /// in index order; the slabs of a colour share nothing, so they are visited at once on the
    /// pool, with the bits of visiting them one after the other: the same at any thread count.
    pub(super) fn correct(
        &mut self,
        position: &mut [Vector3<f64>],
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
        force: &mut [Load],
        target: f64,
    ) -> bool {
        let visit = VISIT * target;
        self.next.clear();
        self.next.par_extend(
            (force.par_iter().enumerate())
                .filter(|(_, f)| f.0.norm() >= visit)
                .map(|(i, _)| i),
        );
        let above = (self.next.iter())
            .filter(|&&i| force[i].0.norm() >= target)
            .count();
        if above == 0 || above as f64 > MOST * position.len() as f64 {
            return false;
        }
        self.cut_slabs(position, problem.0.radius);
        for _ in 0..ROUNDS {
            self.deal();
            let apart = self.slabs_apart(list);
            let bed = Shared::new(position, force, &mut self.touched);
            let parallel_from = if apart {
                self.parallel_visits
            } else {
                usize::MAX
            };
            for colour in 0..COLOURS {
                visit_colour(&mut self.slabs, colour, parallel_from, bed, (problem, list));
            }
            self.next.clear();
            for slab in &mut self.slabs {
                self.next.append(&mut slab.touched);
            }
            self.next.sort_unstable();
            for &j in &self.next {
                self.touched[j] = false;
            }
            self.next.retain(|&j| force[j].0.norm() >= visit);
            if self.next.is_empty() {
                break;
            }
        }
        true
    }

    /// Each particle's slab by the height of its centre above the lowest (slabs of
    /// 2 R_max + 2 skin: a listed pair is closer than R_i + R_j + 2 skin, the list's spread
    /// rule allowing each particle half a skin from its place at the build; taller where that
    /// would make more slabs than particles, as a bed blown apart would).
    fn cut_slabs(&mut self, position: &[Vector3<f64>], radius: &[f64]) {
        let bottom = position.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        let top = position
            .iter()
            .map(|p| p.z)
            .fold(f64::NEG_INFINITY, f64::max);
        let height = (2.0 * radius.iter().cloned().fold(0.0, f64::max) + 2.0 * SKIN)
            .max((top - bottom) / position.len() as f64);
        self.slab_of.clear();
        (self.slab_of).extend(position.iter().map(|p| ((p.z - bottom) / height) as u32));
        let slabs = self.slab_of.iter().max().map_or(0, |&k| k as usize + 1);
        self.slabs.resize_with(slabs, Slab::default);
        self.touched.resize(position.len(), false);
    }

    /// Hands the particles to visit (`next`, ascending) to their slabs.
    fn deal(&mut self) {
        for slab in &mut self.slabs {
            slab.active.clear();
        }
        for &i in &self.next {
            self.slabs[self.slab_of[i] as usize].active.push(i);
        }
    }

    /// Whether every particle to visit has its listed partners in its own slab or the next
    /// ones (what the slabs' height provides; where not, the slabs are visited one after
    /// the other, which gives the same bits).
    fn slabs_apart(&self, list: &NeighborList<3>) -> bool {
        let slab = |j: u32| self.slab_of[j as usize];
        self.next.iter().all(|&i| {
            let own = self.slab_of[i];
            list.of(i).iter().all(|&j| slab(j).abs_diff(own) <= 1)
        })
    }
}

/// Visits the slabs of one colour: on the pool from `parallel_from` visits on, else one after
/// another (the same bits).
fn visit_colour(
    slabs: &mut [Slab],
    colour: usize,
    parallel_from: usize,
    bed: Shared,
    (problem, list): ((&Loads, &Container, &Anchor), &NeighborList<3>),
) {
    let visits: usize = (slabs.iter().skip(colour).step_by(COLOURS))
        .map(|slab| slab.active.len())
        .sum();
    let visit_slab = |slab: &mut Slab| slab.visit_all(bed, problem, list);
    if visits >= parallel_from {
        let group = slabs.par_iter_mut().skip(colour).step_by(COLOURS);
        group.for_each(visit_slab);
    } else {
        slabs
            .iter_mut()
            .skip(colour)
            .step_by(COLOURS)
            .for_each(visit_slab);
    }
}

impl Slab {
    /// Visits the slab's particles in index order.
    fn visit_all(
        &mut self,
        bed: Shared,
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
    ) {
        self.touched.clear();
        for k in 0..self.active.len() {
            self.visit(self.active[k], bed, problem, list);
        }
    }

    /// Moves particle i by one Newton step on its own net force and updates the forces on it
    /// and on its partners.
    fn visit(
        &mut self,
        i: usize,
        bed: Shared,
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
    ) {
        let stiffness = particle_load(i, &bed, problem, list, &mut self.before).1;
        // SAFETY (here and below): i is this slab's, the partners are in its own or the next
        // slabs, which no other task of this colour reads or writes (`Shared`)
        let force_on = |j: usize| unsafe { bed.force(j) };
        let Some(step) = stiffness.cholesky().map(|c| c.solve(&force_on(i).0)) else {
            return;
        };
        unsafe { bed.move_by(i, step * (MAX_MOVE / step.norm()).min(1.0)) };
        force_on(i).0 = particle_load(i, &bed, problem, list, &mut self.after).0;
        // each partner feels the reaction: −(its force on i)
        for &(j, g) in &self.before {
            force_on(j).0 += g;
        }
        for &(j, g) in &self.after {
            force_on(j).0 -= g;
        }
        let partners = self.before.iter().chain(&self.after).map(|p| p.0);
        for j in std::iter::once(i).chain(partners) {
            // SAFETY: as above
            if unsafe { bed.first_touch(j) } {
                self.touched.push(j);
            }
        }
    }
}

/// The positions and forces that one colour's slabs change at once, element by element.
///
/// Safety of its use: a task reads the positions of its slab and the next ones, moves its own
/// slab's particles and writes the forces on them and on their listed partners; the tasks
/// running at once are the slabs of one colour, three slabs apart, and every listed partner of
/// a visited particle lies in its own or the next slab (`Corrections::slabs_apart`, else the
/// slabs run one after the other), so no element one task writes is read or written by
/// another while it runs.
#[derive(Clone, Copy)]
struct Shared<'a> {
    position: *mut Vector3<f64>,
    force: *mut Load,
    touched: *mut bool,
    len: usize,
    _borrow: PhantomData<&'a mut [Load]>,
}

// SAFETY: see the type's documentation: the tasks sharing it touch disjoint elements.
unsafe impl Send for Shared<'_> {}
unsafe impl Sync for Shared<'_> {}

impl<'a> Shared<'a> {
    fn new(
        position: &'a mut [Vector3<f64>],
        force: &'a mut [Load],
        touched: &'a mut [bool],
    ) -> Self {
        assert!(position.len() == force.len() && force.len() == touched.len());
        Self {
            position: position.as_mut_ptr(),
            force: force.as_mut_ptr(),
            touched: touched.as_mut_ptr(),
            len: position.len(),
            _borrow: PhantomData,
        }
    }

    /// The force on particle i.
    ///
    /// # Safety
    /// No other task reads or writes it while the reference lives (the type's documentation).
    #[allow(clippy::mut_from_ref)]
    unsafe fn force(&self, i: usize) -> &mut Load {
        assert!(i < self.len);
        // SAFETY: in bounds; exclusive by the caller's promise
        unsafe { &mut *self.force.add(i) }
    }

    /// Marks particle i's force as changed in this round; returns whether it was not yet.
    ///
    /// # Safety
    /// No other task reads or writes its mark meanwhile (the type's documentation).
    unsafe fn first_touch(&self, i: usize) -> bool {
        assert!(i < self.len);
        // SAFETY: in bounds; exclusive by the caller's promise
        let mark = unsafe { &mut *self.touched.add(i) };
        !std::mem::replace(mark, true)
    }

    /// Moves particle i by `step`.
    ///
    /// # Safety
    /// No other task reads or writes its position meanwhile (the type's documentation).
    unsafe fn move_by(&self, i: usize, step: Vector3<f64>) {
        assert!(i < self.len);
        // SAFETY: in bounds; exclusive by the caller's promise
        unsafe { *self.position.add(i) += step };
    }
}

impl Index<usize> for Shared<'_> {
    type Output = Vector3<f64>;

    /// Particle i's position (no other task moves it meanwhile: the type's documentation).
    fn index(&self, i: usize) -> &Vector3<f64> {
        assert!(i < self.len);
        // SAFETY: in bounds; its slab is this task's or a neighbour, which no task of the
        // running colour moves but this one, and this one only between these reads
        unsafe { &*self.position.add(i) }
    }
}

/// Particle i's net force (contacts, surfaces, anchor) and the negative of its derivative in
/// x_i, Σ k n nᵀ + c I (positive definite: c > 0); `pairs` gets each touching partner's force
/// on i.
fn particle_load<P: Index<usize, Output = Vector3<f64>> + ?Sized>(
    i: usize,
    position: &P,
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

    /// The slabs of a colour visited at once on two threads give the bits of visiting them one
    /// after another: a loaded bed of 1 500 particles, its anchor 10⁻³ k_max, every particle
    /// moved off it, corrected to the force that a twentieth of them feel.
    #[test]
    fn slabs_visited_at_once_give_the_bits_of_one_after_another() {
        use crate::models::align::dem::packing::{as_gathered, Packing};
        let (bed, stages) = Packing::loaded_for_tests(1500, 2);
        let loads = stages.release_loads(&bed.radius);
        let (mut list, mut force) = (NeighborList::rebuilt_on_spread(SKIN), Vec::new());
        force.resize(bed.position.len(), (Vector3::zeros(), 0.0, 0.0, 0));
        let mut work = ContactWork::default();
        let container = &bed.container;
        let x = &bed.position;
        let largest = loads.evaluate(x, container, &mut list, &mut force, &mut work, as_gathered);
        let anchor = Anchor::new(x.clone(), 1e-3 * largest[1]);
        let moved: Vec<_> = (x.iter().enumerate())
            .map(|(i, p)| {
                p + 0.004 * Vector3::new((1.3 * i as f64).sin(), (0.7 * i as f64).cos(), 0.5)
            })
            .collect();
        let problem = (&loads, container, &anchor);
        evaluate(problem, &moved, &mut list, &mut force);
        let mut sizes: Vec<f64> = force.iter().map(|f| f.0.norm()).collect();
        sizes.sort_by(f64::total_cmp);
        let target = sizes[sizes.len() * 95 / 100];
        let run = |parallel_visits: usize, threads: usize| {
            let (mut position, mut force) = (moved.clone(), force.clone());
            let mut corrections = Corrections {
                parallel_visits,
                ..Corrections::default()
            };
            corrections.cut_slabs(&position, &bed.radius);
            corrections.next = (0..position.len()).collect();
            let apart = corrections.slabs_apart(&list);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let ran = pool
                .install(|| corrections.correct(&mut position, problem, &list, &mut force, target));
            (
                apart && ran && corrections.slabs.len() >= 2 * COLOURS,
                position,
                force,
            )
        };
        let (ran, at_once, forces_at_once) = run(0, 2);
        let (_, one_by_one, forces_one_by_one) = run(usize::MAX, 1);
        assert!(
            ran,
            "the slabs were apart, several per colour, and the corrections ran"
        );
        assert!(
            at_once.iter().zip(&moved).any(|(a, b)| a != b),
            "particles moved"
        );
        assert_eq!(at_once, one_by_one);
        let bits = |f: &[Load]| f.iter().map(|f| f.0.map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&forces_at_once), bits(&forces_one_by_one));
    }

    /// A bed blown apart (a sphere a terametre up, one at infinity) is cut into no more slabs
    /// than it has particles, not into one per 2 R_max + 2 skin of its height.
    #[test]
    fn a_bed_blown_apart_gets_no_more_slabs_than_particles() {
        for far in [1e12, f64::INFINITY] {
            let position = [
                Vector3::zeros(),
                Vector3::new(0.0, 0.0, 1.0),
                Vector3::new(0.0, 0.0, far),
            ];
            let mut corrections = Corrections::default();
            corrections.cut_slabs(&position, &[1.0; 3]);
            assert!(
                corrections.slabs.len() <= 4,
                "{far}: {} slabs",
                corrections.slabs.len()
            );
            assert_eq!(corrections.slab_of[..2], [0, 0]);
        }
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
