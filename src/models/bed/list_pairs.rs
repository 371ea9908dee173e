//! The geometric part of a neighbour list's pair terms (separation, 1/r², 1/r³), evaluated
//! once per unordered pair: a full list holds every pair twice, and the division and square
//! root of a pair are the costly part of its term. Each disk then gathers its partners in its
//! own list order from these shared terms, so the sums are the ones a gather evaluating
//! every pair itself would give, bit for bit (the separation seen from the other disk is the
//! exact negative, fl(a − b) = −fl(b − a)), at any thread count.

use nalgebra::Vector2;
use rayon::prelude::*;

use crate::neighbor::NeighborList;

/// Pairs per batch: the divisions and square roots of a batch are independent and vectorize.
const LANES: usize = 8;

/// From this many pairs on, the terms are evaluated on the rayon pool, in chunks of `CHUNK`.
const PARALLEL_FROM: usize = 4096;
const CHUNK: usize = 512;

/// The geometry of one pair (i < j) inside the distance range, zero outside it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Separation {
    /// d = r_i − r_j, m.
    pub(super) d: Vector2<f64>,
    /// 1/r², 1/m² (0 outside the range).
    pub(super) inv_r2: f64,
    /// 1/r³, 1/m³ (0 outside the range).
    pub(super) inv_r3: f64,
}

/// The unordered pairs of one neighbour list and their terms, reindexed at each list build.
#[derive(Debug, Clone, Default)]
pub(super) struct HalfList {
    /// The list build the indices below belong to (0: none yet).
    build: usize,
    /// (i, j), i < j, in list order of i.
    pairs: Vec<(u32, u32)>,
    /// For every list entry (disk i, partner j) in list order: its pair's index in `pairs`.
    slot: Vec<u32>,
    /// Index in `slot` of each disk's first entry.
    row: Vec<usize>,
    terms: Vec<Separation>,
}

impl HalfList {
    /// Evaluates every pair of `list` at these positions, m, counting pairs at squared
    /// distances in [inner2, cutoff2) (the others get zero inverse powers).
    pub(super) fn evaluate(
        &mut self,
        list: &NeighborList<2>,
        position: &[Vector2<f64>],
        range: (f64, f64),
    ) {
        if self.build != list.builds() {
            self.index(list, position.len());
        }
        let terms = &mut self.terms;
        terms.resize(self.pairs.len(), Separation::default());
        if self.pairs.len() >= PARALLEL_FROM {
            terms
                .par_chunks_mut(CHUNK)
                .zip(self.pairs.par_chunks(CHUNK))
                .for_each(|(terms, pairs)| separations(terms, pairs, position, range));
        } else {
            separations(terms, &self.pairs, position, range);
        }
    }

    /// Disk i's partners in its list order, with the pair's separation as seen from i.
    pub(super) fn of<'a>(
        &'a self,
        list: &'a NeighborList<2>,
        i: usize,
    ) -> impl Iterator<Item = (usize, Separation)> + 'a {
        let row = list.of(i);
        let slots = &self.slot[self.row[i]..self.row[i] + row.len()];
        row.iter().zip(slots).map(move |(&j, &s)| {
            let t = self.terms[s as usize];
            let j = j as usize;
            let d = if j > i { t.d } else { -t.d };
            (j, Separation { d, ..t })
        })
    }

    /// The pairs of a newly built list and every entry's pair, in one pass: disk i's entries
    /// below it (partners j < i) come in ascending j, the order in which the disks j reach
    /// their pair with i, so each row fills its lower part from a cursor.
    fn index(&mut self, list: &NeighborList<2>, n: usize) {
        self.pairs.clear();
        self.row.clear();
        let mut start = 0;
        for i in 0..n {
            self.row.push(start);
            start += list.of(i).len();
        }
        self.slot.clear();
        self.slot.resize(start, 0);
        let mut below = vec![0; n];
        for i in 0..n {
            let row = list.of(i);
            let above = row.partition_point(|&j| (j as usize) <= i);
            for (k, &j) in row.iter().enumerate().skip(above) {
                let (pair, j) = (self.pairs.len() as u32, j as usize);
                self.pairs.push((i as u32, j as u32));
                self.slot[self.row[i] + k] = pair;
                self.slot[self.row[j] + below[j]] = pair;
                below[j] += 1;
            }
            debug_assert_eq!(
                below[i], above,
                "a neighbour list holds every pair in both rows"
            );
        }
        self.build = list.builds();
    }
}

/// The separations of `pairs` into `terms`, in batches of `LANES` pairs. The arithmetic is
/// the per-disk gather's (the range is a 0/1 weight, not a branch: a list holds many pairs
/// beyond r_c in no predictable order).
fn separations(
    terms: &mut [Separation],
    pairs: &[(u32, u32)],
    position: &[Vector2<f64>],
    (inner2, cutoff2): (f64, f64),
) {
    for (terms, pairs) in terms.chunks_mut(LANES).zip(pairs.chunks(LANES)) {
        let (mut r2, mut weight) = ([1.0; LANES], [0.0; LANES]);
        for (k, (t, &(i, j))) in terms.iter_mut().zip(pairs).enumerate() {
            t.d = position[i as usize] - position[j as usize];
            r2[k] = t.d.x * t.d.x + t.d.y * t.d.y;
            weight[k] = if r2[k] >= inner2 && r2[k] < cutoff2 {
                1.0
            } else {
                0.0
            };
        }
        let (mut inv_r2, mut inv_r3) = ([0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            inv_r2[k] = weight[k] / r2[k];
            inv_r3[k] = inv_r2[k] * inv_r2[k].sqrt();
        }
        for (k, t) in terms.iter_mut().enumerate() {
            (t.inv_r2, t.inv_r3) = (inv_r2[k], inv_r3[k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every disk's partners come in its list order with the separation, 1/r² and 1/r³ it
    /// would compute itself, bit for bit, inside the range and zero outside, also after the
    /// list is rebuilt with other pairs.
    #[test]
    fn each_disk_sees_its_own_pair_terms_in_list_order() {
        let mut list = NeighborList::<2>::new(0.0);
        let mut half = HalfList::default();
        for (n, spread) in [(150, 1.0), (90, 0.6)] {
            let position: Vec<_> = (0..n)
                .map(|k| {
                    let t = k as f64;
                    Vector2::new(spread * (1.3 * t).sin() * t.sqrt(), (0.7 * t).cos() * 5.0)
                })
                .collect();
            list.build(&position, &vec![1.0; n]);
            let range = (0.09, 2.25);
            half.evaluate(&list, &position, range);
            for i in 0..n {
                let seen: Vec<_> = half.of(&list, i).collect();
                assert_eq!(seen.len(), list.of(i).len());
                for ((j, s), &listed) in seen.into_iter().zip(list.of(i)) {
                    assert_eq!(j, listed as usize);
                    let d = position[i] - position[j];
                    let r2 = d.x * d.x + d.y * d.y;
                    let inside = r2 >= range.0 && r2 < range.1;
                    let inv_r2 = if inside { 1.0 / r2 } else { 0.0 };
                    let bits = |v: Vector2<f64>, a: f64, b: f64| [v.x, v.y, a, b].map(f64::to_bits);
                    assert_eq!(
                        bits(s.d, s.inv_r2, s.inv_r3),
                        bits(d, inv_r2, inv_r2 * inv_r2.sqrt()),
                        "{n}: {i}–{j}"
                    );
                }
            }
        }
    }
}
