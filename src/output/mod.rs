//! Output layer: result tables (Parquet), figures (PNG) and atomic file writes.
//!
//! Everything the crate writes to disk goes through this module, so that:
//! - no half-written file is ever visible under its final name ([`atomic`]);
//! - the rest of the crate never touches polars or plotters types ([`table`], [`plot`]).

pub mod atomic;
pub mod guard;
pub mod particles;
pub mod plot;
pub mod shapes;
pub mod snapshots;
pub mod table;
