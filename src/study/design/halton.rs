//! Halton sequence (Halton 1960): coordinate `j` of point `i` is the radical inverse of `i` in
//! the `j`-th prime base.
//!
//! Scrambling replaces every digit `d` at position `k` of coordinate `j` by `π_{j,k}(d)`, with
//! independent uniformly random permutations `π_{j,k}` of `0..b_j` drawn from the seed (random
//! digit permutation, the non-nested permutation scramble of Matoušek 1998, J. Complexity 14,
//! 527–556; Owen's nested scramble would also make π depend on the digits above). The
//! permutation applies to the trailing zero digits as well, for as many digits as an `f64`
//! resolves, so scrambled points are not confined to a `b^-k` grid. It keeps every
//! stratification of the sequence: the first `b^k` points put one point in each interval of
//! width `b^-k`, and the first `2^k1 · 3^k2` points one in each `2^-k1 × 3^-k2` box of
//! dimensions 1 and 2. The first point (the origin) is skipped only when unscrambled.
//!
//! Halton's higher dimensions (large bases) are correlated in short prefixes; prefer Sobol'
//! above a dozen dimensions.

use super::{shuffle, stream, Stream};

/// The most dimensions [`halton`] supports (the first 1000 primes, up to 7919).
pub const MAX_DIMS: usize = 1000;

/// The first `count` primes.
pub fn primes(count: usize) -> Vec<u64> {
    let mut primes: Vec<u64> = Vec::with_capacity(count);
    let mut candidate = 2u64;
    while primes.len() < count {
        if primes
            .iter()
            .take_while(|&&p| p * p <= candidate)
            .all(|&p| !candidate.is_multiple_of(p))
        {
            primes.push(candidate);
        }
        candidate += 1;
    }
    primes
}

/// `n` points of the Halton sequence in `dims` dimensions, in `[0, 1)`.
///
/// `scramble: Some(seed)` gives randomly digit-permuted points from index 0; `None` the plain
/// sequence without its first point (the origin): 1/2, 1/4, 3/4, 1/8, … in base 2 and 1/3,
/// 2/3, 1/9, 4/9, … in base 3. Errors for `dims` outside `1..=MAX_DIMS`.
pub fn halton(n: usize, dims: usize, scramble: Option<u64>) -> Result<Vec<Vec<f64>>, String> {
    halton_points(n, dims, scramble, scramble.is_none())
}

/// The generator: `skip_first` drops index 0.
pub(crate) fn halton_points(
    n: usize,
    dims: usize,
    scramble: Option<u64>,
    skip_first: bool,
) -> Result<Vec<Vec<f64>>, String> {
    if dims == 0 || dims > MAX_DIMS {
        return Err(format!(
            "the Halton sequence supports 1 to {MAX_DIMS} dimensions, not {dims}"
        ));
    }
    let bases = primes(dims);
    // Digits that an f64 resolves in base b: b^-K < 2^-53.
    let digits = |b: u64| (53.0 / (b as f64).log2()).ceil() as usize + 1;
    let perms: Option<Vec<Vec<Vec<u64>>>> = scramble.map(|seed| {
        let mut rng = stream(seed, Stream::HaltonScramble);
        bases
            .iter()
            .map(|&b| {
                (0..digits(b))
                    .map(|_| {
                        let mut p: Vec<u64> = (0..b).collect();
                        shuffle(&mut p, &mut rng);
                        p
                    })
                    .collect()
            })
            .collect()
    });
    let skip = usize::from(skip_first);
    let points = (skip..n + skip)
        .map(|i| {
            bases
                .iter()
                .enumerate()
                .map(|(j, &b)| match &perms {
                    None => radical_inverse(i as u64, b),
                    Some(perms) => permuted_radical_inverse(i as u64, b, &perms[j]),
                })
                .collect()
        })
        .collect();
    Ok(points)
}

/// The radical inverse of `i` in base `b`: its digits mirrored about the radix point.
pub fn radical_inverse(mut i: u64, b: u64) -> f64 {
    let inv = 1.0 / b as f64;
    let (mut x, mut scale) = (0.0, inv);
    while i > 0 {
        x += (i % b) as f64 * scale;
        i /= b;
        scale *= inv;
    }
    x
}

/// The radical inverse with digit `k` replaced by `perms[k][digit]`, over all `perms.len()`
/// digits (the zeros above the leading digit of `i` included); below 1.
fn permuted_radical_inverse(mut i: u64, b: u64, perms: &[Vec<u64>]) -> f64 {
    // Digits as an integer first, least significant position last, to keep the sum exact as
    // long as it fits; the tail beyond f64 precision only rounds.
    let inv = 1.0 / b as f64;
    let mut digits = Vec::with_capacity(perms.len());
    for perm in perms {
        digits.push(perm[(i % b) as usize]);
        i /= b;
    }
    let x = digits
        .iter()
        .rev()
        .fold(0.0, |acc, &d| (acc + d as f64) * inv);
    x.min(1.0 - f64::EPSILON / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_first_points_in_bases_two_and_three() {
        let p = halton(8, 2, None).unwrap();
        let base2 = [0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875, 0.0625];
        let base3 = [
            1.0,
            2.0,
            1.0 / 3.0,
            4.0 / 3.0,
            7.0 / 3.0,
            2.0 / 3.0,
            5.0 / 3.0,
            8.0 / 3.0,
        ];
        for (k, x) in p.iter().enumerate() {
            assert_eq!(x[0], base2[k]);
            assert!((x[1] - base3[k] / 3.0).abs() < 1e-15, "{k}: {}", x[1]);
        }
        assert_eq!(primes(6), vec![2, 3, 5, 7, 11, 13]);
        assert_eq!(primes(MAX_DIMS)[MAX_DIMS - 1], 7919);
    }

    #[test]
    fn prefixes_of_powers_of_the_base_are_stratified() {
        for scramble in [None, Some(3), Some(4)] {
            let p = halton_points(3125, 5, scramble, false).unwrap();
            for (j, b) in primes(5).into_iter().enumerate() {
                let k = (3125f64.ln() / (b as f64).ln()).floor() as u32;
                let cells = b.pow(k) as usize;
                let mut counts = vec![0; cells];
                for x in &p[..cells] {
                    assert!((0.0..1.0).contains(&x[j]));
                    // A hair up: unscrambled points sit on the left edges, which rounding may miss.
                    counts[(x[j] * cells as f64 + 1e-9) as usize] += 1;
                }
                assert!(counts.iter().all(|&c| c == 1), "base {b} {scramble:?}");
            }
            // 2^4 · 3^3 points: one in every 2^-4 × 3^-3 box of dimensions 1 and 2.
            let n = 16 * 27;
            let mut boxes = vec![0; n];
            for x in &p[..n] {
                boxes[(x[0] * 16.0 + 1e-9) as usize * 27 + (x[1] * 27.0 + 1e-9) as usize] += 1;
            }
            assert!(boxes.iter().all(|&c| c == 1), "{scramble:?}");
        }
    }

    #[test]
    fn scrambling_changes_the_points_reproducibly() {
        let a = halton(100, 4, Some(9)).unwrap();
        assert_eq!(a, halton(100, 4, Some(9)).unwrap());
        assert_ne!(a, halton(100, 4, Some(10)).unwrap());
        assert_ne!(a, halton_points(100, 4, None, false).unwrap());
        let mean = a.iter().flatten().sum::<f64>() / 400.0;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
        assert!(halton(1, 0, None).is_err());
    }
}
