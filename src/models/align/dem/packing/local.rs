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
/// Over 24 paired seeds at N = 10⁴ the released beds keep τ_0.95, τ_0.90, the contacts, φ and
/// the sticking fraction of 0.5 (the value before 2026-12-06, sixth session) within one
/// standard error, with 2.2× fewer visits. 0.9 did too (within 1.2) and was faster, but
/// against Newton steps alone the contacts fall as the value rises (−17, −25, −28 at 0.5,
/// 0.75, 0.9), and a trial visiting down to 0.95 from the particles above the target lost
/// 39 ± 12 over 12 seeds; every value from 0.5 up shifts φ there by −0.0004 to −0.0006, a
/// sixth of the seeds' sd (results/bench/README.md, "Fewer visits in the release's
/// corrections").
const VISIT: f64 = 0.75;

/// The rounds visit horizontal slabs in this many colours, slab k in colour k mod `COLOURS`:
/// a slab is 2 R_max + 2 skin high, so a listed pair spans at most two neighbouring slabs, and
/// two slabs of one colour, three apart, share no particle that either's visits read or write.
const COLOURS: usize = 3;

/// A colour's slabs are visited on the pool from this many visits on (a round of fewer is
/// shorter than the pool's fork and join).
const PARALLEL_VISITS: usize = 192;

/// Particles per task of the slabs' cut (a pass over all particles, twice per correction).
const CUT_PIECE: usize = 4096;

/// What the corrections keep between Newton steps (their vectors reused from one to the next).
#[derive(Debug)]
pub(super) struct Corrections {
    /// `PARALLEL_VISITS` (a test sets others).
    parallel_visits: usize,
    /// Each slab's visits of the round and its room.
    slabs: Vec<Slab>,
    /// Each slab's particles whose force its visits changed first in the round (apart from
    /// `slabs`: the next round's slabs read their neighbours' while each writes its own).
    touched: Vec<Vec<usize>>,
    /// Each particle's slab, by its height at the correction's start.
    slab_of: Vec<u32>,
    /// The particles to visit in the first round (all slabs), ascending.
    first: Vec<usize>,
    /// The round in which each particle's force last changed (marks that need no clearing).
    stamp: Vec<u32>,
    /// The current round's number, counted across corrections (0: none).
    round: u32,
}

/// One slab's particles to visit in this round (ascending), whether their listed partners all
/// lie in this slab or the next ones, and each touching partner's force on the visited
/// particle before and after its move.
#[derive(Debug, Default)]
struct Slab {
    active: Vec<usize>,
    apart: bool,
    before: Vec<(usize, Vector3<f64>)>,
    after: Vec<(usize, Vector3<f64>)>,
}

impl Default for Corrections {
    fn default() -> Self {
        Self {
            parallel_visits: PARALLEL_VISITS,
            slabs: Vec::new(),
            touched: Vec::new(),
            slab_of: Vec::new(),
            first: Vec::new(),
            stamp: Vec::new(),
            round: 0,
        }
    }
}

