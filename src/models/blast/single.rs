//! The near-field sum over all pairs (C8) in single precision: an approximation of the exact
//! sum ([`super::all_pairs`]) for the source's exponents β = (1, 2), with an error of order
//! 10⁻⁷–10⁻⁶ of the force (test `single_precision_stays_within_a_millionth_of_the_exact_sum`)
//! at roughly half the exact kernel's cost. The default (`auto`) uses it while the cloud is
//! at most [`EXTENT_LIMIT`] diameters across, where its error has a bound below 10⁻³.
//!
//! Why it is faster: the exact kernel is bound by one square root and one division per pair
//! on four double lanes; here eight (AVX) or sixteen (AVX-512) single lanes share each such
//! instruction and each product, and the divider takes single-precision operands in fewer
//! cycles (the kernels: [`super::single_lanes`]).
//!
//! Why it stays accurate: the positions are taken relative to the centre of the cloud's
//! bounding box and in units of the particle diameter L = 2R, so every quantity in the lanes
//! is of order one at contact; the law's coefficients are scaled to at most one
//! (A_k = α_k / L^k, both divided by the larger) and applied in double precision at the
//! gather, which also sums each particle's tile results in double precision. Every operation
//! is IEEE single precision (square root and division correctly rounded; the sums of
//! squares and the accumulations fused multiply-adds, rounded once, in the lanes and in the
//! portable loop alike), so the AVX and AVX-512 lanes give the portable loop's bits and the
//! result does not depend on the machine or the thread count. Pairs are summed in tiles as in [`crate::numerics::tiled_pairs`]:
//! each unordered pair once (action = reaction within a tile pair), tile results combined in
//! tile order.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::pairs::PairLaw;
use super::single_lanes::{self, Columns, Form, Sums, LANES, TILE};
use crate::numerics::tiled_pairs::{results_of, size_tile_pairs};

/// The largest bounding-box side, in particle diameters, over which `auto` precision uses
/// these lanes. Why 1000: centred coordinates of magnitude ≤ E/2 are rounded within
/// (E/2)·2⁻²⁴, so a separation's error is at most √3·E·2⁻²⁴; a pair term d·(A1/r² − A2/r³)
/// changes by at most 4|δd|/r of its two parts' magnitudes, and the kernel's own rounding
/// (square root, division, products, 128-term tile sums) adds at most about 150·2⁻²⁴. For
/// pairs no closer than half a diameter, the bound relative to the summed magnitudes of a
/// particle's pair terms is 2⁻²⁴(8√3·E + 150) = 8.4·10⁻⁴ at E = 1000: within issue 18's 10⁻³.
pub const EXTENT_LIMIT: f64 = 1000.0;

/// Whether the cloud at `positions` fits within [`EXTENT_LIMIT`] diameters of `law`'s
/// particles along every axis.
pub fn within_extent_limit(law: &PairLaw, positions: &[Vector3<f64>]) -> bool {
    let (low, high) = bounding_box(positions);
    (high - low).max() <= EXTENT_LIMIT * 2.0 * law.radius
}

/// Where the padding points sit (in diameters): far enough that their pull on the cloud is
/// finite and tiny, and it is multiplied by their zero sign anyway.
const FAR: f32 = 1e15;

/// The kernel's buffers, reused between evaluations (no allocation once sized).
#[derive(Debug, Clone, Default)]
pub struct SinglePairs {
    /// Scaled coordinates x, y, z and the charge signs c (0 for padding), padded to LANES.
    at: Columns,
    /// Whether some sign is −1.
    signed: bool,
    /// Scaled coefficients (A1, A2) / max(A1, A2).
    coefficients: (f32, f32),
    pairs: Vec<Sums>,
    tiles: usize,
}

impl SinglePairs {
    /// Near-field force on every particle from all others, written into `out`, N; the law's
    /// exponents must be β = (1, 2) ([`super::all_pairs::AllPairs::applies`]).
    pub fn sum(
        &mut self,
        law: &PairLaw,
        positions: &[Vector3<f64>],
        charge_per_mass: &[f64],
        out: &mut [Vector3<f64>],
    ) {
        let scale = self.load(law, positions, charge_per_mass);
        self.fill(Form::detect());
        self.gather(scale, out);
    }

    /// Loads the scaled coordinates and coefficients; returns the force scale max(A1, A2), N.
    fn load(&mut self, law: &PairLaw, positions: &[Vector3<f64>], charge_per_mass: &[f64]) -> f64 {
        let length = 2.0 * law.radius;
        let (a1, a2) = (law.alpha.0 / length, law.alpha.1 / (length * length));
        let scale = a1.max(a2);
        self.coefficients = if scale > 0.0 {
            ((a1 / scale) as f32, (a2 / scale) as f32)
        } else {
            (0.0, 0.0)
        };
        let centre = bounding_box_centre(positions);
        let padded = positions.len().div_ceil(LANES) * LANES;
        for (c, column) in self.at.iter_mut().enumerate() {
            column.clear();
            column.extend(
                positions
                    .iter()
                    .zip(charge_per_mass)
                    .map(|(p, &q)| match c {
                        3 if law.charge_sign && q < 0.0 => -1.0,
                        3 => 1.0,
                        _ => ((p[c] - centre[c]) / length) as f32,
                    }),
            );
            let fill = if c == 0 { FAR } else { 0.0 };
            column.resize(padded, fill);
        }
        self.signed = self.at[3].contains(&-1.0);
        scale
    }

