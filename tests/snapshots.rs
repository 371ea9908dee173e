//! Particle frames from the outside: every model writes its moments and the frames a schedule
//! asks for (command line and study files), the frames hold what they claim (align: the mean
//! of cos θ is the run's alignment degree; moments are M_s V), every format reads back the same
//! frame, and impossible schedules are one-line errors with exit code 2 before any work.

mod common;
use common::magopt;

use std::path::{Path, PathBuf};

use magopt::output::particles::{
    read_lammps_dump, read_particle_table, read_vtk, read_xyz, ParticleFrame, Values,
};

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("magopt-snap-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    dir
}

fn text(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The frames of a multi-frame extended XYZ file.
fn frames(path: &Path) -> Vec<ParticleFrame> {
    let t = text(path);
    (0..)
        .map_while(|k| read_xyz(&t, k).ok())
        .collect::<Vec<_>>()
}

fn scalar<'a>(frame: &'a ParticleFrame, name: &str) -> &'a [f64] {
    match &frame.extra.iter().find(|p| p.name == name).unwrap().values {
        Values::Scalar(v) => v,
        Values::Vector(_) => panic!("{name} is a vector"),
    }
}

fn vector<'a>(frame: &'a ParticleFrame, name: &str) -> &'a [nalgebra::Vector3<f64>] {
    match &frame.extra.iter().find(|p| p.name == name).unwrap().values {
        Values::Vector(v) => v,
        Values::Scalar(_) => panic!("{name} is a scalar"),
    }
}

/// The steps of the scheduled frames, from their LAMMPS dumps.
fn dump_steps(dir: &Path) -> Vec<u64> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("frame.") && n.ends_with(".dump"))
        .collect();
    names.sort();
    names
        .iter()
        .map(|n| {
            let t = text(&dir.join(n));
            let at = t.lines().position(|l| l == "ITEM: TIMESTEP").unwrap();
            t.lines().nth(at + 1).unwrap().parse().unwrap()
        })
        .collect()
}

