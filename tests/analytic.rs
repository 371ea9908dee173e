//! The `analytic` model from the outside: `magopt sweep` on a study file of test functions
//! writes runs.parquet whose values are the functions, and bad inputs are one line with exit
//! code 2.

mod common;
use common::magopt;

use magopt::models::analytic::{branin, zdt1_front, BRANIN_ARGMIN, BRANIN_MIN};
use magopt::output::table::{read_parquet, ColumnData, Table};
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-analytic-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn numbers(table: &Table, name: &str) -> Vec<Option<f64>> {
    match table.column(name) {
        Some(ColumnData::F64(v)) => v.iter().map(|x| Some(*x)).collect(),
        Some(ColumnData::OptF64(v)) => v.clone(),
        other => panic!("{name}: {other:?}"),
    }
}

fn sweep(dir: &Path, study: &str) -> (i32, String, String) {
    let file = dir.join("study.toml");
    std::fs::write(&file, study).unwrap();
    let out = dir.join("out");
    magopt(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

const BRANIN_GRID: &str = r#"
name = "branin-grid"
model = "analytic"
seed = 3
[base]
function = "branin"
[sweep]
x1 = [-5.0, -3.141592653589793, 0.0, 3.141592653589793, 9.42477796076938, 10.0]
x2 = { range = [0.0, 15.0, 7] }
"#;

#[test]
fn sweep_over_branin_reports_the_function() {
    let dir = temp_dir("branin");
    let (code, stdout, stderr) = sweep(&dir, BRANIN_GRID);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("42 runs done now"), "{stdout}");
    let runs = read_parquet(&dir.join("out/runs.parquet")).unwrap();
    assert_eq!(runs.n_rows(), 42);
    let (x1, x2, value) = (
        numbers(&runs, "x1"),
        numbers(&runs, "x2"),
        numbers(&runs, "value"),
    );
    for k in 0..runs.n_rows() {
        let (a, b) = (x1[k].unwrap(), x2[k].unwrap());
        assert_eq!(value[k], Some(branin(a, b)), "at ({a}, {b})");
    }
    // f1 and f2 exist for every model run and are null for a scalar function
    assert!(numbers(&runs, "f1").iter().all(Option::is_none));
    assert!(numbers(&runs, "f2").iter().all(Option::is_none));
    match runs.column("status") {
        Some(ColumnData::Str(s)) => assert!(s.iter().all(|s| s == "ok")),
        other => panic!("status: {other:?}"),
    }
    // the grid holds the second minimizer (π, 2.5) only approximately; the lowest value is
    // above the minimum but close to it
    let lowest = value
        .iter()
        .flatten()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    assert!((BRANIN_MIN..BRANIN_MIN + 0.1).contains(&lowest), "{lowest}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn minimizers_reach_the_minimum_and_noise_is_seeded() {
    let dir = temp_dir("noise");
    let [x1, x2] = BRANIN_ARGMIN[1];
    let study = format!(
        "name = \"noise\"\nmodel = \"analytic\"\nreplicates = 3\nseed = 5\n[base]\n\
         function = \"branin\"\nx1 = {x1:?}\nx2 = {x2:?}\n[sweep]\nnoise = [0.0, 0.1]\n"
    );
    let (code, _, stderr) = sweep(&dir, &study);
    assert_eq!(code, 0, "{stderr}");
    let runs = read_parquet(&dir.join("out/runs.parquet")).unwrap();
    let noise = numbers(&runs, "noise");
    let value = numbers(&runs, "value");
    let exact = branin(x1, x2);
    assert!((exact - BRANIN_MIN).abs() < 1e-12);
    let (mut quiet, mut noisy) = (Vec::new(), Vec::new());
    for k in 0..runs.n_rows() {
        if noise[k] == Some(0.0) {
            quiet.push(value[k].unwrap());
        } else {
            noisy.push(value[k].unwrap());
        }
    }
    assert_eq!(quiet, vec![exact; 3], "noise 0 is exact in every replicate");
    assert_eq!(noisy.len(), 3);
    assert!(
        noisy[0] != noisy[1] && noisy[1] != noisy[2] && noisy[0] != noisy[2],
        "replicates differ: {noisy:?}"
    );
    assert!(noisy.iter().all(|v| (v - exact).abs() < 1.0));
    // the same study again gives the same numbers
    let again = temp_dir("noise-again");
    assert_eq!(sweep(&again, &study).0, 0);
    let repeat = read_parquet(&again.join("out/runs.parquet")).unwrap();
    assert_eq!(numbers(&repeat, "value"), value);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&again).ok();

    // each of the three minimizers gives the minimum
    for (k, p) in BRANIN_ARGMIN.iter().enumerate() {
        let dir = temp_dir(&format!("argmin-{k}"));
        let study = format!(
            "name = \"argmin\"\nmodel = \"analytic\"\n[base]\nfunction = \"branin\"\n\
             x1 = {:?}\nx2 = {:?}\n",
            p[0], p[1]
        );
        let (code, _, stderr) = sweep(&dir, &study);
        assert_eq!(code, 0, "{stderr}");
        let runs = read_parquet(&dir.join("out/runs.parquet")).unwrap();
        let v = numbers(&runs, "value")[0].unwrap();
        assert!((v - BRANIN_MIN).abs() < 1e-12, "{v}");
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn zdt1_reports_both_objectives() {
    let dir = temp_dir("zdt1");
    let study = "name = \"zdt1\"\nmodel = \"analytic\"\n[base]\nfunction = \"zdt1\"\nx2 = 0\n\
                 x3 = 0\nx4 = 0\nx5 = 0\nx6 = 0\n[sweep]\nx1 = { range = [0.0, 1.0, 5] }\n";
    let (code, _, stderr) = sweep(&dir, study);
    assert_eq!(code, 0, "{stderr}");
    let runs = read_parquet(&dir.join("out/runs.parquet")).unwrap();
    let (x1, value, f1, f2) = (
        numbers(&runs, "x1"),
        numbers(&runs, "value"),
        numbers(&runs, "f1"),
        numbers(&runs, "f2"),
    );
    for k in 0..runs.n_rows() {
        let x = x1[k].unwrap();
        assert_eq!(value[k], Some(x));
        assert_eq!(f1[k], Some(x));
        assert!((f2[k].unwrap() - zdt1_front(x)).abs() < 1e-15);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_is_one_line_with_exit_code_2() {
    let cases = [
        (
            "model = \"analytic\"\n[base]\nfunction = \"branin\"\nx1 = 12\n",
            "x1: 12 is outside the domain of branin (need x1 in [-5, 10])",
        ),
        (
            "model = \"analytic\"\n[base]\nfunction = \"branin\"\n[sweep]\nx2 = [1, 16]\n",
            "x2: 16 is outside the domain of branin (need x2 in [0, 15])",
        ),
        (
            "model = \"analytic\"\n[base]\nfunction = \"rastrigin\"\n",
            "base.function: 'rastrigin' is not one of ishigami, branin, hartmann6, zdt1",
        ),
        (
            "model = \"analytic\"\n[base]\nnoise = -0.1\n",
            "base.noise: -0.1 is not allowed (need ≥ 0)",
        ),
        (
            "model = \"analytic\"\nmetrics = [\"f3\"]\n",
            "unknown metric 'f3' (known: value, f1, f2)",
        ),
        (
            "model = \"analytic\"\n[snapshots]\nevery = 1\n",
            "no particles",
        ),
    ];
    for (k, (study, expected)) in cases.iter().enumerate() {
        let dir = temp_dir(&format!("bad-{k}"));
        let (code, _, stderr) = sweep(&dir, study);
        assert_eq!(code, 2, "{study}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("magopt: "), "{stderr}");
        assert!(stderr.contains(expected), "{study}: {stderr}");
        assert!(!dir.join("out/runs.parquet").exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn the_shipped_example_runs() {
    let dir = temp_dir("example");
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/analytic-branin-grid.toml");
    let out = dir.join("out");
    let (code, stdout, stderr) = magopt(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("256 runs done now"), "{stdout}");
    let runs = read_parquet(&out.join("runs.parquet")).unwrap();
    let (x1, x2, value) = (
        numbers(&runs, "x1"),
        numbers(&runs, "x2"),
        numbers(&runs, "value"),
    );
    for k in 0..runs.n_rows() {
        assert_eq!(value[k], Some(branin(x1[k].unwrap(), x2[k].unwrap())));
    }
    std::fs::remove_dir_all(&dir).ok();
}
