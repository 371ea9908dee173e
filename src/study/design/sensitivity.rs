//! Global sensitivity analysis: Sobol' indices by Saltelli sampling, Morris elementary
//! effects, and the share of replicate noise in a metric's variance.
//!
//! **Sobol' indices** (Saltelli et al. 2010, Comput. Phys. Commun. 181, 259–270). From a base
//! sample of N points in 2d dimensions, A is its first d columns and B its last d; AB_i is A
//! with column i taken from B. With f_A, f_B, f_ABi the model outputs and V the variance of
//! the 2N outputs of A and B:
//! - first order (Saltelli 2010, Table 2 (b)): S_i = (1/N) Σ_j f_B(j) (f_ABi(j) − f_A(j)) / V;
//! - total (Jansen 1999, Saltelli 2010 Table 2 (f)): S_Ti = (1/2N) Σ_j (f_A(j) − f_ABi(j))² / V.
//!
//! Confidence intervals are bootstrap percentile intervals over the N row groups (A_j, AB_ij,
//! B_j resampled together). With a scrambled Sobol' base the estimates are better than the
//! independent-sample bootstrap assumes, so the intervals are conservative.
//!
//! **Morris elementary effects** (Morris 1991, Technometrics 33, 161–174): r trajectories of
//! d + 1 points on a p-level grid of [0, 1]^d, each step moving one coordinate by
//! Δ = p / (2(p − 1)); EE_i = (f(x + Δ e_i) − f(x)) / Δ (signed by the step). Reported: μ (mean
//! EE), μ* (mean |EE|, Campolongo, Cariboni & Saltelli 2007), σ (standard deviation of EE:
//! nonlinearity or interactions; 0 for a linear model) and a 95 % half-width of μ*.
//! [`morris_points_spread`] adds Campolongo et al.'s (2007) selection of the r most spread
//! trajectories out of more candidates.
//!
//! **Replicate noise** ([`replicate_variance`]): for metrics measured at several seeds per
//! point, the one-way ANOVA split of the total variance into its within-point (replicate)
//! part; a Sobol' index computed from replicate means is then about the remaining share.

use rand::RngExt;

use super::{random_points, shuffle, sobol, stream, Stream};
use crate::numerics::stats::{quantile_sorted, Stats};

/// The Saltelli sample: `n · (dims + 2)` points in `[0, 1)^dims`, in row groups of `dims + 2`:
///
/// `A_0, AB_{0,0}, …, AB_{d−1,0}, B_0, A_1, AB_{0,1}, …, B_1, …`
///
/// i.e. point `j·(d+2)` is row `j` of A, point `j·(d+2) + 1 + i` is row `j` of AB_i (A's row
/// with coordinate `i` from B) and point `j·(d+2) + d + 1` is row `j` of B (the order of
/// SALib's `saltelli.sample` without second-order terms). The base sample of `n` points in
/// `2·dims` dimensions is scrambled Sobol' (balanced when `n` is a power of two) when
/// `2·dims ≤` [`sobol::MAX_DIMS`], independent uniform points above.
pub fn saltelli_points(n: usize, dims: usize, seed: u64) -> Vec<Vec<f64>> {
    let base =
        sobol::sobol(n, 2 * dims, Some(seed)).unwrap_or_else(|_| random_points(n, 2 * dims, seed));
    let mut points = Vec::with_capacity(n * (dims + 2));
    for row in base {
        let (a, b) = row.split_at(dims);
        points.push(a.to_vec());
        for i in 0..dims {
            let mut ab = a.to_vec();
            ab[i] = b[i];
            points.push(ab);
        }
        points.push(b.to_vec());
    }
    points
}

/// First-order and total Sobol' indices with bootstrap intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct SobolIndices {
    /// First-order indices S_i (Saltelli 2010), one per dimension.
    pub first: Vec<f64>,
    /// Bootstrap percentile interval `[low, high]` of each S_i (NaN without bootstrap).
    pub first_ci: Vec<[f64; 2]>,
    /// Total indices S_Ti (Jansen 1999), one per dimension.
    pub total: Vec<f64>,
    /// Bootstrap percentile interval `[low, high]` of each S_Ti (NaN without bootstrap).
    pub total_ci: Vec<[f64; 2]>,
    /// The total variance V of the output (over the 2N points of A and B, n − 1 divisor).
    pub variance: f64,
    /// The intervals' confidence level (e.g. 0.95).
    pub confidence: f64,
}

