//! The Coulomb limit of the velocity problem (`friction_scheme = coulomb-limit`; docs/align.md,
//! "The Coulomb limit"): Φ of `velocity` with v_ε = 0, whose friction term μ F_n |v_t,c| is
//! convex but not smooth.
//!
//! Descending Φ particle by particle would stall: two particles stuck together and pushed the
//! same way can only move together, and moving either one alone costs friction. The solve
//! therefore keeps the friction force f_c of every contact as an unknown of its own (the
//! primal–dual form: μ F_n |s| = max over |f| ≤ μ F_n of −f·s) and sweeps in the Gauss–Seidel
//! order of `velocity`. For each particle: (1) its frictionless local problem under the
//! current friction forces of its contacts (damped Newton, as in `velocity`); (2) for each of
//! its friction-carrying contacts, the projected step f_c ← Π(f_c − s_c / W_c) onto the disc
//! |f_c| ≤ μ F_n of the tangent plane, with s_c the slip and W_c the tangential compliance
//! under drag alone (2 for each sphere: 1 from translation, 1 from rotation), and both
//! particles' velocities moved by their drag response to the change (projected Gauss–Seidel,
//! as in nonsmooth contact dynamics). A fixed point obeys Coulomb's law exactly: s_c = 0 with
//! |f_c| ≤ μ F_n (stick), or |f_c| = μ F_n against s_c (slide). The forces carry over from one
//! solve to the next (warm start), keyed by the particle and its partner.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::contacts::{Contact, ContactLaw, ContactSet, LID};
use super::velocity::{
    relax_lid, solve_particle, Local, Motion, Schedule, SolveStats, SolverControl, Stage, Terms,
};

/// A contact's identity across solves: particle, partner, and for a wall which one (its
/// outward normal's axis and sense; 0 for a particle partner or the lid).
type ContactKey = (u32, u32, u8);

/// Friction forces of the contacts (on the listing particle, reduced units), aligned with
/// `ContactSet::all`, and those of the last solve by contact identity.
#[derive(Debug, Default)]
pub struct FrictionForces {
    force: Vec<Vector3<f64>>,
    /// For each listed contact, where its partner lists it (pairs only).
    mirror: Vec<Option<usize>>,
    previous: HashMap<ContactKey, Vector3<f64>>,
}

impl FrictionForces {
    /// Aligns the forces with the stage's contacts, each starting from its value in the last
    /// solve projected onto its current tangent disc.
    fn prepare(&mut self, contacts: &ContactSet, law: &ContactLaw, n: usize) {
        self.force.clear();
        self.mirror.clear();
        for i in 0..n {
            for c in contacts.of(i) {
                let start = self.previous.get(&key(i, &c)).copied().unwrap_or_default();
                self.force.push(project(start, c.normal, bound(law, &c)));
                self.mirror
                    .push(c.particle().and_then(|j| contacts.slot_of(j, i)));
            }
        }
    }

    /// Keeps the forces of this solve for the next one.
    fn remember(&mut self, contacts: &ContactSet, n: usize) {
        self.previous.clear();
        for i in 0..n {
            for (c, f) in contacts.of(i).zip(&self.force[contacts.slots(i)]) {
                if *f != Vector3::zeros() {
                    self.previous.insert(key(i, &c), *f);
                }
            }
        }
    }
}

fn key(i: usize, c: &Contact) -> ContactKey {
    let wall = match c.particle() {
        Some(_) => 0,
        None if c.partner == LID => 0,
        None => {
            let axis = c.normal.iamax();
            1 + 2 * axis as u8 + u8::from(c.normal[axis] > 0.0)
        }
    };
    (i as u32, c.partner, wall)
}

/// The friction bound μ F_n at the stage's overlap.
fn bound(law: &ContactLaw, c: &Contact) -> f64 {
    law.friction_of(c) * c.normal_force_at(c.overlap)
}

/// f projected onto the tangent plane of e and then onto the disc of radius `bound`.
fn project(f: Vector3<f64>, e: Vector3<f64>, bound: f64) -> Vector3<f64> {
    let tangential = f - f.dot(&e) * e;
    let size = tangential.norm();
    if size > bound {
        tangential * (bound / size)
    } else {
        tangential
    }
}

