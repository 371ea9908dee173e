//! Time stepping of the alignment stage: Heun (explicit trapezoid) on positions and
//! orientations (q ← exp(½ ω dt) ⊗ q), each stage's velocities coming from the implicit
//! velocity problem (`velocity`). The step is set by rotation accuracy alone (contacts are
//! implicit, so they impose no stiffness limit): dt = `rotation_step` / ω_max with ω_max the
//! angular speed of the largest particle under the largest possible torque K V.

use nalgebra::UnitQuaternion;
use rayon::prelude::*;

use super::packing::Packing;
use super::state::State;
use super::torque::reduced_anisotropy;
use crate::models::align::params::AlignParams;

/// Fastest possible angular speed (largest particle, torque K V), in 1/t_char, and the
/// largest radius.
pub fn fastest_rotation(params: &AlignParams, packing: &Packing) -> (f64, f64) {
    let r_max = packing.radius.iter().cloned().fold(0.0, f64::max);
    let k_red = reduced_anisotropy(params);
    (k_red * 4.0 / 3.0 * std::f64::consts::PI * r_max, r_max)
}

/// The alignment time step in units of t_char.
pub fn time_step(params: &AlignParams, packing: &Packing) -> f64 {
    params.numerics.rotation_step / fastest_rotation(params, packing).0
}

/// The alignment time step, s.
pub fn time_step_s(params: &AlignParams, packing: &Packing) -> f64 {
    time_step(params, packing) * params.scales().time
}

/// Heun's method: the predictor advances the state with the velocities solved at the step's
/// start; the corrector advances the *start* again with the mean of those and the velocities
/// solved at the predicted state.
#[derive(Debug, Default)]
pub struct Heun {
    /// Step length, t_char.
    pub dt: f64,
    /// The state (with the predictor velocities) at the start of the current step.
    start: State,
}

impl Heun {
    /// Steps of length dt.
    pub fn new(dt: f64) -> Self {
        Self {
            dt,
            start: State::default(),
        }
    }

    /// Keeps the step's start and advances the state by dt with its velocities (the predictor
    /// velocities, just solved there).
    pub fn predict(&mut self, state: &mut State) {
        self.start.copy_from(state);
        self.advance(state, false);
    }

    /// Advances the step's start by dt with the mean of the predictor velocities and the state's
    /// current (corrector) velocities.
    pub fn correct(&self, state: &mut State) {
        self.advance(state, true);
    }

    /// Returns the state to the start of the current step (positions, orientations, lid; the
    /// predictor velocities stay as the next solve's warm start).
    pub fn restore(&self, state: &mut State) {
        state.copy_from(&self.start);
    }

    /// Largest distance any particle (or the lid) moves in dt at its predictor or corrector
    /// velocity.
    pub fn largest_move(&self, state: &State) -> f64 {
        self.stage_move(&self.start).max(self.stage_move(state))
    }

    /// Largest distance any particle (or the lid) would move in dt at the state's velocities.
    pub fn stage_move(&self, state: &State) -> f64 {
        let lid_speed = state.lid.map_or(0.0, |l| l.velocity.abs());
        (state.motion.par_iter())
            .map(|m| m.v.norm())
            .reduce(|| lid_speed, f64::max)
            * self.dt
    }

    /// Sets positions and orientations to the start advanced by dt with the predictor
    /// velocities, or (`corrected`) with the mean of predictor and corrector velocities.
    fn advance(&self, state: &mut State, corrected: bool) {
        let (dt, start) = (self.dt, &self.start);
        let motion = &state.motion;
        // particle by particle (a sine and a cosine each), so on the pool
        (state.position.par_iter_mut().zip(&mut state.orientation))
            .enumerate()
            .for_each(|(i, (position, orientation))| {
                let a = start.motion[i];
                let b = if corrected { motion[i] } else { a };
                let (v, w) = (0.5 * (a.v + b.v), 0.5 * (a.w + b.w));
                *position = start.position[i] + dt * v;
                let q = UnitQuaternion::from_scaled_axis(dt * w) * start.orientation[i];
                *orientation = UnitQuaternion::new_normalize(q.into_inner());
            });
        if let (Some(a), Some(lid)) = (start.lid, state.lid.as_mut()) {
            let b = if corrected { lid.velocity } else { a.velocity };
            lid.height = a.height + dt * 0.5 * (a.velocity + b);
        }
    }
}
