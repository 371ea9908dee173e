//! Pair statistics of 2D particle centres: the radial distribution function g(r) and the
//! contact coordination number.
//!
//! Edge treatment of g(r) (a numerical choice the spec leaves open): only particles at least
//! r_max from every side of the rectangle spanned by the extreme centres serve as reference
//! particles (a guard zone), so every annulus around a reference particle lies wholly inside
//! the sample and needs no correction; the number density is N / (area of that rectangle).
//! This is unbiased for a homogeneous sample and costs statistics when r_max is large.

use nalgebra::Vector2;

use crate::neighbor::NeighborList;
use crate::{Error, Result};

/// g(r) on equal bins of [0, r_max].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RadialDistribution {
    /// Bin centres (m).
    pub r: Vec<f64>,
    /// g at the bin centres (1 for an ideal gas).
    pub g: Vec<f64>,
    /// Number of reference particles (those inside the guard zone).
    pub reference_particles: usize,
    /// Number density used for the normalization (m⁻²).
    pub density: f64,
}

/// Bounding rectangle of the centres (min, max corner).
fn bounds(points: &[Vector2<f64>]) -> (Vector2<f64>, Vector2<f64>) {
    points.iter().fold(
        (
            Vector2::repeat(f64::INFINITY),
            Vector2::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    )
}

/// Checks that every coordinate is finite.
fn check_finite(points: &[Vector2<f64>]) -> Result<()> {
    match points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        Some(i) => Err(Error::input(format!(
            "particle {i} has a non-finite centre ({}, {}); all coordinates must be finite",
            points[i].x, points[i].y
        ))),
        None => Ok(()),
    }
}

/// Checks that a cell grid of cell size `cell` over the centres stays O(N) in memory (the
/// neighbour list's grid is dense): at most 8 N + 10⁶ cells.
fn check_grid(points: &[Vector2<f64>], cell: f64, what: &str) -> Result<()> {
    let (lo, hi) = bounds(points);
    let cells = ((hi.x - lo.x) / cell + 1.0) * ((hi.y - lo.y) / cell + 1.0);
    let limit = 8.0 * points.len() as f64 + 1e6;
    if cells.is_nan() || cells > limit {
        return Err(Error::input(format!(
            "{what}: the length {cell:e} is too small for a sample spanning {:e} × {:e} \
             (a neighbour grid of {cells:.1e} cells, limit {limit:.1e})",
            hi.x - lo.x,
            hi.y - lo.y
        )));
    }
    Ok(())
}

/// Radial distribution function g(r) with `bins` equal bins on [0, r_max] (m), guard-zone
/// edge treatment (see the module documentation).
///
/// # Errors
/// [`Error::Input`] for a non-finite coordinate, r_max ≤ 0, zero bins, a zero-area sample,
/// or no particle farther than r_max from the sample's edges.
pub fn radial_distribution(
    points: &[Vector2<f64>],
    r_max: f64,
    bins: usize,
) -> Result<RadialDistribution> {
    check_finite(points)?;
    if !(r_max.is_finite() && r_max > 0.0) || bins == 0 {
        return Err(Error::input(format!(
            "g(r): r_max = {r_max} and bins = {bins} are not allowed (need r_max > 0, bins ≥ 1)"
        )));
    }
    let (lo, hi) = bounds(points);
    let area = (hi.x - lo.x) * (hi.y - lo.y);
    if area.is_nan() || area <= 0.0 {
        return Err(Error::input(
            "g(r): the particle centres span no area (need a 2D sample)",
        ));
    }
    let reference: Vec<usize> = (0..points.len())
        .filter(|i| {
            let p = points[*i];
            p.x - lo.x >= r_max && hi.x - p.x >= r_max && p.y - lo.y >= r_max && hi.y - p.y >= r_max
        })
        .collect();
    if reference.is_empty() {
        return Err(Error::input(format!(
            "g(r): no particle lies {r_max} or more from the sample's edges; choose a smaller r_max"
        )));
    }
    check_grid(points, r_max, "g(r) r_max")?;
    let mut list = NeighborList::<2>::new(0.0);
    list.build(points, &vec![0.5 * r_max; points.len()]);
    let dr = r_max / bins as f64;
    let mut counts = vec![0usize; bins];
    for &i in &reference {
        for &j in list.of(i) {
            let d = (points[j as usize] - points[i]).norm();
            // The list holds pairs with d < r_max; guard against round-off at the top edge.
            counts[((d / dr) as usize).min(bins - 1)] += 1;
        }
    }
    let density = points.len() as f64 / area;
    let per_ref = reference.len() as f64 * density;
    let r = (0..bins).map(|k| (k as f64 + 0.5) * dr).collect();
    let g = counts
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
            *c as f64 / (per_ref * std::f64::consts::PI * (r1 * r1 - r0 * r0))
        })
        .collect();
    Ok(RadialDistribution {
        r,
        g,
        reference_particles: reference.len(),
        density,
    })
}

