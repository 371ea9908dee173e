//! The geometric part of a neighbour list's pair terms (separation, 1/r², 1/r³), evaluated
//! once per unordered pair: a full list holds every pair twice, and the division and square
//! root of a pair are the costly part of its term. Each disk then gathers its partners in its
//! own list order from these shared terms, so the sums are the ones a gather evaluating
//! every pair itself would give, bit for bit (the separation seen from the other disk is the
//! exact negative, fl(a − b) = −fl(b − a)), at any thread count.

use std::ops::Range;

use nalgebra::Vector2;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use crate::neighbor::NeighborList;
use crate::numerics::has_avx;

/// Pairs per batch of the portable kernel: the divisions and square roots of a batch are
/// independent and overlap (the compiler keeps them scalar, hence the AVX kernel).
const LANES: usize = 8;

/// From this many pairs on, the terms are evaluated on the rayon pool, in chunks of `CHUNK`.
const PARALLEL_FROM: usize = 4096;
const CHUNK: usize = 512;

/// The geometry of one pair (i < j) inside the distance range, zero outside it.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
pub(super) struct Separation {
    /// d = r_i − r_j, m.
    pub(super) d: Vector2<f64>,
    /// 1/r², 1/m² (0 outside the range).
    pub(super) inv_r2: f64,
    /// 1/r³, 1/m³ (0 outside the range).
    pub(super) inv_r3: f64,
}

/// The unordered pairs of one neighbour list and their terms, reindexed at each list build.
/// A list row is sorted: a disk's partners below it, then those above it. The pairs (i, j)
/// with j above i are numbered consecutively in i's list order, so i reads their terms in
/// sequence; its partners below it find theirs through `below`.
#[derive(Debug, Clone, Default)]
pub(super) struct HalfList {
    /// The list build the indices below belong to (0: none yet).
    build: usize,
    /// (i, j), i < j, in list order of i.
    pairs: Vec<(u32, u32)>,
    /// Index in `pairs` of each disk's first pair with a partner above it (N + 1 entries).
    first_pair: Vec<usize>,
    /// For every list entry (disk i, partner j < i) in list order: its pair's index in `pairs`.
    below: Vec<u32>,
    /// Index in `below` of each disk's first entry (N + 1 entries).
    below_row: Vec<usize>,
    terms: Vec<Separation>,
}

/// One disk's list entries, below it and above it (see [`HalfList::row`]).
pub(super) struct Row<'a> {
    /// Partners j < i, ascending.
    pub(super) below: &'a [u32],
    /// Each of their pairs' index in `terms`.
    pub(super) slots: &'a [u32],
    /// Every pair's terms (as seen from the disk with the lower index).
    pub(super) terms: &'a [Separation],
    /// Partners j > i, ascending.
    pub(super) above: &'a [u32],
    /// Their pairs' terms, in the same order.
    pub(super) above_terms: &'a [Separation],
}

impl Row<'_> {
    /// The entries in list order, with the separation as seen from the disk (portable form).
    pub(super) fn entries(&self) -> impl Iterator<Item = (usize, Separation)> + '_ {
        let below = self.below.iter().zip(self.slots).map(|(&j, &s)| {
            let t = self.terms[s as usize];
            (j as usize, Separation { d: -t.d, ..t })
        });
        let above = self.above.iter().zip(self.above_terms);
        below.chain(above.map(|(&j, &t)| (j as usize, t)))
    }
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
        if self.build == list.builds() {
            evaluate_terms(&mut self.terms, &self.pairs, position, range);
            return;
        }
        self.index_pairs(list, position.len());
        // The entries' slots are filled in one serial pass; the terms, which need only the
        // pairs, are evaluated on the pool meanwhile.
        let (below, terms) = (&mut self.below, &mut self.terms);
        let mut index = || index_below(below, &self.below_row, &self.first_pair, list);
        let mut evaluate = || evaluate_terms(terms, &self.pairs, position, range);
        if self.pairs.len() >= PARALLEL_FROM {
            rayon::join(index, evaluate);
        } else {
            index();
            evaluate();
        }
        self.build = list.builds();
    }

    /// Disk i's list entries: its partners below it with their pairs' slots, then those
    /// above it with their terms in order.
    pub(super) fn row<'a>(&'a self, list: &'a NeighborList<2>, i: usize) -> Row<'a> {
        let slots = &self.below[self.below_row[i]..self.below_row[i + 1]];
        let (below, above) = list.of(i).split_at(slots.len());
        Row {
            below,
            slots,
            terms: &self.terms,
            above,
            above_terms: &self.terms[self.first_pair[i]..self.first_pair[i + 1]],
        }
    }

    /// The pairs (i, j > i) of a newly built list, in each disk's list order, and where
    /// each disk's pairs and lower entries begin (the rows are split and the pairs written
    /// on the pool for long lists).
    fn index_pairs(&mut self, list: &NeighborList<2>, n: usize) {
        // each row's count of lower entries into below_row[i + 1], then the running sums
        let count = |(i, below): (usize, &mut usize)| {
            *below = list.of(i).partition_point(|&j| (j as usize) < i);
        };
        let parallel = list.len() >= 2 * PARALLEL_FROM;
        self.below_row.resize(n + 1, 0);
        self.below_row[0] = 0;
        if parallel {
            self.below_row[1..]
                .par_iter_mut()
                .enumerate()
                .for_each(count);
        } else {
            self.below_row[1..].iter_mut().enumerate().for_each(count);
        }
        self.first_pair.clear();
        self.first_pair.push(0);
        for i in 0..n {
            let below = self.below_row[i + 1];
            self.below_row[i + 1] += self.below_row[i];
            self.first_pair
                .push(self.first_pair[i] + list.of(i).len() - below);
        }
        self.pairs.resize(self.first_pair[n], (0, 0));
        let below_row = &self.below_row;
        let fill = |(disks, pairs): (Range<usize>, &mut [(u32, u32)])| {
            let rows = disks.flat_map(|i| {
                let lower = below_row[i + 1] - below_row[i];
                list.of(i)[lower..].iter().map(move |&j| (i as u32, j))
            });
            pairs
                .iter_mut()
                .zip(rows)
                .for_each(|(slot, pair)| *slot = pair);
        };
        let blocks = split_rows(&mut self.pairs, &self.first_pair, CHUNK);
        if parallel {
            blocks.into_par_iter().for_each(fill);
        } else {
            blocks.into_iter().for_each(fill);
        }
    }
}

