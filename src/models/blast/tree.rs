//! Barnes–Hut octree for the long-ranged near-field sum (C8). With the mass-based law
//! α_k = ᾱ_k m_i m_j the pair force is linear in m_j, so a distant group of equal particles
//! acts, to second order in (cell size / distance), like their count at their centre of mass
//! (the first-order term vanishes about the centre of mass). A cell is used whole when
//! size < θ · distance; θ = 0 opens every cell (the exact sum). The tree is built sequentially
//! and each particle walks it alone, so forces are bit-identical at any thread count.

use nalgebra::Vector3;

/// Particles per leaf.
const LEAF: usize = 8;

/// Depth of the traversal stack: 8 per level for up to [`MAX_DEPTH`] levels.
const STACK: usize = 8 * MAX_DEPTH + 1;

/// Deepest level; cells there stay leaves whatever their count (coincident particles).
const MAX_DEPTH: usize = 48;

#[derive(Debug, Clone)]
struct Node {
    /// Centre of mass of the cell's particles, m.
    centre: Vector3<f64>,
    /// Number of particles.
    count: usize,
    /// Edge length of the cubic cell, m.
    size: f64,
    /// Children: range into `links` (empty for a leaf).
    children: (u32, u32),
    /// Particles: range into `order` and `sorted`.
    range: (usize, usize),
}

/// An octree over particle positions.
#[derive(Debug, Clone, Default)]
pub struct Octree {
    nodes: Vec<Node>,
    /// Child node indices, each node's children contiguous.
    links: Vec<u32>,
    /// Particle indices in tree order.
    order: Vec<usize>,
    /// Positions in tree order (contiguous leaves).
    sorted: Vec<Vector3<f64>>,
    /// Scratch for the octant partition.
    scratch: Vec<usize>,
}

impl Octree {
    /// Builds the tree (deterministic: stable octant partition).
    pub fn build(&mut self, positions: &[Vector3<f64>]) {
        self.nodes.clear();
        self.links.clear();
        self.order.clear();
        self.order.extend(0..positions.len());
        self.sorted.clear();
        if positions.is_empty() {
            return;
        }
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in positions {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let size = (hi - lo).max().max(f64::MIN_POSITIVE);
        self.split(positions, 0, positions.len(), lo, size, 0);
        self.sorted.extend(self.order.iter().map(|&i| positions[i]));
    }

    /// Adds the node of order[start..end] in the cube (corner, size); returns its index.
    fn split(
        &mut self,
        positions: &[Vector3<f64>],
        start: usize,
        end: usize,
        corner: Vector3<f64>,
        size: f64,
        depth: usize,
    ) -> u32 {
        let index = self.nodes.len();
        let centre = self.order[start..end]
            .iter()
            .map(|&i| positions[i])
            .sum::<Vector3<f64>>()
            / (end - start) as f64;
        self.nodes.push(Node {
            centre,
            count: end - start,
            size,
            children: (0, 0),
            range: (start, end),
        });
        if end - start <= LEAF || depth == MAX_DEPTH {
            return index as u32;
        }
        let half = 0.5 * size;
        let mid = corner + Vector3::repeat(half);
        let octant = |p: &Vector3<f64>| {
            (p.x >= mid.x) as usize + 2 * (p.y >= mid.y) as usize + 4 * (p.z >= mid.z) as usize
        };
        // stable counting sort of the slice by octant
        self.scratch.clear();
        self.scratch.extend_from_slice(&self.order[start..end]);
        let mut bounds = [0usize; 9];
        for &i in &self.scratch {
            bounds[octant(&positions[i]) + 1] += 1;
        }
        for k in 1..9 {
            bounds[k] += bounds[k - 1];
        }
        let mut fill = bounds;
        for &i in &self.scratch {
            let o = octant(&positions[i]);
            self.order[start + fill[o]] = i;
            fill[o] += 1;
        }
        let mut children = [0u32; 8];
        let mut count = 0;
        for o in 0..8 {
            let (a, b) = (start + bounds[o], start + bounds[o + 1]);
            if a < b {
                let offset = Vector3::new(
                    (o & 1) as f64 * half,
                    ((o >> 1) & 1) as f64 * half,
                    ((o >> 2) & 1) as f64 * half,
                );
                children[count] = self.split(positions, a, b, corner + offset, half, depth + 1);
                count += 1;
            }
        }
        let first = self.links.len() as u32;
        self.links.extend_from_slice(&children[..count]);
        self.nodes[index].children = (first, first + count as u32);
        index as u32
    }

    /// Σ_j pair(r_i, r_j) over j ≠ i, with distant cells replaced by count · pair(r_i, centre)
    /// when size < θ · distance. `pair(a, b)` is the force on a particle at a from one at b.
    pub fn sum(
        &self,
        positions: &[Vector3<f64>],
        i: usize,
        theta: f64,
        pair: impl Fn(&Vector3<f64>, &Vector3<f64>) -> Vector3<f64>,
    ) -> Vector3<f64> {
        let ri = &positions[i];
        let mut total = Vector3::zeros();
        if self.nodes.is_empty() {
            return total;
        }
        // fixed stack (no allocation per particle): ≤ 8 entries per level of a shallow tree
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            let far = node.size * node.size < theta * theta * (node.centre - ri).norm_squared();
            if far {
                total += node.count as f64 * pair(ri, &node.centre);
            } else if node.children.0 == node.children.1 {
                let (a, b) = node.range;
                for (&j, rj) in self.order[a..b].iter().zip(&self.sorted[a..b]) {
                    if j != i {
                        total += pair(ri, rj);
                    }
                }
            } else {
                // reverse, so children are visited in octant order
                let (a, b) = node.children;
                for &c in self.links[a as usize..b as usize].iter().rev() {
                    stack[top] = c;
                    top += 1;
                }
            }
        }
        total
    }
}
