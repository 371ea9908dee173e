//! `magopt blast` from the outside: JSON output, output files, and one-line errors with exit
//! code 2 on bad input.

mod common;
use common::magopt;

#[test]
fn json_reports_the_envelope() {
    let (code, stdout, _) = magopt(&[
        "blast",
        "--particles",
        "200",
        "--duration",
        "0.2s",
        "--json",
    ]);
    assert_eq!(code, 0);
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    for key in [
        "semi_axis_along_B_m",
        "semi_axis_across_B_m",
        "aspect_ratio",
        "kinetic_energy_J",
        "steps",
    ] {
        assert!(json[key].as_f64().is_some(), "{key} in {stdout}");
    }
    assert_eq!(json["steps"].as_f64(), Some(2000.0));
}

#[test]
fn out_writes_tables_and_snapshots() {
    let dir = std::env::temp_dir().join(format!("magopt-blast-cli-{}", std::process::id()));
    let (code, _, stderr) = magopt(&[
        "blast",
        "--particles",
        "100",
        "--duration",
        "0.1",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    for file in ["runs.parquet", "series.parquet", "study.toml"] {
        assert!(dir.join(file).exists(), "{file}");
    }
    let snaps: Vec<_> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    // start, middle, end, and all three in trajectory.xyz.
    assert_eq!(snaps.iter().filter(|s| s.ends_with(".xyz")).count(), 4);
    assert_eq!(snaps.iter().filter(|s| s.ends_with(".parquet")).count(), 3);
    assert_eq!(snaps.iter().filter(|s| s.ends_with(".png")).count(), 3);
    assert_eq!(snaps.iter().filter(|s| s.ends_with(".dump")).count(), 3);
    assert_eq!(snaps.iter().filter(|s| s.ends_with(".vtk")).count(), 3);
    for moment in ["start", "middle", "end"] {
        let text = std::fs::read_to_string(dir.join(format!("snapshots/{moment}.xyz"))).unwrap();
        assert_eq!(text.lines().next(), Some("100"));
        assert_eq!(text.lines().count(), 102);
    }
    let trajectory = std::fs::read_to_string(dir.join("snapshots/trajectory.xyz")).unwrap();
    assert_eq!(trajectory.lines().count(), 3 * 102);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_is_one_line_with_exit_code_2() {
    let cases: &[(&[&str], &str)] = &[
        (&["--radius", "0"], "radius"),
        (&["--radius", "-0.01"], "radius"),
        (&["--density", "-7000"], "density"),
        (&["--energy", "0"], "energy"),
        (&["--particles", "0"], "particles"),
        (&["--particles", "-5"], "particles"),
        (
            &["--particles", "100000"],
            "cloud too small for its particles",
        ),
        (
            &["--cloud-radius", "0.04"],
            "cloud too small for its particles",
        ),
        (&["--dt", "0"], "dt"),
        (&["--dt", "-1e-4"], "dt"),
        (&["--field", "NaN"], "field"),
        (&["--energy", "nan"], "energy"),
        (&["--duration", "0"], "duration"),
        (&["--duration", "1e9"], "steps"),
        (&["--samples", "1e9"], "samples"),
        (&["--field-direction", "0,0,0"], "field"),
        (&["--interacting", "--interactions", "glue"], "interactions"),
    ];
    for (args, needle) in cases {
        let mut all = vec!["blast"];
        all.extend_from_slice(args);
        let (code, stdout, stderr) = magopt(&all);
        assert_eq!(code, 2, "{args:?}: {stdout}{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
}

#[test]
fn blast_studies_sweep_optimize_and_plot() {
    let dir = std::env::temp_dir().join(format!("magopt-blast-study-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        r#"name = "tiny"
model = "blast"
replicates = 2
seed = 1
[base]
particles = 60
energy = "0.3kJ"
duration = "0.3s"
samples = 5
target_aspect_ratio = 1.5
[sweep]
field = ["0T", "10T"]
[optimize]
parameters = { field = ["0.05T", "5T"] }
metric = "shape_error"
scale = "log"
scan_points = 4
iterations = 3
"#,
    )
    .unwrap();
    let sweep = dir.join("sweep");
    let (code, _, stderr) = magopt(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        sweep.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let (code, _, stderr) = magopt(&["plot", sweep.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(sweep.join("plots/aspect_ratio_vs_field.png").exists());
    let (code, stdout, stderr) = magopt(&[
        "optimize",
        study.to_str().unwrap(),
        "--out",
        dir.join("opt").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(json.to_string().contains("field"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}
