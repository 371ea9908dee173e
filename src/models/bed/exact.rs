//! The bed's exact pair sums (`--neighbors exact`, B1 and the B4 plate normal over every
//! pair): each unordered pair is evaluated once for both disks by the shared tiled all-pairs
//! scheme ([`TiledPairs`]), from positions copied once per evaluation into coordinate arrays.
//! A gather over all partners of each disk in turn would evaluate every pair twice, one
//! partner at a time. The sums are bit-identical at any thread count; they differ from such
//! a gather at round-off only (another summation order).

use nalgebra::Vector2;

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::forces::PairSums;
use super::state::Particles;
#[cfg(target_arch = "x86_64")]
use crate::numerics::tiled_pairs::negate;
use crate::numerics::tiled_pairs::{PairTerm, TiledPairs};

/// Per-disk data of the pair term in structure-of-arrays form.
#[derive(Debug, Clone)]
struct Disks {
    /// Position components, m.
    x: Vec<f64>,
    y: Vec<f64>,
    /// μ_j, A·m².
    moment: Vec<f64>,
    /// μ_j sin θ_j, A·m² (B4).
    moment_sin: Vec<f64>,
    /// D_j, m.
    diameter: Vec<f64>,
}

/// The exact pair sums of every disk, with the buffers reused between evaluations.
#[derive(Debug, Clone)]
pub(super) struct ExactSums {
    disks: Disks,
    tiles: TiledPairs<5>,
}

impl ExactSums {
    /// The sums' constant data for these particles (positions come with each evaluation).
    pub(super) fn new(particles: &Particles) -> Self {
        let n = particles.len();
        Self {
            disks: Disks {
                x: vec![0.0; n],
                y: vec![0.0; n],
                moment: particles.moment.clone(),
                moment_sin: (0..n)
                    .map(|j| particles.moment[j] * particles.tilt_sin[j])
                    .collect(),
                diameter: particles.diameter.clone(),
            },
            tiles: TiledPairs::default(),
        }
    }

    /// Evaluates every pair at these positions, m.
    pub(super) fn evaluate(&mut self, position: &[Vector2<f64>]) {
        self.load(position);
        self.tiles.fill(&self.disks);
    }

    fn load(&mut self, position: &[Vector2<f64>]) {
        for (k, p) in position.iter().enumerate() {
            (self.disks.x[k], self.disks.y[k]) = (p.x, p.y);
        }
    }

    /// Disk i's sums over all other disks (after [`ExactSums::evaluate`]).
    pub(super) fn of(&self, i: usize) -> PairSums {
        let [fx, fy, normal, stiffest, closeness] = self.tiles.gather::<Disks>(i);
        PairSums {
            force: Vector2::new(fx, fy),
            normal,
            stiffest,
            closeness,
        }
    }
}

/// Components (summed) d μ_j/r⁵ (x, y) and μ_j sin θ_j/r³, then (maxima) μ_j/r⁵ and
/// ((D_i + D_j)/2)²/r², with d = r_i − r_j; j's side has −d and μ_i. The 1/r² is computed
/// unconditionally and then selected, so the loop has no branch (zero at r = 0, i = j). The
/// arithmetic is the lists' (`list_pairs::separations`, then `ForceField::pair_sums`), so
/// below one group of lanes (N < 8: every partner in the scalar tail, in index order) both
/// give the same bits.
impl PairTerm<5> for Disks {
    const SUMS: usize = 3;

    fn count(&self) -> usize {
        self.x.len()
    }

