//! The source's qualitative findings for Sr ferrite (spec align.md, "Studies"), asserted as
//! structure, never as tuned numbers: the DEM optimum lies in 20–50 kOe, τ(100 kOe) > τ(40 kOe),
//! τ(10 kOe) clearly above τ(40 kOe); the same without friction and without pressure; friction
//! slows alignment under pressure. Small beds (N = 150, 2 replicates) keep CI fast: the
//! properties hold there already (the single-particle torque law sets the valley).

use magopt::materials::MaterialDb;
use magopt::models::align::dem::{self, Packing};
use magopt::models::align::field_search::FieldSearch;
use magopt::models::align::{AlignParams, ModelKind};
use magopt::optimize::Settings;
use magopt::units::si_per_unit;

const KOE: f64 = 1e6 / (4.0 * std::f64::consts::PI);

fn small_bed(friction: f64, pressure_atm: f64) -> AlignParams {
    let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
    let mut p = AlignParams::paper_defaults(material, 40.0 * KOE);
    p.particles = 150;
    p.friction = friction;
    p.wall_friction = friction;
    p.pressure = pressure_atm * si_per_unit("atm");
    p
}

fn search(params: AlignParams) -> FieldSearch {
    FieldSearch {
        base: params,
        model: ModelKind::Dem,
        replicates: 2,
        seed: 1,
        settings: Settings {
            lower: 5.0 * KOE,
            upper: 100.0 * KOE,
            scan_points: 7,
            brent_iterations: 6,
            rel_tolerance: 1e-3,
            band: 0.02,
        },
    }
}

/// Mean τ over the search's replicates at one field.
fn mean_tau(s: &FieldSearch, packings: &[Result<Packing, String>], field_koe: f64) -> f64 {
    let runs = s.evaluate(field_koe * KOE, packings, &|| {});
    runs.iter()
        .map(|r| r.outcome.alignment_time_s.expect("target reached"))
        .sum::<f64>()
        / runs.len() as f64
}

fn assert_source_structure(params: AlignParams) {
    let s = search(params);
    let packings = s.packings(&|| {});
    let (t10, t40, t100) = (
        mean_tau(&s, &packings, 10.0),
        mean_tau(&s, &packings, 40.0),
        mean_tau(&s, &packings, 100.0),
    );
    assert!(
        t100 > t40,
        "τ(100 kOe) = {t100} must exceed τ(40 kOe) = {t40}"
    );
    assert!(
        t10 > 1.3 * t40,
        "τ(10 kOe) = {t10} must be clearly above τ(40 kOe) = {t40}"
    );
    let optimum = s.run(&|| {}, |_| {}).optimum;
    let at = optimum.x / KOE;
    assert!(
        (20.0..=50.0).contains(&at),
        "optimum {at} kOe outside 20–50 kOe"
    );
}

#[test]
fn sr_ferrite_optimum_with_friction_and_pressure() {
    assert_source_structure(small_bed(0.2, 0.5));
}

#[test]
fn sr_ferrite_optimum_without_friction() {
    assert_source_structure(small_bed(0.0, 0.5));
}

#[test]
fn sr_ferrite_optimum_without_pressure() {
    assert_source_structure(small_bed(0.2, 0.0));
}

#[test]
fn friction_slows_alignment_under_pressure() {
    let params = small_bed(0.0, 0.5);
    let packing = Packing::generate(&params.packing(), 2).unwrap();
    let tau = |mu: f64| {
        let mut p = params.clone();
        p.friction = mu;
        p.wall_friction = mu;
        dem::align(&p, &packing).alignment_time_s.unwrap()
    };
    let (free, rough) = (tau(0.0), tau(0.5));
    assert!(
        rough > 1.05 * free,
        "τ(μ = 0.5) = {rough} vs τ(μ = 0) = {free}"
    );
}
