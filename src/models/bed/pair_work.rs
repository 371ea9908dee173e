//! What a run's pair sums cost, for benchmarks: the pair terms its kernels evaluated and the
//! pairs inside the cut-off, summed over the steps, and the step-mean packing fraction (the
//! density those pairs come from).

use nalgebra::Vector2;

use super::forces::ForceField;

/// Running tallies over a run's steps.
#[derive(Debug, Clone, Copy, Default)]
pub struct PairWork {
    /// Steps tallied.
    pub steps: u64,
    /// Ordered pair terms evaluated ([`ForceField::pair_terms`]), summed over the steps.
    pub pair_terms: u64,
    /// Ordered pairs inside the cut-off ([`ForceField::pairs_within_cutoff`]), summed over the
    /// steps. Counting them costs a pass over the list, so they are counted at each list build
    /// and that count is held until the next build.
    pub pairs_within_cutoff: u64,
    /// Packing fraction summed over the steps.
    packing_fraction_sum: f64,
    /// Σ π D_i²/4 / W, m: the packing fraction times the piston height.
    area_per_width: f64,
    /// List builds at the last count of `held`, and that count.
    counted_at_build: Option<usize>,
    held: u64,
}

impl PairWork {
    /// Empty tallies for discs of total area `disc_area` (m²) in a cell of width `width` (m).
    pub fn new(disc_area: f64, width: f64) -> Self {
        Self {
            area_per_width: disc_area / width,
            ..Self::default()
        }
    }

    /// Adds the step just evaluated by `field` at `position`, with the piston at `piston` (m).
    pub fn record(&mut self, field: &ForceField, position: &[Vector2<f64>], piston: f64) {
        let builds = field.list_builds();
        if self.counted_at_build != Some(builds) {
            self.held = field.pairs_within_cutoff(position) as u64;
            self.counted_at_build = Some(builds);
        }
        self.steps += 1;
        self.pair_terms += field.pair_terms() as u64;
        self.pairs_within_cutoff += self.held;
        self.packing_fraction_sum += self.area_per_width / piston;
    }

    /// Step-mean packing fraction (NaN before the first step).
    pub fn mean_packing_fraction(&self) -> f64 {
        self.packing_fraction_sum / self.steps as f64
    }
}
