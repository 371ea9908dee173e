//! Exact sums over all pairs of N particles with each unordered pair evaluated once, shared by
//! the models' all-pairs kernels (the blast near field C8, the bed's exact sums B1/B4).
//!
//! The particles are cut into tiles of [`TILE`] in index order and each pair of tiles (I ≤ J)
//! is summed once for both sides (action = reaction). Within a tile pair a particle sums its
//! partners in [`LANES`] independent accumulators, so the loop vectorizes and the divisions
//! overlap; the lanes are then combined pairwise in a fixed order. Every tile pair writes its
//! own buffer and each particle combines its tiles' results in tile order, so the results are
//! bit-identical at any thread count. The model supplies the pair term ([`PairTerm`]), in a
//! portable form and, on x86-64, an AVX form with identical bits (the same operations in the
//! same order, none fused).
//!
//! Components 0..[`PairTerm::SUMS`] of a term are summed; the rest are running maxima (order
//! independent, all values ≥ 0, starting from 0).

use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Independent partial sums per particle (two AVX registers of f64, four SSE2 ones).
pub const LANES: usize = 8;

/// Particles per tile (a multiple of [`LANES`]): a tile pair's data and sums stay in the
/// first-level cache.
pub const TILE: usize = 64;

/// A model's pair term over the particles it holds in structure-of-arrays form.
pub trait PairTerm<const C: usize>: Sync {
    /// Components 0..SUMS are summed, SUMS..C are running maxima.
    const SUMS: usize;

    /// Number of particles.
    fn count(&self) -> usize;

    /// What the pair (i, j) adds to i's components and to j's; zero for a pair at distance 0
    /// (the diagonal tile pairs meet i = j).
    fn term(&self, i: usize, j: usize) -> ([f64; C], [f64; C]);

    /// [`PairTerm::term`] for i and the partners j, …, j + 3 (one per AVX lane): the same
    /// operations in the same order.
    ///
    /// # Safety
    /// Only where the processor has AVX; j + 4 ≤ [`PairTerm::count`].
    #[cfg(target_arch = "x86_64")]
    unsafe fn term_avx(&self, i: usize, j: usize) -> ([__m256d; C], [__m256d; C]);
}

/// Results of one tile pair (I ≤ J) of tiles of N particles, C components of type T: on I's
/// particles from J's and, for I < J, on J's from I's. A diagonal pair (one tile with itself)
/// fills the same way and only `on_first` is read.
#[derive(Debug, Clone)]
pub struct TilePair<T, const N: usize, const C: usize> {
    /// (I, J).
    pub tiles: (usize, usize),
    /// On I's particles, by component and slot.
    pub on_first: [[T; N]; C],
    /// On J's particles, by component and slot.
    pub on_second: [[T; N]; C],
}

/// Sizes `pairs` to every tile pair of `tiles` tiles, I ≤ J in row-major order (kept when
/// the count already matches: no allocation between evaluations).
pub fn size_tile_pairs<T: Copy + Default, const N: usize, const C: usize>(
    pairs: &mut Vec<TilePair<T, N, C>>,
    tiles: usize,
) {
    if pairs.len() != tiles * (tiles + 1) / 2 {
        *pairs = (0..tiles)
            .flat_map(|i| (i..tiles).map(move |j| (i, j)))
            .map(|tiles| TilePair {
                tiles,
                on_first: [[T::default(); N]; C],
                on_second: [[T::default(); N]; C],
            })
            .collect();
    }
}

/// The results of particle p (slot p mod N of tile p / N) in each tile pair, in tile order.
pub fn results_of<T: Copy, const N: usize, const C: usize>(
    pairs: &[TilePair<T, N, C>],
    tiles: usize,
    p: usize,
) -> impl Iterator<Item = [T; C]> + '_ {
    let (tile, slot) = (p / N, p % N);
    (0..tiles).map(move |other| {
        let side = if other < tile {
            &pairs[pair_index(tiles, other, tile)].on_second
        } else {
            &pairs[pair_index(tiles, tile, other)].on_first
        };
        std::array::from_fn(|c| side[c][slot])
    })
}

/// A tile pair of the double-precision kernel.
type Results<const C: usize> = TilePair<f64, TILE, C>;

/// The per-tile-pair buffers, reused between evaluations (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct TiledPairs<const C: usize> {
    pairs: Vec<Results<C>>,
    tiles: usize,
}

impl<const C: usize> TiledPairs<C> {
    /// Evaluates every pair of `kernel`'s particles once, on the rayon pool, with the AVX
    /// term where the processor has AVX.
    pub fn fill<K: PairTerm<C>>(&mut self, kernel: &K) {
        self.fill_with(kernel, super::has_avx());
    }

