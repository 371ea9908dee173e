//! Physics of the `bed` model: free fall, second-order convergence and energy conservation of
//! a disc bouncing on the magnetic floor, action = reaction, neighbour lists against exact
//! sums, thread-count independence, and the semi-implicit dry friction against a small-step
//! explicit reference.

use magopt::models::bed::forces::{pair_force, ForceField};
use magopt::models::bed::integrator::{step, Kick, StepScan};
use magopt::models::bed::params::{
    BedParams, Friction, FrictionScheme, Heights, Neighbors, Reach, TailCorrection,
};
use magopt::models::bed::protocol::run_cycle;
use magopt::models::bed::state::{Geometry, Particles, State};
use nalgebra::Vector2;

/// One disc in a cell far larger than the range of the walls except the floor.
struct Single {
    particles: Particles,
    field: ForceField,
    state: State,
    kick: Kick,
    params: BedParams,
}

fn single(y0: f64) -> Single {
    let mut params = BedParams::defaults();
    params.friction = Friction::None;
    let particles = Particles::new(&params, vec![0]);
    let geometry = Geometry {
        width: 2.0,
        height: 20.0,
        start_height: 20.0,
        final_height: 20.0,
    };
    let state = State {
        position: vec![Vector2::new(1.0, y0)],
        velocity: vec![Vector2::zeros()],
        piston: 20.0,
        time: 0.0,
    };
    let mut field = ForceField::new(&params, &particles, geometry);
    field.evaluate(&particles, &state);
    let kick = Kick::of(&params, false);
    Single {
        particles,
        field,
        state,
        kick,
        params,
    }
}

impl Single {
    /// One Störmer–Verlet step of length dt with the piston held where it is.
    fn step_by(&mut self, dt: f64) {
        let piston = self.state.piston;
        step(
            &mut self.state,
            &self.particles,
            &mut self.field,
            &self.kick,
            dt,
            piston,
        );
    }

    fn run_fixed(&mut self, dt: f64, t_end: f64) {
        let n = (t_end / dt).round() as usize;
        for _ in 0..n {
            self.step_by(dt);
        }
    }

    fn run_adaptive(&mut self, factor: f64, t_end: f64) -> usize {
        let mut steps = 0;
        while self.state.time < t_end {
            let scan = StepScan::of(&self.state, &self.particles, &self.field, &self.kick);
            let dt = scan.time_step(factor, 1e-3).min(t_end - self.state.time);
            self.step_by(dt);
            steps += 1;
        }
        steps
    }

    /// ½ m v² + m g y + Σ_walls c/(2.5 w^2.5) (the potential of the empirical wall law).
    fn energy(&self) -> f64 {
        let (p, v) = (self.state.position[0], self.state.velocity[0]);
        let m = self.particles.mass[0];
        let c = magopt::units::MU0 * self.particles.moment[0] * self.params.wall_strength()
            / (2.0 * std::f64::consts::PI);
        let walls = [p.y, p.x, 2.0 - p.x, self.state.piston - p.y];
        0.5 * m * v.norm_squared()
            + m * self.params.gravity * p.y
            + walls.iter().map(|w| c / (2.5 * w.powf(2.5))).sum::<f64>()
    }
}

#[test]
fn free_fall_from_rest_follows_half_g_t_squared() {
    let mut s = single(10.0);
    let t = 0.8;
    s.run_fixed(1e-3, t);
    let drop = 10.0 - s.state.position[0].y;
    let expected = 0.5 * 9.8 * t * t;
    // the floor at 7 m pushes with ~1e-11 of gravity; Verlet is exact for a constant force
    assert!(
        (drop - expected).abs() < 1e-9 * expected,
        "{drop} vs {expected}"
    );
    assert_eq!(s.state.position[0].x, 1.0, "side walls cancel by symmetry");
}

#[test]
fn bounce_on_the_magnetic_floor_converges_at_second_order() {
    // dropped from 8 cm; the floor balances gravity at 3.3 cm; 0.6 s spans ~3 bounces
    let t_end = 0.6;
    let position = |dt: f64| {
        let mut s = single(0.08);
        s.run_fixed(dt, t_end);
        s.state.position[0].y
    };
    let reference = position(2.5e-6);
    let errors: Vec<f64> = [8e-5, 4e-5, 2e-5]
        .iter()
        .map(|&dt| (position(dt) - reference).abs())
        .collect();
    for pair in errors.windows(2) {
        let order = (pair[0] / pair[1]).log2();
        assert!(
            (1.8..2.2).contains(&order),
            "order {order}, errors {errors:?}"
        );
    }
}

