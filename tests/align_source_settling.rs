//! The source's settling as a variant (issue 12 item 2; docs/align.md, "The ≈ 40 kOe
//! question"): E&B 2020 §2.1 and §3 move the spheres overdamped (γ v = F, Heun's method, §2.3)
//! and "drop" them under gravity, a force ∝ mass. The packing it makes must be a resting one
//! (the same stop rules as FIRE's) and, like every run, the same at any thread count.

use magopt::materials::MaterialDb;
use magopt::models::align::dem::Packing;
use magopt::models::align::{AlignParams, SettlingScheme};
use magopt::units::si_per_unit;

fn dropped(particles: usize) -> (AlignParams, Packing) {
    let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
    let mut params = AlignParams::paper_defaults(material, 40.0 * si_per_unit("kOe"));
    params.particles = particles;
    params.numerics.settling_scheme = SettlingScheme::SourceDropped;
    let packing = Packing::generate(&params.packing(), 2).unwrap();
    (params, packing)
}

#[test]
fn dropped_spheres_rest_inside_the_die_without_overlaps() {
    let (params, p) = dropped(80);
    let tolerance = params.numerics.overlap_tolerance;
    let c = &p.container;
    for (i, (x, r)) in p.position.iter().zip(&p.radius).enumerate() {
        for (y, s) in p.position.iter().zip(&p.radius).skip(i + 1) {
            assert!(r + s - (x - y).norm() < tolerance, "pair overlap at {x:?}");
        }
        let gaps = [x.x - r, c.lx - x.x - r, x.y - r, c.ly - x.y - r, x.z - r];
        assert!(
            gaps.iter().all(|g| *g > -tolerance),
            "wall overlap at {x:?}"
        );
    }
    // dropped into a bed, not left where stage 1 spread them (3 die heights: φ ≈ 0.2)
    assert!(p.packing_fraction() > 0.4, "φ = {}", p.packing_fraction());
}

#[test]
fn dropped_packing_is_the_same_at_any_thread_count() {
    let at = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| dropped(60).1)
    };
    let (one, three) = (at(1), at(3));
    assert_eq!(one.steps, three.steps);
    for (a, b) in one.position.iter().zip(&three.position) {
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    }
}
