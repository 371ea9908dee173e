//! Neighbour search in D dimensions (3 by default): a cell grid feeding a Verlet list (all
//! pairs closer than R_i + R_j + skin), rebuilt when some particle has moved more than half the
//! skin since the last build, so no pair inside R_i + R_j is ever missed. Building is O(N); no
//! O(N²) loop exists outside tests.
//!
//! A fixed cut-off r_c with list radius r_v (the usual MD Verlet list) is the special case
//! R_i = r_c/2, skin = r_v − r_c; a plain cell list is a list rebuilt every step with skin 0.
//! A list may also be rebuilt on another displacement than half its skin
//! ([`NeighborList::with_rebuild_distance`]): then pairs can enter R_i + R_j unseen between
//! builds, which is what a list summed without a cut-off (de Paula 2025, §5.1) does. Or it may
//! wait until the displacements spread over the skin ([`NeighborList::rebuilt_on_spread`]),
//! which misses no pair either and lasts longer where part of the set moves as one. A caller
//! that moves every point can run either check in its own pass ([`NeighborList::watch`],
//! [`NeighborList::spread_watch`]), so that the list needs no walk of its own.

use std::ops::Range;

use nalgebra::SVector;
use rayon::prelude::*;

use crate::numerics::fold_items;

mod grid;
mod spread;

use grid::{CellGrid, Query};
pub use spread::{Spread, SpreadWatch};

/// From this many points on, a build searches in parallel blocks of `BUILD_BLOCK` points.
const PARALLEL_BUILD_FROM: usize = 1024;
const BUILD_BLOCK: usize = 256;

/// Full (both directions) Verlet neighbour list in compressed-row form.
#[derive(Debug, Clone)]
pub struct NeighborList<const D: usize = 3> {
    offsets: Vec<usize>,
    neighbors: Vec<u32>,
    reference: Vec<SVector<f64, D>>,
    skin: f64,
    rule: Rebuild,
    builds: usize,
    /// The displacements' box centre at the last two checks seen by a [`SpreadWatch`] since
    /// the build (zero before): the watch's guess of the next.
    centres: [SVector<f64, D>; 2],
}

/// The lower and upper corners of a bounding box.
type Bounds<const D: usize> = (SVector<f64, D>, SVector<f64, D>);

/// A distance-rule list's rebuild check of single points (see [`NeighborList::watch`]).
#[derive(Debug, Clone, Copy)]
pub struct Watch<'a, const D: usize> {
    reference: &'a [SVector<f64, D>],
    limit2: f64,
}

impl<const D: usize> Watch<'_, D> {
    /// Whether point i at `p` has moved beyond the rebuild distance since the build.
    pub fn beyond(&self, i: usize, p: &SVector<f64, D>) -> bool {
        (p - self.reference[i]).norm_squared() > self.limit2
    }

    /// Whether some point of `block`, the points from index `start` on, has.
    pub fn any_beyond(&self, start: usize, block: &[SVector<f64, D>]) -> bool {
        (start..).zip(block).any(|(i, p)| self.beyond(i, p))
    }
}

/// When a list is rebuilt.
#[derive(Debug, Clone, Copy)]
enum Rebuild {
    /// When some particle's displacement since the build differs by more than half the skin
    /// from c, the centre of the displacements' bounding box, and from zero: two particles
    /// have then approached each other by at most |Δ_i − c| + |Δ_j − c| ≤ the skin, so no
    /// pair within R_i + R_j is missed. Never sooner than the half-skin rule (c = 0 is also
    /// tried), and twice as late where part of the set moves as one (a bed falling onto its
    /// settled floor: c is then half the fall).
    Spread,
    /// When some particle has moved more than this distance.
    Distance(f64),
}

impl<const D: usize> NeighborList<D> {
    /// An empty list with the given skin (same length unit as the positions).
    pub fn new(skin: f64) -> Self {
        Self::with_rebuild_distance(skin, 0.5 * skin)
    }

    /// An empty list with the given skin, rebuilt only when the particles' displacements
    /// spread over more than the skin (see `Rebuild::Spread`).
    pub fn rebuilt_on_spread(skin: f64) -> Self {
        Self {
            rule: Rebuild::Spread,
            ..Self::new(skin)
        }
    }

    /// An empty list with the given skin, rebuilt when some particle has moved more than
    /// `rebuild` since the last build (same length unit as the positions).
    pub fn with_rebuild_distance(skin: f64, rebuild: f64) -> Self {
        Self {
            offsets: Vec::new(),
            neighbors: Vec::new(),
            reference: Vec::new(),
            skin,
            rule: Rebuild::Distance(rebuild),
            builds: 0,
            centres: [SVector::zeros(); 2],
        }
    }