/// Sobol' indices from the outputs `y` at [`saltelli_points`]`(n, dims, _)`, in that order.
///
/// `bootstrap` resamples of the `n` row groups (0: no intervals) give percentile intervals at
/// `confidence` (e.g. 0.95), drawn reproducibly from `seed`. NaN outputs make the affected
/// indices NaN. Indices are NaN when the output has no variance.
///
/// # Panics
/// If `y.len() != n · (dims + 2)` or `confidence` is not inside (0, 1).
pub fn sobol_indices(
    y: &[f64],
    n: usize,
    dims: usize,
    bootstrap: usize,
    seed: u64,
    confidence: f64,
) -> SobolIndices {
    assert_eq!(
        y.len(),
        n * (dims + 2),
        "sobol_indices: expected n·(dims + 2) = {} outputs, got {}",
        n * (dims + 2),
        y.len()
    );
    assert!(
        confidence > 0.0 && confidence < 1.0,
        "sobol_indices: confidence {confidence} outside (0, 1)"
    );
    let group = |j: usize| &y[j * (dims + 2)..(j + 1) * (dims + 2)];
    let all: Vec<usize> = (0..n).collect();
    let (first, total, variance) = estimate(&all, &group, dims);
    let mut first_ci = vec![[f64::NAN; 2]; dims];
    let mut total_ci = vec![[f64::NAN; 2]; dims];
    if bootstrap > 0 && n > 0 {
        let mut rng = stream(seed, Stream::Bootstrap);
        let mut boot_first = vec![Vec::with_capacity(bootstrap); dims];
        let mut boot_total = vec![Vec::with_capacity(bootstrap); dims];
        let mut rows = vec![0usize; n];
        for _ in 0..bootstrap {
            for r in rows.iter_mut() {
                *r = rng.random_range(0..n);
            }
            let (s, st, _) = estimate(&rows, &group, dims);
            for i in 0..dims {
                boot_first[i].push(s[i]);
                boot_total[i].push(st[i]);
            }
        }
        let (lo, hi) = ((1.0 - confidence) / 2.0, (1.0 + confidence) / 2.0);
        let interval = |mut v: Vec<f64>| {
            if v.iter().any(|x| x.is_nan()) {
                return [f64::NAN; 2];
            }
            v.sort_by(f64::total_cmp);
            [quantile_sorted(&v, lo), quantile_sorted(&v, hi)]
        };
        for i in 0..dims {
            first_ci[i] = interval(std::mem::take(&mut boot_first[i]));
            total_ci[i] = interval(std::mem::take(&mut boot_total[i]));
        }
    }
    SobolIndices {
        first,
        first_ci,
        total,
        total_ci,
        variance,
        confidence,
    }
}

/// The estimators over the row groups `rows` (with repeats for a bootstrap resample).
fn estimate<'a>(
    rows: &[usize],
    group: &impl Fn(usize) -> &'a [f64],
    dims: usize,
) -> (Vec<f64>, Vec<f64>, f64) {
    let n = rows.len() as f64;
    let ab = rows.iter().flat_map(|&j| {
        let g = group(j);
        [g[0], g[dims + 1]]
    });
    let variance = Stats::of(ab).std.powi(2);
    let mut first = vec![0.0; dims];
    let mut total = vec![0.0; dims];
    for &j in rows {
        let g = group(j);
        let (fa, fb) = (g[0], g[dims + 1]);
        for i in 0..dims {
            let fab = g[1 + i];
            first[i] += fb * (fab - fa);
            total[i] += (fa - fab) * (fa - fab);
        }
    }
    for i in 0..dims {
        first[i] /= n * variance;
        total[i] /= 2.0 * n * variance;
    }
    (first, total, variance)
}

