//! The interacting blast model: the adaptive trapezoidal scheme (C9, C10) and the pair forces
//! (C4–C8): agreement with the explicit scheme, step control through a stiff contact,
//! second-order convergence at φ = 0.5, action = reaction, the near-field crossover, bonding,
//! the near-field cut-off's truncation error, thread-count independence, and the stage
//! times a benchmark reads.

use magopt::models::blast::cloud::Cloud;
use magopt::models::blast::interact::{Interactor, StageTimes};
use magopt::models::blast::pairs::{Body, PairLaw};
use magopt::models::blast::trapezoid::{Trapezoid, RESTART_CAP};
use magopt::models::blast::{
    run, BlastOutcome, BlastParams, DragLaw, Integrator, Interactions, Simulation,
};
use nalgebra::Vector3;

fn small_cloud() -> BlastParams {
    let mut p = BlastParams::source_example();
    p.particles = 200;
    p
}

#[test]
fn trapezoidal_reproduces_the_explicit_solution_on_a_non_stiff_case() {
    let mut p = small_cloud();
    p.duration = 0.2;
    p.samples = 1;
    let cloud = Cloud::blast(&p, 7).unwrap();
    let mut explicit = p.clone();
    explicit.step.dt = 1e-5;
    let mut boris = Simulation::new(&explicit, cloud.clone());
    let mut implicit = p.clone();
    implicit.step.integrator = Integrator::Trapezoidal;
    let mut trapezoid = Simulation::new(&implicit, cloud);
    boris.advance_to(p.duration).unwrap();
    trapezoid.advance_to(p.duration).unwrap();
    let worst = boris
        .cloud
        .positions
        .iter()
        .zip(&trapezoid.cloud.positions)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let stats = trapezoid.stats();
    assert!(stats.dt_max == p.step.dt_max, "{stats:?}");
    // each step's iteration error is at most TOL times its displacement: bound by TOL · v0 T
    let v0 = cloud_speed(&p);
    let bound = p.step.tolerance * v0 * p.duration;
    assert!(
        worst < bound,
        "largest position difference {worst} m (bound {bound} m)"
    );
}

fn cloud_speed(p: &BlastParams) -> f64 {
    (2.0 * p.energy / (p.particle_mass() * p.particles as f64)).sqrt()
}

/// Two spheres flying head-on at `speed` each, 4 cm apart; contact (and `extra`) only, with
/// contact stiffness K_p0 = `stiffness`.
fn head_on(extra: Interactions, stiffness: f64, speed: f64) -> (BlastParams, Simulation) {
    let mut p = BlastParams::source_example();
    p.contact.stiffness = stiffness;
    p.step.dt_initial = p.step.dt_max; // so the smallest step is the contact's
    p.field_strength = 0.0;
    p.drag = DragLaw::None;
    p.interactions = Interactions {
        contact: true,
        thermal_softening: true,
        ..extra
    };
    let mut cloud = Cloud::at_rest(
        vec![Vector3::new(-0.07, 0.0, 0.0), Vector3::new(0.07, 0.0, 0.0)],
        &p,
    );
    cloud.velocities = vec![
        Vector3::new(speed, 0.0, 0.0),
        Vector3::new(-speed, 0.0, 0.0),
    ];
    let sim = Simulation::new(&p, cloud);
    (p, sim)
}

fn gap(sim: &Simulation) -> f64 {
    (sim.cloud.positions[1] - sim.cloud.positions[0]).norm() - 2.0 * sim.cloud.radius
}

