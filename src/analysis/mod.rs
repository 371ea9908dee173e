//! Analysis toolbox shared by the models and the `magopt analyze` command (spec analysis.md):
//! Voronoi structure and order of 2D snapshots, pair correlation and coordination,
//! histograms (Knuth's rule), correlation, and least-squares fits.
//!
//! Entry points for a model:
//! - [`structure::analyze`]`(&[nalgebra::Vector2<f64>]) -> Result<StructureMetrics>` on the
//!   particle centres (any length unit): n5, n6, n7, side histogram, Ψ6 (plain and
//!   side-length weighted), hexagon regularity mean/std, cells counted by the border rule
//!   (the bed model records them per cycle stage). Degenerate centres (< 3, collinear, duplicates, NaN) are an
//!   [`crate::Error::Input`], never a panic.
//! - [`structure::analyze_full`] adds the cells and per-particle ψ6;
//!   [`report::analyze_snapshot`] on a [`snapshot::Snapshot`] adds coordination, force
//!   distributions and g(r), as `magopt analyze` prints them.

pub mod distribution;
pub mod fit;
pub mod force_chain;
pub mod pair;
pub mod picture;
pub mod report;
pub mod snapshot;
pub mod structure;
pub mod voronoi;
