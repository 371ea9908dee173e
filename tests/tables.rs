//! The tables magopt writes, read back as a user's tools read them: every input of every run,
//! units, nulls (never NaN) for missing values, integers for counts; and `magopt analyze` on
//! every particle format magopt writes.

mod common;

use common::magopt;
use magopt::output::table::{read_parquet, read_parquet_with_metadata, ColumnData, Table};
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-tables-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn column<'a>(t: &'a Table, name: &str) -> &'a ColumnData {
    t.column(name).unwrap_or_else(|| panic!("no column {name}"))
}

/// Checks the runs table of one successful single run: ok, reason and notes null, every
/// declared parameter present, units on the numeric columns.
fn check_single_runs(dir: &Path, inputs: &[(&str, &str)], counts: &[&str]) {
    let (runs, kv) = read_parquet_with_metadata(&dir.join("runs.parquet")).unwrap();
    assert_eq!(runs.n_rows(), 1);
    assert_eq!(column(&runs, "status"), &ColumnData::Str(vec!["ok".into()]));
    assert_eq!(column(&runs, "reason"), &ColumnData::OptStr(vec![None]));
    assert_eq!(column(&runs, "notes"), &ColumnData::OptStr(vec![None]));
    for (name, unit) in inputs {
        assert!(runs.column(name).is_some(), "input column {name}");
        assert_eq!(runs.unit(name), Some(*unit), "unit of {name}");
    }
    for name in counts {
        assert!(
            matches!(
                column(&runs, name),
                ColumnData::I64(_) | ColumnData::OptI64(_)
            ),
            "{name} is {}",
            column(&runs, name).kind()
        );
    }
    assert_eq!(runs.unit("wall_time_s"), Some("s"));
    assert!(kv.iter().any(|(k, _)| k == "magopt.units"));
    let series = read_parquet(&dir.join("series.parquet")).unwrap();
    let ColumnData::Str(units) = column(&series, "unit") else {
        panic!("unit column is not text");
    };
    assert_eq!(units.len(), series.n_rows());
    assert_eq!(series.unit("time_s"), Some("s"));
}