#[test]
fn step_shrinks_in_contact_grows_back_and_iterations_stay_near_desired() {
    // a contact 1e5 times stiffer than the source's and a 10 m/s impact, so that Δt_max is
    // far too long for it
    let (p, mut sim) = head_on(Interactions::default(), 1e12, 5.0);
    let mut trace = Vec::new(); // (time, gap, next Δt, iterations, steps)
    for k in 1..=40 {
        sim.advance_to(5e-4 * k as f64).unwrap();
        let s = sim.stats();
        trace.push((sim.time, gap(&sim), sim.time_step(), s.iterations, s.steps));
    }
    let stats = sim.stats();
    let dt_max = p.step.dt_max;
    let first_touch = trace.iter().position(|t| t.1 < 0.0).expect("they collide");
    let last_touch = trace.iter().rposition(|t| t.1 < 0.0).unwrap();
    assert!(
        trace[first_touch - 1].2 == dt_max,
        "free flight runs at Δt_max"
    );
    assert!(
        stats.rejected >= 1 && stats.dt_min < 0.5 * dt_max,
        "{stats:?}"
    );
    assert!(trace.last().unwrap().1 > 0.0, "they separate");
    assert_eq!(trace.last().unwrap().2, dt_max, "Δt grows back");
    let (a, b) = (&trace[first_touch - 1], &trace[last_touch]);
    let per_step = (b.3 - a.3) as f64 / (b.4 - a.4) as f64;
    let kd = p.step.iterations as f64;
    println!("{stats:?}; {per_step:.2} iterations per step in contact (K_d = {kd})");
    assert!(
        per_step > 0.3 * kd && per_step <= kd,
        "iterations per step in contact {per_step} (K_d = {kd})"
    );
}

#[test]
fn restarts_shrink_the_step_by_a_tenth_or_more_and_the_next_step_is_no_longer() {
    // the stiff head-on contact above, stepped by the adaptive rule itself
    let (p, sim) = head_on(Interactions::default(), 1e12, 5.0);
    let mut cloud = sim.cloud.clone();
    let mut forces = Interactor::new(&p, cloud.len());
    let mut stepper = Trapezoid::new(&p.step, &cloud);
    let (mut after_restarts, mut t) = (0, 0.0);
    while t < 0.02 {
        let (tried, rejected) = (stepper.dt, stepper.stats.rejected);
        let h = stepper
            .step(&mut cloud, &mut forces, f64::INFINITY)
            .unwrap();
        t += h;
        let restarts = stepper.stats.rejected - rejected;
        if restarts > 0 {
            after_restarts += 1;
            assert!(
                h <= RESTART_CAP.powi(restarts as i32) * tried,
                "{h} after {tried}"
            );
            assert_eq!(stepper.dt, h, "the step after restarts is no longer");
        }
    }
    assert!(after_restarts >= 1, "{:?}", stepper.stats);
    let gap = (cloud.positions[1] - cloud.positions[0]).norm() - 2.0 * cloud.radius;
    assert!(gap > 0.0, "they separate");
}

/// Error of the trapezoidal cyclotron orbit at t = 0.5 s with fixed step h and weight φ.
fn cyclotron_error(phi: f64, h: f64) -> f64 {
    let mut p = BlastParams::source_example();
    p.field_strength = 2.0;
    p.field_direction = Vector3::z();
    p.drag = DragLaw::None;
    p.step.integrator = Integrator::Trapezoidal;
    p.step.phi = phi;
    p.step.dt_initial = h;
    p.step.dt_max = h;
    p.step.tolerance = 1e-13;
    p.step.iterations = 60;
    let v0 = 3.0;
    let mut cloud = Cloud::at_rest(vec![Vector3::zeros()], &p);
    cloud.velocities[0] = Vector3::new(v0, 0.0, 0.0);
    let mut sim = Simulation::new(&p, cloud);
    let t = 0.5;
    sim.advance_to(t).unwrap();
    let omega = p.charge_per_mass * p.field_strength;
    let rc = v0 / omega;
    let exact = Vector3::new(rc * (omega * t).sin(), rc * (omega * t).cos() - rc, 0.0);
    (sim.cloud.positions[0] - exact).norm()
}

#[test]
fn phi_one_half_is_second_order_and_phi_one_first_order() {
    let h = 2e-3;
    let order = |phi: f64| (cyclotron_error(phi, h) / cyclotron_error(phi, h / 2.0)).log2();
    let (second, first) = (order(0.5), order(1.0));
    assert!(
        (second - 2.0).abs() < 0.1,
        "φ = 0.5: measured order {second}"
    );
    assert!((first - 1.0).abs() < 0.15, "φ = 1: measured order {first}");
}

