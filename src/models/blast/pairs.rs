//! Pair forces between equal spheres (C4–C8): contact with contact area, damping, regularized
//! friction at the contact point, bonds, and the near-field law. Each function returns the
//! force on particle i (and the moment about its centre) from partner j; swapping i and j
//! gives the exact negative force (action = reaction).

use nalgebra::Vector3;
use std::f64::consts::PI;

use super::params::{BlastParams, ContactParams, Interactions, NearFieldBasis, NearFieldParams};

/// One particle's kinematic state as a pair force sees it.
#[derive(Debug, Clone, Copy)]
pub struct Body {
    /// Centre, m.
    pub position: Vector3<f64>,
    /// Velocity, m/s.
    pub velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub spin: Vector3<f64>,
}

/// Force on i (N) and moment on i about its centre (N·m).
pub type Wrench = (Vector3<f64>, Vector3<f64>);

/// Constants of the pair laws, resolved once per run.
#[derive(Debug, Clone)]
pub struct PairLaw {
    /// Which terms are on.
    pub flags: Interactions,
    /// Constants of C4–C7.
    pub contact: ContactParams,
    /// Contact stiffness K_p after optional thermal softening, N/m².
    pub stiffness: f64,
    /// Particle radius R, m.
    pub radius: f64,
    /// α1 = ᾱ1 w², α2 = ᾱ2 w² of a like-signed pair, w the particle's weight of the near
    /// field's basis (C8).
    pub alpha: (f64, f64),
    /// Whether unlike charges flip the near field (the factor c_i c_j of C8).
    pub charge_sign: bool,
    /// β1, β2.
    pub beta: (f64, f64),
}

impl PairLaw {
    /// The pair law of `params`.
    pub fn new(params: &BlastParams) -> Self {
        let c = &params.contact;
        let stiffness = if params.interactions.thermal_softening {
            softened_stiffness(c)
        } else {
            c.stiffness
        };
        let w2 = near_field_weight(params).powi(2);
        let NearFieldParams {
            charge_sign,
            attraction,
            attraction_exponent,
            repulsion,
            repulsion_exponent,
            ..
        } = params.near_field;
        Self {
            flags: params.interactions,
            contact: c.clone(),
            stiffness,
            radius: params.radius,
            alpha: (attraction * w2, repulsion * w2),
            charge_sign,
            beta: (attraction_exponent, repulsion_exponent),
        }
    }

    /// Contact (C4), damping (C5) and friction (C6) on i from an overlapping j; also the
    /// tangential bond (C7) when `bond_area` is given. Zero when the pair does not touch and
    /// is not bonded. `dt` is the step of the regularized stick laws.
    pub fn contact(&self, i: &Body, j: &Body, bond_area: Option<f64>, dt: f64) -> Wrench {
        let d = j.position - i.position;
        if bond_area.is_none() && clearly_beyond(&d, 2.0 * self.radius) {
            // apart (dist > 2R, strain < 0): the zero below without the square root
            return (Vector3::zeros(), Vector3::zeros());
        }
        let dist = d.norm();
        let strain = (2.0 * self.radius - dist) / (2.0 * self.radius);
        if (strain <= 0.0 && bond_area.is_none()) || dist == 0.0 {
            return (Vector3::zeros(), Vector3::zeros());
        }
        let n = d / dist;
        let lever = 0.5 * dist; // centre to contact plane, L_i = L_j for equal spheres
        let area = contact_area(self.radius, dist);
        let mut force = Vector3::zeros();
        let mut normal = 0.0;
        if strain > 0.0 && self.flags.contact {
            normal = self.stiffness * power(strain, self.contact.exponent) * area;
            force -= normal * n;
        }
        if strain > 0.0 && self.flags.damping {
            force += self.contact.damping * (j.velocity - i.velocity).dot(&n) * area * n;
        }
        let slip = self.tangential_slip(i, j, &n, lever);
        let slip_speed = slip.norm();
        if slip_speed > 0.0 {
            let tau = slip / slip_speed;
            if strain > 0.0 && self.flags.friction {
                let stick = self.contact.friction_stiffness * slip_speed * area * dt;
                let limit = self.contact.static_friction * normal;
                force += if stick < limit {
                    stick * tau
                } else {
                    self.contact.dynamic_friction * normal * tau
                };
            }
            if let Some(a_b) = bond_area {
                force += self.contact.bond_tangential * slip_speed * a_b * dt * tau;
            }
        }
        if let Some(a_b) = bond_area.filter(|_| strain < 0.0) {
            force +=
                self.contact.bond_stiffness * (-strain).powf(self.contact.bond_exponent) * a_b * n;
        }
        let tangential = force - force.dot(&n) * n;
        let moment = if self.flags.rotation {
            (lever * n).cross(&tangential)
        } else {
            Vector3::zeros()
        };
        (force, moment)
    }

    /// Relative tangential velocity of j's contact point with respect to i's, v^c_{j,τ} − v^c_{i,τ}.
    fn tangential_slip(&self, i: &Body, j: &Body, n: &Vector3<f64>, lever: f64) -> Vector3<f64> {
        let at_i = i.velocity + i.spin.cross(&(lever * n));
        let at_j = j.velocity + j.spin.cross(&(-lever * n));
        let rel = at_j - at_i;
        rel - rel.dot(n) * n
    }

