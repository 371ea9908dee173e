//! The four walls' repulsion on one disc (B2 or its alternatives): the bottom, the two sides
//! and the piston.
//!
//! The power laws (B2's w^−3.5, the infinite row's w^−3) take the four walls in the four
//! lanes of one AVX register where the processor has it: one square root and two divisions
//! instead of four and eight, with each lane's operations those of the portable form, in its
//! order and none fused (the same bits). The divider, shared with the kicks and the pair
//! geometry, is what a disc's walls wait on.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use nalgebra::Vector2;

use super::params::WallLaw;
use super::state::Geometry;

/// Inward normals of the bottom, the left and right sides and the piston.
pub(super) const WALL_NORMALS: [Vector2<f64>; 4] = [
    Vector2::new(0.0, 1.0),
    Vector2::new(1.0, 0.0),
    Vector2::new(-1.0, -0.0),
    Vector2::new(-0.0, -1.0),
];

/// Closest a disc's centre is taken to be to a wall, m (keeps the laws finite).
const CLOSEST: f64 = 1e-9;

/// The four walls' repulsion on one disc, in the order of [`WALL_NORMALS`].
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Walls {
    /// Force magnitudes, N.
    pub(super) magnitude: [f64; 4],
    /// Stiffnesses (power-law exponent × magnitude / distance), N/m.
    pub(super) stiffness: [f64; 4],
}

impl Walls {
    /// The walls of a cell of this geometry, with the piston's lower face at height `piston`,
    /// on a disc at `p` whose wall coefficient (the law's prefactor) is `c`.
    pub(super) fn on(law: WallLaw, c: f64, p: Vector2<f64>, g: &Geometry, piston: f64) -> Self {
        let walls = layout(p, g, piston);
        #[cfg(target_arch = "x86_64")]
        if law != WallLaw::FiniteBar && crate::numerics::has_avx() {
            // SAFETY: the processor has AVX.
            let [d0, d1, d2, d3] = walls.map(|w| w.0);
            return unsafe { power_law_avx(law, c, d0, d1, d2, d3) };
        }
        Self::portable(law, c, walls)
    }

    fn portable(law: WallLaw, c: f64, walls: [(f64, f64, f64); 4]) -> Self {
        let mut out = Self::default();
        for (k, (w, along, length)) in walls.into_iter().enumerate() {
            let w = w.max(CLOSEST);
            let (magnitude, exponent) = wall_force(law, c, w, along, length);
            out.magnitude[k] = magnitude;
            out.stiffness[k] = exponent * magnitude / w;
        }
        out
    }
}

/// Each wall's (distance, the disc's coordinate along it, its length), m.
fn layout(p: Vector2<f64>, g: &Geometry, piston: f64) -> [(f64, f64, f64); 4] {
    [
        (p.y, p.x, g.width),
        (p.x, p.y, g.height),
        (g.width - p.x, p.y, g.height),
        (piston - p.y, p.x, g.width),
    ]
}

/// Magnitude of a wall's repulsion at distance w, N, and its power-law exponent; `along`
/// is the disc's coordinate along the wall of this length (only the finite bar uses it).
fn wall_force(law: WallLaw, c: f64, w: f64, along: f64, length: f64) -> (f64, f64) {
    match law {
        WallLaw::Empirical => (c / (w * w * w * w.sqrt()), 3.5),
        WallLaw::InfiniteRow => (c / (w * w * w), 3.0),
        WallLaw::FiniteBar => {
            let f = (along / length).clamp(0.0, 1.0);
            // Each end term, written with t = fL/ℓ so that f → 0 is regular:
            // (1/√(A²+1))(3A²+2)/(3A²+3) = t(3+2t²)/(√(1+t²)(3+3t²)), A = 1/t.
            let end =
                |t: f64| t * (3.0 + 2.0 * t * t) / ((1.0 + t * t).sqrt() * (3.0 + 3.0 * t * t));
            let bracket = end(f * length / w) + end((1.0 - f) * length / w);
            (c * bracket / (w * w * w), 4.0)
        }
    }
}

/// The power laws' four walls in four lanes.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn power_law_avx(law: WallLaw, c: f64, d0: f64, d1: f64, d2: f64, d3: f64) -> Walls {
    // max(w, CLOSEST) takes CLOSEST for a NaN w, as f64::max does.
    let w = _mm256_max_pd(_mm256_set_pd(d3, d2, d1, d0), _mm256_set1_pd(CLOSEST));
    let cube = _mm256_mul_pd(_mm256_mul_pd(w, w), w);
    let (power, exponent) = match law {
        WallLaw::Empirical => (_mm256_mul_pd(cube, _mm256_sqrt_pd(w)), 3.5),
        _ => (cube, 3.0),
    };
    let magnitude = _mm256_div_pd(_mm256_set1_pd(c), power);
    let stiffness = _mm256_div_pd(_mm256_mul_pd(_mm256_set1_pd(exponent), magnitude), w);
    // Lane by lane, not one 32-byte store: the scalar reads that follow would wait on it.
    Walls {
        magnitude: lanes(magnitude),
        stiffness: lanes(stiffness),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn lanes(x: __m256d) -> [f64; 4] {
    let (low, high) = (_mm256_castpd256_pd128(x), _mm256_extractf128_pd::<1>(x));
    [
        _mm_cvtsd_f64(low),
        _mm_cvtsd_f64(_mm_unpackhi_pd(low, low)),
        _mm_cvtsd_f64(high),
        _mm_cvtsd_f64(_mm_unpackhi_pd(high, high)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn avx_and_portable_walls_are_identical() {
        let g = Geometry {
            width: 0.094,
            height: 0.2,
            start_height: 0.2,
            final_height: 0.1,
        };
        let discs = [
            (0.03, 0.05, 0.12),
            (1e-12, 0.05, 0.12),
            (0.093, 0.19999, 0.2),
            (0.047, -1e-3, 0.1),
            (f64::NAN, 0.05, 0.12),
            (0.01, 0.003, 0.0031),
        ];
        for law in [WallLaw::Empirical, WallLaw::InfiniteRow, WallLaw::FiniteBar] {
            for (x, y, piston) in discs {
                let (p, c) = (Vector2::new(x, y), 3.7e-9);
                let on = Walls::on(law, c, p, &g, piston);
                let portable = Walls::portable(law, c, layout(p, &g, piston));
                let bits =
                    |w: Walls| (w.magnitude.map(f64::to_bits), w.stiffness.map(f64::to_bits));
                assert_eq!(
                    bits(on),
                    bits(portable),
                    "{law:?} at ({x}, {y}), piston {piston}"
                );
            }
        }
    }
}
