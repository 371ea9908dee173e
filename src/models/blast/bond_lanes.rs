//! The bonded pairs' law (C4–C7, [`PairLaw::contact`] with a bond) four pairs per AVX
//! instruction, with the scalar law's bits.
//!
//! Why: a bonded pair costs two square roots and seven divisions (the distance, the strain,
//! the normal, the slip speed and its direction), which the scalar law issues one at a time.
//! The lanes take every branch of the law (compression or tension, stick or slip, a slip or
//! none) and select per lane, with the scalar law's operations in its order and nothing
//! fused; a term a lane does not take is selected away, never added as zero (which could
//! flip the sign of a zero). The bond's power (−ε)^{p_b} is the library's `powf`, per
//! lane, as in the scalar law (for p_b = 2 mostly x·x, where that is provably `powf`'s
//! result). Test: `four_lanes_give_the_bits_of_the_scalar_law`.

#![cfg(target_arch = "x86_64")]

use nalgebra::Vector3;
use std::arch::x86_64::*;
use std::f64::consts::PI;

use super::cloud::Cloud;
use super::pairs::{PairLaw, Wrench};

/// Three components in four lanes.
type V = [__m256d; 3];

/// The wrenches on the first particle of four bonded pairs (i, j, area at bonding), written
/// into `out` (in place: a returned array cost a library copy per call).
///
/// # Safety
/// Only where the processor has AVX.
#[target_feature(enable = "avx")]
pub unsafe fn four_wrenches(
    law: &PairLaw,
    cloud: &Cloud,
    dt: f64,
    pairs: &[(u32, u32, f64); 4],
    out: &mut [Wrench; 4],
) {
    // the 18 coordinates of each pair's two bodies, one row per coordinate
    let mut rows = [[0.0; 4]; 19];
    for (k, &(i, j, area)) in pairs.iter().enumerate() {
        let fields = [&cloud.positions, &cloud.velocities, &cloud.spins];
        for (f, of) in fields.into_iter().enumerate() {
            let (a, b) = (&of[i as usize], &of[j as usize]);
            for c in 0..3 {
                rows[6 * f + c][k] = a[c];
                rows[6 * f + 3 + c][k] = b[c];
            }
        }
        rows[18][k] = area;
    }
    let mut v = [_mm256_setzero_pd(); 19];
    for (v, row) in v.iter_mut().zip(&rows) {
        // SAFETY: each row holds 4 f64.
        *v = unsafe { _mm256_loadu_pd(row.as_ptr()) };
    }
    let three = |at: usize| -> V { [v[at], v[at + 1], v[at + 2]] };
    let (pi, pj, vi, vj, wi, wj) = (three(0), three(3), three(6), three(9), three(12), three(15));
    let bond_area = v[18];
    let (force, moment) = law_lanes(law, dt, [pi, pj, vi, vj, wi, wj], bond_area);
    let mut values = [[0.0; 4]; 6];
    for (row, lanes) in values.iter_mut().zip(force.iter().chain(&moment)) {
        // SAFETY: each row holds 4 f64.
        unsafe { _mm256_storeu_pd(row.as_mut_ptr(), *lanes) };
    }
    for (k, w) in out.iter_mut().enumerate() {
        w.0 = Vector3::new(values[0][k], values[1][k], values[2][k]);
        w.1 = Vector3::new(values[3][k], values[4][k], values[5][k]);
    }
}

