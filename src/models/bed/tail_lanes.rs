//! The horizontal band-edge terms of [`super::tail`]'s integrals, four edges per AVX
//! instruction.
//!
//! Why: a disc's tail sums about 2·FINE + 2·COARSE·log₂(bands) edge terms, each with
//! thirteen divisions and two square roots behind the branches of the closed forms; at
//! N = 10⁴ the tails' refreshes held 15 % of a standard cycle's compression on one thread.
//! Most edges lie at least r_c above or below the disc, where every closed form takes its
//! branch without an arc (the half-plane beyond r_c, the corner outside the disc): those run
//! four side by side, each lane with the operations of [`horizontal_edge`] in its order, none
//! fused, so the terms are its bits. The edges nearer than r_c take [`horizontal_edge`]
//! itself.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use nalgebra::Vector2;

use super::tail::{edge, horizontal_edge, Edge};

/// The terms (∫ ŝ/|s|⁴ dA, ∫ 1/|s|³ dA) of [`horizontal_edge`] of the first `count` (≤ 4)
/// horizontal edges at `heights`, seen from height `at_y` between the vertical edges
/// `sides`; the edges are numbered from `first`, and those up to `own` lie below the disc.
/// Whole fours with AVX where the processor has it; the lanes from `count` on are unspecified.
pub(super) fn four_edges(
    sides: (Edge, Edge),
    at_y: f64,
    (first, own): (usize, usize),
    heights: [f64; 4],
    count: usize,
    rc: f64,
) -> [(Vector2<f64>, f64); 4] {
    let below = [0, 1, 2, 3].map(|l| first + l <= own);
    let one = |l: usize| {
        let y = edge((at_y - heights[l]).abs(), rc);
        horizontal_edge(sides, y, below[l], rc)
    };
    #[cfg(target_arch = "x86_64")]
    if count == 4 && crate::numerics::has_avx() {
        // SAFETY: the processor has AVX.
        let (mut terms, far) = unsafe { far_lanes(sides, at_y, below, heights, rc) };
        for l in (0..count).filter(|l| far & (1 << l) == 0) {
            terms[l] = one(l);
        }
        return terms;
    }
    [0, 1, 2, 3].map(|l| {
        if l < count {
            one(l)
        } else {
            Default::default()
        }
    })
}