impl Corrections {
    /// Corrects `position` where some but at most `MOST` of the particles feel `target` or
    /// more in `force` (the net forces at `position`, anchor included; `list` up to date
    /// there): Gauss–Seidel rounds of one-particle Newton steps (each particle moved to where
    /// its linearized net force vanishes, its partners held, by at most `MAX_MOVE`) over the
    /// particles at `VISIT` × `target` or more, with `force` kept pair by pair as they move,
    /// until none is left or for `ROUNDS` rounds. Returns the visits where it ran (then `force`
    /// holds approximate values: the caller evaluates again), `None` where it did not.
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
    ) -> Option<usize> {
        let visit = VISIT * target;
        self.first.clear();
        self.first.par_extend(
            (force.par_iter().enumerate())
                .filter(|(_, f)| f.0.norm() >= visit)
                .map(|(i, _)| i),
        );
        let above = (self.first.iter())
            .filter(|&&i| force[i].0.norm() >= target)
            .count();
        if above == 0 || above as f64 > MOST * position.len() as f64 {
            return None;
        }
        self.cut_slabs(position, problem.0.radius);
        self.deal(list);
        let mut all_visits = 0;
        for _ in 0..ROUNDS {
            let visits: usize = self.slabs.iter().map(|slab| slab.active.len()).sum();
            if visits == 0 {
                break;
            }
            all_visits += visits;
            let apart = self.slabs.iter().all(|slab| slab.apart);
            let round = self.next_round();
            let bed = Shared::new(position, force, &mut self.stamp, round);
            let parallel_from = if apart {
                self.parallel_visits
            } else {
                usize::MAX
            };
            for colour in 0..COLOURS {
                let slabs = (&mut self.slabs[..], &mut self.touched[..]);
                visit_colour(slabs, colour, parallel_from, bed, (problem, list));
            }
            let keep = |j: usize| force[j].0.norm() >= visit;
            self.gather(apart, visits >= self.parallel_visits, keep, list);
        }
        Some(all_visits)
    }

    /// Each particle's slab by the height of its centre above the lowest (slabs of
    /// 2 R_max + 2 skin: a listed pair is closer than R_i + R_j + 2 skin, the list's spread
    /// rule allowing each particle half a skin from its place at the build; taller where that
    /// would make more slabs than particles, as a bed blown apart would).
    fn cut_slabs(&mut self, position: &[Vector3<f64>], radius: &[f64]) {
        let (bottom, top, widest) = (position.par_iter().zip(radius))
            .with_min_len(CUT_PIECE)
            .map(|(p, &r)| (p.z, p.z, r))
            .reduce(
                || (f64::INFINITY, f64::NEG_INFINITY, 0.0),
                |a, b| (a.0.min(b.0), a.1.max(b.1), a.2.max(b.2)),
            );
        let height = (2.0 * widest + 2.0 * SKIN).max((top - bottom) / position.len() as f64);
        let slab = |z: f64| ((z - bottom) / height) as u32;
        self.slab_of.clear();
        (self.slab_of).par_extend(
            (position.par_iter())
                .with_min_len(CUT_PIECE)
                .map(|p| slab(p.z)),
        );
        // the highest centre's slab is the last (the cut is monotone in the height)
        let slabs = slab(top) as usize + 1;
        self.slabs.resize_with(slabs, Slab::default);
        self.touched.resize_with(slabs, Vec::new);
        self.stamp.resize(position.len(), 0);
    }

    /// Hands the first round's particles (`first`, ascending) to their slabs.
    fn deal(&mut self, list: &NeighborList<3>) {
        for slab in &mut self.slabs {
            slab.active.clear();
        }
        for &i in &self.first {
            self.slabs[self.slab_of[i] as usize].active.push(i);
        }
        let slab_of = &self.slab_of;
        (self.slabs.par_iter_mut().enumerate())
            .for_each(|(t, slab)| slab.check_apart(t, slab_of, list));
    }

    /// Hands each slab the particles whose force the round changed, that lie in it and still
    /// `keep` their visit, ascending: the next round's visits (on the pool where `parallel`,
    /// the same lists either way; as the whole round's changes sorted and dealt would be). A
    /// changed particle is the visiting slab's or a listed partner: in the slab or the next
    /// ones where the round's slabs were `apart`, else anywhere.
    fn gather(
        &mut self,
        apart: bool,
        parallel: bool,
        keep: impl Fn(usize) -> bool + Sync,
        list: &NeighborList<3>,
    ) {
        let (touched, slab_of) = (&self.touched[..], &self.slab_of[..]);
        let n = touched.len();
        let gather = |(t, slab): (usize, &mut Slab)| {
            let from = if apart {
                t.saturating_sub(1)..(t + 2).min(n)
            } else {
                0..n
            };
            slab.active.clear();
            for changed in &touched[from] {
                let here = changed.iter().filter(|&&j| slab_of[j] as usize == t);
                slab.active.extend(here.filter(|&&j| keep(j)));
            }
            slab.active.sort_unstable();
            slab.check_apart(t, slab_of, list);
        };
        if parallel {
            self.slabs.par_iter_mut().enumerate().for_each(gather);
        } else {
            self.slabs.iter_mut().enumerate().for_each(gather);
        }
    }

    /// Numbers a new round: marks of earlier rounds then differ from it (all cleared where the
    /// count wraps round).
    fn next_round(&mut self) -> u32 {
        self.round = self.round.wrapping_add(1);
        if self.round == 0 {
            self.stamp.fill(0);
            self.round = 1;
        }
        self.round
    }
}

