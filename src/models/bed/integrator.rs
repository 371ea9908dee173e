//! Störmer–Verlet (velocity form: half kick, drift, force, half kick) with friction inside the
//! kicks, and the time-step rule.
//!
//! Friction in a half kick of length h from velocity v under the non-friction force F_T:
//! - viscous (B3) is integrated exactly for constant F_T: u = v e^{−h/τ} + (F_T/m) τ (1 − e^{−h/τ});
//!   without it u = v + h F_T/m;
//! - dry (B5), semi-implicit: stick (v → 0) if |v| < v_t and |F_T| ≤ μ_e N; otherwise the slip
//!   law is evaluated at the *end* velocity (backward Euler): v' = u − (h/m) μ_d N v'/(|v'| + v_t),
//!   solved in closed form. v' is parallel to u with 0 ≤ |v'| ≤ |u|, so friction can stop a
//!   particle but never reverse it, at any step size;
//! - the explicit reference evaluates B5 (and B3) at the start velocity (stick: F_F = −F_T, so a stuck
//!   particle keeps its creep velocity below v_t); it needs Δt ≲ m v_t/(μ_d N).
//!
//! Δt = factor/ω_max with ω_max² the largest k/m over every pair and wall interaction at the
//! current closest approaches (and, for the explicit reference, μ_d N/(m v_t)); it is
//! recomputed every step from the state, so the sequence of steps is deterministic.

use nalgebra::Vector2;
use rayon::prelude::*;

use super::forces::{ForceField, ParticleForce};
use super::kick_lanes::{kick_fours, Discs};
use super::observables::Extremes;
use super::params::BedParams;
pub use super::params::FrictionScheme;
use super::state::{Geometry, Particles, State};
use crate::neighbor::Watch;
use crate::numerics::fold_items;

/// From this many particles on, kicks and drifts run on the rayon pool (below it the pool's
/// overhead exceeds the work).
const PARALLEL_UPDATE_FROM: usize = 4096;

/// Friction constants of the kicks.
#[derive(Debug, Clone, Copy)]
pub struct Kick {
    /// Viscous time τ_v, s, or None for no viscous friction.
    pub viscous_time: Option<f64>,
    /// Whether dry friction acts.
    pub dry: bool,
    /// μ_e.
    pub static_friction: f64,
    /// μ_d.
    pub dynamic_friction: f64,
    /// v_t, m/s.
    pub threshold_speed: f64,
    /// Dry-friction scheme.
    pub scheme: FrictionScheme,
}

impl Kick {
    /// The kick of a run's friction model (`damped` forces viscous friction on, as in every
    /// relaxation).
    pub fn of(params: &BedParams, damped: bool) -> Self {
        Self {
            viscous_time: (damped || params.friction.viscous()).then_some(params.viscous_time),
            dry: params.friction.dry(),
            static_friction: params.static_friction,
            dynamic_friction: params.dynamic_friction,
            threshold_speed: params.threshold_speed,
            scheme: params.friction_scheme,
        }
    }

    /// The new velocity after a half kick of length h.
    pub fn velocity(
        &self,
        v: Vector2<f64>,
        force: Vector2<f64>,
        normal: f64,
        m: f64,
        h: f64,
    ) -> Vector2<f64> {
        self.velocity_with(v, force, normal, m, (h, self.viscous_decay(h)))
    }

    /// (τ_v, e^{−h/τ_v}) of a half kick of length h, None without viscous friction: the same
    /// for every particle, so a pass over the particles takes the exponential once.
    fn viscous_decay(&self, h: f64) -> Option<(f64, f64)> {
        self.viscous_time.map(|tau| (tau, (-h / tau).exp()))
    }

    /// [`Kick::velocity`] with the kick's length h and its [`Kick::viscous_decay`].
    fn velocity_with(
        &self,
        v: Vector2<f64>,
        force: Vector2<f64>,
        normal: f64,
        m: f64,
        (h, viscous): (f64, Option<(f64, f64)>),
    ) -> Vector2<f64> {
        let vt = self.threshold_speed;
        if self.dry && self.scheme == FrictionScheme::Explicit {
            let force = force - v * self.viscous_time.map_or(0.0, |tau| m / tau);
            let friction = if v.norm() < vt && force.norm() <= self.static_friction * normal {
                -force
            } else {
                -v * (self.dynamic_friction * normal / (v.norm() + vt))
            };
            return v + (force + friction) * (h / m);
        }
        if self.dry && v.norm() < vt && force.norm() <= self.static_friction * normal {
            return Vector2::zeros();
        }
        let u = match viscous {
            Some((tau, decay)) => v * decay + force * (tau * (1.0 - decay) / m),
            None => v + force * (h / m),
        };
        if !self.dry {
            return u;
        }
        // s (1 + c/(s + v_t)) = |u| with c = h μ_d N/m: the positive root.
        let (speed, c) = (u.norm(), h * self.dynamic_friction * normal / m);
        if speed == 0.0 {
            return u;
        }
        let b = speed - vt - c;
        let s = 0.5 * (b + (b * b + 4.0 * speed * vt).sqrt());
        u * (s / speed)
    }
}

