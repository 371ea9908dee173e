//! Resume as a user meets it, through the real process: `kill -9` mid-sweep and resume gives
//! the uninterrupted result; an edited grid reuses exactly the runs whose inputs match and
//! labels every point from the current grid; an edited materials file makes the saved runs
//! stale (recomputed, or kept with --keep-stale); an unreadable run file is set aside; a second
//! sweep into a directory in use is refused. Runs use the `align` ensemble model (≈ 0.1 s).

mod common;

use common::magopt;
use magopt::output::table::{read_parquet, ColumnData, Table};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-resume-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn sweep(study: &Path, out: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    magopt(&args)
}

/// A table without the columns that differ between executions of the same runs.
fn table(dir: &Path, file: &str) -> Table {
    let mut t = read_parquet(&dir.join(file)).unwrap();
    t.columns.retain(|c| c.name != "wall_time_s");
    t
}

fn column<'a>(t: &'a Table, name: &str) -> &'a ColumnData {
    &t.columns.iter().find(|c| c.name == name).unwrap().data
}

const GRID: &str = "name = \"grid\"\nmodel = \"align\"\nreplicates = 2\n\
                    metrics = [\"alignment_time_s\", \"alignment_time_90_s\", \"final_alignment\"]\n\
                    [base]\nmodel = \"ensemble\"\n\
                    [sweep]\nfield = { log = [\"8kOe\", \"90kOe\", 10] }\ntarget = [0.9, 0.95]\n";

