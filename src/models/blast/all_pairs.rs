//! The exact near-field sum over all pairs (C8), the cost that dominates the interacting
//! model at the source's density (N = 2000: 2·10⁶ pairs per force evaluation).
//!
//! Why a kernel of its own: the per-pair form in [`PairLaw::near_field`] walks nalgebra
//! vectors one partner at a time, a dependent chain of a square root and a division per
//! pair. Here the positions are copied once per evaluation into coordinate arrays and summed
//! by the shared tiled all-pairs scheme ([`TiledPairs`]: every unordered pair evaluated once,
//! in vectorized lanes, bit-identical at any thread count).

use nalgebra::Vector3;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::pairs::PairLaw;
use super::params::NearFieldPrecision;
use super::single::{self, SinglePairs};
#[cfg(target_arch = "x86_64")]
use crate::numerics::tiled_pairs::negate;
use crate::numerics::tiled_pairs::{PairTerm, TiledPairs, TILE};

/// Coordinates and charge signs in structure-of-arrays form, with the law's coefficients.
#[derive(Debug, Clone, Default)]
struct Coordinates {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// c_i: −1 for a negative charge when the law carries the sign factor, else 1.
    sign: Vec<f64>,
    /// (α1, α2) of the law.
    alpha: (f64, f64),
}

/// The kernel's buffers, reused between evaluations (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct AllPairs {
    at: Coordinates,
    tiles: TiledPairs<3>,
    /// The single-precision kernel, when it may be chosen instead.
    single: Option<SinglePairs>,
    /// Whether single precision is taken only within [`single::EXTENT_LIMIT`] (`auto`).
    limited: bool,
    /// Evaluations so far: (all, in single precision).
    evaluations: (usize, usize),
}

impl AllPairs {
    /// The kernel in the given arithmetic.
    pub fn new(precision: NearFieldPrecision) -> Self {
        Self {
            single: (precision != NearFieldPrecision::Double).then(SinglePairs::default),
            limited: precision == NearFieldPrecision::Auto,
            ..Self::default()
        }
    }

    /// Evaluations so far: (all, in single precision).
    pub fn evaluations(&self) -> (usize, usize) {
        self.evaluations
    }

    /// Near-field force on every particle from all others, written into `out`, N. Only for
    /// the source's exponents β = (1, 2) (see [`AllPairs::applies`]).
    pub fn sum(
        &mut self,
        law: &PairLaw,
        positions: &[Vector3<f64>],
        charge_per_mass: &[f64],
        out: &mut [Vector3<f64>],
    ) {
        self.evaluations.0 += 1;
        if let Some(lanes) = &mut self.single {
            if !self.limited || single::within_extent_limit(law, positions) {
                self.evaluations.1 += 1;
                return lanes.sum(law, positions, charge_per_mass, out);
            }
        }
        self.at.load(law, positions, charge_per_mass);
        self.tiles.fill(&self.at);
        self.gather(out);
    }

    /// Whether the kernel covers `law`: the fast path is written for β = (1, 2) only.
    pub fn applies(law: &PairLaw) -> bool {
        law.beta == (1.0, 2.0)
    }

    /// Each particle's force from its tile sums, with its own sign c_p.
    fn gather(&self, out: &mut [Vector3<f64>]) {
        out.par_iter_mut()
            .enumerate()
            .with_min_len(TILE)
            .for_each(|(p, f)| {
                *f = self.at.sign[p] * Vector3::from(self.tiles.gather::<Coordinates>(p))
            });
    }
}

impl Coordinates {
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
        self.alpha = law.alpha;
    }
}

/// The pair (i, j) adds c_j f(r_j − r_i) to i and −c_i f to j (each particle's own sign c_p
/// is applied at the gather).
impl PairTerm<3> for Coordinates {
    const SUMS: usize = 3;

    fn count(&self) -> usize {
        self.x.len()
    }

    #[inline(always)]
    fn term(&self, i: usize, j: usize) -> ([f64; 3], [f64; 3]) {
        let d = [
            self.x[j] - self.x[i],
            self.y[j] - self.y[i],
            self.z[j] - self.z[i],
        ];
        let f = pair_term(d[0], d[1], d[2], self.alpha);
        (f.map(|f| self.sign[j] * f), f.map(|f| -(self.sign[i] * f)))
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn term_avx(&self, i: usize, j: usize) -> ([__m256d; 3], [__m256d; 3]) {
        // SAFETY (loads): each slice holds 4 f64.
        let at = |v: &[f64]| unsafe { _mm256_loadu_pd(v[j..j + 4].as_ptr()) };
        let own = |v: &[f64]| _mm256_set1_pd(v[i]);
        let (zero, one) = (_mm256_setzero_pd(), _mm256_set1_pd(1.0));
        let d = [
            _mm256_sub_pd(at(&self.x), own(&self.x)),
            _mm256_sub_pd(at(&self.y), own(&self.y)),
            _mm256_sub_pd(at(&self.z), own(&self.z)),
        ];
        let r2 = _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1])),
            _mm256_mul_pd(d[2], d[2]),
        );
        let reciprocal = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
        let inv = _mm256_and_pd(reciprocal, _mm256_cmp_pd::<_CMP_GT_OQ>(r2, zero));
        let (a1, a2) = (_mm256_set1_pd(self.alpha.0), _mm256_set1_pd(self.alpha.1));
        let scale = _mm256_mul_pd(
            _mm256_mul_pd(inv, inv),
            _mm256_sub_pd(a1, _mm256_mul_pd(a2, inv)),
        );
        let (sign_i, sign_j) = (own(&self.sign), at(&self.sign));
        let f = d.map(|d| _mm256_mul_pd(d, scale));
        (
            f.map(|f| _mm256_mul_pd(sign_j, f)),
            f.map(|f| negate(_mm256_mul_pd(sign_i, f))),
        )
    }
}

/// d (α1/r² − α2/r³) for the separation d = (dx, dy, dz); zero at d = 0. The reciprocal is
/// computed unconditionally and then selected, so the loop has no branch.
#[inline(always)]
fn pair_term(dx: f64, dy: f64, dz: f64, (a1, a2): (f64, f64)) -> [f64; 3] {
    let r2 = dx * dx + dy * dy + dz * dz;
    let reciprocal = 1.0 / r2.sqrt();
    let inv = if r2 > 0.0 { reciprocal } else { 0.0 };
    let scale = inv * inv * (a1 - a2 * inv);
    [dx * scale, dy * scale, dz * scale]
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
        for (simd, out) in [(true, &mut avx), (false, &mut portable)] {
            let mut kernel = AllPairs::default();
            kernel.at.load(&law, &positions, &q);
            kernel.tiles.fill_with(&kernel.at, simd);
            kernel.gather(out);
        }
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
