//! `magopt bench analyze`: the 2D structure analysis on jittered triangular lattices.

use nalgebra::Vector2;
use rand::{RngExt, SeedableRng};
use serde_json::json;
use std::time::Instant;

use super::{counts, BenchArgs};
use crate::Result;

/// `magopt bench analyze`: wall time of `structure::analyze` (tessellation, side counts, Ψ6,
/// regularity) on a triangular lattice with 10 % jitter, best of three runs.
pub(super) fn run(args: &BenchArgs) -> Result<Vec<serde_json::Value>> {
    println!("analyze: triangular lattice, uniform jitter ±0.1 spacing, best of 3 runs");
    println!(
        "{:>9} {:>13} {:>8} {:>13}",
        "points", "cells counted", "n6", "analyze (s)"
    );
    let mut rows = Vec::new();
    for n in counts("points", Some(&args.points), &[])? {
        let side = (n as f64).sqrt().ceil() as usize;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let points: Vec<Vector2<f64>> = (0..n)
            .map(|k| {
                let (r, c) = ((k / side) as f64, (k % side) as f64);
                let jitter = Vector2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                Vector2::new(c + 0.5 * (r % 2.0), r * 0.75f64.sqrt()) + 0.2 * jitter
            })
            .collect();
        let mut best = f64::INFINITY;
        let mut metrics = None;
        for _ in 0..3 {
            let started = Instant::now();
            metrics = Some(crate::analysis::structure::analyze(&points)?);
            best = best.min(started.elapsed().as_secs_f64());
        }
        let m = metrics.expect("three runs");
        println!("{n:>9} {:>13} {:>8.4} {best:>13.3}", m.cells_counted, m.n6);
        rows.push(
            json!({"points": n, "cells_counted": m.cells_counted, "n6": m.n6, "analyze_s": best}),
        );
    }
    Ok(rows)
}
