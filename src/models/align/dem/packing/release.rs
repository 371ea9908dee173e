//! The overdamped release (spec align.md, stage 3: "then the device is switched off and
//! overlaps relax"; docs/align.md, "The release").
//!
//! The model moves without inertia (Eq. A6: γ v = F), so a loaded bed freed of its settling
//! force decompresses without overshoot and keeps its contact network. Straight FIRE does not:
//! its inertia carries the springing-back bed past jamming, and whether a run keeps its network
//! is chance (results/bench/README.md, "The released bed"). Following γ ẋ = F by explicit steps
//! costs ~10⁵ steps at N = 1000 (the stiffest contact limits the step, the near-jammed bed's
//! slow modes set the time). Backward-Euler steps of length h,
//!
//!   x' = argmin_x  U(x) + |x − x₀|² / (2h)        (γ = 1; U: the Hertz energy),
//!
//! are stable at any h, and the minimizer of each step is the same whichever solver finds it
//! (to the solve's tolerance: 1 % of the step's starting force, 10 % in large beds, where
//! paired seeds show no change in the bed beyond their noise): each is found by nonlinear
//! conjugate gradients (2.2–2.4× fewer force evaluations than FIRE at N = 10³ and 10⁴:
//! results/bench/README.md, "An overdamped release"), in large beds by Newton steps on stored
//! contact stiffnesses (`newton`; the packing 1.7× faster at 10⁴–10⁵, paired seeds again
//! within their noise: "Newton steps for the release"). The anchor's
//! stiffness 1/h bounds the condition number by 1 + h k_max. h = `release_step`/k_max, with
//! k_max the largest summed contact stiffness at the step's start (the step grows as the
//! overlaps, and with them the Hertz stiffness, shrink, as an explicit step would); in large
//! beds (Newton) also at most MAX_MOVE/F_max, F_max the largest net force at the step's start.

use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::Vector3;
use rayon::prelude::*;

use super::newton::Newton;
use super::{
    as_gathered, ordered_sums, ordered_update, ContactWork, Load, Loads, Packing, Stages,
    EVALUATE_PIECE, MAX_MOVE, MAX_STEPS, SKIN,
};
use crate::models::align::dem::contacts::Container;
use crate::neighbor::NeighborList;

/// How each backward-Euler step of the release is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum StepSolver {
    /// Nonlinear conjugate gradients, two force evaluations per iteration.
    ConjugateGradients,
    /// Newton steps on stored contact stiffnesses (`newton`), the conjugate gradients taking
    /// over a step they do not finish.
    Newton,
}

/// Largest displacement (R_av) of the finite difference that measures the curvature along a
/// search direction: far below any overlap that matters, far above round-off.
const PROBE_MOVE: f64 = 1e-6;

/// Springs of stiffness `stiffness` that tie each particle to its position at the start of a
/// backward-Euler step (the step's |x − x₀|²/(2h) term, h = 1/stiffness).
pub(super) struct Anchor {
    pub(super) position: Vec<Vector3<f64>>,
    pub(super) stiffness: f64,
    /// Each particle's force before the pull in the last [`Anchor::net_forces`]: the loads'
    /// alone at those positions (the bits of each coordinate; atomic, so that the evaluation's
    /// tasks write their own particles through a shared reference).
    unpulled: Vec<[AtomicU64; 3]>,
}

impl Anchor {
    /// Springs at `position` of stiffness `stiffness`.
    pub(super) fn new(position: Vec<Vector3<f64>>, stiffness: f64) -> Self {
        let unpulled = position.iter().map(|_| Default::default()).collect();
        Self {
            position,
            stiffness,
            unpulled,
        }
    }

    /// Adds particle i's spring force −c (x − x₀) to its net force.
    pub(super) fn pull(&self, i: usize, position: &[Vector3<f64>], force: &mut Load) {
        force.0 -= self.stiffness * (position[i] - self.position[i]);
    }

