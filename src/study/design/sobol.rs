//! Sobol' sequence (Sobol' 1967) with the Joe & Kuo (2008) direction numbers and Owen (1998)
//! nested uniform scrambling.
//!
//! Direction numbers: the first 64 dimensions of `new-joe-kuo-6.21201` (S. Joe and F. Y. Kuo,
//! "Constructing Sobol sequences with better two-dimensional projections", SIAM J. Sci.
//! Comput. 30 (2008) 2635–2654; file at <https://web.maths.unsw.edu.au/~fkuo/sobol/>),
//! embedded below as `(s, a, m_1 … m_s)`; dimension 1 is the van der Corput sequence and needs
//! no row. Points are generated in Gray-code order (Antonov & Saleev 1979), which visits the
//! same set as the natural order in every prefix of 2^k points, with 32-bit direction numbers,
//! so at most 2^32 points.
//!
//! Scrambling is Owen's nested uniform scramble (Owen 1995/1998), not a linear matrix scramble:
//! digit `k` of a coordinate is flipped by a bit that depends on the seed, the dimension and
//! all digits above `k`, for the 53 digits an `f64` holds. The flip bits are a keyed hash of
//! the node of the binary tree (the hash-based form of Burley 2020, with a full 64-bit hash
//! per node), keyed per dimension from the design seed. Each scrambled point is uniform on the
//! cube and every elementary-interval property of the unscrambled net is kept. The first point
//! (the origin) is skipped only when unscrambled.

use rand::RngExt;

use super::{stream, Stream};

/// Joe & Kuo `new-joe-kuo-6.21201`, dimensions 2 to 64: degree `s` of the primitive
/// polynomial, its inner coefficients `a` (bits, highest degree first) and the initial
/// direction numbers `m_1 … m_s`.
const JOE_KUO: [(u32, u32, &[u32]); MAX_DIMS - 1] = [
    (1, 0, &[1]),                                  // dimension 2
    (2, 1, &[1, 3]),                               // dimension 3
    (3, 1, &[1, 3, 1]),                            // dimension 4
    (3, 2, &[1, 1, 1]),                            // dimension 5
    (4, 1, &[1, 1, 3, 3]),                         // dimension 6
    (4, 4, &[1, 3, 5, 13]),                        // dimension 7
    (5, 2, &[1, 1, 5, 5, 17]),                     // dimension 8
    (5, 4, &[1, 1, 5, 5, 5]),                      // dimension 9
    (5, 7, &[1, 1, 7, 11, 19]),                    // dimension 10
    (5, 11, &[1, 1, 5, 1, 1]),                     // dimension 11
    (5, 13, &[1, 1, 1, 3, 11]),                    // dimension 12
    (5, 14, &[1, 3, 5, 5, 31]),                    // dimension 13
    (6, 1, &[1, 3, 3, 9, 7, 49]),                  // dimension 14
    (6, 13, &[1, 1, 1, 15, 21, 21]),               // dimension 15
    (6, 16, &[1, 3, 1, 13, 27, 49]),               // dimension 16
    (6, 19, &[1, 1, 1, 15, 7, 5]),                 // dimension 17
    (6, 22, &[1, 3, 1, 15, 13, 25]),               // dimension 18
    (6, 25, &[1, 1, 5, 5, 19, 61]),                // dimension 19
    (7, 1, &[1, 3, 7, 11, 23, 15, 103]),           // dimension 20
    (7, 4, &[1, 3, 7, 13, 13, 15, 69]),            // dimension 21
    (7, 7, &[1, 1, 3, 13, 7, 35, 63]),             // dimension 22
    (7, 8, &[1, 3, 5, 9, 1, 25, 53]),              // dimension 23
    (7, 14, &[1, 3, 1, 13, 9, 35, 107]),           // dimension 24
    (7, 19, &[1, 3, 1, 5, 27, 61, 31]),            // dimension 25
    (7, 21, &[1, 1, 5, 11, 19, 41, 61]),           // dimension 26
    (7, 28, &[1, 3, 5, 3, 3, 13, 69]),             // dimension 27
    (7, 31, &[1, 1, 7, 13, 1, 19, 1]),             // dimension 28
    (7, 32, &[1, 3, 7, 5, 13, 19, 59]),            // dimension 29
    (7, 37, &[1, 1, 3, 9, 25, 29, 41]),            // dimension 30
    (7, 41, &[1, 3, 5, 13, 23, 1, 55]),            // dimension 31
    (7, 42, &[1, 3, 7, 3, 13, 59, 17]),            // dimension 32
    (7, 50, &[1, 3, 1, 3, 5, 53, 69]),             // dimension 33
    (7, 55, &[1, 1, 5, 5, 23, 33, 13]),            // dimension 34
    (7, 56, &[1, 1, 7, 7, 1, 61, 123]),            // dimension 35
    (7, 59, &[1, 1, 7, 9, 13, 61, 49]),            // dimension 36
    (7, 62, &[1, 3, 3, 5, 3, 55, 33]),             // dimension 37
    (8, 14, &[1, 3, 1, 15, 31, 13, 49, 245]),      // dimension 38
    (8, 21, &[1, 3, 5, 15, 31, 59, 63, 97]),       // dimension 39
    (8, 22, &[1, 3, 1, 11, 11, 11, 77, 249]),      // dimension 40
    (8, 38, &[1, 3, 1, 11, 27, 43, 71, 9]),        // dimension 41
    (8, 47, &[1, 1, 7, 15, 21, 11, 81, 45]),       // dimension 42
    (8, 49, &[1, 3, 7, 3, 25, 31, 65, 79]),        // dimension 43
    (8, 50, &[1, 3, 1, 1, 19, 11, 3, 205]),        // dimension 44
    (8, 52, &[1, 1, 5, 9, 19, 21, 29, 157]),       // dimension 45
    (8, 56, &[1, 3, 7, 11, 1, 33, 89, 185]),       // dimension 46
    (8, 67, &[1, 3, 3, 3, 15, 9, 79, 71]),         // dimension 47
    (8, 70, &[1, 3, 7, 11, 15, 39, 119, 27]),      // dimension 48
    (8, 84, &[1, 1, 3, 1, 11, 31, 97, 225]),       // dimension 49
    (8, 97, &[1, 1, 1, 3, 23, 43, 57, 177]),       // dimension 50
    (8, 103, &[1, 3, 7, 7, 17, 17, 37, 71]),       // dimension 51
    (8, 115, &[1, 3, 1, 5, 27, 63, 123, 213]),     // dimension 52
    (8, 122, &[1, 1, 3, 5, 11, 43, 53, 133]),      // dimension 53
    (9, 8, &[1, 3, 5, 5, 29, 17, 47, 173, 479]),   // dimension 54
    (9, 13, &[1, 3, 3, 11, 3, 1, 109, 9, 69]),     // dimension 55
    (9, 16, &[1, 1, 1, 5, 17, 39, 23, 5, 343]),    // dimension 56
    (9, 22, &[1, 3, 1, 5, 25, 15, 31, 103, 499]),  // dimension 57
    (9, 25, &[1, 1, 1, 11, 11, 17, 63, 105, 183]), // dimension 58
    (9, 44, &[1, 1, 5, 11, 9, 29, 97, 231, 363]),  // dimension 59
    (9, 47, &[1, 1, 5, 15, 19, 45, 41, 7, 383]),   // dimension 60
    (9, 52, &[1, 3, 7, 7, 31, 19, 83, 137, 221]),  // dimension 61
    (9, 55, &[1, 1, 1, 3, 23, 15, 111, 223, 83]),  // dimension 62
    (9, 59, &[1, 1, 5, 13, 31, 15, 55, 25, 161]),  // dimension 63
    (9, 62, &[1, 1, 3, 13, 25, 47, 39, 87, 257]),  // dimension 64
];

