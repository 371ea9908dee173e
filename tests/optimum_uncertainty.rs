//! `[optimize]` beside `[design]` or `[sweep]`: the optimum at every point and its
//! distribution, checked against the align ensemble's exact scaling laws.
//!
//! The ensemble is overdamped and non-interacting: γ dθ/dt = −∂E/∂θ with E = K V e(θ, h),
//! h = H/H_K and H_K = 2K/(μ0 M_s). So τ(H; K, γ) = (γ/K) G(H/H_K): the optimal field is
//! h* H_K ∝ K, the optimal τ* ∝ γ/K, and γ does not move the optimum at all. A distribution
//! of K must therefore come out as a distribution of H* with the same relative spread, with
//! τ* K the same at every sample; a grid over γ gives the same H* at every γ and τ* ∝ γ.

mod common;

use common::magopt;
use magopt::materials::MaterialDb;
use magopt::models::align::study::AlignModel;
use magopt::output::table::{read_parquet, ColumnData, Table};
use magopt::study::spec::Study;

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-uq-opt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const OPTIMIZE: &str = r#"
[optimize]
parameters = { field = ["5kOe", "100kOe"] }
metric = "alignment_time_s"
scan_points = 7
iterations = 8
"#;

fn numbers(t: &Table, name: &str) -> Vec<f64> {
    match t.column(name) {
        Some(ColumnData::F64(v)) => v.clone(),
        Some(ColumnData::OptF64(v)) => v.iter().map(|x| x.expect(name)).collect(),
        other => panic!("{name}: {other:?}"),
    }
}

fn spread(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    var.sqrt() / mean
}

