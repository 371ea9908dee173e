//! Multi-objective optimization: the Pareto front of two or three objectives.
//!
//! Pure mathematics on the unit cube of the free parameters, every objective minimized (the
//! study layer, [`crate::study::multi`], maps parameters, negates maximized objectives and
//! evaluates the model):
//!
//! - [`front`]: Pareto dominance, fast non-dominated sorting and crowding distance (Deb et al.
//!   2002); a point with a missing objective is dominated by every complete point.
//! - [`hypervolume`]: the exact hypervolume indicator (Zitzler & Thiele 1998) by a sweep for
//!   two objectives and by slicing (HSO, While et al. 2006) for three.
//! - [`nsga2`]: real-coded NSGA-II with SBX crossover, polynomial mutation and crowded
//!   binary tournaments, seeded from a ChaCha8 stream, evaluating one generation per call of
//!   a batch closure. Tested on ZDT1 (Zitzler, Deb & Thiele 2000).
//!
//! References:
//! - K. Deb, A. Pratap, S. Agarwal, T. Meyarivan, "A fast and elitist multiobjective genetic
//!   algorithm: NSGA-II", IEEE Trans. Evol. Comput. 6 (2002) 182–197.
//! - K. Deb, R. B. Agrawal, "Simulated binary crossover for continuous search space",
//!   Complex Systems 9 (1995) 115–148.
//! - E. Zitzler, L. Thiele, "Multiobjective optimization using evolutionary algorithms — a
//!   comparative case study", PPSN V, LNCS 1498 (1998) 292–301.
//! - E. Zitzler, K. Deb, L. Thiele, "Comparison of multiobjective evolutionary algorithms:
//!   empirical results", Evol. Comput. 8 (2000) 173–195.
//! - L. While, P. Hingston, L. Barone, S. Huband, "A faster algorithm for calculating
//!   hypervolume", IEEE Trans. Evol. Comput. 10 (2006) 29–38.

pub mod front;
pub mod hypervolume;
pub mod nsga2;

pub use front::{crowding_distance, dominates, non_dominated, non_dominated_sort};
pub use hypervolume::hypervolume;
pub use nsga2::{nsga2, Outcome, Settings};