/// The most dimensions [`sobol`] supports (the embedded table).
pub const MAX_DIMS: usize = 64;

/// Bits of the direction numbers: at most 2^BITS points.
const BITS: usize = 32;

/// The direction numbers of one dimension, top-aligned in a `u64` (bit 63 is 1/2).
fn directions(dim: usize) -> [u64; BITS] {
    let mut v = [0u64; BITS];
    if dim == 0 {
        for (k, vk) in v.iter_mut().enumerate() {
            *vk = 1u64 << (63 - k);
        }
        return v;
    }
    let (s, a, m) = JOE_KUO[dim - 1];
    let s = s as usize;
    for k in 0..BITS {
        v[k] = if k < s {
            u64::from(m[k]) << (63 - k)
        } else {
            let mut x = v[k - s] ^ (v[k - s] >> s);
            for l in 1..s {
                if (a >> (s - 1 - l)) & 1 == 1 {
                    x ^= v[k - l];
                }
            }
            x
        };
    }
    v
}

/// `n` points of the Sobol' sequence in `dims` dimensions, in `[0, 1)`.
///
/// `scramble: Some(seed)` gives Owen-scrambled points (all `n` from index 0, so `n = 2^m`
/// points form a scrambled (t, m, s)-net); `None` gives the plain sequence without its first
/// point (the origin), i.e. 0.5, 0.75, 0.25, 0.375, … in the first dimension. Errors for
/// `dims` outside `1..=MAX_DIMS` or more than 2^32 points.
pub fn sobol(n: usize, dims: usize, scramble: Option<u64>) -> Result<Vec<Vec<f64>>, String> {
    sobol_points(n, dims, scramble, scramble.is_none())
}

