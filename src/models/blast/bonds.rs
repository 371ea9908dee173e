//! Each bonded pair's wrench (C4–C7) computed once per force evaluation and given to both
//! partners. After the cloud collapses a particle holds some 35 bonds, so evaluating every
//! bond from both sides doubled the model's largest cost after the near field.
//!
//! Why the partner's share is exact: swapping i and j negates the separation, and with it the
//! normal, the relative velocities and the tangential slip, exactly (IEEE negation commutes
//! with every rounding used), so `PairLaw::contact` gives j exactly −F and the same moment
//! (lever·(−n)) × (−t) = (lever·n) × t. Each particle then adds its bonds' shares in its
//! list's ascending order, the order of the per-particle evaluation this replaces, so the
//! forces keep their bits. A new bond is appended to the pairs (an insertion into two lists,
//! not a re-index of every bond), and the pairs are renumbered in first-particle order once
//! an eighth of them are new ([`BondIndex::tidy`]): a pair's wrench does not depend on where
//! it sits (the four lanes give the scalar law's bits), so no bit depends on that order.

use nalgebra::Vector3;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::bond_lanes::four_wrenches;
use super::cloud::Cloud;
use super::pairs::{Body, PairLaw, Wrench};

/// Pairs per rayon task.
const CHUNK: usize = 256;

/// Each particle's bonds, and the bonded pairs once each with their wrenches at the last
/// evaluation. Bonds are permanent: new ones are appended, and [`BondIndex::tidy`] puts the
/// pairs back in first-particle order now and then.
#[derive(Debug, Clone, Default)]
pub struct BondIndex {
    /// Each particle's bonds, ascending by partner.
    lists: Vec<Vec<Bond>>,
    /// (i, j, contact area at bonding in m²), i < j: ascending up to `tidy_at`, then in the
    /// order the bonds formed.
    pairs: Vec<(u32, u32, f64)>,
    /// Wrench on the pair's first particle, N and N·m.
    wrenches: Vec<Wrench>,
    /// The pairs at the last [`BondIndex::tidy`].
    tidy_at: usize,
}

/// One entry of a particle's bond list: the partner and the pair's index.
#[derive(Debug, Clone, Copy)]
struct Bond {
    partner: u32,
    pair: u32,
}

impl BondIndex {
    /// No bonds among `n` particles.
    pub fn new(n: usize) -> Self {
        Self {
            lists: vec![Vec::new(); n],
            ..Self::default()
        }
    }

    /// Number of bonded pairs.
    pub fn count(&self) -> usize {
        self.pairs.len()
    }

