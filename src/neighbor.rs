//! Neighbour search: a cell grid feeding a Verlet list (all pairs closer than R_i + R_j + skin),
//! rebuilt when some particle has moved more than half the skin since the last build, so no
//! contact is ever missed. Building is O(N); no O(N²) loop exists outside tests.

use nalgebra::Vector3;

/// Full (both directions) Verlet neighbour list in compressed-row form.
#[derive(Debug, Clone, Default)]
pub struct NeighborList {
    offsets: Vec<usize>,
    neighbors: Vec<u32>,
    reference: Vec<Vector3<f64>>,
    skin: f64,
    builds: usize,
}

impl NeighborList {
    /// An empty list with the given skin (same length unit as the positions).
    pub fn new(skin: f64) -> Self {
        Self {
            skin,
            ..Default::default()
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

    /// Rebuilds if needed; returns whether it did.
    pub fn update(&mut self, positions: &[Vector3<f64>], radii: &[f64]) -> bool {
        if self.needs_rebuild(positions) {
            self.build(positions, radii);
            true
        } else {
            false
        }
    }

    fn needs_rebuild(&self, positions: &[Vector3<f64>]) -> bool {
        if self.reference.len() != positions.len() {
            return true;
        }
        let limit = 0.25 * self.skin * self.skin;
        positions
            .iter()
            .zip(&self.reference)
            .any(|(p, r)| (p - r).norm_squared() > limit)
    }

    /// Builds the list from a cell grid of cell size 2 R_max + skin.
    pub fn build(&mut self, positions: &[Vector3<f64>], radii: &[f64]) {
        let n = positions.len();
        let r_max = radii.iter().cloned().fold(0.0, f64::max);
        let grid = CellGrid::new(positions, 2.0 * r_max + self.skin);
        self.offsets.clear();
        self.neighbors.clear();
        self.offsets.push(0);
        let mut found = Vec::new();
        for i in 0..n {
            found.clear();
            grid.for_each_near(positions[i], |j| {
                if j != i {
                    let cutoff = radii[i] + radii[j] + self.skin;
                    if (positions[j] - positions[i]).norm_squared() < cutoff * cutoff {
                        found.push(j as u32);
                    }
                }
            });
            found.sort_unstable();
            self.neighbors.extend_from_slice(&found);
            self.offsets.push(self.neighbors.len());
        }
        self.reference.clear();
        self.reference.extend_from_slice(positions);
        self.builds += 1;
    }
}

/// Particles binned into cubic cells (counting sort), for O(1) near-point queries.
struct CellGrid {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    start: Vec<usize>,
    members: Vec<usize>,
}

impl CellGrid {
    fn new(positions: &[Vector3<f64>], cell: f64) -> Self {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in positions {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        if positions.is_empty() {
            lo = Vector3::zeros();
            hi = Vector3::zeros();
        }
        let dims = [0, 1, 2].map(|a| (((hi[a] - lo[a]) / cell).floor() as usize + 1).max(1));
        let mut grid = Self {
            origin: lo,
            cell,
            dims,
            start: vec![0; dims[0] * dims[1] * dims[2] + 1],
            members: vec![0; positions.len()],
        };
        let index: Vec<usize> = positions.iter().map(|p| grid.cell_of(*p)).collect();
        for &c in &index {
            grid.start[c + 1] += 1;
        }
        for c in 1..grid.start.len() {
            grid.start[c] += grid.start[c - 1];
        }
        let mut fill = grid.start.clone();
        for (i, &c) in index.iter().enumerate() {
            grid.members[fill[c]] = i;
            fill[c] += 1;
        }
        grid
    }

    fn coords(&self, p: Vector3<f64>) -> [usize; 3] {
        [0, 1, 2].map(|a| {
            let c = ((p[a] - self.origin[a]) / self.cell).floor();
            (c.max(0.0) as usize).min(self.dims[a] - 1)
        })
    }

    fn cell_of(&self, p: Vector3<f64>) -> usize {
        let [x, y, z] = self.coords(p);
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    fn for_each_near(&self, p: Vector3<f64>, mut visit: impl FnMut(usize)) {
        let c = self.coords(p);
        let range = |a: usize| c[a].saturating_sub(1)..=(c[a] + 1).min(self.dims[a] - 1);
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    let cell = (z * self.dims[1] + y) * self.dims[0] + x;
                    for &j in &self.members[self.start[cell]..self.start[cell + 1]] {
                        visit(j);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let mut list = NeighborList::new(0.3);
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
    fn rebuilds_only_after_half_skin_displacement() {
        let positions = vec![Vector3::zeros(), Vector3::new(3.0, 0.0, 0.0)];
        let radii = vec![1.0, 1.0];
        let mut list = NeighborList::new(0.4);
        assert!(list.update(&positions, &radii));
        let moved = vec![Vector3::new(0.19, 0.0, 0.0), positions[1]];
        assert!(!list.update(&moved, &radii));
        let moved = vec![Vector3::new(0.21, 0.0, 0.0), positions[1]];
        assert!(list.update(&moved, &radii));
    }
}
