//! The mean-field tail of the cut-off pair sums (issue 18, item 3; docs/bed.md, "Tail
//! correction"): what the pairs beyond r_c would add if the discs there were spread uniformly
//! over the bed.
//!
//! Why it is needed: both pair sums decay slowly. The B4 sum Σ μ_j sin θ_j/r³ has no sign
//! cancellation, and beyond r_c a uniform bed of number density ρ adds 2πρ/r_c to it: about
//! 10 % of the sum at r_c = 7.13 D. The B1 force sum cancels inside the bed but not within
//! r_c of its edges, where the missing far discs would push each disc towards the walls and
//! the piston. A cut-off list therefore underestimates both the piston force and the plate
//! friction.
//!
//! The model: the discs' moments μ_j (and μ_j sin θ_j) spread uniformly over the rectangle R
//! spanned by the disc centres and widened by half the mean spacing a on every side (the
//! region a disc of a uniform lattice stands for). For a disc at r inside R,
//!
//!   tail of Σ μ_j d/r⁵        = ρ_μ ∫_{R, |s| > r_c} (−s) |s|⁻⁵ dA = ρ_μ ∫_{R^c, |s| > r_c} s |s|⁻⁵ dA
//!   tail of Σ μ_j sin θ_j/r³   = ρ_μs (2π/r_c − ∫_{R^c, |s| > r_c} |s|⁻³ dA)
//!
//! with s the position relative to the disc (the integrals over the whole plane outside the
//! disc |s| = r_c are 0 and 2π/r_c). R^c is the union of the four half-planes beyond the
//! edges, whose pairwise overlaps are the four corner quadrants, so each integral is four
//! half-plane terms minus four quadrant terms, each in closed form (polar coordinates about
//! the disc: ∫ dφ/r_e for the r⁻³ sum and ∫ ŝ/(2 r_e²) dφ for the force, r_e(φ) the larger of
//! r_c and the distance to the region along φ).

use nalgebra::Vector2;
use std::f64::consts::PI;

use super::list_gather::Partner;

/// The uniform-density tail of one run's cut-off sums.
#[derive(Debug, Clone)]
pub(super) struct Tail {
    cutoff: f64,
    /// Σ μ_j and Σ μ_j sin θ_j over all discs, A·m².
    moments: (f64, f64),
    /// Lower and upper corner of R, m.
    region: (Vector2<f64>, Vector2<f64>),
    /// (ρ_μ, ρ_μs): the moments per area of R, A·m²/m².
    density: (f64, f64),
}

impl Tail {
    /// The tail beyond `cutoff` (m) of these discs.
    pub(super) fn new(cutoff: f64, discs: &[Partner]) -> Self {
        Self {
            cutoff,
            moments: (
                discs.iter().map(|d| d.moment).sum(),
                discs.iter().map(|d| d.moment_sin).sum(),
            ),
            region: (Vector2::zeros(), Vector2::zeros()),
            density: (0.0, 0.0),
        }
    }

    /// Spreads the moments over the region of the discs at `position`: their bounding box
    /// widened by half the mean spacing a = (2/(√3 n))^½ of its number density n.
    pub(super) fn update(&mut self, position: &[Vector2<f64>]) {
        let Some(first) = position.first() else {
            return;
        };
        let (low, high) = position
            .iter()
            .fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
        let hull = (high - low).x * (high - low).y;
        // discs in one row or column span no area: widen by r_c/2 so the region stays finite
        let spacing = if hull > 0.0 {
            (2.0 * hull / (3f64.sqrt() * position.len() as f64)).sqrt()
        } else {
            self.cutoff
        };
        let widen = Vector2::repeat(0.5 * spacing);
        self.region = (low - widen, high + widen);
        let area = (self.region.1 - self.region.0).product();
        self.density = (self.moments.0 / area, self.moments.1 / area);
    }

    /// The tails (of Σ μ_j d/r⁵, of Σ μ_j sin θ_j/r³) at a disc at `at` inside the region.
    pub(super) fn at(&self, at: Vector2<f64>) -> (Vector2<f64>, f64) {
        let (g, s) = outside(self.region, at, self.cutoff);
        (
            self.density.0 * g,
            self.density.1 * (2.0 * PI / self.cutoff - s),
        )
    }
}

