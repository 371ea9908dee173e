//! Newton steps for the release's backward-Euler steps (docs/align.md, "The release"), used
//! from `Numerics::large_bed_from` particles on. Each Newton step linearizes the net force
//! (Hertz contacts, surfaces, the anchor) about the current positions, stores each touching
//! contact's stiffness once, and solves H p = F by linear conjugate gradients on the stored
//! stiffnesses; the true forces are evaluated again only after the step.
//!
//! Why: nonlinear conjugate gradients pay two force evaluations per iteration (the step and a
//! curvature probe), each a walk over the whole neighbour list. A product with the stored
//! stiffnesses walks the touching pairs alone, a fifth to a third of an evaluation. The minimizer
//! of each backward-Euler step is the same whichever solver finds it, to the solve's tolerance.
//!
//! H keeps each contact's normal stiffness dF/dδ and drops the geometric term F/r across the
//! normal (a pushed pair that slides sideways opens, which softens those directions): without
//! it H is positive definite (the anchor adds c I), as the conjugate gradients need; with it
//! near-floppy particles made steps of tens of radii. The stop rule uses the true forces, so
//! the approximation costs Newton steps, not accuracy.
//!
//! After each Newton step that leaves at most a tenth of the particles at the target force or
//! above, `local` corrects them particle by particle before the forces are evaluated again:
//! the overshoots of gaps the step closed, which took most of the Newton steps before
//! (results/bench/README.md, "Local corrections in the release").

use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;

use super::hertz_lanes::touching_contacts;
use super::local::Corrections;
use super::release::Anchor;
use super::{ordered_update_in, ContactWork, Load, Loads, Repulsion, MAX_MOVE};
use crate::models::align::dem::contacts::{Contact, Container};
use crate::neighbor::NeighborList;

/// Partner code of a surface contact in a [`Spring`] (its partner does not move).
const FIXED: u32 = u32::MAX;

/// Each Newton step's linear solve stops once its largest residual is below this fraction of
/// the largest net force it started from (an inexact Newton method's forcing term: a tighter
/// solve is wasted on a linear model that the step's opening and closing contacts spoil).
const FORCING: f64 = 0.3;

/// The linear solve's residual target as a fraction of the step's: the linear model stops a
/// little below it, so that the last Newton step usually meets the true target.
const INNER: f64 = 0.5;

/// Newton steps after which a backward-Euler step is handed to the nonlinear conjugate
/// gradients (in a trace at N = 10⁴, of a build before the final chunking, the most any step
/// took was 52, the median 6).
const NEWTON_LIMIT: usize = 100;

/// Particles per chunk of the stored stiffnesses and of the solve's sums (the chunk fixes the
/// sums' bits). Small enough that the chunks of a bed of 10⁴ spread evenly over the threads.
const CHUNK: usize = 256;

/// Iterations after which a linear solve stops short (a bound, far above the few dozen a solve
/// takes).
const LINEAR_LIMIT: usize = 1000;

/// One contact of a linearization: its stiffness k acting on the relative displacement
/// Δ = d_i − d_j (d_j = 0 for a surface) adds k (n·Δ) n = (m·Δ) m to (H d)_i, stored as
/// m = √k n: 16 bytes a contact, which the solves stream once per product. Single precision:
/// the product only steers the solve, whose stop rule uses the true forces.
#[derive(Debug, Clone, Copy)]
struct Spring {
    partner: u32,
    scaled_normal: [f32; 3],
}

impl Spring {
    fn new(partner: u32, normal: Vector3<f64>, stiffness: f64) -> Self {
        Self {
            partner,
            scaled_normal: (stiffness.sqrt() * normal).map(|x| x as f32).into(),
        }
    }
}

/// H at one set of positions, stored as each particle's touching contacts in chunks of
/// `CHUNK` particles (products summed in chunk order: the same bits at any thread count).
#[derive(Debug, Default)]
struct Stiffness {
    chunks: Vec<Chunk>,
    anchor: f64,
}

#[derive(Debug, Default)]
struct Chunk {
    springs: Vec<Spring>,
    /// End of each particle's springs in `springs`.
    end: Vec<u32>,
}