/// The generator: `skip_first` drops index 0.
pub(crate) fn sobol_points(
    n: usize,
    dims: usize,
    scramble: Option<u64>,
    skip_first: bool,
) -> Result<Vec<Vec<f64>>, String> {
    if dims == 0 || dims > MAX_DIMS {
        return Err(format!(
            "the Sobol' sequence supports 1 to {MAX_DIMS} dimensions, not {dims}"
        ));
    }
    let skip = usize::from(skip_first);
    if (n + skip) as u128 > 1u128 << BITS {
        return Err(format!(
            "the Sobol' sequence supports at most 2^{BITS} points, not {n}"
        ));
    }
    let v: Vec<[u64; BITS]> = (0..dims).map(directions).collect();
    let keys: Option<Vec<u64>> = scramble.map(|seed| {
        let mut rng = stream(seed, Stream::SobolScramble);
        (0..dims).map(|_| rng.random::<u64>()).collect()
    });
    let mut x = vec![0u64; dims];
    let mut points = Vec::with_capacity(n);
    for i in 0..n + skip {
        if i > 0 {
            // Gray code: point i differs from point i − 1 in direction ctz(i).
            let c = i.trailing_zeros() as usize;
            for (xj, vj) in x.iter_mut().zip(&v) {
                *xj ^= vj[c];
            }
        }
        if i < skip {
            continue;
        }
        let point = match &keys {
            Some(keys) => x
                .iter()
                .zip(keys)
                .map(|(&xj, &key)| to_unit(owen_scramble(xj, key)))
                .collect(),
            None => x.iter().map(|&xj| to_unit(xj)).collect(),
        };
        points.push(point);
    }
    Ok(points)
}

