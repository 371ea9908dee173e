//! The study runner (spec studies.md): every model is an objective — parameters in, metrics
//! out. A study names a model, base parameters, swept parameters (a grid) or a design,
//! replicate seeds and metrics; the runner expands its points, runs (point, replicate) pairs in
//! parallel, saves each run as it finishes, aggregates tables (with sensitivity indices and
//! metric distributions for designs), optimizes free parameters and plots.

pub mod awake;
pub mod bayes;
pub mod design;
pub mod design_spec;
pub mod domain;
pub mod fingerprint;
pub mod model;
pub mod multi;
pub mod objectives;
pub mod optimize;
pub mod optimize_points;
pub mod optimize_shard;
pub mod param;
pub mod pareto;
pub mod plot;
pub mod plot_design;
pub mod plot_optimize;
pub mod records;
pub mod runner;
pub mod sensitivity_tables;
pub mod spec;