/// The one-way ANOVA split of a metric's variance over points with replicates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplicateVariance {
    /// Pooled within-point variance Σ_i Σ_r (y_ir − ȳ_i)² / (N − k): the replicate noise
    /// (equal to the mean within-point variance when every point has as many replicates).
    pub within: f64,
    /// Total variance of all N values about their grand mean, Σ (y − ȳ)² / (N − 1).
    pub total: f64,
    /// `within / total`: the fraction of the variance that is replicate noise (≈ 0: the
    /// parameters explain the metric; ≈ 1: noise dominates). A sample estimate, so it can
    /// slightly exceed 1. NaN when undefined (no replicates or no variance).
    pub share: f64,
    /// Points k with at least one value.
    pub points: usize,
    /// Values N (NaN values, i.e. failed runs, are left out).
    pub values: usize,
}

/// The replicate-noise split of `y[point][replicate]` (see [`ReplicateVariance`]).
pub fn replicate_variance(y: &[Vec<f64>]) -> ReplicateVariance {
    let groups: Vec<Vec<f64>> = y
        .iter()
        .map(|g| {
            g.iter()
                .copied()
                .filter(|v| !v.is_nan())
                .collect::<Vec<f64>>()
        })
        .filter(|g| !g.is_empty())
        .collect();
    let values: usize = groups.iter().map(Vec::len).sum();
    let points = groups.len();
    let grand = groups.iter().flatten().sum::<f64>() / values as f64;
    let mut ss_within = 0.0;
    let mut ss_total = 0.0;
    for g in &groups {
        let mean = g.iter().sum::<f64>() / g.len() as f64;
        ss_within += g.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        ss_total += g.iter().map(|v| (v - grand).powi(2)).sum::<f64>();
    }
    let within = if values > points {
        ss_within / (values - points) as f64
    } else {
        f64::NAN
    };
    let total = if values > 1 {
        ss_total / (values - 1) as f64
    } else {
        f64::NAN
    };
    ReplicateVariance {
        within,
        total,
        share: if total > 0.0 {
            within / total
        } else {
            f64::NAN
        },
        points,
        values,
    }
}

/// The fraction of the variance of `y[point][replicate]` that is within-point (replicate)
/// noise: [`replicate_variance`]`(y).share`.
pub fn noise_share(y: &[Vec<f64>]) -> f64 {
    replicate_variance(y).share
}

/// Morris statistics of one input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MorrisEffect {
    /// μ: mean elementary effect (signed; effects of opposite signs cancel).
    pub mu: f64,
    /// μ*: mean absolute elementary effect, the importance measure.
    pub mu_star: f64,
    /// σ: sample standard deviation of the elementary effects (NaN below two).
    pub sigma: f64,
    /// Half-width of the 95 % interval of μ*: t_{0.975, r−1} · sd(|EE|) / √r (NaN below two).
    pub mu_star_ci: f64,
}

/// Morris (1991) trajectories: `trajectories` · (`dims` + 1) points on the grid
/// `{0, 1/(p−1), …, 1}^dims` (`p = levels`, even), trajectory after trajectory: point
/// `t·(d+1) + k` is step `k` of trajectory `t`. Each trajectory starts at a random grid point
/// and moves every coordinate once, in random order, by ±Δ = ±p/(2(p−1)), so all its points
/// stay in [0, 1] and the levels are visited with equal probability.
///
/// # Panics
/// If `levels` is odd or below 2 (Δ would leave the grid).
pub fn morris_points(trajectories: usize, dims: usize, levels: usize, seed: u64) -> Vec<Vec<f64>> {
    check_levels(levels);
    let mut rng = stream(seed, Stream::Morris);
    (0..trajectories)
        .flat_map(|_| trajectory(dims, levels, &mut rng))
        .collect()
}