/// Four edges' terms by the far branches of the closed forms ([`super::tail`]'s
/// `half_plane` beyond r_c, `quadrant` with its corner outside the disc), and the mask of
/// the lanes whose edge is at least r_c away, where those branches are the ones taken
/// (d ≥ r_c gives d² ≥ r_c² and so dx² + d² ≥ r_c², rounding being monotone).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn far_lanes(
    (left, right): (Edge, Edge),
    at_y: f64,
    below: [bool; 4],
    heights: [f64; 4],
    rc: f64,
) -> ([(Vector2<f64>, f64); 4], i32) {
    let set = _mm256_set1_pd;
    // SAFETY: `heights` holds 4 f64.
    let h = unsafe { _mm256_loadu_pd(heights.as_ptr()) };
    // edge(): |at_y − h|, at least a billionth of rc, and its inverse
    let dist = _mm256_andnot_pd(set(-0.0), _mm256_sub_pd(set(at_y), h));
    let d = _mm256_max_pd(dist, set(1e-9 * rc));
    let inv = _mm256_div_pd(set(1.0), d);
    let far = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(d, set(rc)));
    let sign = |b: bool| if b { -1.0 } else { 1.0 };
    let sy = _mm256_set_pd(
        sign(below[3]),
        sign(below[2]),
        sign(below[1]),
        sign(below[0]),
    );
    // half_plane() beyond rc: (2/3 inv², 2 inv)
    let normal = _mm256_mul_pd(_mm256_mul_pd(set(2.0 / 3.0), inv), inv);
    let mut sum = _mm256_mul_pd(set(2.0), inv);
    let mut gx = _mm256_setzero_pd();
    let mut gy = _mm256_mul_pd(sy, normal);
    let half_y2 = _mm256_mul_pd(_mm256_mul_pd(set(0.5), inv), inv);
    let third_cube = |v| _mm256_div_pd(_mm256_mul_pd(v, _mm256_mul_pd(v, v)), set(3.0));
    let cube_tail = |a, c| {
        let two_plus = _mm256_add_pd(set(2.0), c);
        _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(a, a), two_plus), set(3.0))
    };
    for (x, sx) in [(left, -1.0), (right, 1.0)] {
        let (dx, x_inv) = (set(x.d), set(x.inv));
        // quadrant() with its corner outside the disc
        let corner = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(d, d)));
        let c_inv = _mm256_div_pd(set(1.0), corner);
        let (cx, cy) = (_mm256_add_pd(corner, dx), _mm256_add_pd(corner, d));
        let shared = _mm256_div_pd(c_inv, _mm256_mul_pd(cx, cy));
        let (sin, cos) = (_mm256_mul_pd(d, c_inv), _mm256_mul_pd(dx, c_inv));
        let one_minus_cos = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(d, d), cy), shared);
        let one_minus_sin = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(dx, dx), cx), shared);
        // edges_of_quadrant(): the parts below φ1 and above φ2
        let half_x2 = _mm256_mul_pd(_mm256_mul_pd(set(0.5), x_inv), x_inv);
        let qx = _mm256_add_pd(
            _mm256_mul_pd(third_cube(sin), half_y2),
            _mm256_mul_pd(cube_tail(one_minus_sin, sin), half_x2),
        );
        let qy = _mm256_add_pd(
            _mm256_mul_pd(cube_tail(one_minus_cos, cos), half_y2),
            _mm256_mul_pd(third_cube(cos), half_x2),
        );
        let q_sum = _mm256_add_pd(
            _mm256_mul_pd(one_minus_cos, inv),
            _mm256_mul_pd(one_minus_sin, x_inv),
        );
        // horizontal_edge(): g −= (sx q.x, sy q.y), s −= the quadrant's sum
        gx = _mm256_sub_pd(gx, _mm256_mul_pd(set(sx), qx));
        gy = _mm256_sub_pd(gy, _mm256_mul_pd(sy, qy));
        sum = _mm256_sub_pd(sum, q_sum);
    }
    let mut v = [[0.0; 4]; 3];
    for (v, lanes) in v.iter_mut().zip([gx, gy, sum]) {
        // SAFETY: each array holds 4 f64.
        unsafe { _mm256_storeu_pd(v.as_mut_ptr(), lanes) };
    }
    let terms = [0, 1, 2, 3].map(|l| (Vector2::new(v[0][l], v[1][l]), v[2][l]));
    (terms, far)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every edge's terms, far or near, below or above the disc, in whole fours or not, are
    /// the bits of [`horizontal_edge`].
    #[test]
    fn lanes_give_the_bits_of_the_scalar_edges() {
        let rc = 0.0428;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let mut heights = [0.0; 4].map(|_| 0.3 * uniform());
            heights.sort_by(f64::total_cmp);
            let at_y = 0.3 * uniform();
            let own = heights.partition_point(|&h| h <= at_y).max(1) - 1;
            let first = (uniform() * 3.0) as usize;
            let sides = (edge(uniform() * 0.1, rc), edge(uniform() * 0.5, rc));
            let count = 1 + (uniform() * 4.0) as usize % 4;
            let got = four_edges(sides, at_y, (first, first + own), heights, count, rc);
            for (l, &(g, s)) in got.iter().enumerate().take(count) {
                let y = edge((at_y - heights[l]).abs(), rc);
                let (eg, es) = horizontal_edge(sides, y, l <= own, rc);
                let bits = |v: f64| v.to_bits();
                assert_eq!(
                    [g.x, g.y, s].map(bits),
                    [eg.x, eg.y, es].map(bits),
                    "edge {l} at {} from {at_y}",
                    heights[l]
                );
            }
        }
    }
}