    /// Particle i's bonded partners, ascending.
    pub fn partners(&self, i: usize) -> impl Iterator<Item = u32> + '_ {
        self.lists[i].iter().map(|b| b.partner)
    }

    /// Bonded pairs (i < j), ascending by i, then j.
    pub fn bonded_pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.lists.iter().enumerate().flat_map(|(i, list)| {
            list.iter()
                .map(move |bond| (i, bond.partner as usize))
                .filter(|(i, j)| i < j)
        })
    }

    /// Bonds i and j (i < j, not bonded yet) with the contact area `area`, m². Each list
    /// stays ascending (an insertion: a list holds a few dozen bonds, 46 on average at the end
    /// of the source's interacting example).
    pub fn add(&mut self, i: usize, j: usize, area: f64) {
        debug_assert!(i < j && self.partners(i).all(|b| b as usize != j));
        let pair = self.pairs.len() as u32;
        self.pairs.push((i as u32, j as u32, area));
        self.wrenches.push((Vector3::zeros(), Vector3::zeros()));
        for (a, b) in [(i, j), (j, i)] {
            let list = &mut self.lists[a];
            let at = list.partition_point(|bond| (bond.partner as usize) < b);
            list.insert(
                at,
                Bond {
                    partner: b as u32,
                    pair,
                },
            );
        }
    }

    /// Renumbers the pairs ascending by first particle, then second, once the pairs appended
    /// since the last renumbering are an eighth of all. Why: the force gather runs over the
    /// particles in parallel and reads each particle's pairs; in first-particle order a
    /// thread's upper pairs sit in the part of the array it wrote itself, where in the order
    /// of formation they are scattered over lines the other core wrote. No bit depends on the
    /// order (see the module's comment).
    pub fn tidy(&mut self) {
        let appended = self.pairs.len() - self.tidy_at;
        if appended == 0 || 8 * appended < self.pairs.len() {
            return;
        }
        let mut new_of = vec![0u32; self.pairs.len()];
        let mut pairs = Vec::with_capacity(self.pairs.len());
        for (i, list) in self.lists.iter().enumerate() {
            for bond in list.iter().filter(|b| b.partner as usize > i) {
                new_of[bond.pair as usize] = pairs.len() as u32;
                pairs.push(self.pairs[bond.pair as usize]);
            }
        }
        for bond in self.lists.iter_mut().flatten() {
            bond.pair = new_of[bond.pair as usize];
        }
        self.pairs = pairs;
        self.tidy_at = self.pairs.len();
    }

    /// Every bonded pair's wrench on its first particle at the state `cloud`: four pairs
    /// per AVX instruction where the processor has AVX (the same bits), the rest one by one.
    pub fn evaluate(&mut self, law: &PairLaw, cloud: &Cloud, dt: f64) {
        self.evaluate_with(law, cloud, dt, crate::numerics::has_avx());
    }

    /// [`BondIndex::evaluate`] with or without the AVX lanes.
    fn evaluate_with(&mut self, law: &PairLaw, cloud: &Cloud, dt: f64, avx: bool) {
        self.wrenches
            .par_chunks_mut(CHUNK)
            .zip(self.pairs.par_chunks(CHUNK))
            .for_each(|(out, pairs)| {
                let mut done = 0;
                #[cfg(target_arch = "x86_64")]
                if avx {
                    for (out, pairs) in out.chunks_exact_mut(4).zip(pairs.chunks_exact(4)) {
                        let four = pairs.try_into().expect("chunks of four");
                        let out = out.try_into().expect("chunks of four");
                        // SAFETY: `avx` is true only where the processor has AVX.
                        unsafe { four_wrenches(law, cloud, dt, four, out) };
                        done += 4;
                    }
                }
                #[cfg(not(target_arch = "x86_64"))]
                let _ = avx; // no AVX lanes off x86-64
                for (w, &(i, j, area)) in out[done..].iter_mut().zip(&pairs[done..]) {
                    *w = law.contact(&body(cloud, i), &body(cloud, j), Some(area), dt);
                }
            });
    }

    /// The wrenches on particle i from its bonds, in its list's (ascending) order.
    pub fn wrenches_on(&self, i: usize) -> impl Iterator<Item = Wrench> + '_ {
        self.lists[i].iter().map(move |bond| {
            let (force, moment) = self.wrenches[bond.pair as usize];
            if (bond.partner as usize) > i {
                (force, moment)
            } else {
                (-force, moment)
            }
        })
    }
}