/// Morris trajectories selected for spread (Campolongo et al. 2007): `candidates` trajectories
/// are drawn as in [`morris_points`] and the `trajectories` of them that keep the largest sum
/// of squared pairwise distances are kept (greedy backward elimination; the trajectory
/// distance is the sum of the Euclidean distances between all pairs of their points). Same
/// order and panics as [`morris_points`]; with `candidates ≤ trajectories` it equals it.
pub fn morris_points_spread(
    trajectories: usize,
    dims: usize,
    levels: usize,
    candidates: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    check_levels(levels);
    let mut rng = stream(seed, Stream::Morris);
    let pool: Vec<Vec<Vec<f64>>> = (0..candidates.max(trajectories))
        .map(|_| trajectory(dims, levels, &mut rng))
        .collect();
    let m = pool.len();
    let mut d2 = vec![0.0; m * m];
    for a in 0..m {
        for b in a + 1..m {
            let d: f64 = pool[a]
                .iter()
                .flat_map(|p| pool[b].iter().map(move |q| dist(p, q)))
                .sum();
            d2[a * m + b] = d * d;
            d2[b * m + a] = d * d;
        }
    }
    let mut alive = vec![true; m];
    let mut contribution: Vec<f64> = (0..m)
        .map(|a| d2[a * m..(a + 1) * m].iter().sum())
        .collect();
    for _ in trajectories..m {
        let drop = (0..m)
            .filter(|&a| alive[a])
            .min_by(|&a, &b| contribution[a].total_cmp(&contribution[b]))
            .expect("a candidate is left");
        alive[drop] = false;
        for a in 0..m {
            contribution[a] -= d2[a * m + drop];
        }
    }
    pool.into_iter()
        .zip(alive)
        .filter(|(_, keep)| *keep)
        .flat_map(|(t, _)| t)
        .collect()
}

fn check_levels(levels: usize) {
    assert!(
        levels >= 2 && levels.is_multiple_of(2),
        "Morris levels must be even and at least 2, not {levels}"
    );
}

fn dist(p: &[f64], q: &[f64]) -> f64 {
    p.iter()
        .zip(q)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt()
}

