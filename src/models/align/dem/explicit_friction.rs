//! The source's friction scheme as a switchable variant (`friction_scheme = source-explicit`):
//! E&B 2020, Eq. (8), F_t = −μ F_n v_t/|v_t|, evaluated from the relative velocity of the
//! previous iterate (the velocities of the previous velocity solve) and applied as a fixed
//! force and torque, with no implicit solve and no regularization. The spec (align.md, A5)
//! warns that such an explicit fixed point chatters and loses part of the friction effect;
//! this variant exists to measure by how much. The rotational term uses the corrected sign +
//! (docs/align.md, A5).

use nalgebra::Vector3;

use super::contacts::{ContactLaw, ContactSet};
use super::velocity::Motion;

/// Adds to `force` and `torque` the Coulomb friction (A5) of every contact at the velocities
/// `motion` of the previous iterate: −μ F_n(δ) v_t/|v_t| on the particle and R_i e × F_t about
/// its centre (nothing where v_t = 0).
pub fn add_previous_iterate_friction(
    contacts: &ContactSet,
    law: &ContactLaw,
    radius: &[f64],
    motion: &[Motion],
    force: &mut [Vector3<f64>],
    torque: &mut [Vector3<f64>],
) {
    for (i, m) in motion.iter().enumerate() {
        for c in contacts.of(i) {
            let bound = law.friction_of(&c) * c.normal_force_at(c.overlap);
            if bound == 0.0 {
                continue;
            }
            // walls and the lid have no tangential velocity
            let partner = c.particle().map_or(Vector3::zeros(), |j| {
                motion[j].v - radius[j] * motion[j].w.cross(&c.normal)
            });
            let rel = m.v + radius[i] * m.w.cross(&c.normal) - partner;
            let slip = rel - rel.dot(&c.normal) * c.normal;
            let speed = slip.norm();
            if speed > 0.0 {
                let f_t = -bound / speed * slip;
                force[i] += f_t;
                torque[i] += radius[i] * c.normal.cross(&f_t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::contacts::pressed_pair;

    /// Two pressed spheres, the first sliding along +y: each gets the full Coulomb force μ F_n
    /// against its slip, equal and opposite, and the first the torque R e × F_t.
    #[test]
    fn coulomb_force_opposes_the_previous_slip_at_full_strength() {
        let (_, radius, law, contacts) = pressed_pair(0.3);
        let motion = vec![
            Motion {
                v: Vector3::new(0.0, 1e-9, 0.0),
                w: Vector3::zeros(),
            },
            Motion::default(),
        ];
        let (mut force, mut torque) = (vec![Vector3::zeros(); 2], vec![Vector3::zeros(); 2]);
        add_previous_iterate_friction(&contacts, &law, &radius, &motion, &mut force, &mut torque);
        let c = contacts.contact(0, 0);
        let bound = 0.3 * c.normal_force_at(c.overlap);
        assert!((force[0] - Vector3::new(0.0, -bound, 0.0)).norm() < 1e-15 * bound);
        assert!((force[0] + force[1]).norm() < 1e-15 * bound);
        assert!((torque[0] - Vector3::new(0.0, 0.0, -bound)).norm() < 1e-15 * bound);
    }
}