    /// The net forces at `at` (the loads and this anchor) into `force`, in one pass (`list`
    /// brought up to date there); returns the largest.
    pub(super) fn net_forces(
        &self,
        (loads, container): (&Loads, &Container),
        at: &[Vector3<f64>],
        (list, force): (&mut NeighborList<3>, &mut [Load]),
        work: &mut ContactWork,
    ) -> f64 {
        let then = |i: usize, f: &mut Load| {
            let kept = &self.unpulled[i];
            for (bits, x) in kept.iter().zip(f.0.iter()) {
                bits.store(x.to_bits(), Ordering::Relaxed);
            }
            self.pull(i, at, f);
        };
        loads.evaluate(at, container, list, force, work, then)[0]
    }

    /// Sets `force` to what [`Loads::evaluate`] gives, without the anchor, at the positions of
    /// the last [`Anchor::net_forces`] into it, without a second walk over the contacts: the
    /// forces before the pull, and the other fields as they are (the pull moves the force
    /// alone). Returns the largest force, summed stiffness and overlap, as `evaluate` does.
    fn unpull(&self, force: &mut [Load]) -> [f64; 3] {
        (force.par_iter_mut().zip(&self.unpulled))
            .with_max_len(EVALUATE_PIECE)
            .map(|(f, kept)| {
                f.0 = Vector3::from(
                    kept.each_ref()
                        .map(|x| f64::from_bits(x.load(Ordering::Relaxed))),
                );
                [f.0.norm(), f.1, f.2]
            })
            .reduce(|| [0.0; 3], |a, b| [0, 1, 2].map(|k| f64::max(a[k], b[k])))
    }
}

impl Packing {
    /// Backward-Euler steps of γ ẋ = F (the `relax` stage's forces, no settling force) until
    /// the largest overlap is below `tolerance`; `step` is h k_max, and each step is solved
    /// until its largest net force is below `reduction` times its value at the step's start.
    /// Returns the force evaluations and what the contact sums cost (the last evaluation at
    /// the released positions).
    pub(super) fn release(
        &mut self,
        stages: &Stages,
        step: f64,
        (reduction, step_solver): (f64, StepSolver),
        tolerance: f64,
    ) -> Result<(usize, ContactWork), String> {
        let Packing {
            radius,
            position,
            container,
            ..
        } = self;
        let loads = stages.release_loads(radius);
        let mut solver = ConjugateGradients::new(position.len());
        let mut newton = (step_solver == StepSolver::Newton).then(|| Newton::new(position.len()));
        let mut work = ContactWork::default();
        let mut anchor = Anchor::new(position.clone(), 0.0);
        // whether the last force evaluation was the anchor's, at `position` (both solvers end
        // a step with one there): the loads alone are then known without another evaluation
        let mut pulled_here = false;
        loop {
            let force = &mut solver.force;
            let [max_force, max_stiffness, max_overlap] = if pulled_here {
                anchor.unpull(force)
            } else {
                let list = &mut solver.list;
                loads.evaluate(position, container, list, force, &mut work, as_gathered)
            };
            // (a bed whose forces all balance exactly is at rest: γ ẋ = F no longer moves it)
            if max_overlap < tolerance || max_force == 0.0 {
                return Ok((work.evaluations as usize, work));
            }
            if work.evaluations as usize >= MAX_STEPS {
                return Err(format!(
                    "packing: the release did not finish within {MAX_STEPS} force evaluations"
                ));
            }
            anchor.position.copy_from_slice(position);
            anchor.stiffness = max_stiffness / step;
            if newton.is_some() {
                // large beds: h also at most MAX_MOVE/F_max, the step after which the
                // fastest particle would have moved MAX_MOVE at its starting speed (the
                // loaded bed's first steps would otherwise ask each Newton step to cross
                // several MAX_MOVE: results/bench/README.md, "The release's early steps")
                anchor.stiffness = anchor.stiffness.max(max_force / MAX_MOVE);
            }
            let target = reduction * max_force;
            // the forces just evaluated are the step's start: the anchor pulls with zero there
            let solved = newton.as_mut().is_some_and(|newton| {
                let ConjugateGradients { list, force, .. } = &mut solver;
                let problem = (&loads, &*container, &anchor);
                newton.minimize(
                    position,
                    problem,
                    (list, force),
                    target,
                    max_force,
                    &mut work,
                )
            });
            if !solved {
                solver.minimize(position, &loads, container, &anchor, target, &mut work)?;
            }
            pulled_here = true;
        }
    }
}