/// Particle k of `cloud` as a pair force sees it.
fn body(cloud: &Cloud, k: u32) -> Body {
    let k = k as usize;
    Body {
        position: cloud.positions[k],
        velocity: cloud.velocities[k],
        spin: cloud.spins[k],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::params::BlastParams;
    use crate::models::blast::switches::Interactions;

    /// Four spheres with spins, some overlapping and some stretched apart, bonded 0–1, 0–2,
    /// 1–3, 2–3: each pair is indexed once, and each partner's share is exactly what the
    /// law gives it evaluated from its own side (the bits the gather relies on).
    #[test]
    fn each_partner_gets_the_bits_of_its_own_evaluation() {
        let mut params = BlastParams::source_example();
        params.interactions = Interactions::all();
        let law = PairLaw::new(&params);
        let r = law.radius;
        let positions = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.9 * r, 0.1 * r, -0.05 * r),
            Vector3::new(-0.3 * r, 2.05 * r, 0.2 * r),
            Vector3::new(1.7 * r, 1.95 * r, 0.4 * r),
        ];
        let mut cloud = Cloud::at_rest(positions.to_vec(), &params);
        for (k, (v, w)) in cloud
            .velocities
            .iter_mut()
            .zip(&mut cloud.spins)
            .enumerate()
        {
            let t = k as f64 + 1.0;
            *v = Vector3::new(0.3 * t.sin(), -0.2 * t, 0.7 * t.cos());
            *w = Vector3::new(5.0 * t.cos(), 3.0, -2.0 * t);
        }
        let area = 0.01 * r * r;
        let lists = vec![
            vec![(1, area), (2, 2.0 * area)],
            vec![(0, area), (3, 3.0 * area)],
            vec![(0, 2.0 * area), (3, 4.0 * area)],
            vec![(1, 3.0 * area), (2, 4.0 * area)],
        ];
        let index = &mut indexed(&lists);
        assert_eq!(index.count(), 4);
        index.evaluate(&law, &cloud, 1e-4);
        for (i, list) in lists.iter().enumerate() {
            let shares: Vec<Wrench> = index.wrenches_on(i).collect();
            assert_eq!(shares.len(), list.len());
            for (&(j, a), share) in list.iter().zip(shares) {
                let own = law.contact(&body(&cloud, i as u32), &body(&cloud, j), Some(a), 1e-4);
                assert_ne!(own.0, Vector3::zeros(), "{i}–{j} acts");
                assert_eq!(share, own, "{i}–{j}");
            }
        }
    }

    /// An index holding the bonds of `lists` (symmetric, each ascending), added from
    /// their lower particle's side in ascending order.
    fn indexed(lists: &[Vec<(u32, f64)>]) -> BondIndex {
        let mut index = BondIndex::new(lists.len());
        for (i, list) in lists.iter().enumerate() {
            for &(j, area) in list.iter().filter(|&&(j, _)| j as usize > i) {
                index.add(i, j as usize, area);
            }
        }
        index
    }

    /// Bonds added in a random order, in batches each followed by a [`BondIndex::tidy`],
    /// with particles bonded to none, to lower ones only and to upper ones only: every list
    /// ascends, holds each partner once, and each entry points at its pair, held once as
    /// (lower, upper, area); a tidy that renumbers leaves the pairs ascending.
    #[test]
    fn every_entry_finds_its_pair_once() {
        use rand::seq::SliceRandom;
        use rand::RngExt;
        let mut rng = crate::rng::run_stream(5, crate::rng::Purpose::Positions);
        let n = 300;
        let mut pairs = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                if (i % 7 != 3 && j % 11 != 5) && rng.random::<f64>() < 0.05 {
                    pairs.push((i, j, (i * n + j) as f64));
                }
            }
        }
        pairs.shuffle(&mut rng);
        let mut index = BondIndex::new(n);
        let mut renumbered = 0;
        for batch in pairs.chunks(pairs.len() / 20) {
            for &(i, j, area) in batch {
                index.add(i, j, area);
            }
            index.tidy();
            if index.tidy_at == index.count() {
                renumbered += 1;
                let firsts: Vec<_> = index.pairs.iter().map(|&(a, b, _)| (a, b)).collect();
                assert!(firsts.windows(2).all(|w| w[0] < w[1]));
            }
        }
        assert!(
            renumbered > 3 && index.tidy_at < index.count(),
            "{renumbered}"
        );
        assert_eq!(index.count(), pairs.len());
        for (i, list) in index.lists.iter().enumerate() {
            let mut expected: Vec<u32> = pairs
                .iter()
                .filter_map(|&(a, b, _)| (a == i).then_some(b).or((b == i).then_some(a)))
                .map(|p| p as u32)
                .collect();
            expected.sort_unstable();
            assert_eq!(index.partners(i).collect::<Vec<_>>(), expected, "{i}");
            for bond in list {
                let (a, b) = (i.min(bond.partner as usize), i.max(bond.partner as usize));
                let pair = index.pairs[bond.pair as usize];
                assert_eq!(pair, (a as u32, b as u32, (a * n + b) as f64));
            }
        }
    }

    /// The AVX lanes give the scalar law's bits for every regime: compressed pairs that
    /// stick or slip, stretched pairs, pairs without slip, a coincident pair, with the
    /// source's exponents and with non-integer ones (the `powf` path), rotation on and off;
    /// 203 pairs, so a remainder runs scalar.
    #[test]
    fn four_lanes_give_the_bits_of_the_scalar_law() {
        use rand::RngExt;
        let mut rng = crate::rng::run_stream(11, crate::rng::Purpose::Positions);
        let mut params = BlastParams::source_example();
        params.interactions = Interactions::all();
        let r = params.radius;
        let n = 60;
        let positions: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::from_fn(|_, _| rng.random::<f64>() * 6.0 * r))
            .collect();
        let mut cloud = Cloud::at_rest(positions, &params);
        for (k, (v, w)) in cloud
            .velocities
            .iter_mut()
            .zip(&mut cloud.spins)
            .enumerate()
        {
            // at rest, creeping (sticking contacts) or moving (slipping ones)
            let speed = [0.0, 1e-6, 1.0][k % 3];
            *v = Vector3::from_fn(|_, _| speed * (rng.random::<f64>() - 0.5));
            *w = Vector3::from_fn(|_, _| 40.0 * speed * (rng.random::<f64>() - 0.5));
        }
        cloud.positions[1] = cloud.positions[0]; // a coincident pair
        let mut lists = vec![Vec::new(); n];
        let mut pairs = 0;
        for i in 0..n {
            for j in i + 1..n {
                let dist = (cloud.positions[j] - cloud.positions[i]).norm();
                if dist < 2.3 * r && pairs < 203 {
                    let area = 0.02 * r * r * (1.0 + (i + j) as f64 / n as f64);
                    lists[i].push((j as u32, area));
                    lists[j].push((i as u32, area));
                    pairs += 1;
                }
            }
        }
        assert!(pairs > 100 && pairs % 4 != 0, "{pairs} pairs");
        let mut regimes = [0; 4]; // stretched, no slip, stick, slip (source exponents)
        let law = PairLaw::new(&params);
        for (i, list) in lists.iter().enumerate() {
            for &(j, _) in list.iter().filter(|&&(j, _)| j as usize > i) {
                let (a, b) = (body(&cloud, i as u32), body(&cloud, j));
                let dist = (b.position - a.position).norm();
                let strain = (2.0 * r - dist) / (2.0 * r);
                let slip = (b.velocity - a.velocity).norm() + (b.spin - a.spin).norm();
                let area = super::super::pairs::contact_area(r, dist);
                let stick = law.contact.friction_stiffness * slip * area * 1e-4;
                let limit = law.contact.static_friction * law.stiffness * strain * strain * area;
                regimes[match (strain < 0.0, slip == 0.0, stick < 0.5 * limit) {
                    (true, _, _) => 0,
                    (_, true, _) => 1,
                    (_, _, true) => 2,
                    _ => 3,
                }] += 1;
            }
        }
        assert!(regimes.iter().all(|&k| k > 0), "regimes {regimes:?}");
        for (exponents, rotation) in [((2.0, 2.0), true), ((1.5, 1.7), false)] {
            params.contact.exponent = exponents.0;
            params.contact.bond_exponent = exponents.1;
            params.interactions.rotation = rotation;
            let law = PairLaw::new(&params);
            let mut index = indexed(&lists);
            index.evaluate_with(&law, &cloud, 1e-4, false);
            let scalar = index.wrenches.clone();
            index.evaluate_with(&law, &cloud, 1e-4, crate::numerics::has_avx());
            for (k, (a, b)) in scalar.iter().zip(&index.wrenches).enumerate() {
                assert_eq!(
                    (a.0.map(f64::to_bits), a.1.map(f64::to_bits)),
                    (b.0.map(f64::to_bits), b.1.map(f64::to_bits)),
                    "pair {k}: {:?}",
                    index.pairs[k]
                );
            }
        }
    }
}
