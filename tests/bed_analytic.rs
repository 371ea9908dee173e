//! Analytic and conservation checks of the `bed` forces and integrator: the wall law at w = D
//! with the default M_w, the plate normal force (B4) of two discs, the finite bar tending to the
//! infinite row, energy conservation of a frictionless many-disc bed (second order in Δt) and
//! total momentum with the walls off.

use std::f64::consts::PI;

use magopt::models::bed::forces::ForceField;
use magopt::models::bed::integrator::{step, Kick, StepScan};
use magopt::models::bed::params::{
    BedParams, Friction, Neighbors, Reach, TailCorrection, TiltOrder, WallLaw,
};
use magopt::models::bed::state::{Geometry, Particles, State};
use magopt::units::MU0;
use nalgebra::Vector2;

/// A cell of width w and height h with the piston at the top.
fn cell(width: f64, height: f64) -> Geometry {
    Geometry {
        width,
        height,
        start_height: height,
        final_height: height,
    }
}

/// Forces on discs at rest at `position` in `geometry`.
fn forces(params: &BedParams, geometry: Geometry, position: Vec<Vector2<f64>>) -> ForceField {
    let n = position.len();
    let particles = Particles::new(params, vec![0; n]);
    let state = State {
        position,
        velocity: vec![Vector2::zeros(); n],
        piston: geometry.height,
        time: 0.0,
    };
    let mut field = ForceField::new(params, &particles, geometry);
    field.evaluate(&particles, &state);
    field
}

/// (D, μ, m) of the mono-disperse disc.
fn disc(params: &BedParams) -> (f64, f64, f64) {
    let d = params.reference_diameter();
    (d, params.moment(d), params.mass(d))
}

#[test]
fn the_default_wall_law_at_one_diameter_is_the_infinite_row() {
    // (B2) with M_w = 2μ/√D at w = D: (μ0 μ/2π)(2μ/√D)/D^3.5 = μ0 μ²/(π D⁴) (≈ 2.377 N for
    // μ = 0.08775 A·m², D = 6 mm)
    let params = BedParams::defaults();
    let (d, mu, m) = disc(&params);
    let expected = MU0 * mu * mu / (PI * d.powi(4));
    assert!((expected - 2.377).abs() < 1e-3, "{expected}");
    for law in [WallLaw::Empirical, WallLaw::InfiniteRow] {
        let mut p = params.clone();
        p.wall_law = law;
        // 2 m wide and 20 m high: the side walls cancel, the piston adds ~1e-10 of the floor
        let field = forces(&p, cell(2.0, 20.0), vec![Vector2::new(1.0, d)]);
        let floor = field.out[0].force.y + m * p.gravity;
        assert!(
            (floor - expected).abs() < 1e-9 * expected,
            "{law:?}: {floor} vs {expected}"
        );
        assert_eq!(field.out[0].force.x, 0.0);
    }
}

#[test]
fn the_plate_normal_force_of_two_discs_follows_the_torque_balance() {
    // de Paula 2025, Eq. (2.15) and, second order, Eq. (3.2), for two equal discs at r
    let mut params = BedParams::defaults();
    params.gravity = 0.0;
    params.neighbors = Neighbors::Exact; // 10 D is beyond the default cut-off
    let (d, mu, _) = disc(&params);
    let (eps, gap) = (params.thickness, params.gap);
    let hyp = (d * d + eps * eps).sqrt();
    let phi = (eps / d).atan();
    let theta = (gap / hyp).asin() - phi;
    assert!((theta.to_degrees() - 0.959).abs() < 1e-3, "θ = {theta}");
    for (order, torque) in [
        (TiltOrder::First, (2.0 * theta).sin()),
        (
            TiltOrder::Second,
            (2.0 * theta).sin() + 2.0 / 3.0 * theta.sin(),
        ),
    ] {
        params.tilt_order = order;
        for r in [1.2 * d, 3.0 * d, 10.0 * d] {
            let field = forces(
                &params,
                cell(2.0, 20.0),
                vec![Vector2::new(0.9, 10.0), Vector2::new(0.9 + r, 10.0)],
            );
            let expected =
                3.0 * MU0 * mu * mu / (8.0 * PI) * torque / ((phi + theta).cos() * hyp * r.powi(3));
            for out in &field.out {
                assert!(
                    (out.normal - expected).abs() < 1e-12 * expected,
                    "{order:?} at {} D: {} vs {expected}",
                    r / d,
                    out.normal
                );
            }
        }
    }
}

#[test]
fn the_finite_bar_tends_to_the_infinite_row() {
    let mut params = BedParams::defaults();
    params.gravity = 0.0;
    let (d, mu, _) = disc(&params);
    let row = MU0 * mu * (mu / d) / (PI * d.powi(3));
    params.wall_law = WallLaw::FiniteBar;
    let errors: Vec<f64> = [10.0, 100.0, 1000.0]
        .iter()
        .map(|&length| {
            // a floor of `length` D with the disc above its middle; the piston 1e4 D away
            let width = length * d;
            let field = forces(
                &params,
                cell(width, 1e4 * d),
                vec![Vector2::new(0.5 * width, d)],
            );
            (row - field.out[0].force.y) / row
        })
        .collect();
    // with t = (L/2)/ℓ each end term is (2/3)(1 + 3/(2t²))(1 + 1/t²)^(−3/2) = (2/3)(1 − 3/(8t⁴)
    // + …): the bar falls short of the row by 3/(8t⁴), 10⁴× less per decade of L
    for (&length, &error) in [10.0, 100.0, 1000.0].iter().zip(&errors) {
        let t: f64 = 0.5 * length;
        let expected = 3.0 / (8.0 * t.powi(4));
        assert!(
            (error - expected).abs() < 0.1 * expected,
            "L = {length} D: {error} vs {expected}"
        );
    }
    assert!(errors[2] < 1e-11, "{errors:?}");
}

