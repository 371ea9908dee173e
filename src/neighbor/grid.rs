//! The cell grid behind [`super::NeighborList`]: points binned into cubic cells (counting
//! sort), stored cell by cell as structure of arrays, and searched a run of cells along axis
//! 0 at a time, four candidates per AVX instruction where the processor has it. Both forms
//! compute every candidate's squared distance and reach with the same operations in the
//! same order (none fused), so they find the same pairs.

use std::ops::Range;

use nalgebra::SVector;
use rayon::prelude::*;

use crate::numerics::fold_items;

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Candidates per AVX instruction; the arrays carry `LANES − 1` padding points so a load
/// that starts inside a run stays in bounds.
const LANES: usize = 4;

/// From this many points on, the points' cells are found on the rayon pool.
const PARALLEL_FROM: usize = 4096;

/// Points binned into cubic cells, for O(1) near-point queries.
pub(super) struct CellGrid<const D: usize> {
    origin: SVector<f64, D>,
    cell: f64,
    dims: [usize; D],
    start: Vec<usize>,
    /// Each cell's points in turn: index, coordinates by axis and radius (a run of cells is
    /// read without going back to the input arrays).
    index: Vec<u32>,
    coords: [Vec<f64>; D],
    radii: Vec<f64>,
    /// The largest radius: with a query's radius and skin, how far its partners can lie.
    largest_radius: f64,
}

/// A query: the point, its index (never its own neighbour), its radius and the skin.
pub(super) struct Query<const D: usize> {
    pub point: SVector<f64, D>,
    pub index: u32,
    pub radius: f64,
    pub skin: f64,
}

impl<const D: usize> CellGrid<D> {
    /// Bins `positions` (with their `radii`) into cells of at least 2 R_max + `skin`, the
    /// reach of the widest pair.
    pub(super) fn new(positions: &[SVector<f64, D>], radii: &[f64], skin: f64) -> Self {
        let largest_radius = radii.iter().copied().fold(0.0, f64::max);
        let (lo, hi) = bounds(positions);
        // Cells of at least 2 R_max + skin; coarser where a sparse, spread-out set would
        // otherwise need more cells than about 4 per point (a query's box holds its partners at
        // any cell size).
        let target = (4 * positions.len()).max(64) as f64;
        let mut cell = 2.0 * largest_radius + skin;
        let count = |cell: f64| {
            (0..D)
                .map(|a| ((hi[a] - lo[a]) / cell).floor() + 1.0)
                .product::<f64>()
        };
        while count(cell) > target {
            cell *= 2.0;
        }
        let dims = std::array::from_fn(|a| (((hi[a] - lo[a]) / cell).floor() as usize + 1).max(1));
        let padded = positions.len() + LANES - 1;
        let mut grid = Self {
            origin: lo,
            cell,
            dims,
            start: vec![0; dims.iter().product::<usize>() + 1],
            index: vec![u32::MAX; padded],
            coords: std::array::from_fn(|_| vec![f64::NAN; padded]),
            radii: vec![f64::NAN; padded],
            largest_radius,
        };
        let cell_of = |p| grid.flat(grid.coords(p));
        let cells: Vec<usize> = if positions.len() >= PARALLEL_FROM {
            positions.par_iter().map(cell_of).collect()
        } else {
            positions.iter().map(cell_of).collect()
        };
        for &c in &cells {
            grid.start[c + 1] += 1;
        }
        for c in 1..grid.start.len() {
            grid.start[c] += grid.start[c - 1];
        }
        let mut fill = grid.start.clone();
        for (i, &c) in cells.iter().enumerate() {
            let slot = fill[c];
            grid.index[slot] = i as u32;
            for (axis, &x) in grid.coords.iter_mut().zip(positions[i].iter()) {
                axis[slot] = x;
            }
            grid.radii[slot] = radii[i];
            fill[c] += 1;
        }
        grid
    }

    fn coords(&self, p: &SVector<f64, D>) -> [usize; D] {
        std::array::from_fn(|a| self.cell_along(a, p[a]))
    }

    /// The cell coordinate along axis `a` of `x` (clamped to the grid).
    fn cell_along(&self, a: usize, x: f64) -> usize {
        // truncation is the floor of the clamped (non-negative) offset, without the libm
        // call `floor` is on x86-64's baseline (no SSE4.1 rounding instruction)
        let c = ((x - self.origin[a]) / self.cell).max(0.0);
        (c as usize).min(self.dims[a] - 1)
    }

    /// Row-major cell index, axis 0 fastest.
    fn flat(&self, c: [usize; D]) -> usize {
        (0..D).rev().fold(0, |acc, a| acc * self.dims[a] + c[a])
    }