    /// Neighbours of particle i, ascending.
    pub fn of(&self, i: usize) -> &[u32] {
        &self.neighbors[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of builds so far (a diagnostic).
    pub fn builds(&self) -> usize {
        self.builds
    }

    /// Total number of stored (directed) neighbour entries.
    pub fn len(&self) -> usize {
        self.neighbors.len()
    }

    /// Whether the list holds no pairs.
    pub fn is_empty(&self) -> bool {
        self.neighbors.is_empty()
    }

    /// Rebuilds if needed; returns whether it did.
    pub fn update(&mut self, positions: &[SVector<f64, D>], radii: &[f64]) -> bool {
        if self.needs_rebuild(positions) {
            self.build(positions, radii);
            true
        } else {
            false
        }
    }

    /// The displacement check of a list rebuilt on a distance and built for `n` points, for a
    /// caller that moves the points to run as it moves them ([`Self::update_watched`]); None
    /// for a list rebuilt on the spread or not built for `n` points.
    pub fn watch(&self, n: usize) -> Option<Watch<'_, D>> {
        match self.rule {
            Rebuild::Distance(limit) if self.reference.len() == n => Some(Watch {
                reference: &self.reference,
                limit2: limit * limit,
            }),
            _ => None,
        }
    }

    /// [`Self::update`] for a caller that ran [`Self::watch`] over every point as it moved
    /// them: `beyond` is whether some point went beyond. Rebuilds if needed; returns whether
    /// it did.
    pub fn update_watched(
        &mut self,
        positions: &[SVector<f64, D>],
        radii: &[f64],
        beyond: bool,
    ) -> bool {
        debug_assert!(self.watch(positions.len()).is_some());
        if beyond {
            self.build(positions, radii);
        }
        beyond
    }

    fn needs_rebuild(&self, positions: &[SVector<f64, D>]) -> bool {
        let n = positions.len();
        if self.reference.len() != n {
            return true;
        }
        // scans of every particle, each step: on the pool for large sets (`any`, min and max
        // give the same answer in any order)
        let any = |a, b| a || b;
        if let Some(watch) = self.watch(n) {
            return fold_items(n, false, |i| watch.beyond(i, &positions[i]), any);
        }
        // the spread rule
        if !self.beyond(positions, SVector::zeros()) {
            return false;
        }
        let moved = |i: usize| positions[i] - self.reference[i];
        let far = SVector::<f64, D>::repeat(f64::INFINITY);
        let bounds = |i: usize| (moved(i), moved(i));
        let merge = |(lo, hi): Bounds<D>, (a, b): Bounds<D>| (lo.inf(&a), hi.sup(&b));
        let (lo, hi) = fold_items(n, (far, -far), bounds, merge);
        self.beyond(positions, 0.5 * (lo + hi))
    }

    /// Whether some point's displacement since the build differs from `centre` by more than
    /// half the skin.
    fn beyond(&self, positions: &[SVector<f64, D>], centre: SVector<f64, D>) -> bool {
        let limit2 = (0.5 * self.skin).powi(2);
        let out = |i: usize| (positions[i] - self.reference[i] - centre).norm_squared() > limit2;
        fold_items(positions.len(), false, out, |a, b| a || b)
    }

    /// Builds the list from a cell grid of cell size 2 R_max + skin; large sets are searched
    /// in blocks on the rayon pool, concatenated in index order (the same list either way).
    pub fn build(&mut self, positions: &[SVector<f64, D>], radii: &[f64]) {
        let n = positions.len();
        let grid = CellGrid::new(positions, radii, self.skin);
        let (skin, lanes) = (self.skin, crate::numerics::has_avx());
        let block = |range: Range<usize>| {
            let (mut found, mut counts) = (Vec::new(), Vec::with_capacity(range.len()));
            for i in range {
                let start = found.len();
                let query = Query {
                    point: positions[i],
                    index: i as u32,
                    radius: radii[i],
                    skin,
                };
                grid.find_near(&query, lanes, &mut found);
                found[start..].sort_unstable();
                counts.push(found.len() - start);
            }
            (found, counts)
        };
        let blocks: Vec<(Vec<u32>, Vec<usize>)> = if n >= PARALLEL_BUILD_FROM {
            // one block per task: the pool's default split, about two pieces per thread,
            // leaves a thread waiting where the density varies along the index (cell order)
            (0..n.div_ceil(BUILD_BLOCK))
                .into_par_iter()
                .with_max_len(1)
                .map(|b| block(b * BUILD_BLOCK..((b + 1) * BUILD_BLOCK).min(n)))
                .collect()
        } else {
            vec![block(0..n)]
        };
        self.offsets.clear();
        self.offsets.push(0);
        let mut end = 0;
        for count in blocks.iter().flat_map(|(_, counts)| counts) {
            end += count;
            self.offsets.push(end);
        }
        self.concatenate(&blocks, end);
        self.reference.clear();
        self.reference.extend_from_slice(positions);
        self.centres = [SVector::zeros(); 2];
        self.builds += 1;
    }
}

impl<const D: usize> NeighborList<D> {
    /// Sets the entries to the blocks' found neighbours, `total` of them, one after the
    /// other, copied on the pool (the length grows without clearing, so only entries beyond
    /// the last build's are zeroed first).
    fn concatenate(&mut self, blocks: &[(Vec<u32>, Vec<usize>)], total: usize) {
        self.neighbors.resize(total, 0);
        let mut rest = &mut self.neighbors[..];
        let mut parts = Vec::with_capacity(blocks.len());
        for (found, _) in blocks {
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(found.len());
            parts.push((part, found));
            rest = tail;
        }
        let copy = |(part, found): (&mut [u32], &Vec<u32>)| part.copy_from_slice(found);
        if parts.len() > 1 {
            parts.into_par_iter().for_each(copy);
        } else {
            parts.into_iter().for_each(copy);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};
    use rand::{RngExt, SeedableRng};

    #[test]
    fn matches_all_pairs_search() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let n = 400;
        let positions: Vec<Vector3<f64>> = (0..n)
            .map(|_| {
                Vector3::new(
                    rng.random::<f64>() * 20.0,
                    rng.random::<f64>() * 10.0,
                    rng.random::<f64>() * 5.0,
                )
            })
            .collect();
        let radii: Vec<f64> = (0..n).map(|_| 0.8 + 0.4 * rng.random::<f64>()).collect();
        let mut list = NeighborList::<3>::new(0.3);
        list.build(&positions, &radii);
        for i in 0..n {
            let brute: Vec<u32> = (0..n)
                .filter(|&j| {
                    j != i && (positions[j] - positions[i]).norm() < radii[i] + radii[j] + 0.3
                })
                .map(|j| j as u32)
                .collect();
            assert_eq!(list.of(i), &brute[..], "particle {i}");
        }
    }

