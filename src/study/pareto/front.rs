//! Pareto dominance, fast non-dominated sorting and crowding distance (Deb, Pratap, Agarwal &
//! Meyarivan 2002, §III-A and §III-B). Every objective is minimized.

/// Whether `a` Pareto-dominates `b` (minimization): `a` is no worse in every objective and
/// strictly better in at least one. NaN compares as neither better nor worse, so a point with
/// a NaN never dominates and is never dominated through that objective.
pub fn dominates(a: &[f64], b: &[f64]) -> bool {
    debug_assert_eq!(a.len(), b.len());
    let mut better = false;
    for (x, y) in a.iter().zip(b) {
        if x > y {
            return false;
        }
        if x < y {
            better = true;
        }
    }
    better
}

/// Deb's fast non-dominated sort: the fronts F1, F2, … as indices into `points`, each front in
/// increasing index order. F1 holds the points nobody dominates, F2 those dominated only by
/// points of F1, and so on. O(M N²) comparisons.
pub fn non_dominated_sort(points: &[Vec<f64>]) -> Vec<Vec<usize>> {
    let n = points.len();
    // dominated_by[p]: the points p dominates; count[p]: how many points dominate p
    let mut dominated_by: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut count = vec![0usize; n];
    for p in 0..n {
        for q in p + 1..n {
            if dominates(&points[p], &points[q]) {
                dominated_by[p].push(q);
                count[q] += 1;
            } else if dominates(&points[q], &points[p]) {
                dominated_by[q].push(p);
                count[p] += 1;
            }
        }
    }
    let mut fronts = Vec::new();
    let mut current: Vec<usize> = (0..n).filter(|&p| count[p] == 0).collect();
    while !current.is_empty() {
        let mut next = Vec::new();
        for &p in &current {
            for &q in &dominated_by[p] {
                count[q] -= 1;
                if count[q] == 0 {
                    next.push(q);
                }
            }
        }
        next.sort_unstable();
        fronts.push(current);
        current = next;
    }
    fronts
}

/// Non-dominated sort of points some of whose objectives may be missing (`None`, or any
/// objective `None`): the complete points are sorted as by [`non_dominated_sort`], and every
/// incomplete point is dominated by all of them, forming one last front of its own.
pub fn sort_with_missing(points: &[Option<Vec<f64>>]) -> Vec<Vec<usize>> {
    let complete: Vec<usize> = (0..points.len())
        .filter(|&i| {
            points[i]
                .as_ref()
                .is_some_and(|f| f.iter().all(|v| v.is_finite()))
        })
        .collect();
    let values: Vec<Vec<f64>> = complete
        .iter()
        .map(|&i| points[i].clone().expect("complete"))
        .collect();
    let mut fronts: Vec<Vec<usize>> = non_dominated_sort(&values)
        .into_iter()
        .map(|front| front.into_iter().map(|k| complete[k]).collect())
        .collect();
    let missing: Vec<usize> = (0..points.len())
        .filter(|i| complete.binary_search(i).is_err())
        .collect();
    if !missing.is_empty() {
        fronts.push(missing);
    }
    fronts
}

/// Crowding distance of each member of one front (same order as `front`): for every
/// objective, the members are sorted by it, the two extremes get +∞ and each other member
/// adds the normalized distance between its two neighbours, (f_{i+1} − f_{i−1}) / (f_max −
/// f_min). An objective that is constant over the front adds nothing. Fronts of one or two
/// members are all extremes (+∞).
#[allow(clippy::needless_range_loop)] // k indexes the objectives of several points
pub fn crowding_distance(points: &[Vec<f64>], front: &[usize]) -> Vec<f64> {
    let n = front.len();
    let mut distance = vec![0.0; n];
    if n <= 2 {
        return vec![f64::INFINITY; n];
    }
    let m = points[front[0]].len();
    let mut order: Vec<usize> = (0..n).collect();
    for k in 0..m {
        let value = |i: usize| points[front[i]][k];
        order.sort_by(|&a, &b| value(a).total_cmp(&value(b)).then(a.cmp(&b)));
        let (lo, hi) = (value(order[0]), value(order[n - 1]));
        distance[order[0]] = f64::INFINITY;
        distance[order[n - 1]] = f64::INFINITY;
        let span = hi - lo;
        if !(span > 0.0 && span.is_finite()) {
            continue;
        }
        for w in 1..n - 1 {
            let i = order[w];
            if distance[i].is_finite() {
                distance[i] += (value(order[w + 1]) - value(order[w - 1])) / span;
            }
        }
    }
    distance
}

