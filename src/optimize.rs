//! Minimizing a noisy objective of one parameter that is evaluated on several replicate seeds
//! with common random numbers (the same seeds at every point, so a given x always gives the
//! same value).
//!
//! Method: a log-spaced scan over [lower, upper] brackets the minimum of the replicate mean;
//! argmin's Brent optimizer then refines it in ln x inside the bracket. Every evaluation is
//! kept. The optimum's uncertainty comes from the replicates: each replicate's own minimum is
//! located by a parabola in ln x through its three best evaluated points, and the standard error
//! of those minima is reported. The near-optimal band is the interval of x where the
//! (piecewise-linear interpolated) mean is within `band` of the minimum mean.

use argmin::core::{CostFunction, Executor};
use argmin::solver::brent::BrentOpt;
use std::cell::RefCell;

use crate::numerics::stats::Stats;

/// One evaluated point: the objective of each replicate (None: not available there, e.g. the
/// target was not reached or the run failed).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Point {
    /// Parameter value.
    pub x: f64,
    /// Per-replicate objective values.
    pub values: Vec<Option<f64>>,
}

impl Point {
    /// Statistics over the replicates with a value.
    fn stats(&self) -> Stats {
        Stats::of(self.values.iter().flatten().copied())
    }

    /// Mean over replicates with a value (NaN if none).
    pub fn mean(&self) -> f64 {
        self.stats().mean
    }

    /// Sample standard deviation over replicates with a value (0 for one, NaN for none).
    pub fn std(&self) -> f64 {
        let s = self.stats();
        if s.count == 1 {
            0.0
        } else {
            s.std
        }
    }

    /// Whether every replicate has a value.
    pub fn complete(&self) -> bool {
        self.values.iter().all(Option::is_some)
    }
}

/// Controls of the scan + Brent search.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Settings {
    /// Lower end of the search interval (> 0).
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
    /// Log-spaced scan points (≥ 3).
    pub scan_points: usize,
    /// Brent iterations after the scan.
    pub brent_iterations: u64,
    /// Relative width in x at which Brent stops.
    pub rel_tolerance: f64,
    /// Near-optimal band: values within this fraction of the minimum mean (0.02).
    pub band: f64,
    /// Search in ln x (true) or in x.
    pub log: bool,
}

/// The result of a search.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Optimum {
    /// The evaluated x with the smallest mean.
    pub x: f64,
    /// Its mean objective.
    pub value: f64,
    /// Standard error of the replicate minima (NaN with fewer than two replicates).
    pub uncertainty: f64,
    /// [low, high] of the near-optimal band.
    pub band: (f64, f64),
    /// Every evaluated point, sorted by x.
    pub points: Vec<Point>,
}

/// Score of a point for the search: the replicate mean, or `penalty` if any replicate has no
/// value (a field where some replicate never reaches the target is no candidate).
fn score(point: &Point, penalty: f64) -> f64 {
    if point.complete() {
        point.mean()
    } else {
        penalty
    }
}

struct Objective<'a, F: FnMut(&[f64]) -> Vec<Vec<Option<f64>>>> {
    evaluate: RefCell<F>,
    points: &'a RefCell<Vec<Point>>,
    penalty: f64,
    log: bool,
}

impl<F: FnMut(&[f64]) -> Vec<Vec<Option<f64>>>> Objective<'_, F> {
    fn at(&self, x: f64) -> f64 {
        self.all(&[x])[0]
    }

    /// Scores of the points xs: those not yet evaluated are evaluated as one batch, and kept
    /// in the order of xs.
    fn all(&self, xs: &[f64]) -> Vec<f64> {
        let mut fresh: Vec<f64> = Vec::new();
        for &x in xs {
            let known = self.points.borrow().iter().any(|p| p.x == x);
            if !known && !fresh.contains(&x) {
                fresh.push(x);
            }
        }
        if !fresh.is_empty() {
            let values = (self.evaluate.borrow_mut())(&fresh);
            let new = fresh
                .iter()
                .zip(values)
                .map(|(&x, values)| Point { x, values });
            self.points.borrow_mut().extend(new);
        }
        let points = self.points.borrow();
        xs.iter()
            .map(|&x| {
                let p = points.iter().find(|p| p.x == x).expect("evaluated above");
                score(p, self.penalty)
            })
            .collect()
    }
}

