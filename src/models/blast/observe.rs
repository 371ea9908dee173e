//! Observables: pure functions of the cloud. The envelope comes from the gyration tensor (the
//! semi-axes of the uniform ellipsoid with the same second moments, a = √(5 σ²)) and from the
//! extreme particles; clusters are connected components (union-find) of touching or bonded
//! pairs.

use nalgebra::{Matrix3, Vector3};

use super::cloud::{centre_of_mass, Cloud};
use super::field::{lorentz_acceleration, Drag};
use super::params::BlastParams;
use crate::neighbor::NeighborList;

/// Shape of the cloud relative to the field axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// Semi-axis along B from the gyration tensor, √(5 b̂ᵀGb̂), m.
    pub along: f64,
    /// Semi-axis across B from the gyration tensor, √(5 (tr G − b̂ᵀGb̂)/2), m.
    pub across: f64,
    /// Largest |(r_i − r_c)·b̂| + R, m.
    pub extent_along: f64,
    /// Largest distance from the axis through r_c along b̂, plus R, m.
    pub extent_across: f64,
    /// Mean distance of the particles from the centre of mass, m.
    pub mean_radius: f64,
}

impl Envelope {
    /// along / across (gyration-tensor semi-axes).
    pub fn aspect_ratio(&self) -> f64 {
        self.along / self.across
    }

    /// The envelope of `cloud` about the unit axis `axis`.
    pub fn of(cloud: &Cloud, axis: &Vector3<f64>) -> Self {
        let centre = centre_of_mass(&cloud.positions);
        let n = cloud.len().max(1) as f64;
        let mut gyration = Matrix3::zeros();
        let (mut extent_along, mut extent_across, mut radius_sum) = (0.0_f64, 0.0_f64, 0.0);
        for r in &cloud.positions {
            let d = r - centre;
            gyration += d * d.transpose();
            let along = d.dot(axis);
            extent_along = extent_along.max(along.abs());
            extent_across = extent_across.max((d - along * axis).norm());
            radius_sum += d.norm();
        }
        gyration /= n;
        let parallel = axis.dot(&(gyration * axis));
        let perpendicular = 0.5 * (gyration.trace() - parallel);
        Self {
            along: (5.0 * parallel).sqrt(),
            across: (5.0 * perpendicular.max(0.0)).sqrt(),
            extent_along: extent_along + cloud.radius,
            extent_across: extent_across + cloud.radius,
            mean_radius: radius_sum / n,
        }
    }
}

/// How the cloud moves about the field axis (C15).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Angular momentum about the axis through the centre of mass along B of the positive
    /// charges, Σ m ((r − r_c) × v)·b̂, J·s (negative: clockwise seen from +B).
    pub spin_positive: f64,
    /// The same for the negative charges, J·s.
    pub spin_negative: f64,
    /// RMS velocity component along B, m/s.
    pub speed_along: f64,
    /// RMS velocity component across B, m/s.
    pub speed_across: f64,
    /// Mean turning radius |v⊥| / (|q̄| |B|) of the particles (C13), m; NaN without B.
    pub turning_radius: f64,
    /// Σ |Ψ^{e+m}| / Σ |Ψ^drag| over the particles (C11 for the cloud, with the run's drag
    /// law); NaN at rest or without drag.
    pub force_ratio: f64,
}

impl Motion {
    /// The motion of `cloud` under the fields and drag of `params`.
    pub fn of(cloud: &Cloud, params: &BlastParams) -> Self {
        let axis = params.field_axis();
        let (e, b) = (params.electric_field(), params.field());
        let drag = Drag::new(params);
        let centre = centre_of_mass(&cloud.positions);
        let n = cloud.len().max(1) as f64;
        let (mut spin, mut along2, mut across2, mut turning) = ([0.0; 2], 0.0, 0.0, 0.0);
        let (mut lorentz, mut resist) = (0.0, 0.0);
        for ((r, v), &qm) in cloud
            .positions
            .iter()
            .zip(&cloud.velocities)
            .zip(&cloud.charge_per_mass)
        {
            let l = cloud.mass * (r - centre).cross(v).dot(&axis);
            spin[usize::from(qm < 0.0)] += l;
            let along = v.dot(&axis);
            let across = (v - along * axis).norm();
            (along2, across2) = (along2 + along * along, across2 + across * across);
            turning += across / (qm.abs() * b.norm());
            lorentz += lorentz_acceleration(qm, &e, &b, v).norm();
            resist += drag.acceleration(v).norm();
        }
        Self {
            spin_positive: spin[0],
            spin_negative: spin[1],
            speed_along: (along2 / n).sqrt(),
            speed_across: (across2 / n).sqrt(),
            turning_radius: if b.norm() > 0.0 {
                turning / n
            } else {
                f64::NAN
            },
            force_ratio: if resist > 0.0 {
                lorentz / resist
            } else {
                f64::NAN
            },
        }
    }
}

/// Translational plus rotational kinetic energy, J.
pub fn kinetic_energy(cloud: &Cloud) -> f64 {
    let inertia = cloud.inertia();
    cloud
        .velocities
        .iter()
        .zip(&cloud.spins)
        .map(|(v, w)| 0.5 * cloud.mass * v.norm_squared() + 0.5 * inertia * w.norm_squared())
        .sum()
}

/// Clusters of touching or bonded particles: (number of clusters with at least two
/// particles, size of the largest cluster).
pub fn clusters(cloud: &Cloud, bonds: impl Iterator<Item = (usize, usize)>) -> (usize, usize) {
    let n = cloud.len();
    let mut parent: Vec<usize> = (0..n).collect();
    let mut list = NeighborList::<3>::new(0.0);
    list.build(&cloud.positions, &vec![cloud.radius; n]);
    let touching = (0..n).flat_map(|i| list.of(i).iter().map(move |&j| (i, j as usize)));
    for (i, j) in touching.chain(bonds) {
        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
        if a != b {
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut size = vec![0usize; n];
    for i in 0..n {
        let r = root(&mut parent, i);
        size[r] += 1;
    }
    let count = size.iter().filter(|&&s| s >= 2).count();
    (count, size.into_iter().max().unwrap_or(0))
}

/// Union-find root with path halving.
fn root(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::params::BlastParams;

    #[test]
    fn uniform_ball_has_its_radius_as_semi_axes() {
        let mut p = BlastParams::source_example();
        p.particles = 1500;
        p.radius = 0.02;
        let cloud = Cloud::blast(&p, 2).unwrap();
        let env = Envelope::of(&cloud, &Vector3::x());
        let room = p.cloud_radius - p.radius;
        assert!((env.along / room - 1.0).abs() < 0.06, "{env:?}");
        assert!((env.across / room - 1.0).abs() < 0.06, "{env:?}");
        assert!((env.mean_radius / (0.75 * room) - 1.0).abs() < 0.05);
        assert!(env.extent_along <= p.cloud_radius + 1e-12);
    }

    #[test]
    fn chain_of_touching_spheres_is_one_cluster() {
        let p = BlastParams::source_example();
        let positions = (0..5)
            .map(|k| Vector3::new(0.099 * k as f64, 0.0, 0.0))
            .chain([Vector3::new(5.0, 0.0, 0.0), Vector3::new(5.3, 0.0, 0.0)])
            .collect();
        let cloud = Cloud::at_rest(positions, &p);
        assert_eq!(clusters(&cloud, std::iter::empty()), (1, 5));
        assert_eq!(clusters(&cloud, [(5, 6)].into_iter()), (2, 5));
    }
}