/// [`PairLaw::contact`] with a bond of area `bond_area`, on four lanes; the bodies are
/// [r_i, r_j, v_i, v_j, ω_i, ω_j].
#[target_feature(enable = "avx")]
fn law_lanes(law: &PairLaw, dt: f64, bodies: [V; 6], bond_area: __m256d) -> (V, V) {
    let [pi, pj, vi, vj, wi, wj] = bodies;
    let c = &law.contact;
    let s = _mm256_set1_pd;
    let zero = _mm256_setzero_pd();
    let d = sub(pj, pi);
    let dist = _mm256_sqrt_pd(dot(d, d));
    let two_r = s(2.0 * law.radius);
    let strain = _mm256_div_pd(_mm256_sub_pd(two_r, dist), two_r);
    let n = divide(d, dist);
    let lever = _mm256_mul_pd(s(0.5), dist);
    let r2 = s(law.radius * law.radius);
    let area = _mm256_max_pd(
        _mm256_mul_pd(s(PI), _mm256_sub_pd(r2, _mm256_mul_pd(lever, lever))),
        zero,
    );
    let compressed = _mm256_cmp_pd::<_CMP_GT_OQ>(strain, zero);
    let mut force = [zero; 3];
    let mut normal = zero;
    if law.flags.contact {
        let pressed = power(strain, c.exponent, compressed);
        normal = select(
            compressed,
            _mm256_mul_pd(_mm256_mul_pd(s(law.stiffness), pressed), area),
            zero,
        );
        let push = scale(normal, n);
        force = add_where(compressed, force, push, true);
    }
    if law.flags.damping {
        let closing = dot(sub(vj, vi), n);
        let size = _mm256_mul_pd(_mm256_mul_pd(s(c.damping), closing), area);
        force = add_where(compressed, force, scale(size, n), false);
    }
    let slip = tangential_slip([vi, vj, wi, wj], n, lever);
    let slip_speed = _mm256_sqrt_pd(dot(slip, slip));
    let slipping = _mm256_cmp_pd::<_CMP_GT_OQ>(slip_speed, zero);
    let tau = divide(slip, slip_speed);
    if law.flags.friction {
        let stick = _mm256_mul_pd(
            _mm256_mul_pd(_mm256_mul_pd(s(c.friction_stiffness), slip_speed), area),
            s(dt),
        );
        let limit = _mm256_mul_pd(s(c.static_friction), normal);
        let sliding = _mm256_mul_pd(s(c.dynamic_friction), normal);
        let size = select(_mm256_cmp_pd::<_CMP_LT_OQ>(stick, limit), stick, sliding);
        force = add_where(
            _mm256_and_pd(slipping, compressed),
            force,
            scale(size, tau),
            false,
        );
    }
    let drag = _mm256_mul_pd(
        _mm256_mul_pd(_mm256_mul_pd(s(c.bond_tangential), slip_speed), bond_area),
        s(dt),
    );
    force = add_where(slipping, force, scale(drag, tau), false);
    let stretched = _mm256_cmp_pd::<_CMP_LT_OQ>(strain, zero);
    let pull = bond_power(negate(strain), c.bond_exponent, stretched);
    let size = _mm256_mul_pd(_mm256_mul_pd(s(c.bond_stiffness), pull), bond_area);
    force = add_where(stretched, force, scale(size, n), false);
    let along = dot(force, n);
    let tangential = sub(force, scale(along, n));
    let moment = if law.flags.rotation {
        cross(scale(lever, n), tangential)
    } else {
        [zero; 3]
    };
    let apart = _mm256_cmp_pd::<_CMP_NEQ_UQ>(dist, zero);
    (
        select3(apart, force, [zero; 3]),
        select3(apart, moment, [zero; 3]),
    )
}

/// v^c_{j,τ} − v^c_{i,τ} for [v_i, v_j, ω_i, ω_j], as `PairLaw::tangential_slip`.
#[target_feature(enable = "avx")]
fn tangential_slip(motion: [V; 4], n: V, lever: __m256d) -> V {
    let [vi, vj, wi, wj] = motion;
    let at_i = add(vi, cross(wi, scale(lever, n)));
    let at_j = add(vj, cross(wj, scale(negate(lever), n)));
    let rel = sub(at_j, at_i);
    sub(rel, scale(dot(rel, n), n))
}

/// x^p as the scalar law's `power` (products for p = 1, 2, 3, else `powf` per lane where
/// `used`; elsewhere 0).
#[target_feature(enable = "avx")]
fn power(x: __m256d, p: f64, used: __m256d) -> __m256d {
    match p {
        1.0 => x,
        2.0 => _mm256_mul_pd(x, x),
        3.0 => _mm256_mul_pd(_mm256_mul_pd(x, x), x),
        _ => bond_power(x, p, used),
    }
}

