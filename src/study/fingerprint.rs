//! Code fingerprints: which build of a model's physics computed a run. build.rs hashes each
//! model directory `src/models/<dir>/` together with the shared physics sources; a run records
//! its model's fingerprint, its id hashes it, and resume recomputes a saved run whose
//! fingerprint differs. A change to one model leaves the other models' saved runs valid.

use super::records::VERSION;

include!(concat!(env!("OUT_DIR"), "/fingerprints.rs"));

/// The fingerprint of the model whose sources are `src/models/<dir>/`: the version and the
/// hash of those and the shared sources ("unknown" for a directory build.rs did not see, which
/// test `every_model_has_a_fingerprint` rules out for the shipped models).
pub fn code(dir: &str) -> String {
    let hash = MODEL_FINGERPRINTS
        .iter()
        .find(|(d, _)| *d == dir)
        .map_or("unknown", |(_, h)| h);
    format!("{VERSION}+{hash}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::{align, analytic, bed, blast};
    use crate::study::model::StudyModel;

    #[test]
    fn every_model_has_a_fingerprint() {
        let dirs = [
            <align::study::AlignModel as StudyModel>::SOURCES,
            <analytic::study::AnalyticModel as StudyModel>::SOURCES,
            <bed::study::BedModel as StudyModel>::SOURCES,
            <blast::study::BlastModel as StudyModel>::SOURCES,
        ];
        for dir in dirs {
            assert!(!code(dir).ends_with("unknown"), "{dir}");
        }
        let codes: std::collections::HashSet<String> = dirs.iter().map(|d| code(d)).collect();
        assert_eq!(codes.len(), dirs.len(), "each model its own fingerprint");
    }

    /// The per-model fingerprint is sound only while no model's sources use another model's:
    /// a model directory may name only itself under `crate::models::`.
    #[test]
    fn no_model_imports_another() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/models");
        let models: Vec<String> = MODEL_FINGERPRINTS
            .iter()
            .map(|(d, _)| d.to_string())
            .collect();
        for dir in &models {
            for file in rust_files(&root.join(dir)) {
                let text = std::fs::read_to_string(&file).unwrap();
                for other in models.iter().filter(|m| *m != dir) {
                    for pattern in [format!("models::{other}"), format!("super::super::{other}")] {
                        assert!(
                            !text.contains(&pattern),
                            "{} uses {pattern}",
                            file.display()
                        );
                    }
                }
            }
        }
    }

    fn rust_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
        let mut out = Vec::new();
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                out.extend(rust_files(&path));
            } else if path.extension().is_some_and(|x| x == "rs") {
                out.push(path);
            }
        }
        out
    }
}
