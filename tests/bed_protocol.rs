//! The `bed` protocol and command line: geometry rules (packing-fraction heights, bi-disperse
//! H_f, √a size scaling), a full small cycle (hysteresis with dry friction, none without),
//! snapshots in the agreed format, the damper, bad input and study files.

mod common;
use common::magopt;

use magopt::models::bed::damper::run_damper;
use magopt::models::bed::params::{BedParams, Friction, Heights, Preset};
use magopt::models::bed::protocol::run_cycle;
use magopt::models::bed::state::Geometry;
use magopt::output::particles::{read_lammps_dump, read_xyz};
use magopt::output::table::{read_parquet, ColumnData};

fn small_bed() -> BedParams {
    let mut p = BedParams::defaults();
    p.particles = Some(24);
    p.piston_speed = 0.02;
    p.relaxation_time = 1.0;
    p.piston_decay_time = 0.2;
    p.settle_time = 0.5;
    p
}

#[test]
fn heights_follow_the_packing_fraction_and_the_bidisperse_rule() {
    let mut p = BedParams::defaults();
    p.preset = Preset::Bidisperse;
    let g0 = Geometry::of(&p);
    let d1 = 5e-3;
    // H_r = 14 D1 gives φ = 0.34 with N = 400 in W = 66 D1 (to the rounding of the source)
    assert!(
        (g0.final_height / (14.0 * d1) - 1.0).abs() < 0.01,
        "{}",
        g0.final_height
    );
    for (r, a) in [(0.5, 0.5), (0.5, 0.75), (1.0, 0.6)] {
        p.mixing_ratio = r;
        p.aspect_ratio = a;
        let g = Geometry::of(&p);
        let expected = (1.0 + r * (a * a - 1.0)) * g0.final_height;
        assert!(
            (g.final_height / expected - 1.0).abs() < 1e-12,
            "R = {r}, a = {a}"
        );
    }
    // size scaling: 4× the particles doubles W and H; φ unchanged
    let mut q = BedParams::defaults();
    let g = Geometry::of(&q);
    q.particles = Some(4 * 368);
    let g4 = Geometry::of(&q);
    assert!((g4.width / g.width - 2.0).abs() < 1e-12);
    assert!((g4.final_height / g.final_height - 2.0).abs() < 1e-12);
}

#[test]
fn source_heights_compress_from_the_top_of_the_cell_over_the_table_a1_strokes() {
    // de Paula 2025, Table A.1 (D1 = 5 mm, N = 400, H = 0.445 m): T·V_c = H0 − H_f in metres
    // (R where the interleaving realizes R exactly)
    let mut p = BedParams::defaults();
    p.preset = Preset::Bidisperse;
    for (a, r, stroke) in [
        (0.6, 0.0, 0.375),
        (0.6, 0.5, 0.3974),
        (0.6, 1.0, 0.4198),
        (0.5, 0.2, 0.3855),
        (0.75, 0.8, 0.3995),
    ] {
        (p.aspect_ratio, p.mixing_ratio) = (a, r);
        let g = Geometry::of(&p);
        assert_eq!(g.start_height, g.height);
        // H_r = 14 D1 for φ = 0.34 holds to the source's rounding (0.2 %)
        let relative = (g.start_height - g.final_height) / stroke - 1.0;
        assert!(relative.abs() < 2e-3, "a = {a}, R = {r}: {relative}");
    }
    // a small mono-disperse cycle under them ends at the top of its cell
    let q = small_bed();
    assert_eq!(q.heights, Heights::Source);
    let run = run_cycle(&q, 2, &|_| {});
    assert!(run.failure.is_none(), "{:?}", run.failure);
    let g = Geometry::of(&q);
    assert!((run.stroke - (g.height - g.final_height)).abs() < 1e-12);
    let top = run.series.get("piston_height").last().unwrap().1;
    assert!((top - g.height).abs() < 1e-9 * g.height, "{top}");
}

#[test]
fn compression_can_stop_at_a_target_piston_force() {
    let mut p = small_bed();
    p.heights = Heights::PackingFractions; // the shorter stroke keeps the test fast
    let full = run_cycle(&p, 2, &|_| {});
    let target = 0.5 * full.force_at_max_compression.unwrap();
    p.target_force = Some(target);
    let stopped = run_cycle(&p, 2, &|_| {});
    assert!(stopped.failure.is_none(), "{:?}", stopped.failure);
    let force = stopped.force_at_max_compression.unwrap();
    assert!(
        force >= target && force < 1.05 * target,
        "{force} vs {target}"
    );
    assert!(
        stopped.stroke < full.stroke,
        "{} vs {}",
        stopped.stroke,
        full.stroke
    );
    // the expansion still returns the piston to H0 (φ_start)
    assert!((stopped.final_packing_fraction - 0.12).abs() < 1e-12);
    // a target beyond the force at H_f fails with its reason
    p.target_force = Some(10.0 * full.max_force.unwrap());
    let failed = run_cycle(&p, 2, &|_| {});
    assert!(
        failed
            .failure
            .as_deref()
            .is_some_and(|r| r.contains("target_force")),
        "{:?}",
        failed.failure
    );
}