    /// [`TiledPairs::fill`] with the AVX term or the portable one (identical results).
    pub fn fill_with<K: PairTerm<C>>(&mut self, kernel: &K, avx: bool) {
        let n = kernel.count();
        self.tiles = n.div_ceil(TILE);
        size_tile_pairs(&mut self.pairs, self.tiles);
        self.pairs.par_iter_mut().for_each(|pair| {
            #[cfg(target_arch = "x86_64")]
            if avx {
                // SAFETY: `avx` is true only where the processor has AVX.
                return unsafe { tile_pair_avx(kernel, pair, n) };
            }
            #[cfg(not(target_arch = "x86_64"))]
            let _ = avx; // no AVX kernel off x86-64
            tile_pair(kernel, pair, n);
        });
    }

    /// Particle p's components over all its partners, its tiles' results combined in tile
    /// order (after [`TiledPairs::fill`]).
    pub fn gather<K: PairTerm<C>>(&self, p: usize) -> [f64; C] {
        let mut out = [0.0; C];
        for result in results_of(&self.pairs, self.tiles, p) {
            for c in 0..C {
                out[c] = combine::<K, C>(c, out[c], result[c]);
            }
        }
        out
    }
}

/// Component c of a running result and a new value: their sum, or their maximum.
#[inline(always)]
fn combine<K: PairTerm<C>, const C: usize>(c: usize, running: f64, new: f64) -> f64 {
    if c < K::SUMS {
        running + new
    } else if running > new {
        // the maximum as AVX `max_pd(running, new)` computes it
        running
    } else {
        new
    }
}

/// The particles of tile `t` of n, tiles of N.
pub fn tile<const N: usize>(t: usize, n: usize) -> std::ops::Range<usize> {
    t * N..((t + 1) * N).min(n)
}

/// Fills one tile pair: each particle a of the first tile combines its terms from the second
/// tile's particles b (lanes, then the tail); each b gathers its side in the same pass.
#[inline(always)]
fn tile_pair<K: PairTerm<C>, const C: usize>(kernel: &K, pair: &mut Results<C>, n: usize) {
    let (first, second) = (tile::<TILE>(pair.tiles.0, n), tile::<TILE>(pair.tiles.1, n));
    pair.on_second = [[0.0; TILE]; C];
    let body = second.len() - second.len() % LANES;
    for (a, i) in first.enumerate() {
        let mut acc = [[0.0; C]; LANES];
        for group in (0..body).step_by(LANES) {
            for (l, lane) in acc.iter_mut().enumerate() {
                let b = group + l;
                let (on_i, on_j) = kernel.term(i, second.start + b);
                for c in 0..C {
                    lane[c] = combine::<K, C>(c, lane[c], on_i[c]);
                    pair.on_second[c][b] = combine::<K, C>(c, pair.on_second[c][b], on_j[c]);
                }
            }
        }
        let lanes = std::array::from_fn(|c| reduce_lanes::<K, C>(c, acc.map(|lane| lane[c])));
        finish(kernel, pair, (a, i), second.clone(), body, lanes);
    }
}

/// Particle i's (slot a of the first tile) results: its reduced lanes plus the partners after
/// the last full group of lanes, scalar.
#[inline(always)]
fn finish<K: PairTerm<C>, const C: usize>(
    kernel: &K,
    pair: &mut Results<C>,
    (a, i): (usize, usize),
    second: std::ops::Range<usize>,
    body: usize,
    mut own: [f64; C],
) {
    for b in body..second.len() {
        let (on_i, on_j) = kernel.term(i, second.start + b);
        for c in 0..C {
            own[c] = combine::<K, C>(c, own[c], on_i[c]);
            pair.on_second[c][b] = combine::<K, C>(c, pair.on_second[c][b], on_j[c]);
        }
    }
    for (side, value) in pair.on_first.iter_mut().zip(own) {
        side[a] = value;
    }
}

