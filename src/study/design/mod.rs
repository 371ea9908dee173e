//! Design of experiments: points in the unit cube for studies beyond the grid, and the
//! statistics read off the runs made at them.
//!
//! Everything here is pure mathematics on `[0, 1)^d` (Morris trajectories: the closed grid
//! `[0, 1]^d`); mapping the unit cube onto parameter ranges or distributions
//! ([`distributions::Distribution::quantile`]) and running the model are the study runner's job.
//! Every random choice is drawn from a ChaCha8 stream keyed by the caller's seed (the
//! construction of [`crate::rng`]), with one stream number per purpose, so a design is
//! reproducible bit for bit from `(method, n, dims, seed)` on every platform.
//!
//! - [`Method::Random`]: independent uniform points.
//! - [`Method::LatinHypercube`] ([`lhs`]): McKay, Beckman & Conover (1979), improved towards
//!   maximin distance by a seeded column-swap search.
//! - [`Method::Sobol`] ([`sobol`]): Sobol' (1967) with the Joe & Kuo (2008) direction numbers
//!   `new-joe-kuo-6.21201`, Owen (1998) nested uniform scrambling.
//! - [`Method::Halton`] ([`halton`]): Halton (1960) in the first primes, with random digit
//!   permutations.
//! - [`sensitivity`]: Saltelli et al. (2010) sampling with first-order (Saltelli 2010) and
//!   total (Jansen 1999) Sobol' indices and bootstrap intervals; Morris (1991) elementary
//!   effects with μ* (Campolongo, Cariboni & Saltelli 2007) and optional spread-maximizing
//!   trajectory selection; the replicate-noise share of the variance (one-way ANOVA).
//! - [`distributions`]: Normal, LogNormal and Uniform inverse CDFs for uncertainty propagation
//!   (the normal quantile by Wichura 1988, AS 241).
//!
//! References:
//! - I. M. Sobol', USSR Comput. Math. Math. Phys. 7 (1967) 86–112.
//! - S. Joe, F. Y. Kuo, SIAM J. Sci. Comput. 30 (2008) 2635–2654.
//! - A. B. Owen, J. Complexity 14 (1998) 466–489 (scrambling); Owen, Monte Carlo and
//!   Quasi-Monte Carlo Methods 1995, Lecture Notes in Statistics 106 (nested scrambling).
//! - J. H. Halton, Numer. Math. 2 (1960) 84–90.
//! - M. D. McKay, R. J. Beckman, W. J. Conover, Technometrics 21 (1979) 239–245.
//! - A. Saltelli, P. Annoni, I. Azzini, F. Campolongo, M. Ratto, S. Tarantola,
//!   Comput. Phys. Commun. 181 (2010) 259–270.
//! - M. J. W. Jansen, Comput. Phys. Commun. 117 (1999) 35–43.
//! - M. D. Morris, Technometrics 33 (1991) 161–174.
//! - F. Campolongo, J. Cariboni, A. Saltelli, Environ. Model. Softw. 22 (2007) 1509–1518.
//! - M. J. Wichura, Appl. Statist. 37 (1988) 477–484 (AS 241).
//! - R. J. Hyndman, Y. Fan, Am. Stat. 50 (1996) 361–365 (sample quantiles, type 7).

pub mod distributions;
pub mod halton;
pub mod lhs;
pub mod sensitivity;
pub mod sobol;

use std::fmt;
use std::str::FromStr;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use crate::numerics::stats::{describe, Description};

/// How the points of a design are placed in the unit cube.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Independent uniform points (`"random"`).
    Random,
    /// Latin hypercube with maximin improvement (`"lhs"`).
    LatinHypercube,
    /// Scrambled Sobol' sequence (`"sobol"`); balanced for powers of two.
    Sobol,
    /// Scrambled Halton sequence (`"halton"`).
    Halton,
}

impl Method {
    /// Every method, in the order of its documentation.
    pub const ALL: [Method; 4] = [
        Method::Random,
        Method::LatinHypercube,
        Method::Sobol,
        Method::Halton,
    ];

