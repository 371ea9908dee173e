//! The exact near-field sum over all pairs (C8), the cost that dominates the interacting
//! model at the source's density (N = 2000: 2·10⁶ pairs per force evaluation).
//!
//! Why a kernel of its own: the per-pair form in [`PairLaw::near_field`] walks nalgebra
//! vectors one partner at a time, a dependent chain of a square root and a division per
//! pair. Here the positions are copied once per evaluation into coordinate arrays, cut into
//! tiles of [`TILE`] particles, and each pair of tiles is summed once for both sides
//! (action = reaction: every unordered pair is evaluated once). Within a tile pair a particle
//! sums its partners in [`LANES`] independent accumulators, so the loop vectorizes and the
//! divisions overlap. Every tile pair writes its own buffer and each particle adds its tiles'
//! sums in tile order, so the forces are bit-identical at any thread count.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::pairs::PairLaw;

/// Independent partial sums per particle (two AVX registers of f64, four SSE2 ones).
const LANES: usize = 8;

/// Particles per tile (a multiple of [`LANES`]): a tile pair's coordinates and sums stay in
/// the first-level cache.
const TILE: usize = 64;

/// Sums of one tile pair (I ≤ J): on I's particles from J's and, for I < J, on J's from I's
/// (components x, y, z); each without its own particle's sign c_p.
#[derive(Debug, Clone)]
struct TilePair {
    tiles: (usize, usize),
    on_first: [[f64; TILE]; 3],
    on_second: [[f64; TILE]; 3],
}

/// Coordinates and charge signs in structure-of-arrays form.
#[derive(Debug, Clone, Default)]
struct Coordinates {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// c_i: −1 for a negative charge when the law carries the sign factor, else 1.
    sign: Vec<f64>,
}

/// The kernel's buffers, reused between evaluations (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct AllPairs {
    at: Coordinates,
    pairs: Vec<TilePair>,
}

impl AllPairs {
    /// Near-field force on every particle from all others, written into `out`, N. Only for
    /// the source's exponents β = (1, 2) (see [`AllPairs::applies`]).
    pub fn sum(
        &mut self,
        law: &PairLaw,
        positions: &[Vector3<f64>],
        charge_per_mass: &[f64],
        out: &mut [Vector3<f64>],
    ) {
        #[cfg(target_arch = "x86_64")]
        let avx = std::arch::is_x86_feature_detected!("avx");
        #[cfg(not(target_arch = "x86_64"))]
        let avx = false;
        self.sum_with(law, positions, charge_per_mass, out, avx);
    }

    /// Whether the kernel covers `law`: the fast path is written for β = (1, 2) only.
    pub fn applies(law: &PairLaw) -> bool {
        law.beta == (1.0, 2.0)
    }

    /// [`AllPairs::sum`] with the AVX tile kernel or the portable one (identical results:
    /// the same operations in the same order, none fused).
    fn sum_with(
        &mut self,
        law: &PairLaw,
        positions: &[Vector3<f64>],
        charge_per_mass: &[f64],
        out: &mut [Vector3<f64>],
        avx: bool,
    ) {
        self.at.load(law, positions, charge_per_mass);
        let tiles = positions.len().div_ceil(TILE);
        if self.pairs.len() != tiles * (tiles + 1) / 2 {
            self.pairs = (0..tiles)
                .flat_map(|i| (i..tiles).map(move |j| (i, j)))
                .map(|tiles| TilePair {
                    tiles,
                    on_first: [[0.0; TILE]; 3],
                    on_second: [[0.0; TILE]; 3],
                })
                .collect();
        }
        let (at, alpha) = (&self.at, law.alpha);
        self.pairs
            .par_iter_mut()
            .for_each(|pair| at.fill(pair, alpha, avx));
        let pairs = &self.pairs;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(TILE)
            .for_each(|(p, f)| *f = self.at.sign[p] * gather(pairs, tiles, p));
    }
}

