//! The study runner: deterministic expansion and seeds, resume, shards + collect, and no
//! panic on malformed study files (their messages are in tests/inputs/). Runs use the `align`
//! ensemble model (milliseconds each).

use magopt::materials::MaterialDb;
use magopt::models::align::study::AlignModel;
use magopt::output::table::{read_parquet, Table};
use magopt::study::runner::{collect, sweep, Shard, SweepOptions};
use magopt::study::spec::Study;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const STUDY: &str = r#"
name = "grid"
model = "align"
replicates = 2
seed = 7
metrics = ["alignment_time_s", "final_alignment"]
[base]
model = "ensemble"
friction = 0.1
[sweep]
field = { log = ["10kOe", "80kOe", 4] }
target = [0.9, 0.95]
"#;

fn model() -> AlignModel {
    AlignModel::new(MaterialDb::builtin())
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-study-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run(dir: &Path, resume: bool, shard: Option<Shard>) {
    let m = model();
    let study = Study::parse(&m, STUDY, "grid.toml").unwrap();
    let options = SweepOptions {
        out: dir.to_path_buf(),
        resume,
        keep_stale: false,
        shard,
        command: "test".into(),
    };
    sweep(&m, &study, &options, |_| {}, &|| {}).unwrap();
}

/// A result table without the columns that legitimately differ between executions.
fn table(dir: &Path, file: &str) -> Table {
    let mut t = read_parquet(&dir.join(file)).unwrap();
    t.columns.retain(|c| c.name != "wall_time_s");
    t
}

fn assert_same_results(a: &Path, b: &Path) {
    for file in ["runs.parquet", "series.parquet", "summary.parquet"] {
        assert_eq!(table(a, file), table(b, file), "{file} differs");
    }
}

#[test]
fn expansion_and_seeds_are_deterministic() {
    let m = model();
    let a = Study::parse(&m, STUDY, "grid.toml")
        .unwrap()
        .runs(&m)
        .unwrap();
    let b = Study::parse(&m, STUDY, "grid.toml")
        .unwrap()
        .runs(&m)
        .unwrap();
    assert_eq!(a, b);
    assert_eq!(a.len(), 4 * 2 * 2);
    for run in &a {
        assert_eq!(
            run.seed,
            7 + run.replicate as u64,
            "common random numbers: seed + r at every point"
        );
    }
    let ids: std::collections::HashSet<_> = a.iter().map(|r| r.id.clone()).collect();
    assert_eq!(ids.len(), a.len(), "run ids are unique");
    let changed = STUDY.replace("friction = 0.1", "friction = 0.2");
    let c = Study::parse(&m, &changed, "grid.toml")
        .unwrap()
        .runs(&m)
        .unwrap();
    assert!(
        a.iter().zip(&c).all(|(x, y)| x.id != y.id),
        "a different base gives different ids"
    );
}

#[test]
fn resumed_sweep_equals_an_uninterrupted_one() {
    let (whole, resumed) = (temp_dir("whole"), temp_dir("resumed"));
    run(&whole, false, None);
    run(&resumed, false, None);
    // Simulate a sweep killed part-way: half of the runs and every table are lost.
    let mut saved: Vec<_> = std::fs::read_dir(resumed.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    saved.sort();
    for path in saved.iter().step_by(2) {
        std::fs::remove_file(path).unwrap();
    }
    for file in ["runs.parquet", "series.parquet", "summary.parquet"] {
        std::fs::remove_file(resumed.join(file)).unwrap();
    }
    run(&resumed, true, None);
    assert_same_results(&whole, &resumed);
    for dir in [whole, resumed] {
        std::fs::remove_dir_all(dir).ok();
    }
}

#[test]
fn sweep_refuses_to_overwrite_without_resume() {
    let dir = temp_dir("again");
    run(&dir, false, None);
    let m = model();
    let study = Study::parse(&m, STUDY, "grid.toml").unwrap();
    let options = SweepOptions {
        out: dir.clone(),
        resume: false,
        keep_stale: false,
        shard: None,
        command: "test".into(),
    };
    let err = sweep(&m, &study, &options, |_| {}, &|| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("--resume"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn shards_collected_equal_one_sweep() {
    let whole = temp_dir("unsharded");
    run(&whole, false, None);
    let shards: Vec<PathBuf> = (0..3).map(|i| temp_dir(&format!("shard{i}"))).collect();
    for (i, dir) in shards.iter().enumerate() {
        run(dir, false, Some(Shard { index: i, count: 3 }));
    }
    let merged = temp_dir("merged");
    let m = model();
    let study = Study::parse(&m, STUDY, "grid.toml").unwrap();
    let n = collect(&m, &study, &shards, &merged, "test").unwrap();
    assert_eq!(n, 16);
    assert_same_results(&whole, &merged);
    for dir in shards.iter().chain([&whole, &merged]) {
        std::fs::remove_dir_all(dir).ok();
    }
}

proptest! {
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
        let m = model();
        let _ = Study::parse(&m, &text, "fuzz.toml");
    }

    #[test]
    fn mutated_study_files_never_panic(cut in 0usize..400, insert in "[\\[\\]{}=\",.a-z0-9 \n-]{0,12}") {
        let m = model();
        let at = cut.min(STUDY.len());
        let at = (0..=at).rev().find(|&k| STUDY.is_char_boundary(k)).unwrap_or(0);
        let text = format!("{}{}{}", &STUDY[..at], insert, &STUDY[at..]);
        let _ = Study::parse(&m, &text, "fuzz.toml");
    }
}

#[test]
fn two_parameter_optimization_finds_the_known_optimum() {
    // Ensemble: τ ∝ damping at fixed h, so the optimum is the lower damping bound, and the
    // optimal field is the 1D optimum (h ≈ 1.56, about 28.8 kOe for Sr ferrite).
    let text = r#"
model = "align"
[base]
model = "ensemble"
[optimize]
parameters = { field = ["10kOe", "80kOe"], damping = [10.0, 40.0] }
metric = "alignment_time_s"
iterations = 60
"#;
    let m = model();
    let study = Study::parse(&m, text, "nd.toml").unwrap();
    let result = magopt::study::optimize::optimize(&m, &study, None, &|| {}).unwrap();
    let spec = study.optimize.as_ref().unwrap();
    let at = |name: &str| result.best[spec.free.iter().position(|(s, ..)| s.name == name).unwrap()];
    let field_koe = at("field") / (1e6 / (4.0 * std::f64::consts::PI));
    assert!(
        (field_koe / 28.8 - 1.0).abs() < 0.1,
        "field {field_koe} kOe"
    );
    assert!(at("damping") < 11.0, "damping {}", at("damping"));
    assert!(result.one_dimensional.is_none());
}
