//! The mean-field tail of the cut-off pair sums (issue 18, item 3; docs/bed.md, "Tail
//! correction"): what the pairs beyond r_c would add if the discs there were spread evenly
//! across the bed within each height band.
//!
//! Why it is needed: both pair sums decay slowly. The B4 sum Σ μ_j sin θ_j/r³ has no sign
//! cancellation, and beyond r_c a uniform bed of number density ρ adds 2πρ/r_c to it: about
//! 10 % of the sum at r_c = 7.13 D. The B1 force sum cancels inside the bed but not within
//! r_c of its edges, where the missing far discs would push each disc towards the walls and
//! the piston. A cut-off list therefore underestimates both the piston force and the plate
//! friction.
//!
//! The model: the discs' moments μ_j (and μ_j sin θ_j) spread over the rectangle R spanned
//! by the disc centres and widened by half the mean spacing a on every side (the region a
//! disc of a uniform lattice stands for), evenly within each horizontal band of height about
//! r_c/2. For a disc at r inside R and a band B of densities (ρ_μ, ρ_μs),
//!
//!   its part of the tail of Σ μ_j d/r⁵       = ρ_μ ∫_{B, |s| > r_c} (−s) |s|⁻⁵ dA
//!   its part of the tail of Σ μ_j sin θ_j/r³  = ρ_μs ∫_{B, |s| > r_c} |s|⁻³ dA
//!
//! with s the position relative to the disc. For a box holding the disc the integrals are
//! those over the whole plane outside the disc |s| = r_c (0 and 2π/r_c) less those over its
//! complement: four half-planes beyond its edges, whose pairwise overlaps are the four corner
//! quadrants, each in closed form (polar coordinates about the disc: ∫ dφ/r_e for the r⁻³ sum
//! and ∫ ŝ/(2 r_e²) dφ for the force, r_e(φ) the larger of r_c and the distance to the
//! region along φ). A band that does not hold the disc is the difference of two such boxes.
//!
//! Why bands: a uniform density leaves out the bed's height profile (denser at the floor
//! under gravity, or under the piston), and summed over the real discs its push is no longer
//! balanced: a net force on the bed that pairs (action = reaction) cannot exert (at N = 736
//! and 128 mm/s, 0.26 N upwards at 15.8 N of piston force, 0.6 N downwards in the loose bed;
//! 0.001–0.04 N with every band at every step). With it the cycle work came out 1.2–2.5 %
//! above the exact sums; with bands −0.7 … +0.4 %, mean −0.13 % (results/bed/README.md,
//! "Tail correction over whole cycles"). Each disc's tail changes slowly (on the scale r_c/2
//! of its position and of the bed's profile): it is computed anew, from blocks of bands that
//! grow with the distance, once some disc has moved r_c/64, and held in between.

use nalgebra::Vector2;
use std::f64::consts::PI;
use std::ops::Range;

use super::list_gather::Partner;
use super::tail_lanes::four_edges;

/// Height of the density bands, in cut-off radii. Why r_c/2: the far kernel beyond r_c is
/// smooth on the scale r_c, so it resolves density changes over r_c (the bed's gravity
/// gradient, its layer under the piston) and averages the disc-scale layering it cannot see.
const BAND_HEIGHT: f64 = 0.5;

/// The mean-field tail of one run's cut-off sums.
#[derive(Debug, Clone)]
pub(super) struct Tail {
    cutoff: f64,
    /// Lower and upper corner of R, m.
    region: (Vector2<f64>, Vector2<f64>),
    /// R cut into bands of height about [`BAND_HEIGHT`] r_c, their own densities.
    bands: Vec<Band>,
    /// Σ of the bands' moments (μ, μ sin θ) below each band edge, A·m².
    running: Vec<(f64, f64)>,
    /// Per disc: its tails (of Σ μ_j d/r⁵, of Σ μ_j sin θ_j/r³) as of the last refresh.
    held: Vec<(Vector2<f64>, f64)>,
    /// The discs' positions at the last refresh, m.
    refreshed_at: Vec<Vector2<f64>>,
    /// Per band holding a disc, the blocks its discs see ([`Self::blocks_around`]), end to
    /// end: the same for all of them, so made once per refresh (at most N bands' worth).
    views: Vec<Band>,
    /// Each band's blocks in `views` (none for a band without discs).
    view_of: Vec<Range<usize>>,
}

