//! Analytic cases of the blast model (spec blast.md): cyclotron orbit, helix, quadratic and
//! Stokes drag, energy conservation of the Boris scheme against the drift of forward Euler,
//! and Chow's drag law.

use magopt::models::blast::cloud::Cloud;
use magopt::models::blast::field::chow_drag_coefficient;
use magopt::models::blast::{BlastParams, DragLaw, Integrator, Simulation};
use nalgebra::Vector3;

/// One particle of the source's size and density at the origin with velocity `v0`.
fn single(params: &BlastParams, v0: Vector3<f64>) -> Simulation {
    let mut cloud = Cloud::at_rest(vec![Vector3::zeros()], params);
    cloud.velocities[0] = v0;
    Simulation::new(params, cloud)
}

/// B = B e3, E = E e3, no drag, q/m = 10 C/kg.
fn gyration(b: f64, e: f64) -> BlastParams {
    let mut p = BlastParams::source_example();
    p.field_strength = b;
    p.field_direction = Vector3::z();
    p.electric_strength = e;
    p.drag = DragLaw::None;
    p
}

#[test]
fn cyclotron_radius_frequency_and_period() {
    let (b, v0) = (2.0, 3.0);
    let p = gyration(b, 0.0);
    let omega = p.charge_per_mass * b; // ω = qB/m
    let radius = v0 / omega; // v0 m/(qB)
    let period = 2.0 * std::f64::consts::PI / omega;
    let mut sim = single(&p, Vector3::new(v0, 0.0, 0.0));
    // positive charge, B along +z: the orbit turns clockwise about (0, −r_c, 0)
    let centre = Vector3::new(0.0, -radius, 0.0);
    for k in 1..=8 {
        let t = period * k as f64 / 8.0;
        sim.advance_to(t).unwrap();
        let r = sim.cloud.positions[0];
        let phase = omega * t;
        let expected = centre + radius * Vector3::new(phase.sin(), phase.cos(), 0.0);
        assert!(
            (r - expected).norm() < 1e-5 * radius,
            "t = {t}: {r:?} vs {expected:?}"
        );
        assert!(((r - centre).norm() - radius).abs() < 1e-6 * radius);
    }
    // after one period the particle is back where it started
    assert!(sim.cloud.positions[0].norm() < 1e-5 * radius);
}

#[test]
fn helix_with_electric_field_along_b() {
    let (b, e, v0) = (2.0, 0.5, 3.0);
    let p = gyration(b, e);
    let omega = p.charge_per_mass * b;
    let radius = v0 / omega;
    let mut sim = single(&p, Vector3::new(v0, 0.0, 0.0));
    for k in 1..=10 {
        let t = 0.1 * k as f64;
        sim.advance_to(t).unwrap();
        let r = sim.cloud.positions[0];
        let z = p.charge_per_mass * e * t * t / 2.0; // z = qEt²/(2m)
        assert!(
            (r.z - z).abs() < 1e-9 * z.max(1.0),
            "t = {t}: z {} vs {z}",
            r.z
        );
        let across = (r - Vector3::new(0.0, -radius, r.z)).norm();
        assert!((across - radius).abs() < 1e-6 * radius);
    }
}

/// Drag only, no field: a light particle so that drag matters within a second.
fn drag_only(law: DragLaw) -> BlastParams {
    let mut p = BlastParams::source_example();
    p.field_strength = 0.0;
    p.drag = law;
    p.drag_coefficient = 0.5;
    p.density = 10.0;
    p.radius = 0.01;
    p
}

#[test]
fn quadratic_drag_speed_and_distance() {
    let p = drag_only(DragLaw::Quadratic);
    let k = 3.0 * p.drag_coefficient * p.air_density / (8.0 * p.density * p.radius);
    let v0 = 10.0;
    let mut sim = single(&p, Vector3::new(v0, 0.0, 0.0));
    for step in 1..=10 {
        let t = 0.1 * step as f64;
        sim.advance_to(t).unwrap();
        let v = sim.cloud.velocities[0].x;
        let r = sim.cloud.positions[0].x;
        let v_exact = v0 / (k * v0 * t + 1.0);
        let r_exact = (k * v0 * t + 1.0).ln() / k;
        assert!(
            (v - v_exact).abs() < 1e-12 * v0,
            "v({t}) = {v} vs {v_exact}"
        );
        assert!(
            (r - r_exact).abs() < 1e-6 * r_exact,
            "r({t}) = {r} vs {r_exact}"
        );
        // the inverse relation v(r) = v0 e^{−K (r − r0)}
        assert!((v - v0 * (-k * r).exp()).abs() < 1e-6 * v0);
    }
}

