//! The evolving state of an alignment run (reduced units): particle centres, orientations and
//! the velocities of the latest stage solve.

use nalgebra::{UnitQuaternion, Vector3};

use super::packing::Packing;
use super::velocity::Motion;

/// Positions, orientations (easy axis n = q·ẑ) and velocities of every particle.
#[derive(Debug, Default)]
pub struct State {
    /// Centres.
    pub position: Vec<Vector3<f64>>,
    /// Orientations.
    pub orientation: Vec<UnitQuaternion<f64>>,
    /// Velocities of the latest stage solve; they warm-start the next one.
    pub motion: Vec<Motion>,
}

impl State {
    /// The settled packing, at rest.
    pub fn at_rest(packing: &Packing) -> Self {
        Self {
            position: packing.position.clone(),
            orientation: packing.orientation.clone(),
            motion: vec![Motion::default(); packing.radius.len()],
        }
    }

    /// Becomes a copy of `other`, reusing this state's buffers (no allocation per step).
    pub fn copy_from(&mut self, other: &Self) {
        self.position.clone_from(&other.position);
        self.orientation.clone_from(&other.orientation);
        self.motion.clone_from(&other.motion);
    }
}