/// `items` split into the parts of consecutive rows, `rows` rows a part, where row i holds
/// `items[start[i]..start[i + 1]]`.
fn split_rows<'a, T>(
    mut items: &'a mut [T],
    start: &[usize],
    rows: usize,
) -> Vec<(Range<usize>, &'a mut [T])> {
    let n = start.len() - 1;
    (0..n)
        .step_by(rows)
        .map(|first| {
            let last = (first + rows).min(n);
            let (part, rest) = std::mem::take(&mut items).split_at_mut(start[last] - start[first]);
            items = rest;
            (first..last, part)
        })
        .collect()
}

/// Every list entry's pair: disk i's entries below it (partners j < i) come in ascending j,
/// the order in which the disks j reach their pair with i, so each row fills its lower part
/// from a cursor.
fn index_below(
    below: &mut Vec<u32>,
    below_row: &[usize],
    first_pair: &[usize],
    list: &NeighborList<2>,
) {
    let n = below_row.len() - 1;
    below.clear();
    below.resize(below_row[n], 0);
    let mut cursor = below_row[..n].to_vec();
    for i in 0..n {
        debug_assert_eq!(
            cursor[i],
            below_row[i + 1],
            "a neighbour list holds every pair in both rows"
        );
        let above = &list.of(i)[below_row[i + 1] - below_row[i]..];
        for (pair, &j) in (first_pair[i]..).zip(above) {
            below[cursor[j as usize]] = pair as u32;
            cursor[j as usize] += 1;
        }
    }
}

/// The terms of `pairs` at these positions (on the pool for long lists).
fn evaluate_terms(
    terms: &mut Vec<Separation>,
    pairs: &[(u32, u32)],
    position: &[Vector2<f64>],
    range: (f64, f64),
) {
    terms.resize(pairs.len(), Separation::default());
    if pairs.len() >= PARALLEL_FROM {
        terms
            .par_chunks_mut(CHUNK)
            .zip(pairs.par_chunks(CHUNK))
            .for_each(|(terms, pairs)| separations(terms, pairs, position, range));
    } else {
        separations(terms, pairs, position, range);
    }
}

/// The separations of `pairs` into `terms`, with AVX where the processor has it (identical
/// results: see [`separations_with`]).
fn separations(
    terms: &mut [Separation],
    pairs: &[(u32, u32)],
    position: &[Vector2<f64>],
    range: (f64, f64),
) {
    separations_with(terms, pairs, position, range, has_avx());
}