/// x.powf(p) per lane where `used`, else 0 (for p = 2 by [`square_as_pow`] where the
/// processor has FMA).
#[target_feature(enable = "avx")]
fn bond_power(x: __m256d, p: f64, used: __m256d) -> __m256d {
    if p == 2.0 && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has AVX (this function's feature) and FMA (just checked)
        return unsafe { square_as_pow(x, used) };
    }
    pow_lanes(x, p, used)
}

/// x.powf(2.0) per lane where `used`, else 0, with `powf`'s bits but mostly without it.
///
/// Why: the library's pow (glibc's and musl's, from Arm's optimized routines) is within
/// 0.54 ULP of the exact x^y, not correctly rounded, so x·x may differ from it and the
/// scalar law keeps `powf`. But where the exact square lies within 0.4 ULP of the rounded
/// product p = x·x (its rounding error x·x − p is exact by a fused multiply-add), every
/// other double is more than 0.6 ULP away, and pow must return p. Elsewhere (within 0.1 ULP
/// of a rounding midpoint, p a power of two, zero, subnormal, infinite or NaN) the lane
/// calls `powf`: about one lane in five. Test: `square_as_pow_gives_the_bits_of_powf`.
///
/// # Safety
/// Only where the processor has AVX and FMA.
#[target_feature(enable = "avx,fma")]
unsafe fn square_as_pow(x: __m256d, used: __m256d) -> __m256d {
    let product = _mm256_mul_pd(x, x);
    let error = _mm256_fmsub_pd(x, x, product);
    // 2^E for a product in [2^E, 2^(E+1)): its exponent bits alone; its ULP is 2^E · 2^-52
    let binade = _mm256_and_pd(product, _mm256_set1_pd(f64::INFINITY));
    let limit = _mm256_mul_pd(binade, _mm256_set1_pd(0.4 * f64::EPSILON));
    let size = _mm256_andnot_pd(_mm256_set1_pd(-0.0), error);
    let rounded = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_LT_OQ>(size, limit),
        _mm256_cmp_pd::<_CMP_NEQ_OQ>(product, binade),
    );
    let by_pow = _mm256_andnot_pd(rounded, used);
    let quick = _mm256_and_pd(_mm256_and_pd(rounded, used), product);
    if _mm256_movemask_pd(by_pow) == 0 {
        return quick;
    }
    _mm256_blendv_pd(quick, pow_lanes(x, 2.0, by_pow), by_pow)
}

/// x.powf(p) per lane where `used`, else 0.
#[target_feature(enable = "avx")]
fn pow_lanes(x: __m256d, p: f64, used: __m256d) -> __m256d {
    // the library's pow even where p is known: LLVM turns pow(x, 2.0) into x·x
    let p = std::hint::black_box(p);
    let (mut v, mut m) = ([0.0; 4], [0.0; 4]);
    // SAFETY: both arrays hold 4 f64.
    unsafe {
        _mm256_storeu_pd(v.as_mut_ptr(), x);
        _mm256_storeu_pd(m.as_mut_ptr(), used);
    }
    let r: [f64; 4] = std::array::from_fn(|k| if m[k] != 0.0 { v[k].powf(p) } else { 0.0 });
    // SAFETY: `r` holds 4 f64.
    unsafe { _mm256_loadu_pd(r.as_ptr()) }
}

/// Where `mask`: `running + term` (`running − term` when `subtract`, as `-=` computes it);
/// elsewhere `running` unchanged.
#[target_feature(enable = "avx")]
fn add_where(mask: __m256d, running: V, term: V, subtract: bool) -> V {
    let next = if subtract {
        sub(running, term)
    } else {
        add(running, term)
    };
    select3(mask, next, running)
}

/// `yes` where `mask`, else `no`.
#[target_feature(enable = "avx")]
fn select(mask: __m256d, yes: __m256d, no: __m256d) -> __m256d {
    _mm256_blendv_pd(no, yes, mask)
}

#[target_feature(enable = "avx")]
fn negate(x: __m256d) -> __m256d {
    _mm256_xor_pd(x, _mm256_set1_pd(-0.0))
}

