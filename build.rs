//! Code fingerprint of the physics: a hash of every source file that can change what a run
//! computes (models, analysis, neighbour search, numerics, materials, units, random streams).
//! Saved runs record it, and resume recomputes runs whose fingerprint no longer matches.

use std::path::{Path, PathBuf};

const PHYSICS: &[&str] = &[
    "src/models",
    "src/analysis",
    "src/numerics",
    "src/neighbor.rs",
    "src/materials.rs",
    "src/units.rs",
    "src/rng.rs",
];

fn files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(path)
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        entries.sort();
        for entry in entries {
            files(&entry, out);
        }
    } else if path.extension().is_some_and(|x| x == "rs") {
        out.push(path.to_path_buf());
    }
}

fn main() {
    let mut all = Vec::new();
    for root in PHYSICS {
        println!("cargo:rerun-if-changed={root}");
        files(Path::new(root), &mut all);
    }
    // FNV-1a over each file's path and contents, in a fixed order
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in &all {
        let bytes = std::fs::read(file).unwrap_or_default();
        for b in file.to_string_lossy().bytes().chain(bytes) {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    println!("cargo:rustc-env=MAGOPT_PHYSICS_HASH={hash:016x}");
}
