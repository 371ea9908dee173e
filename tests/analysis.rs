//! The analysis toolbox at model level: lattices with known order, invariance of the Voronoi
//! analysis under translation, rotation and point order, degenerate input, and the
//! `magopt analyze` command (output, JSON, errors with exit code 2).

mod common;
use common::magopt;

use magopt::analysis::structure::{analyze, analyze_full};
use magopt::analysis::voronoi::TessellationSettings;
use magopt::Error;
use nalgebra::Vector2;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use std::path::PathBuf;

fn triangular(rows: usize, cols: usize, a: f64) -> Vec<Vector2<f64>> {
    let h = a * 3f64.sqrt() / 2.0;
    (0..rows * cols)
        .map(|k| {
            let (r, c) = (k / cols, k % cols);
            let shift = if r % 2 == 1 { 0.5 * a } else { 0.0 };
            Vector2::new(c as f64 * a + shift, r as f64 * h)
        })
        .collect()
}

/// A square lattice of spacing 1 with uniform jitter of ± `jitter` on each coordinate.
fn jittered_square(n: usize, jitter: f64, seed: u64) -> Vec<Vector2<f64>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n * n)
        .map(|k| {
            let dx = jitter * (2.0 * rng.random::<f64>() - 1.0);
            let dy = jitter * (2.0 * rng.random::<f64>() - 1.0);
            Vector2::new((k % n) as f64 + dx, (k / n) as f64 + dy)
        })
        .collect()
}

#[test]
fn triangular_lattice_in_metres_turned_and_shifted() {
    // 0.5 mm spacing, turned by 90° and shifted. (The border rule assumes a sample aligned
    // with the axes: in a lattice turned by an odd angle, the five-sided cells along its hull
    // have every corner inside the axis-aligned rectangle of the centres and are counted.)
    let pts: Vec<_> = triangular(24, 24, 5e-4)
        .iter()
        .map(|p| Vector2::new(-p.y + 0.3, p.x - 0.1))
        .collect();
    let m = analyze(&pts).unwrap();
    assert!(m.cells_counted > 200, "{m:?}");
    assert_eq!((m.n5, m.n6, m.n7), (0.0, 1.0, 0.0));
    assert!((m.psi6 - 1.0).abs() < 1e-9);
    assert!((m.hexagon_regularity_mean - 1.0).abs() < 1e-9);
}

#[test]
fn jittered_square_lattice_has_little_hexatic_order() {
    let pts = jittered_square(30, 1e-3, 5);
    let s = analyze_full(&pts, &TessellationSettings::default()).unwrap();
    // The plain definition counts the arbitrary Delaunay diagonals as full bonds: with four
    // lattice bonds (Σ e^{6iθ} = 0) and k diagonals each ±i, |ψ6| ≤ 2/6 per particle.
    for (o, c) in s.order.iter().zip(&s.tessellation.cells) {
        if c.counted {
            assert!(o.psi6.0.hypot(o.psi6.1) <= 1.0 / 3.0 + 1e-2);
        }
    }
    let m = &s.metrics;
    assert!(m.psi6 < 0.2, "{}", m.psi6);
    // Weighted by side length, the diagonals (sides of length ~ jitter) drop out: Ψ6 = O(jitter).
    assert!(m.psi6_weighted < 10.0 * 1e-3, "{}", m.psi6_weighted);
    // Side counts are topological and see the tiny diagonal sides as sides: most cells have
    // 5–7. Merging sides below 1 % of the bond length recovers the squares.
    assert!(m.n6 > 0.2, "{m:?}");
    let merged = TessellationSettings {
        merge_tolerance: 1e-2,
    };
    let m = analyze_full(&pts, &merged).unwrap().metrics;
    assert_eq!(
        m.side_histogram.keys().copied().collect::<Vec<_>>(),
        vec![4]
    );
    assert!(m.psi6 < 10.0 * 1e-3, "{}", m.psi6);
}

