//! The source's qualitative findings for Sr ferrite (spec align.md, "Studies"), asserted as
//! structure, never as tuned numbers: the DEM optimum lies in 20–50 kOe, τ(100 kOe) > τ(40 kOe),
//! τ(10 kOe) clearly above τ(40 kOe); the same without friction and without pressure; friction
//! slows alignment under pressure. Small beds (N = 150, 2 replicates) keep CI fast: the
//! properties hold there already (the single-particle torque law sets the valley).

use magopt::models::align::dem;
use magopt::models::align::study::{AlignModel, AlignSetup};
use magopt::study::model::{StudyModel, Value};
use magopt::study::optimize::optimize;
use magopt::study::spec::Study;
use rayon::prelude::*;

const KOE: f64 = 1e6 / (4.0 * std::f64::consts::PI);

/// The source's setup on a small bed, as a study file with the field free.
fn small_bed(friction: f64, pressure_atm: f64) -> (AlignModel, Study<AlignModel>) {
    let text = format!(
        r#"model = "align"
replicates = 2
seed = 1
[base]
material = "srfe12o19"
particles = 150
friction = {friction:?}
pressure = "{pressure_atm} atm"
[optimize]
parameters = {{ field = ["5kOe", "100kOe"] }}
metric = "alignment_time_s"
scan_points = 7
iterations = 6
"#
    );
    let model = AlignModel::new(magopt::materials::MaterialDb::builtin());
    let study = Study::parse(&model, &text, "regression.toml").unwrap();
    (model, study)
}

fn at_field(model: &AlignModel, base: &AlignSetup, field_koe: f64) -> AlignSetup {
    let mut setup = base.clone();
    model
        .set(
            &mut setup,
            "field",
            &Value::Number(field_koe * KOE),
            "field",
        )
        .unwrap();
    setup
}

/// Mean τ over the replicates (same packings at every field) at one field.
fn mean_tau(model: &AlignModel, study: &Study<AlignModel>, field_koe: f64) -> f64 {
    let setup = at_field(model, &study.base, field_koe);
    let taus: Vec<f64> = (0..study.replicates as u64)
        .into_par_iter()
        .map(|r| {
            model
                .outcome(&setup, study.seed + r)
                .alignment_time_s
                .expect("target reached")
        })
        .collect();
    taus.iter().sum::<f64>() / taus.len() as f64
}

fn assert_source_structure(friction: f64, pressure_atm: f64) {
    let (model, study) = small_bed(friction, pressure_atm);
    let (t10, t40, t100) = (
        mean_tau(&model, &study, 10.0),
        mean_tau(&model, &study, 40.0),
        mean_tau(&model, &study, 100.0),
    );
    assert!(
        t100 > t40,
        "τ(100 kOe) = {t100} must exceed τ(40 kOe) = {t40}"
    );
    assert!(
        t10 > 1.3 * t40,
        "τ(10 kOe) = {t10} must be clearly above τ(40 kOe) = {t40}"
    );
    let optimum = optimize(&model, &study, None, &|| {}).unwrap();
    let at = optimum.best[0] / KOE;
    assert!(
        (20.0..=50.0).contains(&at),
        "optimum {at} kOe outside 20–50 kOe"
    );
}

#[test]
fn sr_ferrite_optimum_with_friction_and_pressure() {
    assert_source_structure(0.2, 0.5);
}

#[test]
fn sr_ferrite_optimum_without_friction() {
    assert_source_structure(0.0, 0.5);
}

#[test]
fn sr_ferrite_optimum_without_pressure() {
    assert_source_structure(0.2, 0.0);
}

#[test]
fn friction_slows_alignment_under_pressure() {
    let (model, study) = small_bed(0.0, 0.5);
    let base = at_field(&model, &study.base, 40.0);
    let packing = model.packing(&base.params, 2);
    let packing = packing.get().unwrap().as_ref().unwrap();
    let tau = |mu: f64| {
        let mut setup = base.clone();
        model
            .set(&mut setup, "friction", &Value::Number(mu), "friction")
            .unwrap();
        dem::align(&setup.params, packing, None)
            .alignment_time_s
            .unwrap()
    };
    let (free, rough) = (tau(0.0), tau(0.5));
    assert!(
        rough > 1.05 * free,
        "τ(μ = 0.5) = {rough} vs τ(μ = 0) = {free}"
    );
}