impl<F: FnMut(&[f64]) -> Vec<Vec<Option<f64>>>> CostFunction for Objective<'_, F> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, u: &f64) -> Result<f64, argmin::core::Error> {
        Ok(self.at(if self.log { u.exp() } else { *u }))
    }
}

/// Minimizes `evaluate` (a batch of x ↦ per-point, per-replicate values) over
/// [lower, upper], on a log scale if `settings.log`. The scan's points are one batch (a
/// caller may run them in parallel), Brent's one point each. `penalty` scores points where a
/// replicate has no value.
pub fn minimize_1d(
    settings: &Settings,
    penalty: f64,
    evaluate: impl FnMut(&[f64]) -> Vec<Vec<Option<f64>>>,
) -> Optimum {
    let points = RefCell::new(Vec::new());
    let objective = Objective {
        evaluate: RefCell::new(evaluate),
        points: &points,
        penalty,
        log: settings.log,
    };
    let to_u = |x: f64| if settings.log { x.ln() } else { x };
    let from_u = |u: f64| if settings.log { u.exp() } else { u };
    let (lo, hi) = (to_u(settings.lower), to_u(settings.upper));
    let n = settings.scan_points.max(3);
    let grid: Vec<f64> = (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
        .collect();
    let scores = objective.all(&grid.iter().map(|&u| from_u(u)).collect::<Vec<_>>());
    let best = (0..n)
        .min_by(|&a, &b| scores[a].total_cmp(&scores[b]))
        .unwrap();
    let (a, b) = (grid[best.saturating_sub(1)], grid[(best + 1).min(n - 1)]);
    if settings.brent_iterations > 0 && scores[best] < penalty {
        let tol = settings.rel_tolerance;
        let solver = BrentOpt::new(a, b).set_tolerance(tol, tol);
        let run = Executor::new(&objective, solver)
            .configure(|state| state.max_iters(settings.brent_iterations))
            .run();
        // An argmin error only means the bracket was degenerate: the scan result stands.
        let _ = run;
    }
    let mut points = points.into_inner();
    points.sort_by(|p, q| p.x.total_cmp(&q.x));
    summarize(points, settings.band, penalty, settings.log)
}

impl<F: FnMut(&[f64]) -> Vec<Vec<Option<f64>>>> CostFunction for &Objective<'_, F> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, ln_x: &f64) -> Result<f64, argmin::core::Error> {
        (*self).cost(ln_x)
    }
}

/// A batch evaluation from a one-point evaluation (the batch's points one after another).
pub fn pointwise(
    mut evaluate: impl FnMut(f64) -> Vec<Option<f64>>,
) -> impl FnMut(&[f64]) -> Vec<Vec<Option<f64>>> {
    move |xs| xs.iter().map(|&x| evaluate(x)).collect()
}

fn summarize(points: Vec<Point>, band: f64, penalty: f64, log: bool) -> Optimum {
    let scores: Vec<f64> = points.iter().map(|p| score(p, penalty)).collect();
    let best = (0..points.len())
        .min_by(|&a, &b| scores[a].total_cmp(&scores[b]))
        .unwrap();
    let replicates = points[0].values.len();
    let minima: Vec<f64> = (0..replicates)
        .filter_map(|r| replicate_minimum(&points, r, log))
        .collect();
    let uncertainty = if minima.len() >= 2 {
        let single = Point {
            x: 0.0,
            values: minima.iter().map(|&m| Some(m)).collect(),
        };
        single.std() / (minima.len() as f64).sqrt()
    } else {
        f64::NAN
    };
    let level = scores[best] * (1.0 + band);
    Optimum {
        x: points[best].x,
        value: scores[best],
        uncertainty,
        band: band_around(&points, &scores, best, level, log),
        points,
    }
}

/// Replicate r's minimum: vertex of the parabola in ln x through its best point and the two
/// neighbours (the best point itself at an end or if the parabola is not convex).
fn replicate_minimum(points: &[Point], r: usize, log: bool) -> Option<f64> {
    let (to_u, from_u) = scale(log);
    let data: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| p.values[r].map(|v| (to_u(p.x), v)))
        .collect();
    let k = (0..data.len()).min_by(|&a, &b| data[a].1.total_cmp(&data[b].1))?;
    if k == 0 || k + 1 == data.len() {
        return Some(from_u(data[k].0));
    }
    let ((x0, y0), (x1, y1), (x2, y2)) = (data[k - 1], data[k], data[k + 1]);
    let num = (x1 - x0).powi(2) * (y1 - y2) - (x1 - x2).powi(2) * (y1 - y0);
    let den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0);
    if den.abs() < f64::MIN_POSITIVE {
        return Some(from_u(x1));
    }
    let vertex = x1 - 0.5 * num / den;
    Some(from_u(vertex.clamp(x0, x2)))
}