#[test]
fn energy_is_conserved_over_many_bounces() {
    let mut s = single(0.08);
    let e0 = s.energy();
    let mut worst: f64 = 0.0;
    for k in 1..=40 {
        s.run_adaptive(s.params.time_step_factor(), 0.25 * k as f64);
        worst = worst.max((s.energy() - e0).abs());
    }
    // 10 s ≈ 50 bounces; the bounce energy scale is m g × 5 cm
    let scale = s.particles.mass[0] * 9.8 * 0.05;
    assert!(worst < 2e-3 * scale, "drift {worst} J of {scale} J");
}

#[test]
fn pair_forces_obey_action_and_reaction() {
    let (a, b) = (Vector2::new(0.013, 0.021), Vector2::new(0.0305, 0.0102));
    assert_eq!(pair_force(0.08, 0.05, a, b), -pair_force(0.05, 0.08, b, a));
    // in a huge cell without gravity the internal forces of a cluster sum to zero
    let mut params = BedParams::defaults();
    params.gravity = 0.0;
    params.neighbors = Neighbors::Exact;
    let species: Vec<usize> = (0..40).map(|k| k % 2).collect();
    params.preset = magopt::models::bed::params::Preset::Bidisperse;
    params.mixing_ratio = 0.5;
    let particles = Particles::new(&params, species);
    let geometry = Geometry {
        width: 1e4,
        height: 1e4,
        start_height: 1e4,
        final_height: 1e4,
    };
    let state = State {
        position: (0..40)
            .map(|k| {
                Vector2::new(
                    5e3 + 0.011 * (k % 7) as f64,
                    5e3 + 0.013 * (k / 7) as f64 + 1e-3 * (k % 3) as f64,
                )
            })
            .collect(),
        velocity: vec![Vector2::zeros(); 40],
        piston: 1e4,
        time: 0.0,
    };
    let mut field = ForceField::new(&params, &particles, geometry);
    field.evaluate(&particles, &state);
    let total: Vector2<f64> = field.out.iter().map(|o| o.force).sum();
    let largest = field.out.iter().map(|o| o.force.norm()).fold(0.0, f64::max);
    assert!(total.norm() < 1e-12 * largest, "{total:?} vs {largest}");
}

/// 16 discs under the former heights φ 0.12 → 0.34 (a short stroke keeps these tests fast).
fn small_bed() -> BedParams {
    let mut p = BedParams::defaults();
    p.heights = Heights::PackingFractions;
    p.particles = Some(16);
    p.piston_speed = 0.05;
    p.relaxation_time = 0.5;
    p.piston_decay_time = 0.1;
    p.settle_time = 0.3;
    p.snapshots = false;
    p
}

/// Lists whose cut-off lies beyond the cell hold every pair: the three list modes gather the
/// same terms in the same order (the same bits), and the exact sums (each pair once, in tiles
/// of lanes: the same terms added in another order) agree with them to round-off over the
/// whole cycle (F_max and every recorded series but the kinetic energy). Round-off is ~1e-16
/// per evaluation; the cycle's stick-slip amplifies it along the way, to below 1e-12 of each
/// series' scale at the time-step factor 0.2 and to 1e-11 at the default 0.4 (measured
/// 2026-12-05: 8.7e-11 N in a piston force of 9.15 N). A missing pair or a wrong term would
/// show at the 1e-4 level, far above the 1e-10 asked.
#[test]
fn lists_with_a_cutoff_beyond_the_cell_reproduce_exact_sums() {
    let mut p = small_bed();
    p.neighbors = Neighbors::Exact;
    let exact = run_cycle(&p, 3, &|_| {});
    assert!(exact.failure.is_none(), "{:?}", exact.failure);
    p.cutoff = Reach::Diameters(100.0);
    p.list_radius = Reach::Diameters(120.0);
    let listed: Vec<_> = [Neighbors::Cells, Neighbors::Verlet, Neighbors::SourceVerlet]
        .into_iter()
        .map(|kind| {
            p.neighbors = kind;
            run_cycle(&p, 3, &|_| {})
        })
        .collect();
    for other in &listed[1..] {
        assert_eq!(other.max_force, listed[0].max_force);
        assert_eq!(other.series, listed[0].series);
    }
    let (a, b) = (listed[0].max_force.unwrap(), exact.max_force.unwrap());
    assert!((a - b).abs() <= 1e-10 * b, "F_max {a} vs {b}");
    for ((name, list), (_, exact)) in listed[0].series.0.iter().zip(&exact.series.0) {
        assert_eq!(list.len(), exact.len(), "{name}");
        if name == "kinetic_energy" {
            // a residual of balanced forces near rest: round-off of the forces shows in it
            // at ~1e-11 of its own scale; the positions and forces below pin the motion
            continue;
        }
        let scale = exact.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
        for (l, e) in list.iter().zip(exact) {
            assert!(
                (l.0 - e.0).abs() <= 1e-12 * e.0.abs(),
                "{name} t {l:?} vs {e:?}"
            );
            assert!((l.1 - e.1).abs() <= 1e-10 * scale, "{name}: {l:?} vs {e:?}");
        }
    }
}

