//! The hypervolume indicator (Zitzler & Thiele 1998, the "size of the space covered"): the
//! Lebesgue measure of the region dominated by a set of points and bounded by a reference
//! point, every objective minimized. Exact: a sweep for two objectives (O(n log n)), and for
//! more by slicing along the last objective (the HSO idea of While, Hingston, Barone & Huband
//! 2006): between consecutive values of the last objective the dominated region is a prism
//! whose base is the hypervolume of the points below the slice, one dimension lower. Three
//! objectives cost O(n² log n), plenty for NSGA-II fronts of a few hundred points.

/// The hypervolume dominated by `points` inside the box bounded by `reference` (minimization).
/// Points that do not strictly dominate the reference in every objective add nothing, and so
/// do non-finite ones; dominated and duplicate points are harmless. Every point must have the
/// reference's dimension (≥ 1).
pub fn hypervolume(points: &[Vec<f64>], reference: &[f64]) -> f64 {
    let d = reference.len();
    assert!(d >= 1, "a hypervolume needs at least one objective");
    let inside: Vec<&[f64]> = points
        .iter()
        .inspect(|p| assert_eq!(p.len(), d, "point and reference differ in dimension"))
        .filter(|p| p.iter().zip(reference).all(|(x, r)| x.is_finite() && x < r))
        .map(Vec::as_slice)
        .collect();
    slice(inside, reference)
}

/// The hypervolume of points that all lie strictly inside the reference box.
fn slice(mut points: Vec<&[f64]>, reference: &[f64]) -> f64 {
    let d = reference.len();
    match (points.len(), d) {
        (0, _) => 0.0,
        (_, 1) => reference[0] - points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
        (_, 2) => sweep_2d(points, reference),
        _ => {
            // slabs along the last objective, from its smallest value up to the reference
            let last = d - 1;
            points.sort_by(|a, b| a[last].total_cmp(&b[last]));
            let mut volume = 0.0;
            let mut below: Vec<&[f64]> = Vec::with_capacity(points.len());
            let mut k = 0;
            while k < points.len() {
                let z = points[k][last];
                while k < points.len() && points[k][last] == z {
                    below.push(&points[k][..last]);
                    k += 1;
                }
                let top = if k < points.len() {
                    points[k][last]
                } else {
                    reference[last]
                };
                volume += (top - z) * slice(below.clone(), &reference[..last]);
            }
            volume
        }
    }
}