/// ∫ ŝ/|s|⁴ dA and ∫ 1/|s|³ dA over the plane outside `region` and outside the disc |s| ≤ rc
/// about `at` (a point inside the region). Each edge distance is inverted once and shared by
/// its half-plane and its two corners (the divisions are most of the cost).
fn outside(region: (Vector2<f64>, Vector2<f64>), at: Vector2<f64>, rc: f64) -> (Vector2<f64>, f64) {
    let below = at - region.0; // distances to the left and bottom edges
    let above = region.1 - at; // to the right and top edges
    let edge = |d: f64| Edge { d, inv: 1.0 / d };
    let (left, right, bottom, top) = (edge(below.x), edge(above.x), edge(below.y), edge(above.y));
    let mut g = Vector2::zeros();
    let mut s = 0.0;
    for (axis, low, high) in [(0, left, right), (1, bottom, top)] {
        for (e, sign) in [(low, -1.0), (high, 1.0)] {
            let (normal, sum) = half_plane(e, rc);
            g[axis] += sign * normal;
            s += sum;
        }
    }
    for (x, sx) in [(left, -1.0), (right, 1.0)] {
        for (y, sy) in [(bottom, -1.0), (top, 1.0)] {
            let (q, sum) = quadrant(x, y, rc);
            g -= Vector2::new(sx * q.x, sy * q.y);
            s -= sum;
        }
    }
    (g, s)
}

/// An edge's distance d > 0 from the point and 1/d.
#[derive(Clone, Copy)]
struct Edge {
    d: f64,
    inv: f64,
}

/// The half-plane beyond an edge, outside the disc of radius rc: (its ∫ ŝ/|s|⁴ dA along the
/// outward normal, its ∫ 1/|s|³ dA). With u = d/rc < 1 the disc cuts the edge over the
/// angles |φ| < φ0 = arccos u.
fn half_plane(e: Edge, rc: f64) -> (f64, f64) {
    let (d, inv) = (e.d, e.inv);
    if d >= rc {
        return (2.0 / 3.0 * inv * inv, 2.0 * inv);
    }
    let u = d / rc;
    let sin0 = (1.0 - u * u).sqrt();
    let one_minus_sin0 = u * u / (1.0 + sin0);
    let normal = sin0 / (rc * rc) + cube_tail(one_minus_sin0, sin0) * inv * inv;
    let sum = 2.0 * u.acos() / rc + 2.0 * one_minus_sin0 * inv;
    (normal, sum)
}

/// The quadrant beyond the edges x = dx and y = dy (dx, dy > 0) outside the disc of radius
/// rc: (its ∫ ŝ/|s|⁴ dA, its ∫ 1/|s|³ dA). Along φ in (0, π/2) the quadrant starts at
/// dy/sin φ below the angle φ1 and at dx/cos φ above φ2, and at rc in between, where the disc
/// holds its corner (φ1 = arcsin(dy/rc), φ2 = arccos(dx/rc); φ1 = φ2 = the corner's angle
/// when it lies outside the disc).
fn quadrant(x: Edge, y: Edge, rc: f64) -> (Vector2<f64>, f64) {
    let (dx, dy) = (x.d, y.d);
    let corner2 = dx * dx + dy * dy;
    if corner2 >= rc * rc {
        // φ1 = φ2 = the corner's angle: no arc, no angle needed. 1 − cos and 1 − sin without
        // cancellation: dy²/(c (c + dx)) and dx²/(c (c + dy)), c the corner's distance, over
        // one shared division.
        let corner = corner2.sqrt();
        let inv = 1.0 / corner;
        let shared = inv / ((corner + dx) * (corner + dy));
        let (sin, cos) = (dy * inv, dx * inv);
        let one_minus_cos = dy * dy * (corner + dy) * shared;
        let one_minus_sin = dx * dx * (corner + dx) * shared;
        let ((low, below), (high, above)) =
            edges_of_quadrant((sin, cos, one_minus_cos), (sin, cos, one_minus_sin), x, y);
        return (low + high, below + above);
    }
    let (sin1, cos2) = (dy / rc, dx / rc);
    let (cos1, sin2) = ((1.0 - sin1 * sin1).sqrt(), (1.0 - cos2 * cos2).sqrt());
    let first = (sin1, cos1, sin1 * sin1 / (1.0 + cos1));
    let second = (sin2, cos2, cos2 * cos2 / (1.0 + sin2));
    let ((low, below), (high, above)) = edges_of_quadrant(first, second, x, y);
    let mid = Vector2::new(sin2 - sin1, cos1 - cos2) / (2.0 * rc * rc);
    let arc = cos2.acos() - sin1.asin();
    (low + mid + high, below + arc / rc + above)
}

/// One part of [`quadrant`]: (∫ ŝ/|s|⁴ dA, ∫ 1/|s|³ dA).
type Part = (Vector2<f64>, f64);

