//! Small numerical building blocks shared by the models.

pub mod quadrature;
pub mod roots;
pub mod special;
pub mod stats;
pub mod tiled_pairs;