fn body(p: [f64; 3], v: [f64; 3], w: [f64; 3]) -> Body {
    Body {
        position: Vector3::from(p),
        velocity: Vector3::from(v),
        spin: Vector3::from(w),
    }
}

#[test]
fn every_pair_force_obeys_action_and_reaction() {
    let mut p = BlastParams::source_example();
    let i = body([0.0, 0.0, 0.0], [0.3, -0.2, 0.1], [1.0, 2.0, -3.0]);
    let j = body([0.085, 0.02, -0.01], [-0.5, 0.4, 0.2], [-2.0, 0.5, 1.0]);
    let terms = [
        "contact",
        "damping",
        "friction",
        "contact,friction",
        "near-field",
    ];
    for term in terms {
        p.interactions = Interactions::parse(term).unwrap();
        let law = PairLaw::new(&p);
        for bond in [None, Some(1e-3)] {
            let (fi, _) = law.contact(&i, &j, bond, 1e-4);
            let (fj, _) = law.contact(&j, &i, bond, 1e-4);
            assert!((fi + fj).norm() <= 1e-12 * fi.norm().max(1e-300), "{term}");
            assert!(fi.norm() > 0.0 || term == "near-field" || term == "friction");
        }
        let (ni, nj) = (
            law.near_field(&i.position, &j.position),
            law.near_field(&j.position, &i.position),
        );
        assert!((ni + nj).norm() <= 1e-12 * ni.norm());
    }
    // a stretched bond pulls both ways equally
    let far = body([0.12, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0; 3]);
    p.interactions = Interactions::parse("bonding").unwrap();
    let law = PairLaw::new(&p);
    let (fi, _) = law.contact(&i, &far, Some(1e-3), 1e-4);
    let (fj, _) = law.contact(&far, &i, Some(1e-3), 1e-4);
    assert!(fi.x > 0.0 && (fi + fj).norm() <= 1e-12 * fi.norm());
}

#[test]
fn near_field_crosses_from_repulsion_to_attraction_at_r_star() {
    let p = BlastParams::source_example();
    let law = PairLaw::new(&p);
    let nf = &p.near_field;
    let r_star =
        (nf.repulsion / nf.attraction).powf(1.0 / (nf.repulsion_exponent - nf.attraction_exponent));
    assert!((law.crossover_distance().unwrap() - r_star).abs() < 1e-15);
    let toward_j = |r: f64| {
        law.near_field(&Vector3::zeros(), &Vector3::new(r, 0.0, 0.0))
            .x
    };
    assert!(toward_j(0.98 * r_star) < 0.0, "repulsive inside r*");
    assert!(toward_j(1.02 * r_star) > 0.0, "attractive outside r*");
    assert!(toward_j(r_star).abs() < 1e-9 * toward_j(2.0 * r_star));
}

#[test]
fn bonds_form_past_the_bonding_strain_and_hold() {
    let bonding = Interactions {
        bonding: true,
        ..Default::default()
    };
    let stiffness = BlastParams::source_example().contact.stiffness;
    let (_, mut bonded) = head_on(bonding, stiffness, 1.0);
    let (_, mut free) = head_on(Interactions::default(), stiffness, 1.0);
    let mut max_stretch: f64 = 0.0;
    for k in 1..=100 {
        let t = 1e-3 * k as f64;
        bonded.advance_to(t).unwrap();
        free.advance_to(t).unwrap();
        if bonded.interactor().unwrap().bond_count() == 1 {
            max_stretch = max_stretch.max(gap(&bonded));
        }
    }
    assert_eq!(bonded.interactor().unwrap().bond_count(), 1);
    assert_eq!(free.interactor().unwrap().bond_count(), 0);
    assert!(gap(&free) > 0.05, "without a bond they fly apart");
    // the bond stops the separation within a radius and pulls the pair back
    assert!(
        max_stretch < 2.0 * bonded.cloud.radius,
        "bond holds: {max_stretch}"
    );
    assert!(
        gap(&bonded) < 0.6 * max_stretch,
        "pulled back: {}",
        gap(&bonded)
    );
}

