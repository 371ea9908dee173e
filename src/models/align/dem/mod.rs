//! The DEM model of `align` (spec align.md): settled packing, then alignment of the easy axes
//! under field and pressure with Hertz contacts and regularized Coulomb friction, overdamped.
//!
//! The alignment stage, one concern per module:
//! - [`state`]: positions, orientations and velocities, the evolving run state;
//! - [`torque`] and [`loads`]: the anisotropy torque and the pressure and gravity loads;
//! - [`contacts`] and [`velocity`]: the Hertz contacts and the implicit velocity problem
//!   solved at every integrator stage; [`explicit_friction`]: the source's explicit friction
//!   (a switchable variant); [`coulomb`]: the velocity problem in its Coulomb limit v_ε = 0;
//! - [`integrator`]: Heun stepping and the time step;
//! - [`observables`]: A(t), τ_x, sticking fraction, contact count and the outcome;
//! - [`snapshot`]: the state as a particle frame (easy axes, moments, cos θ, contacts);
//! - `run`: the loop that calls them.

pub mod contacts;
pub mod coulomb;
pub mod explicit_friction;
pub mod integrator;
pub mod loads;
pub mod observables;
pub mod packing;
mod run;
pub mod snapshot;
pub mod state;
pub mod torque;
pub mod velocity;

use std::time::Instant;

use super::params::AlignParams;
use super::AlignOutcome;
use crate::output::snapshots::Recorder;
pub use integrator::time_step_s;
pub use observables::{alignment_degree, crossing_time};
pub use packing::{ContactWork, NewtonWork, Packing};
use run::Run;
pub use torque::magnetic_torque;

/// Runs the alignment stage on a settled packing (not modified); `recorder` writes its
/// particle frames.
pub fn align(
    params: &AlignParams,
    packing: &Packing,
    recorder: Option<&mut Recorder>,
) -> AlignOutcome {
    let started = Instant::now();
    let mut outcome = Run::new(params, packing).integrate(recorder);
    outcome.wall_time_s = started.elapsed().as_secs_f64();
    outcome
}