/// A frictionless bed integrated with a fixed step; returns the largest |E(t) − E(0)| and E's
/// potential scale.
fn energy_drift(dt: f64, t_end: f64) -> (f64, f64) {
    let mut params = BedParams::defaults();
    params.friction = Friction::None;
    params.neighbors = Neighbors::Exact;
    params.particles = Some(24);
    let geometry = Geometry::of(&params);
    let particles = Particles::new(&params, vec![0; 24]);
    let mut state = State::initial(&params, &geometry, 4);
    let mut field = ForceField::new(&params, &particles, geometry);
    field.evaluate(&particles, &state);
    let kick = Kick::of(&params, false);
    let energy = |s: &State| bed_energy(&params, &particles, &geometry, s);
    let e0 = energy(&state);
    let mut worst: f64 = 0.0;
    for _ in 0..(t_end / dt).round() as usize {
        step(
            &mut state,
            &particles,
            &mut field,
            &kick,
            dt,
            geometry.height,
        );
        worst = worst.max((energy(&state) - e0).abs());
    }
    let weight: f64 = particles.mass.iter().map(|m| m * params.gravity).sum();
    (worst, weight * geometry.height)
}

/// ½ Σ m v² + Σ m g y + Σ_pairs μ0 μ_i μ_j/(4π r³) (the potential of B1) + the walls' c/(2.5 w^2.5)
/// (the potential of B2), J.
fn bed_energy(params: &BedParams, particles: &Particles, g: &Geometry, s: &State) -> f64 {
    let mut e = 0.0;
    for (i, (p, v)) in s.position.iter().zip(&s.velocity).enumerate() {
        let (m, mu) = (particles.mass[i], particles.moment[i]);
        e += 0.5 * m * v.norm_squared() + m * params.gravity * p.y;
        let c = MU0 * mu * params.wall_strength() / (2.0 * PI);
        for w in [p.y, p.x, g.width - p.x, s.piston - p.y] {
            e += c / (2.5 * w.powf(2.5));
        }
        for j in i + 1..s.position.len() {
            let r = (p - s.position[j]).norm();
            e += MU0 * mu * particles.moment[j] / (4.0 * PI * r.powi(3));
        }
    }
    e
}

#[test]
fn a_frictionless_bed_conserves_energy_at_second_order() {
    // 24 discs fall from the initial grid onto the magnetic floor for 0.3 s
    let drifts: Vec<(f64, f64)> = [2e-4, 1e-4, 5e-5]
        .iter()
        .map(|&dt| energy_drift(dt, 0.3))
        .collect();
    let scale = drifts[0].1;
    assert!(drifts[2].0 < 1e-4 * scale, "{drifts:?}");
    for pair in drifts.windows(2) {
        let order = (pair[0].0 / pair[1].0).log2();
        assert!((1.7..2.3).contains(&order), "order {order}: {drifts:?}");
    }
}

#[test]
fn total_momentum_is_conserved_with_the_walls_off() {
    // no gravity, no friction, a wall strength of 1e-30 of the default in a 10 km cell; the
    // pair sums alone (the mean-field tail, a field and no pairs, has no reaction: its net push
    // is bounded in src/models/bed/tail.rs and tests/bed_tail.rs)
    let mut params = BedParams::defaults();
    params.tail_correction = TailCorrection::None;
    params.gravity = 0.0;
    params.friction = Friction::None;
    params.wall_strength = Some(1e-30 * params.wall_strength());
    let n = 30;
    let position: Vec<_> = (0..n)
        .map(|k| {
            let (i, j) = ((k % 6) as f64, (k / 6) as f64);
            Vector2::new(5e3 + 0.011 * i + 1e-3 * j, 5e3 + 0.012 * j + 7e-4 * i * i)
        })
        .collect();
    let velocity: Vec<_> = (0..n)
        .map(|k| Vector2::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos()) * 0.05)
        .collect();
    for (neighbors, list_radius) in [
        (Neighbors::Exact, 8.0),
        (Neighbors::Verlet, 4.0),
        (Neighbors::SourceVerlet, 3.0),
    ] {
        params.neighbors = neighbors;
        params.cutoff = Reach::Diameters(3.0);
        params.list_radius = Reach::Diameters(list_radius);
        let particles = Particles::new(&params, vec![0; n]);
        let mut state = State {
            position: position.clone(),
            velocity: velocity.clone(),
            piston: 1e4,
            time: 0.0,
        };
        let mut field = ForceField::new(&params, &particles, cell(1e4, 1e4));
        field.evaluate(&particles, &state);
        let kick = Kick::of(&params, false);
        let momentum = |s: &State| -> Vector2<f64> {
            s.velocity
                .iter()
                .zip(&particles.mass)
                .map(|(v, m)| v * *m)
                .sum()
        };
        let p0 = momentum(&state);
        let mut moved = 0.0;
        for _ in 0..3000 {
            let dt = StepScan::of(&state, &particles, &field, &kick).time_step(0.2, 1e-3);
            step(&mut state, &particles, &mut field, &kick, dt, 1e4);
            moved = state
                .velocity
                .iter()
                .zip(&particles.mass)
                .map(|(v, m)| m * v.norm())
                .sum::<f64>()
                .max(moved);
        }
        let change = (momentum(&state) - p0).norm();
        assert!(
            change < 1e-13 * moved,
            "{neighbors:?}: ΔP {change} of Σ m|v| {moved}"
        );
        assert!(field.list_builds() > 1 || neighbors == Neighbors::Exact);
    }
}
