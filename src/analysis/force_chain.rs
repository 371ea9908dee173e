//! Force-chain measures of a 2D snapshot with force vectors: whether the forces share a
//! direction and whether large and small forces cluster in space. de Paula 2025 (§4.3.6,
//! Figs. 4.23–4.24) judges both by eye ("no preferred direction", "no pattern on the
//! colouring"); these two numbers put that judgement on a scale. A force chain is a line of
//! particles carrying more than the mean along one axis: it raises both.

use nalgebra::Vector2;

use super::voronoi::Cell;

/// Direction and clustering of the particle forces over the counted cells.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ForceChainMetrics {
    /// S = |⟨exp(2iθ_k)⟩| over the counted particles with a non-zero force, θ_k the force's
    /// angle: 0 for directions spread evenly over the half-turn, 1 when every force lies
    /// along one axis (either sense).
    pub direction_order: f64,
    /// The axis of that order, degrees from +x in (−90, 90].
    pub direction_axis_deg: f64,
    /// Pearson r of the relative fluctuation |F − F̄_s|/F̄_s (Eq. (4.35)) between Voronoi
    /// neighbours, both counted (each neighbour pair once in each order): near 0 when the
    /// fluctuations have no spatial pattern, towards 1 when large forces sit next to large
    /// ones; NaN with fewer than two pairs or constant values.
    pub fluctuation_neighbor_correlation: f64,
    /// Neighbour pairs in that correlation.
    pub neighbor_pairs: usize,
    /// The same r over the neighbour pairs whose bond lies within 45° of the direction axis:
    /// a chain along the forces raises this one.
    pub correlation_along_axis: f64,
    /// The same r over the bonds more than 45° from the axis: layers across the forces (rows
    /// of like forces) raise this one.
    pub correlation_across_axis: f64,
}

/// The measures for forces `force` and relative fluctuations `fluctuation` of the particles at
/// `position` on `cells` (one per particle, with their counted flags and Voronoi neighbours).
pub fn force_chain_metrics(
    position: &[Vector2<f64>],
    force: &[Vector2<f64>],
    fluctuation: &[f64],
    cells: &[Cell],
) -> ForceChainMetrics {
    let counted = |k: usize| cells[k].counted;
    let (mut c, mut s) = (0.0, 0.0);
    let mut n = 0usize;
    for (k, f) in force.iter().enumerate() {
        if counted(k) && f.norm_squared() > 0.0 {
            let theta = f.y.atan2(f.x);
            c += (2.0 * theta).cos();
            s += (2.0 * theta).sin();
            n += 1;
        }
    }
    let (c, s) = (c / n.max(1) as f64, s / n.max(1) as f64);
    let axis_angle = 0.5 * s.atan2(c);
    let axis = Vector2::new(axis_angle.cos(), axis_angle.sin());
    let (mut along, mut across) = (Vec::new(), Vec::new());
    for (i, cell) in cells.iter().enumerate() {
        for &j in &cell.neighbors {
            let j = j as usize;
            let (a, b) = (fluctuation[i], fluctuation[j]);
            if counted(i) && counted(j) && a.is_finite() && b.is_finite() {
                let bond = (position[j] - position[i]).normalize();
                // |cos| ≥ cos 45°: the bond is within 45° of the axis
                if bond.dot(&axis).abs() >= std::f64::consts::FRAC_1_SQRT_2 {
                    along.push((a, b));
                } else {
                    across.push((a, b));
                }
            }
        }
    }
    let all: Vec<(f64, f64)> = along.iter().chain(&across).copied().collect();
    ForceChainMetrics {
        direction_order: (c * c + s * s).sqrt(),
        direction_axis_deg: axis_angle.to_degrees(),
        fluctuation_neighbor_correlation: correlation(&all),
        neighbor_pairs: all.len(),
        correlation_along_axis: correlation(&along),
        correlation_across_axis: correlation(&across),
    }
}

