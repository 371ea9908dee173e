//! The tile-pair kernels of the single-precision near field ([`super::single`]): a portable
//! loop, eight AVX lanes and sixteen AVX-512 lanes, with the same operations in the same
//! order, so the same bits on every machine.
//!
//! Each particle a of a tile pair's first tile sums its partners b of the second tile in
//! [`LANES`] independent lanes (lane l takes the partners b ≡ l mod 16: one AVX-512 register,
//! two AVX ones), combined as t_k = l_k + l_{k+8} and then ((t0+t1)+(t2+t3))+((t4+t5)+(t6+t7));
//! each b's side of the pair is updated in the same pass (action = reaction).
//!
//! The pair term is d s with s = (c1 r − c2)/(r² r) (the law's d (A1/r² − A2/r³) in scaled
//! units), one square root and one division per pair and five products before the sums.
//! Why this form and the sixteen lanes: the loop is bound by its products and fused
//! multiply-adds as much as by the root and the division (a build without either ran
//! 0.70–0.75 of the time), so each product taken out counts. Against the earlier 1/√r² form,
//! s took 0.92 of the time, skipping the signs' products where every charge is positive 0.82,
//! and AVX-512 0.65 on the AMD EPYC VM (results/bench/README.md, "`blast`: the near field in
//! sixteen lanes").

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use crate::numerics::tiled_pairs::{tile, TilePair};

/// Independent lanes per particle (the AVX-512 register's width; columns are padded to it).
pub(super) const LANES: usize = 16;

/// Particles per tile (a multiple of [`LANES`]).
pub(super) const TILE: usize = 128;

/// One tile pair's single-precision sums.
pub(super) type Sums = TilePair<f32, TILE, 3>;

/// The columns the kernels read: scaled x, y, z and the charge signs c (0 for padding).
pub(super) type Columns = [Vec<f32>; 4];

/// Which kernel fills the tile pairs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Form {
    Portable,
    /// AVX and FMA, eight lanes a register.
    Avx,
    /// AVX-512F, sixteen lanes a register.
    Avx512,
}

impl Form {
    /// The widest form the processor runs (no allocation: called once per evaluation).
    pub(super) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") {
                return Form::Avx512;
            }
            if has!("avx") && has!("fma") {
                return Form::Avx;
            }
        }
        Form::Portable
    }

    /// Every form the processor runs, narrowest first (each AVX-512 processor also has AVX
    /// and FMA).
    #[cfg(test)]
    pub(super) fn available() -> Vec<Self> {
        let all = [Form::Portable, Form::Avx, Form::Avx512];
        let widest = all.iter().position(|&f| f == Self::detect()).unwrap_or(0);
        all[..=widest].to_vec()
    }
}

/// Fills one tile pair with `form` (which the processor must run): i gains d s c_j and j
/// loses d s c_i. `signed`: some sign is −1; otherwise the SIMD forms leave out the products
/// by the signs, which is exact (s · 1 = s; a padding partner's s is +0 or −0, since r² r
/// overflows to +∞ there, so its terms add zeros either way).
pub(super) fn fill(form: Form, at: &Columns, c: (f32, f32), signed: bool, pair: &mut Sums) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `form` is one the processor runs (`Form::detect` or a narrower one).
    unsafe {
        match (form, signed) {
            (Form::Avx, true) => return tile_pair_avx::<true>(at, c, pair),
            (Form::Avx, false) => return tile_pair_avx::<false>(at, c, pair),
            (Form::Avx512, true) => return tile_pair_avx512::<true>(at, c, pair),
            (Form::Avx512, false) => return tile_pair_avx512::<false>(at, c, pair),
            (Form::Portable, _) => {}
        }
    }
    let _ = signed; // the portable loop always multiplies by the signs
    tile_pair(at, c, pair);
}