/// Advances the particles by Δt with the piston moved to `piston_after` (prescribed motion);
/// the forces in `field` must be those of the current state and are those of the new state on
/// return, and so is the returned scan.
pub fn step(
    state: &mut State,
    particles: &Particles,
    field: &mut ForceField,
    kick: &Kick,
    dt: f64,
    piston_after: f64,
) -> StepScan {
    let beyond = kick_and_drift(state, particles, field, kick, 0.5 * dt, dt);
    state.piston = piston_after;
    state.time += dt;
    field.evaluate_watched(particles, state, beyond);
    half_kick(state, particles, field, kick, 0.5 * dt)
}

/// A half kick of length h, then a drift of dt, of every particle in one pass; returns, where
/// the field's neighbour list has a watch ([`ForceField::watch`]), whether the drift moved some
/// particle beyond it (for [`ForceField::evaluate_watched`]: its rebuild check then needs no
/// pass of its own).
pub fn kick_and_drift(
    state: &mut State,
    particles: &Particles,
    field: &ForceField,
    kick: &Kick,
    h: f64,
    dt: f64,
) -> Option<bool> {
    let watch = field.watch(state.position.len());
    let found = kick_each(state, particles, field, kick, h, Some((dt, watch.as_ref())));
    watch.map(|_| found.beyond)
}

/// One half kick of every particle (friction included); returns the scan of the kicked state
/// (found in the same pass).
pub fn half_kick(
    state: &mut State,
    particles: &Particles,
    field: &ForceField,
    kick: &Kick,
    h: f64,
) -> StepScan {
    kick_each(state, particles, field, kick, h, None)
}

/// A half kick of length h of every particle, each followed by a drift of dt if `drift` gives
/// one; without a drift, returns the scan of the kicked state, with one whether it moved a
/// disc beyond the watch it gives (if any).
fn kick_each(
    state: &mut State,
    particles: &Particles,
    field: &ForceField,
    kick: &Kick,
    h: f64,
    drift: Option<(f64, Option<&Watch<'_, 2>>)>,
) -> StepScan {
    let length = (h, kick.viscous_decay(h));
    let scan = Scanner::new(kick, field, state.piston);
    let (position, velocity) = (&mut state.position, &mut state.velocity);
    let (force, mass) = (&field.out[..], &particles.mass[..]);
    // the block from disc `start` on: kicked (and drifted), then scanned or watched
    let block = |start: usize, discs: Discs| {
        let discs = kick_block(kick, discs, length, drift.map(|(dt, _)| dt));
        match drift {
            None => scan.block(&discs),
            Some((_, Some(watch))) => StepScan {
                beyond: watch.any_beyond(start, discs.position),
                ..StepScan::NONE
            },
            Some((_, None)) => StepScan::NONE,
        }
    };
    if position.len() >= PARALLEL_UPDATE_FROM {
        position
            .par_chunks_mut(UPDATE_BLOCK)
            .zip(velocity.par_chunks_mut(UPDATE_BLOCK))
            .zip(
                force
                    .par_chunks(UPDATE_BLOCK)
                    .zip(mass.par_chunks(UPDATE_BLOCK)),
            )
            .enumerate()
            .map(|(b, ((position, velocity), (force, mass)))| {
                let discs = Discs {
                    position,
                    velocity,
                    force,
                    mass,
                };
                block(b * UPDATE_BLOCK, discs)
            })
            .reduce(|| StepScan::NONE, StepScan::merge)
    } else {
        let discs = Discs {
            position,
            velocity,
            force,
            mass,
        };
        block(0, discs)
    }
}

/// Discs per parallel task of the kicks.
const UPDATE_BLOCK: usize = 512;

/// The kicks (and drifts) of one block of discs: in fours where [`kick_fours`] can, the
/// rest one by one; returns the block.
fn kick_block<'a>(
    kick: &Kick,
    mut discs: Discs<'a>,
    length: (f64, Option<(f64, f64)>),
    drift: Option<f64>,
) -> Discs<'a> {
    let done = kick_fours(kick, &mut discs, length, drift);
    for (((x, v), o), m) in discs
        .position
        .iter_mut()
        .zip(discs.velocity.iter_mut())
        .zip(discs.force)
        .zip(discs.mass)
        .skip(done)
    {
        *v = kick.velocity_with(*v, o.force, o.normal, *m, length);
        if let Some(dt) = drift {
            *x += *v * dt;
        }
    }
    discs
}

/// What the end of a step gives the run: the time-step rule's largest rate and the run checks'
/// extremes, found in the pass of the step's closing half kick (one pass on the pool instead
/// of three; max, min and "all" give the same values in any order, so at any thread count).
#[derive(Debug, Clone, Copy)]
pub struct StepScan {
    /// ω_max² of the time-step rule, 1/s².
    rate2: f64,
    /// The extremes the run checks look at.
    pub extremes: Extremes,
    /// Whether a drift moved some disc beyond the neighbour list's watch (a pass of
    /// [`kick_and_drift`]; the other fields are then empty).
    beyond: bool,
}