#[test]
fn dry_friction_gives_hysteresis_and_no_friction_none() {
    let mut p = small_bed();
    p.heights = Heights::PackingFractions;
    let dry = run_cycle(&p, 2, &|_| {});
    assert!(dry.failure.is_none(), "{:?}", dry.failure);
    assert!((dry.max_packing_fraction - 0.34).abs() < 1e-12);
    assert!((dry.final_packing_fraction - 0.12).abs() < 1e-12);
    assert!(dry.closest_pair > 0.9 && dry.closest_wall > 0.0);
    // compression branch above the expansion branch at the same piston height
    let height = dry.series.get("piston_height");
    let force = dry.series.get("piston_force");
    let g = Geometry::of(&p);
    let mid = 0.5 * (g.start_height + g.final_height);
    let t_max = height
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|h| h.0)
        .unwrap();
    let near = |compressing: bool| {
        let k = (0..height.len())
            .filter(|&k| (height[k].0 < t_max) == compressing && height[k].1 < g.start_height)
            .min_by(|&a, &b| {
                (height[a].1 - mid)
                    .abs()
                    .total_cmp(&(height[b].1 - mid).abs())
            })
            .unwrap();
        force[k].1
    };
    assert!(
        near(true) > near(false),
        "{} vs {}",
        near(true),
        near(false)
    );
    assert!(dry.cycle_work.unwrap() > 0.0);
    p.friction = Friction::None;
    let none = run_cycle(&p, 2, &|_| {});
    assert!(none.failure.is_none(), "{:?}", none.failure);
    let ratio = none.cycle_work.unwrap().abs() / dry.cycle_work.unwrap();
    assert!(
        ratio < 0.1,
        "frictionless cycle dissipates {ratio} of the dry one"
    );
}

