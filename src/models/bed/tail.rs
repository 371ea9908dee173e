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
    /// The tail beyond `cutoff` (m) of discs with these moments and moments μ sin θ.
    pub(super) fn new(cutoff: f64, moment: &[f64], moment_sin: &[f64]) -> Self {
        Self {
            cutoff,
            moments: (moment.iter().sum(), moment_sin.iter().sum()),
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
/// about `at` (a point inside the region).
fn outside(region: (Vector2<f64>, Vector2<f64>), at: Vector2<f64>, rc: f64) -> (Vector2<f64>, f64) {
    let below = at - region.0; // distances to the left and bottom edges
    let above = region.1 - at; // to the right and top edges
    let mut g = Vector2::zeros();
    let mut s = 0.0;
    for axis in 0..2 {
        for (d, sign) in [(below[axis], -1.0), (above[axis], 1.0)] {
            let (normal, sum) = half_plane(d, rc);
            g[axis] += sign * normal;
            s += sum;
        }
    }
    for (dx, sx) in [(below.x, -1.0), (above.x, 1.0)] {
        for (dy, sy) in [(below.y, -1.0), (above.y, 1.0)] {
            let (q, sum) = quadrant(dx, dy, rc);
            g -= Vector2::new(sx * q.x, sy * q.y);
            s -= sum;
        }
    }
    (g, s)
}

/// The half-plane beyond an edge at distance d > 0, outside the disc of radius rc: (its
/// ∫ ŝ/|s|⁴ dA along the outward normal, its ∫ 1/|s|³ dA). With u = d/rc < 1 the disc cuts
/// the edge over the angles |φ| < φ0 = arccos u.
fn half_plane(d: f64, rc: f64) -> (f64, f64) {
    let u = d / rc;
    if u >= 1.0 {
        return (2.0 / (3.0 * d * d), 2.0 / d);
    }
    let sin0 = (1.0 - u * u).sqrt();
    let one_minus_sin0 = u * u / (1.0 + sin0);
    let normal = sin0 / (rc * rc) + cube_tail(one_minus_sin0, sin0) / (d * d);
    let sum = 2.0 * u.acos() / rc + 2.0 * one_minus_sin0 / d;
    (normal, sum)
}

/// The quadrant x > dx, y > dy (dx, dy > 0) outside the disc of radius rc: (its ∫ ŝ/|s|⁴ dA,
/// its ∫ 1/|s|³ dA). Along φ in (0, π/2) the quadrant starts at dy/sin φ below the angle φ1
/// and at dx/cos φ above φ2, and at rc in between, where the disc holds its corner
/// (φ1 = arcsin(dy/rc), φ2 = arccos(dx/rc); φ1 = φ2 = the corner's angle when it lies outside
/// the disc).
fn quadrant(dx: f64, dy: f64, rc: f64) -> (Vector2<f64>, f64) {
    let corner = dx.hypot(dy);
    let ((sin1, cos1, phi1), (sin2, cos2, phi2)) = if corner >= rc {
        let (s, c) = (dy / corner, dx / corner);
        let phi = dy.atan2(dx);
        ((s, c, phi), (s, c, phi))
    } else {
        let (s1, c2) = (dy / rc, dx / rc);
        let (c1, s2) = ((1.0 - s1 * s1).sqrt(), (1.0 - c2 * c2).sqrt());
        ((s1, c1, s1.asin()), (s2, c2, c2.acos()))
    };
    let one_minus_cos1 = sin1 * sin1 / (1.0 + cos1);
    let one_minus_sin2 = cos2 * cos2 / (1.0 + sin2);
    // below φ1 (the edge y = dy), between (the disc), above φ2 (the edge x = dx)
    let low = Vector2::new(sin1.powi(3) / 3.0, cube_tail(one_minus_cos1, cos1)) / (2.0 * dy * dy);
    let mid = Vector2::new(sin2 - sin1, cos1 - cos2) / (2.0 * rc * rc);
    let high = Vector2::new(cube_tail(one_minus_sin2, sin2), cos2.powi(3) / 3.0) / (2.0 * dx * dx);
    let sum = one_minus_cos1 / dy + (phi2 - phi1) / rc + one_minus_sin2 / dx;
    (low + mid + high, sum)
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
        let (_, s_edge) = half_plane(1e-9, rc);
        assert!((s_edge - PI / rc).abs() < 1e-6, "{s_edge}");
        let (normal, _) = half_plane(1e-9, rc);
        assert!((normal - 1.0 / (rc * rc)).abs() < 1e-6, "{normal}");
    }
}
