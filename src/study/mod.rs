//! The study runner (spec studies.md): every model is an objective — parameters in, metrics
//! out. A study names a model, base parameters, swept parameters, replicate seeds and metrics;
//! the runner expands the grid, runs (point, replicate) pairs in parallel, saves each run as it
//! finishes, aggregates tables, optimizes free parameters and plots.

pub mod design;
pub mod model;
pub mod optimize;
pub mod param;
pub mod plot;
pub mod records;
pub mod runner;
pub mod spec;