impl Coordinates {
    /// One tile pair's sums, with the AVX kernel where `avx` says the processor has it.
    fn fill(&self, pair: &mut TilePair, alpha: (f64, f64), avx: bool) {
        #[cfg(target_arch = "x86_64")]
        if avx {
            // SAFETY: `avx` is true only where the processor has AVX.
            return unsafe { self.tile_pair_avx(pair, alpha) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = avx; // no AVX kernel off x86-64
        self.tile_pair(pair, alpha);
    }

    fn load(&mut self, law: &PairLaw, positions: &[Vector3<f64>], charge_per_mass: &[f64]) {
        let n = positions.len();
        for v in [&mut self.x, &mut self.y, &mut self.z, &mut self.sign] {
            v.resize(n, 0.0);
        }
        for (k, p) in positions.iter().enumerate() {
            (self.x[k], self.y[k], self.z[k]) = (p.x, p.y, p.z);
        }
        for (s, &q) in self.sign.iter_mut().zip(charge_per_mass) {
            *s = if law.charge_sign && q < 0.0 {
                -1.0
            } else {
                1.0
            };
        }
    }

    /// The particles of tile `t`.
    fn tile(&self, t: usize) -> std::ops::Range<usize> {
        t * TILE..((t + 1) * TILE).min(self.x.len())
    }

    /// Fills the sums of one tile pair: each particle a of the first tile sums c_b f(r_b − r_a)
    /// over the second tile's particles b (lanes, then the tail); each b gathers −c_a f in
    /// the same pass. A diagonal pair (one tile with itself) fills the same way, and only its
    /// `on_first` is read (the a = b term is zero).
    #[inline(always)]
    fn tile_pair(&self, pair: &mut TilePair, alpha: (f64, f64)) {
        let (first, second) = (self.tile(pair.tiles.0), self.tile(pair.tiles.1));
        pair.on_second = [[0.0; TILE]; 3];
        let body = second.len() - second.len() % LANES;
        for (a, i) in first.enumerate() {
            let mut acc = [[0.0; LANES]; 3];
            for group in (0..body).step_by(LANES) {
                for l in 0..LANES {
                    let b = group + l;
                    self.mutual(
                        i,
                        second.start + b,
                        alpha,
                        &mut acc,
                        l,
                        &mut pair.on_second,
                        b,
                    );
                }
            }
            let sums = acc.map(pairwise_sum);
            self.finish(pair, a, i, second.clone(), body, alpha, sums);
        }
    }

    /// One pair (i, j): lane `l` of i's sums gains c_j f, slot `b` of the second tile's sums
    /// loses c_i f.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn mutual(
        &self,
        i: usize,
        j: usize,
        (a1, a2): (f64, f64),
        acc: &mut [[f64; LANES]; 3],
        l: usize,
        on_second: &mut [[f64; TILE]; 3],
        b: usize,
    ) {
        let f = self.term(i, j, (a1, a2));
        for c in 0..3 {
            acc[c][l] += self.sign[j] * f[c];
            on_second[c][b] -= self.sign[i] * f[c];
        }
    }

    /// f(r_j − r_i) = d (α1/r² − α2/r³), the pair's force on i before the signs.
    #[inline(always)]
    fn term(&self, i: usize, j: usize, (a1, a2): (f64, f64)) -> [f64; 3] {
        let d = [
            self.x[j] - self.x[i],
            self.y[j] - self.y[i],
            self.z[j] - self.z[i],
        ];
        pair_term(d[0], d[1], d[2], a1, a2)
    }

    /// Particle i's (slot a of the first tile) sums: its lanes' `sums` plus the partners
    /// after the last full group of lanes, scalar.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        pair: &mut TilePair,
        a: usize,
        i: usize,
        second: std::ops::Range<usize>,
        body: usize,
        (a1, a2): (f64, f64),
        mut sums: [f64; 3],
    ) {
        for b in body..second.len() {
            let j = second.start + b;
            let f = self.term(i, j, (a1, a2));
            for c in 0..3 {
                sums[c] += self.sign[j] * f[c];
                pair.on_second[c][b] -= self.sign[i] * f[c];
            }
        }
        for (side, sum) in pair.on_first.iter_mut().zip(sums) {
            side[a] = sum;
        }
    }