/// The pair term's scale s for the separation d (scaled), zero at d = 0; the term is d s.
/// Fused multiply-adds where the lanes use them (`mul_add` rounds once, as the instruction
/// does). Beyond r ≈ 7·10¹² diameters r² r overflows and s is 0 (against about 10⁻²⁶).
#[inline(always)]
pub(super) fn pair_scale(d: [f32; 3], (c1, c2): (f32, f32)) -> f32 {
    let r2 = d[2].mul_add(d[2], d[1].mul_add(d[1], d[0] * d[0]));
    let r = r2.sqrt();
    let s = c1.mul_add(r, -c2) / (r2 * r);
    if r2 > 0.0 {
        s
    } else {
        0.0
    }
}

/// The portable form.
fn tile_pair(at: &Columns, c: (f32, f32), pair: &mut Sums) {
    let len = at[0].len();
    let (first, second) = (
        tile::<TILE>(pair.tiles.0, len),
        tile::<TILE>(pair.tiles.1, len),
    );
    pair.on_second = [[0.0; TILE]; 3];
    for (a, i) in first.enumerate() {
        let mut acc = [[0.0f32; LANES]; 3];
        for b in 0..second.len() {
            let j = second.start + b;
            let d: [f32; 3] = std::array::from_fn(|k| at[k][j] - at[k][i]);
            let s = pair_scale(d, c);
            let (on_i, on_j) = (s * at[3][j], s * at[3][i]);
            for ((lanes, side), d) in acc.iter_mut().zip(&mut pair.on_second).zip(d) {
                lanes[b % LANES] = d.mul_add(on_i, lanes[b % LANES]);
                side[b] = (-d).mul_add(on_j, side[b]);
            }
        }
        for (side, lanes) in pair.on_first.iter_mut().zip(acc) {
            side[a] = reduce(std::array::from_fn(|k| lanes[k] + lanes[k + 8]));
        }
    }
}

/// ((t0+t1)+(t2+t3))+((t4+t5)+(t6+t7)).
fn reduce(t: [f32; 8]) -> f32 {
    ((t[0] + t[1]) + (t[2] + t[3])) + ((t[4] + t[5]) + (t[6] + t[7]))
}

/// The eight-lane form: lanes 0–7 and 8–15 in two registers per component.
///
/// # Safety
/// Only where the processor has AVX and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
unsafe fn tile_pair_avx<const SIGNED: bool>(at: &Columns, c: (f32, f32), pair: &mut Sums) {
    let len = at[0].len();
    let (first, second) = (
        tile::<TILE>(pair.tiles.0, len),
        tile::<TILE>(pair.tiles.1, len),
    );
    pair.on_second = [[0.0; TILE]; 3];
    let c = (_mm256_set1_ps(c.0), _mm256_set1_ps(c.1));
    for (a, i) in first.enumerate() {
        let own = at.each_ref().map(|v| _mm256_set1_ps(v[i]));
        let (mut low, mut high) = ([_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3]);
        for b in (0..second.len()).step_by(LANES) {
            let j = second.start + b;
            // SAFETY: the processor has AVX and FMA; the columns hold whole groups of LANES
            // from every tile start.
            unsafe {
                eight::<SIGNED>(at, (&own, c), (j, b), &mut low, &mut pair.on_second);
                eight::<SIGNED>(
                    at,
                    (&own, c),
                    (j + 8, b + 8),
                    &mut high,
                    &mut pair.on_second,
                );
            }
        }
        for ((side, low), high) in pair.on_first.iter_mut().zip(low).zip(high) {
            let mut t = [0.0f32; 8];
            // SAFETY: `t` holds 8 f32.
            unsafe { _mm256_storeu_ps(t.as_mut_ptr(), _mm256_add_ps(low, high)) };
            side[a] = reduce(t);
        }
    }
}