#[test]
fn stokes_drag_speed_and_terminal_blast_radius() {
    let mut p = drag_only(DragLaw::Stokes);
    p.radius = 1e-4;
    p.density = 1000.0;
    p.cloud_radius = 0.05;
    p.particles = 200;
    p.energy = 1e-9;
    let m = p.particle_mass();
    let c = 6.0 * std::f64::consts::PI * p.air_viscosity * p.radius;
    let cloud = Cloud::blast(&p, 4).unwrap();
    let v0 = cloud.velocities[0].norm();
    let start = cloud.clone();
    let mut sim = Simulation::new(&p, cloud);
    let t = 0.2;
    sim.advance_to(t).unwrap();
    let v = sim.cloud.velocities[0].norm();
    assert!((v - v0 * (-(c / m) * t).exp()).abs() < 1e-12 * v0);
    sim.advance_to(5.0).unwrap(); // many relaxation times m/c
    let terminal = v0 * 2.0 * p.density * p.radius * p.radius / (9.0 * p.air_viscosity);
    assert!((terminal - v0 * m / c).abs() < 1e-12 * terminal);
    for (r, r0) in sim.cloud.positions.iter().zip(&start.positions) {
        let travel = (r - r0).norm();
        assert!(
            (travel - terminal).abs() < 1e-6 * terminal,
            "{travel} vs {terminal}"
        );
    }
}

#[test]
fn boris_conserves_energy_and_forward_euler_drifts() {
    let p = gyration(10.0, 0.0);
    let omega = p.charge_per_mass * 10.0;
    let periods = 20.0;
    let duration = periods * 2.0 * std::f64::consts::PI / omega;
    let v0 = Vector3::new(1.65, 0.0, 0.3);
    let energy = |s: &Simulation| s.cloud.velocities[0].norm_squared();
    let mut boris = single(&p, v0);
    let mut euler_params = p.clone();
    euler_params.step.integrator = Integrator::Euler;
    let mut euler = single(&euler_params, v0);
    let e0 = v0.norm_squared();
    let mut last_euler = e0;
    for k in 1..=20 {
        let t = duration * k as f64 / 20.0;
        boris.advance_to(t).unwrap();
        euler.advance_to(t).unwrap();
        assert!((energy(&boris) / e0 - 1.0).abs() < 1e-12);
        assert!(
            energy(&euler) > last_euler,
            "forward-Euler energy grows every interval"
        );
        last_euler = energy(&euler);
    }
    // |v_⊥|² grows by (1 + (ωΔt)²) per step under forward Euler
    let steps = euler.stats().steps as f64;
    let h = duration / steps;
    let perpendicular = v0.x * v0.x;
    let predicted = perpendicular * (1.0 + (omega * h).powi(2)).powf(steps) + v0.z * v0.z;
    assert!(
        (last_euler / predicted - 1.0).abs() < 1e-6,
        "{last_euler} vs {predicted}"
    );
    assert!(
        last_euler / e0 > 2.0,
        "drift after {periods} periods: {}",
        last_euler / e0
    );
}

#[test]
fn chow_drag_coefficient_on_each_branch() {
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b;
    assert!(close(chow_drag_coefficient(0.5), 48.0));
    assert!(close(
        chow_drag_coefficient(100.0),
        24.0 / 100f64.powf(0.646)
    ));
    assert!(close(chow_drag_coefficient(1e4), 0.5));
    assert!(close(
        chow_drag_coefficient(1e6),
        0.000366 * 1e6f64.powf(0.4275)
    ));
    assert!(close(chow_drag_coefficient(1e7), 0.18));
    let jump = |re: f64| {
        (
            chow_drag_coefficient(re),
            chow_drag_coefficient(re * (1.0 + 1e-12)),
        )
    };
    let (below, above) = jump(1.0);
    assert!((below - above).abs() < 1e-9, "continuous at Re = 1");
    let (below, above) = jump(400.0);
    assert!(
        (below / above - 1.0).abs() < 3e-3,
        "nearly continuous at 400"
    );
    let (below, above) = jump(3e5);
    assert!(
        below == 0.5 && (above - 0.0804).abs() < 1e-3,
        "drag crisis at 3e5"
    );
    let (below, above) = jump(2e6);
    assert!(
        (below / above - 1.0).abs() < 1e-2,
        "nearly continuous at 2e6"
    );
}

#[test]
fn default_example_elongates_along_b_and_stays_spherical_without_field() {
    let mut p = BlastParams::source_example();
    p.particles = 300;
    p.duration = 0.5;
    let on = magopt::models::blast::run(&p, 1, &|_| {}, None).unwrap();
    p.field_strength = 0.0;
    let off = magopt::models::blast::run(&p, 1, &|_| {}, None).unwrap();
    let (e_on, e_off) = (on.last().envelope, off.last().envelope);
    assert!(e_on.aspect_ratio() > 1.5, "{e_on:?}");
    assert!(e_on.extent_across < 1.05 * p.cloud_radius, "{e_on:?}");
    assert!((e_off.aspect_ratio() - 1.0).abs() < 0.1, "{e_off:?}");
}
