//! The particle models. Each has the same shape: parameters (with units and defaults), state,
//! forces, integrator step, observables. Besides them, `analytic`: standard test functions
//! with known answers, run through the same study machinery to validate it.

pub mod align;
pub mod analytic;
pub mod bed;
pub mod blast;