/// Partners j..j + 8 (slots b..b + 8 of the second tile) of the particle at `own`, into the
/// lanes `acc` and the partners' sides.
///
/// # Safety
/// Only where the processor has AVX and FMA; j + 8 ≤ the columns' length, b + 8 ≤ TILE.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
#[inline]
unsafe fn eight<const SIGNED: bool>(
    at: &Columns,
    (own, (c1, c2)): (&[__m256; 4], (__m256, __m256)),
    (j, b): (usize, usize),
    acc: &mut [__m256; 3],
    sides: &mut [[f32; TILE]; 3],
) {
    // SAFETY: as the caller promises.
    let other = at
        .each_ref()
        .map(|v| unsafe { _mm256_loadu_ps(v[j..j + 8].as_ptr()) });
    let d: [__m256; 3] = std::array::from_fn(|k| _mm256_sub_ps(other[k], own[k]));
    let r2 = _mm256_fmadd_ps(
        d[2],
        d[2],
        _mm256_fmadd_ps(d[1], d[1], _mm256_mul_ps(d[0], d[0])),
    );
    let r = _mm256_sqrt_ps(r2);
    let s = _mm256_div_ps(_mm256_fmsub_ps(c1, r, c2), _mm256_mul_ps(r2, r));
    let s = _mm256_and_ps(s, _mm256_cmp_ps::<_CMP_GT_OQ>(r2, _mm256_setzero_ps()));
    let (on_i, on_j) = match SIGNED {
        true => (_mm256_mul_ps(s, other[3]), _mm256_mul_ps(s, own[3])),
        false => (s, s),
    };
    for ((lanes, side), d) in acc.iter_mut().zip(sides).zip(d) {
        *lanes = _mm256_fmadd_ps(d, on_i, *lanes);
        let slot = &mut side[b..b + 8];
        // SAFETY: `slot` holds 8 f32.
        unsafe {
            let running = _mm256_loadu_ps(slot.as_ptr());
            _mm256_storeu_ps(slot.as_mut_ptr(), _mm256_fnmadd_ps(d, on_j, running));
        }
    }
}

/// The sixteen-lane form.
///
/// # Safety
/// Only where the processor has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn tile_pair_avx512<const SIGNED: bool>(
    at: &Columns,
    (c1, c2): (f32, f32),
    pair: &mut Sums,
) {
    let len = at[0].len();
    let (first, second) = (
        tile::<TILE>(pair.tiles.0, len),
        tile::<TILE>(pair.tiles.1, len),
    );
    pair.on_second = [[0.0; TILE]; 3];
    let (c1, c2, zero) = (_mm512_set1_ps(c1), _mm512_set1_ps(c2), _mm512_setzero_ps());
    for (a, i) in first.enumerate() {
        let own = at.each_ref().map(|v| _mm512_set1_ps(v[i]));
        let mut acc = [zero; 3];
        for b in (0..second.len()).step_by(LANES) {
            let j = second.start + b;
            // SAFETY: the columns hold whole groups of LANES from every tile start.
            let other = at
                .each_ref()
                .map(|v| unsafe { _mm512_loadu_ps(v[j..j + LANES].as_ptr()) });
            let d: [__m512; 3] = std::array::from_fn(|k| _mm512_sub_ps(other[k], own[k]));
            let r2 = _mm512_fmadd_ps(
                d[2],
                d[2],
                _mm512_fmadd_ps(d[1], d[1], _mm512_mul_ps(d[0], d[0])),
            );
            let r = _mm512_sqrt_ps(r2);
            let s = _mm512_div_ps(_mm512_fmsub_ps(c1, r, c2), _mm512_mul_ps(r2, r));
            let s = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(r2, zero), s);
            let (on_i, on_j) = match SIGNED {
                true => (_mm512_mul_ps(s, other[3]), _mm512_mul_ps(s, own[3])),
                false => (s, s),
            };
            for ((lanes, side), d) in acc.iter_mut().zip(&mut pair.on_second).zip(d) {
                *lanes = _mm512_fmadd_ps(d, on_i, *lanes);
                let slot = &mut side[b..b + LANES];
                // SAFETY: `slot` holds 16 f32.
                unsafe {
                    let running = _mm512_loadu_ps(slot.as_ptr());
                    _mm512_storeu_ps(slot.as_mut_ptr(), _mm512_fnmadd_ps(d, on_j, running));
                }
            }
        }
        for (side, lanes) in pair.on_first.iter_mut().zip(acc) {
            let low = _mm512_castps512_ps256(lanes);
            let high = _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(lanes)));
            let mut t = [0.0f32; 8];
            // SAFETY: `t` holds 8 f32.
            unsafe { _mm256_storeu_ps(t.as_mut_ptr(), _mm256_add_ps(low, high)) };
            side[a] = reduce(t);
        }
    }
}
