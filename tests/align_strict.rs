//! The spec's strict test of the DEM (spec align.md, "Studies from the paper"; issue 12 item 8):
//! with μ = 0 the rotation of each particle decouples from its contacts, so each DEM sample's
//! A(t) equals the non-interacting ensemble of the same particles (sizes and axes), integrated
//! by the same scheme and step, to round-off, whatever the pressure and its mode. With P = 0
//! and μ > 0 friction can act only through normal forces: those stage 3's overlap tolerance
//! leaves, and the particles' true weights. Without both, μ > 0 gives μ = 0 bit for bit.

use magopt::materials::MaterialDb;
use magopt::models::align::dem::integrator::time_step;
use magopt::models::align::dem::torque::reduced_anisotropy;
use magopt::models::align::dem::{self, magnetic_torque, Packing};
use magopt::models::align::{
    AlignOutcome, AlignParams, FrictionScheme, PressureMode, ReleaseScheme,
};
use magopt::units::si_per_unit;
use nalgebra::UnitQuaternion;

fn params(friction: f64, pressure_atm: f64, mode: PressureMode) -> AlignParams {
    let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
    let mut p = AlignParams::paper_defaults(material, 40.0 * si_per_unit("kOe"));
    p.particles = 80;
    p.friction = friction;
    p.wall_friction = friction;
    p.pressure = pressure_atm * 101_325.0;
    p.pressure_mode = mode;
    p
}

/// A(t) after each of `steps` Heun steps of every particle turning alone (r² ω = T, reduced
/// units), with the DEM's step and the DEM's update q ← exp(ω dt) q.
fn lone_particles(params: &AlignParams, packing: &Packing, steps: usize) -> Vec<f64> {
    let dt = time_step(params, packing);
    let (k_red, h) = (reduced_anisotropy(params), params.reduced_field());
    let mut q = packing.orientation.clone();
    let mut series = vec![dem::alignment_degree(&q)];
    let omega = |q: &UnitQuaternion<f64>, r: f64| {
        let kv = k_red * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        magnetic_torque(q, kv, h) / (r * r)
    };
    for _ in 0..steps {
        for (qi, &r) in q.iter_mut().zip(&packing.radius) {
            let a = omega(qi, r);
            let predicted = UnitQuaternion::from_scaled_axis(dt * a) * *qi;
            let predicted = UnitQuaternion::new_normalize(predicted.into_inner());
            let b = omega(&predicted, r);
            let turned = UnitQuaternion::from_scaled_axis(dt * (0.5 * (a + b))) * *qi;
            *qi = UnitQuaternion::new_normalize(turned.into_inner());
        }
        series.push(dem::alignment_degree(&q));
    }
    series
}

