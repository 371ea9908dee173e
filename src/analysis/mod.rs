//! Analysis toolbox shared by the models and the `magopt analyze` command (spec analysis.md):
//! Voronoi structure and order of 2D snapshots, pair correlation and coordination,
//! histograms (Knuth's rule), correlation, and least-squares fits.
//!
//! Entry point for a model: [`structure::analyze`] on the particle centres returns the
//! [`structure::StructureMetrics`] (n5, n6, n7, side histogram, Ψ6, hexagon regularity).

pub mod distribution;
pub mod fit;
pub mod pair;
pub mod picture;
pub mod report;
pub mod snapshot;
pub mod structure;
pub mod voronoi;
