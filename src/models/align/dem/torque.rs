//! The anisotropy torque (spec align.md, A3) on each particle, from the Stoner–Wohlfarth
//! equilibrium of its moment (`stoner_wohlfarth`), in units of E R_av³.

use nalgebra::{UnitQuaternion, Vector3};

use super::packing::Packing;
use crate::models::align::params::AlignParams;
use crate::models::align::stoner_wohlfarth::equilibrium;

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
        }
    }

    /// Writes the torque on every particle at the given orientations.
    pub fn apply(&self, orientation: &[UnitQuaternion<f64>], torque: &mut [Vector3<f64>]) {
        for (i, t) in torque.iter_mut().enumerate() {
            *t = magnetic_torque(&orientation[i], self.kv[i], self.h);
        }
    }
}

/// The anisotropy torque (A3) on a particle with easy axis n = q·ẑ in a field along +z:
/// magnitude K V sin 2ψ, about n' × ẑ (n' = ±n with n'·ẑ ≥ 0), turning the axis toward H.
pub fn magnetic_torque(q: &UnitQuaternion<f64>, kv: f64, h: f64) -> Vector3<f64> {
    let n = q * Vector3::z();
    let n = if n.z < 0.0 { -n } else { n };
    let sin_theta = n.x.hypot(n.y);
    if sin_theta == 0.0 {
        return Vector3::zeros();
    }
    let eq = equilibrium(sin_theta, n.z, h);
    kv * eq.torque_factor / sin_theta * Vector3::new(n.y, -n.x, 0.0)
}
