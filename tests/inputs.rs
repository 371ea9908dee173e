//! The input contract as data: every file in `tests/inputs/good/` is accepted, every file in
//! `tests/inputs/bad/` is refused with exactly the one-line message its first line states
//! (`# expect: …`), and every shipped study in `studies/` parses and checks at every point.
//! The file name's prefix says what it is: `study-`, `materials-` or `species-`.

use magopt::materials::MaterialDb;
use magopt::models::align::study::AlignModel;
use magopt::models::analytic::study::AnalyticModel;
use magopt::models::bed::study::{load_species, BedModel};
use magopt::models::blast::study::BlastModel;
use magopt::study::model::StudyModel;
use magopt::study::spec::{model_name, Study};
use std::path::{Path, PathBuf};

fn files(dir: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

/// Parses a study with the model it names and checks every grid point.
fn study<M: StudyModel>(model: &M, text: &str, origin: &str) -> magopt::Result<usize> {
    let study = Study::parse(model, text, origin)?;
    for point in study.points() {
        study.params_at(model, &point)?;
    }
    Ok(study.points().len())
}

/// Reads one input file the way magopt reads it; the error as magopt prints it.
fn read(path: &Path) -> Result<(), String> {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let text = std::fs::read_to_string(path).unwrap();
    let result = if name.starts_with("study-") {
        model_name(&text, &name)
            .and_then(|m| match m.as_str() {
                "align" => study(&AlignModel::new(MaterialDb::builtin()), &text, &name),
                "bed" => study(&BedModel::cycle(), &text, &name),
                "damper" => study(&BedModel::damper(), &text, &name),
                "blast" => study(&BlastModel, &text, &name),
                "analytic" => study(&AnalyticModel, &text, &name),
                other => Err(magopt::Error::input(format!(
                    "{name}: model: '{other}' is not available (available: align, bed, damper, \
                 blast, analytic)"
                ))),
            })
            .map(|_| ())
    } else if name.starts_with("materials-") {
        MaterialDb::builtin().load_file(path)
    } else if name.starts_with("species-") {
        load_species(&path.to_string_lossy()).map(|_| ())
    } else {
        panic!("{name}: the name must start with study-, materials- or species-");
    };
    result.map_err(|e| {
        let message = e.to_string();
        let dir = path.parent().unwrap().to_string_lossy().into_owned();
        message.replace(&format!("{dir}/"), "")
    })
}

#[test]
fn good_inputs_are_accepted() {
    let good = files("tests/inputs/good");
    assert!(good.len() >= 5);
    for path in good {
        if let Err(e) = read(&path) {
            panic!("{}: {e}", path.display());
        }
    }
}

#[test]
fn bad_inputs_are_refused_with_their_one_line_message() {
    let bad = files("tests/inputs/bad");
    assert!(bad.len() >= 30);
    // every file is checked before failing, so one run lists every message that changed
    let mut wrong = Vec::new();
    for path in bad {
        let text = std::fs::read_to_string(&path).unwrap();
        let expected = text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("# expect: "))
            .unwrap_or_else(|| panic!("{}: first line must be '# expect: …'", path.display()));
        match read(&path) {
            Ok(()) => wrong.push(format!("{} was accepted", path.display())),
            Err(message) if message.contains('\n') || message != expected => {
                wrong.push(format!("{}\n  got:      {message}", path.display()));
            }
            Err(_) => {}
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn every_shipped_study_parses_and_checks() {
    let mut checked = 0;
    for dir in ["studies", "studies/quick"] {
        for path in files(dir) {
            let text = std::fs::read_to_string(&path).unwrap();
            let name = path.display().to_string();
            let result = match model_name(&text, &name).unwrap().as_str() {
                "align" => study(&AlignModel::new(MaterialDb::builtin()), &text, &name),
                "bed" => study(&BedModel::cycle(), &text, &name),
                "damper" => study(&BedModel::damper(), &text, &name),
                "blast" => study(&BlastModel, &text, &name),
                "analytic" => study(&AnalyticModel, &text, &name),
                other => panic!("{name}: unknown model {other}"),
            };
            if let Err(e) = result {
                panic!("{name}: {e}");
            }
            checked += 1;
        }
    }
    assert!(checked >= 40, "{checked} study files");
}