    /// The sign factor c_i c_j of the near field for charges per mass `qi`, `qj` (C8): −1 for
    /// unlike charges when the law carries it, else 1.
    #[inline]
    pub fn sign_factor(&self, qi: f64, qj: f64) -> f64 {
        if self.charge_sign && qi * qj < 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// Near-field force on i at r_i from a like-signed j at r_j (C8):
    /// (α1 r^{−β1} − α2 r^{−β2}) n_ij, N (times [`sign_factor`](Self::sign_factor) for j's sign).
    #[inline]
    pub fn near_field(&self, ri: &Vector3<f64>, rj: &Vector3<f64>) -> Vector3<f64> {
        let d = rj - ri;
        let dist2 = d.norm_squared();
        if dist2 == 0.0 {
            return Vector3::zeros();
        }
        let inv2 = 1.0 / dist2;
        let inv = inv2.sqrt();
        let (a1, a2) = self.alpha;
        if self.beta == (1.0, 2.0) {
            // the source's exponents: d (α1/r² − α2/r³), no powers
            return d * (inv2 * (a1 - a2 * inv));
        }
        d * ((a1 * power(inv, self.beta.0) - a2 * power(inv, self.beta.1)) * inv)
    }

    /// Distance where the near-field attraction and repulsion balance,
    /// r* = (α2/α1)^{1/(β2−β1)}, m (None if they never balance).
    pub fn crossover_distance(&self) -> Option<f64> {
        let r = (self.alpha.1 / self.alpha.0).powf(1.0 / (self.beta.1 - self.beta.0));
        r.is_finite().then_some(r).filter(|r| *r > 0.0)
    }
}

/// The particle's weight w of the near-field basis (C8): mass (kg), surface area 4πR² (m²),
/// volume 4/3 πR³ (m³) or charge magnitude |q/m| m (C).
pub fn near_field_weight(params: &BlastParams) -> f64 {
    let r = params.radius;
    match params.near_field.basis {
        NearFieldBasis::Mass => params.particle_mass(),
        NearFieldBasis::Area => 4.0 * PI * r * r,
        NearFieldBasis::Volume => 4.0 / 3.0 * PI * r * r * r,
        NearFieldBasis::Charge => params.charge_per_mass.abs() * params.particle_mass(),
    }
}

/// x^p with fast paths for the usual exponents (β = 1, 2; p_p = p_b = 2).
fn power(x: f64, p: f64) -> f64 {
    if p == 1.0 {
        x
    } else if p == 2.0 {
        x * x
    } else if p == 3.0 {
        x * x * x
    } else {
        x.powf(p)
    }
}

/// Whether the separation `d` is longer than `reach` (m) by far more than round-off: a test on
/// |d|² that lets a pair skip the square root, never a pair the exact test |d| ≤ reach keeps.
pub fn clearly_beyond(d: &Vector3<f64>, reach: f64) -> bool {
    d.norm_squared() > reach * reach * (1.0 + 1e-9)
}

/// Contact area A^c = π(R² − L²) of two equal spheres with centres `dist` apart (C4), m²;
/// zero when they do not touch.
pub fn contact_area(radius: f64, dist: f64) -> f64 {
    let lever = 0.5 * dist;
    (PI * (radius * radius - lever * lever)).max(0.0)
}

/// K_p = max(K_p0 e^{−a(Θ/Θ* − 1)}, K_p^lim) (C4), N/m²; equal temperatures, so the pair
/// average is the value itself.
pub fn softened_stiffness(c: &ContactParams) -> f64 {
    let factor = (-c.softening_rate * (c.temperature / c.reference_temperature - 1.0)).exp();
    (c.stiffness * factor).max(c.stiffness_floor)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::switches::Interactions;

    fn at(x: f64) -> Body {
        Body {
            position: Vector3::new(x, 0.0, 0.0),
            velocity: Vector3::new(0.0, 0.1 * x, 0.0),
            spin: Vector3::zeros(),
        }
    }

    /// The shortcut for pairs clearly apart never drops a touching pair: at 2R(1 − 1e-12)
    /// the normal force acts, at 2R and beyond it is zero, and a bonded pair beyond
    /// touching keeps its bond force.
    #[test]
    fn contact_acts_exactly_while_the_spheres_overlap() {
        let mut params = BlastParams::source_example();
        params.interactions = Interactions::all();
        let law = PairLaw::new(&params);
        let touch = 2.0 * law.radius;
        let force = |dist: f64, bond: Option<f64>| law.contact(&at(0.0), &at(dist), bond, 1e-4).0;
        assert!(force(touch * (1.0 - 1e-12), None).x < 0.0, "pushed apart");
        for dist in [touch, touch * (1.0 + 1e-12), 1.2 * touch] {
            assert_eq!(force(dist, None), Vector3::zeros(), "{dist}");
        }
        let area = contact_area(law.radius, 0.9 * touch);
        assert!(
            force(1.01 * touch, Some(area)).x > 0.0,
            "the bond pulls back"
        );
    }
}
