//! Helpers shared by the integration tests.

use std::process::Command;

/// Runs the magopt binary with `args`: (exit code, stdout, stderr).
pub fn magopt(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_magopt"))
        .args(args)
        .output()
        .expect("the magopt binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