/// Nonlinear conjugate gradients (Polak–Ribière+, restarted along the force when the
/// direction stops descending) on one backward-Euler step; each iteration takes one Newton
/// step along its direction, the curvature measured by a second force evaluation a
/// `PROBE_MOVE` away.
struct ConjugateGradients {
    list: NeighborList<3>,
    force: Vec<Load>,
    probe: Vec<Load>,
    trial: Vec<Vector3<f64>>,
    direction: Vec<Vector3<f64>>,
    previous: Vec<Vector3<f64>>,
}

impl ConjugateGradients {
    fn new(n: usize) -> Self {
        let zero: Load = (Vector3::zeros(), 0.0, 0.0, 0);
        Self {
            // the release moves little: a list rebuilt on the displacements' spread
            list: NeighborList::rebuilt_on_spread(SKIN),
            force: vec![zero; n],
            // the rest is allocated on first use (a release solved by Newton steps may need none)
            probe: Vec::new(),
            trial: Vec::new(),
            direction: Vec::new(),
            previous: Vec::new(),
        }
    }

    /// Allocates the search's vectors, once.
    fn reserve(&mut self) {
        let n = self.force.len();
        if self.trial.len() != n {
            self.probe = self.force.clone();
            self.trial = vec![Vector3::zeros(); n];
            self.direction = vec![Vector3::zeros(); n];
            self.previous = vec![Vector3::zeros(); n];
        }
    }

    /// Sets the search direction to f + β d (`None`: to f itself) and returns Σ f·d and the
    /// largest |d|, in one pass.
    fn steer(&mut self, beta: Option<f64>) -> (f64, f64) {
        let force = &self.force;
        let ([descent], reach) = ordered_update(&mut self.direction, |i, d| {
            let f = force[i].0;
            *d = beta.map_or(f, |beta| f + beta * *d);
            ([f.dot(d)], d.norm())
        });
        (descent, reach)
    }

