//! The blast initial condition (C1): N equal non-overlapping spheres placed by random
//! sequential addition (RSA) in a sphere of radius R_0, each given the same radial velocity
//! pulse |δv| = √(2W/M) away from the centre of mass, and a charge per mass of either sign.

use nalgebra::Vector3;
use rand::RngExt;

// The packing check is a parameter check (`BlastParams::validate` runs it), so it lives in
// params and the dependency runs one way, cloud → params; re-exported under its old path.
use super::params::BlastParams;
pub use super::params::{check_packing, MAX_VOLUME_FRACTION};
use crate::rng::{run_stream, Purpose};
use crate::{Error, Result};

/// Failed RSA attempts in a row after which placement gives up.
pub const MAX_ATTEMPTS: usize = 200_000;

/// The state of the cloud (SI). Equal spheres: one mass, radius and moment of inertia.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cloud {
    /// Centres r_i, m.
    pub positions: Vec<Vector3<f64>>,
    /// Velocities v_i, m/s.
    pub velocities: Vec<Vector3<f64>>,
    /// Angular velocities ω_i, rad/s.
    pub spins: Vec<Vector3<f64>>,
    /// Signed charge per mass q_i/m_i, C/kg.
    pub charge_per_mass: Vec<f64>,
    /// Particle mass m, kg.
    pub mass: f64,
    /// Particle radius R, m.
    pub radius: f64,
}

impl Cloud {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the cloud is empty.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Moment of inertia of a solid sphere, I = 2/5 m R², kg·m².
    pub fn inertia(&self) -> f64 {
        0.4 * self.mass * self.radius * self.radius
    }

    /// A cloud of given particles at rest (tests and analytic cases).
    pub fn at_rest(positions: Vec<Vector3<f64>>, params: &BlastParams) -> Self {
        let n = positions.len();
        Self {
            positions,
            velocities: vec![Vector3::zeros(); n],
            spins: vec![Vector3::zeros(); n],
            charge_per_mass: vec![params.charge_per_mass; n],
            mass: params.particle_mass(),
            radius: params.radius,
        }
    }

    /// The blasted cloud of (C1) for one seed.
    pub fn blast(params: &BlastParams, seed: u64) -> Result<Self> {
        check_packing(params)?;
        let positions = random_sequential_addition(params, seed)?;
        let mut cloud = Self::at_rest(positions, params);
        let mut rng = run_stream(seed, Purpose::Charges);
        for q in &mut cloud.charge_per_mass {
            if rng.random::<f64>() < params.negative_fraction {
                *q = -*q;
            }
        }
        let mass_total = cloud.mass * cloud.len() as f64;
        let pulse = (2.0 * params.energy / mass_total).sqrt();
        let centre = centre_of_mass(&cloud.positions);
        for (v, r) in cloud.velocities.iter_mut().zip(&cloud.positions) {
            *v = (r - centre).try_normalize(0.0).unwrap_or_default() * pulse;
        }
        Ok(cloud)
    }
}

/// Centre of mass of equal particles (sequential sum: deterministic).
pub fn centre_of_mass(positions: &[Vector3<f64>]) -> Vector3<f64> {
    positions.iter().sum::<Vector3<f64>>() / positions.len().max(1) as f64
}