/// Largest |A_DEM(t) − A_reference(t)| over the DEM's (thinned) series.
fn largest_gap(out: &AlignOutcome, reference: &[f64]) -> f64 {
    out.series
        .iter()
        .map(|&(t, a)| {
            let step = (t / out.time_step_s).round() as usize;
            (a - reference[step]).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn frictionless_dem_is_the_lone_particle_ensemble_to_round_off() {
    let packing = Packing::generate(&params(0.0, 0.0, PressureMode::Punch).packing(), 4).unwrap();
    for (pressure, mode) in [
        (0.0, PressureMode::ExposedLayer),
        (5.0, PressureMode::ExposedLayer),
        (5.0, PressureMode::SourceLayer),
        (5.0, PressureMode::Punch),
    ] {
        let p = params(0.0, pressure, mode);
        let out = dem::align(&p, &packing, None);
        assert!(out.alignment_time_s.is_some());
        let reference = lone_particles(&p, &packing, out.steps);
        let gap = largest_gap(&out, &reference);
        assert!(gap < 1e-13, "P = {pressure} atm {mode:?}: |ΔA| = {gap:e}");
    }
    // the Coulomb-limit solve too: with μ = 0 its friction forces stay zero
    let mut p = params(0.0, 5.0, PressureMode::Punch);
    p.numerics.friction_scheme = FrictionScheme::CoulombLimit;
    let out = dem::align(&p, &packing, None);
    let gap = largest_gap(&out, &lone_particles(&p, &packing, out.steps));
    assert!(gap < 1e-13, "Coulomb limit, punch: |ΔA| = {gap:e}");
}

/// Largest |A(t)| difference between μ = 0.5 and μ = 0 at P = 0, on one packing released by
/// `release`, with stage 3's overlap tolerance δ_tol, the velocity solver's tolerance, and
/// gravity scaled by `g_scale`. The sweep cap is raised for the tight solver tolerances; at the
/// default tolerance no solve reaches the default cap, so that case gives the same bits as the
/// default numerics.
fn friction_gap_without_pressure(
    release: ReleaseScheme,
    overlap_tolerance: f64,
    solver_tolerance: f64,
    g_scale: f64,
) -> f64 {
    let mut base = params(0.0, 0.0, PressureMode::ExposedLayer);
    base.numerics.release_scheme = release;
    base.numerics.overlap_tolerance = overlap_tolerance;
    base.numerics.solver_tolerance = solver_tolerance;
    base.numerics.max_sweeps = 100_000;
    base.material.density *= g_scale;
    let packing = Packing::generate(&base.packing(), 4).unwrap();
    let frictionless = dem::align(&base, &packing, None);
    let mut rubbing = base.clone();
    rubbing.friction = 0.5;
    rubbing.wall_friction = 0.5;
    let rubbing = dem::align(&rubbing, &packing, None);
    frictionless
        .series
        .iter()
        .zip(&rubbing.series)
        .map(|(a, b)| (a.1 - b.1).abs())
        .fold(0.0, f64::max)
}

/// P = 0, μ = 0.5 against μ = 0. Friction needs a normal force, and with P = 0 only two remain:
/// the contact forces stage 3 leaves (its overlaps relax down to δ_tol, forces ~k δ_tol^{3/2})
/// and the true weights (~1e-12 of the contact force scale). Each is taken away in turn:
/// - default numerics (δ_tol 1e-5, solver 1e-4, the overdamped release): |ΔA| ≈ 2.3e-3,
///   shrinking with δ_tol (the inertial release, whose bed has lost most of its contacts:
///   8e-5);
/// - without gravity and with the overlaps relaxed to 1e-14 R_av, no contact carries friction,
///   every particle turns alone, and μ = 0.5 gives the frictionless A(t) to round-off (measured:
///   identical bits);
/// - with true gravity the weights' friction stays: |ΔA| ≈ 8e-10, growing with g (measured:
///   × 2.4–2.5 per doubling, 0.5 g to 4 g); that is the spec's "no contact forces with P = 0",
///   which holds only up to the weights.
///
/// The last two beds are released by FIRE (`inertial`), whose inertia opens the contacts: the
/// overdamped release approaches touching from above, and overlaps of 1e-12–1e-14 R_av are a
/// few units in the last place of the positions, below what its curvature probe resolves.
#[test]
fn friction_without_pressure_acts_only_through_residual_overlaps_and_weights() {
    let default = ReleaseScheme::Overdamped;
    let (coarse, fine) = (
        friction_gap_without_pressure(default, 1e-5, 1e-4, 1.0),
        friction_gap_without_pressure(default, 1e-6, 1e-4, 1.0),
    );
    println!("P = 0: μ = 0.5 against μ = 0: |ΔA| = {coarse:e} (δ_tol 1e-5), {fine:e} (1e-6)");
    assert!(coarse > 10.0 * fine, "{coarse:e} vs {fine:e}");

    let opened = ReleaseScheme::Inertial;
    let weightless = friction_gap_without_pressure(opened, 1e-14, 1e-12, 0.0);
    println!("no gravity, δ_tol 1e-14: |ΔA| = {weightless:e}");
    assert!(
        weightless < 1e-14,
        "friction acted without normal forces: {weightless:e}"
    );

    let weights: Vec<f64> = [1.0, 2.0]
        .iter()
        .map(|&g| friction_gap_without_pressure(opened, 1e-12, 1e-10, g))
        .collect();
    println!(
        "true gravity × 1, × 2: |ΔA| = {:e}, {:e}",
        weights[0], weights[1]
    );
    assert!(weights[0] > 0.0 && weights[0] < 1e-8, "{:e}", weights[0]);
    let growth = weights[1] / weights[0];
    assert!((1.5..3.0).contains(&growth), "doubling g: × {growth}");
}