impl StepScan {
    const NONE: Self = Self {
        rate2: 0.0,
        extremes: Extremes::NONE,
        beyond: false,
    };

    /// The scan of a state whose forces `field` holds (for the first step of a stage).
    pub fn of(state: &State, particles: &Particles, field: &ForceField, kick: &Kick) -> Self {
        let scan = Scanner::new(kick, field, state.piston);
        let (position, velocity, out) = (&state.position, &state.velocity, &field.out);
        let disc = |i: usize| scan.disc(position[i], velocity[i], &out[i], particles.mass[i]);
        fold_items(position.len(), Self::NONE, disc, Self::merge)
    }

    fn merge(self, other: Self) -> Self {
        Self {
            rate2: self.rate2.max(other.rate2),
            extremes: self.extremes.merge(other.extremes),
            beyond: self.beyond || other.beyond,
        }
    }

    /// The step the rule gives: factor/ω_max, at most `max_step`, s.
    pub fn time_step(&self, factor: f64, max_step: f64) -> f64 {
        if self.rate2 > 0.0 {
            (factor / self.rate2.sqrt()).min(max_step)
        } else {
            max_step
        }
    }
}

/// What a scan of discs needs besides the discs.
struct Scanner<'a> {
    kick: &'a Kick,
    geometry: &'a Geometry,
    piston: f64,
}

impl<'a> Scanner<'a> {
    fn new(kick: &'a Kick, field: &'a ForceField, piston: f64) -> Self {
        let geometry = field.geometry();
        Self {
            kick,
            geometry,
            piston,
        }
    }

    /// One disc: ω² = k/m of its stiffest interaction (and, for the explicit friction
    /// reference, (μ_d N/(m v_t))², from the friction force's slope at v_t).
    fn disc(&self, p: Vector2<f64>, v: Vector2<f64>, o: &ParticleForce, m: f64) -> StepScan {
        let kick = self.kick;
        let mut rate2 = o.stiffness;
        if kick.dry && kick.scheme == FrictionScheme::Explicit {
            let friction = (kick.dynamic_friction * o.normal / (m * kick.threshold_speed)).max(0.0);
            rate2 = rate2.max(friction * friction);
        }
        let extremes = Extremes::of_disc(p, v, o.closeness, self.geometry, self.piston);
        StepScan {
            rate2,
            extremes,
            beyond: false,
        }
    }

    fn block(&self, discs: &Discs) -> StepScan {
        let disc = |i: usize| {
            let (p, v) = (discs.position[i], discs.velocity[i]);
            self.disc(p, v, &discs.force[i], discs.mass[i])
        };
        (0..discs.position.len())
            .map(disc)
            .fold(StepScan::NONE, StepScan::merge)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dry() -> Kick {
        Kick {
            viscous_time: None,
            dry: true,
            static_friction: 0.6,
            dynamic_friction: 0.45,
            threshold_speed: 1e-6,
            scheme: FrictionScheme::SemiImplicit,
        }
    }

    #[test]
    fn dry_friction_stops_but_never_reverses() {
        let k = dry();
        let v = Vector2::new(1e-3, 0.0);
        for h in [1e-6, 1e-4, 1e-2, 1.0] {
            let w = k.velocity(v, Vector2::zeros(), 1.0, 1e-3, h);
            assert!(w.x >= 0.0 && w.x <= v.x && w.y == 0.0, "h = {h}: {w:?}");
        }
        // a strong step brings it (nearly) to rest, then the stick rule holds it exactly
        let w = k.velocity(v, Vector2::zeros(), 1.0, 1e-3, 1.0);
        assert!(w.norm() < 1e-6);
        let f = Vector2::new(0.5, 0.0);
        assert_eq!(k.velocity(w, f, 1.0, 1e-3, 1.0), Vector2::zeros());
    }

    #[test]
    fn semi_implicit_slip_solves_the_backward_euler_equation() {
        let k = dry();
        let (v, f, n, m, h) = (
            Vector2::new(2e-3, -1e-3),
            Vector2::new(0.3, 0.1),
            0.2,
            6e-4,
            1e-4,
        );
        let w = k.velocity(v, f, n, m, h);
        let residual = w - (v + f * (h / m) - w * (h / m * 0.45 * n / (w.norm() + 1e-6)));
        assert!(
            residual.norm() < 1e-12 * v.norm().max(w.norm()),
            "{residual:?}"
        );
    }

    #[test]
    fn viscous_kick_is_exact_for_constant_force() {
        let k = Kick {
            viscous_time: Some(0.1),
            dry: false,
            ..dry()
        };
        let (v0, f, m) = (Vector2::new(0.3, 0.0), Vector2::new(0.0, -1.0), 2.0);
        let whole = k.velocity(v0, f, 0.0, m, 0.2);
        let halves = k.velocity(k.velocity(v0, f, 0.0, m, 0.1), f, 0.0, m, 0.1);
        assert!((whole - halves).norm() < 1e-15);
        let terminal = f * (0.1 / m);
        let expected = terminal + (v0 - terminal) * (-2.0f64).exp();
        assert!((whole - expected).norm() < 1e-15);
    }
}