    /// Moves `position` to the minimizer of U + anchor until the largest net force is below
    /// `target`, starting from `self.force`, the forces at `position` (= the anchor's).
    fn minimize(
        &mut self,
        position: &mut [Vector3<f64>],
        loads: &Loads,
        container: &Container,
        anchor: &Anchor,
        target: f64,
        work: &mut ContactWork,
    ) -> Result<(), String> {
        self.reserve();
        let n = position.len();
        let mut net_force = |at: &[Vector3<f64>], force: &mut [Load], list: &mut _| {
            anchor.net_forces((loads, container), at, (list, force), work)
        };
        let mut max_force = f64::INFINITY;
        let (_, mut reach) = self.steer(None);
        for _ in 0..MAX_STEPS {
            if max_force < target {
                return Ok(());
            }
            reach = reach.max(f64::MIN_POSITIVE);
            let eps = PROBE_MOVE / reach;
            (self
                .trial
                .par_iter_mut()
                .zip(&*position)
                .zip(&self.direction))
            .for_each(|((t, x), d)| *t = x + eps * d);
            net_force(&self.trial, &mut self.probe, &mut self.list);
            let (f, p, d) = (&self.force, &self.probe, &self.direction);
            let [slope, change] =
                ordered_sums(n, |i| [f[i].0.dot(&d[i]), (f[i].0 - p[i].0).dot(&d[i])]);
            let curvature = change / eps;
            // a Newton step along d, never moving a particle further than MAX_MOVE
            let newton = if curvature > 0.0 {
                slope / curvature
            } else {
                f64::INFINITY
            };
            let alpha = newton.min(MAX_MOVE / reach);
            (position
                .par_iter_mut()
                .zip(&mut self.previous)
                .zip(d)
                .zip(f))
            .for_each(|(((x, old), d), f)| {
                *x += alpha * d;
                *old = f.0;
            });
            max_force = net_force(position, &mut self.force, &mut self.list);
            let (f, old) = (&self.force, &self.previous);
            let [gain, old_squared] = ordered_sums(n, |i| {
                [f[i].0.dot(&(f[i].0 - old[i])), old[i].norm_squared()]
            });
            let beta = (gain / old_squared).max(0.0);
            let descent;
            (descent, reach) = self.steer(Some(beta));
            if descent <= 0.0 {
                (_, reach) = self.steer(None);
            }
        }
        Err("packing: a release step did not converge".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;
    use crate::models::align::dem::contacts::{ContactLaw, Container};
    use crate::models::align::dem::packing::{FlowStatus, Repulsion, Settling, STEP_REDUCTION};
    use crate::models::align::{AlignParams, SettlingScheme};
    use nalgebra::UnitQuaternion;

    /// One sphere (R = 1) pressed into the floor by δ₀: a backward-Euler step of
    /// δ̇ = −F(δ) with the Hertz force F = (4/3) E* √R δ^{3/2} lands on the root of
    /// δ + h F(δ) = δ₀ (solved here by bisection), whatever the solver's path.
    #[test]
    fn one_release_step_is_the_backward_euler_step_of_the_overdamped_motion() {
        let (e_star, overlap0) = (0.55, 0.05);
        let hertz = |d: f64| 4.0 / 3.0 * e_star * d.powf(1.5);
        let packing = Packing {
            radius: vec![1.0],
            position: vec![Vector3::new(2.0, 2.0, 1.0 - overlap0)],
            orientation: vec![UnitQuaternion::identity()],
            container: Container {
                lx: 4.0,
                ly: 4.0,
                top: None,
            },
            steps: [0; 3],
        };
        let law = ContactLaw {
            effective_modulus: e_star,
            friction: 0.0,
            wall_friction: 0.0,
            skin: 0.0,
        };
        let settling = Settling::new(SettlingScheme::Fire, &[1.0]);
        let loads = Loads {
            law: &law,
            repulsion: Repulsion::Hertz,
            settling: &settling,
            down_force: 0.0,
            radius: &packing.radius,
        };
        let h = 40.0;
        let anchor = Anchor::new(packing.position.clone(), 1.0 / h);
        let (mut lo, mut hi) = (0.0, overlap0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid + h * hertz(mid) > overlap0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let mut work = ContactWork::default();
        let container = &packing.container;
        for step_solver in [StepSolver::ConjugateGradients, StepSolver::Newton] {
            let mut position = packing.position.clone();
            let mut solver = ConjugateGradients::new(1);
            let (list, force) = (&mut solver.list, &mut solver.force);
            let [largest, ..] =
                loads.evaluate(&position, container, list, force, &mut work, as_gathered);
            if step_solver == StepSolver::Newton {
                let problem = (&loads, container, &anchor);
                let mut newton = Newton::new(1);
                let done = newton.minimize(
                    &mut position,
                    problem,
                    (list, force),
                    1e-12,
                    largest,
                    &mut work,
                );
                assert!(done);
            } else {
                let target = 1e-12;
                (solver.minimize(&mut position, &loads, container, &anchor, target, &mut work))
                    .unwrap();
            }
            let overlap = 1.0 - position[0].z;
            assert!(
                (overlap - lo).abs() < 1e-9,
                "{step_solver:?}: {overlap} vs {lo}"
            );
            // the step is implicit: it stops short of the explicit step's overshoot
            assert!(overlap > 0.0 && overlap < overlap0);
        }
    }

    /// The same loaded bed released by backward-Euler steps (conjugate gradients inside each)
    /// and by the explicit overdamped motion (Heun steps of 0.8/k_max, the source's scheme): two
    /// independent integrations of γ ẋ = F. The released positions converge to the explicit
    /// ones at first order in the step (backward Euler's order: the distance falls ~10× per
    /// 10× shorter step), and at the default step the bed keeps the explicit release's contact
    /// network, which the inertial release largely loses; solved to the large beds' looser
    /// tolerance, by either solver, it stays as close, and with the large beds' Newton steps
    /// (h also capped at MAX_MOVE/F_max) closer still.
    #[test]
    fn the_overdamped_release_converges_to_explicit_overdamped_steps() {
        let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        let mut params = AlignParams::paper_defaults(material, 0.0);
        params.particles = 200;
        let params = params.packing();
        let n = &params.numerics;
        let (loaded, stages, _) = Packing::loaded(&params, 3).unwrap();
        let done = |s: &FlowStatus| s.max_overlap < n.overlap_tolerance;
        let released = |settling: &Settling| {
            let mut bed = loaded.clone();
            let (_, work) = bed.flow(&stages.law, settling, stages.relax, done).unwrap();
            (bed, work)
        };
        let (explicit, explicit_work) = released(&Settling::new(
            SettlingScheme::SourceDropped,
            &loaded.radius,
        ));
        let (_, inertial_work) = released(&stages.settling);
        let apart_solved_to = |step: f64, solve: (f64, StepSolver)| {
            let mut bed = loaded.clone();
            let (_, work) = bed
                .release(&stages, step, solve, n.overlap_tolerance)
                .unwrap();
            let sum: f64 = (bed.position.iter().zip(&explicit.position))
                .map(|(p, q)| (p - q).norm_squared())
                .sum();
            ((sum / bed.position.len() as f64).sqrt(), work)
        };
        let apart =
            |step: f64| apart_solved_to(step, (STEP_REDUCTION, StepSolver::ConjugateGradients));
        let (near, _) = apart(10.0);
        let (mid, _) = apart(100.0);
        let (far, default_work) = apart(n.release_step);
        assert!(n.release_step == 1e3);
        assert!(near < 0.2 * mid && mid < 0.2 * far, "{near} {mid} {far}");
        let contacts = |w: ContactWork| w.final_contacts as f64;
        let reference = contacts(explicit_work);
        let kept = contacts(default_work);
        assert!(
            (kept - reference).abs() < 0.02 * reference,
            "{kept} vs {reference}"
        );
        // the large beds' looser solves stay as close to the explicit path as the time
        // discretization itself, and keep its contacts
        for solver in [StepSolver::ConjugateGradients, StepSolver::Newton] {
            let solve = (n.release_reduction, solver);
            let (loose, loose_work) = apart_solved_to(n.release_step, solve);
            assert!(loose < 1.5 * far, "{solver:?}: {loose} vs {far}");
            if solver == StepSolver::Newton {
                // its steps capped at MAX_MOVE/F_max follow the early decompression closely
                // (measured: 0.0035 R_av with the local corrections, 0.0057 without them,
                // against 0.065 for the 1 % solves at h k_max = 10³)
                assert!(loose < 0.2 * far, "capped steps: {loose} vs {far}");
                // and its parts are counted: at least a Newton step and a linear iteration
                // per backward-Euler step, each correction at least one visit
                let parts = loose_work.newton;
                assert!(parts.steps > 0 && parts.linear_iterations >= parts.steps);
                assert!(parts.correction_visits >= parts.corrections && parts.corrections > 0);
                assert!(parts.linearize_s > 0.0 && parts.solve_s > 0.0);
            } else {
                assert_eq!(loose_work.newton.steps, 0, "no Newton steps");
            }
            let kept_loosely = contacts(loose_work);
            assert!(
                (kept_loosely - reference).abs() < 0.02 * reference,
                "{solver:?}: {kept_loosely} vs {reference}"
            );
        }
        let inertial = contacts(inertial_work);
        assert!(
            inertial < 0.8 * reference,
            "inertial {inertial} vs {reference}"
        );
    }

    /// The conjugate gradients' sums are the same bits on any number of threads, for sums
    /// whose value depends on the order of addition (terms from 1e16 down to 1).
    #[test]
    fn ordered_sums_are_the_same_at_any_thread_count() {
        let term =
            |i: usize| 10f64.powi((i % 17) as i32) * if i.is_multiple_of(3) { -1.0 } else { 1.0 };
        let sum_on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| ordered_sums(10_000, |i| [term(i)])[0])
        };
        let one = sum_on(1);
        assert_eq!(one.to_bits(), sum_on(2).to_bits());
        assert_eq!(one.to_bits(), sum_on(3).to_bits());
        let serial: f64 = (0..10_000).map(term).sum();
        assert!((one - serial).abs() <= 1e-10 * serial.abs().max(1e16));
    }

    /// The fused update sums its terms with `ordered_sums`' bits at any thread count (the
    /// release's direction update relies on it), updates every item, and returns the largest
    /// of its values.
    #[test]
    fn ordered_update_sums_as_ordered_sums_do() {
        let term =
            |i: usize| 10f64.powi((i % 17) as i32) * if i.is_multiple_of(3) { -1.0 } else { 1.0 };
        let want = ordered_sums(10_001, |i| [term(i), -2.0 * term(i)]);
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut items = vec![0.0; 10_001];
            let (sums, largest) = pool.install(|| {
                ordered_update(&mut items, |i, x| {
                    *x = term(i);
                    ([*x, -2.0 * *x], (i % 977) as f64)
                })
            });
            assert_eq!(sums.map(f64::to_bits), want.map(f64::to_bits), "{threads}");
            assert_eq!(largest, 976.0);
            assert!(items.iter().enumerate().all(|(i, &x)| x == term(i)));
        }
    }