    #[inline(always)]
    fn term(&self, i: usize, j: usize) -> ([f64; 5], [f64; 5]) {
        let (dx, dy) = (self.x[i] - self.x[j], self.y[i] - self.y[j]);
        let r2 = dx * dx + dy * dy;
        let reciprocal = 1.0 / r2;
        let inv_r2 = if r2 > 0.0 { reciprocal } else { 0.0 };
        let inv_r3 = inv_r2 * inv_r2.sqrt();
        let on_i = self.moment[j] * inv_r3 * inv_r2;
        let on_j = self.moment[i] * inv_r3 * inv_r2;
        let mean = 0.5 * (self.diameter[i] + self.diameter[j]);
        let closeness = mean * mean * inv_r2;
        (
            [
                dx * on_i,
                dy * on_i,
                self.moment_sin[j] * inv_r3,
                on_i,
                closeness,
            ],
            [
                -(dx * on_j),
                -(dy * on_j),
                self.moment_sin[i] * inv_r3,
                on_j,
                closeness,
            ],
        )
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn term_avx(&self, i: usize, j: usize) -> ([__m256d; 5], [__m256d; 5]) {
        // SAFETY (loads): each slice holds 4 f64.
        let at = |v: &[f64]| unsafe { _mm256_loadu_pd(v[j..j + 4].as_ptr()) };
        let own = |v: &[f64]| _mm256_set1_pd(v[i]);
        let dx = _mm256_sub_pd(own(&self.x), at(&self.x));
        let dy = _mm256_sub_pd(own(&self.y), at(&self.y));
        let r2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
        let reciprocal = _mm256_div_pd(_mm256_set1_pd(1.0), r2);
        let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(r2, _mm256_setzero_pd());
        let inv_r2 = _mm256_and_pd(reciprocal, positive);
        let inv_r3 = _mm256_mul_pd(inv_r2, _mm256_sqrt_pd(inv_r2));
        let on_i = _mm256_mul_pd(_mm256_mul_pd(at(&self.moment), inv_r3), inv_r2);
        let on_j = _mm256_mul_pd(_mm256_mul_pd(own(&self.moment), inv_r3), inv_r2);
        let sum_d = _mm256_add_pd(own(&self.diameter), at(&self.diameter));
        let mean = _mm256_mul_pd(_mm256_set1_pd(0.5), sum_d);
        let closeness = _mm256_mul_pd(_mm256_mul_pd(mean, mean), inv_r2);
        (
            [
                _mm256_mul_pd(dx, on_i),
                _mm256_mul_pd(dy, on_i),
                _mm256_mul_pd(at(&self.moment_sin), inv_r3),
                on_i,
                closeness,
            ],
            [
                negate(_mm256_mul_pd(dx, on_j)),
                negate(_mm256_mul_pd(dy, on_j)),
                _mm256_mul_pd(own(&self.moment_sin), inv_r3),
                on_j,
                closeness,
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::bed::forces::pair_force;
    use std::f64::consts::PI;

    /// A poly-disperse set of tilted disks spread over a few millimetres, N not a multiple of
    /// the lanes or the tile.
    fn disks(n: usize) -> (ExactSums, Vec<Vector2<f64>>) {
        let position: Vec<_> = (0..n)
            .map(|k| {
                let t = k as f64;
                Vector2::new(1e-3 * (1.3 * t).sin() + 1e-5 * t, 2e-3 * (0.7 * t).cos())
            })
            .collect();
        let diameter: Vec<f64> = (0..n)
            .map(|k| 1e-3 * (1.0 + 0.1 * (k % 3) as f64))
            .collect();
        let sums = ExactSums {
            disks: Disks {
                x: vec![0.0; n],
                y: vec![0.0; n],
                moment: diameter.iter().map(|d| 0.02 * d * d * d).collect(),
                moment_sin: diameter
                    .iter()
                    .enumerate()
                    .map(|(k, d)| 0.02 * d * d * d * (0.1 * k as f64).sin())
                    .collect(),
                diameter,
            },
            tiles: TiledPairs::default(),
        };
        (sums, position)
    }

    /// Each disk's sums equal the per-pair law summed pair by pair (B1 through
    /// [`pair_force`], B4 and the maxima written out here), and the forces balance
    /// (action = reaction).
    #[test]
    fn matches_the_pair_law_summed_directly() {
        for n in [23, 64, 203] {
            let (mut sums, position) = disks(n);
            sums.evaluate(&position);
            let d = &sums.disks;
            let pair = 3.0 * crate::units::MU0 / (4.0 * PI);
            let mut total = Vector2::zeros();
            let mut scale = 0.0;
            for i in 0..n {
                let got = sums.of(i);
                let others = (0..n).filter(|&j| j != i);
                let force: Vector2<f64> = others
                    .clone()
                    .map(|j| pair_force(d.moment[i], d.moment[j], position[i], position[j]))
                    .sum();
                let r = |j: usize| (position[i] - position[j]).norm();
                let normal: f64 = others.clone().map(|j| d.moment_sin[j] / r(j).powi(3)).sum();
                let stiffest = others.clone().map(|j| d.moment[j] / r(j).powi(5));
                let closeness = others
                    .map(|j| (0.5 * (d.diameter[i] + d.diameter[j]) / r(j)).powi(2))
                    .fold(0.0, f64::max);
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
                let own = pair * d.moment[i] * got.force;
                assert!((own - force).norm() <= 1e-12 * force.norm(), "{n}: {i}");
                assert!(close(got.normal, normal), "{n}: {i}");
                assert!(
                    close(got.stiffest, stiffest.fold(0.0, f64::max)),
                    "{n}: {i}"
                );
                assert!(close(got.closeness, closeness), "{n}: {i}");
                total += own;
                scale += own.norm();
            }
            assert!(total.norm() < 1e-12 * scale, "action = reaction");
        }
    }

    /// The AVX term gives the portable term's bits, and a pool of one thread the bits of a
    /// pool of two, so a run depends on neither the vector width nor the thread count.
    #[test]
    fn bits_do_not_depend_on_vectors_or_threads() {
        let (mut sums, position) = disks(203);
        sums.load(&position);
        let run = |threads: usize, avx: bool| {
            let mut sums = sums.clone();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            pool.install(|| sums.tiles.fill_with(&sums.disks, avx));
            (0..203)
                .map(|i| sums.tiles.gather::<Disks>(i).map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        let reference = run(1, false);
        assert_eq!(run(2, false), reference);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            assert_eq!(run(1, true), reference);
            assert_eq!(run(2, true), reference);
        }
    }
}
