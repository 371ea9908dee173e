//! Voronoi tessellation of 2D particle centres, taken from spade's Delaunay triangulation (its
//! dual), with the source's border rule (spec analysis.md, "2D structure").
//!
//! Numerical choices:
//! - the centres are shifted to the centre of their bounding rectangle and scaled by its half
//!   diagonal before triangulating, so results do not depend on the length unit or on where
//!   the snapshot sits (round-off aside) and spade's coordinate limits are never hit;
//! - a Voronoi edge shorter than `merge_tolerance` × the mean Delaunay bond length is treated
//!   as a point: it only arises from (nearly) co-circular centres such as a perfect square
//!   lattice, where the Delaunay triangulation must pick one of two diagonals arbitrarily. The
//!   two particles across such an edge are then not neighbours and the cell loses that side.

use nalgebra::Vector2;
use spade::{DelaunayTriangulation, Point2, Triangulation};

use crate::{Error, Result};

/// Default of [`TessellationSettings::merge_tolerance`]: far above round-off (1e-16) and far
/// below any physical edge.
pub const DEFAULT_MERGE_TOLERANCE: f64 = 1e-9;

/// Numerical settings of the tessellation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TessellationSettings {
    /// Voronoi edges shorter than this fraction of the mean Delaunay bond length are merged
    /// into a point (dimensionless, ≥ 0; default [`DEFAULT_MERGE_TOLERANCE`]).
    pub merge_tolerance: f64,
}

impl Default for TessellationSettings {
    fn default() -> Self {
        Self {
            merge_tolerance: DEFAULT_MERGE_TOLERANCE,
        }
    }
}

/// The Voronoi cell of one particle.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Voronoi neighbours (indices into the input), counter-clockwise.
    pub neighbors: Vec<u32>,
    /// Cell corners (m, or the input's unit), counter-clockwise; empty for an unbounded cell.
    /// Corner k is where the sides shared with `neighbors[k]` and `neighbors[k + 1]` meet.
    pub vertices: Vec<Vector2<f64>>,
    /// Whether the cell is bounded (the particle is not on the convex hull).
    pub bounded: bool,
    /// The border rule: bounded and every corner inside the rectangle spanned by the extreme
    /// particle centres.
    pub counted: bool,
}

impl Cell {
    /// Number of sides (= number of Voronoi neighbours).
    pub fn sides(&self) -> usize {
        self.neighbors.len()
    }

    /// Area (m²) by the shoelace formula; NaN for an unbounded cell.
    pub fn area(&self) -> f64 {
        if !self.bounded {
            return f64::NAN;
        }
        let n = self.vertices.len();
        let twice: f64 = (0..n)
            .map(|k| {
                let (a, b) = (self.vertices[k], self.vertices[(k + 1) % n]);
                a.x * b.y - b.x * a.y
            })
            .sum();
        0.5 * twice
    }

    /// Side lengths (m), side k from corner k−1 to corner k, i.e. the side shared with
    /// `neighbors[k]`; empty for an unbounded cell.
    pub fn side_lengths(&self) -> Vec<f64> {
        let n = self.vertices.len();
        (0..n)
            .map(|k| (self.vertices[k] - self.vertices[(k + n - 1) % n]).norm())
            .collect()
    }

    /// Regularity R = (4/√3) A / Σ_k ℓ_k² (1 for a regular hexagon, < 1 otherwise); NaN for
    /// an unbounded cell. Meaningful as "hexagon regularity" for six-sided cells.
    pub fn regularity(&self) -> f64 {
        let sum_sq: f64 = self.side_lengths().iter().map(|l| l * l).sum();
        4.0 / 3f64.sqrt() * self.area() / sum_sq
    }
}

/// Voronoi cells of a set of particle centres.
#[derive(Debug, Clone)]
pub struct Tessellation {
    /// One cell per input point, in input order.
    pub cells: Vec<Cell>,
    /// Rectangle spanned by the extreme centres: (min corner, max corner).
    pub bounds: (Vector2<f64>, Vector2<f64>),
}

/// Affine map to the normalized frame (centre of the bounding box at 0, half diagonal 1).
struct Frame {
    centre: Vector2<f64>,
    scale: f64,
}

impl Frame {
    fn to_local(&self, p: &Vector2<f64>) -> Point2<f64> {
        // Flush values below spade's smallest allowed magnitude (relatively ~1e-43) to zero.
        let flush = |v: f64| {
            if v.abs() < spade::MIN_ALLOWED_VALUE {
                0.0
            } else {
                v
            }
        };
        let q = (p - self.centre) / self.scale;
        Point2::new(flush(q.x), flush(q.y))
    }

    fn to_global(&self, q: Point2<f64>) -> Vector2<f64> {
        self.centre + Vector2::new(q.x, q.y) * self.scale
    }
}

/// Checks the input: at least 3 finite points, not all on one line, no duplicates.
fn check_points(points: &[Vector2<f64>]) -> Result<(Vector2<f64>, Vector2<f64>)> {
    if points.len() < 3 {
        return Err(Error::input(format!(
            "structure analysis needs at least 3 particle centres, got {}",
            points.len()
        )));
    }
    if let Some(i) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return Err(Error::input(format!(
            "particle {i} has a non-finite centre ({}, {}); all coordinates must be finite",
            points[i].x, points[i].y
        )));
    }
    let mut lo = points[0];
    let mut hi = points[0];
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    Ok((lo, hi))
}

