//! The exact near-field sum over all pairs (C8), the cost that dominates the interacting
//! model at the source's density (N = 2000: 4·10⁶ pair terms per force evaluation).
//!
//! Why a kernel of its own: the per-pair form in [`PairLaw::near_field`] walks nalgebra
//! vectors one partner at a time, a dependent chain of a square root and a division per
//! pair. Here the positions are copied once per evaluation into coordinate arrays and each
//! particle sums its partners in [`LANES`] independent accumulators, so the compiler
//! vectorizes the loop and the divisions overlap. Each particle still sums its partners in a
//! fixed order, so the forces are bit-identical at any thread count.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::pairs::PairLaw;

/// Independent partial sums per particle (two AVX registers of f64, four SSE2 ones).
const LANES: usize = 8;

/// Particles per rayon task.
const CHUNK: usize = 16;

/// Coordinates and charge signs of the cloud in structure-of-arrays form, reused between
/// evaluations (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct AllPairs {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// c_i: −1 for a negative charge when the law carries the sign factor, else 1.
    sign: Vec<f64>,
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
        self.load(law, positions, charge_per_mass);
        let this = &*self;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, f)| *f = this.on(law.alpha, i));
    }

    /// Whether the kernel covers `law`: the fast path is written for β = (1, 2) only.
    pub fn applies(law: &PairLaw) -> bool {
        law.beta == (1.0, 2.0)
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

    /// Σ_j c_i c_j (α1/r² − α2/r³) n_ij on particle i, with AVX where the processor has it
    /// (identical results: the same operations in the same order, none fused).
    fn on(&self, alpha: (f64, f64), i: usize) -> Vector3<f64> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor supports AVX (checked just above).
            return unsafe { self.on_avx(alpha, i) };
        }
        self.on_portable(alpha, i)
    }

    /// [`Self::on_portable`] written in AVX intrinsics (the compiler keeps the portable loop
    /// at two lanes): the same operations in the same order on lanes 0–3 and 4–7.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn on_avx(&self, (a1, a2): (f64, f64), i: usize) -> Vector3<f64> {
        use std::arch::x86_64::*;
        let (xi, yi, zi) = (self.x[i], self.y[i], self.z[i]);
        let (pxi, pyi, pzi) = (_mm256_set1_pd(xi), _mm256_set1_pd(yi), _mm256_set1_pd(zi));
        let (pa1, pa2) = (_mm256_set1_pd(a1), _mm256_set1_pd(a2));
        let (zero, one) = (_mm256_setzero_pd(), _mm256_set1_pd(1.0));
        let mut acc = [[zero; 2]; 3];
        let blocks = lanes(&self.x)
            .zip(lanes(&self.y))
            .zip(lanes(&self.z))
            .zip(lanes(&self.sign));
        for (((x, y), z), sign) in blocks {
            for half in 0..2 {
                let at = |v: &[f64; LANES]| _mm256_loadu_pd(v[4 * half..].as_ptr());
                let dx = _mm256_sub_pd(at(x), pxi);
                let dy = _mm256_sub_pd(at(y), pyi);
                let dz = _mm256_sub_pd(at(z), pzi);
                let r2 = _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                    _mm256_mul_pd(dz, dz),
                );
                let reciprocal = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
                let inv = _mm256_and_pd(reciprocal, _mm256_cmp_pd::<_CMP_GT_OQ>(r2, zero));
                let repulsion = _mm256_sub_pd(pa1, _mm256_mul_pd(pa2, inv));
                let scale =
                    _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(at(sign), inv), inv), repulsion);
                for (c, d) in [dx, dy, dz].into_iter().enumerate() {
                    acc[c][half] = _mm256_add_pd(acc[c][half], _mm256_mul_pd(d, scale));
                }
            }
        }
        let mut sum = [0.0; 3];
        for c in 0..3 {
            let mut lanes = [0.0; LANES];
            _mm256_storeu_pd(lanes.as_mut_ptr(), acc[c][0]);
            _mm256_storeu_pd(lanes[4..].as_mut_ptr(), acc[c][1]);
            sum[c] = pairwise_sum(lanes);
        }
        self.sign[i] * Vector3::from(self.tail(sum, (a1, a2), i))
    }

    /// The sum on particle i; the j = i term (r = 0) is zero.
    #[inline(always)]
    fn on_portable(&self, (a1, a2): (f64, f64), i: usize) -> Vector3<f64> {
        let (xi, yi, zi) = (self.x[i], self.y[i], self.z[i]);
        let mut acc = [[0.0; LANES]; 3];
        let blocks = lanes(&self.x)
            .zip(lanes(&self.y))
            .zip(lanes(&self.z))
            .zip(lanes(&self.sign));
        for (((x, y), z), sign) in blocks {
            for l in 0..LANES {
                let f = pair_term(x[l] - xi, y[l] - yi, z[l] - zi, a1, a2, sign[l]);
                for c in 0..3 {
                    acc[c][l] += f[c];
                }
            }
        }
        self.sign[i] * Vector3::from(self.tail(acc.map(pairwise_sum), (a1, a2), i))
    }

    /// `sum` plus the partners after the last full block of lanes.
    #[inline(always)]
    fn tail(&self, mut sum: [f64; 3], (a1, a2): (f64, f64), i: usize) -> [f64; 3] {
        let (xi, yi, zi) = (self.x[i], self.y[i], self.z[i]);
        for j in self.x.len() - self.x.len() % LANES..self.x.len() {
            let f = pair_term(
                self.x[j] - xi,
                self.y[j] - yi,
                self.z[j] - zi,
                a1,
                a2,
                self.sign[j],
            );
            for c in 0..3 {
                sum[c] += f[c];
            }
        }
        sum
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

/// The values of `v` in blocks of [`LANES`] (the tail left out).
fn lanes(v: &[f64]) -> impl Iterator<Item = &[f64; LANES]> {
    v.chunks_exact(LANES)
        .map(|c| c.try_into().expect("chunks_exact yields LANES values"))
}

/// c_j d (α1/r² − α2/r³) for the separation d = (dx, dy, dz) and partner sign c_j; zero at
/// d = 0. The reciprocal is computed unconditionally and then selected, so the loop has no
/// branch and vectorizes.
#[inline(always)]
fn pair_term(dx: f64, dy: f64, dz: f64, a1: f64, a2: f64, sign: f64) -> [f64; 3] {
    let r2 = dx * dx + dy * dy + dz * dz;
    let reciprocal = 1.0 / r2.sqrt();
    let inv = if r2 > 0.0 { reciprocal } else { 0.0 };
    let scale = sign * inv * inv * (a1 - a2 * inv);
    [dx * scale, dy * scale, dz * scale]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::params::BlastParams;

    /// The kernel equals the per-pair law summed pair by pair, for like and mixed charges.
    #[test]
    fn matches_the_pair_law_summed_directly() {
        for charge_sign in [false, true] {
            let mut p = BlastParams::source_example();
            p.near_field.charge_sign = charge_sign;
            let law = PairLaw::new(&p);
            let n = 23; // not a multiple of LANES: the tail is exercised
            let positions: Vec<_> = (0..n)
                .map(|k| {
                    let t = k as f64;
                    Vector3::new((1.3 * t).sin(), (0.7 * t).cos(), 0.1 * t)
                })
                .collect();
            let q: Vec<f64> = (0..n)
                .map(|k| if k % 3 == 0 { -10.0 } else { 10.0 })
                .collect();
            let mut out = vec![Vector3::zeros(); n];
            AllPairs::default().sum(&law, &positions, &q, &mut out);
            for i in 0..n {
                let direct: Vector3<f64> = (0..n)
                    .filter(|&j| j != i)
                    .map(|j| {
                        law.sign_factor(q[i], q[j]) * law.near_field(&positions[i], &positions[j])
                    })
                    .sum();
                assert!((out[i] - direct).norm() <= 1e-12 * direct.norm(), "{i}");
            }
            let total: Vector3<f64> = out.iter().sum();
            let scale: f64 = out.iter().map(|f| f.norm()).sum();
            assert!(total.norm() < 1e-12 * scale, "action = reaction");
        }
    }

    /// Where the processor has AVX, the intrinsics give the portable loop's bits exactly, so
    /// a run does not depend on the machine's vector width.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_and_portable_sums_are_identical() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut p = BlastParams::source_example();
        p.near_field.charge_sign = true;
        let law = PairLaw::new(&p);
        let n = 37;
        let positions: Vec<_> = (0..n)
            .map(|k| {
                Vector3::new(
                    (0.3 * k as f64).sin(),
                    (1.1 * k as f64).cos(),
                    0.2 * k as f64,
                )
            })
            .collect();
        let q: Vec<f64> = (0..n)
            .map(|k| if k % 2 == 0 { -1.0 } else { 1.0 })
            .collect();
        let mut kernel = AllPairs::default();
        kernel.load(&law, &positions, &q);
        for i in 0..n {
            // SAFETY: AVX is present (checked above).
            let avx = unsafe { kernel.on_avx(law.alpha, i) };
            assert_eq!(avx, kernel.on_portable(law.alpha, i), "particle {i}");
        }
    }
}
