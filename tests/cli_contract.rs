//! The command line's contract with scripts: exit codes (0 success, 2 bad input, 3 a single run
//! that failed or did not reach its target, 4 `collect` with runs missing), one-line errors,
//! options validated whether or not the run uses them, units on every dimensional option, help
//! defaults, and one optimum schema for `optimize` and `optimize-field`.

mod common;

use common::magopt;

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn a_run_that_does_not_reach_its_target_exits_3_and_still_prints_its_json() {
    let (code, stdout, stderr) = magopt(&[
        "align",
        "--model",
        "ensemble",
        "--field",
        "5kOe",
        "--max-time",
        "1s",
        "--json",
    ]);
    assert_eq!(code, 3, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["status"], "not-reached");
    assert!(v["alignment_time_s"].is_null());
    assert!(v["reason"].is_null());
    assert_eq!(v["parameters"]["max_time_s"], 1.0);
}

#[test]
fn a_successful_run_exits_0_with_every_parameter_in_its_json() {
    let (code, stdout, stderr) = magopt(&[
        "align",
        "--model",
        "ensemble",
        "--damping",
        "20N*s/m",
        "--rotation-step",
        "0.05rad",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["status"], "ok");
    assert_eq!(v["parameters"]["field_kOe"], 40.0);
    assert_eq!(v["parameters"]["material"], "srfe12o19");
    assert!(v["parameters"]["wall_friction"].is_null(), "derived: {v}");
    assert!(v["alignment_time_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_input_is_one_line_and_exit_2_even_for_options_the_run_does_not_use() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["align", "--field", "40m"],
            "--field: '40m': unknown unit 'm'",
        ),
        (&["align", "--material", "unobtainium"], "--material: "),
        (
            &["align", "--model", "md"],
            "--model: 'md' is not one of dem, ensemble",
        ),
        (
            &["align", "--target", "1"],
            "--target: 1 is not allowed (need in (0, 1))",
        ),
        (&["align", "--particles", "1e12"], "--particles"),
        (&["blast", "--interactions", "abc"], "--interactions"),
        (
            &["blast", "--drag", "sticky"],
            "quadratic, chow, stokes, none",
        ),
        (&["blast", "--temperature", "300 m"], "--temperature"),
        (
            &["optimize-field", "--scan-points", "1e12"],
            "--scan-points",
        ),
        (&["optimize-field", "--threads", "1000000"], "--threads"),
        (&["optimize-field", "--field", "40kOe"], "--field"),
        (
            &["sweep", "/nonexistent/study.toml"],
            "cannot read study file",
        ),
    ];
    for (args, needle) in cases {
        let (code, stdout, stderr) = magopt(args);
        assert_eq!(code, 2, "{args:?}: {stdout}{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
}

#[test]
fn help_prints_the_models_defaults_units_and_exit_codes() {
    let (code, help, _) = magopt(&["align", "--help"]);
    assert_eq!(code, 0);
    for needle in [
        "[default: 40 kOe]",
        "[default: 0.5 atm]",
        "[default: 20 N*s/m]",
        "[default: 0.05 rad]",
        "[default: same as friction]",
    ] {
        assert!(help.contains(needle), "{needle} in\n{help}");
    }
    let (_, help, _) = magopt(&["bed", "--help"]);
    assert!(help.contains("--friction-model"), "{help}");
    assert!(help.contains("(also: --friction)"), "{help}");
    assert!(help.contains("in units of D1, or a length"), "{help}");
    let (_, help, _) = magopt(&["--help"]);
    assert!(help.contains("Exit codes"), "{help}");
}

#[test]
fn optimize_field_and_optimize_write_one_optimum_schema() {
    let dir = temp_dir("optimum");
    let (code, stdout, stderr) = magopt(&[
        "optimize-field",
        "--model",
        "ensemble",
        "--scan-points",
        "5",
        "--brent-iterations",
        "3",
        "--json",
        "--out",
        dir.join("field").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let field: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        "name = \"opt\"\nmodel = \"align\"\n[base]\nmodel = \"ensemble\"\n[optimize]\n\
         parameters = { field = [\"5kOe\", \"100kOe\"] }\nmetric = \"alignment_time_s\"\n\
         scan_points = 5\niterations = 3\n",
    )
    .unwrap();
    let (code, stdout, stderr) = magopt(&[
        "optimize",
        study.to_str().unwrap(),
        "--json",
        "--out",
        dir.join("opt").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let generic: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let keys = |v: &serde_json::Value| {
        let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    assert_eq!(keys(&field), keys(&generic));
    // the same search on the same model finds the same optimum
    assert_eq!(
        field["optimum"]["field_kOe"],
        generic["optimum"]["field_kOe"]
    );
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("field/optimum.json")).unwrap())
            .unwrap();
    assert_eq!(saved, field);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn collect_with_missing_runs_exits_4_unless_partial_results_are_accepted() {
    let dir = temp_dir("collect");
    std::fs::create_dir_all(&dir).unwrap();
    let study = dir.join("grid.toml");
    std::fs::write(
        &study,
        "name = \"grid\"\nmodel = \"align\"\n[base]\nmodel = \"ensemble\"\n[sweep]\n\
         field = [\"10kOe\", \"20kOe\", \"40kOe\"]\n",
    )
    .unwrap();
    let shard = dir.join("shard0");
    let (code, stdout, stderr) = magopt(&[
        "sweep",
        study.to_str().unwrap(),
        "--shard",
        "0/2",
        "--out",
        shard.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("0 failed or not reached"), "{stdout}");
    let (code, _, stderr) = magopt(&["collect", shard.to_str().unwrap()]);
    assert_eq!(code, 4, "{stderr}");
    assert!(stderr.contains("1 of 3 runs are missing"), "{stderr}");
    let (code, _, stderr) = magopt(&["collect", shard.to_str().unwrap(), "--allow-partial"]);
    assert_eq!(code, 0, "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_reader_that_goes_away_ends_the_run_quietly() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_magopt"))
        .args(["blast", "--particles", "50", "--duration", "0.01s"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader closes the pipe before anything is written
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `align --packing-cache DIR`: the first run settles its packing and stores it, a second run
/// (another field: the packing does not depend on it) loads it, and both give the results of
/// runs without the cache, bit for bit; a damaged file is settled again and replaced.
#[test]
fn a_cached_packing_gives_the_same_run_as_a_settled_one() {
    let dir = temp_dir("packing-cache");
    let cache = dir.to_str().unwrap();
    let run = |field: &str, cached: bool| {
        let mut args = vec!["align", "--particles", "60", "--field", field, "--json"];
        if cached {
            args.extend(["--packing-cache", cache]);
        }
        let (code, stdout, stderr) = magopt(&args);
        assert_eq!(code, 0, "{stderr}");
        let mut v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        v.as_object_mut().unwrap().remove("wall_time_s");
        v
    };
    let files = || std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(run("40", true), run("40", false));
    assert_eq!(files(), 1);
    assert_eq!(run("20", true), run("20", false));
    assert_eq!(files(), 1, "the second field reused the packing");
    let file = std::fs::read_dir(&dir)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    std::fs::write(&file, b"magopt packing 1\ntruncated").unwrap();
    assert_eq!(run("40", true), run("40", false));
    assert!(std::fs::metadata(&file).unwrap().len() > 1000, "replaced");
    std::fs::remove_dir_all(&dir).unwrap();
}