/// A coordinate transform.
type Transform = fn(f64) -> f64;

/// The coordinate transform of a scale and its inverse.
fn scale(log: bool) -> (Transform, Transform) {
    if log {
        (f64::ln, f64::exp)
    } else {
        (|x| x, |x| x)
    }
}

/// The connected interval around `best` where the interpolated score stays ≤ level.
fn band_around(points: &[Point], scores: &[f64], best: usize, level: f64, log: bool) -> (f64, f64) {
    let (to_u, from_u) = scale(log);
    let cross = |i: usize, j: usize| {
        // linear interpolation (in ln x on a log scale) between an inside point i and an
        // outside point j
        let (xi, xj) = (to_u(points[i].x), to_u(points[j].x));
        let t = (level - scores[i]) / (scores[j] - scores[i]);
        from_u(xi + t * (xj - xi))
    };
    let mut lo = best;
    while lo > 0 && scores[lo - 1] <= level {
        lo -= 1;
    }
    let mut hi = best;
    while hi + 1 < points.len() && scores[hi + 1] <= level {
        hi += 1;
    }
    let low = if lo == 0 {
        points[0].x
    } else {
        cross(lo, lo - 1)
    };
    let high = if hi + 1 == points.len() {
        points[hi].x
    } else {
        cross(hi, hi + 1)
    };
    (low, high)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_minimum_of_a_smooth_function_and_its_band() {
        // f(x) = 1 + (ln x − ln 30)²: minimum at 30, band f ≤ 1.02 ⇔ |ln x − ln 30| ≤ √0.02.
        let settings = Settings {
            lower: 5.0,
            upper: 100.0,
            scan_points: 7,
            brent_iterations: 40,
            rel_tolerance: 1e-8,
            band: 0.02,
            log: true,
        };
        let mut batches = Vec::new();
        let opt = minimize_1d(&settings, 1e9, |xs: &[f64]| {
            batches.push(xs.len());
            let f = |x: f64| 1.0 + (x.ln() - 30f64.ln()).powi(2);
            xs.iter().map(|&x| vec![Some(f(x)), Some(f(x))]).collect()
        });
        // the scan is one batch (run in parallel by studies), Brent's points one each
        assert_eq!(batches[0], 7);
        assert!(batches[1..].iter().all(|&n| n == 1), "{batches:?}");
        assert!((opt.x / 30.0 - 1.0).abs() < 1e-4, "{}", opt.x);
        let w = 0.02f64.sqrt();
        // interpolation between evaluated points: the band is approximate but close
        assert!(
            (opt.band.0.ln() - (30f64.ln() - w)).abs() < 0.05,
            "{:?}",
            opt.band
        );
        assert!(
            (opt.band.1.ln() - (30f64.ln() + w)).abs() < 0.05,
            "{:?}",
            opt.band
        );
        assert_eq!(opt.uncertainty, 0.0);
    }

    #[test]
    fn replicate_spread_gives_uncertainty() {
        // Two replicates with minima at 20 and 40: the mean's minimum is between, the standard
        // error of the two minima is |ln-space parabola vertices| spread / √2.
        let settings = Settings {
            lower: 5.0,
            upper: 100.0,
            scan_points: 9,
            brent_iterations: 40,
            rel_tolerance: 1e-8,
            band: 0.02,
            log: true,
        };
        let opt = minimize_1d(
            &settings,
            1e9,
            pointwise(|x| {
                let a = 1.0 + (x.ln() - 20f64.ln()).powi(2);
                let b = 1.0 + (x.ln() - 40f64.ln()).powi(2);
                vec![Some(a), Some(b)]
            }),
        );
        assert!((opt.x - 800f64.sqrt()).abs() < 1e-2 * opt.x, "{}", opt.x);
        assert!((opt.uncertainty - 10.0).abs() < 0.5, "{}", opt.uncertainty);
    }
}