#[target_feature(enable = "avx")]
fn add(a: V, b: V) -> V {
    [
        _mm256_add_pd(a[0], b[0]),
        _mm256_add_pd(a[1], b[1]),
        _mm256_add_pd(a[2], b[2]),
    ]
}

#[target_feature(enable = "avx")]
fn sub(a: V, b: V) -> V {
    [
        _mm256_sub_pd(a[0], b[0]),
        _mm256_sub_pd(a[1], b[1]),
        _mm256_sub_pd(a[2], b[2]),
    ]
}

/// s v, componentwise.
#[target_feature(enable = "avx")]
fn scale(s: __m256d, v: V) -> V {
    [
        _mm256_mul_pd(s, v[0]),
        _mm256_mul_pd(s, v[1]),
        _mm256_mul_pd(s, v[2]),
    ]
}

/// v / s, componentwise.
#[target_feature(enable = "avx")]
fn divide(v: V, s: __m256d) -> V {
    [
        _mm256_div_pd(v[0], s),
        _mm256_div_pd(v[1], s),
        _mm256_div_pd(v[2], s),
    ]
}

/// `yes` where `mask`, else `no`, componentwise.
#[target_feature(enable = "avx")]
fn select3(mask: __m256d, yes: V, no: V) -> V {
    [
        select(mask, yes[0], no[0]),
        select(mask, yes[1], no[1]),
        select(mask, yes[2], no[2]),
    ]
}

/// (a_x b_x + a_y b_y) + a_z b_z, nalgebra's order.
#[target_feature(enable = "avx")]
fn dot(a: V, b: V) -> __m256d {
    let xy = _mm256_add_pd(_mm256_mul_pd(a[0], b[0]), _mm256_mul_pd(a[1], b[1]));
    _mm256_add_pd(xy, _mm256_mul_pd(a[2], b[2]))
}

/// a × b, nalgebra's formula.
#[target_feature(enable = "avx")]
fn cross(a: V, b: V) -> V {
    let m = _mm256_mul_pd;
    [
        _mm256_sub_pd(m(a[1], b[2]), m(a[2], b[1])),
        _mm256_sub_pd(m(a[2], b[0]), m(a[0], b[2])),
        _mm256_sub_pd(m(a[0], b[1]), m(a[1], b[0])),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A million squares over the strains a bond meets and over twenty decades, with zero,
    /// a power of two, a subnormal, infinity and NaN: each lane is `powf(x, 2.0)`'s bits (or
    /// 0 where unused). (Python's `math.pow` on this machine's glibc differs from x·x for 8
    /// in 10⁴ strains in [0, 0.2), so the fallback is exercised.)
    #[test]
    fn square_as_pow_gives_the_bits_of_powf() {
        if !(crate::numerics::has_avx() && std::arch::is_x86_feature_detected!("fma")) {
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let special = [0.0, 0.5, 1e-160, f64::INFINITY, f64::NAN, -0.03];
        for k in 0..250_000 {
            let x: [f64; 4] = std::array::from_fn(|l| match (k, l) {
                (0, _) => special[l],
                (1, 0 | 1) => special[4 + l],
                _ if l % 2 == 0 => 0.2 * rng.random::<f64>(),
                _ => 10f64.powf(20.0 * rng.random::<f64>() - 10.0),
            });
            let used: [f64; 4] = std::array::from_fn(|l| {
                if (k + l) % 7 == 0 {
                    0.0
                } else {
                    f64::from_bits(u64::MAX)
                }
            });
            let mut out = [0.0; 4];
            // SAFETY: AVX and FMA checked above; the arrays hold 4 f64
            unsafe {
                let got =
                    square_as_pow(_mm256_loadu_pd(x.as_ptr()), _mm256_loadu_pd(used.as_ptr()));
                _mm256_storeu_pd(out.as_mut_ptr(), got);
            }
            for l in 0..4 {
                let two = std::hint::black_box(2.0);
                let want = if used[l] == 0.0 { 0.0 } else { x[l].powf(two) };
                assert_eq!(out[l].to_bits(), want.to_bits(), "x = {:e}", x[l]);
            }
        }
    }
}
