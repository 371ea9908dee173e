//! The source's Verlet variant (de Paula 2025, §5.1, Eq. (5.4); docs/bed.md "Neighbour
//! cut-off") against the standard (r_v, r_c) list: equal right after a build, then it keeps
//! the pairs of its last build (those that left r_v included, those that entered r_v missed)
//! until a disc has moved r_s.

use magopt::models::bed::forces::{pair_force, ForceField};
use magopt::models::bed::params::{BedParams, Neighbors, Reach, TailCorrection};
use magopt::models::bed::state::{Geometry, Particles, State};
use nalgebra::Vector2;

const D: f64 = 6e-3;

/// Three equal discs near the middle of a 10 km cell without gravity: the walls add ~1e-19 of
/// the pair forces.
fn far_from_walls(offsets: [Vector2<f64>; 3]) -> State {
    State {
        position: offsets
            .iter()
            .map(|o| Vector2::new(5e3, 5e3) + o * D)
            .collect(),
        velocity: vec![Vector2::zeros(); 3],
        piston: 1e4,
        time: 0.0,
    }
}

/// The lists' truncated sums (no tail: the comparison is of the pairs each list keeps).
fn field(neighbors: Neighbors, cutoff: f64, list_radius: f64) -> (ForceField, Particles) {
    let mut params = BedParams::defaults();
    params.tail_correction = TailCorrection::None;
    params.gravity = 0.0;
    params.neighbors = neighbors;
    params.cutoff = Reach::Diameters(cutoff);
    params.list_radius = Reach::Diameters(list_radius);
    let particles = Particles::new(&params, vec![0; 3]);
    let geometry = Geometry {
        width: 1e4,
        height: 1e4,
        start_height: 1e4,
        final_height: 1e4,
    };
    (ForceField::new(&params, &particles, geometry), particles)
}

#[test]
fn the_source_variant_keeps_its_last_list_until_a_disc_has_moved_the_skin() {
    // r_v = 5 D for both; the standard list sums r < r_c = 5 D from a list of 6 D
    let (mut source, particles) = field(Neighbors::SourceVerlet, 7.13, 5.0);
    let (mut standard, _) = field(Neighbors::Verlet, 5.0, 6.0);
    let mut evaluate = |state: &State| {
        source.evaluate(&particles, state);
        standard.evaluate(&particles, state);
        (source.out[0], standard.out[0], source.list_builds())
    };
    // disc 1 inside r_v, disc 2 outside: the same pairs, the same bits
    let built = far_from_walls([
        Vector2::zeros(),
        Vector2::new(4.9, 0.0),
        Vector2::new(0.0, 5.2),
    ]);
    let (s, t, builds) = evaluate(&built);
    assert_eq!((s.force, s.normal, builds), (t.force, t.normal, 1));
    // 1 leaves r_v, 2 enters it, both by less than r_s = 4.13 D: the source variant still
    // sums 0–1 and misses 0–2
    let moved = far_from_walls([
        Vector2::zeros(),
        Vector2::new(5.1, 0.0),
        Vector2::new(0.0, 4.8),
    ]);
    let (s, t, builds) = evaluate(&moved);
    assert_eq!(builds, 1);
    let (p, mu) = (&moved.position, particles.moment[0]);
    let expected = pair_force(mu, mu, p[0], p[1]) - pair_force(mu, mu, p[0], p[2]);
    let difference = s.force - t.force;
    assert!(
        (difference - expected).norm() < 1e-12 * expected.norm(),
        "{difference:?} vs {expected:?}"
    );
    // the normal force (B4) likewise: 1/r³ of the kept pair instead of the missed one
    let r3 = |j: usize| (p[0] - p[j]).norm().powi(3);
    let ratio = (s.normal - t.normal) / t.normal;
    let expected_ratio = (1.0 / r3(1) - 1.0 / r3(2)) / (1.0 / r3(2));
    assert!(
        (ratio - expected_ratio).abs() < 1e-12,
        "{ratio} vs {expected_ratio}"
    );
    // once disc 1 has moved r_s the list is rebuilt and both agree again, bit for bit
    let rebuilt = far_from_walls([
        Vector2::zeros(),
        Vector2::new(4.9 + 4.2, 0.0),
        Vector2::new(0.0, 4.8),
    ]);
    let (s, t, builds) = evaluate(&rebuilt);
    assert_eq!((s.force, s.normal, builds), (t.force, t.normal, 2));
}

#[test]
fn the_source_variant_equals_exact_sums_when_its_list_covers_the_cell() {
    let (mut source, particles) = field(Neighbors::SourceVerlet, 7.13, 1e7);
    let (mut exact, _) = field(Neighbors::Exact, 7.13, 8.0);
    for spread in [1.5, 30.0, 300.0] {
        let state = far_from_walls([
            Vector2::zeros(),
            Vector2::new(spread, 0.3),
            Vector2::new(-0.2, spread),
        ]);
        source.evaluate(&particles, &state);
        exact.evaluate(&particles, &state);
        for (s, e) in source.out.iter().zip(&exact.out) {
            assert_eq!(
                (s.force, s.normal),
                (e.force, e.normal),
                "spread {spread} D"
            );
        }
    }
}

#[test]
fn the_source_variant_is_a_named_neighbour_mode() {
    let mut p = BedParams::defaults();
    p.neighbors = Neighbors::SourceVerlet;
    p.list_radius = Reach::Diameters(6.26); // below the default r_c: r_c plays no part here
    assert!(p.validate().is_ok());
}