/// Near-field forces on a blasted cloud of 500 at rest (no field, no drag), with a cut-off
/// (m) or a Barnes–Hut opening angle, and their relative RMS error against the exact sum.
fn near_field_error(cutoff: f64, theta: f64) -> f64 {
    let mut p = BlastParams::source_example();
    p.particles = 500;
    p.field_strength = 0.0;
    p.drag = DragLaw::None;
    p.interactions = Interactions::parse("near-field").unwrap();
    // Against the exact sum in double precision (the default sums in single precision).
    p.near_field.precision = magopt::models::blast::NearFieldPrecision::Double;
    let positions = Cloud::blast(&p, 3).unwrap().positions;
    let cloud = Cloud::at_rest(positions, &p);
    let forces = |cutoff: f64, theta: f64| {
        let mut q = p.clone();
        q.near_field.cutoff = cutoff;
        q.near_field.theta = theta;
        let mut f = vec![Vector3::zeros(); cloud.len()];
        let mut m = f.clone();
        Interactor::new(&q, cloud.len()).evaluate(&cloud, 1e-4, &mut f, &mut m);
        f
    };
    let exact = forces(0.0, 0.0);
    let approx = forces(cutoff, theta);
    let norm = |v: &mut dyn Iterator<Item = f64>| v.sum::<f64>().sqrt();
    norm(
        &mut approx
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).norm_squared()),
    ) / norm(&mut exact.iter().map(|f| f.norm_squared()))
}

#[test]
fn near_field_cutoff_truncation_error_against_exact_sum() {
    let mut last = f64::INFINITY;
    for cutoff in [0.25, 0.5, 1.0, 2.0] {
        let error = near_field_error(cutoff, 0.0);
        println!("near-field cut-off {cutoff} m: relative RMS force error {error:.3e}");
        assert!(error < last, "error shrinks as the cut-off grows");
        last = error;
    }
    assert!(last < 1e-12, "a cut-off beyond the cloud diameter is exact");
}

#[test]
fn barnes_hut_converges_to_the_exact_near_field() {
    let mut last = f64::INFINITY;
    for theta in [1.0, 0.5, 0.25, 0.1] {
        let error = near_field_error(0.0, theta);
        println!("Barnes–Hut θ = {theta}: relative RMS force error {error:.3e}");
        assert!(error < last, "error shrinks with θ");
        last = error;
    }
    assert!(last < 1e-3);
    assert!(
        near_field_error(0.0, 1e-9) < 1e-12,
        "θ → 0 opens every cell"
    );
}

#[test]
fn runs_are_bit_identical_at_any_thread_count() {
    for interactions in [Interactions::all(), Interactions::default()] {
        let mut p = small_cloud();
        p.interactions = interactions;
        p.duration = 0.02;
        p.samples = 2;
        let in_pool = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run(&p, 5, &|_| {}, None).unwrap())
        };
        let (one, two) = (in_pool(1), in_pool(2));
        assert_eq!(one.cloud, two.cloud);
        assert_eq!(one.stats, two.stats);
        for run in [one, two] {
            stage_times_add_up(&run, interactions.any());
        }
    }
}

/// The force stages' wall times lie within the run's, and only a run with interactions has
/// them.
fn stage_times_add_up(run: &BlastOutcome, interacting: bool) {
    let t = run.stage_times;
    let stages = t.named().map(|(_, s)| s);
    assert!(stages.iter().all(|&s| s >= 0.0), "{t:?}");
    assert!(stages.iter().sum::<f64>() <= run.wall_time_s, "{t:?}");
    if interacting {
        assert!(
            t.contacts > 0.0 && t.near_field > 0.0 && t.gather > 0.0,
            "{t:?}"
        );
    } else {
        assert_eq!(t, StageTimes::default());
    }
}
