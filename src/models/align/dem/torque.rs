//! The anisotropy torque (spec align.md, A3) on each particle, from the Stoner–Wohlfarth
//! equilibrium of its moment (`stoner_wohlfarth`), in units of E R_av³.

use nalgebra::{UnitQuaternion, Vector3};
use rayon::prelude::*;

use super::packing::Packing;
use crate::models::align::params::{AlignParams, MomentBranch};
use crate::models::align::stoner_wohlfarth::{equilibrium, metastable_equilibrium};

/// K in units of the stress scale E.
pub fn reduced_anisotropy(params: &AlignParams) -> f64 {
    params.material.anisotropy_constant / params.scales().stress()
}

/// The torques of one run: K V_i per particle and the reduced field h.
#[derive(Debug)]
pub struct Anisotropy {
    /// K V_i in units of E R_av³.
    kv: Vec<f64>,
    h: f64,
    branch: MomentBranch,
}

impl Anisotropy {
    /// The torque scales of the packing's particles in the run's field.
    pub fn new(params: &AlignParams, packing: &Packing) -> Self {
        let k_red = reduced_anisotropy(params);
        Self {
            kv: packing
                .radius
                .iter()
                .map(|r| k_red * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
                .collect(),
            h: params.reduced_field(),
            branch: params.moment_branch,
        }
    }

    /// Writes the torque on every particle at the given orientations; on the metastable
    /// branch, moments whose branch has ended switch (their `sense` flips for good).
    pub fn apply(
        &self,
        orientation: &[UnitQuaternion<f64>],
        sense: &mut [f64],
        torque: &mut [Vector3<f64>],
    ) {
        // particle by particle, so on the pool (each particle's Stoner–Wohlfarth solve costs
        // about a microsecond: serial, it left the second thread idle)
        (torque.par_iter_mut().zip(sense).enumerate()).for_each(|(i, (t, sense))| {
            *t = match self.branch {
                MomentBranch::GlobalMinimum => magnetic_torque(&orientation[i], self.kv[i], self.h),
                MomentBranch::Metastable => {
                    hysteretic_torque(&orientation[i], self.kv[i], self.h, sense)
                }
            };
        });
    }
}

/// The torque on a particle whose moment lies near the easy direction d = sense · n: the
/// global-minimum torque when d·ẑ ≥ 0, else the metastable branch's torque (which turns d
/// toward H the long way round) while that branch exists; when it has ended the moment
/// switches to −d (`sense` flips) and the global-minimum torque applies.
fn hysteretic_torque(q: &UnitQuaternion<f64>, kv: f64, h: f64, sense: &mut f64) -> Vector3<f64> {
    let d = *sense * (q * Vector3::z());
    let sin = d.x.hypot(d.y);
    if d.z < 0.0 {
        if let Some(eq) = metastable_equilibrium(sin, -d.z, h) {
            return toward_field(&d, kv * eq.torque_factor);
        }
        *sense = -*sense;
        return toward_field(&-d, kv * equilibrium(sin, -d.z, h).torque_factor);
    }
    toward_field(&d, kv * equilibrium(sin, d.z, h).torque_factor)
}

/// A torque of the given magnitude about d × ẑ: it turns the direction d toward the field.
fn toward_field(d: &Vector3<f64>, magnitude: f64) -> Vector3<f64> {
    let sin = d.x.hypot(d.y);
    if sin == 0.0 {
        return Vector3::zeros();
    }
    magnitude / sin * Vector3::new(d.y, -d.x, 0.0)
}

/// The anisotropy torque (A3) on a particle with easy axis n = q·ẑ in a field along +z:
/// magnitude K V sin 2ψ, about n' × ẑ (n' = ±n with n'·ẑ ≥ 0), turning the axis toward H.
pub fn magnetic_torque(q: &UnitQuaternion<f64>, kv: f64, h: f64) -> Vector3<f64> {
    let n = q * Vector3::z();
    let n = if n.z < 0.0 { -n } else { n };
    let eq = equilibrium(n.x.hypot(n.y), n.z, h);
    toward_field(&n, kv * eq.torque_factor)
}