/// How far (in cut-off radii) a disc may move before the tails are computed anew. Why
/// r_c/64 (0.11 D at the default 7.13 D): a disc's tail varies on the scale of r_c beside
/// the distance to R's edges and of r_c/2 (the band height) elsewhere, and held tails then
/// stay within a few per cent of fresh ones (test `held_tails_stay_close_to_fresh_ones`).
const MOVE_LIMIT: f64 = 1.0 / 64.0;

/// Bands kept as they are on either side of a disc's own band ([`Tail::blocks_around`]).
const FINE: usize = 4;

/// Beyond them, blocks of 2^L bands start [`COARSE`]·2^L bands away.
const COARSE: usize = 2;

/// The most bands R is cut into (a region higher than 2²⁰ half cut-offs is no bed; its bands
/// are then taller).
const MOST_BANDS: usize = 1 << 20;

/// A horizontal band of R: its lower edge (m) and its densities (ρ_μ, ρ_μs), A·m²/m².
#[derive(Debug, Clone, Copy, Default)]
struct Band {
    low: f64,
    density: (f64, f64),
}

impl Tail {
    /// The tail beyond `cutoff` (m), computed at the first update.
    pub(super) fn new(cutoff: f64) -> Self {
        Self {
            cutoff,
            region: (Vector2::zeros(), Vector2::zeros()),
            bands: Vec::new(),
            running: Vec::new(),
            held: Vec::new(),
            refreshed_at: Vec::new(),
            views: Vec::new(),
            view_of: Vec::new(),
        }
    }

    /// Once some disc has moved more than [`MOVE_LIMIT`] r_c since the last refresh (and at
    /// the first call, or when the discs are more or fewer):
    /// spreads the moments over the region of the discs at `position` (their bounding box
    /// widened by half the mean spacing a = (2/(√3 n))^½ of its number density n) band by
    /// band, and computes each disc's tails anew (`per_disc` fills a vector by index, on the
    /// pool where the caller's rule says).
    pub(super) fn update(
        &mut self,
        position: &[Vector2<f64>],
        discs: &[Partner],
        per_disc: impl Fn(&mut Vec<(Vector2<f64>, f64)>, &(dyn Fn(usize) -> (Vector2<f64>, f64) + Sync)),
    ) {
        if position.is_empty() || !self.due(position) {
            return;
        }
        self.refreshed_at.clear();
        self.refreshed_at.extend_from_slice(position);
        self.region = region_of(position, self.cutoff);
        self.fill_bands(position, discs);
        self.fill_views();
        let mut held = std::mem::take(&mut self.held);
        let this = &*self;
        per_disc(&mut held, &|i| {
            let at = position[i];
            let blocks = &this.views[this.view_of[this.band_of(at.y)].clone()];
            this.integral(blocks, at)
        });
        self.held = held;
    }

    /// Whether a refresh is due: the discs are more or fewer than at the last, or one has
    /// moved more than [`MOVE_LIMIT`] r_c since.
    fn due(&self, position: &[Vector2<f64>]) -> bool {
        let limit = (MOVE_LIMIT * self.cutoff).powi(2);
        self.refreshed_at.len() != position.len()
            || (position.iter().zip(&self.refreshed_at))
                .any(|(p, q)| (p - q).norm_squared() > limit)
    }

