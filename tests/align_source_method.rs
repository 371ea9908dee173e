//! The source's friction scheme as a variant (issue 12 item 2; docs/align.md, "The ≈ 40 kOe
//! question"): E&B 2020, Eq. (8) evaluated from the previous iterate's velocities, no implicit
//! solve. Without friction it is the implicit scheme bit for bit; with friction it loses much of
//! the friction effect (the spec's warning about explicit fixed points, align.md A5).

use magopt::materials::MaterialDb;
use magopt::models::align::dem::{self, Packing};
use magopt::models::align::{AlignParams, FrictionScheme};
use magopt::units::si_per_unit;

fn tau(friction: f64, scheme: FrictionScheme) -> f64 {
    let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
    let mut params = AlignParams::paper_defaults(material, 40.0 * si_per_unit("kOe"));
    params.particles = 80;
    params.friction = friction;
    params.wall_friction = friction;
    params.numerics.friction_scheme = scheme;
    let packing = Packing::generate(&params.packing(), 1).unwrap();
    dem::align(&params, &packing, None)
        .alignment_time_s
        .unwrap()
}

#[test]
fn explicit_friction_is_exact_without_friction_and_weaker_with_it() {
    let (implicit0, explicit0) = (
        tau(0.0, FrictionScheme::Implicit),
        tau(0.0, FrictionScheme::SourceExplicit),
    );
    assert_eq!(implicit0.to_bits(), explicit0.to_bits());
    let (implicit, explicit) = (
        tau(0.5, FrictionScheme::Implicit),
        tau(0.5, FrictionScheme::SourceExplicit),
    );
    println!("μ = 0.5: implicit {implicit} s, explicit {explicit} s, μ = 0: {implicit0} s");
    assert!(explicit > implicit0, "friction still slows alignment");
    assert!(
        explicit - implicit0 < 0.5 * (implicit - implicit0),
        "the explicit scheme keeps less than half the friction slow-down: {explicit} vs {implicit}"
    );
}
