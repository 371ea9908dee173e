//! Shuffles shared by the AVX pair kernels.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// The 4 × 4 transpose of four registers of four f64: lane k of register c becomes lane c of
/// register k (columns of four entries into one row per entry, or back). Shuffles only, so
/// every bit is kept.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub unsafe fn transpose4([c0, c1, c2, c3]: [__m256d; 4]) -> [__m256d; 4] {
    let (a, b) = (_mm256_unpacklo_pd(c0, c1), _mm256_unpackhi_pd(c0, c1));
    let (c, d) = (_mm256_unpacklo_pd(c2, c3), _mm256_unpackhi_pd(c2, c3));
    [
        _mm256_permute2f128_pd::<0x20>(a, c),
        _mm256_permute2f128_pd::<0x20>(b, d),
        _mm256_permute2f128_pd::<0x31>(a, c),
        _mm256_permute2f128_pd::<0x31>(b, d),
    ]
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// Entry (c, k) lands at (k, c), and transposing twice gives the registers back.
    #[test]
    fn transpose4_swaps_registers_and_lanes() {
        if !crate::numerics::has_avx() {
            return;
        }
        let value = |c: usize, k: usize| (10 * c + k) as f64;
        let columns: [[f64; 4]; 4] = std::array::from_fn(|c| std::array::from_fn(|k| value(c, k)));
        // SAFETY: the processor has AVX, and each array holds 4 f64.
        let (rows, back) = unsafe {
            let v = columns.map(|c| _mm256_loadu_pd(c.as_ptr()));
            let t = transpose4(v);
            (t.map(unload), transpose4(t).map(unload))
        };
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(*row, std::array::from_fn(|c| value(c, k)), "row {k}");
        }
        assert_eq!(back, columns);
    }

    fn unload(v: __m256d) -> [f64; 4] {
        let mut out = [0.0; 4];
        // SAFETY: `out` holds 4 f64 (the caller has AVX).
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    }
}