/// Visits the slabs of one colour: on the pool from `parallel_from` visits on, else one after
/// another (the same bits).
fn visit_colour(
    (slabs, touched): (&mut [Slab], &mut [Vec<usize>]),
    colour: usize,
    parallel_from: usize,
    bed: Shared,
    (problem, list): ((&Loads, &Container, &Anchor), &NeighborList<3>),
) {
    let visits: usize = (slabs.iter().skip(colour).step_by(COLOURS))
        .map(|slab| slab.active.len())
        .sum();
    let visit_slab = |(slab, touched): (&mut Slab, &mut Vec<usize>)| {
        slab.visit_all(touched, bed, problem, list);
    };
    if visits >= parallel_from {
        let group = slabs.par_iter_mut().zip(touched);
        group.skip(colour).step_by(COLOURS).for_each(visit_slab);
    } else {
        let group = slabs.iter_mut().zip(touched);
        group.skip(colour).step_by(COLOURS).for_each(visit_slab);
    }
}

impl Slab {
    /// Visits the slab's particles in index order; `touched` gets the particles whose force
    /// they changed first in the round.
    fn visit_all(
        &mut self,
        touched: &mut Vec<usize>,
        bed: Shared,
        problem: (&Loads, &Container, &Anchor),
        list: &NeighborList<3>,
    ) {
        touched.clear();
        for k in 0..self.active.len() {
            self.visit(self.active[k], touched, bed, problem, list);
        }
    }

    /// Sets `apart`: whether each particle to visit, this slab being slab t, has its listed
    /// partners in it or the next ones (what the slabs' height provides; where not, the slabs
    /// are visited one after the other, which gives the same bits).
    fn check_apart(&mut self, t: usize, slab_of: &[u32], list: &NeighborList<3>) {
        let own = t as u32;
        let near = |j: &u32| slab_of[*j as usize].abs_diff(own) <= 1;
        self.apart = self.active.iter().all(|&i| list.of(i).iter().all(near));
    }

    /// Moves particle i by one Newton step on its own net force and updates the forces on it
    /// and on its partners.
    fn visit(
        &mut self,
        i: usize,
        touched: &mut Vec<usize>,
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
                touched.push(j);
            }
        }
    }
}

/// The positions and forces that one colour's slabs change at once, element by element.
///
/// Safety of its use: a task reads the positions of its slab and the next ones, moves its own
/// slab's particles and writes the forces on them and on their listed partners; the tasks
/// running at once are the slabs of one colour, three slabs apart, and every listed partner of
/// a visited particle lies in its own or the next slab (`Slab::check_apart`, else the
/// slabs run one after the other), so no element one task writes is read or written by
/// another while it runs.
#[derive(Clone, Copy)]
struct Shared<'a> {
    position: *mut Vector3<f64>,
    force: *mut Load,
    stamp: *mut u32,
    round: u32,
    len: usize,
    _borrow: PhantomData<&'a mut [Load]>,
}

// SAFETY: see the type's documentation: the tasks sharing it touch disjoint elements.
unsafe impl Send for Shared<'_> {}
unsafe impl Sync for Shared<'_> {}