    /// What the anchor keeps of its last net forces is, bit for bit, what a fresh evaluation
    /// of the loads alone gives there: every field of every particle's load and the largest
    /// force, stiffness and overlap (a loaded bed of 300 particles, moved off its anchor).
    #[test]
    fn the_unpulled_forces_are_a_fresh_evaluation_of_the_loads() {
        let (bed, stages) = Packing::loaded_for_tests(300, 5);
        let loads = stages.release_loads(&bed.radius);
        let anchor = Anchor::new(bed.position.clone(), 0.7);
        let moved: Vec<_> = (bed.position.iter().enumerate())
            .map(|(i, x)| x + 0.01 * Vector3::new((1.7 * i as f64).sin(), 0.5, -0.3))
            .collect();
        let zero: Load = (Vector3::zeros(), 0.0, 0.0, 0);
        let (mut pulled, mut fresh) = (vec![zero; moved.len()], vec![zero; moved.len()]);
        let mut list = NeighborList::rebuilt_on_spread(SKIN);
        let mut work = ContactWork::default();
        let sources = (&loads, &bed.container);
        anchor.net_forces(sources, &moved, (&mut list, &mut pulled), &mut work);
        assert!(pulled.iter().any(|f| f.1 > 0.0), "a bed with contacts");
        let largest = anchor.unpull(&mut pulled);
        let container = &bed.container;
        let expected = loads.evaluate(
            &moved,
            container,
            &mut list,
            &mut fresh,
            &mut work,
            as_gathered,
        );
        assert_eq!(largest.map(f64::to_bits), expected.map(f64::to_bits));
        for (a, b) in pulled.iter().zip(&fresh) {
            assert_eq!(a.0.map(f64::to_bits), b.0.map(f64::to_bits));
            assert_eq!(
                (a.1.to_bits(), a.2.to_bits(), a.3),
                (b.1.to_bits(), b.2.to_bits(), b.3)
            );
        }
    }
}