    /// Cuts R into bands of height about [`BAND_HEIGHT`] r_c and spreads each disc's
    /// moments over the band holding its centre; keeps the running sums of the bands'
    /// moments for the blocks of [`Self::blocks_around`], and marks the bands that hold a
    /// disc for [`Self::fill_views`].
    fn fill_bands(&mut self, position: &[Vector2<f64>], discs: &[Partner]) {
        let (low, high) = self.region;
        let count = (((high.y - low.y) / (BAND_HEIGHT * self.cutoff)).round() as usize)
            .clamp(1, MOST_BANDS);
        let height = (high.y - low.y) / count as f64;
        self.bands.clear();
        self.bands.extend((0..count).map(|b| Band {
            low: low.y + height * b as f64,
            density: (0.0, 0.0),
        }));
        self.view_of.clear();
        self.view_of.resize(count, 0..0);
        for (p, disc) in position.iter().zip(discs) {
            let b = self.band_of(p.y);
            let d = &mut self.bands[b].density;
            *d = (d.0 + disc.moment, d.1 + disc.moment_sin);
            self.view_of[b] = 0..1; // marks the band as held; `fill_views` sets its range
        }
        self.running.clear();
        self.running.push((0.0, 0.0));
        for band in &self.bands {
            let last = self.running[self.running.len() - 1];
            self.running
                .push((last.0 + band.density.0, last.1 + band.density.1));
        }
        let area = (high.x - low.x) * height;
        for band in &mut self.bands {
            band.density = (band.density.0 / area, band.density.1 / area);
        }
    }

    /// The blocks of each band that [`Self::fill_bands`] marked as holding a disc.
    fn fill_views(&mut self) {
        let mut views = std::mem::take(&mut self.views);
        views.clear();
        for own in 0..self.bands.len() {
            if !self.view_of[own].is_empty() {
                let start = views.len();
                self.blocks_around(own, &mut views);
                self.view_of[own] = start..views.len();
            }
        }
        self.views = views;
    }

    /// The band holding height y (the first or last beyond R's bottom or top).
    fn band_of(&self, y: f64) -> usize {
        let (low, high) = (self.region.0.y, self.region.1.y);
        let count = self.bands.len();
        (((y - low) / (high - low) * count as f64).max(0.0) as usize).min(count - 1)
    }

    /// The bands as a disc in band `own` sees them: its own and [`FINE`] on either side as
    /// they are; beyond, blocks of 2^L bands (aligned to multiples of 2^L) from
    /// [`COARSE`]·2^L bands away, each with its mean density. Why: a far edge's term varies
    /// on the scale of its distance, so a block's inner profile matters there by about
    /// (size/distance)² of its density steps, and the blocks grow with the distance: about
    /// 2·FINE + 2·COARSE·log₂(bands) edge terms per disc instead of one per band.
    /// Appends them to `out`.
    fn blocks_around(&self, own: usize, out: &mut Vec<Band>) {
        let count = self.bands.len();
        let (low, height) = (
            self.region.0.y,
            (self.region.1.y - self.region.0.y) / count as f64,
        );
        let width = self.region.1.x - self.region.0.x;
        let block = |a: usize, b: usize| {
            let (sa, sb) = (self.running[a], self.running[b]);
            let area = width * height * (b - a) as f64;
            Band {
                low: low + height * a as f64,
                density: ((sb.0 - sa.0) / area, (sb.1 - sa.1) / area),
            }
        };
        let level = |edge: usize, distance: usize| {
            let mut size = 1;
            while edge.is_multiple_of(2 * size) && COARSE * 2 * size <= distance {
                size *= 2;
            }
            size
        };
        let start = out.len();
        // below the window, from the window down (reversed after)
        let mut edge = own.saturating_sub(FINE);
        while edge > 0 {
            let size = level(edge, own + 1 - edge).min(edge);
            out.push(block(edge - size, edge));
            edge -= size;
        }
        out[start..].reverse();
        for b in own.saturating_sub(FINE)..(own + FINE + 1).min(count) {
            out.push(self.bands[b]);
        }
        let mut edge = (own + FINE + 1).min(count);
        while edge < count {
            let size = level(edge, edge - own).min(count - edge);
            out.push(block(edge, edge + size));
            edge += size;
        }
    }

    /// The tails (of Σ μ_j d/r⁵, of Σ μ_j sin θ_j/r³) at disc `i` as of the last refresh.
    pub(super) fn at(&self, i: usize) -> (Vector2<f64>, f64) {
        self.held[i]
    }