#[test]
fn align_frames_hold_the_alignment_and_the_moments() {
    let dir = temp("align");
    let (code, json, err) = magopt(&[
        "align",
        "--particles",
        "150",
        "--out",
        dir.to_str().unwrap(),
        "--snapshot-every",
        "7",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let run: serde_json::Value = serde_json::from_str(&json).unwrap();
    let snaps = dir.join("snapshots");
    let end = read_xyz(&text(&snaps.join("end.xyz")), 0).unwrap();
    let cos = scalar(&end, "cos_theta");
    let mean = cos.iter().sum::<f64>() / cos.len() as f64;
    let a = run["final_alignment"].as_f64().unwrap();
    assert!((mean - a).abs() < 1e-12, "⟨cos θ⟩ = {mean}, A = {a}");
    // |m| = M_s V with one M_s for every particle; easy axes are unit vectors.
    let ms: Vec<f64> = vector(&end, "moment")
        .iter()
        .zip(&end.radius)
        .map(|(m, r)| m.norm() / (4.0 / 3.0 * std::f64::consts::PI * r.powi(3)))
        .collect();
    assert!(ms.iter().all(|x| (x / ms[0] - 1.0).abs() < 1e-9), "{ms:?}");
    assert!((ms[0] - 380e3).abs() < 1.0, "Sr ferrite M_s = 380 emu/cm³");
    assert!(vector(&end, "easy_axis")
        .iter()
        .all(|n| (n.norm() - 1.0).abs() < 1e-12));
    // Scheduled frames at steps 0, 7, 14, …; start + frames + end in the trajectory.
    let steps = dump_steps(&snaps);
    let taken = run["steps"].as_f64().unwrap() as u64;
    let expected: Vec<u64> = (0..=taken).filter(|s| s % 7 == 0).collect();
    assert_eq!(steps, expected);
    assert_eq!(frames(&snaps.join("trajectory.xyz")).len(), steps.len() + 2);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bed_frames_serve_each_time_once_at_the_first_step_after_it() {
    let dir = temp("bed");
    let times = [0.5, 1.0, 2.5];
    let (code, _, err) = magopt(&[
        "bed",
        "--particles",
        "24",
        "--out",
        dir.to_str().unwrap(),
        "--snapshot-times",
        "0.5 s, 1000 ms, 2.5",
        "--snapshot-format",
        "xyz",
    ]);
    assert_eq!(code, 0, "{err}");
    let snaps = dir.join("snapshots");
    for (k, t) in times.iter().enumerate() {
        let frame = read_xyz(&text(&snaps.join(format!("frame.{k:05}.xyz"))), 0).unwrap();
        // a time reached up to round-off counts (`Snapshots::due`): 2500 steps of 1 ms sum to
        // 2.4999999999998
        assert!(
            frame.time >= t * (1.0 - 1e-12) && frame.time < t + 0.01,
            "{} for {t}",
            frame.time
        );
    }
    assert!(!snaps.join("frame.00003.xyz").exists());
    assert!(
        !snaps.join("frame.00000.dump").exists(),
        "only xyz asked for"
    );
    let all = frames(&snaps.join("trajectory.xyz"));
    assert_eq!(all.len(), 3 + 3, "three times and three moments");
    assert!(
        all.windows(2).all(|w| w[0].time <= w[1].time),
        "in time order"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn blast_frames_land_on_times_and_strides_and_read_back_in_every_format() {
    let dir = temp("blast");
    let (code, _, err) = magopt(&[
        "blast",
        "--particles",
        "60",
        "--duration",
        "0.1",
        "--out",
        dir.to_str().unwrap(),
        "--snapshot-every",
        "250",
        "--snapshot-times",
        "0.0333",
    ]);
    assert_eq!(code, 0, "{err}");
    let snaps = dir.join("snapshots");
    // Δt = 1e-4 s: steps 0, 250, 333 (t = 0.0333 s exactly), 500, 750, 1000.
    assert_eq!(dump_steps(&snaps), vec![0, 250, 333, 500, 750, 1000]);
    let at = read_xyz(&text(&snaps.join("frame.00002.xyz")), 0).unwrap();
    assert_eq!(at.time, 0.0333);
    let xyz = read_xyz(&text(&snaps.join("middle.xyz")), 0).unwrap();
    let mut plain = xyz.clone();
    plain.extra.iter_mut().for_each(|p| p.unit.clear());
    assert_eq!(
        read_lammps_dump(&text(&snaps.join("middle.dump"))).unwrap(),
        plain
    );
    assert_eq!(read_vtk(&text(&snaps.join("middle.vtk"))).unwrap(), plain);
    assert_eq!(
        read_particle_table(&snaps.join("middle.parquet")).unwrap(),
        xyz
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn study_files_snapshot_every_run_and_resume_sees_a_changed_schedule() {
    let dir = temp("study");
    std::fs::create_dir_all(&dir).unwrap();
    let study = dir.join("s.toml");
    let write = |every: u32| {
        let body = format!(
            "name = \"s\"\nmodel = \"blast\"\nreplicates = 2\n[base]\nparticles = 20\n\
             duration = \"0.05 s\"\n[snapshots]\nevery = {every}\nformats = [\"xyz\"]\n"
        );
        std::fs::write(&study, body).unwrap();
    };
    write(100);
    let out = dir.join("out");
    let args = [
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let (code, _, err) = magopt(&args);
    assert_eq!(code, 0, "{err}");
    let run_dirs = |d: &Path| -> Vec<PathBuf> {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir() && p.file_name().unwrap() != "stale")
            .collect()
    };
    let runs = run_dirs(&out.join("runs"));
    assert_eq!(runs.len(), 2);
    for run in &runs {
        // start, 0, 100, 200, 300, 400, 500 (the end), middle, end: 9 frames.
        assert_eq!(frames(&run.join("snapshots/trajectory.xyz")).len(), 9);
        assert!(run.with_extension("json").exists());
    }
    write(250);
    let mut resume = args.to_vec();
    resume.push("--resume");
    let (code, _, err) = magopt(&resume);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("stale"), "{err}");
    assert_eq!(
        run_dirs(&out.join("runs/stale")).len(),
        2,
        "old frames set aside"
    );
    for run in run_dirs(&out.join("runs")) {
        assert_eq!(frames(&run.join("snapshots/trajectory.xyz")).len(), 3 + 3);
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn impossible_schedules_are_refused_before_any_work() {
    let dir = temp("bad");
    let out = dir.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["bed", "--snapshot-every", "0"], "--snapshot-every: '0'"),
        (&["bed", "--snapshot-every", "-3"], "--snapshot-every: '-3'"),
        (&["bed", "--snapshot-times=-1"], "need times ≥ 0 s"),
        (
            &["bed", "--snapshot-times", "1 h"],
            "beyond the end of the run",
        ),
        (&["bed", "--snapshot-times", "1 m"], "--snapshot-times"),
        (
            &["bed", "--snapshot-format", "pdb"],
            "not a snapshot format",
        ),
        (&["blast", "--snapshot-every", "1"], "limit 10000"),
        (
            &["align", "--model", "ensemble", "--snapshot-every", "2"],
            "no particles",
        ),
    ];
    for (args, expected) in cases {
        let mut all = args.to_vec();
        all.extend(["--out", out]);
        let (code, stdout, err) = magopt(&all);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            stdout.is_empty() && err.lines().count() == 1,
            "{args:?}: {err}"
        );
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!dir.exists(), "{args:?} created its output directory");
    }
    let (code, _, err) = magopt(&["bed", "--snapshot-every", "5"]);
    assert_eq!(code, 2);
    assert!(err.contains("need --out"), "{err}");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("snapshots"), "a file").unwrap();
    let (code, _, err) = magopt(&["bed", "--particles", "12", "--out", out]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not writable"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}