impl Stiffness {
    /// Stores the touching contacts at `position` (`list` up to date there) and the anchor's
    /// stiffness.
    fn linearize(
        &mut self,
        loads: &Loads,
        position: &[Vector3<f64>],
        container: &Container,
        list: &NeighborList<3>,
        anchor: f64,
    ) {
        let n = position.len();
        self.anchor = anchor;
        self.chunks.resize_with(n.div_ceil(CHUNK), Chunk::default);
        let (law, radius, repulsion) = (loads.law, loads.radius, loads.repulsion);
        self.chunks
            .par_iter_mut()
            .enumerate()
            .for_each(|(c, chunk)| {
                let Chunk { springs, end } = chunk;
                springs.clear();
                end.clear();
                for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    let mut spring = |partner, normal, stiffness: f64| {
                        if stiffness > 0.0 {
                            springs.push(Spring::new(partner, normal, stiffness));
                        }
                    };
                    let stiffness = |c: &Contact| repulsion.force_and_stiffness(c).1;
                    match repulsion {
                        Repulsion::Hertz => {
                            touching_contacts(law, i, position, radius, list, &mut spring)
                        }
                        Repulsion::Harmonic => {
                            law.particle_contacts_of(i, position, radius, list, |j, c| {
                                spring(j, c.normal, stiffness(&c))
                            })
                        }
                    }
                    law.wall_contacts_of(i, position, radius, container, |_, c| {
                        spring(FIXED, c.normal, stiffness(&c))
                    });
                    end.push(springs.len() as u32);
                }
            });
    }

    /// The conjugate gradients' updates that need no sum first, in one pass: with the
    /// residuals r, the last step length α and the coefficient β, p ← p + α d, then
    /// d ← r + β d and q ← H r + β q, which is H d (H is linear); returns d·q. One pass
    /// instead of three: on two threads each pass on the pool costs about 15 µs beyond its
    /// work, against about 105 µs for a product at 10⁴ (results/bench/README.md, "The
    /// release's passes on two threads").
    fn conjugate(&self, residual: &[Vector3<f32>], (alpha, beta): (f64, f64), cg: Cg) -> f64 {
        let Cg {
            step,
            direction,
            product,
            partial,
        } = cg;
        let (alpha, beta, anchor) = (alpha as f32, beta as f32, self.anchor as f32);
        (self.chunks.par_iter())
            .zip(step.par_chunks_mut(CHUNK))
            .zip(direction.par_chunks_mut(CHUNK))
            .zip(product.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (((chunk, step), direction), product))| {
                let mut start = 0;
                let mut curvature = 0.0;
                let rows = (step.iter_mut().zip(direction).zip(product)).zip(&chunk.end);
                for (k, (((p, d), q), &end)) in rows.enumerate() {
                    let ri = residual[c * CHUNK + k];
                    let mut h = anchor * ri;
                    for s in &chunk.springs[start..end as usize] {
                        let delta = match s.partner {
                            FIXED => ri,
                            j => ri - residual[j as usize],
                        };
                        let m = Vector3::from(s.scaled_normal);
                        h += m.dot(&delta) * m;
                    }
                    *p += alpha * *d;
                    *d = ri + beta * *d;
                    *q = h + beta * *q;
                    curvature += d.cast::<f64>().dot(&q.cast::<f64>());
                    start = end as usize;
                }
                curvature
            })
            .collect_into_vec(partial);
        partial.iter().fold(0.0, |a, b| a + b)
    }
}

/// The per-particle vectors of a linear conjugate-gradient solve besides the residual: the
/// Newton step p, the search direction d and its product q = H d; and the chunks' partial
/// sums of d·q (kept between iterations: no allocation per product). The vectors, like the
/// residual, are single precision: a solve streams them once or twice per iteration and, at
/// large N, waits on memory; it only steers the Newton step, and its sums are double
/// (results/bench/README.md, "The release's solve in single precision").
struct Cg<'a> {
    step: &'a mut [Vector3<f32>],
    direction: &'a mut [Vector3<f32>],
    product: &'a mut [Vector3<f32>],
    partial: &'a mut Vec<f64>,
}

/// Newton's method with linear conjugate gradients inside, on one backward-Euler step.
pub(super) struct Newton {
    stiffness: Stiffness,
    residual: Vec<Vector3<f32>>,
    step: Vec<Vector3<f32>>,
    direction: Vec<Vector3<f32>>,
    product: Vec<Vector3<f32>>,
    partial: Vec<f64>,
    local: Corrections,
}