#[test]
fn poisson_voronoi_side_distribution() {
    // Cells of uniformly random points (Poisson–Voronoi): p6 = 0.29470, p5 = 0.25938,
    // p4 = 0.10705, p3 = 0.01124 (Hinde & Miles 1980; Calka 2003), so n5 = 0.37767, and the
    // mean side count is 6 (Euler). Error model: binomial, √(p(1 − p)/cells) ≈ 0.0023 at
    // 40 000 cells; neighbouring cells are correlated (Aboav–Weaire), hence 5σ.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let pts: Vec<_> = (0..40_000)
        .map(|_| Vector2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let m = analyze(&pts).unwrap();
    let cells = m.cells_counted as f64;
    for (got, p) in [(m.n6, 0.29470), (m.n5, 0.37767)] {
        let sigma = (p * (1.0 - p) / cells).sqrt();
        assert!((got - p).abs() < 5.0 * sigma, "{got} vs {p} (σ = {sigma})");
    }
    let mean_sides = m
        .side_histogram
        .iter()
        .map(|(s, c)| (s * c) as f64)
        .sum::<f64>()
        / cells;
    assert!((mean_sides - 6.0).abs() < 0.02, "{mean_sides}");
}

#[test]
fn degenerate_input_is_an_input_error() {
    let line: Vec<_> = (0..10)
        .map(|k| Vector2::new(k as f64, 2.0 * k as f64))
        .collect();
    let mut dup = triangular(5, 5, 1.0);
    dup.push(dup[7]);
    let mut nan = triangular(5, 5, 1.0);
    nan[3].y = f64::NAN;
    let cases: [(&[Vector2<f64>], &str); 5] = [
        (&line, "one line"),
        (&dup, "duplicates"),
        (&nan, "non-finite"),
        (&line[..2], "at least 3"),
        (&[Vector2::new(1.0, 1.0); 4], "coincide"),
    ];
    for (pts, needle) in cases {
        match analyze(pts) {
            Err(Error::Input(msg)) => assert!(msg.contains(needle), "{msg}"),
            other => panic!("expected an input error containing '{needle}', got {other:?}"),
        }
    }
}

/// Per-particle data that do not depend on the frame: side count, bounded flag, |ψ6|, R.
fn local_data(pts: &[Vector2<f64>]) -> Vec<(usize, bool, f64, f64)> {
    let s = analyze_full(pts, &TessellationSettings::default()).unwrap();
    s.tessellation
        .cells
        .iter()
        .zip(&s.order)
        .map(|(c, o)| {
            (
                c.sides(),
                c.bounded,
                o.psi6.0.hypot(o.psi6.1),
                c.regularity(),
            )
        })
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() < 1e-9
}

fn random_points(seed: u64, n: usize) -> Vec<Vector2<f64>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| Vector2::new(rng.random::<f64>() * 3.0, rng.random::<f64>()))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn invariant_under_translation_rotation_and_order(
        seed in 0u64..1_000_000,
        n in 20usize..300,
        shift in (-10.0f64..10.0, -10.0f64..10.0),
        angle in 0.0f64..std::f64::consts::TAU,
        quarter in 1usize..4,
    ) {
        let pts = random_points(seed, n);
        let base = analyze(&pts).unwrap();
        let local = local_data(&pts);
        // Translation and quarter turns keep the border rectangle: identical metrics.
        let moved: Vec<_> = pts.iter().map(|p| p + Vector2::new(shift.0, shift.1)).collect();
        let turned: Vec<_> = pts
            .iter()
            .map(|p| (0..quarter).fold(*p, |q, _| Vector2::new(-q.y, q.x)))
            .collect();
        for other in [analyze(&moved).unwrap(), analyze(&turned).unwrap()] {
            prop_assert_eq!(&other.side_histogram, &base.side_histogram);
            prop_assert_eq!(other.cells_counted, base.cells_counted);
            prop_assert!(close(other.psi6, base.psi6) && close(other.n6, base.n6));
            prop_assert!(close(other.hexagon_regularity_mean, base.hexagon_regularity_mean));
        }
        // Any rotation: every cell keeps its sides, boundedness, |ψ6| and regularity (which
        // cells pass the border rule depends on the axis-aligned rectangle, so not compared).
        let (c, s) = (angle.cos(), angle.sin());
        let rotated: Vec<_> = pts.iter().map(|p| Vector2::new(c * p.x - s * p.y, s * p.x + c * p.y)).collect();
        for (a, b) in local.iter().zip(local_data(&rotated)) {
            prop_assert!(a.0 == b.0 && a.1 == b.1 && close(a.2, b.2) && close(a.3, b.3));
        }
        // Point order: a permutation permutes the cells and leaves the metrics unchanged.
        let mut perm: Vec<usize> = (0..n).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xabc);
        for i in (1..n).rev() {
            perm.swap(i, rng.random_range(0..=i));
        }
        let shuffled: Vec<_> = perm.iter().map(|i| pts[*i]).collect();
        let other = analyze(&shuffled).unwrap();
        prop_assert_eq!(&other.side_histogram, &base.side_histogram);
        prop_assert!(close(other.psi6, base.psi6));
        let shuffled_local = local_data(&shuffled);
        for (k, i) in perm.iter().enumerate() {
            let (a, b) = (&local[*i], &shuffled_local[k]);
            prop_assert!(a.0 == b.0 && a.1 == b.1 && close(a.2, b.2) && close(a.3, b.3));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Whatever the centres (duplicates, lines, extreme or non-finite values), the analysis
    /// returns metrics or an input error, never panics.
    #[test]
    fn never_panics(points in prop::collection::vec(
        (prop_oneof![
            4 => (-3i32..3).prop_map(f64::from),
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(1e308),
            1 => Just(-1e308),
            1 => Just(1e-300),
            2 => -1e6f64..1e6,
        ], -3i32..3),
        0..40,
    )) {
        let pts: Vec<_> = points.iter().map(|(x, y)| Vector2::new(*x, f64::from(*y))).collect();
        match analyze(&pts) {
            Ok(m) => prop_assert!(m.cells_counted <= pts.len()),
            Err(e) => prop_assert!(matches!(e, Error::Input(_)), "{e:?}"),
        }
    }
}