    #[test]
    fn parallel_blocks_give_the_all_pairs_list() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let n = PARALLEL_BUILD_FROM + BUILD_BLOCK / 2;
        let positions: Vec<Vector2<f64>> = (0..n)
            .map(|_| Vector2::new(rng.random::<f64>() * 60.0, rng.random::<f64>() * 40.0))
            .collect();
        let radii = vec![0.5; n];
        let mut list = NeighborList::<2>::new(0.2);
        list.build(&positions, &radii);
        let mut entries = 0;
        for i in 0..n {
            let brute: Vec<u32> = (0..n)
                .filter(|&j| j != i && (positions[j] - positions[i]).norm() < 1.2)
                .map(|j| j as u32)
                .collect();
            assert_eq!(list.of(i), &brute[..], "particle {i}");
            entries += brute.len();
        }
        assert_eq!(list.len(), entries);
    }

    #[test]
    fn sparse_spread_out_points_get_a_bounded_grid() {
        let positions = vec![
            Vector3::zeros(),
            Vector3::new(1e6, 1e6, 1e6),
            Vector3::new(0.5, 0.0, 0.0),
        ];
        let mut list = NeighborList::<3>::new(0.0);
        list.build(&positions, &[0.3; 3]);
        assert_eq!(list.of(0), &[2]);
        assert!(list.of(1).is_empty());
    }

    #[test]
    fn rebuilds_only_after_half_skin_displacement() {
        let positions = vec![Vector3::zeros(), Vector3::new(3.0, 0.0, 0.0)];
        let radii = vec![1.0, 1.0];
        let mut list = NeighborList::<3>::new(0.4);
        assert!(list.update(&positions, &radii));
        let moved = vec![Vector3::new(0.19, 0.0, 0.0), positions[1]];
        assert!(!list.update(&moved, &radii));
        let moved = vec![Vector3::new(0.21, 0.0, 0.0), positions[1]];
        assert!(list.update(&moved, &radii));
    }

    #[test]
    fn a_spread_list_waits_for_relative_motion() {
        let positions = vec![Vector3::zeros(), Vector3::new(3.0, 0.0, 0.0)];
        let radii = vec![1.0, 1.0];
        let mut list = NeighborList::<3>::rebuilt_on_spread(0.4);
        assert!(list.update(&positions, &radii));
        // one falls 0.3 (beyond half the skin) while the other rests: 0.15 from the centre
        let moved = vec![Vector3::new(0.0, 0.0, -0.3), positions[1]];
        assert!(!list.update(&moved, &radii));
        let moved = vec![Vector3::new(0.0, 0.0, -0.41), positions[1]];
        assert!(list.update(&moved, &radii));
        // both moving as one never need a rebuild
        let far = Vector3::new(5.0, -7.0, 2.0);
        let moved: Vec<_> = list.reference.iter().map(|p| p + far).collect();
        assert!(!list.update(&moved, &radii));
    }

