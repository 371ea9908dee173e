//! The bed's pair sums beyond the near cut-off r_s by a Barnes–Hut quadtree
//! (`--neighbors tree`, docs/bed.md "Far field"): every pair at r ≥ r_s enters, either exactly
//! or through the multipole expansion of a distant group, so no tail is cut off. Both sums are
//! potentials of the r⁻³ kernel: the B1 force sum Σ μ_j d/r⁵ = −⅓∇Σ μ_j/r³ and the B4 normal
//! sum Σ μ_j sin θ_j/r³. Each group carries, for both weights w = μ and w = μ sin θ, its total
//! Σw, its w-weighted centroid (the dipole term then vanishes) and its second moment about that
//! centroid (the quadrupole term), so the remaining error is third order in size / distance.
//!
//! The tree is a Morton-ordered quadtree (discs sorted by their interleaved cell bits). Each
//! leaf walks the tree once: a node is used whole when its bounding box is at least r_s from
//! the leaf's (every pair in it is far) and its extent is below θ times that gap; a leaf that
//! fails is summed pair by pair with the pairs closer than r_s masked out. θ = 0 opens every
//! node (the exact far sums). Leaves run in parallel and every disc's sum has a fixed order,
//! so the result is bit-identical at any thread count.

use nalgebra::Vector2;
use rayon::prelude::*;

use super::forces::PairSums;

/// Discs per leaf.
const LEAF: usize = 12;

/// Bits per coordinate of the Morton key, so also the deepest level.
const LEVELS: u32 = 16;

/// Traversal stack depth: 3 open siblings per level plus the root.
const STACK: usize = 4 * LEVELS as usize + 4;

/// Zeroth, first and second moments of one weight over a group of discs.
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    /// Σ w_j.
    total: f64,
    /// Σ w_j r_j / Σ w_j, m (the box centre when the total is 0).
    centre: Vector2<f64>,
    /// Σ w_j y y^T with y = r_j − centre: (xx, xy, yy), m².
    second: [f64; 3],
}

impl Moments {
    fn of(points: &[Vector2<f64>], weight: &[f64], fallback: Vector2<f64>) -> Self {
        let total: f64 = weight.iter().sum();
        let centre = if total > 0.0 {
            points
                .iter()
                .zip(weight)
                .map(|(p, &w)| p * w)
                .sum::<Vector2<f64>>()
                / total
        } else {
            fallback
        };
        let mut second = [0.0; 3];
        for (p, &w) in points.iter().zip(weight) {
            let y = p - centre;
            second[0] += w * y.x * y.x;
            second[1] += w * y.x * y.y;
            second[2] += w * y.y * y.y;
        }
        Self {
            total,
            centre,
            second,
        }
    }

    /// Σ_j w_j/|p − r_j|³ to the quadrupole term: W r⁻³ − 1.5 tr Q r⁻⁵ + 7.5 xᵀQx r⁻⁷.
    #[inline(always)]
    fn potential(&self, p: Vector2<f64>) -> f64 {
        let x = p - self.centre;
        let inv_r2 = 1.0 / x.norm_squared();
        let inv_r3 = inv_r2 * inv_r2.sqrt();
        let [qxx, qxy, qyy] = self.second;
        let a = qxx * x.x * x.x + 2.0 * qxy * x.x * x.y + qyy * x.y * x.y;
        inv_r3 * (self.total + inv_r2 * (-1.5 * (qxx + qyy) + 7.5 * a * inv_r2))
    }

    /// Σ_j w_j (p − r_j)/|p − r_j|⁵ = −⅓∇ of [`Moments::potential`]:
    /// W x r⁻⁵ − 5 Qx r⁻⁷ + (17.5 xᵀQx r⁻⁹ − 2.5 tr Q r⁻⁷) x.
    #[inline(always)]
    fn field(&self, p: Vector2<f64>) -> Vector2<f64> {
        let x = p - self.centre;
        let inv_r2 = 1.0 / x.norm_squared();
        let inv_r5 = inv_r2 * inv_r2 * inv_r2.sqrt();
        let [qxx, qxy, qyy] = self.second;
        let qx = Vector2::new(qxx * x.x + qxy * x.y, qxy * x.x + qyy * x.y);
        let a = x.dot(&qx);
        let radial = self.total + inv_r2 * (-2.5 * (qxx + qyy) + 17.5 * a * inv_r2);
        (x * radial - qx * (5.0 * inv_r2)) * inv_r5
    }
}

#[derive(Debug, Clone)]
struct Node {
    /// Bounding box of the node's discs, m.
    lo: Vector2<f64>,
    hi: Vector2<f64>,
    /// Moments of μ and of μ sin θ.
    moment: Moments,
    moment_sin: Moments,
    /// Children: range into `links` (empty for a leaf).
    children: (u32, u32),
    /// Discs: range into the tree-ordered arrays.
    range: (usize, usize),
}