#[test]
fn snapshots_follow_the_contract() {
    let p = small_bed();
    let o = run_cycle(&p, 1, &|_| {});
    let labels: Vec<&str> = o.snapshots.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(labels, ["compression-start", "max-compression", "end"]);
    let dir = std::env::temp_dir().join(format!("magopt-bed-snap-{}", std::process::id()));
    o.snapshots[1].write(&dir, "max").unwrap();
    let table = read_parquet(&dir.join("max.parquet")).unwrap();
    for name in [
        "x_m",
        "y_m",
        "z_m",
        "radius_m",
        "vx_m_per_s",
        "vy_m_per_s",
        "vz_m_per_s",
        "mass_kg",
        "magnetic_force_x_N",
        "magnetic_force_y_N",
        "force_magnitude_N",
    ] {
        assert!(
            matches!(table.column(name), Some(ColumnData::F64(v)) if v.len() == 24),
            "{name}"
        );
    }
    assert!(matches!(table.column("type"), Some(ColumnData::I64(_))));
    // the magnitude column is the magnetic force's length
    let column = |name: &str| match table.column(name) {
        Some(ColumnData::F64(v)) => v.clone(),
        _ => panic!("{name}"),
    };
    let (fx, fy, f) = (
        column("magnetic_force_x_N"),
        column("magnetic_force_y_N"),
        column("force_magnitude_N"),
    );
    for k in 0..f.len() {
        assert!((fx[k].hypot(fy[k]) - f[k]).abs() <= 1e-12 * f[k]);
    }
    let xyz = std::fs::read_to_string(dir.join("max.xyz")).unwrap();
    let lines: Vec<&str> = xyz.lines().collect();
    assert_eq!(lines[0], "24");
    assert!(lines[1].contains(
        "Properties=type:I:1:species:S:1:pos:R:3:radius:R:1:velo:R:3:masses:R:1:momenta:R:3:\
         magnetic_force:R:3:force_magnitude:R:1 "
    ));
    assert_eq!(lines.len(), 26);
    assert_eq!(lines[2].split_whitespace().count(), 17);
    let frame = read_xyz(&xyz, 0).unwrap();
    assert_eq!(frame, o.snapshots[1].frame());
    let dump = std::fs::read_to_string(dir.join("max.dump")).unwrap();
    let mut from_dump = read_lammps_dump(&dump).unwrap();
    // a dump has no units: both extra columns are in N
    from_dump.extra.iter_mut().for_each(|p| p.unit = "N".into());
    assert_eq!(from_dump, frame);
    assert!(dir.join("max.vtk").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn damper_rests_on_the_bed_and_a_heavy_piston_crushes_it() {
    let mut p = small_bed();
    p.friction = Friction::Viscous;
    p.damper_time = 1.0;
    p.piston_mass = 0.05;
    let light = run_damper(&p, 1, &|_| {});
    assert!(light.failure.is_none(), "{:?}", light.failure);
    let z = light.series.get("piston_displacement");
    assert!(
        (z[0].1 - 0.2 * 6e-3).abs() < 1e-4,
        "starts 0.2 D above rest: {}",
        z[0].1
    );
    // a damped oscillation about the rest height: the last quarter swings less than the first
    let swing = |part: &[(f64, f64)]| part.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
    let quarter = z.len() / 4;
    assert!(
        swing(&z[3 * quarter..]) < swing(&z[..quarter]),
        "{} vs {}",
        swing(&z[3 * quarter..]),
        swing(&z[..quarter])
    );
    p.piston_mass = 20.0;
    let heavy = run_damper(&p, 1, &|_| {});
    assert!(
        heavy
            .failure
            .as_deref()
            .is_some_and(|r| r.contains("crushed")),
        "{:?}",
        heavy.failure
    );
}

#[test]
fn bad_input_is_one_line_and_exit_code_2() {
    let cases: &[(&[&str], &str)] = &[
        (&["--packing-fraction", "0.95"], "max_packing_fraction"),
        (
            &[
                "--heights",
                "packing-fractions",
                "--packing-fraction",
                "0.1",
            ],
            "start_packing_fraction",
        ),
        (
            &["--packing-fraction", "0.05"],
            "max_packing_fraction: 0.05",
        ),
        (
            &["--velocity", "0"],
            "--velocity: 0 mm/s is not allowed (need > 0 mm/s)",
        ),
        (&["--piston-speed", "-3mm/s"], "--piston-speed: -3 mm/s"),
        (
            &["--mixing-ratio", "1.5"],
            "--mixing-ratio: 1.5 is not allowed",
        ),
        (&["--aspect-ratio", "0"], "--aspect-ratio"),
        (&["--aspect-ratio", "1.2"], "--aspect-ratio"),
        (&["--friction", "sticky"], "none, viscous, dry, both"),
        (&["--cutoff", "43 s"], "--cutoff"),
        (
            &["--velocity", "1mm/s", "--piston-speed", "2mm/s"],
            "given twice",
        ),
        (&["--big-diameter", "40mm"], "particles"),
        (&["--velocity", "5 kOe"], "--velocity"),
        (&["--species", "/nonexistent.toml"], "--species"),
        (&["--far-field-interval", "0"], "--far-field-interval"),
        (
            &["--far-field-interval", "4", "--neighbors", "exact"],
            "neighbors = verlet",
        ),
        (
            &["--far-field-interval", "4", "--near-cutoff", "8"],
            "near_cutoff",
        ),
    ];
    for (args, needle) in cases {
        let mut full = vec!["bed"];
        full.extend_from_slice(args);
        let (code, _, err) = magopt(&full);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let mut p = BedParams::defaults();
    p.gap = 3e-3;
    let e = p.validate().unwrap_err().to_string();
    assert!(e.starts_with("gap:") && e.contains("thickness"), "{e}");
}

#[test]
fn bed_and_damper_run_from_the_command_line_and_study_files() {
    let dir = std::env::temp_dir().join(format!("magopt-bed-cli-{}", std::process::id()));
    let out = dir.join("run");
    let (code, json, err) = magopt(&[
        "bed",
        "--particles",
        "12",
        "--velocity",
        "50mm/s",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    for key in [
        "max_piston_force_N",
        "final_packing_fraction",
        "mean_distance_start_D",
        "mean_distance_min_D",
        "mean_distance_end_D",
        "steps",
        "wall_time_s",
    ] {
        assert!(v[key].is_number(), "{key}: {json}");
    }
    for file in [
        "runs.parquet",
        "series.parquet",
        "snapshots/end.xyz",
        "snapshots/end.parquet",
    ] {
        assert!(out.join(file).exists(), "{file}");
    }
    let species = dir.join("species.toml");
    std::fs::write(&species, "[[species]]\ndiameter = \"6mm\"\nfraction = 0.7\n[[species]]\ndiameter = 4.5\nfraction = 0.3\n").unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"t\"\nmodel = \"bed\"\nreplicates = 1\nseed = 1\n[base]\nparticles = 12\npiston_speed = \"50mm/s\"\nspecies_file = {:?}\n[sweep]\nfriction = [\"dry\", \"viscous\"]\n",
            species.to_str().unwrap()
        ),
    )
    .unwrap();
    let (code, _, err) = magopt(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        dir.join("sweep").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let runs = read_parquet(&dir.join("sweep/runs.parquet")).unwrap();
    assert_eq!(runs.n_rows(), 2);
    let (code, json, err) = magopt(&[
        "damper",
        "--particles",
        "12",
        "--damper-time",
        "0.5",
        "--piston-mass",
        "20g",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(json.contains("\"damper_rest_height_m\":0."), "{json}");
    std::fs::remove_dir_all(dir).ok();
}