/// RSA with a cell grid of cell size 2R: each candidate is checked against the 27 cells around
/// it only, so placement is O(N) per accepted particle's neighbourhood, not O(N²).
fn random_sequential_addition(params: &BlastParams, seed: u64) -> Result<Vec<Vector3<f64>>> {
    let (r, room) = (params.radius, params.cloud_radius - params.radius);
    // cells of at least 2R (so the 27 around a candidate hold every sphere it could touch),
    // and no more cells than about 8 per particle (a dilute cloud of tiny spheres)
    let most = (2.0 * (params.particles as f64).cbrt()).ceil().max(1.0);
    let side = (2.0 * room / (2.0 * r)).floor().clamp(1.0, most) as usize;
    let cell = 2.0 * room / side as f64;
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); side * side * side];
    let coords = |p: &Vector3<f64>| -> [usize; 3] {
        std::array::from_fn(|a| (((p[a] + room) / cell).floor().max(0.0) as usize).min(side - 1))
    };
    let mut rng = run_stream(seed, Purpose::Positions);
    let mut positions: Vec<Vector3<f64>> = Vec::with_capacity(params.particles);
    let mut failures = 0;
    while positions.len() < params.particles {
        let p = Vector3::from_fn(|_, _| (2.0 * rng.random::<f64>() - 1.0) * room);
        if p.norm_squared() > room * room {
            continue;
        }
        let c = coords(&p);
        let overlaps = neighbour_cells(c, side).any(|k| {
            cells[k]
                .iter()
                .any(|&j| (positions[j as usize] - p).norm_squared() < 4.0 * r * r)
        });
        if overlaps {
            failures += 1;
            if failures >= MAX_ATTEMPTS {
                return Err(Error::input(format!(
                    "cloud too small for its particles: random sequential addition placed only {} of {} \
                     spheres (radius {} m) in a cloud of radius {} m after {MAX_ATTEMPTS} failed tries in a row",
                    positions.len(),
                    params.particles,
                    params.radius,
                    params.cloud_radius
                )));
            }
            continue;
        }
        failures = 0;
        cells[(c[2] * side + c[1]) * side + c[0]].push(positions.len() as u32);
        positions.push(p);
    }
    Ok(positions)
}

/// Flat indices of the (up to) 27 cells around cell `c` of a cubic grid of `side` cells.
fn neighbour_cells(c: [usize; 3], side: usize) -> impl Iterator<Item = usize> {
    let range = move |a: usize| c[a].saturating_sub(1)..=(c[a] + 1).min(side - 1);
    range(2).flat_map(move |z| {
        range(1).flat_map(move |y| range(0).map(move |x| (z * side + y) * side + x))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> BlastParams {
        let mut p = BlastParams::source_example();
        p.particles = 300;
        p.cloud_radius = 0.6;
        p
    }

    #[test]
    fn spheres_do_not_overlap_and_stay_inside() {
        let p = small();
        let cloud = Cloud::blast(&p, 3).unwrap();
        assert_eq!(cloud.len(), 300);
        for (i, a) in cloud.positions.iter().enumerate() {
            assert!(a.norm() <= p.cloud_radius - p.radius + 1e-12);
            for b in &cloud.positions[..i] {
                assert!((a - b).norm() >= 2.0 * p.radius);
            }
        }
    }

    #[test]
    fn pulse_carries_the_detonation_energy_radially() {
        let p = small();
        let cloud = Cloud::blast(&p, 5).unwrap();
        let ke: f64 = cloud
            .velocities
            .iter()
            .map(|v| 0.5 * cloud.mass * v.norm_squared())
            .sum();
        assert!((ke - p.energy).abs() < 1e-9 * p.energy);
        let c = centre_of_mass(&cloud.positions);
        for (r, v) in cloud.positions.iter().zip(&cloud.velocities) {
            assert!((r - c).normalize().cross(v).norm() < 1e-9 * v.norm());
        }
    }

    #[test]
    fn sign_mix_follows_the_fraction() {
        let mut p = small();
        p.negative_fraction = 0.5;
        let cloud = Cloud::blast(&p, 9).unwrap();
        let negative = cloud.charge_per_mass.iter().filter(|q| **q < 0.0).count();
        assert!((100..200).contains(&negative), "{negative}");
    }

    #[test]
    fn dilute_cloud_of_tiny_spheres_uses_a_small_grid() {
        let mut p = small();
        p.radius = 1e-6;
        p.particles = 50;
        let cloud = Cloud::blast(&p, 1).unwrap();
        assert_eq!(cloud.len(), 50);
    }

    #[test]
    fn overfull_cloud_is_rejected() {
        let mut p = small();
        p.particles = 5000;
        let e = Cloud::blast(&p, 1).unwrap_err().to_string();
        assert!(e.contains("cloud too small for its particles"), "{e}");
        p.radius = 0.7;
        assert!(check_packing(&p).is_err());
    }
}