/// The quadtree and its buffers (reused between evaluations: no allocation once warm, except
/// the per-evaluation list of leaf slices). Its sums fill the `force` and `normal` fields of
/// [`PairSums`] (Σ_j μ_j d/r⁵ and Σ_j μ_j sin θ_j/r³ over r_ij ≥ r_s, without the μ_i and
/// 3μ0/4π factors); the closest-approach fields stay 0: the near list holds the close pairs.
#[derive(Debug, Clone, Default)]
pub(super) struct FarField {
    /// Opening angle θ: a node is used whole when extent < θ · gap.
    theta: f64,
    /// r_s², m²: closer pairs belong to the near list.
    near2: f64,
    nodes: Vec<Node>,
    links: Vec<u32>,
    leaves: Vec<u32>,
    /// (Morton key, disc) in tree order.
    keys: Vec<(u32, u32)>,
    /// Positions, μ and μ sin θ in tree order.
    point: Vec<Vector2<f64>>,
    weight: Vec<f64>,
    weight_sin: Vec<f64>,
    /// Constant per-disc μ and μ sin θ by disc index.
    moment: Vec<f64>,
    moment_sin: Vec<f64>,
    /// Sums in tree order.
    sums: Vec<PairSums>,
    /// Pair and node terms of the last evaluation (a benchmark count).
    terms: usize,
}

impl FarField {
    /// A far field with opening angle θ ≥ 0 and near cut-off r_s > 0 (m), for discs with
    /// moments μ_j (A·m²) and tilt sines sin θ_j.
    pub(super) fn new(theta: f64, near: f64, moment: &[f64], tilt_sin: &[f64]) -> Self {
        Self {
            theta,
            near2: near * near,
            moment: moment.to_vec(),
            moment_sin: moment.iter().zip(tilt_sin).map(|(m, s)| m * s).collect(),
            ..Self::default()
        }
    }

    /// Pair and node terms of the last evaluation (each disc's direct pairs counted once per
    /// disc, masked ones included; each node used whole counted once per disc).
    pub(super) fn terms(&self) -> usize {
        self.terms
    }

    /// The far sums of every disc at these positions, m, into `out` (by disc index).
    pub(super) fn evaluate(&mut self, position: &[Vector2<f64>], out: &mut Vec<PairSums>) {
        out.clear();
        out.resize(position.len(), PairSums::default());
        if position.is_empty() {
            return;
        }
        self.build(position);
        let mut sums = std::mem::take(&mut self.sums);
        sums.clear();
        sums.resize(position.len(), PairSums::default());
        let mut slices = Vec::with_capacity(self.leaves.len());
        let mut rest = &mut sums[..];
        for &leaf in &self.leaves {
            let (a, b) = self.nodes[leaf as usize].range;
            let (head, tail) = rest.split_at_mut(b - a);
            slices.push((a, b, head));
            rest = tail;
        }
        let this = &*self;
        self.terms = slices
            .into_par_iter()
            .map(|(a, b, sums)| this.leaf_sums(a, b, sums))
            .sum();
        for (&(_, i), s) in self.keys.iter().zip(&sums) {
            out[i as usize] = *s;
        }
        self.sums = sums;
    }

