//! The evolving state of an alignment run (reduced units): particle centres, orientations and
//! the velocities of the latest stage solve, and the punch's lid if there is one.

use nalgebra::{UnitQuaternion, Vector3};

use super::packing::Packing;
use super::velocity::Motion;

/// Height and vertical velocity of the punch's lid (reduced units).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct LidState {
    /// Height of the lid's underside above the floor.
    pub height: f64,
    /// Upward velocity of the latest stage solve.
    pub velocity: f64,
}

/// Positions, orientations (easy axis n = q·ẑ) and velocities of every particle.
#[derive(Debug, Default)]
pub struct State {
    /// Centres.
    pub position: Vec<Vector3<f64>>,
    /// Orientations.
    pub orientation: Vec<UnitQuaternion<f64>>,
    /// Velocities of the latest stage solve; they warm-start the next one.
    pub motion: Vec<Motion>,
    /// Sense s_i = ±1 of each moment along its body axis: the moment's easy direction is
    /// s_i n_i (1 at the start; flipped when a metastable moment switches).
    pub moment_sense: Vec<f64>,
    /// The punch's lid (pressure mode `punch` only).
    pub lid: Option<LidState>,
}

impl State {
    /// The settled packing, at rest.
    pub fn at_rest(packing: &Packing) -> Self {
        Self {
            position: packing.position.clone(),
            orientation: packing.orientation.clone(),
            motion: vec![Motion::default(); packing.radius.len()],
            moment_sense: vec![1.0; packing.radius.len()],
            lid: None,
        }
    }

    /// Becomes a copy of `other`, reusing this state's buffers (no allocation per step).
    pub fn copy_from(&mut self, other: &Self) {
        self.position.clone_from(&other.position);
        self.orientation.clone_from(&other.orientation);
        self.motion.clone_from(&other.motion);
        self.moment_sense.clone_from(&other.moment_sense);
        self.lid = other.lid;
    }
}