    /// The name in study files: `"random"`, `"lhs"`, `"sobol"`, `"halton"`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Random => "random",
            Method::LatinHypercube => "lhs",
            Method::Sobol => "sobol",
            Method::Halton => "halton",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!("unknown sampling method \"{s}\" (expected random, lhs, sobol or halton)")
            })
    }
}

/// `n` points in the unit cube `[0, 1)^dims`, reproducible from `seed`: one `Vec` of `dims`
/// coordinates per point.
///
/// Sobol' and Halton points are scrambled with the seed (so they are never the fixed
/// unscrambled sequences, and the first point is kept); Sobol' points are balanced when `n`
/// is a power of two. Latin hypercubes get [`lhs::DEFAULT_MAXIMIN_ITERATIONS`] maximin
/// iterations. Errors (one line) for `dims == 0`, or for more dimensions or points than the
/// chosen sequence supports ([`sobol::MAX_DIMS`], [`halton::MAX_DIMS`]).
pub fn unit_points(
    method: Method,
    n: usize,
    dims: usize,
    seed: u64,
) -> Result<Vec<Vec<f64>>, String> {
    if dims == 0 {
        return Err("a design needs at least one dimension".into());
    }
    match method {
        Method::Random => Ok(random_points(n, dims, seed)),
        Method::LatinHypercube => Ok(lhs::latin_hypercube(
            n,
            dims,
            seed,
            lhs::DEFAULT_MAXIMIN_ITERATIONS,
        )),
        Method::Sobol => sobol::sobol(n, dims, Some(seed)),
        Method::Halton => halton::halton(n, dims, Some(seed)),
    }
}

/// `n` independent uniform points in `[0, 1)^dims`, drawn row by row.
pub fn random_points(n: usize, dims: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = stream(seed, Stream::Random);
    (0..n)
        .map(|_| (0..dims).map(|_| rng.random::<f64>()).collect())
        .collect()
}

/// The purposes of the design's random streams (their ChaCha8 stream numbers), kept apart
/// from [`crate::rng::Purpose`]'s so that design and run randomness never share a stream.
#[derive(Debug, Clone, Copy)]
#[repr(u64)]
pub(crate) enum Stream {
    Random = 101,
    LatinHypercube = 102,
    SobolScramble = 103,
    HaltonScramble = 104,
    Bootstrap = 105,
    Morris = 106,
}

/// The ChaCha8 stream of one purpose, keyed by the design seed (as [`crate::rng::run_stream`]).
pub(crate) fn stream(seed: u64, purpose: Stream) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(purpose as u64);
    rng
}

/// Fisher–Yates shuffle on a design stream (kept here so the order depends only on
/// `random_range`).
pub(crate) fn shuffle<T>(items: &mut [T], rng: &mut ChaCha8Rng) {
    for i in (1..items.len()).rev() {
        let j = rng.random_range(0..=i);
        items.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_round_trip() {
        for m in Method::ALL {
            assert_eq!(m.to_string().parse::<Method>(), Ok(m));
        }
        assert_eq!("lhs".parse::<Method>(), Ok(Method::LatinHypercube));
        let err = "grid".parse::<Method>().unwrap_err();
        assert!(err.contains("\"grid\"") && !err.contains('\n'), "{err}");
    }

    #[test]
    fn every_method_fills_the_unit_cube_reproducibly() {
        for m in Method::ALL {
            let a = unit_points(m, 64, 5, 7).unwrap();
            let b = unit_points(m, 64, 5, 7).unwrap();
            let c = unit_points(m, 64, 5, 8).unwrap();
            assert_eq!(a, b, "{m}");
            assert_ne!(a, c, "{m}");
            assert_eq!(a.len(), 64);
            assert!(a
                .iter()
                .all(|p| p.len() == 5 && p.iter().all(|&x| (0.0..1.0).contains(&x))));
        }
        assert!(unit_points(Method::Random, 3, 0, 1).is_err());
        assert!(unit_points(Method::Sobol, 4, sobol::MAX_DIMS + 1, 1).is_err());
        assert!(unit_points(Method::Halton, 4, halton::MAX_DIMS + 1, 1).is_err());
        assert!(unit_points(Method::Sobol, 0, 3, 1).unwrap().is_empty());
    }
}