/// Tessellates the centres with the default settings.
///
/// # Errors
/// As [`tessellate_with`].
pub fn tessellate(points: &[Vector2<f64>]) -> Result<Tessellation> {
    tessellate_with(points, &TessellationSettings::default())
}

/// Tessellates the centres (any length unit; results in the same unit).
///
/// # Errors
/// [`Error::Input`] for fewer than 3 points, a non-finite coordinate, duplicate centres, all
/// centres on one line, or a negative/non-finite merge tolerance.
pub fn tessellate_with(
    points: &[Vector2<f64>],
    settings: &TessellationSettings,
) -> Result<Tessellation> {
    let tol = settings.merge_tolerance;
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(Error::input(format!(
            "merge tolerance {tol} is not allowed (need a finite value ≥ 0)"
        )));
    }
    let (lo, hi) = check_points(points)?;
    let half_diagonal = 0.5 * (hi - lo).norm();
    if !half_diagonal.is_finite() {
        return Err(Error::input(format!(
            "the particle centres span {:e} × {:e}: too large to analyse",
            hi.x - lo.x,
            hi.y - lo.y
        )));
    }
    if half_diagonal == 0.0 {
        return Err(Error::input(format!(
            "all {} particle centres coincide",
            points.len()
        )));
    }
    let frame = Frame {
        centre: 0.5 * (lo + hi),
        scale: half_diagonal,
    };
    let local: Vec<Point2<f64>> = points.iter().map(|p| frame.to_local(p)).collect();
    let dt = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(local)
        .map_err(|e| Error::input(format!("cannot triangulate the centres: {e}")))?;
    if dt.num_vertices() < points.len() {
        return Err(Error::input(format!(
            "{} of {} particle centres are duplicates; every centre must be distinct",
            points.len() - dt.num_vertices(),
            points.len()
        )));
    }
    if dt.num_inner_faces() == 0 {
        return Err(Error::input(format!(
            "all {} particle centres lie on one line; a tessellation needs a 2D point set",
            points.len()
        )));
    }
    let (llo, lhi) = (frame.to_local(&lo), frame.to_local(&hi));
    let inside = |c: &Point2<f64>| c.x >= llo.x && c.x <= lhi.x && c.y >= llo.y && c.y <= lhi.y;
    let mean_bond = dt
        .undirected_edges()
        .map(|e| e.length_2().sqrt())
        .sum::<f64>()
        / dt.num_undirected_edges() as f64;
    let merge = tol * mean_bond;
    let centres = circumcentres(&dt);
    let cells = dt
        .vertices()
        .map(|v| {
            let cell = local_cell(v, &centres, merge);
            Cell {
                counted: cell.bounded && cell.vertices.iter().all(inside),
                neighbors: cell.neighbors,
                vertices: cell
                    .vertices
                    .into_iter()
                    .map(|c| frame.to_global(c))
                    .collect(),
                bounded: cell.bounded,
            }
        })
        .collect();
    Ok(Tessellation {
        cells,
        bounds: (lo, hi),
    })
}

/// Circumcentres of the inner faces, indexed by face index (the outer face gets None).
fn circumcentres(dt: &DelaunayTriangulation<Point2<f64>>) -> Vec<Option<Point2<f64>>> {
    let mut centres = vec![None; dt.num_all_faces()];
    for face in dt.inner_faces() {
        centres[face.fix().index()] = Some(face.circumcenter());
    }
    centres
}

/// A cell in the normalized frame (corners not yet mapped back).
struct LocalCell {
    neighbors: Vec<u32>,
    vertices: Vec<Point2<f64>>,
    bounded: bool,
}

/// The cell of one Delaunay vertex: walking its out-edges counter-clockwise, the face left of
/// out-edge k is the corner c_k, and the side dual to edge k runs from c_{k−1} to c_k.
fn local_cell(
    v: spade::handles::VertexHandle<'_, Point2<f64>>,
    centres: &[Option<Point2<f64>>],
    merge: f64,
) -> LocalCell {
    let edges: Vec<_> = v.out_edges().collect();
    let corners: Vec<Option<Point2<f64>>> = edges
        .iter()
        .map(|e| centres[e.face().fix().index()])
        .collect();
    let m = edges.len();
    let bounded = corners.iter().all(Option::is_some);
    let mut neighbors = Vec::with_capacity(m);
    let mut vertices = Vec::with_capacity(m);
    for k in 0..m {
        let (start, end) = (corners[(k + m - 1) % m], corners[k]);
        let degenerate = match (start, end) {
            (Some(a), Some(b)) => ((a.x - b.x).powi(2) + (a.y - b.y).powi(2)).sqrt() <= merge,
            _ => false,
        };
        if !degenerate {
            neighbors.push(edges[k].to().index() as u32);
            if let Some(c) = end {
                vertices.push(c);
            }
        }
    }
    if !bounded {
        vertices.clear();
    }
    LocalCell {
        neighbors,
        vertices,
        bounded,
    }
}