/// The indices of the non-dominated points among the complete ones (the first front of
/// [`sort_with_missing`]; empty if no point is complete).
pub fn non_dominated(points: &[Option<Vec<f64>>]) -> Vec<usize> {
    let fronts = sort_with_missing(points);
    match fronts.first() {
        Some(first)
            if points[first[0]]
                .as_ref()
                .is_some_and(|f| f.iter().all(|v| v.is_finite())) =>
        {
            first.clone()
        }
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Fronts by definition: peel off the points nobody left dominates, repeatedly.
    fn brute_force(points: &[Vec<f64>]) -> Vec<Vec<usize>> {
        let mut left: Vec<usize> = (0..points.len()).collect();
        let mut fronts = Vec::new();
        while !left.is_empty() {
            let front: Vec<usize> = left
                .iter()
                .copied()
                .filter(|&p| !left.iter().any(|&q| dominates(&points[q], &points[p])))
                .collect();
            left.retain(|p| !front.contains(p));
            fronts.push(front);
        }
        fronts
    }

    #[test]
    fn dominance_is_strict_and_by_definition() {
        assert!(dominates(&[1.0, 2.0], &[1.0, 3.0]));
        assert!(
            !dominates(&[1.0, 3.0], &[1.0, 3.0]),
            "equal points do not dominate"
        );
        assert!(!dominates(&[0.0, 4.0], &[1.0, 3.0]));
        assert!(!dominates(&[1.0, 3.0], &[0.0, 4.0]));
        assert!(dominates(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1e-12]));
    }

    #[test]
    fn sort_matches_brute_force_on_random_points() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for trial in 0..60 {
            let m = 2 + trial % 3;
            let n = 1 + rng.random_range(0..80usize);
            // coarse grid values: many ties and equal points
            let points: Vec<Vec<f64>> = (0..n)
                .map(|_| (0..m).map(|_| rng.random_range(0..6u32) as f64).collect())
                .collect();
            assert_eq!(
                non_dominated_sort(&points),
                brute_force(&points),
                "trial {trial}"
            );
            let continuous: Vec<Vec<f64>> = (0..n)
                .map(|_| (0..m).map(|_| rng.random::<f64>()).collect())
                .collect();
            assert_eq!(
                non_dominated_sort(&continuous),
                brute_force(&continuous),
                "trial {trial}"
            );
        }
        assert!(non_dominated_sort(&[]).is_empty());
    }

    #[test]
    fn missing_objectives_form_the_last_front() {
        let points = vec![
            Some(vec![1.0, 1.0]),
            None,
            Some(vec![2.0, 2.0]),
            Some(vec![0.5, f64::NAN]),
            Some(vec![3.0, 0.0]),
        ];
        assert_eq!(
            sort_with_missing(&points),
            vec![vec![0, 4], vec![2], vec![1, 3]]
        );
        assert_eq!(non_dominated(&points), vec![0, 4]);
        assert!(non_dominated(&[None, None]).is_empty());
    }

    #[test]
    fn crowding_of_extremes_is_infinite_and_interior_is_the_normalized_cuboid() {
        // f2 = 1 − f1 on f1 = 0, 0.1, 0.4, 1: interior members' cuboid sides
        let points = vec![
            vec![0.4, 0.6],
            vec![0.0, 1.0],
            vec![1.0, 0.0],
            vec![0.1, 0.9],
        ];
        let d = crowding_distance(&points, &[0, 1, 2, 3]);
        assert!(d[1].is_infinite() && d[2].is_infinite());
        // member 3 (f1 = 0.1): neighbours 0 and 0.4 in both objectives → 0.4 + 0.4
        assert!((d[3] - 0.8).abs() < 1e-12, "{d:?}");
        // member 0 (f1 = 0.4): neighbours 0.1 and 1 → 0.9 + 0.9
        assert!((d[0] - 1.8).abs() < 1e-12, "{d:?}");
        assert!(crowding_distance(&points, &[0, 1])
            .iter()
            .all(|d| d.is_infinite()));
        // three objectives, random front: the extremes of every objective are infinite
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let points: Vec<Vec<f64>> = (0..30)
            .map(|_| (0..3).map(|_| rng.random::<f64>()).collect())
            .collect();
        let front: Vec<usize> = (0..30).collect();
        let d = crowding_distance(&points, &front);
        #[allow(clippy::needless_range_loop)]
        for k in 0..3 {
            let lo = (0..30)
                .min_by(|&a, &b| points[a][k].total_cmp(&points[b][k]))
                .unwrap();
            let hi = (0..30)
                .max_by(|&a, &b| points[a][k].total_cmp(&points[b][k]))
                .unwrap();
            assert!(d[lo].is_infinite() && d[hi].is_infinite());
        }
        assert!(d.iter().filter(|d| d.is_finite()).all(|&d| d > 0.0));
    }
}
