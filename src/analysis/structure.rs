//! Order metrics of a 2D packing (spec analysis.md, "2D structure"): Voronoi side-count
//! fractions n5/n6/n7 and histogram, hexagon regularity, bond-orientational order Ψ6.
//!
//! Conventions:
//! - only counted cells (bounded, every corner inside the rectangle spanned by the extreme
//!   centres: the source's border rule) enter the fractions, the histogram, the regularity and
//!   the global Ψ6, so that all of them describe the same interior population;
//! - n5 lumps all cells with ≤ 5 sides and n7 all with ≥ 7; `side_histogram` has every count;
//! - ψ6 of particle i is (1/n_i) Σ_j exp(6 i θ_ij) over its Voronoi neighbours j (the spec's
//!   definition); `psi6_weighted` also reports the variant weighted by the shared Voronoi side
//!   length (Mickel et al. 2013), which is continuous under small displacements: on a square
//!   lattice with jitter the plain definition stays near 0.13 (the arbitrary Delaunay
//!   diagonals count as full bonds; it is ≤ 1/3 per particle), the weighted one goes to 0.

use std::collections::BTreeMap;

use nalgebra::Vector2;

use super::voronoi::{tessellate_with, Cell, Tessellation, TessellationSettings};
use crate::numerics::stats::Stats;
use crate::Result;

/// Global order metrics of one snapshot.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StructureMetrics {
    /// Number of particle centres analysed.
    pub particles: usize,
    /// Cells passing the border rule (the population of every other field).
    pub cells_counted: usize,
    /// Fraction of counted cells with ≤ 5 sides (NaN if none counted).
    pub n5: f64,
    /// Fraction of counted cells with exactly 6 sides.
    pub n6: f64,
    /// Fraction of counted cells with ≥ 7 sides.
    pub n7: f64,
    /// Number of counted cells per side count.
    pub side_histogram: BTreeMap<usize, usize>,
    /// Ψ6 = ⟨|ψ6_i|⟩ over counted cells (spec definition; 1 on a triangular lattice).
    pub psi6: f64,
    /// ⟨|ψ6_i|⟩ with bonds weighted by their Voronoi side length, over counted cells.
    pub psi6_weighted: f64,
    /// Ψ6 = ⟨|ψ6_i|⟩ over every particle, border cells included (de Paula 2025, Eq. (4.28)
    /// averages "over all particles").
    pub psi6_all: f64,
    /// Mean regularity R = (4/√3) A / Σ ℓ_k² over counted six-sided cells.
    pub hexagon_regularity_mean: f64,
    /// Sample standard deviation of R over counted six-sided cells (NaN below two).
    pub hexagon_regularity_std: f64,
    /// Counted six-sided cells.
    pub hexagons: usize,
}

/// Per-particle order data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleOrder {
    /// Local ψ6 = (1/n_i) Σ_j exp(6 i θ_ij) as (real, imaginary).
    pub psi6: (f64, f64),
    /// Side-length-weighted local ψ6; NaN for an unbounded cell.
    pub psi6_weighted: (f64, f64),
}

/// Full structure analysis: metrics, cells and per-particle order.
#[derive(Debug, Clone)]
pub struct Structure {
    /// Global metrics.
    pub metrics: StructureMetrics,
    /// Voronoi cells (one per particle, input order).
    pub tessellation: Tessellation,
    /// Per-particle order (input order).
    pub order: Vec<ParticleOrder>,
}

/// Global order metrics of the particle centres, default settings. This is the call for a
/// model that wants n5/n6/n7, Ψ6 and the hexagon regularity of a snapshot.
///
/// # Errors
/// [`crate::Error::Input`] for fewer than 3 points, a non-finite coordinate, duplicate
/// centres, or all centres on one line.
pub fn analyze(points: &[Vector2<f64>]) -> Result<StructureMetrics> {
    Ok(analyze_full(points, &TessellationSettings::default())?.metrics)
}

/// Full analysis with explicit tessellation settings (cells and per-particle data for tables
/// and pictures).
///
/// # Errors
/// As [`analyze`], plus a bad merge tolerance.
pub fn analyze_full(points: &[Vector2<f64>], settings: &TessellationSettings) -> Result<Structure> {
    let tessellation = tessellate_with(points, settings)?;
    let order: Vec<ParticleOrder> = tessellation
        .cells
        .iter()
        .enumerate()
        .map(|(i, cell)| particle_order(points, i, cell))
        .collect();
    let metrics = metrics(points.len(), &tessellation.cells, &order);
    Ok(Structure {
        metrics,
        tessellation,
        order,
    })
}

/// exp(6 i θ) of the bond from `a` to `b`, as (cos 6θ, sin 6θ).
fn hexatic_phase(a: &Vector2<f64>, b: &Vector2<f64>) -> (f64, f64) {
    let d = b - a;
    let theta = d.y.atan2(d.x);
    ((6.0 * theta).cos(), (6.0 * theta).sin())
}