/// [`separations`] with the AVX kernel (four pairs per instruction) or the portable one. The
/// AVX kernel does each pair's operations in the same order, none fused, and IEEE division
/// and square root round the same in every lane, so the terms are the same bits; it leaves
/// the last pairs (fewer than four) to the portable kernel.
fn separations_with(
    terms: &mut [Separation],
    pairs: &[(u32, u32)],
    position: &[Vector2<f64>],
    range: (f64, f64),
    avx: bool,
) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if avx {
        done = pairs.len() - pairs.len() % 4;
        // SAFETY: the caller found AVX; `pairs` index into `position` (list entries).
        unsafe { separations_avx(&mut terms[..done], &pairs[..done], position, range) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = avx;
    separations_portable(&mut terms[done..], &pairs[done..], position, range);
}

/// The portable kernel, in batches of `LANES` pairs. The range is a 0/1 weight, not a branch:
/// a list holds many pairs beyond r_c in no predictable order.
fn separations_portable(
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

/// The AVX kernel: pairs in fours (`pairs.len()` a multiple of 4), one lane each, written
/// out whole (closures and lane arrays here spilled to the stack and cost more than the
/// scalar kernel). The portable kernel's divisions and square roots compile to scalar
/// instructions; here four share one.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn separations_avx(
    terms: &mut [Separation],
    pairs: &[(u32, u32)],
    position: &[Vector2<f64>],
    (inner2, cutoff2): (f64, f64),
) {
    let (inner2, cutoff2) = (_mm256_set1_pd(inner2), _mm256_set1_pd(cutoff2));
    let one = _mm256_set1_pd(1.0);
    // SAFETY (loads): a Vector2<f64> is two contiguous f64.
    let at = |k: u32| unsafe { _mm_loadu_pd(position[k as usize].as_ptr()) };
    for (terms, pairs) in terms.chunks_exact_mut(4).zip(pairs.chunks_exact(4)) {
        let d = |k: usize| _mm_sub_pd(at(pairs[k].0), at(pairs[k].1));
        // (dx, dy) of pairs 0 and 2, and of pairs 1 and 3
        let (even, odd) = (_mm256_set_m128d(d(2), d(0)), _mm256_set_m128d(d(3), d(1)));
        let (dx, dy) = (_mm256_unpacklo_pd(even, odd), _mm256_unpackhi_pd(even, odd));
        let r2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
        let inside = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(r2, inner2),
            _mm256_cmp_pd::<_CMP_LT_OQ>(r2, cutoff2),
        );
        let inv_r2 = _mm256_div_pd(_mm256_and_pd(one, inside), r2);
        let inv_r3 = _mm256_mul_pd(inv_r2, _mm256_sqrt_pd(inv_r2));
        // (1/r², 1/r³) of pairs 0 and 2, and of pairs 1 and 3
        let (powers_even, powers_odd) = (
            _mm256_unpacklo_pd(inv_r2, inv_r3),
            _mm256_unpackhi_pd(inv_r2, inv_r3),
        );
        let rows = [
            _mm256_permute2f128_pd::<0x20>(even, powers_even),
            _mm256_permute2f128_pd::<0x20>(odd, powers_odd),
            _mm256_permute2f128_pd::<0x31>(even, powers_even),
            _mm256_permute2f128_pd::<0x31>(odd, powers_odd),
        ];
        for (t, row) in terms.iter_mut().zip(rows) {
            // SAFETY: a Separation is four f64 in this order (repr(C)).
            unsafe { _mm256_storeu_pd((t as *mut Separation).cast::<f64>(), row) };
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
                let seen: Vec<_> = half.row(&list, i).entries().collect();
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

    /// Where the processor has AVX, its kernel gives the portable kernel's bits for every
    /// pair, inside the range, outside it and on its bounds, with a count of pairs that
    /// leaves a remainder for the portable tail.
    #[test]
    fn avx_and_portable_separations_are_identical() {
        let position: Vec<_> = (0..61)
            .map(|k| {
                let t = k as f64;
                Vector2::new((1.7 * t).sin() * 3.0, (0.3 * t).cos() * 2.0 + 0.01 * t)
            })
            .collect();
        let mut pairs: Vec<(u32, u32)> = (0..61u32)
            .flat_map(|i| (i + 1..61).map(move |j| (i, j)))
            .collect();
        pairs.truncate(pairs.len() - 3);
        let d = position[0] - position[1];
        let on_bound = d.x * d.x + d.y * d.y;
        for range in [(0.09, 2.25), (on_bound, 2.0 * on_bound), (0.5, on_bound)] {
            let bits = |avx: bool| {
                let mut terms = vec![Separation::default(); pairs.len()];
                separations_with(&mut terms, &pairs, &position, range, avx);
                terms
                    .iter()
                    .map(|t| [t.d.x, t.d.y, t.inv_r2, t.inv_r3].map(f64::to_bits))
                    .collect::<Vec<_>>()
            };
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                assert_eq!(bits(true), bits(false), "{range:?}");
            }
            assert!(bits(false).iter().any(|t| t[2] != 0) && bits(false).iter().any(|t| t[2] == 0));
        }
    }
}