    /// [`Coordinates::tile_pair`] in AVX intrinsics (the compiler keeps the portable loop at
    /// two lanes): the same operations in the same order, lanes 0–3 and 4–7 of each group.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn tile_pair_avx(&self, pair: &mut TilePair, (a1, a2): (f64, f64)) {
        use std::arch::x86_64::*;
        let (first, second) = (self.tile(pair.tiles.0), self.tile(pair.tiles.1));
        pair.on_second = [[0.0; TILE]; 3];
        let body = second.len() - second.len() % LANES;
        let (pa1, pa2) = (_mm256_set1_pd(a1), _mm256_set1_pd(a2));
        let (zero, one) = (_mm256_setzero_pd(), _mm256_set1_pd(1.0));
        let s = second.start;
        for (a, i) in first.enumerate() {
            let own = [self.x[i], self.y[i], self.z[i]].map(|v| _mm256_set1_pd(v));
            let sign_i = _mm256_set1_pd(self.sign[i]);
            let mut acc = [[zero; 2]; 3];
            for group in (0..body).step_by(LANES) {
                for (half, b) in [group, group + 4].into_iter().enumerate() {
                    let at = |v: &[f64]| _mm256_loadu_pd(v[s + b..].as_ptr());
                    let d = [
                        _mm256_sub_pd(at(&self.x), own[0]),
                        _mm256_sub_pd(at(&self.y), own[1]),
                        _mm256_sub_pd(at(&self.z), own[2]),
                    ];
                    let r2 = _mm256_add_pd(
                        _mm256_add_pd(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1])),
                        _mm256_mul_pd(d[2], d[2]),
                    );
                    let reciprocal = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
                    let inv = _mm256_and_pd(reciprocal, _mm256_cmp_pd::<_CMP_GT_OQ>(r2, zero));
                    let scale = _mm256_mul_pd(
                        _mm256_mul_pd(inv, inv),
                        _mm256_sub_pd(pa1, _mm256_mul_pd(pa2, inv)),
                    );
                    let sign_j = at(&self.sign);
                    for c in 0..3 {
                        let f = _mm256_mul_pd(d[c], scale);
                        acc[c][half] = _mm256_add_pd(acc[c][half], _mm256_mul_pd(sign_j, f));
                        let slot = pair.on_second[c][b..].as_mut_ptr();
                        let lost = _mm256_mul_pd(sign_i, f);
                        _mm256_storeu_pd(slot, _mm256_sub_pd(_mm256_loadu_pd(slot), lost));
                    }
                }
            }
            let sums = acc.map(|[low, high]| {
                let mut lanes = [0.0; LANES];
                _mm256_storeu_pd(lanes.as_mut_ptr(), low);
                _mm256_storeu_pd(lanes[4..].as_mut_ptr(), high);
                pairwise_sum(lanes)
            });
            self.finish(pair, a, i, second.clone(), body, (a1, a2), sums);
        }
    }
}

/// ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)): the lanes' partial sums, in a fixed
/// order.
fn pairwise_sum(a: [f64; LANES]) -> f64 {
    let mut width = LANES;
    let mut a = a;
    while width > 1 {
        width /= 2;
        for k in 0..width {
            a[k] = a[2 * k] + a[2 * k + 1];
        }
    }
    a[0]
}

/// d (α1/r² − α2/r³) for the separation d = (dx, dy, dz); zero at d = 0. The reciprocal is
/// computed unconditionally and then selected, so the loop has no branch.
#[inline(always)]
fn pair_term(dx: f64, dy: f64, dz: f64, a1: f64, a2: f64) -> [f64; 3] {
    let r2 = dx * dx + dy * dy + dz * dz;
    let reciprocal = 1.0 / r2.sqrt();
    let inv = if r2 > 0.0 { reciprocal } else { 0.0 };
    let scale = inv * inv * (a1 - a2 * inv);
    [dx * scale, dy * scale, dz * scale]
}