fn run(dir: &std::path::Path, text: &str) -> (String, std::path::PathBuf) {
    let study = dir.join("study.toml");
    std::fs::write(&study, text).unwrap();
    let out = dir.join("out");
    let (code, stdout, stderr) = magopt(&[
        "optimize",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    (stdout, out)
}

#[test]
fn the_optimal_field_over_sampled_anisotropy_constants_scales_with_k() {
    let dir = temp_dir("design");
    let text = format!(
        "name = \"k\"\nmodel = \"align\"\nreplicates = 1\nseed = 3\n\
         [base]\nmodel = \"ensemble\"\nparticles = 200\n{OPTIMIZE}\
         [design]\nmethod = \"sobol\"\nsamples = 6\n\
         [design.parameters]\nanisotropy_constant = {{ normal = [\"350kJ/m3\", \"5%\"] }}\n"
    );
    let (stdout, out) = run(&dir, &text);
    assert!(stdout.contains("optimum_field_kOe (kOe):"), "{stdout}");
    let optima = read_parquet(&out.join("optima.parquet")).unwrap();
    assert_eq!(optima.n_rows(), 6);
    assert_eq!(optima.unit("optimum_field_kOe"), Some("kOe"));
    let k = numbers(&optima, "anisotropy_constant_kJ_per_m3");
    let h = numbers(&optima, "optimum_field_kOe");
    let tau = numbers(&optima, "alignment_time_s");
    // τ* K is exact (a pure time scale); H*/K within the resolution of τ (A(t) is sampled)
    let tk: Vec<f64> = tau.iter().zip(&k).map(|(t, k)| t * k).collect();
    let hk: Vec<f64> = h.iter().zip(&k).map(|(h, k)| h / k).collect();
    assert!(spread(&tk) < 1e-3, "τ* K {tk:?}");
    assert!(spread(&hk) < 0.02, "H*/K {hk:?}");
    // so H* carries K's relative spread
    assert!((spread(&h) - spread(&k)).abs() < 0.01, "{h:?} {k:?}");
    let d = read_parquet(&out.join("optimum_distribution.parquet")).unwrap();
    let Some(ColumnData::Str(q)) = d.column("quantity") else {
        panic!("quantity")
    };
    assert_eq!(q, &["optimum_field_kOe", "alignment_time_s"]);
    let mean = numbers(&d, "mean");
    assert!((mean[0] - h.iter().sum::<f64>() / 6.0).abs() < 1e-9);
    // `magopt plot` draws the optimum's histogram
    let (code, stdout, stderr) = magopt(&["plot", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("optimum_field_kOe.png"), "{stdout}");
    std::fs::remove_dir_all(out.join("plots")).unwrap();
    // every run is saved: a re-run reloads them all and writes the same optima
    let runs = std::fs::read_dir(out.join("runs")).unwrap().count();
    let first = std::fs::read(out.join("optima.parquet")).unwrap();
    run(&dir, &text);
    assert_eq!(std::fs::read_dir(out.join("runs")).unwrap().count(), runs);
    assert_eq!(std::fs::read(out.join("optima.parquet")).unwrap(), first);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_grid_of_dampings_leaves_the_optimal_field_and_scales_the_time() {
    let dir = temp_dir("grid");
    let text = format!(
        "name = \"g\"\nmodel = \"align\"\nreplicates = 1\n\
         [base]\nmodel = \"ensemble\"\nparticles = 200\n{OPTIMIZE}\
         [sweep]\ndamping = [10.0, 20.0]\nfield = [\"20kOe\", \"40kOe\"]\n"
    );
    // the swept field is the free parameter: its values serve `magopt sweep` only, and the
    // optimization runs at each damping
    let (_, out) = run(&dir, &text);
    let optima = read_parquet(&out.join("optima.parquet")).unwrap();
    assert_eq!(optima.n_rows(), 2);
    let h = numbers(&optima, "optimum_field_kOe");
    let tau = numbers(&optima, "alignment_time_s");
    assert!((h[1] / h[0] - 1.0).abs() < 1e-9, "{h:?}");
    assert!((tau[1] / tau[0] - 2.0).abs() < 1e-9, "{tau:?}");
    // every run row carries its grid point's damping and its field
    let runs = read_parquet(&out.join("evaluations.parquet")).unwrap();
    assert!(runs.column("damping_N_s_per_m").is_some());
    assert!(runs.column("field_kOe").is_some());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_free_parameter_that_is_also_a_design_parameter_is_refused_before_any_run() {
    let dir = temp_dir("bad");
    let study = dir.join("bad.toml");
    std::fs::write(
        &study,
        format!(
            "model = \"align\"\n[base]\nmodel = \"ensemble\"\n{OPTIMIZE}\
             [design]\nmethod = \"lhs\"\nsamples = 4\n\
             [design.parameters]\nfield = [\"10kOe\", \"50kOe\"]\n"
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let (code, _, stderr) = magopt(&[
        "optimize",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("optimize.parameters.field:"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1);
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_anisotropy_constant_survives_the_material_whatever_the_key_order() {
    let model = AlignModel::new(MaterialDb::builtin());
    // TOML tables are read in key order: anisotropy_constant comes before material
    let text = "model = \"align\"\n[base]\nmaterial = \"srfe12o19\"\n\
                anisotropy_constant = \"300kJ/m3\"\n";
    let study = Study::parse(&model, text, "k.toml").unwrap();
    assert_eq!(study.base.params.material.anisotropy_constant, 300e3);
    let plain = Study::parse(&model, "model = \"align\"\n", "p.toml").unwrap();
    assert_eq!(plain.base.params.material.anisotropy_constant, 350e3);
}

/// Two processes as shards 0/2 and 1/2 of one Bayesian optimization (same --out): each runs
/// half of every batch and waits for the other's; both end at the optimum a single process
/// finds, and shard 0 writes it.
#[test]
fn two_shards_in_lockstep_reach_the_single_process_optimum() {
    let dir = temp_dir("shards");
    let study = dir.join("bo.toml");
    std::fs::write(
        &study,
        "name = \"bo\"\nmodel = \"align\"\nreplicates = 2\n[base]\nmodel = \"ensemble\"\n\
         particles = 200\n[optimize]\nparameters = { field = [\"10kOe\", \"80kOe\"] }\n\
         metric = \"alignment_time_s\"\nmethod = \"bayes\"\nbudget = 10\nbatch = 2\n",
    )
    .unwrap();
    let single = dir.join("single");
    let s = study.to_str().unwrap();
    let (code, _, stderr) = magopt(&["optimize", s, "--out", single.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let shared = dir.join("shared");
    let spawn = |shard: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_magopt"))
            .args([
                "optimize",
                s,
                "--out",
                shared.to_str().unwrap(),
                "--shard",
                shard,
            ])
            .args(["--threads", "1"])
            .output()
            .unwrap()
    };
    let (a, b) = std::thread::scope(|scope| {
        let a = scope.spawn(|| spawn("0/2"));
        let b = scope.spawn(|| spawn("1/2"));
        (a.join().unwrap(), b.join().unwrap())
    });
    for o in [&a, &b] {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let read = |d: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("optimum.json")).unwrap()).unwrap()
    };
    let (one, two) = (read(&single), read(&shared));
    assert_eq!(one["optimum"], two["optimum"]);
    assert_eq!(one["value"], two["value"]);
    assert_eq!(one["evaluations"], two["evaluations"]);
    // a lone shard whose peer never starts gives up after the timeout with a one-line error
    let lone = dir.join("lone");
    let (code, _, stderr) = magopt(&[
        "optimize",
        s,
        "--out",
        lone.to_str().unwrap(),
        "--shard",
        "0/2",
        "--shard-timeout",
        "1",
    ]);
    assert_ne!(code, 0, "{stderr}");
    assert!(stderr.contains("shard 1/2 is not running"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    // shards started with different studies on one --out would each wait for runs the other
    // never makes: they stop with an error instead
    let other = dir.join("other.toml");
    let text = std::fs::read_to_string(&study).unwrap();
    std::fs::write(&other, text.replace("particles = 200", "particles = 201")).unwrap();
    let mixed = dir.join("mixed");
    let spawn = |file: &std::path::Path, shard: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_magopt"))
            .args(["optimize", file.to_str().unwrap(), "--out"])
            .args([
                mixed.to_str().unwrap(),
                "--shard",
                shard,
                "--shard-timeout",
                "10",
            ])
            .args(["--threads", "1"])
            .output()
            .unwrap()
    };
    let (a, b) = std::thread::scope(|scope| {
        let a = scope.spawn(|| spawn(&study, "0/2"));
        let b = scope.spawn(|| spawn(&other, "1/2"));
        (a.join().unwrap(), b.join().unwrap())
    });
    let said = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!a.status.success() && !b.status.success());
    assert!(
        [&a, &b]
            .iter()
            .any(|o| said(o).contains("runs another study")),
        "{}\n{}",
        said(&a),
        said(&b)
    );
    std::fs::remove_dir_all(&dir).ok();
}
