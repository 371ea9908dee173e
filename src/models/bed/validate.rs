//! Validation of [`BedParams`] across fields (each field's own range is part of its declaration
//! in `study.rs`): every message names the fields, their values and what is allowed (bad input
//! is exit code 2 at the command line).

use super::params::{BedParams, Heights, Neighbors, TailCorrection};
use super::state::{grid_spacing, Geometry};
use crate::{Error, Result};

impl BedParams {
    /// Checks the values against each other; the message names the fields and what is allowed.
    pub fn validate(&self) -> Result<()> {
        if self.gap <= self.thickness {
            return Err(Error::input(format!(
                "gap: E = {} m is not allowed (need E > thickness ε = {} m: the tilt geometry \
                 of the dry friction needs clearance)",
                self.gap, self.thickness
            )));
        }
        let d1 = self.reference_diameter();
        let (rc, rv) = (self.cutoff.diameters(d1), self.list_radius.diameters(d1));
        if rv < rc && self.neighbors != Neighbors::SourceVerlet {
            return Err(Error::input(format!(
                "cutoff {rc} D1 and list_radius {rv} D1: need r_c ≤ r_v"
            )));
        }
        let rs = self.near_cutoff.diameters(d1);
        if self.far_field_interval > 1 {
            if !matches!(self.neighbors, Neighbors::Verlet | Neighbors::Tree) {
                return Err(Error::input(format!(
                    "far_field_interval {}: multiple time stepping needs neighbors = verlet or \
                     tree",
                    self.far_field_interval
                )));
            }
            if self.neighbors == Neighbors::Verlet && rs >= rc {
                return Err(Error::input(format!(
                    "near_cutoff {rs} D1: need r_s < r_c = {rc} D1"
                )));
            }
        }
        if self.tail_correction == TailCorrection::MeanField && !self.neighbors.cuts_sharply() {
            // the mode as the input spells it (serde's kebab-case name)
            let name = serde_json::to_value(self.neighbors).unwrap_or_default();
            return Err(Error::input(format!(
                "tail_correction mean-field with neighbors = {}: the tail stands for the \
                 pairs beyond a sharp cut-off, so it needs neighbors = verlet or cells",
                name.as_str().unwrap_or_default()
            )));
        }
        self.validate_species()?;
        self.validate_packing()
    }

    fn validate_species(&self) -> Result<()> {
        if let Some(list) = &self.species {
            if list.is_empty() {
                return Err(Error::input(
                    "species: the list is empty (need ≥ 1 species)",
                ));
            }
            for (k, s) in list.iter().enumerate() {
                if !(s.diameter > 0.0 && s.diameter.is_finite()) {
                    return Err(bad(
                        &format!("species[{k}].diameter"),
                        s.diameter,
                        "need > 0",
                    ));
                }
                if !(s.fraction >= 0.0 && s.fraction.is_finite()) {
                    return Err(bad(
                        &format!("species[{k}].fraction"),
                        s.fraction,
                        "need ≥ 0",
                    ));
                }
            }
            if list.iter().all(|s| s.fraction == 0.0) {
                return Err(Error::input("species: all number fractions are 0"));
            }
        }
        Ok(())
    }

    fn validate_packing(&self) -> Result<()> {
        let hexagonal = std::f64::consts::PI / (2.0 * 3f64.sqrt());
        let (phi0, phi1) = (self.start_packing_fraction, self.max_packing_fraction());
        if !(phi1 > 0.0 && phi1 < hexagonal) {
            return Err(bad(
                "max_packing_fraction",
                phi1,
                "need 0 < φ < 0.9069 (hexagonal close packing)",
            ));
        }
        let by_fraction = self.heights == Heights::PackingFractions;
        if by_fraction && !(phi0 > 0.0 && phi0 < phi1) {
            return Err(Error::input(format!(
                "start_packing_fraction: {phi0} is not allowed (need 0 < φ_start < \
                 max_packing_fraction = {phi1})"
            )));
        }
        let geometry = Geometry::of(self);
        let (w, h) = (geometry.width, geometry.height);
        let d_max = self
            .species_list()
            .iter()
            .filter(|s| s.fraction > 0.0)
            .map(|s| s.diameter)
            .fold(0.0, f64::max);
        let spacing = grid_spacing(self.particle_count(), w, h);
        if spacing < 1.5 * d_max {
            return Err(Error::input(format!(
                "particles: {} do not fit a starting grid in the {w:.3} m × {h:.3} m cell \
                 (spacing {:.2} mm < 1.5 D_max; need fewer particles or a larger cell)",
                self.particle_count(),
                spacing * 1e3
            )));
        }
        if by_fraction && geometry.start_height >= h {
            return Err(Error::input(format!(
                "start_packing_fraction: {phi0} needs a start height {:.4} m above the cell \
                 height {h:.4} m (need a larger φ_start or a taller cell)",
                geometry.start_height
            )));
        }
        if !by_fraction && geometry.final_height >= h {
            return Err(bad(
                "max_packing_fraction",
                phi1,
                "with heights = source the piston starts at the top of the cell and H_f must lie \
                 below it: need a larger φ_max or a taller cell",
            ));
        }
        if geometry.final_height < 2.0 * d_max {
            return Err(Error::input(format!(
                "max_packing_fraction: {phi1} puts the piston at {:.4} m, below two diameters \
                 (too many particles for the cell)",
                geometry.final_height
            )));
        }
        Ok(())
    }
}

/// "name: value is not allowed (why)".
fn bad(name: &str, value: f64, allowed: &str) -> Error {
    Error::input(format!("{name}: {value} is not allowed ({allowed})"))
}
