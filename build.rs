//! Code fingerprints of the physics: for each model under `src/models/<model>/`, a hash of its
//! own sources and of every shared source file that can change what a run computes (analysis,
//! neighbour search, numerics, materials, units, random streams, `src/models/*.rs`). Saved runs
//! record their model's fingerprint, and resume recomputes runs whose fingerprint no longer
//! matches; a change to one model leaves the other models' saved runs valid. No model imports
//! another (test `study::fingerprint::tests::no_model_imports_another`).

use std::path::{Path, PathBuf};

/// Sources every model depends on, besides the model directories under `src/models`.
const SHARED: &[&str] = &[
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

/// FNV-1a over each file's path and contents, in the given order.
fn fingerprint(all: &[PathBuf]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in all {
        let bytes = std::fs::read(file).unwrap_or_default();
        for b in file.to_string_lossy().bytes().chain(bytes) {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}

fn main() {
    let mut shared = Vec::new();
    for root in SHARED.iter().copied().chain(["src/models"]) {
        println!("cargo:rerun-if-changed={root}");
    }
    for root in SHARED {
        files(Path::new(root), &mut shared);
    }
    let mut models = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir("src/models")
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    entries.sort();
    for entry in entries {
        if entry.is_dir() {
            models.push(entry);
        } else {
            files(&entry, &mut shared);
        }
    }
    let mut table = String::from(
        "/// Each model directory's code fingerprint (build.rs).\n\
         pub const MODEL_FINGERPRINTS: &[(&str, &str)] = &[\n",
    );
    for dir in models {
        let mut all = shared.clone();
        files(&dir, &mut all);
        let name = dir.file_name().unwrap_or_default().to_string_lossy();
        let hash = fingerprint(&all);
        table.push_str(&format!("    (\"{name}\", \"{hash:016x}\"),\n"));
    }
    table.push_str("];\n");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default());
    std::fs::write(out.join("fingerprints.rs"), table).expect("build.rs: cannot write OUT_DIR");
}