    /// Pushes onto `found` every point j ≠ `q.index` with |x_j − x_q|² < (R_q + R_j + skin)²,
    /// in cell order; `lanes` chooses the AVX form.
    pub(super) fn find_near(&self, q: &Query<D>, lanes: bool, found: &mut Vec<u32>) {
        #[cfg(target_arch = "x86_64")]
        if lanes {
            // SAFETY: `lanes` is set only where the processor has AVX
            return unsafe { self.find_near_avx(q, found) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = lanes; // no AVX form off x86-64
        self.for_each_run(q, |run| self.run_portable(run, q, found));
    }

    /// Calls `visit` with the members of the cells that meet the box of half-width
    /// R_q + R_max + skin around the query point (every partner lies inside it), a run of
    /// cells along axis 0 at a time (their members are contiguous).
    #[inline(always)]
    fn for_each_run(&self, q: &Query<D>, mut visit: impl FnMut(Range<usize>)) {
        // the margin keeps the box a superset of the hits through the rounding of x ± half
        let half = (q.radius + self.largest_radius + q.skin) * (1.0 + 1e-9);
        let p = &q.point;
        let lo: [usize; D] = std::array::from_fn(|a| self.cell_along(a, p[a] - half));
        let hi: [usize; D] = std::array::from_fn(|a| self.cell_along(a, p[a] + half));
        let mut c = lo;
        loop {
            let first = self.flat(c);
            visit(self.start[first]..self.start[first + hi[0] - lo[0] + 1]);
            // odometer step over the box lo..=hi, axes 1.. (axis 0 is the run)
            let mut a = 1;
            loop {
                if a >= D {
                    return;
                }
                if c[a] < hi[a] {
                    c[a] += 1;
                    break;
                }
                c[a] = lo[a];
                a += 1;
            }
        }
    }

    /// [`CellGrid::find_near`] over one run, a candidate at a time.
    fn run_portable(&self, run: Range<usize>, q: &Query<D>, found: &mut Vec<u32>) {
        for k in run {
            let mut d2 = 0.0;
            for a in 0..D {
                let d = self.coords[a][k] - q.point[a];
                d2 = if a == 0 { d * d } else { d2 + d * d };
            }
            let reach = q.radius + self.radii[k] + q.skin;
            if d2 < reach * reach && self.index[k] != q.index {
                found.push(self.index[k]);
            }
        }
    }

    /// [`CellGrid::find_near`] four candidates at a time: lanes past a run's end are masked
    /// off (the padding keeps their loads in bounds).
    ///
    /// # Safety
    /// Only where the processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn find_near_avx(&self, q: &Query<D>, found: &mut Vec<u32>) {
        let point: [__m256d; D] = std::array::from_fn(|a| _mm256_set1_pd(q.point[a]));
        let (radius, skin) = (_mm256_set1_pd(q.radius), _mm256_set1_pd(q.skin));
        let me = _mm_set1_epi32(q.index as i32);
        self.for_each_run(q, |run| {
            // each step writes LANES slots and keeps its hits: room for the run and one step
            found.reserve(run.len() + LANES);
            let (mut len, out) = (found.len(), found.as_mut_ptr());
            let mut k = run.start;
            while k < run.end {
                // SAFETY: k < run.end ≤ N and every array holds N + LANES − 1 values
                let load = |values: &[f64]| unsafe { _mm256_loadu_pd(values.as_ptr().add(k)) };
                let mut d2 = _mm256_setzero_pd();
                for (a, (axis, centre)) in self.coords.iter().zip(point).enumerate() {
                    let d = _mm256_sub_pd(load(axis), centre);
                    let square = _mm256_mul_pd(d, d);
                    d2 = if a == 0 {
                        square
                    } else {
                        _mm256_add_pd(d2, square)
                    };
                }
                let reach = _mm256_add_pd(_mm256_add_pd(radius, load(&self.radii)), skin);
                let hit = _mm256_cmp_pd::<_CMP_LT_OQ>(d2, _mm256_mul_pd(reach, reach));
                // SAFETY: as above, `index` holds N + LANES − 1 values
                let js = unsafe { _mm_loadu_si128(self.index.as_ptr().add(k).cast()) };
                let own = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(js, me))) as usize;
                let valid = (1usize << (run.end - k).min(LANES)) - 1;
                let mask = _mm256_movemask_pd(hit) as usize & valid & !own;
                // branch-free: the hits' indices moved to the front in order and written as
                // one vector (the slots past them are overwritten or cut off), then the length
                // past them
                // SAFETY: `HIT_LANES[mask]` holds four lane numbers
                let order = unsafe { _mm_loadu_si128(HIT_LANES[mask].as_ptr().cast()) };
                let hits = _mm_castps_si128(_mm_permutevar_ps(_mm_castsi128_ps(js), order));
                // SAFETY: len + LANES ≤ the capacity reserved above
                unsafe { _mm_storeu_si128(out.add(len).cast(), hits) };
                len += mask.count_ones() as usize;
                k += LANES;
            }
            // SAFETY: slots up to `len` are written hits
            unsafe { found.set_len(len) };
        });
    }
}