/// The parts of [`quadrant`] along its two edges: below φ1 (the edge y = dy) and above φ2
/// (the edge x = dx), given (sin, cos, 1 − cos) of φ1 and (sin, cos, 1 − sin) of φ2.
fn edges_of_quadrant(
    (sin1, cos1, one_minus_cos1): (f64, f64, f64),
    (sin2, cos2, one_minus_sin2): (f64, f64, f64),
    x: Edge,
    y: Edge,
) -> (Part, Part) {
    let (half_x2, half_y2) = (0.5 * x.inv * x.inv, 0.5 * y.inv * y.inv);
    let low = Vector2::new(sin1.powi(3) / 3.0, cube_tail(one_minus_cos1, cos1)) * half_y2;
    let high = Vector2::new(cube_tail(one_minus_sin2, sin2), cos2.powi(3) / 3.0) * half_x2;
    (
        (low, one_minus_cos1 * y.inv),
        (high, one_minus_sin2 * x.inv),
    )
}

/// 2/3 − c + c³/3 = (1 − c)²(2 + c)/3, from 1 − c (computed without cancellation).
fn cube_tail(one_minus_c: f64, c: f64) -> f64 {
    one_minus_c * one_minus_c * (2.0 + c) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same integrals over the region itself by rays from the point: along φ the region
    /// ends at L(φ), and the part beyond rc adds (1/rc − 1/L) to ∫ 1/|s|³ and
    /// −ŝ (1/rc² − 1/L²)/2 to ∫ (−s)/|s|⁵ (midpoint rule in φ, its kinks resolved by many rays).
    fn by_rays(
        region: (Vector2<f64>, Vector2<f64>),
        at: Vector2<f64>,
        rc: f64,
    ) -> (Vector2<f64>, f64) {
        let rays = 400_000;
        let (mut g, mut s) = (Vector2::zeros(), 0.0);
        for k in 0..rays {
            let phi = 2.0 * PI * (k as f64 + 0.5) / rays as f64;
            let dir = Vector2::new(phi.cos(), phi.sin());
            let reach = (0..2)
                .map(|a| {
                    if dir[a] > 0.0 {
                        (region.1[a] - at[a]) / dir[a]
                    } else if dir[a] < 0.0 {
                        (region.0[a] - at[a]) / dir[a]
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(f64::INFINITY, f64::min);
            if reach > rc {
                s += 1.0 / rc - 1.0 / reach;
                g -= dir * (1.0 / (rc * rc) - 1.0 / (reach * reach)) / 2.0;
            }
        }
        let w = 2.0 * PI / rays as f64;
        (g * w, s * w)
    }

    /// The closed forms (four half-planes minus four quadrants outside the region) against rays
    /// inside it, for a point deep inside, near an edge, near a corner (the corner inside the
    /// excluded disc), and in a region narrower than 2 rc.
    #[test]
    fn closed_forms_match_the_integral_over_the_region() {
        let rc = 1.0;
        let cases = [
            ((0.0, 0.0, 10.0, 6.0), (5.0, 3.0)),
            ((0.0, 0.0, 10.0, 6.0), (0.3, 3.0)),
            ((0.0, 0.0, 10.0, 6.0), (0.4, 5.5)),
            ((0.0, 0.0, 10.0, 6.0), (1.5, 0.9)),
            ((0.0, 0.0, 1.5, 12.0), (0.7, 6.0)),
            ((-3.0, 1.0, 4.0, 2.2), (3.9, 1.1)),
        ];
        for ((x0, y0, x1, y1), (x, y)) in cases {
            let region = (Vector2::new(x0, y0), Vector2::new(x1, y1));
            let at = Vector2::new(x, y);
            let (g, s) = outside(region, at, rc);
            let tail = (g, 2.0 * PI / rc - s);
            let rays = by_rays(region, at, rc);
            let scale = rays.1.abs().max(1e-3);
            assert!(
                (tail.1 - rays.1).abs() < 1e-6 * scale,
                "{at:?}: {tail:?} {rays:?}"
            );
            let scale = rays.0.norm().max(1e-3);
            assert!(
                (tail.0 - rays.0).norm() < 1e-6 * scale,
                "{at:?}: {tail:?} {rays:?}"
            );
        }
    }

    /// Deep inside a large region the tails are the bulk values: 2π ρ/rc for the r⁻³ sum and
    /// nothing for the force (symmetry); at the centre of an edge the r⁻³ tail is half the
    /// bulk's plus the half-plane beyond (the disc straddles the edge).
    #[test]
    fn bulk_and_edge_limits() {
        let rc = 0.5;
        let region = (Vector2::new(-500.0, -500.0), Vector2::new(500.0, 500.0));
        let (g, s) = outside(region, Vector2::zeros(), rc);
        assert!(g.norm() < 1e-12 && s < 1e-2 * 2.0 * PI / rc, "{g:?} {s}");
        let edge = Edge { d: 1e-9, inv: 1e9 };
        let (_, s_edge) = half_plane(edge, rc);
        assert!((s_edge - PI / rc).abs() < 1e-6, "{s_edge}");
        let (normal, _) = half_plane(edge, rc);
        assert!((normal - 1.0 / (rc * rc)).abs() < 1e-6, "{normal}");
    }
}