    /// Sorts the discs by Morton key and builds the nodes over the sorted ranges.
    fn build(&mut self, position: &[Vector2<f64>]) {
        let (mut lo, mut hi) = (position[0], position[0]);
        for p in position {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let size = (hi - lo).max().max(f64::MIN_POSITIVE);
        let scale = f64::from(1u32 << LEVELS) / size;
        let cell = |v: f64| ((v * scale) as u32).min((1 << LEVELS) - 1);
        self.keys.clear();
        self.keys.extend(
            position
                .iter()
                .enumerate()
                .map(|(i, p)| (morton(cell(p.x - lo.x), cell(p.y - lo.y)), i as u32)),
        );
        self.keys.sort_unstable();
        self.point.clear();
        self.weight.clear();
        self.weight_sin.clear();
        for &(_, i) in &self.keys {
            let i = i as usize;
            self.point.push(position[i]);
            self.weight.push(self.moment[i]);
            self.weight_sin.push(self.moment_sin[i]);
        }
        self.nodes.clear();
        self.links.clear();
        self.leaves.clear();
        self.node(0, position.len(), LEVELS);
    }

    /// Adds the node of the tree-ordered discs start..end, whose keys agree above bit pair
    /// `level`; returns its index.
    fn node(&mut self, start: usize, end: usize, level: u32) -> u32 {
        let points = &self.point[start..end];
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let middle = 0.5 * (lo + hi);
        let index = self.nodes.len() as u32;
        self.nodes.push(Node {
            lo,
            hi,
            moment: Moments::of(points, &self.weight[start..end], middle),
            moment_sin: Moments::of(points, &self.weight_sin[start..end], middle),
            children: (0, 0),
            range: (start, end),
        });
        if end - start <= LEAF || level == 0 {
            self.leaves.push(index);
            return index;
        }
        let shift = 2 * (level - 1);
        let mut children = [0u32; 4];
        let mut count = 0;
        let mut a = start;
        for quadrant in 0..4u32 {
            let b = a + self.keys[a..end].partition_point(|&(k, _)| (k >> shift) & 3 <= quadrant);
            if a < b {
                children[count] = self.node(a, b, level - 1);
                count += 1;
            }
            a = b;
        }
        let first = self.links.len() as u32;
        self.links.extend_from_slice(&children[..count]);
        self.nodes[index as usize].children = (first, first + count as u32);
        index
    }

    /// The sums of the tree-ordered discs a..b of one leaf into `sums`; returns the terms.
    fn leaf_sums(&self, a: usize, b: usize, sums: &mut [PairSums]) -> usize {
        let own = &self.point[a..b];
        let (mut lo, mut hi) = (own[0], own[0]);
        for p in own {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let mut terms = 0;
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            let gap = (node.lo - hi).sup(&(lo - node.hi)).sup(&Vector2::zeros());
            let (gap2, extent) = (gap.norm_squared(), (node.hi - node.lo).max());
            if gap2 >= self.near2 && extent * extent < self.theta * self.theta * gap2 {
                for (s, p) in sums.iter_mut().zip(own) {
                    s.force += node.moment.field(*p);
                    s.normal += node.moment_sin.potential(*p);
                }
                terms += own.len();
            } else if node.children.0 == node.children.1 {
                self.direct(own, node.range, sums);
                terms += own.len() * (node.range.1 - node.range.0);
            } else {
                for &child in self.links[node.children.0 as usize..node.children.1 as usize]
                    .iter()
                    .rev()
                {
                    stack[top] = child;
                    top += 1;
                }
            }
        }
        terms
    }

    /// Pair by pair: the discs `own` against the tree-ordered discs of `range`, pairs closer
    /// than r_s (the disc itself included) masked to exact zeros.
    fn direct(&self, own: &[Vector2<f64>], range: (usize, usize), sums: &mut [PairSums]) {
        let (a, b) = range;
        let (points, weight, weight_sin) = (
            &self.point[a..b],
            &self.weight[a..b],
            &self.weight_sin[a..b],
        );
        for (s, p) in sums.iter_mut().zip(own) {
            for ((q, &w), &w_sin) in points.iter().zip(weight).zip(weight_sin) {
                let d = p - q;
                let r2 = d.norm_squared();
                // 1/∞ = 0: a masked pair adds exact zeros (no branch, no NaN at r = 0)
                let r2 = if r2 >= self.near2 { r2 } else { f64::INFINITY };
                let inv_r2 = 1.0 / r2;
                let inv_r3 = inv_r2 * inv_r2.sqrt();
                s.force += d * (w * inv_r3 * inv_r2);
                s.normal += w_sin * inv_r3;
            }
        }
    }
}

/// Interleaves the bits of x (even positions) and y (odd positions).
fn morton(x: u32, y: u32) -> u32 {
    spread(x) | (spread(y) << 1)
}

/// The 16 low bits of v moved to the even bit positions.
fn spread(v: u32) -> u32 {
    let mut v = v & 0xFFFF;
    v = (v | (v << 8)) & 0x00FF_00FF;
    v = (v | (v << 4)) & 0x0F0F_0F0F;
    v = (v | (v << 2)) & 0x3333_3333;
    (v | (v << 1)) & 0x5555_5555
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{run_stream, Purpose};
    use rand::RngExt;

    /// A disordered bed with a density gradient: a square grid, jittered and squeezed upwards.
    fn bed(n: usize, seed: u64) -> (Vec<Vector2<f64>>, Vec<f64>, Vec<f64>) {
        let mut rng = run_stream(seed, Purpose::Positions);
        let side = (n as f64).sqrt().ceil() as usize;
        let points = (0..n)
            .map(|k| {
                let (i, j) = ((k % side) as f64, (k / side) as f64);
                let y = j + 0.3 * rng.random::<f64>();
                Vector2::new(
                    i + 0.3 * rng.random::<f64>(),
                    y * (1.0 - 0.3 * y / side as f64),
                )
            })
            .collect();
        let moment = (0..n).map(|_| 1.0 + 0.5 * rng.random::<f64>()).collect();
        let tilt = (0..n).map(|_| rng.random::<f64>()).collect();
        (points, moment, tilt)
    }

    /// The far sums by the plain double loop.
    fn brute(p: &[Vector2<f64>], moment: &[f64], tilt: &[f64], near: f64) -> Vec<PairSums> {
        (0..p.len())
            .map(|i| {
                let mut s = PairSums::default();
                for j in 0..p.len() {
                    let d = p[i] - p[j];
                    let r = d.norm();
                    if r >= near {
                        s.force += d * (moment[j] / r.powi(5));
                        s.normal += moment[j] * tilt[j] / r.powi(3);
                    }
                }
                s
            })
            .collect()
    }

    /// The tree's errors against the double loop.
    struct Errors {
        /// Largest error of a disc's force sum, relative to the largest force sum.
        force: f64,
        /// Largest error of a disc's normal sum, relative to the largest normal sum.
        normal: f64,
        /// Root-mean-square error of the force sums, relative to their root-mean-square.
        force_rms: f64,
        /// |Σ_i μ_i F_i| (zero for exact sums: action = reaction) over Σ_i μ_i |F_i|: the
        /// spurious net force the tree puts on the whole bed.
        net: f64,
    }

    fn error(theta: f64, n: usize) -> Errors {
        let (p, moment, tilt) = bed(n, 3);
        let near = 2.5;
        let exact = brute(&p, &moment, &tilt, near);
        let mut tree = FarField::new(theta, near, &moment, &tilt);
        let mut out = Vec::new();
        tree.evaluate(&p, &mut out);
        let scale_f = exact.iter().map(|s| s.force.norm()).fold(0.0, f64::max);
        let scale_n = exact.iter().map(|s| s.normal).fold(0.0, f64::max);
        let (force, normal) = out.iter().zip(&exact).fold((0.0, 0.0), |(ef, en), (t, e)| {
            (
                f64::max(ef, (t.force - e.force).norm() / scale_f),
                f64::max(en, (t.normal - e.normal).abs() / scale_n),
            )
        });
        let squares =
            |v: &mut dyn Iterator<Item = Vector2<f64>>| v.map(|f| f.norm_squared()).sum::<f64>();
        let force_rms = (squares(&mut out.iter().zip(&exact).map(|(t, e)| t.force - e.force))
            / squares(&mut exact.iter().map(|e| e.force)))
        .sqrt();
        let net: Vector2<f64> = out.iter().zip(&moment).map(|(t, m)| t.force * *m).sum();
        let total: f64 = exact
            .iter()
            .zip(&moment)
            .map(|(e, m)| e.force.norm() * m)
            .sum();
        Errors {
            force,
            normal,
            force_rms,
            net: net.norm() / total,
        }
    }

    impl Errors {
        /// Asserts the largest force and normal errors are below these bounds.
        fn assert_within(&self, force: f64, normal: f64) {
            assert!(
                self.force < force && self.normal < normal,
                "force {:e}, normal {:e}",
                self.force,
                self.normal
            );
        }
    }

    #[test]
    fn opening_no_node_gives_the_exact_far_sums() {
        error(0.0, 600).assert_within(1e-13, 1e-13);
    }

    #[test]
    fn the_error_falls_faster_than_the_cube_of_the_opening_angle() {
        let (e1, e2) = (error(0.3, 900), error(0.15, 900));
        e1.assert_within(3e-3, 1e-3);
        let (f1, n1, f2, n2) = (e1.force, e1.normal, e2.force, e2.normal);
        // the quadrupole term leaves a third-order error: halving θ gains more than 8×
        assert!(
            f2 < f1 / 8.0 && n2 < n1 / 8.0,
            "{f1:e} {f2:e} {n1:e} {n2:e}"
        );
    }

    /// At 10⁴ discs θ = 0.3 (the cycles in results/bench/README.md, "Bed far field") keeps
    /// the bound it meets at 900 discs, and its errors do not add up over the bed: the
    /// spurious net force is far below the per-disc error, so the tree puts no coherent bias
    /// on what the walls and the piston carry.
    #[test]
    fn at_ten_thousand_discs_the_error_stays_bounded_and_incoherent() {
        let e = error(0.3, 10_000);
        e.assert_within(3e-3, 1e-3);
        assert!(e.net < e.force_rms / 10.0, "{:e} {:e}", e.net, e.force_rms);
    }

    #[test]
    fn the_sums_do_not_depend_on_the_thread_count() {
        let (p, moment, tilt) = bed(2000, 5);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut tree = FarField::new(0.5, 2.0, &moment, &tilt);
            let mut out = Vec::new();
            pool.install(|| tree.evaluate(&p, &mut out));
            out
        };
        assert_eq!(run(1), run(3));
    }

    #[test]
    fn morton_keys_interleave_the_coordinates() {
        assert_eq!(morton(0b11, 0b00), 0b0101);
        assert_eq!(morton(0b00, 0b11), 0b1010);
        assert_eq!(morton(0xFFFF, 0xFFFF), u32::MAX);
    }
}
