//! `magopt bench` from the outside: the pair counts and pair-evaluation rates the bed and
//! align benchmarks report (bench/lammps compares them with LAMMPS) are consistent with the
//! steps, the wall time and what each neighbour method sums.

mod common;
use common::magopt;
use serde_json::Value;

/// Runs `magopt bench <args> --out DIR` and returns the JSON rows.
fn bench_rows(name: &str, args: &[&str]) -> Vec<Value> {
    let dir = std::env::temp_dir().join(format!("magopt-bench-{name}-{}", std::process::id()));
    let dir_text = dir.to_str().unwrap().to_string();
    let mut all = vec!["bench"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", &dir_text]);
    let (code, stdout, stderr) = magopt(&all);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    let text = std::fs::read_to_string(dir.join(format!("bench-{}.json", args[0]))).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let json: Value = serde_json::from_str(&text).unwrap();
    json["rows"].as_array().unwrap().clone()
}

fn f(row: &Value, key: &str) -> f64 {
    row[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} in {row}"))
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn bed_pair_counts_match_each_neighbour_method() {
    let rows = bench_rows(
        "bed",
        &[
            "bed",
            "--particles",
            "40",
            "--velocity",
            "1000mm/s",
            "--neighbors",
            "exact,verlet,cells",
            "--threads",
            "1",
        ],
    );
    let [exact, verlet, cells] = [0, 1, 2].map(|k| &rows[k]);
    let n = f(exact, "particles");
    // exact sums: every other particle, each unordered pair once per step in the rate and
    // twice in the kernel's terms
    assert_eq!(f(exact, "pairs_per_particle"), n - 1.0);
    assert_eq!(f(exact, "list_entries_per_particle"), n - 1.0);
    let per_step = n * (n - 1.0) / 2.0 * f(exact, "steps");
    assert!(close(
        f(exact, "pair_evaluations_per_s") * f(exact, "wall_s"),
        per_step,
        1e-9
    ));
    assert!(close(
        f(exact, "kernel_pair_terms_per_s"),
        2.0 * f(exact, "pair_evaluations_per_s"),
        1e-12
    ));
    // a cell list rebuilt every step without skin holds exactly the pairs inside r_c; the
    // Verlet list holds more (its skin) and its count, taken at builds, follows the same
    // trajectory (same pairs summed) within a per cent
    assert_eq!(
        f(cells, "pairs_per_particle"),
        f(cells, "list_entries_per_particle")
    );
    assert_eq!(f(cells, "steps"), f(verlet, "steps"));
    assert!(f(verlet, "list_entries_per_particle") > f(verlet, "pairs_per_particle"));
    assert!(close(
        f(verlet, "pairs_per_particle"),
        f(cells, "pairs_per_particle"),
        0.01
    ));
    let phi = f(verlet, "mean_packing_fraction");
    assert!(phi > 0.0 && phi < 0.9, "{phi}");
}

#[test]
fn align_settling_contacts_are_counted_once_per_pair() {
    let rows = bench_rows(
        "align",
        &[
            "align",
            "--particles",
            "200",
            "--max-steps",
            "2",
            "--threads",
            "1",
            // FIRE in all three stages (the overdamped release reports its force evaluations
            // as its steps)
            "--release",
            "inertial",
        ],
    );
    let row = &rows[0];
    let n = f(row, "particles");
    let contacts = f(row, "settle_contacts_per_particle");
    assert!(contacts > 0.0 && contacts < f(row, "settle_list_entries_per_particle"));
    // each of the three stages evaluates its forces once more than it steps
    let steps: f64 = row["settle_steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_f64().unwrap() + 1.0)
        .sum();
    assert!(close(
        f(row, "settle_contact_evaluations_per_s") * f(row, "settle_s"),
        n * contacts / 2.0 * steps,
        1e-9
    ));
    // stages 1 and 2 alone (what the LAMMPS pour is compared with), within the packing's time
    let stage_s: Vec<f64> = row["settle_stage_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_f64().unwrap())
        .collect();
    let fire = &row["fire_stages"];
    let stage_steps = |k: usize| row["settle_steps"][k].as_f64().unwrap();
    assert_eq!(f(fire, "steps"), stage_steps(0) + stage_steps(1));
    assert!(close(f(fire, "s"), stage_s[0] + stage_s[1], 1e-12));
    assert!(stage_s.iter().all(|&s| s > 0.0) && stage_s.iter().sum::<f64>() <= f(row, "settle_s"));
    // each stage starts a list of its own and builds it at most once per force evaluation
    for k in 0..3 {
        let builds = row["settle_list_builds"][k].as_f64().unwrap();
        assert!(
            (1.0..=stage_steps(k) + 1.0).contains(&builds),
            "stage {k}: {builds}"
        );
    }
    // an inertial release (like any bed below `large_bed_from`) takes no Newton steps
    let newton = &row["release_newton"];
    assert_eq!(newton["steps"].as_u64(), Some(0), "{newton}");
    assert_eq!(newton["solve_s"].as_f64(), Some(0.0), "{newton}");
    let fire_contacts = f(fire, "contacts_per_particle");
    assert!(fire_contacts > 0.0 && fire_contacts < f(fire, "list_entries_per_particle"));
    assert!(close(
        f(fire, "contact_evaluations_per_s") * f(fire, "s"),
        n * fire_contacts / 2.0 * (f(fire, "steps") + 2.0),
        1e-9
    ));
    // The heap's peaks are counted by the binary's allocator: each stage holds at least the
    // bed's centres (24 bytes a particle), and the row's peak is the larger of the two.
    let (packing_heap, alignment_heap) = (
        f(row, "packing_peak_heap_mb"),
        f(row, "alignment_peak_heap_mb"),
    );
    let centres_mb = n * 24.0 / (1024.0 * 1024.0);
    assert!(packing_heap > centres_mb && alignment_heap > centres_mb);
    assert_eq!(f(row, "peak_heap_mb"), packing_heap.max(alignment_heap));
}

/// `bench blast` runs the interacting example once per near-field precision and reports each
/// row's near-field error on its final cloud: zero for the exact sum, positive and below 10⁻⁶
/// for single precision; an unknown precision is a one-line input error (exit 2) before any
/// run.
#[test]
fn blast_rows_report_each_precision_and_its_near_field_error() {
    let args = [
        "blast",
        "--particles",
        "200",
        "--threads",
        "1",
        "--interacting-duration",
        "0.01s",
        "--near-field-precision",
        "double,single",
    ];
    let rows = bench_rows("blast-precision", &args);
    let models: Vec<&str> = rows.iter().map(|r| r["model"].as_str().unwrap()).collect();
    assert_eq!(models, ["free", "interacting double", "interacting single"]);
    assert!(rows[0]["near_field_error_rms"].is_null());
    assert_eq!(f(&rows[1], "near_field_error_rms"), 0.0);
    let single = f(&rows[2], "near_field_error_rms");
    assert!(single > 0.0 && single < 1e-6, "{single}");
    let (code, stdout, stderr) = magopt(&["bench", "blast", "--near-field-precision", "half"]);
    assert_eq!(code, 2, "{stdout}");
    assert!(stdout.is_empty(), "{stdout}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("half"), "{stderr}");
}
