//! The external loads of the alignment stage (spec align.md, "Pressure"): the die pressure on
//! the loaded particles (exposed-layer or source-layer rule) and true gravity, in units of
//! E R_av². In `punch` mode no particle is loaded directly: the lid (`velocity::Lid`) carries
//! P L_x L_y and passes it on through its contacts.

use nalgebra::Vector3;

use crate::models::align::params::{AlignParams, PressureMode};

/// External force on every particle and their sum from the pressure.
#[derive(Debug)]
pub struct Loads {
    /// Pressure load plus weight of each particle.
    pub force: Vec<Vector3<f64>>,
    /// Total pressure load carried by the loaded particles.
    pub applied: f64,
}

impl Loads {
    /// No load on n particles (until the first `update`).
    pub fn none(n: usize) -> Self {
        Self {
            force: vec![Vector3::zeros(); n],
            applied: 0.0,
        }
    }

    /// Recomputes the loads for the current positions. The loaded set changes only as the bed
    /// rearranges, so callers refresh it with the neighbour list, not every stage.
    pub fn update(&mut self, params: &AlignParams, position: &[Vector3<f64>], radius: &[f64]) {
        let scales = params.scales();
        let p_red = params.pressure / scales.stress();
        let g_red = params.material.density * 9.80665 * scales.length / scales.stress();
        let loaded = match params.pressure_mode {
            PressureMode::ExposedLayer => exposed_particles(position, radius),
            PressureMode::SourceLayer => source_layer(position),
            PressureMode::Punch => vec![false; position.len()],
        };
        self.applied = 0.0;
        for (i, f) in self.force.iter_mut().enumerate() {
            let r = radius[i];
            let load = if loaded[i] {
                std::f64::consts::PI * r * r * p_red
            } else {
                0.0
            };
            self.applied += load;
            *f = Vector3::new(
                0.0,
                0.0,
                -load - g_red * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
            );
        }
    }
}

/// Particles with no sphere above them: the vertical ray up from the centre meets no other
/// sphere (no higher centre within horizontal distance R_j).
fn exposed_particles(position: &[Vector3<f64>], radius: &[f64]) -> Vec<bool> {
    let r_max = radius.iter().cloned().fold(0.0, f64::max);
    let column = 2.0 * r_max;
    let key = |p: &Vector3<f64>| ((p.x / column).floor() as i64, (p.y / column).floor() as i64);
    let mut columns: std::collections::BTreeMap<(i64, i64), Vec<usize>> = Default::default();
    for (i, p) in position.iter().enumerate() {
        columns.entry(key(p)).or_default().push(i);
    }
    position
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (cx, cy) = key(p);
            !(-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    columns.get(&(cx + dx, cy + dy)).is_some_and(|members| {
                        members.iter().any(|&j| {
                            let d = position[j] - p;
                            j != i && d.z > 0.0 && d.x * d.x + d.y * d.y < radius[j] * radius[j]
                        })
                    })
                })
            })
        })
        .collect()
}

/// The source's rule: centres above 0.9 of the highest centre.
fn source_layer(position: &[Vector3<f64>]) -> Vec<bool> {
    let z_max = position
        .iter()
        .map(|p| p.z)
        .fold(f64::NEG_INFINITY, f64::max);
    position.iter().map(|p| p.z > 0.9 * z_max).collect()
}
