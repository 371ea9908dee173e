//! The blast model against the source's closed forms (Zohdi 2016; docs/blast.md C11–C15):
//! a charge under Stokes drag and B (spiral, terminal displacement), the cloud's terminal
//! envelope under Stokes drag, the force ratio λ of its Eq. (6.3), the turning radius of a
//! cloud against Eq. (2.6), the swirl about B, and the terminal-state stop.

use magopt::models::blast::cloud::Cloud;
use magopt::models::blast::observe::{Envelope, Motion};
use magopt::models::blast::theory::{stokes_spiral_displacement, turning_radius, ChargedSphere};
use magopt::models::blast::{run, BlastParams, DragLaw, Simulation};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Small light spheres under Stokes drag (τ = m/c = 2ρR²/(9μ_f) = 0.123 s) in a field with
/// Ωτ = `omega_tau` (q/m = 10 C/kg, B along z), 200 particles in a 5 cm cloud.
fn stokes_cloud(omega_tau: f64) -> (BlastParams, f64) {
    let mut p = BlastParams::source_example();
    p.drag = DragLaw::Stokes;
    p.radius = 1e-4;
    p.density = 1000.0;
    p.cloud_radius = 0.05;
    p.particles = 200;
    p.energy = 1e-9;
    p.field_direction = Vector3::z();
    let tau = 2.0 * p.density * p.radius * p.radius / (9.0 * p.air_viscosity);
    p.field_strength = omega_tau / (p.charge_per_mass * tau);
    (p, tau)
}

#[test]
fn stokes_drag_and_field_give_the_analytic_spiral_and_terminal_displacement() {
    let (p, tau) = stokes_cloud(2.0);
    let (v0, b) = (Vector3::new(0.6, -0.2, 0.5), p.field());
    let mut cloud = Cloud::at_rest(vec![Vector3::zeros()], &p);
    cloud.velocities[0] = v0;
    let mut sim = Simulation::new(&p, cloud);
    for t in [0.01, 0.05, 0.1, 0.3, 0.6] {
        sim.advance_to(t).unwrap();
        let expected = stokes_spiral_displacement(&v0, p.charge_per_mass, &b, tau, t);
        let r = sim.cloud.positions[0];
        assert!(
            (r - expected).norm() < 1e-6 * v0.norm() * tau,
            "t = {t}: {r:?} vs {expected:?}"
        );
    }
    sim.advance_to(30.0 * tau).unwrap();
    let r = sim.cloud.positions[0];
    // along B: v0∥ τ; across B: v0⊥ τ / √(1 + (ωτ)²), ω = qB/m
    assert!((r.z - v0.z * tau).abs() < 1e-6 * v0.z * tau);
    let across = v0.xy().norm() * tau / (1.0 + 4.0f64).sqrt();
    assert!(
        (r.xy().norm() - across).abs() < 1e-6 * across,
        "{} vs {across}",
        r.xy().norm()
    );
}

#[test]
fn cloud_terminal_envelope_under_stokes_drag_is_the_single_particle_formula() {
    let (p, tau) = stokes_cloud(3.0);
    let start = Cloud::blast(&p, 7).unwrap();
    let mut predicted = start.clone();
    for (r, v) in predicted.positions.iter_mut().zip(&start.velocities) {
        *r += stokes_spiral_displacement(v, p.charge_per_mass, &p.field(), tau, f64::INFINITY);
    }
    let mut sim = Simulation::new(&p, start.clone());
    sim.advance_to(30.0 * tau).unwrap();
    let axis = p.field_axis();
    let (got, want) = (
        Envelope::of(&sim.cloud, &axis),
        Envelope::of(&predicted, &axis),
    );
    for (a, b) in [
        (got.along, want.along),
        (got.across, want.across),
        (got.extent_along, want.extent_along),
        (got.extent_across, want.extent_across),
    ] {
        assert!((a - b).abs() < 1e-6 * b, "{got:?} vs {want:?}");
    }
    // the blast travels v0 τ along B but only v0 τ/√10 across it: the envelope elongates
    let travel = (2.0 * p.energy / (p.particle_mass() * p.particles as f64)).sqrt() * tau;
    assert!(got.along - Envelope::of(&start, &axis).along > 0.5 * travel);
}

#[test]
fn force_ratio_at_blast_speed_for_the_source_parameters() {
    // Zohdi 2016 §6.1: q/m = 10 C/kg, B = 10 T, N = 2000, R = 0.05 m, ρ = 7000 kg/m³,
    // W = 10 kJ, ρ_a = 1.225 kg/m³; C_D = 1 as in its Eq. (6.3).
    let p = BlastParams::source_example();
    let speed = (2.0 * p.energy / (p.particle_mass() * p.particles as f64)).sqrt();
    assert!((speed - 1.651_778).abs() < 1e-6, "|δv| = √(2W/M) = {speed}");
    let sphere = ChargedSphere {
        charge_per_mass: p.charge_per_mass,
        density: p.density,
        radius: p.radius,
        drag_coefficient: 1.0,
        fluid_density: p.air_density,
    };
    let lambda = sphere.force_ratio_bound(0.0, p.field_strength, speed);
    assert!((lambda - 46_126.34).abs() < 0.01, "λ = {lambda}");
    // the source's 56 504.7 is Eq. (5.4) without the fluid density ρ_f = 1.225 in it
    let without_fluid_density = lambda * p.air_density;
    assert!(
        (without_fluid_density - 56_504.7).abs() < 0.1,
        "{without_fluid_density}"
    );
}

