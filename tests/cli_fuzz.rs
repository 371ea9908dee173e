//! Generated command lines and study files through the real binary: every one ends with exit
//! code 0, 2 or 3 within a time limit, never a panic, and an error is one line. The runs use the
//! `align` ensemble model, so a valid command line finishes in a fraction of a second.

use proptest::prelude::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Longest any generated command may take.
const LIMIT: Duration = Duration::from_secs(20);

/// Runs magopt with `args`: (exit code, stderr); panics past [`LIMIT`].
fn run(args: &[String]) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_magopt"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            return (status.code().unwrap_or(-1), err);
        }
        if start.elapsed() > LIMIT {
            child.kill().ok();
            panic!("magopt {args:?} ran longer than {LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn check(args: &[String]) {
    let (code, err) = run(args);
    assert!([0, 2, 3].contains(&code), "{args:?}: exit {code}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    if code == 2 {
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}

const FLAGS: &[&str] = &[
    "--field",
    "--pressure",
    "--friction",
    "--wall-friction",
    "--particles",
    "--diameter",
    "--diameter-sigma",
    "--damping",
    "--target",
    "--max-time",
    "--rotation-step",
    "--friction-regularization",
    "--material",
    "--pressure-mode",
    "--seed",
    "--colour",
];

const VALUES: &[&str] = &[
    "-1",
    "0",
    "1e-320",
    "1e308",
    "nan",
    "inf",
    "3",
    "0.5",
    "1e12",
    "40kOe",
    "3T",
    "40m",
    "20N*s/m",
    "0.05rad",
    "1 h",
    "5 s",
    "abc",
    "",
    "ensemble",
    "srfe12o19",
    "source-layer",
    "18446744073709551616",
    "0.95",
    "1um",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn generated_command_lines_end_cleanly(
        picks in proptest::collection::vec((0..FLAGS.len(), 0..VALUES.len()), 0..5)
    ) {
        let mut args: Vec<String> = ["align", "--model", "ensemble", "--json"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        for (f, v) in picks {
            args.push(FLAGS[f].to_string());
            args.push(VALUES[v].to_string());
        }
        check(&args);
    }

    #[test]
    fn generated_study_files_end_cleanly(
        key in 0..FLAGS.len() - 2,
        values in proptest::collection::vec(0..VALUES.len(), 1..4),
        replicates in prop_oneof![Just("1"), Just("0"), Just("1e9"), Just("\"2\"")],
    ) {
        let dir = std::env::temp_dir().join(format!("magopt-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let name = FLAGS[key].trim_start_matches("--").replace('-', "_");
        let list: Vec<String> = values.iter().map(|&v| format!("{:?}", VALUES[v])).collect();
        let text = format!(
            "model = \"align\"\nreplicates = {replicates}\n[base]\nmodel = \"ensemble\"\n\
             [sweep]\n{name} = [{}]\n",
            list.join(", ")
        );
        let study = dir.join("study.toml");
        std::fs::write(&study, text).unwrap();
        let out = dir.join("out");
        let _ = std::fs::remove_dir_all(&out);
        check(&[
            "sweep".into(),
            study.to_string_lossy().into_owned(),
            "--out".into(),
            out.to_string_lossy().into_owned(),
        ]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