/// Two objectives: sort by the first and sum the rectangles each point adds below the lowest
/// second objective seen so far.
fn sweep_2d(mut points: Vec<&[f64]>, reference: &[f64]) -> f64 {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let mut area = 0.0;
    let mut lowest = reference[1];
    for p in points {
        if p[1] < lowest {
            area += (reference[0] - p[0]) * (lowest - p[1]);
            lowest = p[1];
        }
    }
    area
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Monte Carlo estimate of the hypervolume in the box [lower, reference] and its standard
    /// error.
    fn monte_carlo(points: &[Vec<f64>], lower: &[f64], reference: &[f64], n: usize) -> (f64, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let volume: f64 = lower.iter().zip(reference).map(|(l, r)| r - l).product();
        let mut hits = 0usize;
        let mut z = vec![0.0; lower.len()];
        for _ in 0..n {
            for (k, zk) in z.iter_mut().enumerate() {
                *zk = lower[k] + rng.random::<f64>() * (reference[k] - lower[k]);
            }
            if points.iter().any(|p| p.iter().zip(&z).all(|(a, b)| a <= b)) {
                hits += 1;
            }
        }
        let p = hits as f64 / n as f64;
        (volume * p, volume * (p * (1.0 - p) / n as f64).sqrt())
    }

    #[test]
    fn hand_cases() {
        assert_eq!(hypervolume(&[], &[1.0, 1.0]), 0.0);
        assert_eq!(hypervolume(&[vec![0.5]], &[2.0]), 1.5);
        assert_eq!(hypervolume(&[vec![0.0, 0.0]], &[2.0, 3.0]), 6.0);
        // a staircase: (1,3), (2,2), (3,1) against (4,4): 3·1 + 2·1 + 1·1 = 6
        let stairs = vec![vec![1.0, 3.0], vec![2.0, 2.0], vec![3.0, 1.0]];
        assert_eq!(hypervolume(&stairs, &[4.0, 4.0]), 6.0);
        // a dominated point, a duplicate and a point outside the box change nothing
        let mut more = stairs.clone();
        more.extend([
            vec![3.0, 3.0],
            vec![2.0, 2.0],
            vec![5.0, 0.0],
            vec![0.0, 4.0],
        ]);
        assert_eq!(hypervolume(&more, &[4.0, 4.0]), 6.0);
        // 3-D: one box, then two overlapping boxes (inclusion–exclusion)
        assert_eq!(hypervolume(&[vec![0.0, 0.0, 0.0]], &[1.0, 2.0, 3.0]), 6.0);
        let two = vec![vec![0.0, 1.0, 0.0], vec![1.0, 0.0, 1.0]];
        // 2·1·2 + 1·2·1 − 1·1·1 = 5
        assert_eq!(hypervolume(&two, &[2.0, 2.0, 2.0]), 5.0);
        // three boxes of volume 0.5 against (1, 1, 1)
        let corners = vec![
            vec![0.0, 0.0, 0.5],
            vec![0.0, 0.5, 0.0],
            vec![0.5, 0.0, 0.0],
        ];
        // union of three boxes of volume 0.5 each, pairwise overlaps 0.25, triple 0.125
        assert!((hypervolume(&corners, &[1.0, 1.0, 1.0]) - (1.5 - 0.75 + 0.125)).abs() < 1e-15);
        // 4-D by the same slicing
        assert_eq!(hypervolume(&[vec![0.0; 4]], &[1.0, 2.0, 3.0, 4.0]), 24.0);
    }

    #[test]
    fn order_and_scale_do_not_matter() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut points: Vec<Vec<f64>> = (0..40)
            .map(|_| (0..3).map(|_| rng.random::<f64>()).collect())
            .collect();
        let r = [1.1, 1.2, 1.3];
        let a = hypervolume(&points, &r);
        points.reverse();
        assert!((hypervolume(&points, &r) - a).abs() < 1e-14);
        let scaled: Vec<Vec<f64>> = points
            .iter()
            .map(|p| vec![2.0 * p[0], p[1], 10.0 * p[2]])
            .collect();
        assert!((hypervolume(&scaled, &[2.2, 1.2, 13.0]) - 20.0 * a).abs() < 1e-12);
        // permuting the objectives gives the same volume
        let permuted: Vec<Vec<f64>> = points.iter().map(|p| vec![p[2], p[0], p[1]]).collect();
        assert!((hypervolume(&permuted, &[1.3, 1.1, 1.2]) - a).abs() < 1e-14);
    }

    #[test]
    fn matches_monte_carlo_in_two_and_three_dimensions() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for (d, n) in [(2, 5), (2, 60), (3, 4), (3, 50)] {
            // points near the simplex x1 + … + xd = 1: mostly mutually non-dominated
            let points: Vec<Vec<f64>> = (0..n)
                .map(|_| {
                    let raw: Vec<f64> = (0..d).map(|_| rng.random::<f64>() + 0.05).collect();
                    let s: f64 = raw.iter().sum();
                    raw.iter().map(|x| x / s).collect()
                })
                .collect();
            let reference = vec![1.0; d];
            let exact = hypervolume(&points, &reference);
            let (estimate, se) = monte_carlo(&points, &vec![0.0; d], &reference, 400_000);
            assert!(
                (exact - estimate).abs() < 4.0 * se + 1e-12,
                "d = {d}, n = {n}: exact {exact}, Monte Carlo {estimate} ± {se}"
            );
        }
    }
}