    /// A watched update (the mover checks each point) rebuilds at the same steps as the
    /// list's own check, block by block from any start; a spread list has no watch.
    #[test]
    fn a_watched_update_rebuilds_when_the_list_would() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let n = 300;
        let mut positions: Vec<Vector2<f64>> = (0..n)
            .map(|_| Vector2::new(rng.random::<f64>() * 20.0, rng.random::<f64>() * 20.0))
            .collect();
        let radii = vec![0.5; n];
        let (mut own, mut watched) = (NeighborList::<2>::new(0.4), NeighborList::<2>::new(0.4));
        assert!(watched.watch(n).is_none(), "no watch before a build");
        own.update(&positions, &radii);
        watched.update(&positions, &radii);
        for _ in 0..200 {
            for p in &mut positions {
                *p += Vector2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5) * 0.05;
            }
            let watch = watched.watch(n).expect("a built distance list has a watch");
            let beyond = positions
                .chunks(64)
                .enumerate()
                .any(|(b, c)| watch.any_beyond(64 * b, c));
            assert_eq!(
                watched.update_watched(&positions, &radii, beyond),
                own.update(&positions, &radii)
            );
        }
        assert!(
            own.builds() > 5,
            "the moves rebuilt the list: {}",
            own.builds()
        );
        assert_eq!(own.builds(), watched.builds());
        assert!(NeighborList::<2>::rebuilt_on_spread(0.4).watch(0).is_none());
    }

    /// Random steps, half the points also drifting as one: after every update the list holds
    /// every pair within R_i + R_j, with fewer builds than the half-skin rule.
    #[test]
    fn a_spread_list_never_misses_a_pair() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let n = 300;
        let mut positions: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::from_fn(|_, _| rng.random::<f64>() * 9.0))
            .collect();
        let radii: Vec<f64> = (0..n).map(|_| 0.4 + 0.2 * rng.random::<f64>()).collect();
        let (mut spread, mut half) = (
            NeighborList::<3>::rebuilt_on_spread(0.3),
            NeighborList::<3>::new(0.3),
        );
        for _ in 0..200 {
            for (k, p) in positions.iter_mut().enumerate() {
                *p += Vector3::from_fn(|_, _| 0.01 * (rng.random::<f64>() - 0.5));
                if k % 2 == 0 {
                    p.z -= 0.02;
                }
            }
            spread.update(&positions, &radii);
            half.update(&positions, &radii);
            for i in 0..n {
                for j in (0..n).filter(|&j| j != i) {
                    if (positions[j] - positions[i]).norm() < radii[i] + radii[j] {
                        assert!(spread.of(i).contains(&(j as u32)), "{i}–{j} missed");
                    }
                }
            }
        }
        assert!(
            spread.builds() < half.builds(),
            "{} {}",
            spread.builds(),
            half.builds()
        );
    }

    #[test]
    fn a_rebuild_distance_replaces_the_half_skin_rule() {
        let positions = vec![Vector2::zeros(), Vector2::new(2.4, 0.0)];
        let radii = vec![1.0, 1.0];
        let mut list = NeighborList::<2>::with_rebuild_distance(0.0, 0.5);
        assert!(list.update(&positions, &radii));
        assert!(list.of(0).is_empty());
        // the pair is now inside R_i + R_j = 2, unseen until a particle has moved 0.5
        let moved = vec![positions[0], Vector2::new(2.4 - 0.49, 0.0)];
        assert!(!list.update(&moved, &radii));
        assert!(list.of(0).is_empty());
        let moved = vec![positions[0], Vector2::new(2.4 - 0.51, 0.0)];
        assert!(list.update(&moved, &radii));
        assert_eq!(list.of(0), &[1]);
    }

    #[test]
    fn fixed_cutoff_list_matches_all_pairs_in_2d() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 300;
        let positions: Vec<Vector2<f64>> = (0..n)
            .map(|_| Vector2::new(rng.random::<f64>() * 30.0, rng.random::<f64>() * 12.0))
            .collect();
        let (r_c, r_v) = (2.5, 3.0);
        let radii = vec![0.5 * r_c; n];
        let mut list = NeighborList::<2>::new(r_v - r_c);
        list.build(&positions, &radii);
        for i in 0..n {
            let brute: Vec<u32> = (0..n)
                .filter(|&j| j != i && (positions[j] - positions[i]).norm() < r_v)
                .map(|j| j as u32)
                .collect();
            assert_eq!(list.of(i), &brute[..], "particle {i}");
        }
    }
}
