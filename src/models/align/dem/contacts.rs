//! Contact geometry and the Hertz normal law (spec align.md, A4), in reduced units (length
//! R_av, force E R_av²).
//!
//! For every particle the contact list holds its particle neighbours and the walls it touches
//! or nearly touches (overlap > −skin), with the unit normal e from the particle toward the
//! partner and the current overlap δ = R_i + R_j − |r_j − r_i|. Lists are per particle (each pair
//! appears twice, once from each side) so a particle's forces are a gather: deterministic,
//! free of write conflicts, and exactly antisymmetric since e_ji = −e_ij bit for bit.

use nalgebra::Vector3;
use rayon::prelude::*;

use crate::neighbor::NeighborList;

/// Marks a wall partner (side walls and floor, at rest).
pub const WALL: u32 = u32::MAX;
/// Marks the lid (the ceiling of the die: the punch, which may move along z).
pub const LID: u32 = u32::MAX - 1;

/// A rigid rectangular die [0, lx] × [0, ly] × [0, top] (reduced units); walls of the particle
/// material.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Container {
    /// Side length along x.
    pub lx: f64,
    /// Side length along y.
    pub ly: f64,
    /// Height of the ceiling (the punch's lid), if any (None: open top).
    pub top: Option<f64>,
}

/// One (possible) contact of a particle.
#[derive(Debug, Clone, Copy, Default)]
pub struct Contact {
    /// Partner particle index, `WALL` or `LID`.
    pub partner: u32,
    /// Unit normal from the particle toward the partner.
    pub normal: Vector3<f64>,
    /// Current overlap δ (negative: a gap).
    pub overlap: f64,
    /// Hertz prefactor k with F_n = k δ^{3/2}: k = (4/3) E*/E √(R*/R_av).
    pub hertz: f64,
}

impl Contact {
    /// The partner particle's index, or None for a wall or the lid.
    pub fn particle(&self) -> Option<usize> {
        (self.partner < LID).then_some(self.partner as usize)
    }

    /// Hertz normal force magnitude at overlap δ: k δ^{3/2} for δ > 0, else 0 (A4).
    pub fn normal_force_at(&self, overlap: f64) -> f64 {
        if overlap > 0.0 {
            self.hertz * overlap * overlap.sqrt()
        } else {
            0.0
        }
    }

    /// dF_n/dδ at overlap δ.
    pub fn stiffness_at(&self, overlap: f64) -> f64 {
        if overlap > 0.0 {
            1.5 * self.hertz * overlap.sqrt()
        } else {
            0.0
        }
    }
}

/// Contact laws of one run in reduced units.
#[derive(Debug, Clone, Copy)]
pub struct ContactLaw {
    /// E*/E for a pair of particles (and a particle and a wall): 1/(2(1 − ν²)).
    pub effective_modulus: f64,
    /// μ between particles.
    pub friction: f64,
    /// μ between a particle and a wall.
    pub wall_friction: f64,
    /// Pairs and walls closer than this gap are listed as contacts (they may touch within a
    /// step); at most the neighbour-list skin.
    pub skin: f64,
}

impl ContactLaw {
    /// Emits the contacts of particle i: listed neighbours and walls closer than the skin.
    pub fn contacts_of(
        &self,
        i: usize,
        positions: &[Vector3<f64>],
        radii: &[f64],
        neighbors: &NeighborList,
        container: &Container,
        mut emit: impl FnMut(Contact),
    ) {
        let (p, r) = (positions[i], radii[i]);
        for &j in neighbors.of(i) {
            let ju = j as usize;
            let d = positions[ju] - p;
            // Listed pairs reach out to the neighbour list's skin, most beyond this law's:
            // skip those on the squared distance (a margin far above round-off, so no pair
            // the exact test below would keep is skipped) before paying for the root.
            let reach = r + radii[ju] + self.skin;
            let dist_squared = d.norm_squared();
            if dist_squared > reach * reach * (1.0 + 1e-9) {
                continue;
            }
            let dist = dist_squared.sqrt();
            let overlap = r + radii[ju] - dist;
            if overlap > -self.skin && dist > 0.0 {
                emit(Contact {
                    partner: j,
                    normal: d / dist,
                    overlap,
                    hertz: self.hertz_prefactor(r, Some(radii[ju])),
                });
            }
        }
        for (partner, normal, gap) in wall_gaps(p, container) {
            let overlap = r - gap;
            if overlap > -self.skin {
                emit(Contact {
                    partner,
                    normal,
                    overlap,
                    hertz: self.hertz_prefactor(r, None),
                });
            }
        }
    }

    /// Coulomb coefficient μ of a contact (particle pair or wall).
    pub fn friction_of(&self, c: &Contact) -> f64 {
        if c.particle().is_none() {
            self.wall_friction
        } else {
            self.friction
        }
    }

    /// Prefactor (4/3) E*/E √R* of (A4) for reduced radii (wall: r_j = ∞).
    pub fn hertz_prefactor(&self, r_i: f64, r_j: Option<f64>) -> f64 {
        let r_star = match r_j {
            Some(r_j) => r_i * r_j / (r_i + r_j),
            None => r_i,
        };
        4.0 / 3.0 * self.effective_modulus * r_star.sqrt()
    }
}