/// The quadtree with θ = 0 opens every node: its far sums are the exact sums beyond r_s, and
/// with the near list the cycle is the exact one to round-off (another summation order).
#[test]
fn a_tree_that_opens_every_node_reproduces_exact_sums() {
    let mut p = small_bed();
    p.particles = Some(60);
    p.neighbors = Neighbors::Exact;
    let exact = run_cycle(&p, 3, &|_| {});
    p.neighbors = Neighbors::Tree;
    p.opening_angle = 0.0;
    let tree = run_cycle(&p, 3, &|_| {});
    assert!(tree.failure.is_none(), "{:?}", tree.failure);
    assert_eq!(tree.steps, exact.steps);
    let (a, b) = (tree.max_force.unwrap(), exact.max_force.unwrap());
    assert!((a - b).abs() <= 1e-11 * b, "F_max {a} vs {b}");
}

#[test]
fn the_list_radius_changes_the_rebuilds_but_no_result() {
    let mut p = small_bed();
    p.cutoff = Reach::Diameters(3.0); // inside the 16-disc cell, so the cut-off matters
    let runs: Vec<_> = [3.3, 5.0, 11.26]
        .iter()
        .map(|&rv| {
            p.list_radius = Reach::Diameters(rv);
            run_cycle(&p, 2, &|_| {})
        })
        .collect();
    for r in &runs[1..] {
        assert_eq!(r.max_force, runs[0].max_force);
        assert_eq!(r.series, runs[0].series);
    }
    assert!(
        runs[0].list_builds > runs[2].list_builds,
        "{}",
        runs[0].list_builds
    );
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mut p = small_bed();
    // a fast descent that presses the top rows (closest pair 1.08 D with steps of a tenth of
    // the rule's, from 1.15 D at rest); at 2 m/s even such steps came to 0.904 D, at the edge
    // of the 0.9 D check (results/bench/README.md, "Bed: a bound on a step's approach")
    p.relaxation_time = 1.0;
    p.piston_decay_time = 0.4;
    p.settle_time = 0.0;
    p.piston_speed = 1.5;
    p.max_packing_fraction = Some(0.13);
    // 300 discs: parallel pair sums; 4500: also parallel kicks, drifts and list builds, with
    // the far field held for 3 steps; the quadtree's leaves run in parallel
    for (neighbors, n, k) in [
        (Neighbors::Verlet, 300, 1),
        (Neighbors::Verlet, 4500, 3),
        (Neighbors::Tree, 1000, 2),
    ] {
        p.neighbors = neighbors;
        p.particles = Some(n);
        p.far_field_interval = k;
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run_cycle(&p, 9, &|_| {}))
        };
        let (one, two) = (run(1), run(2));
        assert!(
            one.steps > 10 && one.failure.is_none(),
            "N = {n}: {:?}",
            one.failure
        );
        assert_eq!(one.series, two.series);
        assert_eq!(one.max_force, two.max_force);
    }
}

#[test]
fn semi_implicit_dry_friction_agrees_with_a_small_step_explicit_reference() {
    // Same model (v_t = 1e-4 m/s so the explicit reference is affordable: its step is limited
    // to 0.1 m v_t/(μ_d N)); the semi-implicit scheme runs at the repulsion's step.
    let mut p = small_bed();
    p.threshold_speed = 1e-4;
    p.neighbors = Neighbors::Exact;
    let implicit = run_cycle(&p, 4, &|_| {});
    p.friction_scheme = FrictionScheme::Explicit;
    let explicit = run_cycle(&p, 4, &|_| {});
    assert!(implicit.failure.is_none() && explicit.failure.is_none());
    assert!(
        explicit.steps > 20 * implicit.steps,
        "{} vs {}",
        explicit.steps,
        implicit.steps
    );
    let rel = |a: Option<f64>, b: Option<f64>| (a.unwrap() - b.unwrap()).abs() / b.unwrap().abs();
    let f = rel(
        implicit.force_at_max_compression,
        explicit.force_at_max_compression,
    );
    let w = rel(implicit.cycle_work, explicit.cycle_work);
    eprintln!(
        "force rel diff {f:.2e}, work rel diff {w:.2e}, steps {} vs {}",
        implicit.steps, explicit.steps
    );
    // Tolerance from the one physical difference between the schemes: the explicit law lets a
    // stuck disc creep at up to v_t. Over the ~0.6 s compression that is ≤ 6e-5 m ≈ 0.01 D
    // against a spacing of ≥ 1.3 D, and the r⁻⁴ forces change by ≤ 4 × 0.01/1.3 ≈ 3 %;
    // we ask for 2 % on the force and 5 % on the work (a difference of two branches).
    assert!(
        f < 0.02,
        "piston force at maximum compression differs by {f}"
    );
    assert!(w < 0.05, "dissipated work differs by {w}");
}