/// One trajectory, on integer levels `0..p` turned into `level / (p − 1)` at the end.
fn trajectory(dims: usize, levels: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<Vec<f64>> {
    let jump = levels / 2;
    let mut level: Vec<usize> = Vec::with_capacity(dims);
    let mut up: Vec<bool> = Vec::with_capacity(dims);
    for _ in 0..dims {
        let base = rng.random_range(0..jump);
        let rising = rng.random::<bool>();
        level.push(if rising { base } else { base + jump });
        up.push(rising);
    }
    let mut order: Vec<usize> = (0..dims).collect();
    shuffle(&mut order, rng);
    let scale = 1.0 / (levels - 1) as f64;
    let to_point = |level: &[usize]| {
        level
            .iter()
            .map(|&l| l as f64 * scale)
            .collect::<Vec<f64>>()
    };
    let mut points = vec![to_point(&level)];
    for i in order {
        level[i] = if up[i] {
            level[i] + jump
        } else {
            level[i] - jump
        };
        points.push(to_point(&level));
    }
    points
}

/// Morris statistics per input from `points` (trajectories of `dims + 1` points, as
/// [`morris_points`] orders them, possibly mapped coordinate-wise onto parameter ranges) and
/// the outputs `y` there. Each step of a trajectory must change exactly one coordinate; its
/// elementary effect is Δy / Δx in that coordinate (in the units of `points`).
///
/// # Panics
/// If the lengths disagree or a step changes other than one coordinate.
pub fn morris_effects(points: &[Vec<f64>], y: &[f64], dims: usize) -> Vec<MorrisEffect> {
    assert_eq!(
        points.len(),
        y.len(),
        "morris_effects: points and outputs differ in number"
    );
    assert!(
        points.len().is_multiple_of(dims + 1),
        "morris_effects: {} points are not whole trajectories of {} points",
        points.len(),
        dims + 1
    );
    let mut effects: Vec<Vec<f64>> = vec![Vec::new(); dims];
    for (t, (traj, yt)) in points.chunks(dims + 1).zip(y.chunks(dims + 1)).enumerate() {
        for k in 0..dims {
            let (p, q) = (&traj[k], &traj[k + 1]);
            let moved: Vec<usize> = (0..dims).filter(|&i| p[i] != q[i]).collect();
            assert!(
                moved.len() == 1,
                "morris_effects: step {k} of trajectory {t} changes {} coordinates, not one",
                moved.len()
            );
            let i = moved[0];
            effects[i].push((yt[k + 1] - yt[k]) / (q[i] - p[i]));
        }
    }
    effects
        .iter()
        .map(|ee| {
            let signed = Stats::of(ee.iter().copied());
            let absolute = Stats::of(ee.iter().map(|e| e.abs()));
            MorrisEffect {
                mu: signed.mean,
                mu_star: absolute.mean,
                sigma: signed.std,
                mu_star_ci: absolute.ci95,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::StandardNormal;
    use std::f64::consts::PI;

    const A: f64 = 7.0;
    const B: f64 = 0.1;

    /// Ishigami (1990) on [−π, π]^3, from the unit cube.
    fn ishigami(u: &[f64]) -> f64 {
        let x: Vec<f64> = u.iter().map(|&v| -PI + 2.0 * PI * v).collect();
        x[0].sin() + A * x[1].sin().powi(2) + B * x[2].powi(4) * x[0].sin()
    }

    /// Analytic (S_1, S_2, S_3) and (S_T1, S_T2, S_T3) of the Ishigami function.
    fn ishigami_indices() -> ([f64; 3], [f64; 3]) {
        let v = A * A / 8.0 + B * PI.powi(4) / 5.0 + B * B * PI.powi(8) / 18.0 + 0.5;
        let v1 = 0.5 * (1.0 + B * PI.powi(4) / 5.0).powi(2);
        let v2 = A * A / 8.0;
        let v13 = B * B * PI.powi(8) * (1.0 / 18.0 - 1.0 / 50.0);
        ([v1 / v, v2 / v, 0.0], [(v1 + v13) / v, v2 / v, v13 / v])
    }

    #[test]
    fn analytic_ishigami_values() {
        let (s, st) = ishigami_indices();
        let round = |x: f64| (x * 1e4).round() / 1e4;
        assert_eq!(s.map(round), [0.3139, 0.4424, 0.0]);
        assert_eq!(st.map(round), [0.5576, 0.4424, 0.2437]);
    }

    #[test]
    fn saltelli_point_order() {
        let (n, d) = (8, 3);
        let p = saltelli_points(n, d, 5);
        assert_eq!(p.len(), n * (d + 2));
        for g in p.chunks(d + 2) {
            let (a, b) = (&g[0], &g[d + 1]);
            for i in 0..d {
                for k in 0..d {
                    assert_eq!(g[1 + i][k], if k == i { b[k] } else { a[k] });
                }
            }
        }
        // A's and B's rows are the halves of a balanced 2d-dimensional Sobol' sample.
        let base = sobol::sobol(n, 2 * d, Some(5)).unwrap();
        for (g, row) in p.chunks(d + 2).zip(&base) {
            assert_eq!([g[0].as_slice(), g[d + 1].as_slice()].concat(), *row);
        }
        // Too many dimensions for the table: random base, same layout.
        assert_eq!(saltelli_points(2, 40, 1).len(), 2 * 42);
    }

    #[test]
    fn ishigami_sobol_indices() {
        let (n, d) = (1 << 13, 3);
        let y: Vec<f64> = saltelli_points(n, d, 2024)
            .iter()
            .map(|u| ishigami(u))
            .collect();
        let r = sobol_indices(&y, n, d, 500, 1, 0.95);
        let (s, st) = ishigami_indices();
        let v = A * A / 8.0 + B * PI.powi(4) / 5.0 + B * B * PI.powi(8) / 18.0 + 0.5;
        assert!(
            (r.variance / v - 1.0).abs() < 0.01,
            "V {} vs {v}",
            r.variance
        );
        for i in 0..d {
            for (what, est, ci, truth) in [
                ("S", r.first[i], r.first_ci[i], s[i]),
                ("ST", r.total[i], r.total_ci[i], st[i]),
            ] {
                assert!(
                    (est - truth).abs() < 0.02,
                    "{what}{}: {est} vs {truth}",
                    i + 1
                );
                assert!(
                    ci[0] <= truth && truth <= ci[1],
                    "{what}{}: {ci:?} vs {truth}",
                    i + 1
                );
                assert!(ci[0] <= est && est <= ci[1] && ci[1] - ci[0] < 0.1);
            }
        }
        assert_eq!(r.confidence, 0.95);
        // Reproducible, and no intervals without bootstrap.
        assert_eq!(sobol_indices(&y, n, d, 500, 1, 0.95), r);
        let plain = sobol_indices(&y, n, d, 0, 1, 0.95);
        assert_eq!(plain.first, r.first);
        assert!(plain.first_ci[0][0].is_nan());
    }

    #[test]
    fn morris_ranks_a_linear_model_exactly() {
        let (r, d) = (20, 3);
        let p = morris_points(r, d, 4, 9);
        assert_eq!(p.len(), r * (d + 1));
        let levels = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
        assert!(p.iter().flatten().all(|x| levels.contains(x)));
        let y: Vec<f64> = p.iter().map(|x| 10.0 * x[0] + x[1] - 0.1 * x[2]).collect();
        let e = morris_effects(&p, &y, d);
        for (ei, c) in e.iter().zip([10.0, 1.0, -0.1]) {
            assert!((ei.mu - c).abs() < 1e-12, "{ei:?}");
            assert!((ei.mu_star - c.abs()).abs() < 1e-12, "{ei:?}");
            assert!(ei.sigma < 1e-12 && ei.mu_star_ci < 1e-12, "{ei:?}");
        }
    }

    #[test]
    fn morris_sees_nonlinearity_and_interaction() {
        let (r, d) = (30, 4);
        let p = morris_points(r, d, 6, 3);
        // x1 enters nonlinearly, x2 and x3 interact, x4 is inert.
        let y: Vec<f64> = p
            .iter()
            .map(|x| 5.0 * x[0] * x[0] + 4.0 * x[1] * x[2])
            .collect();
        let e = morris_effects(&p, &y, d);
        assert!(
            e[0].sigma > 0.5 && e[1].sigma > 0.5 && e[2].sigma > 0.5,
            "{e:?}"
        );
        assert_eq!(e[3].mu_star, 0.0);
        assert!(e[0].mu_star > e[1].mu_star.max(e[2].mu_star), "{e:?}");
        // μ* of x1 is E|5(2x + Δ)| = 5; the interval should say so.
        assert!(
            (e[0].mu_star - 5.0).abs() < 2.0 * e[0].mu_star_ci + 0.2,
            "{e:?}"
        );
    }

    #[test]
    fn spread_trajectories_are_more_spread() {
        let spread_of = |p: &[Vec<f64>], d: usize| {
            let t: Vec<&[Vec<f64>]> = p.chunks(d + 1).collect();
            let mut s = 0.0;
            for a in 0..t.len() {
                for b in a + 1..t.len() {
                    let x: f64 = t[a]
                        .iter()
                        .flat_map(|p| t[b].iter().map(move |q| dist(p, q)))
                        .sum();
                    s += x * x;
                }
            }
            s
        };
        let (r, d) = (10, 5);
        let plain = morris_points(r, d, 4, 1);
        let spread = morris_points_spread(r, d, 4, 50, 1);
        assert_eq!(spread.len(), plain.len());
        assert!(spread_of(&spread, d) > spread_of(&plain, d));
        assert_eq!(morris_points_spread(r, d, 4, 5, 1), plain);
        let y: Vec<f64> = spread.iter().map(|x| 3.0 * x[4]).collect();
        assert!((morris_effects(&spread, &y, d)[4].mu_star - 3.0).abs() < 1e-12);
    }

    #[test]
    #[should_panic(expected = "even")]
    fn odd_levels_are_refused() {
        morris_points(2, 2, 5, 1);
    }

    #[test]
    fn noise_share_recovers_the_noise_variance() {
        // y = 2x + ε, x ~ U(0, 1), ε ~ N(0, 1/3): Var f = 1/3, so half the variance is noise.
        let mut rng = stream(77, Stream::Random);
        let sd = (1.0f64 / 3.0).sqrt();
        let y: Vec<Vec<f64>> = (0..2000)
            .map(|_| {
                let x: f64 = rng.random();
                (0..4)
                    .map(|_| 2.0 * x + sd * rng.sample::<f64, _>(StandardNormal))
                    .collect()
            })
            .collect();
        let v = replicate_variance(&y);
        assert_eq!((v.points, v.values), (2000, 8000));
        assert!((v.share - 0.5).abs() < 0.03, "{v:?}");
        assert!((v.within - 1.0 / 3.0).abs() < 0.02, "{v:?}");
        assert_eq!(noise_share(&y), v.share);
        // No noise, and no replicates.
        assert_eq!(
            noise_share(&[vec![1.0, 1.0], vec![2.0, 2.0, f64::NAN]]),
            0.0
        );
        assert!(noise_share(&[vec![1.0], vec![2.0]]).is_nan());
    }
}
