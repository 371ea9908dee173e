//! Latin hypercube sampling (McKay, Beckman & Conover 1979) with maximin improvement.
//!
//! Each dimension is cut into `n` equal strata and every stratum holds exactly one point, at a
//! uniformly random position inside it; the strata are matched across dimensions by
//! independent random permutations. The permutations are then improved towards the maximin
//! design (Johnson, Moore & Ylvisaker 1990: largest minimum pairwise distance) by a seeded
//! column-swap search: each iteration takes one of the two points of the closest pair, swaps
//! one random coordinate with a random other point (which keeps the Latin property) and keeps
//! the swap when the minimum pairwise distance does not decrease. The result is therefore never
//! worse than the plain hypercube of the same seed.

use rand::RngExt;

use super::{shuffle, stream, Stream};

/// Swap iterations [`super::unit_points`] spends on maximin improvement.
pub const DEFAULT_MAXIMIN_ITERATIONS: usize = 2000;

/// Above this many points the maximin search is skipped (its set-up is O(n² · d)).
pub const MAXIMIN_MAX_POINTS: usize = 10_000;

/// A Latin hypercube of `n` points in `[0, 1)^dims` from `seed`, improved by up to
/// `maximin_iterations` column swaps (0: the plain hypercube). Point `i`, dimension `d` lies
/// in stratum `[k/n, (k+1)/n)` with `k` running over `0..n` exactly once per dimension.
pub fn latin_hypercube(
    n: usize,
    dims: usize,
    seed: u64,
    maximin_iterations: usize,
) -> Vec<Vec<f64>> {
    let mut rng = stream(seed, Stream::LatinHypercube);
    let mut points = vec![vec![0.0; dims]; n];
    let mut perm: Vec<usize> = (0..n).collect();
    for d in 0..dims {
        shuffle(&mut perm, &mut rng);
        for (p, &k) in points.iter_mut().zip(&perm) {
            // Clamp: (n − 1 + u)/n may round up to 1 for u just below 1.
            p[d] = ((k as f64 + rng.random::<f64>()) / n as f64).min(1.0 - f64::EPSILON / 2.0);
        }
    }
    if n >= 3 && dims > 0 && maximin_iterations > 0 && n <= MAXIMIN_MAX_POINTS {
        maximin(&mut points, maximin_iterations, &mut rng);
    }
    points
}

/// The smallest Euclidean distance between two of the points (infinite below two points).
pub fn min_distance(points: &[Vec<f64>]) -> f64 {
    let mut best = f64::INFINITY;
    for (i, p) in points.iter().enumerate() {
        for q in &points[i + 1..] {
            best = best.min(dist2(p, q));
        }
    }
    best.sqrt()
}

fn dist2(p: &[f64], q: &[f64]) -> f64 {
    p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum()
}

/// Each point's nearest neighbour (squared distance, index), skipping itself.
fn nearest(points: &[Vec<f64>], i: usize) -> (f64, usize) {
    let mut best = (f64::INFINITY, usize::MAX);
    for (k, q) in points.iter().enumerate() {
        if k != i {
            let d = dist2(&points[i], q);
            if d < best.0 {
                best = (d, k);
            }
        }
    }
    best
}

/// The column-swap search (module docs). Keeps every point's nearest neighbour so that one
/// iteration costs O(n · d) plus a full recount for the points whose neighbour moved.
/// Returns the final minimum pairwise distance.
fn maximin(points: &mut [Vec<f64>], iterations: usize, rng: &mut rand_chacha::ChaCha8Rng) -> f64 {
    let n = points.len();
    let dims = points[0].len();
    let mut nn: Vec<(f64, usize)> = (0..n).map(|i| nearest(points, i)).collect();
    let global = |nn: &[(f64, usize)]| {
        nn.iter().enumerate().fold(
            (f64::INFINITY, 0),
            |best, (i, &(d, _))| {
                if d < best.0 {
                    (d, i)
                } else {
                    best
                }
            },
        )
    };
    let (mut current, mut worst) = global(&nn);
    for _ in 0..iterations {
        // One point of the closest pair, a random partner and a random coordinate.
        let a = if rng.random::<bool>() {
            worst
        } else {
            nn[worst].1
        };
        let mut b = rng.random_range(0..n - 1);
        if b >= a {
            b += 1;
        }
        let c = rng.random_range(0..dims);
        swap_coordinate(points, a, b, c);
        let mut trial = nn.clone();
        trial[a] = nearest(points, a);
        trial[b] = nearest(points, b);
        for k in (0..n).filter(|&k| k != a && k != b) {
            if trial[k].1 == a || trial[k].1 == b {
                trial[k] = nearest(points, k);
            } else {
                for m in [a, b] {
                    let d = dist2(&points[k], &points[m]);
                    if d < trial[k].0 {
                        trial[k] = (d, m);
                    }
                }
            }
        }
        let (min, at) = global(&trial);
        if min >= current {
            nn = trial;
            current = min;
            worst = at;
        } else {
            swap_coordinate(points, a, b, c);
        }
    }
    current.sqrt()
}

fn swap_coordinate(points: &mut [Vec<f64>], a: usize, b: usize, c: usize) {
    let t = points[a][c];
    points[a][c] = points[b][c];
    points[b][c] = t;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_latin(points: &[Vec<f64>]) -> bool {
        let n = points.len();
        (0..points[0].len()).all(|d| {
            let mut seen = vec![false; n];
            points.iter().all(|p| {
                let k = (p[d] * n as f64) as usize;
                k < n && !std::mem::replace(&mut seen[k], true)
            })
        })
    }

    #[test]
    fn one_point_per_stratum_in_every_dimension() {
        for (n, dims, iterations) in [(1, 3, 100), (2, 2, 100), (17, 4, 0), (50, 6, 3000)] {
            let p = latin_hypercube(n, dims, 42, iterations);
            assert_eq!(p.len(), n);
            assert!(is_latin(&p), "n {n} dims {dims}");
        }
    }

    #[test]
    fn maximin_never_loses_to_the_plain_hypercube() {
        let mut gained = 0;
        for seed in 0..8 {
            let plain = latin_hypercube(30, 3, seed, 0);
            let improved = latin_hypercube(30, 3, seed, DEFAULT_MAXIMIN_ITERATIONS);
            assert!(is_latin(&improved));
            let (d0, d1) = (min_distance(&plain), min_distance(&improved));
            assert!(d1 >= d0, "seed {seed}: {d1} < {d0}");
            if d1 > 1.5 * d0 {
                gained += 1;
            }
        }
        // The search should make a real difference for most seeds.
        assert!(gained >= 6, "{gained}");
    }

    #[test]
    fn the_neighbour_bookkeeping_matches_a_full_recount() {
        let mut p = latin_hypercube(40, 3, 3, 0);
        let kept = maximin(&mut p, 700, &mut stream(9, Stream::LatinHypercube));
        assert_eq!(kept, min_distance(&p));
        assert!(is_latin(&p));
        assert_eq!(
            latin_hypercube(40, 2, 3, 500),
            latin_hypercube(40, 2, 3, 500)
        );
    }
}