    /// Σ_b ρ_b ∫_{band b, |s| > r_c} ((−s)/|s|⁵, 1/|s|³) dA at `at` (inside R), the bands
    /// given by their lower edges (ascending, the first R's; the last band ends at R's top).
    ///
    /// Each band is a box; a box holding the point is the plane less four half-planes plus
    /// four corner quadrants; a band below it is the difference of two boxes reaching up to
    /// R's top (above it, down to R's bottom), which differ in one edge and its two corners
    /// only. So the whole sum is the two sides (weighted by the point's own band) and one
    /// horizontal edge term per band edge, weighted by the density step across it.
    fn integral(&self, bands: &[Band], at: Vector2<f64>) -> (Vector2<f64>, f64) {
        let rc = self.cutoff;
        let (region_low, region_high) = self.region;
        let (left, right) = (
            edge(at.x - region_low.x, rc),
            edge(region_high.x - at.x, rc),
        );
        let own = bands.partition_point(|b| b.low <= at.y).max(1) - 1;
        let rho = |k: usize| bands.get(k).map_or((0.0, 0.0), |b| b.density);
        let (near_left, sum_left) = half_plane(left, rc);
        let (near_right, sum_right) = half_plane(right, rc);
        let rho_own = rho(own);
        let mut g = Vector2::new(rho_own.0 * (near_right - near_left), 0.0);
        let mut s = rho_own.1 * (2.0 * PI / rc - sum_left - sum_right);
        let edges = bands.len() + 1;
        let height = |k: usize| bands.get(k).map_or(region_high.y, |b| b.low);
        for first in (0..edges).step_by(4) {
            // the last four padded with the top edge, its extra lanes unused
            let heights = [0, 1, 2, 3].map(|l| height((first + l).min(edges - 1)));
            let count = (edges - first).min(4);
            let terms = four_edges((left, right), at.y, (first, own), heights, count, rc);
            for (l, (eg, es)) in terms.into_iter().enumerate().take(count) {
                let k = first + l;
                let step = if k <= own {
                    let before = if k == 0 { (0.0, 0.0) } else { rho(k - 1) };
                    (rho(k).0 - before.0, rho(k).1 - before.1)
                } else {
                    (rho(k - 1).0 - rho(k).0, rho(k - 1).1 - rho(k).1)
                };
                g += eg * step.0;
                s -= es * step.1;
            }
        }
        (g, s)
    }
}

/// The discs' bounding box widened by half their mean spacing a = (2/(√3 n))^½ (n their
/// number density in the box) on every side: the region a disc of a uniform triangular
/// lattice stands for. Discs in one row or column span no area: then widened by rc/2.
fn region_of(position: &[Vector2<f64>], rc: f64) -> (Vector2<f64>, Vector2<f64>) {
    let first = position[0];
    let (low, high) = position
        .iter()
        .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let hull = (high - low).x * (high - low).y;
    let spacing = if hull > 0.0 {
        (2.0 * hull / (3f64.sqrt() * position.len() as f64)).sqrt()
    } else {
        rc
    };
    let widen = Vector2::repeat(0.5 * spacing);
    (low - widen, high + widen)
}

/// ∫ ŝ/|s|⁴ dA and ∫ 1/|s|³ dA outside the disc |s| ≤ rc over the half-plane beyond a
/// horizontal edge at distance `y` below (`below`) or above the point, less its two corner
/// quadrants beyond the vertical edges at distances `sides` (the part that a box's
/// complement holds for that edge).
pub(super) fn horizontal_edge(
    sides: (Edge, Edge),
    y: Edge,
    below: bool,
    rc: f64,
) -> (Vector2<f64>, f64) {
    let sy = if below { -1.0 } else { 1.0 };
    let (normal, mut s) = half_plane(y, rc);
    let mut g = Vector2::new(0.0, sy * normal);
    for (x, sx) in [(sides.0, -1.0), (sides.1, 1.0)] {
        let (q, sum) = quadrant(x, y, rc);
        g -= Vector2::new(sx * q.x, sy * q.y);
        s -= sum;
    }
    (g, s)
}

/// The edge at distance d from the point, at least a billionth of rc (a point on an edge is
/// the limit of points beside it; the closed forms are continuous there).
pub(super) fn edge(d: f64, rc: f64) -> Edge {
    let d = d.max(1e-9 * rc);
    Edge { d, inv: 1.0 / d }
}