impl Newton {
    pub(super) fn new(n: usize) -> Self {
        Self {
            stiffness: Stiffness::default(),
            residual: vec![Vector3::zeros(); n],
            step: vec![Vector3::zeros(); n],
            direction: vec![Vector3::zeros(); n],
            product: vec![Vector3::zeros(); n],
            partial: Vec::new(),
            local: Corrections::default(),
        }
    }

    /// Moves `position` towards the minimizer of U + anchor until the largest net force is
    /// below `target`, starting from `force`, the net forces at `position` (`list` up to date
    /// there), whose largest is `max_force`; `force` and `list` follow the moves. Each Newton
    /// step is followed by local corrections where few particles are left above the target.
    /// Returns whether it got there within `NEWTON_LIMIT` steps.
    pub(super) fn minimize(
        &mut self,
        position: &mut [Vector3<f64>],
        (loads, container, anchor): (&Loads, &Container, &Anchor),
        (list, force): (&mut NeighborList<3>, &mut [Load]),
        target: f64,
        mut max_force: f64,
        work: &mut ContactWork,
    ) -> bool {
        for _ in 0..NEWTON_LIMIT {
            if max_force < target {
                return true;
            }
            let (c, at) = (anchor.stiffness, &*position);
            let start = Instant::now();
            self.stiffness.linearize(loads, at, container, list, c);
            let solving = Instant::now();
            let tolerance = (INNER * target).max(FORCING * max_force);
            let iterations = self.solve_linear(force, tolerance);
            let parts = &mut work.newton;
            parts.steps += 1;
            parts.linear_iterations += iterations as u64;
            parts.linearize_s += (solving - start).as_secs_f64();
            parts.solve_s += solving.elapsed().as_secs_f64();
            // never moving a particle further than MAX_MOVE (the whole step scaled)
            let reach = (self.step.par_iter())
                .map(|p| f64::from(p.norm()))
                .reduce(|| 0.0, f64::max);
            let scale = (MAX_MOVE / reach).min(1.0);
            (position.par_iter_mut().zip(&self.step))
                .for_each(|(x, p)| *x += scale * p.cast::<f64>());
            let (sources, problem) = ((loads, container), (loads, container, anchor));
            max_force = anchor.net_forces(sources, position, (list, force), work);
            if max_force >= target && self.correct(position, problem, (list, force), target, work) {
                max_force = anchor.net_forces(sources, position, (list, force), work);
            }
        }
        max_force < target
    }

    /// `Corrections::correct`, its time (whether it ran or not) and visits counted in `work`;
    /// returns whether it ran.
    fn correct(
        &mut self,
        position: &mut [Vector3<f64>],
        problem: (&Loads, &Container, &Anchor),
        (list, force): (&NeighborList<3>, &mut [Load]),
        target: f64,
        work: &mut ContactWork,
    ) -> bool {
        let start = Instant::now();
        let visits = self.local.correct(position, problem, list, force, target);
        let parts = &mut work.newton;
        parts.corrections_s += start.elapsed().as_secs_f64();
        parts.corrections += u64::from(visits.is_some());
        parts.correction_visits += visits.unwrap_or(0) as u64;
        visits.is_some()
    }

    /// Solves H p = F into `self.step` until the largest residual is below `target`, until H
    /// stops being positive along the search direction (round-off in a floppy bed), or for at
    /// most `LINEAR_LIMIT` iterations (the Newton step then takes the solve as it stands).
    /// Returns the iterations.
    fn solve_linear(&mut self, force: &[Load], target: f64) -> usize {
        let ([mut rr], _) = ordered_update_in(CHUNK, &mut self.residual, |i, r| {
            *r = force[i].0.cast::<f32>();
            ([r.cast::<f64>().norm_squared()], 0.0)
        });
        self.step.par_iter_mut().for_each(|p| *p = Vector3::zeros());
        let (mut alpha, mut beta) = (0.0, 0.0);
        let mut iterations = 0;
        while iterations < LINEAR_LIMIT {
            iterations += 1;
            let cg = Cg {
                step: &mut self.step,
                direction: &mut self.direction,
                product: &mut self.product,
                partial: &mut self.partial,
            };
            let curvature = (self.stiffness).conjugate(&self.residual, (alpha, beta), cg);
            // H not positive along d (or a NaN curvature): keep the step so far
            if curvature.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return iterations;
            }
            alpha = rr / curvature;
            let q = &self.product;
            let ([next], largest) = ordered_update_in(CHUNK, &mut self.residual, |i, r| {
                *r -= (alpha as f32) * q[i];
                let r2 = r.cast::<f64>().norm_squared();
                ([r2], r2)
            });
            // the largest |r| from the largest |r|²: one root, not one per particle (the same
            // value: the root is monotone)
            if largest.sqrt() < target {
                break;
            }
            beta = next / rr;
            rr = next;
        }
        (self.step.par_iter_mut().zip(&self.direction)).for_each(|(p, d)| *p += (alpha as f32) * d);
        iterations
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::packing::{as_gathered, Packing, SKIN};