/// Index of the tile pair (i, j), i ≤ j, among the pairs of `tiles` tiles in row-major order
/// (row k holds tiles − k pairs).
fn pair_index(tiles: usize, i: usize, j: usize) -> usize {
    i * tiles - i * i.saturating_sub(1) / 2 + (j - i)
}

/// Particle p's force (before its sign c_p) from its tile sums, added in tile order.
fn gather(pairs: &[TilePair], tiles: usize, p: usize) -> Vector3<f64> {
    let (tile, slot) = (p / TILE, p % TILE);
    let mut sum = [0.0; 3];
    for other in 0..tiles {
        let side = if other < tile {
            &pairs[pair_index(tiles, other, tile)].on_second
        } else {
            &pairs[pair_index(tiles, tile, other)].on_first
        };
        for c in 0..3 {
            sum[c] += side[c][slot];
        }
    }
    Vector3::from(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::params::BlastParams;

    /// Points spread over a unit ball, with every third charge negative.
    fn cloud(n: usize) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let positions = (0..n)
            .map(|k| {
                let t = k as f64;
                Vector3::new((1.3 * t).sin(), (0.7 * t).cos(), (0.37 * t).sin() * 0.9)
            })
            .collect();
        let q = (0..n)
            .map(|k| if k % 3 == 0 { -10.0 } else { 10.0 })
            .collect();
        (positions, q)
    }

    /// The kernel equals the per-pair law summed pair by pair, for like and mixed charges,
    /// with one tile, a partial tile and several tiles (N not a multiple of LANES or TILE).
    #[test]
    fn matches_the_pair_law_summed_directly() {
        for (charge_sign, n) in [(false, 23), (true, 23), (true, 64), (true, 203)] {
            let mut p = BlastParams::source_example();
            p.near_field.charge_sign = charge_sign;
            let law = PairLaw::new(&p);
            let (positions, q) = cloud(n);
            let mut out = vec![Vector3::zeros(); n];
            AllPairs::default().sum(&law, &positions, &q, &mut out);
            for i in 0..n {
                let direct: Vector3<f64> = (0..n)
                    .filter(|&j| j != i)
                    .map(|j| {
                        law.sign_factor(q[i], q[j]) * law.near_field(&positions[i], &positions[j])
                    })
                    .sum();
                assert!(
                    (out[i] - direct).norm() <= 1e-12 * direct.norm(),
                    "{n}: {i}"
                );
            }
            let total: Vector3<f64> = out.iter().sum();
            let scale: f64 = out.iter().map(|f| f.norm()).sum();
            assert!(total.norm() < 1e-12 * scale, "action = reaction");
        }
    }

    /// Where the processor has AVX, the intrinsics give the portable kernel's bits exactly,
    /// so a run does not depend on the machine's vector width.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_and_portable_sums_are_identical() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut p = BlastParams::source_example();
        p.near_field.charge_sign = true;
        let law = PairLaw::new(&p);
        let (positions, q) = cloud(203);
        let mut avx = vec![Vector3::zeros(); positions.len()];
        let mut portable = avx.clone();
        AllPairs::default().sum_with(&law, &positions, &q, &mut avx, true);
        AllPairs::default().sum_with(&law, &positions, &q, &mut portable, false);
        assert_eq!(avx, portable);
    }

    /// The buffers resize when the cloud changes size between evaluations.
    #[test]
    fn one_kernel_serves_clouds_of_any_size() {
        let law = PairLaw::new(&BlastParams::source_example());
        let mut kernel = AllPairs::default();
        for n in [130, 7, 70] {
            let (positions, q) = cloud(n);
            let mut reused = vec![Vector3::zeros(); n];
            let mut fresh = reused.clone();
            kernel.sum(&law, &positions, &q, &mut reused);
            AllPairs::default().sum(&law, &positions, &q, &mut fresh);
            assert_eq!(reused, fresh, "{n}");
        }
    }
}