impl<'a> Shared<'a> {
    /// The bed's positions and forces, and each particle's mark (`round` where its force
    /// changed in this round).
    fn new(
        position: &'a mut [Vector3<f64>],
        force: &'a mut [Load],
        stamp: &'a mut [u32],
        round: u32,
    ) -> Self {
        assert!(position.len() == force.len() && force.len() == stamp.len());
        Self {
            position: position.as_mut_ptr(),
            force: force.as_mut_ptr(),
            stamp: stamp.as_mut_ptr(),
            round,
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
        let mark = unsafe { &mut *self.stamp.add(i) };
        std::mem::replace(mark, self.round) != self.round
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
            let visits = corrections.correct(&mut position, problem, &list, &mut force, target);
            assert!(visits.is_some_and(|v| v >= 2), "{visits:?}");
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
            corrections.first = (0..position.len()).collect();
            corrections.deal(&list);
            let apart = corrections.slabs.iter().all(|slab| slab.apart);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let ran = pool
                .install(|| corrections.correct(&mut position, problem, &list, &mut force, target));
            (
                apart && ran.is_some() && corrections.slabs.len() >= 2 * COLOURS,
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

    /// Each slab's next visits, gathered from its own and its neighbours' changed particles,
    /// are what sorting the round's changes, keeping those that still feel the force and
    /// dealing them to their slabs gave: on a loaded bed of 600 particles, each particle
    /// changed by its own slab or a neighbour, on the pool or not, and gathered from every
    /// slab where the round's slabs were not apart.
    #[test]
    fn slabs_gather_the_changes_that_sorting_and_dealing_gave() {
        use crate::models::align::dem::packing::{as_gathered, Packing};
        let (bed, stages) = Packing::loaded_for_tests(600, 4);
        let loads = stages.release_loads(&bed.radius);
        let n = bed.position.len();
        let (mut list, mut force) = (NeighborList::rebuilt_on_spread(SKIN), Vec::new());
        force.resize(n, (Vector3::zeros(), 0.0, 0.0, 0));
        let mut work = ContactWork::default();
        let (x, container) = (&bed.position, &bed.container);
        loads.evaluate(x, container, &mut list, &mut force, &mut work, as_gathered);
        let mut corrections = Corrections::default();
        corrections.cut_slabs(x, &bed.radius);
        let slabs = corrections.slabs.len();
        assert!(slabs >= 4, "{slabs} slabs");
        // every fourth particle unchanged; the others changed by the slab below theirs, their
        // own or the one above, in a scrambled order
        let scrambled = (0..n).map(|k| (k, (k * 7919) % n));
        for (k, j) in scrambled.filter(|(k, _)| k % 4 != 0) {
            let own = corrections.slab_of[j] as usize;
            let by = (own + k % 4).saturating_sub(2).min(slabs - 1);
            corrections.touched[by].push(j);
        }
        let keep = |j: usize| !j.is_multiple_of(5);
        let mut sorted: Vec<usize> = corrections.touched.concat();
        sorted.sort_unstable();
        sorted.retain(|&j| keep(j));
        let mut dealt = vec![Vec::new(); slabs];
        for &j in &sorted {
            dealt[corrections.slab_of[j] as usize].push(j);
        }
        for (apart, parallel) in [(true, false), (true, true), (false, false), (false, true)] {
            corrections.gather(apart, parallel, keep, &list);
            let gathered: Vec<_> = corrections.slabs.iter().map(|s| s.active.clone()).collect();
            assert_eq!(gathered, dealt, "apart {apart}, parallel {parallel}");
        }
    }

    /// A particle marked in an earlier round is not marked in this one, nor after the rounds'
    /// count wraps round (particle 0 was marked in a round 1 long ago).
    #[test]
    fn marks_of_earlier_rounds_do_not_count() {
        let (mut position, mut force) = (vec![Vector3::zeros(); 2], vec![Default::default(); 2]);
        let mut corrections = Corrections {
            stamp: vec![1, 0],
            round: u32::MAX - 1,
            ..Corrections::default()
        };
        for (round, touched) in [(u32::MAX, &[1][..]), (1, &[0, 1][..])] {
            assert_eq!(corrections.next_round(), round);
            let bed = Shared::new(&mut position, &mut force, &mut corrections.stamp, round);
            for &i in touched {
                // SAFETY (here and below): one task
                assert!(unsafe { bed.first_touch(i) }, "round {round}: {i} first");
                assert!(!unsafe { bed.first_touch(i) }, "round {round}: {i} again");
            }
        }
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
            let visits = corrections.correct(&mut position, problem, &list, &mut force, target);
            assert_eq!(visits, None);
            assert_eq!(position, anchor.position);
        });
    }
}