/// For each mask of four lanes, its set lanes in order (then zeros): the hits' slots.
#[cfg(target_arch = "x86_64")]
const HIT_LANES: [[i32; LANES]; 1 << LANES] = {
    let mut table = [[0; LANES]; 1 << LANES];
    let mut mask = 0;
    while mask < 1 << LANES {
        let (mut lane, mut count) = (0, 0);
        while lane < LANES {
            if mask & (1 << lane) != 0 {
                table[mask][count] = lane as i32;
                count += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

/// The bounding box of `positions` (the origin for none).
fn bounds<const D: usize>(positions: &[SVector<f64, D>]) -> super::Bounds<D> {
    if positions.is_empty() {
        return (SVector::zeros(), SVector::zeros());
    }
    let far = SVector::<f64, D>::repeat(f64::INFINITY);
    let corners = |i: usize| (positions[i], positions[i]);
    let merge = |(lo, hi): super::Bounds<D>, (a, b): super::Bounds<D>| (lo.inf(&a), hi.sup(&b));
    fold_items(positions.len(), (far, -far), corners, merge)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use rand::{RngExt, SeedableRng};

    /// `n` points at random on the half-integer lattice of a cube of side `side` / 2 (pairs
    /// exactly at reach occur).
    fn half_lattice(seed: u64, n: usize, side: f64) -> Vec<Vector3<f64>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Vector3::from_fn(|_, _| (rng.random::<f64>() * side).round() * 0.5))
            .collect()
    }

    /// Point i's query with skin `skin`.
    fn query(positions: &[Vector3<f64>], radii: &[f64], i: usize, skin: f64) -> Query<3> {
        Query {
            point: positions[i],
            index: i as u32,
            radius: radii[i],
            skin,
        }
    }

    /// Every point's search in both forms, on a bed with pairs exactly at reach, a NaN point
    /// and runs of every length modulo four.
    #[test]
    fn avx_and_portable_searches_find_the_same_points() {
        if !crate::numerics::has_avx() {
            return;
        }
        let mut positions = half_lattice(5, 700, 12.0);
        positions[17] = Vector3::new(f64::NAN, 1.0, 2.0);
        let radii: Vec<f64> = (0..700).map(|k| 0.25 * (1 + k % 3) as f64).collect();
        let grid = CellGrid::new(&positions, &radii, 0.5);
        let mut hits = 0;
        for i in 0..positions.len() {
            let q = query(&positions, &radii, i, 0.5);
            let (mut portable, mut avx) = (Vec::new(), Vec::new());
            grid.find_near(&q, false, &mut portable);
            grid.find_near(&q, true, &mut avx);
            assert_eq!(portable, avx, "point {i}");
            hits += avx.len();
        }
        assert!(hits > 700, "{hits} hits");
    }

    /// A point's search box is fitted to its own radius and the largest (the cells are sized
    /// for two of the largest): on a set whose radii span 0.25–2, with pairs exactly at reach,
    /// both forms find exactly the points within reach, as the test over all pairs does.
    #[test]
    fn a_search_box_fitted_to_each_point_misses_no_pair_of_a_wide_size_range() {
        let n = 900;
        let positions = half_lattice(9, n, 30.0);
        let mut radii: Vec<f64> = (0..n).map(|k| 0.25 * (1 + k % 2) as f64).collect();
        radii[n / 2] = 2.0;
        let skin = 0.5;
        let grid = CellGrid::new(&positions, &radii, skin);
        let within = |i: usize, j: usize| {
            let d = positions[j] - positions[i];
            let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
            let reach = radii[i] + radii[j] + skin;
            j != i && d2 < reach * reach
        };
        let mut hits = 0;
        for i in 0..n {
            let q = query(&positions, &radii, i, skin);
            let all: Vec<u32> = (0..n).filter(|&j| within(i, j)).map(|j| j as u32).collect();
            let forms = [false, crate::numerics::has_avx()];
            for lanes in forms {
                let mut found = Vec::new();
                grid.find_near(&q, lanes, &mut found);
                found.sort_unstable();
                assert_eq!(found, all, "point {i}, lanes {lanes}");
            }
            hits += all.len();
        }
        assert!(hits > 2 * n, "{hits} hits");
        assert!((0..n).filter(|&j| within(n / 2, j)).count() > 10);
    }
}