/// Solves the stage problem in its Coulomb limit (the stage's `slip_scale` only sets Newton's
/// stop), starting from `motion`, the lid's velocity and the friction forces of the last solve.
pub fn solve(
    stage: &Stage,
    schedule: &Schedule,
    motion: &mut [Motion],
    lid_velocity: &mut f64,
    control: SolverControl,
    friction: &mut FrictionForces,
) -> SolveStats {
    let n = motion.len();
    friction.prepare(stage.contacts, stage.law, n);
    let smooth_law = ContactLaw {
        friction: 0.0,
        wall_friction: 0.0,
        ..*stage.law
    };
    let smooth = Stage {
        law: &smooth_law,
        ..*stage
    };
    let lid_contacts = stage.lid_contacts();
    // plain Gauss–Seidel: over-relaxation is validated for the smooth problem only
    let plain = SolverControl {
        over_relaxation: 1.0,
        ..control
    };
    let mut stats = SolveStats::default();
    while stats.sweeps < control.max_sweeps {
        stats.sweeps += 1;
        let w = *lid_velocity;
        let mut largest_change: f64 = 0.0;
        let mut terms = Terms::default();
        for i in schedule.order() {
            let moved = relax_particle(&smooth, (i, w), motion, &mut terms, friction, plain);
            let slipped = relax_friction(stage, i, motion, w, friction);
            largest_change = largest_change.max(moved).max(slipped);
        }
        if let Some(lid) = &stage.lid {
            *lid_velocity = relax_lid(lid, stage.dt, &lid_contacts, motion);
            largest_change = largest_change.max((*lid_velocity - w).abs());
        }
        if largest_change <= control.tolerance {
            stats.converged = true;
            break;
        }
    }
    friction.remember(stage.contacts, n);
    stats
}

/// Particle i's frictionless local problem under its contacts' current friction forces;
/// returns the size of its change.
fn relax_particle(
    smooth: &Stage,
    (i, lid_velocity): (usize, f64),
    motion: &mut [Motion],
    terms: &mut Terms,
    friction: &FrictionForces,
    control: SolverControl,
) -> f64 {
    let r = smooth.radius[i];
    let mut force = smooth.force[i];
    let mut torque = smooth.torque[i];
    for (c, f) in smooth
        .contacts
        .of(i)
        .zip(&friction.force[smooth.contacts.slots(i)])
    {
        force += f;
        torque += r * c.normal.cross(f);
    }
    let partner_velocity = |c: &Contact| smooth.partner_velocity(c, lid_velocity, |j| motion[j]);
    let local = Local::new(smooth, i, (force, torque), terms, partner_velocity);
    let old = motion[i];
    let new = solve_particle(&local, old, control);
    motion[i] = new;
    (new.v - old.v).norm() + r * (new.w - old.w).norm()
}

/// The projected step of each friction-carrying contact of particle i, with the drag response
/// of both particles; returns the largest change of a friction force.
fn relax_friction(
    stage: &Stage,
    i: usize,
    motion: &mut [Motion],
    lid_velocity: f64,
    friction: &mut FrictionForces,
) -> f64 {
    let mut largest_change: f64 = 0.0;
    for slot in stage.contacts.slots(i) {
        let c = stage.contacts.contact(i, slot);
        let limit = bound(stage.law, &c);
        if limit == 0.0 {
            continue;
        }
        let e = c.normal;
        let partner = stage.partner_velocity(&c, lid_velocity, |j| motion[j]);
        let rel = motion[i].v + stage.radius[i] * motion[i].w.cross(&e) - partner;
        let slip = rel - rel.dot(&e) * e;
        // A tangential force f at the contact moves a sphere's surface there by 2f under drag.
        let compliance = if c.particle().is_some() { 4.0 } else { 2.0 };
        let old = friction.force[slot];
        let new = project(old - slip / compliance, e, limit);
        let change = new - old;
        friction.force[slot] = new;
        push(&mut motion[i], stage.radius[i], e, change);
        if let (Some(j), Some(mirror)) = (c.particle(), friction.mirror[slot]) {
            friction.force[mirror] = -new;
            push(&mut motion[j], stage.radius[j], -e, -change);
        }
        largest_change = largest_change.max(change.norm());
    }
    largest_change
}