/// An edge's distance d > 0 from the point and 1/d.
#[derive(Clone, Copy)]
pub(super) struct Edge {
    pub(super) d: f64,
    pub(super) inv: f64,
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

    /// A tail over `region` (its bands unset) for the integrals alone.
    fn over(region: (Vector2<f64>, Vector2<f64>), rc: f64) -> Tail {
        Tail {
            region,
            ..Tail::new(rc)
        }
    }

    /// The integrals ((−s)/|s|⁵, 1/|s|³) over the part of `area` beyond rc from `at` (any
    /// point), by rays: along φ the ray lies in the box between its entry and exit distances,
    /// and the part beyond rc adds (1/a − 1/b) to ∫ 1/|s|³ and −ŝ (1/a² − 1/b²)/2 to the force
    /// integral (midpoint rule in φ, its kinks resolved by many rays).
    fn by_rays(
        area: (Vector2<f64>, Vector2<f64>),
        at: Vector2<f64>,
        rc: f64,
    ) -> (Vector2<f64>, f64) {
        let rays = 400_000;
        let (mut g, mut s) = (Vector2::zeros(), 0.0);
        for k in 0..rays {
            let phi = 2.0 * PI * (k as f64 + 0.5) / rays as f64;
            let dir = Vector2::new(phi.cos(), phi.sin());
            let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
            for a in 0..2 {
                if dir[a] != 0.0 {
                    let (t0, t1) = ((area.0[a] - at[a]) / dir[a], (area.1[a] - at[a]) / dir[a]);
                    enter = enter.max(t0.min(t1));
                    exit = exit.min(t0.max(t1));
                } else if at[a] < area.0[a] || at[a] > area.1[a] {
                    exit = 0.0;
                }
            }
            let from = enter.max(rc);
            if exit > from {
                s += 1.0 / from - 1.0 / exit;
                g -= dir * (1.0 / (from * from) - 1.0 / (exit * exit)) / 2.0;
            }
        }
        let w = 2.0 * PI / rays as f64;
        (g * w, s * w)
    }

    fn assert_close(got: (Vector2<f64>, f64), want: (Vector2<f64>, f64), at: Vector2<f64>) {
        let scale = want.1.abs().max(1e-3);
        assert!(
            (got.1 - want.1).abs() < 1e-6 * scale,
            "{at:?}: {got:?} {want:?}"
        );
        let scale = want.0.norm().max(1e-3);
        assert!(
            (got.0 - want.0).norm() < 1e-6 * scale,
            "{at:?}: {got:?} {want:?}"
        );
    }