/// The top 53 bits of a top-aligned fraction as an `f64` in `[0, 1)`.
pub(crate) fn to_unit(x: u64) -> f64 {
    (x >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Owen's nested uniform scramble of the top 53 bits of `x`: bit `k` (from the top) is
/// flipped by the lowest bit of a keyed hash of the tree node `(k, bits above k)`.
pub(crate) fn owen_scramble(x: u64, key: u64) -> u64 {
    let mut out = 0u64;
    for k in 0..53 {
        let prefix = if k == 0 { 0 } else { x >> (64 - k) };
        // The node as a heap index: a 1 marking the depth, then the k digits above.
        let node = (1u64 << k) | prefix;
        let flip = mix(key ^ mix(node)) & 1;
        out |= (((x >> (63 - k)) & 1) ^ flip) << (63 - k);
    }
    out
}

/// SplitMix64's finalizer (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::design::random_points;

    /// Which cell of `2^b` equal intervals a coordinate falls in.
    fn cell(x: f64, b: u32) -> usize {
        (x * f64::from(1u32 << b)) as usize
    }

    /// Box counts of the 2-D elementary intervals of sizes 2^-b1 × 2^-b2 (dims i, j).
    fn box_counts(points: &[Vec<f64>], i: usize, j: usize, b1: u32, b2: u32) -> Vec<usize> {
        let mut counts = vec![0usize; 1 << (b1 + b2)];
        for p in points {
            counts[(cell(p[i], b1) << b2) | cell(p[j], b2)] += 1;
        }
        counts
    }

    #[test]
    fn table_rows_are_primitive_polynomials_with_odd_initial_numbers() {
        let mut seen = std::collections::HashSet::new();
        for (d, &(s, a, m)) in JOE_KUO.iter().enumerate() {
            assert_eq!(m.len(), s as usize, "dimension {}", d + 2);
            for (k, &mk) in m.iter().enumerate() {
                assert!(mk % 2 == 1 && mk < 1 << (k + 1), "dimension {}", d + 2);
            }
            // x^s + a-bits + 1; primitive iff the order of x modulo it is 2^s − 1.
            let poly = (1u64 << s) | (u64::from(a) << 1) | 1;
            assert!(
                seen.insert(poly),
                "dimension {} repeats a polynomial",
                d + 2
            );
            let period = (1u64 << s) - 1;
            let mut r = 1u64;
            for e in 1..=period {
                r <<= 1;
                if r >> s & 1 == 1 {
                    r ^= poly;
                }
                assert!(r != 1 || e == period, "dimension {}: order {e}", d + 2);
            }
            assert_eq!(r, 1, "dimension {}", d + 2);
        }
    }

    #[test]
    fn first_points_are_the_known_sequence() {
        let p = sobol(7, 3, None).unwrap();
        let expect = [
            [0.5, 0.5, 0.5],
            [0.75, 0.25, 0.25],
            [0.25, 0.75, 0.75],
            [0.375, 0.375, 0.625],
            [0.875, 0.875, 0.125],
            [0.625, 0.125, 0.875],
            [0.125, 0.625, 0.375],
        ];
        for (got, want) in p.iter().zip(expect) {
            assert_eq!(got.as_slice(), want.as_slice());
        }
        // The unscrambled generator from index 0 starts at the origin.
        assert_eq!(sobol_points(1, 2, None, false).unwrap()[0], vec![0.0, 0.0]);
    }

    #[test]
    fn every_one_dimensional_projection_of_a_power_of_two_is_stratified() {
        for scramble in [None, Some(11)] {
            let k = 10;
            let p = sobol_points(1 << k, MAX_DIMS, scramble, false).unwrap();
            for d in 0..MAX_DIMS {
                let mut counts = vec![0; 1 << k];
                for x in &p {
                    counts[cell(x[d], k)] += 1;
                }
                assert!(counts.iter().all(|&c| c == 1), "dim {d} {scramble:?}");
            }
        }
    }

    #[test]
    fn scrambling_keeps_the_net_structure() {
        let m = 10;
        let plain = sobol_points(1 << m, 8, None, false).unwrap();
        for seed in [1, 2, 3] {
            let p = sobol(1 << m, 8, Some(seed)).unwrap();
            assert_ne!(p, plain);
            // Dimensions 1 and 2 are a (0, m, 2)-net: one point in every elementary box.
            for b1 in 0..=m {
                let counts = box_counts(&p, 0, 1, b1, m - b1);
                assert!(counts.iter().all(|&c| c == 1), "seed {seed} split {b1}");
            }
            // Every pair keeps the box-count profile (the t-value) of the unscrambled net.
            for i in 0..8 {
                for j in i + 1..8 {
                    for b1 in 1..m {
                        let mut a = box_counts(&p, i, j, b1, m - b1);
                        let mut b = box_counts(&plain, i, j, b1, m - b1);
                        a.sort_unstable();
                        b.sort_unstable();
                        assert_eq!(a, b, "seed {seed} dims {i},{j} split {b1}");
                    }
                }
            }
        }
    }

    #[test]
    fn scrambled_points_are_uniform_to_the_last_bits() {
        // The low digits are scrambled too: no coordinate is a multiple of 2^-32.
        let p = sobol(256, 4, Some(5)).unwrap();
        let on_grid = p
            .iter()
            .flatten()
            .filter(|&&x| (x * 4294967296.0).fract() == 0.0)
            .count();
        assert_eq!(on_grid, 0);
        let mean = p.iter().flatten().sum::<f64>() / 1024.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }

    /// ∫ Π (π/2) sin(π x_j) dx = 1 over [0, 1]^dims: the error of the mean over `points`.
    fn product_error(points: &[Vec<f64>]) -> f64 {
        let f = |x: &[f64]| {
            x.iter()
                .map(|&t| std::f64::consts::FRAC_PI_2 * (std::f64::consts::PI * t).sin())
                .product::<f64>()
        };
        points.iter().map(|x| f(x)).sum::<f64>() / points.len() as f64 - 1.0
    }

    fn rms(errors: impl Iterator<Item = f64>) -> f64 {
        let e: Vec<f64> = errors.collect();
        (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
    }

    #[test]
    fn smooth_integrands_converge_faster_than_random() {
        // Five dimensions, 4096 points, six seeds: Sobol' RMS error 2.4e-3 against 1.9e-2.
        let (n, dims) = (4096, 5);
        let qmc: Vec<f64> = (1..=6)
            .map(|s| product_error(&sobol(n, dims, Some(s)).unwrap()).abs())
            .collect();
        let mc: Vec<f64> = (1..=6)
            .map(|s| product_error(&random_points(n, dims, s)).abs())
            .collect();
        let (qmc_rms, mc_rms) = (rms(qmc.iter().copied()), rms(mc.iter().copied()));
        assert!(qmc_rms < 0.25 * mc_rms, "Sobol' {qmc:?} random {mc:?}");
        let qmc_max = qmc.iter().cloned().fold(0.0, f64::max);
        assert!(
            qmc_max < mc.iter().sum::<f64>() / 6.0,
            "Sobol' {qmc:?} random {mc:?}"
        );
        // In one dimension the scrambled net converges like n^(-3/2) (Owen 1997): four times the
        // points cut the RMS error about eightfold (random sampling: twofold).
        let at = |m: u32| rms((0..10).map(|s| product_error(&sobol(1 << m, 1, Some(s)).unwrap())));
        let gain = at(10) / at(12);
        assert!(gain > 5.0, "{gain}");
    }

    #[test]
    fn limits_are_one_line_errors() {
        for e in [sobol(4, 0, None), sobol(4, MAX_DIMS + 1, Some(1))] {
            let e = e.unwrap_err();
            assert!(e.contains("dimensions") && !e.contains('\n'), "{e}");
        }
        assert_eq!(sobol(3, MAX_DIMS, None).unwrap()[2].len(), MAX_DIMS);
    }
}