    /// The stored stiffnesses' product is the derivative of the net forces along d,
    /// (F(x) − F(x + ε d))/ε, on a loaded bed of 200 particles (anchor included), less the
    /// geometric term H drops: Σ_j (F_ij/r_ij)(Δ − (n·Δ) n) over the touching pairs, summed
    /// here pair by pair over every pair of the bed.
    #[test]
    fn the_stored_stiffness_is_the_derivative_of_the_forces_less_the_geometric_term() {
        let (bed, stages) = Packing::loaded_for_tests(200, 3);
        let (x, radius) = (&bed.position, &bed.radius);
        let loads = stages.release_loads(radius);
        let n = x.len();
        let mut list = NeighborList::rebuilt_on_spread(SKIN);
        let zero: Load = (Vector3::zeros(), 0.0, 0.0, 0);
        let (mut force, mut moved_force) = (vec![zero; n], vec![zero; n]);
        let mut work = ContactWork::default();
        let largest = loads.evaluate(
            x,
            &bed.container,
            &mut list,
            &mut force,
            &mut work,
            as_gathered,
        );
        let anchor = Anchor::new(x.clone(), 1e-3 * largest[1]);
        let mut newton = Newton::new(n);
        (newton.stiffness).linearize(&loads, x, &bed.container, &list, anchor.stiffness);
        let d: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let t = i as f64;
                Vector3::new((1.3 * t).sin(), (2.1 * t).cos(), (0.7 * t + 1.0).sin())
            })
            .collect();
        let zeros = || vec![Vector3::zeros(); n];
        let (mut step, mut direction, mut product) = (zeros(), zeros(), zeros());
        let cg = Cg {
            step: &mut step,
            direction: &mut direction,
            product: &mut product,
            partial: &mut Vec::new(),
        };
        let single: Vec<Vector3<f32>> = d.iter().map(|d| d.cast()).collect();
        let curvature = (newton.stiffness).conjugate(&single, (0.0, 0.0), cg);
        assert_eq!(direction, single);
        let product: Vec<Vector3<f64>> = product.iter().map(|p| p.cast()).collect();
        let eps = 1e-7;
        let moved: Vec<_> = x.iter().zip(&d).map(|(x, d)| x + eps * d).collect();
        let then = |i, f: &mut Load| anchor.pull(i, &moved, f);
        loads.evaluate(
            &moved,
            &bed.container,
            &mut list,
            &mut moved_force,
            &mut work,
            then,
        );
        let scale = product.iter().map(|p| p.norm()).fold(0.0, f64::max);
        let mut geometric_terms = 0;
        for i in 0..n {
            let mut geometric = Vector3::zeros();
            for j in (0..n).filter(|&j| j != i) {
                let (u, delta) = (x[j] - x[i], d[i] - d[j]);
                let (r, normal) = (u.norm(), u.normalize());
                let overlap = radius[i] + radius[j] - r;
                if overlap > 0.0 {
                    let hertz = stages.law.hertz_prefactor(radius[i], Some(radius[j]));
                    let pushed = hertz * overlap.powf(1.5);
                    geometric += pushed / r * (delta - normal.dot(&delta) * normal);
                    geometric_terms += 1;
                }
            }
            let derivative = (force[i].0 - moved_force[i].0) / eps;
            let error = (derivative + geometric - product[i]).norm();
            assert!(
                error < 1e-4 * scale,
                "{i}: {derivative:?} vs {:?}",
                product[i]
            );
        }
        assert!(geometric_terms > n, "{geometric_terms}");
        let direct: f64 = (single.iter().zip(&product))
            .map(|(d, p)| d.cast().dot(p))
            .sum();
        assert!(curvature > 0.0 && (curvature - direct).abs() < 1e-9 * direct);
    }
}