#[test]
fn cloud_turning_radius_is_pi_over_four_of_the_single_particle_radius() {
    // a blast launches every particle at |δv| in a random direction; its speed across B is
    // |δv| sin θ, and the mean of sin θ over isotropic directions is π/4
    let mut p = BlastParams::source_example();
    p.particles = 1500;
    p.radius = 0.02;
    p.duration = 1e-3;
    p.samples = 1;
    let outcome = run(&p, 3, &|_| {}, None).unwrap();
    let speed = (2.0 * p.energy / (p.particle_mass() * p.particles as f64)).sqrt();
    let single = turning_radius(speed, p.charge_per_mass, p.field_strength);
    let ratio = outcome.samples[0].motion.turning_radius / single;
    assert!((ratio - PI / 4.0).abs() < 0.02, "cloud / single = {ratio}");
}

#[test]
fn swirl_about_b_follows_canonical_angular_momentum_with_opposite_senses() {
    // without drag, m (r × v)·b̂ + q B r⊥²/2 is conserved per particle about an axis along B;
    // two ± pairs placed symmetrically keep the centre of mass on the axis
    let mut p = BlastParams::source_example();
    p.drag = DragLaw::None;
    p.field_direction = Vector3::z();
    p.field_strength = 2.0;
    let positions = vec![
        Vector3::new(0.5, 0.0, 0.1),
        Vector3::new(-0.5, 0.0, -0.1),
        Vector3::new(0.0, 0.4, 0.2),
        Vector3::new(0.0, -0.4, -0.2),
    ];
    let mut cloud = Cloud::at_rest(positions.clone(), &p);
    for (k, (v, r)) in cloud.velocities.iter_mut().zip(&positions).enumerate() {
        *v = 1.5 * r.normalize();
        cloud.charge_per_mass[k] *= if k < 2 { 1.0 } else { -1.0 };
    }
    let mut sim = Simulation::new(&p, cloud);
    sim.advance_to(0.37).unwrap();
    let motion = Motion::of(&sim.cloud, &p);
    let change = |k: std::ops::Range<usize>, sign: f64| -> f64 {
        k.map(|i| {
            let (r, r0) = (sim.cloud.positions[i].xy(), positions[i].xy());
            -sign
                * p.charge_per_mass
                * sim.cloud.mass
                * p.field_strength
                * (r.norm_squared() - r0.norm_squared())
                / 2.0
        })
        .sum()
    };
    let (plus, minus) = (change(0..2, 1.0), change(2..4, -1.0));
    assert!(
        (motion.spin_positive - plus).abs() < 1e-4 * plus.abs(),
        "{motion:?} vs {plus}"
    );
    assert!(
        (motion.spin_negative - minus).abs() < 1e-4 * minus.abs(),
        "{motion:?} vs {minus}"
    );
}

#[test]
fn run_stops_at_the_terminal_energy_fraction() {
    let (mut p, tau) = stokes_cloud(2.0);
    p.duration = 20.0 * tau;
    p.samples = 200;
    p.stop_energy_fraction = 1e-2;
    let outcome = run(&p, 1, &|_| {}, None).unwrap();
    // the kinetic energy decays as e^{−2t/τ}: 1 % at t = τ ln(10)
    let expected = tau * 10f64.ln();
    let stop = outcome.terminal_time.expect("reached");
    assert!(
        stop >= expected && stop < expected + p.duration / 200.0 + 1e-12,
        "{stop}"
    );
    assert_eq!(outcome.last().time, stop);
    p.stop_energy_fraction = 0.0;
    let unstopped = run(&p, 1, &|_| {}, None).unwrap();
    assert!(unstopped.terminal_time.is_none());
    assert!(unstopped.envelope_settled_time().is_none());
}

#[test]
fn envelope_settles_when_the_remaining_stokes_displacement_falls_below_one_percent() {
    let (mut p, tau) = stokes_cloud(2.0);
    p.duration = 20.0 * tau;
    p.samples = 400;
    p.stop_energy_fraction = 1e-8; // e^{−2t/τ}: t = 9.2 τ
    p.cloud_radius = 1e-3; // small beside the terminal displacement v0 τ = 6 mm
    let outcome = run(&p, 1, &|_| {}, None).unwrap();
    let settled = outcome
        .envelope_settled_time()
        .expect("terminal state reached");
    // each particle still has v0 τ e^{−t/τ} to go, 1 % of its terminal displacement at
    // t = τ ln 100 = 4.6 τ (measured 4.5 τ: the initial cloud adds to the envelope)
    println!("settled at {:.2} τ", settled / tau);
    assert!(
        settled > 3.0 * tau && settled < 6.0 * tau,
        "{}",
        settled / tau
    );
    assert!(settled <= outcome.terminal_time.unwrap());
}