/// Pearson r of the pairs (NaN below two pairs or for a constant series).
fn correlation(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    let mean = |f: fn(&(f64, f64)) -> f64| pairs.iter().map(f).sum::<f64>() / n;
    let (ma, mb) = (mean(|p| p.0), mean(|p| p.1));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (a, b) in pairs {
        sab += (a - ma) * (b - mb);
        saa += (a - ma) * (a - ma);
        sbb += (b - mb) * (b - mb);
    }
    if pairs.len() < 2 || saa == 0.0 || sbb == 0.0 {
        return f64::NAN;
    }
    sab / (saa * sbb).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::structure::analyze_full;
    use crate::analysis::voronoi::TessellationSettings;

    /// A triangular lattice of `side` × `side` points, spacing 1.
    fn lattice(side: usize) -> Vec<Vector2<f64>> {
        (0..side * side)
            .map(|k| {
                let (i, j) = ((k % side) as f64, (k / side) as f64);
                Vector2::new(i + 0.5 * (j % 2.0), j * 3f64.sqrt() / 2.0)
            })
            .collect()
    }

    fn cells(points: &[Vector2<f64>]) -> Vec<Cell> {
        analyze_full(points, &TessellationSettings::default())
            .unwrap()
            .tessellation
            .cells
    }

    #[test]
    fn forces_along_one_axis_are_fully_ordered_and_a_cross_is_not() {
        let p = lattice(12);
        let cells = cells(&p);
        let fl = vec![0.0; p.len()];
        // either sense along the axis at 30°: order 1, axis 30°
        let axis = Vector2::new(30f64.to_radians().cos(), 30f64.to_radians().sin());
        let along: Vec<_> = (0..p.len())
            .map(|k| if k % 2 == 0 { axis } else { -2.0 * axis })
            .collect();
        let m = force_chain_metrics(&p, &along, &fl, &cells);
        assert!((m.direction_order - 1.0).abs() < 1e-12);
        assert!((m.direction_axis_deg - 30.0).abs() < 1e-9);
        // four perpendicular directions in turn: no order
        let cross: Vec<_> = (0..p.len())
            .map(|k| {
                let t = k as f64 * std::f64::consts::FRAC_PI_2;
                Vector2::new(t.cos(), t.sin())
            })
            .collect();
        let counted = (0..p.len()).filter(|&k| cells[k].counted).count();
        let m = force_chain_metrics(&p, &cross, &fl, &cells);
        // the counted set need not hold the four directions equally: at most 3 left over
        assert!(m.direction_order <= 3.0 / counted as f64 + 1e-12);
    }

    #[test]
    fn a_smooth_fluctuation_field_correlates_and_a_random_one_does_not() {
        let p = lattice(30);
        let cells = cells(&p);
        let f = vec![Vector2::x(); p.len()];
        let smooth: Vec<f64> = p.iter().map(|q| q.x / 30.0).collect();
        let m = force_chain_metrics(&p, &f, &smooth, &cells);
        assert!(m.fluctuation_neighbor_correlation > 0.95, "{m:?}");
        // independent uniform values (SplitMix64 of the index)
        let random: Vec<f64> = (0..p.len() as u64)
            .map(|k| {
                let mut z = (k + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                (z ^ (z >> 31)) as f64 / u64::MAX as f64
            })
            .collect();
        let m = force_chain_metrics(&p, &f, &random, &cells);
        // ~ 1/√(independent pairs): a few hundred particles give |r| well below 0.15
        assert!(m.fluctuation_neighbor_correlation.abs() < 0.15, "{m:?}");
        assert!(m.neighbor_pairs > 2000);
    }

    /// Rows of like fluctuations across vertical forces correlate across the axis, and
    /// columns of them along it (the first is layering, the second a chain).
    #[test]
    fn rows_and_columns_are_told_apart() {
        let p = lattice(30);
        let cells = cells(&p);
        let up = vec![Vector2::y(); p.len()];
        let by_row: Vec<f64> = p.iter().map(|q| (q.y * 1.7).sin()).collect();
        let m = force_chain_metrics(&p, &up, &by_row, &cells);
        assert!(m.correlation_across_axis > 0.99, "{m:?}");
        let by_column: Vec<f64> = p.iter().map(|q| (q.x * 1.7).sin()).collect();
        let m = force_chain_metrics(&p, &up, &by_column, &cells);
        assert!(
            m.correlation_along_axis > m.correlation_across_axis + 0.5,
            "{m:?}"
        );
    }
}