#[test]
fn a_sweep_killed_at_any_point_resumes_to_the_uninterrupted_result() {
    let dir = temp_dir("kill");
    let study = dir.join("grid.toml");
    std::fs::write(&study, GRID).unwrap();
    let whole = dir.join("whole");
    assert_eq!(sweep(&study, &whole, &[]).0, 0);
    for (k, after_ms) in [150u64, 600, 1200].into_iter().enumerate() {
        let out = dir.join(format!("killed-{k}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_magopt"))
            .args([
                "sweep",
                study.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(after_ms));
        if k == 0 {
            // while it runs, a second sweep into the same directory is refused
            let (code, _, err) = sweep(&study, &out, &["--resume"]);
            if code == 2 {
                assert!(err.contains("in use by magopt process"), "{err}");
            }
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let (code, _, err) = sweep(&study, &out, &["--resume"]);
        assert_eq!(code, 0, "{err}");
        for file in ["runs.parquet", "series.parquet", "summary.parquet"] {
            let same = table(&whole, file) == table(&out, file);
            assert!(same, "{file} differs after a kill at {after_ms} ms");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_edited_grid_reuses_the_matching_runs_and_labels_points_from_the_current_grid() {
    let dir = temp_dir("grid");
    let study = dir.join("friction.toml");
    let text = |list: &str| {
        format!(
            "name = \"friction\"\nmodel = \"align\"\nreplicates = 2\n[base]\nmodel = \"ensemble\"\n\
             [sweep]\nfriction = [{list}]\n"
        )
    };
    std::fs::write(&study, text("0.0, 0.1, 0.2")).unwrap();
    let out = dir.join("out");
    assert_eq!(sweep(&study, &out, &[]).0, 0);
    std::fs::write(&study, text("0.05, 0.0, 0.1, 0.2")).unwrap();
    let (code, stdout, err) = sweep(&study, &out, &["--resume"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        stdout.contains("2 runs done now, 6 were already done"),
        "{stdout}"
    );
    let summary = table(&out, "summary.parquet");
    assert_eq!(
        column(&summary, "friction"),
        &ColumnData::F64(vec![0.05, 0.0, 0.1, 0.2])
    );
    assert_eq!(
        column(&summary, "point"),
        &ColumnData::U64(vec![0, 1, 2, 3])
    );
    let runs = table(&out, "runs.parquet");
    assert_eq!(
        column(&runs, "point"),
        &ColumnData::U64(vec![0, 0, 1, 1, 2, 2, 3, 3])
    );
    // the same value written twice (after unit conversion) is one point, named as an error
    std::fs::write(&study, text("0.1, 0.10")).unwrap();
    let (code, _, err) = sweep(&study, &dir.join("twice"), &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("the same run"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_edited_materials_file_makes_saved_runs_stale() {
    let dir = temp_dir("materials");
    let materials = dir.join("materials.toml");
    let material = |k: &str| {
        format!(
            "[[material]]\nname = \"myferrite\"\nsaturation_magnetization = \"380 emu/cm3\"\n\
             anisotropy_constant = \"{k}\"\nyoungs_modulus = \"1.8e11 Pa\"\npoisson_ratio = 0.28\n\
             density = \"5100 kg/m3\"\n"
        )
    };
    std::fs::write(&materials, material("3.5e6 erg/cm3")).unwrap();
    let study = dir.join("m.toml");
    std::fs::write(
        &study,
        "name = \"m\"\nmodel = \"align\"\n[base]\nmodel = \"ensemble\"\nmaterial = \"myferrite\"\n\
         [sweep]\nfield = [\"20kOe\", \"40kOe\"]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let m = materials.to_str().unwrap();
    assert_eq!(sweep(&study, &out, &["--materials", m]).0, 0);
    let tau = |dir: &Path| column(&table(dir, "runs.parquet"), "alignment_time_s").clone();
    let before = tau(&out);
    std::fs::write(&materials, material("1.5e6 erg/cm3")).unwrap();
    let (code, stdout, err) = sweep(&study, &out, &["--materials", m, "--resume"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("2 saved runs were stale and recomputed"),
        "{err}"
    );
    assert!(err.contains("anisotropy_constant"), "{err}");
    assert!(
        stdout.contains("2 runs done now, 0 were already done"),
        "{stdout}"
    );
    assert_ne!(tau(&out), before, "a weaker anisotropy changes τ");
    let fresh = dir.join("fresh");
    assert_eq!(sweep(&study, &fresh, &["--materials", m]).0, 0);
    assert_eq!(
        tau(&out),
        tau(&fresh),
        "the resumed result is the fresh one"
    );
    assert_eq!(
        std::fs::read_dir(out.join("runs/stale")).unwrap().count(),
        2
    );
    // --keep-stale keeps them and says so in the provenance
    std::fs::write(&materials, material("3.5e6 erg/cm3")).unwrap();
    let (code, _, err) = sweep(
        &study,
        &out,
        &["--materials", m, "--resume", "--keep-stale"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("kept (--keep-stale)"), "{err}");
    let provenance: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("provenance.json")).unwrap())
            .unwrap();
    assert_eq!(provenance["resume"]["stale_kept"], true);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_unreadable_run_file_is_set_aside_and_recomputed() {
    let dir = temp_dir("corrupt");
    let study = dir.join("grid.toml");
    std::fs::write(&study, GRID).unwrap();
    let out = dir.join("out");
    assert_eq!(sweep(&study, &out, &[]).0, 0);
    let whole = table(&out, "runs.parquet");
    let victim = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "json"))
        .unwrap();
    std::fs::write(&victim, "{\"truncated").unwrap();
    let (code, stdout, err) = sweep(&study, &out, &["--resume"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("moved to runs/unreadable/"), "{err}");
    assert!(stdout.contains("1 runs done now"), "{stdout}");
    assert!(table(&out, "runs.parquet") == whole, "runs.parquet differs");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_run_saved_by_another_build_of_its_model_is_stale() {
    let dir = temp_dir("code");
    let study = dir.join("grid.toml");
    std::fs::write(&study, GRID).unwrap();
    let out = dir.join("out");
    assert_eq!(sweep(&study, &out, &[]).0, 0);
    let read = |path: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let code = read(&out.join("provenance.json"))["code"]
        .as_str()
        .unwrap()
        .to_string();
    // one saved run as another build of the align physics would have left it: another
    // fingerprint, hence another id
    let saved = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "json"))
        .unwrap();
    let mut record = read(&saved);
    assert_eq!(
        record["code"],
        code.as_str(),
        "a run records its model's fingerprint"
    );
    record["code"] = "0.0.0+0123456789abcdef".into();
    record["id"] = "00000000deadbeef".into();
    std::fs::remove_file(&saved).unwrap();
    std::fs::write(
        out.join("runs/00000000deadbeef.json"),
        serde_json::to_string(&record).unwrap(),
    )
    .unwrap();
    let (rc, stdout, err) = sweep(&study, &out, &["--resume"]);
    assert_eq!(rc, 0, "{err}");
    assert!(
        err.contains("1 saved runs were stale and recomputed"),
        "{err}"
    );
    assert!(
        err.contains(&format!("code 0.0.0+0123456789abcdef is now {code}")),
        "{err}"
    );
    assert!(stdout.contains("1 runs done now"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}