    /// Evaluates every tile pair, on the rayon pool, with `form` (one the processor runs).
    fn fill(&mut self, form: Form) {
        self.tiles = self.at[0].len().div_ceil(TILE);
        size_tile_pairs(&mut self.pairs, self.tiles);
        let (at, c, signed) = (&self.at, self.coefficients, self.signed);
        (self.pairs.par_iter_mut()).for_each(|pair| single_lanes::fill(form, at, c, signed, pair));
    }

    /// Each particle's force: its sign times the force scale times its tile results summed
    /// in tile order in double precision.
    fn gather(&self, scale: f64, out: &mut [Vector3<f64>]) {
        out.par_iter_mut()
            .enumerate()
            .with_min_len(TILE)
            .for_each(|(p, f)| {
                let mut sum = Vector3::zeros();
                for result in results_of(&self.pairs, self.tiles, p) {
                    sum += Vector3::from(result.map(f64::from));
                }
                *f = (f64::from(self.at[3][p]) * scale) * sum;
            });
    }
}

/// Midpoint of the positions' bounding box (the origin for none).
fn bounding_box_centre(positions: &[Vector3<f64>]) -> Vector3<f64> {
    let (low, high) = bounding_box(positions);
    0.5 * (low + high)
}

/// The positions' lowest and highest corner (the origin twice for none).
fn bounding_box(positions: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let Some(first) = positions.first() else {
        return (Vector3::zeros(), Vector3::zeros());
    };
    positions
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::blast::cloud::Cloud;
    use crate::models::blast::interact::near_field_error;
    use crate::models::blast::params::{BlastParams, NearFieldPrecision};

    /// N points spread through a ball of radius 1 m around `centre` (no two closer than
    /// about a particle diameter), every third charge negative.
    fn cloud(n: usize, centre: Vector3<f64>) -> (Vec<Vector3<f64>>, Vec<f64>) {
        use rand::RngExt;
        let mut rng = crate::rng::run_stream(7, crate::rng::Purpose::Positions);
        let mut points: Vec<Vector3<f64>> = Vec::new();
        while points.len() < n {
            let p = Vector3::from_fn(|_, _| 2.0 * rng.random::<f64>() - 1.0);
            if p.norm() <= 1.0 && points.iter().all(|q| (p - q).norm() >= 0.1) {
                points.push(p);
            }
        }
        let q = (0..n)
            .map(|k| if k % 3 == 0 { -10.0 } else { 10.0 })
            .collect();
        (points.into_iter().map(|p| centre + p).collect(), q)
    }

    /// Against the double-precision exact sum: the largest error and the rms error stay
    /// below 10⁻⁶ of the largest and the rms force (issue 18 asks for 10⁻³), for like and
    /// mixed charges, a cloud at the origin and one 10 km away (the positions are centred
    /// before they are rounded), and a partial last tile.
    #[test]
    fn single_precision_stays_within_a_millionth_of_the_exact_sum() {
        for (charge_sign, offset) in [(false, 0.0), (true, 0.0), (false, 1e4)] {
            let mut p = BlastParams::source_example();
            p.near_field.charge_sign = charge_sign;
            p.near_field.precision = NearFieldPrecision::Single;
            let (positions, q) = cloud(700, Vector3::new(offset, -offset, 0.5 * offset));
            let mut at = Cloud::at_rest(positions, &p);
            at.charge_per_mass = q;
            let (largest, rms) = near_field_error(&p, &at);
            assert!(largest < 1e-6 && rms < 1e-6, "{largest:.2e} {rms:.2e}");
        }
    }

    /// Every form the processor runs (portable, AVX, AVX-512) gives the portable loop's bits,
    /// so a run does not depend on the machine's vector width; for a cloud of like charges the
    /// SIMD forms' shortcut without the signs' products gives the bits of the signed loop. A
    /// cloud of 203 leaves a partial tile and partial lane groups.
    #[test]
    fn every_form_of_the_single_sums_gives_the_same_bits() {
        let law = |charge_sign| {
            let mut p = BlastParams::source_example();
            p.near_field.charge_sign = charge_sign;
            PairLaw::new(&p)
        };
        let (positions, mixed) = cloud(203, Vector3::zeros());
        let like = vec![10.0; positions.len()];
        for (law, q) in [
            (law(true), &mixed),
            (law(false), &mixed),
            (law(true), &like),
        ] {
            let sums = |form, signed: Option<bool>| {
                let mut kernel = SinglePairs::default();
                let scale = kernel.load(&law, &positions, q);
                kernel.signed = signed.unwrap_or(kernel.signed);
                kernel.fill(form);
                let mut out = vec![Vector3::zeros(); positions.len()];
                kernel.gather(scale, &mut out);
                out
            };
            let portable = sums(Form::Portable, None);
            assert!(portable.iter().all(|f| f.norm() > 0.0));
            for form in Form::available() {
                assert_eq!(sums(form, None), portable, "{form:?}");
                assert_eq!(sums(form, Some(true)), portable, "{form:?} signed");
            }
        }
    }
}