/// [`tile_pair`] with the AVX term: the same operations in the same order, lanes 0–3 and 4–7
/// of each group.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn tile_pair_avx<K: PairTerm<C>, const C: usize>(
    kernel: &K,
    pair: &mut Results<C>,
    n: usize,
) {
    let (first, second) = (tile::<TILE>(pair.tiles.0, n), tile::<TILE>(pair.tiles.1, n));
    pair.on_second = [[0.0; TILE]; C];
    let body = second.len() - second.len() % LANES;
    for (a, i) in first.enumerate() {
        let mut acc = [[_mm256_setzero_pd(); 2]; C];
        for group in (0..body).step_by(LANES) {
            for (half, b) in [group, group + 4].into_iter().enumerate() {
                // SAFETY: the caller has AVX; b + 4 ≤ body ≤ the tile's length.
                let (on_i, on_j) = unsafe { kernel.term_avx(i, second.start + b) };
                for c in 0..C {
                    acc[c][half] = combine_avx::<K, C>(c, acc[c][half], on_i[c]);
                    let slot = &mut pair.on_second[c][b..b + 4];
                    // SAFETY: `slot` holds 4 f64.
                    unsafe {
                        let running = _mm256_loadu_pd(slot.as_ptr());
                        _mm256_storeu_pd(
                            slot.as_mut_ptr(),
                            combine_avx::<K, C>(c, running, on_j[c]),
                        );
                    }
                }
            }
        }
        let lanes = std::array::from_fn(|c| {
            let mut lanes = [0.0; LANES];
            // SAFETY: `lanes` holds 8 f64.
            unsafe {
                _mm256_storeu_pd(lanes.as_mut_ptr(), acc[c][0]);
                _mm256_storeu_pd(lanes[4..].as_mut_ptr(), acc[c][1]);
            }
            reduce_lanes::<K, C>(c, lanes)
        });
        finish(kernel, pair, (a, i), second.clone(), body, lanes);
    }
}

/// [`combine`] on four lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn combine_avx<K: PairTerm<C>, const C: usize>(
    c: usize,
    running: __m256d,
    new: __m256d,
) -> __m256d {
    if c < K::SUMS {
        _mm256_add_pd(running, new)
    } else {
        _mm256_max_pd(running, new)
    }
}

/// −v exactly on four lanes (the sign bit flipped, as the scalar negation does).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub fn negate(v: __m256d) -> __m256d {
    _mm256_xor_pd(v, _mm256_set1_pd(-0.0))
}

/// ((a0 ∘ a1) ∘ (a2 ∘ a3)) ∘ ((a4 ∘ a5) ∘ (a6 ∘ a7)) with ∘ the component's combination: the
/// lanes' partial results, in a fixed order.
fn reduce_lanes<K: PairTerm<C>, const C: usize>(c: usize, mut a: [f64; LANES]) -> f64 {
    let mut width = LANES;
    while width > 1 {
        width /= 2;
        for k in 0..width {
            a[k] = combine::<K, C>(c, a[2 * k], a[2 * k + 1]);
        }
    }
    a[0]
}

/// Index of the tile pair (i, j), i ≤ j, among the pairs of `tiles` tiles in row-major order
/// (row k holds tiles − k pairs).
fn pair_index(tiles: usize, i: usize, j: usize) -> usize {
    i * tiles - i * i.saturating_sub(1) / 2 + (j - i)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a line with the term (1/r, 1/r for j; the nearest 1/r as a maximum).
    struct Inverse(Vec<f64>);

    impl PairTerm<2> for Inverse {
        const SUMS: usize = 1;
        fn count(&self) -> usize {
            self.0.len()
        }
        fn term(&self, i: usize, j: usize) -> ([f64; 2], [f64; 2]) {
            let r = (self.0[j] - self.0[i]).abs();
            let inv = if r > 0.0 { 1.0 / r } else { 0.0 };
            ([inv, inv], [inv, inv])
        }
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx")]
        unsafe fn term_avx(&self, i: usize, j: usize) -> ([__m256d; 2], [__m256d; 2]) {
            let terms: [f64; 4] = std::array::from_fn(|k| self.term(i, j + k).0[0]);
            // SAFETY: `terms` holds 4 f64.
            let v = unsafe { _mm256_loadu_pd(terms.as_ptr()) };
            ([v; 2], [v; 2])
        }
    }

    /// Every particle's sum and maximum over all others, for one partial tile and several
    /// tiles, equal the direct ones; the index of a tile pair matches the enumeration.
    #[test]
    fn sums_and_maxima_cover_every_pair_once() {
        for n in [5, 64, 203] {
            let points = Inverse((0..n).map(|k| (k as f64 * 0.37).sin() + k as f64).collect());
            for avx in [false, true] {
                let mut tiled = TiledPairs::<2>::default();
                tiled.fill_with(&points, avx && crate::numerics::has_avx());
                for i in 0..n {
                    let others = (0..n).filter(|&j| j != i).map(|j| points.term(i, j).0[0]);
                    let sum: f64 = others.clone().sum();
                    let [got, largest] = tiled.gather::<Inverse>(i);
                    assert!((got - sum).abs() <= 1e-12 * sum, "{n} {i}");
                    assert_eq!(largest, others.fold(0.0, f64::max), "{n} {i}");
                }
            }
        }
        let tiles = 5;
        let rows = (0..tiles).flat_map(|i| (i..tiles).map(move |j| (i, j)));
        for (k, (i, j)) in rows.enumerate() {
            assert_eq!(pair_index(tiles, i, j), k);
        }
    }
}
