//! magopt: simulation-based optimization of magnetic particle processes.
//!
//! See `ARCHITECTURE.md` for the map of modules and `docs/` for the physics contract (the
//! equations behind the (A…), (B…), (C…) tags cited in comments).
#![warn(missing_docs)]

pub mod analysis;
pub mod cli;
pub mod error;
pub mod materials;
pub mod models;
pub mod neighbor;
pub mod numerics;
pub mod optimize;
pub mod output;
pub mod rng;
pub mod study;
pub mod units;

pub use error::{Error, Result};