/// Local ψ6 of particle i, plain and side-length weighted.
fn particle_order(points: &[Vector2<f64>], i: usize, cell: &Cell) -> ParticleOrder {
    let n = cell.neighbors.len() as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for &j in &cell.neighbors {
        let (c, s) = hexatic_phase(&points[i], &points[j as usize]);
        re += c;
        im += s;
    }
    let weighted = if cell.bounded {
        let lengths = cell.side_lengths();
        let total: f64 = lengths.iter().sum();
        let (mut wr, mut wi) = (0.0, 0.0);
        for (&j, l) in cell.neighbors.iter().zip(&lengths) {
            let (c, s) = hexatic_phase(&points[i], &points[j as usize]);
            wr += l * c;
            wi += l * s;
        }
        (wr / total, wi / total)
    } else {
        (f64::NAN, f64::NAN)
    };
    ParticleOrder {
        psi6: (re / n, im / n),
        psi6_weighted: weighted,
    }
}

/// Magnitude of a complex number given as (re, im).
pub(crate) fn modulus(z: (f64, f64)) -> f64 {
    z.0.hypot(z.1)
}

/// Global metrics over the counted cells.
fn metrics(particles: usize, cells: &[Cell], order: &[ParticleOrder]) -> StructureMetrics {
    let counted: Vec<usize> = (0..cells.len()).filter(|i| cells[*i].counted).collect();
    let mut side_histogram = BTreeMap::new();
    for &i in &counted {
        *side_histogram.entry(cells[i].sides()).or_insert(0) += 1;
    }
    let total = counted.len() as f64;
    let fraction = |keep: &dyn Fn(usize) -> bool| {
        let cells: usize = side_histogram
            .iter()
            .filter(|(s, _)| keep(**s))
            .map(|(_, c)| *c)
            .sum();
        cells as f64 / total
    };
    let hexagon_r = Stats::of(
        counted
            .iter()
            .filter(|i| cells[**i].sides() == 6)
            .map(|i| cells[*i].regularity()),
    );
    let mean_of = |f: &dyn Fn(&ParticleOrder) -> f64| {
        counted.iter().map(|i| f(&order[*i])).sum::<f64>() / total
    };
    StructureMetrics {
        particles,
        cells_counted: counted.len(),
        n5: fraction(&|s| s <= 5),
        n6: fraction(&|s| s == 6),
        n7: fraction(&|s| s >= 7),
        psi6: mean_of(&|o| modulus(o.psi6)),
        psi6_weighted: mean_of(&|o| modulus(o.psi6_weighted)),
        psi6_all: order.iter().map(|o| modulus(o.psi6)).sum::<f64>() / order.len() as f64,
        hexagon_regularity_mean: hexagon_r.mean,
        hexagon_regularity_std: hexagon_r.std,
        hexagons: hexagon_r.count,
        side_histogram,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A triangular lattice of `rows` × `cols` with spacing `a` (rows along x, odd rows
    /// shifted by a/2).
    pub(crate) fn triangular(rows: usize, cols: usize, a: f64) -> Vec<Vector2<f64>> {
        let h = a * 3f64.sqrt() / 2.0;
        (0..rows)
            .flat_map(|r| {
                (0..cols).map(move |c| {
                    let shift = if r % 2 == 1 { 0.5 * a } else { 0.0 };
                    Vector2::new(c as f64 * a + shift, r as f64 * h)
                })
            })
            .collect()
    }

    #[test]
    fn triangular_lattice_is_perfectly_ordered() {
        let pts = triangular(20, 20, 1.0);
        let s = analyze_full(&pts, &TessellationSettings::default()).unwrap();
        let m = &s.metrics;
        // Interior: rows 1..19 minus the cells touching the zig-zag sides.
        assert!(m.cells_counted > 250, "{m:?}");
        assert_eq!(m.n6, 1.0);
        assert_eq!((m.n5, m.n7), (0.0, 0.0));
        assert!((m.psi6 - 1.0).abs() < 1e-12, "{}", m.psi6);
        assert!((m.psi6_weighted - 1.0).abs() < 1e-12);
        assert!((m.hexagon_regularity_mean - 1.0).abs() < 1e-12);
        assert!(m.hexagon_regularity_std < 1e-12);
        // Every counted cell is a regular hexagon of area (√3/2) a².
        for c in s.tessellation.cells.iter().filter(|c| c.counted) {
            assert!((c.area() - 3f64.sqrt() / 2.0).abs() < 1e-12);
        }
        // Over every particle the border (fewer, one-sided neighbours) lowers Ψ6 below 1.
        let all = s.order.iter().map(|o| modulus(o.psi6)).sum::<f64>() / 400.0;
        assert_eq!(m.psi6_all, all);
        assert!(m.psi6_all > 0.5 && m.psi6_all < 0.99, "{}", m.psi6_all);
    }

    #[test]
    fn perfect_square_lattice_has_square_cells() {
        let pts: Vec<_> = (0..15 * 15)
            .map(|k| Vector2::new((k % 15) as f64, (k / 15) as f64))
            .collect();
        let m = analyze(&pts).unwrap();
        // Co-circular quadruples: the arbitrary diagonal is merged away, every cell has 4 sides.
        assert_eq!(
            m.side_histogram.keys().copied().collect::<Vec<_>>(),
            vec![4]
        );
        assert_eq!(m.n5, 1.0);
        assert!(m.psi6 < 1e-12 && m.psi6_weighted < 1e-12, "{m:?}");
    }
}
