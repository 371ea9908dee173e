//! The particle models. Each has the same shape: parameters (with units and defaults), state,
//! forces, integrator step, observables.

pub mod align;
pub mod bed;
pub mod blast;