/// 24 discs at 20 mm/s under the heights φ 0.12 → 0.34, where their dynamics stay regular
/// (under the source's longer stroke they do not), with the default relaxation (3 s + 1 s
/// rest) so that compression starts from a settled bed.
fn regular_bed() -> BedParams {
    let mut p = BedParams::defaults();
    p.heights = Heights::PackingFractions;
    p.particles = Some(24);
    p.piston_speed = 0.02;
    p.snapshots = false;
    p
}

/// One cycle of seed 1, which must not fail.
fn succeeding_cycle(p: &BedParams) -> magopt::models::bed::BedOutcome {
    let o = run_cycle(p, 1, &|_| {});
    assert!(o.failure.is_none(), "{:?}", o.failure);
    o
}

#[test]
fn piston_force_converges_as_the_time_step_factor_is_refined() {
    // the pair sums alone: the tail, computed anew only once a disc has moved r_c/64, adds an
    // error that does not shrink with the step (below)
    let mut p = regular_bed();
    p.tail_correction = TailCorrection::None;
    let errors = force_errors_against_a_fine_step(&mut p, &[0.8, 0.4, 0.2]);
    eprintln!("relative force errors at factors 0.8, 0.4, 0.2: {errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    // the documented claims: at factor 0.2 (the damper's default) the force is converged to
    // 1e-4; at the cycle's default 0.4 to 1e-3, an order of magnitude below the chaotic scatter
    // of F_max between seeds (0.6-1 %, results/bed/README.md)
    assert!(errors[2] < 1e-4, "{errors:?}");
    assert!(errors[1] < 1e-3, "{errors:?}");
    // ... which holds with the default tail too (its held values differ from fresh ones by a
    // few per cent of the tail, itself a few per cent of the force here)
    let mut p = regular_bed();
    let errors = force_errors_against_a_fine_step(&mut p, &[0.4, 0.2]);
    eprintln!("with the tail, relative force errors at factors 0.4, 0.2: {errors:?}");
    assert!(errors[0] < 1e-3 && errors[1] < 1e-4, "{errors:?}");
}

/// The relative errors of the force at maximum compression at each time-step factor against
/// factor 0.0125.
fn force_errors_against_a_fine_step(p: &mut BedParams, factors: &[f64]) -> Vec<f64> {
    let mut force = |factor: f64| {
        p.time_step_factor = Some(factor);
        succeeding_cycle(p).force_at_max_compression.unwrap()
    };
    let reference = force(0.0125);
    factors
        .iter()
        .map(|&f| (force(f) - reference).abs() / reference)
        .collect()
}

#[test]
fn multiple_time_stepping_converges_to_every_step_sums() {
    // 24 discs (regular dynamics): the far pairs (r ≥ 3 D) held for k steps. The error of the
    // piston force against k = 1 shrinks as k does, and is below 1e-3 at the documented k = 4.
    // The cycle work (a small difference of large integrals over stick-slip motion) is
    // printed, not asserted: it moves by 0.1–4 % without a monotone trend in k. The pair sums
    // alone: the tail's own hold (until a disc has moved r_c/64) would add an error of its own.
    let mut p = regular_bed();
    p.tail_correction = TailCorrection::None;
    // at the step these errors were measured at: at the default factor 0.4 the held far field
    // spans twice the time, and K = 16 then lands closer than K = 8 (1.4e-3 against 5.3e-3;
    // K = 4: 5.6e-4), the stick-slip's response to a held force not being monotone in it
    p.time_step_factor = Some(0.2);
    let mut force = |k: usize| {
        p.far_field_interval = k;
        let o = succeeding_cycle(&p);
        (o.force_at_max_compression.unwrap(), o.cycle_work.unwrap())
    };
    let (reference, work) = force(1);
    let errors: Vec<(f64, f64)> = [16, 8, 4, 2]
        .iter()
        .map(|&k| {
            let (f, w) = force(k);
            ((f - reference).abs() / reference, (w - work).abs() / work)
        })
        .collect();
    eprintln!("relative force and work errors at k = 16, 8, 4, 2: {errors:?}");
    let force_errors: Vec<f64> = errors.iter().map(|e| e.0).collect();
    assert!(
        force_errors.windows(2).all(|w| w[0] > w[1]),
        "{force_errors:?}"
    );
    assert!(force_errors[2] < 1e-3, "{force_errors:?}");
}
