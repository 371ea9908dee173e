//! Contact geometry and the Hertz normal law (spec align.md, A4), in reduced units (length
//! R_av, force E R_av²).
//!
//! For every particle the contact list holds its particle neighbours and the walls it touches
//! or nearly touches (overlap > −skin), with the unit normal e from the particle toward the
//! partner and the current overlap δ = R_i + R_j − |r_j − r_i|. Lists are per particle (each pair
//! appears twice, once from each side) so a particle's forces are a gather: deterministic,
//! free of write conflicts, and exactly antisymmetric since e_ji = −e_ij bit for bit.

use std::ops::Index;

use nalgebra::Vector3;
use rayon::prelude::*;

use crate::neighbor::NeighborList;

/// Marks a wall partner (side walls and floor, at rest).
pub const WALL: u32 = u32::MAX;
/// Marks the lid (the ceiling of the die: the punch, which may move along z).
pub const LID: u32 = u32::MAX - 1;

/// A rigid rectangular die [0, lx] × [0, ly] × [0, top] (reduced units); walls of the particle
/// material.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
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
#[derive(Debug, Clone, Copy, Default)]
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
    /// Emits the contacts of particle i: listed neighbours and walls closer than the skin,
    /// each with its code in a [`ContactSet`] (the partner's index, or `SURFACE` + k for the
    /// k-th surface of [`wall_gaps`]).
    pub fn contacts_of(
        &self,
        i: usize,
        positions: &[Vector3<f64>],
        radii: &[f64],
        neighbors: &NeighborList,
        container: &Container,
        mut emit: impl FnMut(u32, Contact),
    ) {
        self.particle_contacts_of(i, positions, radii, neighbors, &mut emit);
        self.wall_contacts_of(i, positions, radii, container, emit);
    }

    /// The particle part of [`Self::contacts_of`]: listed neighbours closer than the skin, in
    /// list order.
    pub fn particle_contacts_of<P: Index<usize, Output = Vector3<f64>> + ?Sized>(
        &self,
        i: usize,
        positions: &P,
        radii: &[f64],
        neighbors: &NeighborList,
        mut emit: impl FnMut(u32, Contact),
    ) {
        let (p, r) = (positions[i], radii[i]);
        for &j in neighbors.of(i) {
            let ju = j as usize;
            // Listed pairs reach out to the neighbour list's skin, most beyond this law's:
            // skip those on the squared distance (a margin far above round-off, so no pair
            // the exact test below would keep is skipped) before paying for the root.
            let reach = r + radii[ju] + self.skin;
            if (positions[ju] - p).norm_squared() > reach * reach * (1.0 + 1e-9) {
                continue;
            }
            let (contact, dist) = self.pair(p, r, positions[ju], radii[ju], j);
            if contact.overlap > -self.skin && dist > 0.0 {
                emit(j, contact);
            }
        }
    }

    /// The wall part of [`Self::contacts_of`]: the surfaces of [`wall_gaps`] closer than the
    /// skin, in their order.
    pub fn wall_contacts_of<P: Index<usize, Output = Vector3<f64>> + ?Sized>(
        &self,
        i: usize,
        positions: &P,
        radii: &[f64],
        container: &Container,
        mut emit: impl FnMut(u32, Contact),
    ) {
        let (p, r) = (positions[i], radii[i]);
        // most particles are near no surface: tell on the gaps alone first
        let near = |gap: f64| r - gap > -self.skin;
        if !wall_gaps(p, container).any(|(_, _, gap)| near(gap)) {
            return;
        }
        for (k, (partner, normal, gap)) in wall_gaps(p, container).enumerate() {
            if near(gap) {
                emit(SURFACE + k as u32, self.wall(r, partner, normal, gap));
            }
        }
    }

    /// The contact of a sphere (centre p, radius r) with sphere j (centre q, radius r_j), and
    /// their centres' distance.
    fn pair(&self, p: Vector3<f64>, r: f64, q: Vector3<f64>, r_j: f64, j: u32) -> (Contact, f64) {
        let d = q - p;
        let dist = d.norm_squared().sqrt();
        let contact = Contact {
            partner: j,
            normal: d / dist,
            overlap: r + r_j - dist,
            hertz: self.hertz_prefactor(r, Some(r_j)),
        };
        (contact, dist)
    }

    /// The contact of a sphere of radius r with a surface at centre distance `gap`.
    fn wall(&self, r: f64, partner: u32, normal: Vector3<f64>, gap: f64) -> Contact {
        Contact {
            partner,
            normal,
            overlap: r - gap,
            hertz: self.hertz_prefactor(r, None),
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

/// Per-particle contact lists (compressed rows). Each listed contact is stored as its
/// partner's code alone (4 bytes, not a 48-byte [`Contact`]); its geometry is recomputed from
/// the positions of the rebuild, by the same operations, so every value is the same bits as
/// when it was listed. The alignment stage at N = 10⁶ then peaks at 0.58 kB per particle, not
/// 0.91 (results/bench/README.md, "Memory at N = 10⁶").
#[derive(Debug, Clone, Default)]
pub struct ContactSet {
    offsets: Vec<usize>,
    codes: Vec<u32>,
    position: Vec<Vector3<f64>>,
    radius: Vec<f64>,
    container: Container,
    law: ContactLaw,
    max_overlap: f64,
}

/// Codes from here on mark surfaces in a [`ContactSet`]: `SURFACE` + k is the k-th entry of
/// [`wall_gaps`] (particle indices stay below it).
const SURFACE: u32 = u32::MAX - 8;

impl ContactSet {
    /// Contacts of particle i, in list order.
    pub fn of(&self, i: usize) -> impl ExactSizeIterator<Item = Contact> + Clone + '_ {
        self.slots(i).map(move |slot| self.contact(i, slot))
    }

    /// Particle i's contact in slot `slot` (one of [`Self::slots`]`(i)`).
    pub fn contact(&self, i: usize, slot: usize) -> Contact {
        let (code, p, r) = (self.codes[slot], self.position[i], self.radius[i]);
        if code < SURFACE {
            let j = code as usize;
            self.law
                .pair(p, r, self.position[j], self.radius[j], code)
                .0
        } else {
            let (partner, normal, gap) = wall_gaps(p, &self.container)
                .nth((code - SURFACE) as usize)
                .expect("a listed surface exists");
            self.law.wall(r, partner, normal, gap)
        }
    }

    /// Positions of particle i's contacts in the set's slots.
    pub fn slots(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// Where particle j lists particle i, if it does.
    pub fn slot_of(&self, j: usize, i: usize) -> Option<usize> {
        let slots = self.slots(j);
        let at = self.codes[slots.clone()]
            .iter()
            .position(|&code| code as usize == i);
        at.map(|k| slots.start + k)
    }

    /// Number of particles.
    pub fn particles(&self) -> usize {
        self.radius.len()
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
        self.position.clear();
        self.position.extend_from_slice(positions);
        self.radius.clear();
        self.radius.extend_from_slice(radii);
        (self.container, self.law) = (*container, *law);
        // Two parallel passes (count, then fill each particle's own slice): the same lists
        // in the same order as a serial loop, at any thread count.
        let counts: Vec<usize> = (0..positions.len())
            .into_par_iter()
            .map(|i| {
                let mut count = 0;
                law.contacts_of(i, positions, radii, neighbors, container, |_, _| count += 1);
                count
            })
            .collect();
        self.offsets.clear();
        self.offsets.push(0);
        for c in &counts {
            self.offsets.push(self.offsets.last().unwrap() + c);
        }
        self.codes.clear();
        self.codes.resize(*self.offsets.last().unwrap(), 0);
        let mut slices = Vec::with_capacity(counts.len());
        let mut rest = &mut self.codes[..];
        for &c in &counts {
            let (mine, tail) = rest.split_at_mut(c);
            slices.push(mine);
            rest = tail;
        }
        // the largest overlap: a maximum, the same at any grouping
        self.max_overlap = slices
            .into_par_iter()
            .enumerate()
            .map(|(i, slot)| {
                let (mut k, mut deepest) = (0, 0.0_f64);
                law.contacts_of(i, positions, radii, neighbors, container, |code, c| {
                    slot[k] = code;
                    k += 1;
                    deepest = deepest.max(c.overlap);
                });
                deepest
            })
            .reduce(|| 0.0, f64::max);
    }

    /// Largest overlap over all contacts (0 if none).
    pub fn max_overlap(&self) -> f64 {
        self.max_overlap
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
    use rand::{RngExt, SeedableRng};

    /// The set stores codes alone; the contacts it gives back are the law's, bit for bit,
    /// walls and lid included, and its largest overlap is theirs.
    #[test]
    fn a_set_gives_back_the_laws_contacts_bit_for_bit() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let container = Container {
            lx: 12.0,
            ly: 10.0,
            top: Some(9.0),
        };
        let radii: Vec<f64> = (0..400).map(|_| 0.8 + 0.4 * rng.random::<f64>()).collect();
        let positions: Vec<Vector3<f64>> = (0..400)
            .map(|_| Vector3::from_fn(|k, _| [12.0, 10.0, 9.0][k] * rng.random::<f64>()))
            .collect();
        let law = ContactLaw {
            effective_modulus: 0.55,
            friction: 0.2,
            wall_friction: 0.3,
            skin: 0.2,
        };
        let mut list = NeighborList::new(0.3);
        list.build(&positions, &radii);
        let mut set = ContactSet::default();
        set.rebuild(&positions, &radii, &list, &container, &law);
        let bits = |c: &Contact| {
            let n = c.normal;
            [n.x, n.y, n.z, c.overlap, c.hertz].map(f64::to_bits)
        };
        let (mut walls, mut lid, mut deepest) = (0, 0, 0.0_f64);
        for i in 0..positions.len() {
            let mut expected = Vec::new();
            law.contacts_of(i, &positions, &radii, &list, &container, |_, c| {
                expected.push(c)
            });
            let stored: Vec<Contact> = set.of(i).collect();
            assert_eq!(stored.len(), expected.len());
            for (a, b) in stored.iter().zip(&expected) {
                assert_eq!((a.partner, bits(a)), (b.partner, bits(b)));
                walls += usize::from(a.partner == WALL);
                lid += usize::from(a.partner == LID);
                deepest = deepest.max(a.overlap);
            }
        }
        assert!(walls > 10 && lid > 5, "{walls} wall and {lid} lid contacts");
        assert_eq!(set.max_overlap(), deepest);
    }

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
