//! Each bonded pair's wrench (C4–C7) computed once per force evaluation and given to both
//! partners. After the cloud collapses a particle holds some 35 bonds, so evaluating every
//! bond from both sides doubled the model's largest cost after the near field.
//!
//! Why the partner's share is exact: swapping i and j negates the separation, and with it the
//! normal, the relative velocities and the tangential slip, exactly (IEEE negation commutes
//! with every rounding used), so `PairLaw::contact` gives j exactly −F and the same moment
//! (lever·(−n)) × (−t) = (lever·n) × t. Each particle then adds its bonds' shares in its
//! list's ascending order, the order of the per-particle evaluation this replaces, so the
//! forces keep their bits.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::cloud::Cloud;
use super::pairs::{Body, PairLaw, Wrench};

/// Pairs per rayon task.
const CHUNK: usize = 256;

/// The bonded pairs once each (i < j), where each particle's bonds find them, and their
/// wrenches at the last evaluation.
#[derive(Debug, Clone, Default)]
pub struct BondIndex {
    /// (i, j, contact area at bonding in m²), i < j, in the order of i's ascending list.
    pairs: Vec<(u32, u32, f64)>,
    /// For each particle, the pair index of each entry of its bond list.
    pair_of: Vec<Vec<u32>>,
    /// Wrench on the pair's first particle, N and N·m.
    wrenches: Vec<Wrench>,
}

impl BondIndex {
    /// Re-indexes the bond lists (each ascending, j in i's list iff i in j's).
    pub fn index(&mut self, lists: &[Vec<(u32, f64)>]) {
        self.pairs.clear();
        self.pair_of.resize(lists.len(), Vec::new());
        for (slots, list) in self.pair_of.iter_mut().zip(lists) {
            slots.clear();
            slots.resize(list.len(), u32::MAX);
        }
        for (i, list) in lists.iter().enumerate() {
            for (k, &(j, area)) in list.iter().enumerate() {
                if (j as usize) < i {
                    continue;
                }
                let pair = self.pairs.len() as u32;
                self.pairs.push((i as u32, j, area));
                self.pair_of[i][k] = pair;
                let back = lists[j as usize]
                    .binary_search_by_key(&(i as u32), |&(b, _)| b)
                    .expect("bond lists are symmetric");
                self.pair_of[j as usize][back] = pair;
            }
        }
        self.wrenches
            .resize(self.pairs.len(), (Vector3::zeros(), Vector3::zeros()));
    }

    /// Every bonded pair's wrench on its first particle at the state `cloud`.
    pub fn evaluate(&mut self, law: &PairLaw, cloud: &Cloud, dt: f64) {
        let body = |k: u32| Body {
            position: cloud.positions[k as usize],
            velocity: cloud.velocities[k as usize],
            spin: cloud.spins[k as usize],
        };
        self.wrenches
            .par_iter_mut()
            .zip(self.pairs.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(w, &(i, j, area))| *w = law.contact(&body(i), &body(j), Some(area), dt));
    }

    /// The wrench on particle i from the bond at entry k of its list, whose partner is j.
    #[inline]
    pub fn on(&self, i: usize, k: usize, j: u32) -> Wrench {
        let (force, moment) = self.wrenches[self.pair_of[i][k] as usize];
        if (j as usize) > i {
            (force, moment)
        } else {
            (-force, moment)
        }
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
        let mut index = BondIndex::default();
        index.index(&lists);
        assert_eq!(index.pairs.len(), 4);
        index.evaluate(&law, &cloud, 1e-4);
        for (i, list) in lists.iter().enumerate() {
            for (k, &(j, a)) in list.iter().enumerate() {
                let body = |p: usize| Body {
                    position: cloud.positions[p],
                    velocity: cloud.velocities[p],
                    spin: cloud.spins[p],
                };
                let own = law.contact(&body(i), &body(j as usize), Some(a), 1e-4);
                assert_ne!(own.0, Vector3::zeros(), "{i}–{j} acts");
                assert_eq!(index.on(i, k, j), own, "{i}–{j}");
            }
        }
    }
}