/// Per-particle contact lists (compressed rows).
#[derive(Debug, Clone, Default)]
pub struct ContactSet {
    offsets: Vec<usize>,
    contacts: Vec<Contact>,
}

impl ContactSet {
    /// Contacts of particle i.
    pub fn of(&self, i: usize) -> &[Contact] {
        &self.contacts[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Positions of particle i's contacts in `all`.
    pub fn slots(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// All listed contacts, both directions.
    pub fn all(&self) -> &[Contact] {
        &self.contacts
    }

    /// Rebuilds the lists for the given positions, reusing the allocation.
    pub fn rebuild(
        &mut self,
        positions: &[Vector3<f64>],
        radii: &[f64],
        neighbors: &NeighborList,
        container: &Container,
        law: &ContactLaw,
    ) {
        // Two parallel passes (count, then fill each particle's own slice): the same lists
        // in the same order as a serial loop, at any thread count.
        let counts: Vec<usize> = (0..positions.len())
            .into_par_iter()
            .map(|i| {
                let mut count = 0;
                law.contacts_of(i, positions, radii, neighbors, container, |_| count += 1);
                count
            })
            .collect();
        self.offsets.clear();
        self.offsets.push(0);
        for c in &counts {
            self.offsets.push(self.offsets.last().unwrap() + c);
        }
        self.contacts.clear();
        self.contacts
            .resize(*self.offsets.last().unwrap(), Contact::default());
        let mut slices = Vec::with_capacity(counts.len());
        let mut rest = &mut self.contacts[..];
        for &c in &counts {
            let (mine, tail) = rest.split_at_mut(c);
            slices.push(mine);
            rest = tail;
        }
        slices.into_par_iter().enumerate().for_each(|(i, slot)| {
            let mut k = 0;
            law.contacts_of(i, positions, radii, neighbors, container, |c| {
                slot[k] = c;
                k += 1;
            });
        });
    }

    /// Largest overlap over all contacts (0 if none).
    pub fn max_overlap(&self) -> f64 {
        self.contacts.iter().map(|c| c.overlap).fold(0.0, f64::max)
    }
}

/// Partner marks, outward wall normals and centre-to-wall distances of a point in the container.
fn wall_gaps(p: Vector3<f64>, c: &Container) -> impl Iterator<Item = (u32, Vector3<f64>, f64)> {
    let walls = [
        (WALL, Vector3::new(-1.0, 0.0, 0.0), p.x),
        (WALL, Vector3::new(1.0, 0.0, 0.0), c.lx - p.x),
        (WALL, Vector3::new(0.0, -1.0, 0.0), p.y),
        (WALL, Vector3::new(0.0, 1.0, 0.0), c.ly - p.y),
        (WALL, Vector3::new(0.0, 0.0, -1.0), p.z),
    ];
    let ceiling = c
        .top
        .map(|top| (LID, Vector3::new(0.0, 0.0, 1.0), top - p.z));
    walls.into_iter().chain(ceiling)
}

/// Two unit spheres pressed together along x (overlap 0.01, no walls in reach) with friction
/// μ: the positions, radii, law and contacts the unit tests of the friction solvers share.
#[cfg(test)]
pub(crate) fn pressed_pair(friction: f64) -> (Vec<Vector3<f64>>, Vec<f64>, ContactLaw, ContactSet) {
    let positions = vec![Vector3::new(5.0, 5.0, 5.0), Vector3::new(6.99, 5.0, 5.0)];
    let radius = vec![1.0, 1.0];
    let law = ContactLaw {
        effective_modulus: 0.55,
        friction,
        wall_friction: 0.0,
        skin: 0.2,
    };
    let mut list = NeighborList::new(0.3);
    list.build(&positions, &radius);
    let container = Container {
        lx: 20.0,
        ly: 20.0,
        top: None,
    };
    let mut contacts = ContactSet::default();
    contacts.rebuild(&positions, &radius, &list, &container, &law);
    (positions, radius, law, contacts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hertz_force_matches_formula() {
        // Two unequal spheres, SI numbers converted: F = 4/3 E* √(R* δ) δ.
        let law = ContactLaw {
            effective_modulus: 1.0 / (2.0 * (1.0 - 0.28f64.powi(2))),
            friction: 0.0,
            wall_friction: 0.0,
            skin: 0.1,
        };
        let (r1, r2, delta) = (1.1, 0.8, 0.01);
        let contact = Contact {
            partner: 1,
            normal: Vector3::x(),
            overlap: delta,
            hertz: law.hertz_prefactor(r1, Some(r2)),
        };
        let e_star = law.effective_modulus;
        let r_star = 1.0 / (1.0 / r1 + 1.0 / r2);
        let expected = 4.0 / 3.0 * e_star * (r_star * delta).sqrt() * delta;
        assert!((contact.normal_force_at(delta) / expected - 1.0).abs() < 1e-14);
        // stiffness is the derivative
        let h = 1e-7;
        let numeric =
            (contact.normal_force_at(delta + h) - contact.normal_force_at(delta - h)) / (2.0 * h);
        assert!((contact.stiffness_at(delta) / numeric - 1.0).abs() < 1e-6);
        assert_eq!(contact.normal_force_at(-0.01), 0.0);
    }
}