/// Drag response of a sphere of radius r to a force f added at its surface point r e.
fn push(m: &mut Motion, r: f64, e: Vector3<f64>, f: Vector3<f64>) {
    m.v += f;
    m.w += e.cross(&f) / r;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::contacts::pressed_pair;
    use crate::models::align::dem::velocity;

    /// The pressed pair (normal along x, overlap held by equal and opposite pushes), both
    /// spun about z by the torque `spin`, solved in the Coulomb limit, or regularized with
    /// `slip_scale` when given.
    fn spun_pair(spin: f64, slip_scale: Option<f64>) -> (Vec<Motion>, f64) {
        let (positions, radius, law, contacts) = pressed_pair(0.5);
        let c = contacts.contact(0, 0);
        let push = c.normal_force_at(c.overlap);
        let torque = vec![Vector3::new(0.0, 0.0, spin); 2];
        let force = vec![Vector3::new(push, 0.0, 0.0), Vector3::new(-push, 0.0, 0.0)];
        let stage = Stage {
            contacts: &contacts,
            law: &law,
            radius: &radius,
            force: &force,
            torque: &torque,
            dt: 1.0,
            slip_scale: slip_scale.unwrap_or(1e-12),
            lid: None,
        };
        let mut motion = vec![Motion::default(); 2];
        let schedule = Schedule::new(&positions, 3.0, usize::MAX);
        let control = SolverControl {
            tolerance: 1e-15,
            max_sweeps: 2000,
            over_relaxation: 1.0,
        };
        let stats = match slip_scale {
            None => solve(
                &stage,
                &schedule,
                &mut motion,
                &mut 0.0,
                control,
                &mut FrictionForces::default(),
            ),
            Some(_) => velocity::solve(&stage, &schedule, &mut motion, &mut 0.0, control),
        };
        assert!(stats.converged, "{stats:?}");
        (motion, 0.5 * push)
    }

    /// Equal spins T about z: the surfaces slide by 2(2 f + T/r) at the contact (f the friction
    /// force on the first sphere, r = 1), so the pair sticks with f = −T/2 while T/2 ≤ μ F_n
    /// (each turning at T/2, drifting at ∓T/2) and slides above with |f| = μ F_n exactly.
    #[test]
    fn a_contact_sticks_below_the_coulomb_threshold_and_slides_with_mu_fn_above() {
        let (_, limit) = spun_pair(0.0, None);
        for spin in [0.5 * limit, 1.9 * limit] {
            let (motion, _) = spun_pair(spin, None);
            for (m, side) in motion.iter().zip([1.0, -1.0]) {
                assert!((m.w.z - spin / 2.0).abs() < 1e-12 * limit, "{m:?}");
                assert!((m.v - Vector3::new(0.0, -side * spin / 2.0, 0.0)).norm() < 1e-12 * limit);
            }
        }
        for spin in [2.1 * limit, 10.0 * limit] {
            let (motion, _) = spun_pair(spin, None);
            for (m, side) in motion.iter().zip([1.0, -1.0]) {
                assert!((m.w.z - (spin - limit)).abs() < 1e-12 * limit, "{m:?}");
                assert!((m.v - Vector3::new(0.0, -side * limit, 0.0)).norm() < 1e-12 * limit);
            }
        }
    }

    /// As v_ε → 0 the regularized solve approaches the Coulomb limit, on both sides of the
    /// threshold, with an error that shrinks with v_ε.
    #[test]
    fn the_regularized_solve_approaches_the_limit_as_the_slip_scale_falls() {
        let (_, limit) = spun_pair(0.0, None);
        for spin in [1.5 * limit, 3.0 * limit] {
            let (exact, _) = spun_pair(spin, None);
            let gap = |scale: f64| {
                let (motion, _) = spun_pair(spin, Some(scale * limit));
                (motion[0].w.z - exact[0].w.z).abs() + (motion[0].v - exact[0].v).norm()
            };
            let (coarse, fine) = (gap(1e-2), gap(1e-5));
            assert!(
                fine < 1e-2 * coarse && fine < 1e-4 * limit,
                "{coarse} {fine}"
            );
        }
    }
}
