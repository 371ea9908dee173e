//! Barnes–Hut octree for the long-ranged near-field sum (C8). With the mass-based law
//! α_k = ᾱ_k m_i m_j the pair force is linear in m_j, so a distant group of equal particles
//! acts, to second order in (cell size / distance), like their count at their centre of mass
//! (the first-order term vanishes about the centre of mass). A cell is used whole when
//! size < θ · distance; θ = 0 opens every cell (the exact sum). The tree is walked once per
//! leaf (the distance is taken to the leaf's bounding box, so the test is stricter than per
//! particle) and the leaf's interaction list is applied to each of its particles. The tree is
//! built sequentially, leaves are processed in parallel, and each particle's sum has a fixed
//! order, so forces are bit-identical at any thread count.

use nalgebra::Vector3;
use rayon::prelude::*;

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
    /// Leaf node indices in tree order.
    leaves: Vec<u32>,
    /// Forces in tree order.
    buffer: Vec<Vector3<f64>>,
}

impl Octree {
    /// Builds the tree (deterministic: stable octant partition).
    pub fn build(&mut self, positions: &[Vector3<f64>]) {
        self.nodes.clear();
        self.leaves.clear();
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
            self.leaves.push(index as u32);
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

    /// Σ_j pair(r_i, r_j) over j ≠ i for every particle i, into `out` (indexed like the
    /// positions of the last build), with distant cells replaced by count · pair(r_i, centre)
    /// when size < θ · (distance from the centre to the leaf's bounding box). `pair(a, b)` is
    /// the force on a particle at a from one at b.
    pub fn sum_all(
        &mut self,
        theta: f64,
        pair: impl Fn(&Vector3<f64>, &Vector3<f64>) -> Vector3<f64> + Sync,
        out: &mut [Vector3<f64>],
    ) {
        let mut buffer = std::mem::take(&mut self.buffer);
        buffer.clear();
        buffer.resize(self.order.len(), Vector3::zeros());
        let mut slices = Vec::with_capacity(self.leaves.len());
        let mut rest = &mut buffer[..];
        for &leaf in &self.leaves {
            let (a, b) = self.nodes[leaf as usize].range;
            let (head, tail) = rest.split_at_mut(b - a);
            slices.push((a, b, head));
            rest = tail;
        }
        let this = &*self;
        slices
            .into_par_iter()
            .for_each(|(a, b, forces)| this.leaf_sums(a, b, theta, &pair, forces));
        for (&i, f) in self.order.iter().zip(&buffer) {
            out[i] = *f;
        }
        self.buffer = buffer;
    }

    /// Sums for the particles a..b (tree order) of one leaf.
    fn leaf_sums(
        &self,
        a: usize,
        b: usize,
        theta: f64,
        pair: &impl Fn(&Vector3<f64>, &Vector3<f64>) -> Vector3<f64>,
        forces: &mut [Vector3<f64>],
    ) {
        let own = &self.sorted[a..b];
        let (mut lo, mut hi) = (own[0], own[0]);
        for p in own {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        // fixed stack (no allocation per leaf): ≤ 8 entries per level of a shallow tree
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            let c = node.centre;
            let gap = (lo - c).sup(&(c - hi)).sup(&Vector3::zeros());
            if node.size * node.size < theta * theta * gap.norm_squared() {
                for (f, ri) in forces.iter_mut().zip(own) {
                    *f += node.count as f64 * pair(ri, &c);
                }
            } else if node.children.0 == node.children.1 {
                let (m0, m1) = node.range;
                for (k, (f, ri)) in forces.iter_mut().zip(own).enumerate() {
                    for (m, rj) in (m0..m1).zip(&self.sorted[m0..m1]) {
                        if m != a + k {
                            *f += pair(ri, rj);
                        }
                    }
                }
            } else {
                // reverse, so children are visited in octant order
                let (c0, c1) = node.children;
                for &child in self.links[c0 as usize..c1 as usize].iter().rev() {
                    stack[top] = child;
                    top += 1;
                }
            }
        }
    }
}
