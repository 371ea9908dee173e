//! The spec's strict test of the DEM (spec align.md, "Studies from the paper"; issue 12 item 8):
//! with μ = 0 the rotation of each particle decouples from its contacts, so each DEM sample's
//! A(t) equals the non-interacting ensemble of the same particles (sizes and axes), integrated
//! by the same scheme and step, to round-off, whatever the pressure and its mode. With P = 0
//! and μ > 0 the only contact forces are the particles' true weights (~1e-12 of the contact
//! force scale), so friction changes A(t) by no more than the ratio of the largest friction
//! torque the weights allow to the magnetic torque scale.

use magopt::materials::MaterialDb;
use magopt::models::align::dem::integrator::time_step;
use magopt::models::align::dem::torque::reduced_anisotropy;
use magopt::models::align::dem::{self, magnetic_torque, Packing};
use magopt::models::align::{AlignOutcome, AlignParams, FrictionScheme, PressureMode};
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

/// P = 0, μ = 0.5 against μ = 0: not equal to round-off. The difference comes from the contact
/// forces left by stage 3, whose overlaps relax only down to `overlap_tolerance` δ_tol (forces
/// ~k δ_tol^{3/2}, far above the true weights): friction bounded by them acts during the first
/// steps. It shrinks with δ_tol (here 8.2e-5 at 1e-5 and 1.4e-6 at 1e-6) toward the floor the
/// true weights set.
#[test]
fn friction_without_pressure_acts_only_through_the_residual_contact_forces() {
    let gap = |tolerance: f64| {
        let mut base = params(0.0, 0.0, PressureMode::ExposedLayer);
        base.numerics.overlap_tolerance = tolerance;
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
    };
    let (coarse, fine) = (gap(1e-5), gap(1e-6));
    println!("P = 0: μ = 0.5 against μ = 0: |ΔA| = {coarse:e} (δ_tol 1e-5), {fine:e} (1e-6)");
    assert!(coarse > 10.0 * fine, "{coarse:e} vs {fine:e}");
}