/// Contact coordination: for each particle the number of others whose centre is closer than
/// (1 + tolerance)·(d_i + d_j)/2, with diameters d (m) and a relative contact tolerance ≥ 0.
///
/// # Errors
/// [`Error::Input`] for a non-finite coordinate, a diameter that is not finite and > 0, a bad
/// tolerance, or mismatched lengths.
pub fn coordination(
    points: &[Vector2<f64>],
    diameters: &[f64],
    tolerance: f64,
) -> Result<Vec<usize>> {
    check_finite(points)?;
    if diameters.len() != points.len() {
        return Err(Error::input(format!(
            "coordination: {} diameters for {} particles",
            diameters.len(),
            points.len()
        )));
    }
    if let Some(i) = diameters.iter().position(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(Error::input(format!(
            "particle {i} has diameter {}; diameters must be finite and > 0",
            diameters[i]
        )));
    }
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::input(format!(
            "contact tolerance {tolerance} is not allowed (need a finite value ≥ 0)"
        )));
    }
    let radii: Vec<f64> = diameters
        .iter()
        .map(|d| 0.5 * d * (1.0 + tolerance))
        .collect();
    let largest = radii.iter().copied().fold(0.0, f64::max);
    check_grid(
        points,
        2.0 * largest,
        "coordination: largest contact diameter",
    )?;
    let mut list = NeighborList::<2>::new(0.0);
    list.build(points, &radii);
    Ok((0..points.len()).map(|i| list.of(i).len()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::structure::tests::triangular;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn ideal_gas_has_flat_g() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let pts: Vec<_> = (0..20_000)
            .map(|_| Vector2::new(rng.random::<f64>(), rng.random::<f64>()))
            .collect();
        let rdf = radial_distribution(&pts, 0.05, 10).unwrap();
        // Error model: Poisson noise of the pair count in each annulus (doubled, since every
        // pair between two reference particles is counted twice) plus a common factor, the
        // binomial fluctuation of the number of points in the reference region relative to
        // the mean density N / area.
        let n_ref = rdf.reference_particles as f64;
        let p = n_ref / pts.len() as f64;
        let common = ((1.0 - p) / n_ref).sqrt();
        for (r, g) in rdf.r.iter().zip(&rdf.g) {
            let expected_pairs = n_ref * rdf.density * 2.0 * std::f64::consts::PI * r * 0.005;
            let sigma = (2.0 / expected_pairs + common * common).sqrt();
            assert!((g - 1.0).abs() < 4.0 * sigma, "g({r}) = {g}, σ = {sigma}");
        }
    }

    #[test]
    fn triangular_lattice_first_shell() {
        let pts = triangular(30, 30, 1.0);
        let rdf = radial_distribution(&pts, 1.5, 30).unwrap();
        // Nothing below the spacing; the integral ρ ∫ 2πr g dr up to 1.5 a counts the 6
        // nearest neighbours (next shell at √3 a).
        let dr = 1.5 / 30.0;
        for (r, g) in rdf.r.iter().zip(&rdf.g) {
            if *r < 0.95 {
                assert_eq!(*g, 0.0);
            }
        }
        let n: f64 = rdf
            .r
            .iter()
            .zip(&rdf.g)
            .map(|(r, g)| {
                let (r0, r1) = (r - dr / 2.0, r + dr / 2.0);
                rdf.density * std::f64::consts::PI * (r1 * r1 - r0 * r0) * g
            })
            .sum();
        assert!((n - 6.0).abs() < 1e-9, "{n}");
        let z = coordination(&pts, &vec![1.0; pts.len()], 1e-6).unwrap();
        assert_eq!(z[15 * 30 + 15], 6);
        assert_eq!(z[0], 2);
    }

    #[test]
    fn bad_input_is_an_error() {
        let pts = triangular(5, 5, 1.0);
        assert!(radial_distribution(&pts, 10.0, 10).is_err());
        assert!(radial_distribution(&pts, -1.0, 10).is_err());
        assert!(radial_distribution(&pts[..3], 0.1, 10).is_err());
        assert!(coordination(&pts, &[1.0], 0.0).is_err());
        assert!(coordination(&pts, &[f64::NAN; 25], 0.0).is_err());
        // Tiny lengths against the sample extent would need a huge dense grid: refused.
        assert!(coordination(&pts, &[1e-12; 25], 0.0).is_err());
        assert!(radial_distribution(&triangular(40, 40, 1.0), 1e-9, 10).is_err());
    }
}