#[test]
fn single_runs_record_every_input_and_null_for_what_is_missing() {
    let dir = temp_dir("single");
    let bed = dir.join("bed");
    let (code, _, err) = magopt(&[
        "bed",
        "--particles",
        "12",
        "--velocity",
        "50mm/s",
        "--out",
        bed.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    check_single_runs(
        &bed,
        &[
            ("particles", "1"),
            ("piston_speed_mm_per_s", "mm/s"),
            ("gap_mm", "mm"),
            ("static_friction", "1"),
        ],
        &["particles", "steps", "list_builds"],
    );
    let runs = read_parquet(&bed.join("runs.parquet")).unwrap();
    assert_eq!(column(&runs, "particles"), &ColumnData::I64(vec![12]));
    // a parameter named like a metric gets an `input_` prefix
    assert!(runs.column("input_max_packing_fraction").is_some());
    assert!(runs.column("max_packing_fraction").is_some());
    let series = read_parquet(&bed.join("series.parquet")).unwrap();
    let (ColumnData::Str(obs), ColumnData::Str(units)) =
        (column(&series, "observable"), column(&series, "unit"))
    else {
        panic!("observable and unit are text");
    };
    let unit_of = |o: &str| &units[obs.iter().position(|x| x == o).unwrap()];
    assert_eq!(unit_of("piston_force"), "N");
    assert_eq!(unit_of("packing_fraction"), "1");
    // one run: std and ci95 null; no damper: damper metrics have no value, their mean is null
    let summary = read_parquet(&bed.join("summary.parquet")).unwrap();
    assert_eq!(
        column(&summary, "max_piston_force_N_std"),
        &ColumnData::OptF64(vec![None])
    );
    assert_eq!(
        column(&summary, "max_piston_force_N_ci95"),
        &ColumnData::OptF64(vec![None])
    );
    assert!(matches!(
        column(&summary, "max_piston_force_N_mean"),
        ColumnData::OptF64(v) if v[0].is_some_and(f64::is_finite)
    ));
    assert_eq!(
        column(&summary, "damper_amplitude_m_count"),
        &ColumnData::U64(vec![0])
    );
    assert_eq!(
        column(&summary, "damper_amplitude_m_mean"),
        &ColumnData::OptF64(vec![None])
    );
    assert_eq!(summary.unit("max_piston_force_N_mean"), Some("N"));

    let blast = dir.join("blast");
    let (code, _, err) = magopt(&[
        "blast",
        "--particles",
        "100",
        "--duration",
        "0.1",
        "--out",
        blast.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    check_single_runs(
        &blast,
        &[
            ("particles", "1"),
            ("field_T", "T"),
            ("duration_s", "s"),
            ("radius_m", "m"),
        ],
        &["particles", "steps", "bonds", "largest_cluster"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_study_records_swept_and_fixed_inputs_and_statistics() {
    let dir = temp_dir("study");
    let study = dir.join("grid.toml");
    std::fs::write(
        &study,
        "name = \"grid\"\nmodel = \"align\"\nreplicates = 2\n\
         metrics = [\"alignment_time_s\", \"final_alignment\", \"steps\"]\n\
         [base]\nmodel = \"ensemble\"\n[sweep]\nfield = [\"20kOe\", \"40kOe\"]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (code, _, err) = magopt(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let runs = read_parquet(&out.join("runs.parquet")).unwrap();
    assert_eq!(runs.n_rows(), 4);
    assert_eq!(
        column(&runs, "field_kOe"),
        &ColumnData::F64(vec![20.0, 20.0, 40.0, 40.0])
    );
    assert_eq!(runs.unit("field_kOe"), Some("kOe"));
    assert_eq!(runs.unit("alignment_time_s"), Some("s"));
    // a fixed parameter is there too, as a text or a number with its unit
    assert!(runs.column("model").is_some());
    assert!(runs.columns.len() > 15, "{}", runs.columns.len());
    assert!(
        matches!(column(&runs, "reason"), ColumnData::OptStr(v) if v.iter().all(Option::is_none))
    );
    assert!(matches!(column(&runs, "steps"), ColumnData::OptI64(_)));
    let summary = read_parquet(&out.join("summary.parquet")).unwrap();
    assert_eq!(summary.n_rows(), 2);
    assert_eq!(
        column(&summary, "final_alignment_count"),
        &ColumnData::U64(vec![2, 2])
    );
    assert!(matches!(
        column(&summary, "final_alignment_std"),
        ColumnData::OptF64(v) if v.iter().all(Option::is_some)
    ));
    let series = read_parquet(&out.join("series.parquet")).unwrap();
    assert!(series.column("unit").is_some());
    std::fs::remove_dir_all(&dir).ok();
}

/// The summary without the keys that name the input file.
fn summary_of(args: &[&str]) -> serde_json::Value {
    let (code, out, err) = magopt(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

#[test]
fn analyze_reads_every_particle_format_and_chooses_frames() {
    let dir = temp_dir("analyze");
    let bed = dir.join("bed");
    let (code, _, err) = magopt(&[
        "bed",
        "--particles",
        "30",
        "--velocity",
        "50mm/s",
        "--out",
        bed.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let snap = bed.join("snapshots");
    // the particle table as CSV
    let table = read_parquet(&snap.join("end.parquet")).unwrap();
    let names = [
        "x_m",
        "y_m",
        "radius_m",
        "type",
        "force_magnitude_N",
        "magnetic_force_x_N",
        "magnetic_force_y_N",
    ];
    let mut csv = names.join(",") + "\n";
    for i in 0..table.n_rows() {
        let row: Vec<String> = names
            .iter()
            .map(|n| match column(&table, n) {
                ColumnData::F64(v) => format!("{:?}", v[i]),
                ColumnData::I64(v) => v[i].to_string(),
                other => panic!("{n}: {}", other.kind()),
            })
            .collect();
        csv += &(row.join(",") + "\n");
    }
    std::fs::write(snap.join("end.csv"), csv).unwrap();
    let path = |f: &str| snap.join(f).to_str().unwrap().to_string();
    let reference = summary_of(&["analyze", &path("end.parquet"), "--json"]);
    assert!(reference["particles"].as_u64() == Some(30), "{reference}");
    assert!(reference["psi6"].as_f64().is_some());
    assert!(reference["forces"].is_array(), "{reference}");
    for file in ["end.xyz", "end.dump", "end.csv"] {
        let s = summary_of(&["analyze", &path(file), "--json"]);
        assert_eq!(s, reference, "{file}");
    }
    // the multi-frame trajectory: the last frame by default, the first with --frame 0
    let last = summary_of(&["analyze", &path("trajectory.xyz"), "--json"]);
    let minus_one = summary_of(&[
        "analyze",
        &path("trajectory.xyz"),
        "--frame",
        "-1",
        "--json",
    ]);
    assert_eq!(last, minus_one);
    let first = summary_of(&["analyze", &path("trajectory.xyz"), "--frame", "0", "--json"]);
    let start = summary_of(&["analyze", &path("compression-start.xyz"), "--json"]);
    assert_eq!(first, start);
    // what --out records
    let out = dir.join("analysis");
    let (code, _, err) = magopt(&[
        "analyze",
        &path("trajectory.xyz"),
        "--frame",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["input"]["frame"], 0);
    assert_eq!(summary["input"]["format"], "extxyz");
    assert!(summary["input"]["frames"].as_u64().unwrap() >= 2);
    assert!(summary["input"]["size_bytes"].as_u64().unwrap() > 0);
    assert_eq!(summary["magopt_version"], env!("CARGO_PKG_VERSION"));
    let (cells, kv) = read_parquet_with_metadata(&out.join("cells.parquet")).unwrap();
    assert!(kv
        .iter()
        .any(|(k, v)| k == "magopt.input" && v.contains("trajectory.xyz")));
    assert!(kv.iter().any(|(k, _)| k == "magopt.version"));
    assert_eq!(cells.unit("area"), Some("m2"));
    // unbounded cells: no area, null (not NaN)
    let (ColumnData::OptF64(area), ColumnData::Bool(bounded)) =
        (column(&cells, "area"), column(&cells, "bounded"))
    else {
        panic!("area and bounded");
    };
    for (a, b) in area.iter().zip(bounded) {
        assert_eq!(a.is_some(), *b);
        assert!(a.is_none_or(|a| !a.is_nan()));
    }
    // bad frame, bad extension: one line, exit 2
    for (args, needle) in [
        (
            vec!["analyze", &path("trajectory.xyz"), "--frame", "99"],
            "out of range",
        ),
        (
            vec!["analyze", &path("end.dump"), "--frame", "-2"],
            "out of range",
        ),
        (
            vec!["analyze", &path("end.parquet"), "--frame", "1"],
            "out of range",
        ),
        (vec!["analyze", &path("end.vtk")], "allowed"),
    ] {
        let (code, _, err) = magopt(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