// ---- the command ----

fn data(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
        .display()
        .to_string()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-analysis-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn analyze_command_json_and_outputs() {
    let (code, stdout, stderr) = magopt(&["analyze", &data("triangular.csv"), "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["n6"], 1.0);
    assert_eq!(v["n5"], 0.0);
    assert_eq!(v["cells_counted"], 100);
    assert_eq!(v["side_histogram"]["6"], 100);
    assert!((v["psi6"].as_f64().unwrap() - 1.0).abs() < 1e-9);
    assert!((v["hexagon_regularity_mean"].as_f64().unwrap() - 1.0).abs() < 1e-9);
    assert_eq!(v["coordination_mean"], 6.0);

    let dir = temp_dir("out");
    let out = dir.join("result");
    let (code, stdout, stderr) = magopt(&[
        "analyze",
        &data("jittered.csv"),
        "--out",
        out.to_str().unwrap(),
        "--rdf-max",
        "3mm",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("n6 = "), "{stdout}");
    for f in [
        "summary.json",
        "cells.parquet",
        "cell_vertices.parquet",
        "particles.parquet",
        "cells.png",
        "force_pdf.parquet",
        "forces.png",
        "force_pdf.png",
        "fluctuations.png",
        "rdf.parquet",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let particles = magopt::output::table::read_parquet(&out.join("particles.parquet")).unwrap();
    assert_eq!(particles.n_rows(), 400);
    assert!(particles.column("relative_fluctuation").is_some());
    // The tables agree with the summary.
    let cells = magopt::output::table::read_parquet(&out.join("cells.parquet")).unwrap();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let Some(magopt::output::table::ColumnData::Bool(counted)) = cells.column("counted") else {
        panic!("no counted column")
    };
    let n_counted = counted.iter().filter(|c| **c).count();
    assert_eq!(summary["cells_counted"].as_u64(), Some(n_counted as u64));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn analyze_command_reads_the_bed_parquet_contract() {
    use magopt::output::table::{write_parquet, ColumnData, Table};
    let pts = triangular(12, 12, 1e-3);
    let n = pts.len();
    let table = Table::new()
        .with("x", ColumnData::F64(pts.iter().map(|p| p.x).collect()))
        .with("y", ColumnData::F64(pts.iter().map(|p| p.y).collect()))
        .with("diameter", ColumnData::F64(vec![1e-3; n]))
        .with(
            "species",
            ColumnData::I64((0..n as i64).map(|i| i % 2).collect()),
        )
        .with("vx", ColumnData::F64(vec![0.0; n]))
        .with("vy", ColumnData::F64(vec![0.0; n]))
        .with(
            "force",
            ColumnData::F64((0..n).map(|i| 1.0 + (i % 7) as f64).collect()),
        );
    let dir = temp_dir("parquet");
    let file = dir.join("snapshot.parquet");
    write_parquet(&file, &table).unwrap();
    let (code, stdout, stderr) = magopt(&["analyze", file.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(
        (v["n6"].as_f64(), v["cells_counted"].as_u64()),
        (Some(1.0), Some(100))
    );
    assert_eq!(v["forces"].as_array().unwrap().len(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn analyze_command_bad_input_exits_2_with_one_line() {
    let dir = temp_dir("bad");
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let cases = [
        (
            write("noy.csv", "x,z\n0,0\n1,0\n0,1\n"),
            "missing column 'y'",
        ),
        (write("line.csv", "x,y\n0,0\n1,1\n2,2\n3,3\n"), "one line"),
        (write("dup.csv", "x,y\n0,0\n1,0\n0,1\n1,0\n"), "duplicates"),
        (write("garbage.parquet", "not parquet"), "garbage.parquet"),
        (dir.join("missing.csv").display().to_string(), "missing.csv"),
        (
            write("species.csv", "x,y,species\n0,0,a\n1,0,b\n0,1,c\n"),
            "species",
        ),
    ];
    for (file, needle) in cases {
        let (code, stdout, stderr) = magopt(&["analyze", &file]);
        assert_eq!(code, 2, "{file}: {stdout}{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(needle), "{file}: {stderr}");
    }
    let (code, _, stderr) = magopt(&["analyze", &data("triangular.csv"), "--rdf-max", "-1mm"]);
    assert_eq!(code, 2, "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A force vector (`force_x`, `force_y`) gives the magnitudes, the force-chain measures and the
/// arrow map; all forces along one axis are fully ordered (S = 1); half a vector is an input
/// error.
#[test]
fn analyze_command_reads_force_vectors() {
    use magopt::output::table::{write_parquet, ColumnData, Table};
    let pts = triangular(12, 12, 1e-3);
    let n = pts.len();
    let fx: Vec<f64> = (0..n)
        .map(|i| if i % 2 == 0 { 3.0 } else { -4.0 })
        .collect();
    let table = Table::new()
        .with("x", ColumnData::F64(pts.iter().map(|p| p.x).collect()))
        .with("y", ColumnData::F64(pts.iter().map(|p| p.y).collect()))
        .with("force_x", ColumnData::F64(fx))
        .with("force_y", ColumnData::F64(vec![0.0; n]));
    let dir = temp_dir("vectors");
    let file = dir.join("snapshot.parquet");
    write_parquet(&file, &table).unwrap();
    let out = dir.join("result");
    let (code, stdout, stderr) = magopt(&[
        "analyze",
        file.to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!((v["forces"][0]["mean"].as_f64().unwrap() - 3.5).abs() < 1e-12);
    let chains = &v["force_chains"];
    assert!((chains["direction_order"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!(chains["neighbor_pairs"].as_u64().unwrap() > 400);
    assert!(out.join("force_vectors.png").is_file());

    let half = Table::new()
        .with("x", ColumnData::F64(pts.iter().map(|p| p.x).collect()))
        .with("y", ColumnData::F64(pts.iter().map(|p| p.y).collect()))
        .with("force_x", ColumnData::F64(vec![1.0; n]));
    write_parquet(&file, &half).unwrap();
    let (code, _, stderr) = magopt(&["analyze", file.to_str().unwrap(), "--json"]);
    assert_eq!(code, 2);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("'force_x' and 'force_y'"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}