    /// One band: the closed forms (four half-planes minus four quadrants outside the region)
    /// against rays inside it, for a point deep inside, near an edge, near a corner (the
    /// corner inside the excluded disc), and in a region narrower than 2 rc.
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
            let one = [Band {
                low: y0,
                density: (1.0, 1.0),
            }];
            let got = over(region, rc).integral(&one, at);
            assert_close(got, by_rays(region, at, rc), at);
        }
    }

    /// Several bands of their own densities (one empty): the telescoped edge terms against
    /// rays over each band, for points inside the lowest, a middle and the top band, near a
    /// side, on a band edge, and within rc of several edges at once.
    #[test]
    fn bands_match_the_integral_over_each_band() {
        let rc = 1.0;
        let region = (Vector2::new(0.0, 0.0), Vector2::new(10.0, 6.0));
        let lows = [0.0, 1.3, 2.0, 2.4, 4.1];
        let densities = [(2.0, 1.5), (0.0, 0.0), (1.0, 3.0), (0.7, 0.2), (1.4, 1.1)];
        let bands: Vec<Band> = lows
            .iter()
            .zip(densities)
            .map(|(&low, density)| Band { low, density })
            .collect();
        let tail = over(region, rc);
        for (x, y) in [
            (5.0, 0.5),
            (5.0, 2.2),
            (0.4, 3.0),
            (9.8, 5.9),
            (3.0, 2.0),
            (6.0, 1.7),
        ] {
            let at = Vector2::new(x, y);
            let mut want = (Vector2::zeros(), 0.0);
            for (b, band) in bands.iter().enumerate() {
                let top = bands.get(b + 1).map_or(region.1.y, |n| n.low);
                let area = (
                    Vector2::new(region.0.x, band.low),
                    Vector2::new(region.1.x, top),
                );
                let (g, s) = by_rays(area, at, rc);
                want = (want.0 + g * band.density.0, want.1 + s * band.density.1);
            }
            assert_close(tail.integral(&bands, at), want, at);
        }
    }

    /// Deep inside a large region the tails are the bulk values: 2π ρ/rc for the r⁻³ sum and
    /// nothing for the force (symmetry); at the centre of an edge the r⁻³ tail is half the
    /// bulk's plus the half-plane beyond (the disc straddles the edge).
    #[test]
    fn bulk_and_edge_limits() {
        let rc = 0.5;
        let region = (Vector2::new(-500.0, -500.0), Vector2::new(500.0, 500.0));
        let one = [Band {
            low: -500.0,
            density: (1.0, 1.0),
        }];
        let (g, s) = over(region, rc).integral(&one, Vector2::zeros());
        assert!(
            g.norm() < 1e-12 && (s - 2.0 * PI / rc).abs() < 1e-2 * 2.0 * PI / rc,
            "{g:?} {s}"
        );
        let (normal, s_edge) = half_plane(edge(0.0, rc), rc);
        assert!((s_edge - PI / rc).abs() < 1e-6, "{s_edge}");
        assert!((normal - 1.0 / (rc * rc)).abs() < 1e-6, "{normal}");
    }

    /// 120 rows of 40 discs 9 mm apart (D = 5 mm), the rows further apart towards the top (a
    /// bed denser at the bottom, as under gravity).
    fn graded_bed() -> (Vec<Vector2<f64>>, Vec<Partner>) {
        let (mut position, mut discs) = (Vec::new(), Vec::new());
        for row in 0..120 {
            let y = 0.0078 * row as f64 * (1.0 + 0.005 * row as f64);
            for col in 0..40 {
                position.push(Vector2::new(
                    0.009 * col as f64 + 0.0045 * (row % 2) as f64,
                    y,
                ));
                discs.push(Partner {
                    moment: 1.0,
                    moment_sin: 0.02,
                    diameter: 0.005,
                });
            }
        }
        (position, discs)
    }

    /// The graded bed's tail after its first update, and R as one band of its mean densities
    /// (a tail of uniform density).
    fn graded_tail() -> (Vec<Vector2<f64>>, Tail, [Band; 1]) {
        let (position, discs) = graded_bed();
        let mut tail = Tail::new(0.035);
        tail.update(&position, &discs, |out, f| {
            out.clear();
            out.extend((0..position.len()).map(f));
        });
        let area = (tail.region.1 - tail.region.0).product();
        let total = |f: fn(&Partner) -> f64| discs.iter().map(f).sum::<f64>() / area;
        let uniform = [Band {
            low: tail.region.0.y,
            density: (total(|d| d.moment), total(|d| d.moment_sin)),
        }];
        (position, tail, uniform)
    }

    /// A graded bed: the uniform tail pushes a disc near the top too hard (the bands above it
    /// are thinner than the mean) and, summed over the discs, gives the bed a net force that
    /// the pairs (action = reaction) cannot; the banded tail does neither. Each disc's tail
    /// (from blocks of bands) is the integral over the bands themselves within 5 % (rms) of
    /// the part the bands add to the uniform tail (measured 3.0 %; 1.6 and 0.6 % with
    /// blocks from 3 and 4 sizes away, 6.7 and 0.5 % with 2 and 8 bands kept as they are).
    #[test]
    fn a_graded_bed_gets_its_banded_tail() {
        let (position, tail, uniform) = graded_tail();
        assert!(
            tail.bands.len() > 2 * (FINE + 2 * COARSE),
            "{}",
            tail.bands.len()
        );
        let (mut net_banded, mut net_uniform) = (Vector2::zeros(), Vector2::zeros());
        let (mut error2, mut part2) = (0.0, 0.0);
        for (i, &at) in position.iter().enumerate() {
            let uniform = tail.integral(&uniform, at);
            let banded = tail.integral(&tail.bands, at);
            error2 += (tail.at(i).0 - banded.0).norm_squared();
            part2 += (banded.0 - uniform.0).norm_squared();
            net_banded += banded.0;
            net_uniform += uniform.0;
        }
        let error = (error2 / part2).sqrt();
        eprintln!("blocks against bands: rms error {error:.2e} of the rms banded part");
        assert!(error < 0.05, "{error}");
        let top = position.len() - 25;
        let (banded, uniform) = (
            tail.integral(&tail.bands, position[top]),
            tail.integral(&uniform, position[top]),
        );
        assert!(banded.0.y < 0.95 * uniform.0.y, "{banded:?} {uniform:?}");
        assert!(
            net_banded.y.abs() < 0.2 * net_uniform.y.abs(),
            "{net_banded:?} {net_uniform:?}"
        );
    }

    /// The tails are held while every disc stays within MOVE_LIMIT r_c of where it was at
    /// the last refresh, and follow the discs once one goes further.
    #[test]
    fn tails_are_refreshed_when_a_disc_has_moved() {
        let (mut position, discs) = graded_bed();
        let mut tail = Tail::new(0.035);
        let n = position.len();
        let fill = move |out: &mut Vec<_>, f: &(dyn Fn(usize) -> (Vector2<f64>, f64) + Sync)| {
            out.clear();
            out.extend((0..n).map(f));
        };
        tail.update(&position, &discs, fill);
        let first = tail.at(0);
        let step = 0.3 * MOVE_LIMIT * 0.035;
        for k in 1..=4 {
            position[0].x += step;
            tail.update(&position, &discs, fill);
            assert_eq!(tail.at(0) == first, k < 4, "after {k} moves");
        }
    }

    /// The blocks a disc sees cover the bands in order without gaps, keep its own band and
    /// FINE on either side as they are, grow no faster than the distance allows, and carry
    /// the bands' moments.
    #[test]
    fn blocks_cover_the_bands_and_grow_with_distance() {
        let (position, discs) = graded_bed();
        let mut tail = Tail::new(0.005);
        tail.update(&position, &discs, |out, f| {
            out.clear();
            out.extend((0..position.len()).map(f));
        });
        let count = tail.bands.len();
        let height = (tail.region.1.y - tail.region.0.y) / count as f64;
        let moment = |bands: &[Band], top: f64| -> f64 {
            (0..bands.len())
                .map(|b| {
                    let end = bands.get(b + 1).map_or(top, |n| n.low);
                    bands[b].density.0 * (end - bands[b].low)
                })
                .sum()
        };
        let total = moment(&tail.bands, tail.region.1.y);
        for own in [0, 3, count / 2, count - 2, count - 1] {
            let mut blocks = Vec::new();
            tail.blocks_around(own, &mut blocks);
            let blocks = blocks.as_slice();
            assert_eq!(blocks[0].low, tail.region.0.y);
            let mut start = 0;
            for (k, b) in blocks.iter().enumerate() {
                let end = blocks.get(k + 1).map_or(count as f64, |n| {
                    ((n.low - tail.region.0.y) / height).round()
                });
                let (a, z) = (start, end as usize);
                let size = z - a;
                assert!(size >= 1 && ((b.low - tail.region.0.y) / height).round() as usize == a);
                let distance = if a > own { a - own } else { own - (z - 1) };
                assert!(
                    size == 1 || COARSE * size <= distance,
                    "own {own}: [{a}, {z}) at {distance}"
                );
                start = z;
            }
            assert!(
                blocks.len()
                    <= 2 * FINE
                        + 1
                        + 2 * (COARSE + 1) * (usize::BITS - count.leading_zeros()) as usize
            );
            let got = moment(blocks, tail.region.1.y);
            assert!((got - total).abs() < 1e-9 * total, "{got} {total}");
        }
        assert!(count > 100, "{count}");
    }
}
