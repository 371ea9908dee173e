//! The readings of the near-field law (C8, Zohdi 2016 Eq. (7.23)): coefficients based on
//! mass, surface area, volume or charge, with or without the charge-sign factor c_i c_j, and
//! a cut-off. Each is checked on two particles for action = reaction and for the analytic
//! force (α1 r^{−β1} − α2 r^{−β2}) c_i c_j along n_ij, through the full force gather.

use magopt::models::blast::cloud::Cloud;
use magopt::models::blast::interact::Interactor;
use magopt::models::blast::{BlastParams, DragLaw, Interactions, NearFieldBasis};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Two particles `distance` apart along (1, 2, −2)/3, B = 0, no drag, near field only, with
/// charges per mass of signs `signs`; returns (params, force on 0, force on 1).
fn pair_forces(
    basis: NearFieldBasis,
    charge_sign: bool,
    signs: (f64, f64),
    distance: f64,
    cutoff: f64,
) -> (BlastParams, Vector3<f64>, Vector3<f64>) {
    let mut p = BlastParams::source_example();
    p.field_strength = 0.0;
    p.drag = DragLaw::None;
    p.interactions = Interactions::parse("near-field").unwrap();
    p.near_field.basis = basis;
    p.near_field.charge_sign = charge_sign;
    p.near_field.cutoff = cutoff;
    // The law itself, to round-off: the default's single-precision lanes are checked apart.
    p.near_field.precision = magopt::models::blast::NearFieldPrecision::Double;
    let direction = Vector3::new(1.0, 2.0, -2.0) / 3.0;
    let mut cloud = Cloud::at_rest(vec![Vector3::zeros(), distance * direction], &p);
    cloud.charge_per_mass[0] *= signs.0;
    cloud.charge_per_mass[1] *= signs.1;
    let mut forces = vec![Vector3::zeros(); 2];
    let mut moments = forces.clone();
    Interactor::new(&p, 2).evaluate(&cloud, 1e-4, &mut forces, &mut moments);
    (p, forces[0], forces[1])
}

/// The particle's weight w of each basis for the source's spheres (R = 0.05 m,
/// ρ = 7000 kg/m³, q/m = 10 C/kg).
fn weight(p: &BlastParams, basis: NearFieldBasis) -> f64 {
    let r = p.radius;
    match basis {
        NearFieldBasis::Mass => p.density * 4.0 / 3.0 * PI * r.powi(3),
        NearFieldBasis::Area => 4.0 * PI * r * r,
        NearFieldBasis::Volume => 4.0 / 3.0 * PI * r.powi(3),
        NearFieldBasis::Charge => p.charge_per_mass * p.density * 4.0 / 3.0 * PI * r.powi(3),
    }
}

#[test]
fn every_basis_and_sign_reading_gives_the_analytic_pair_force_and_reaction() {
    let bases = [
        NearFieldBasis::Mass,
        NearFieldBasis::Area,
        NearFieldBasis::Volume,
        NearFieldBasis::Charge,
    ];
    let direction = Vector3::new(1.0, 2.0, -2.0) / 3.0;
    for basis in bases {
        for charge_sign in [false, true] {
            for signs in [(1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
                for distance in [0.01, 0.03, 0.35, 1.7] {
                    let (p, fi, fj) = pair_forces(basis, charge_sign, signs, distance, 0.0);
                    let w2 = weight(&p, basis).powi(2);
                    let nf = &p.near_field;
                    let c = if charge_sign { signs.0 * signs.1 } else { 1.0 };
                    let magnitude =
                        c * w2 * (nf.attraction / distance - nf.repulsion / (distance * distance));
                    let expected = magnitude * direction; // on 0, towards 1 when attractive
                    let label = format!("{basis:?} sign {charge_sign} {signs:?} r = {distance}");
                    assert!(
                        (fi - expected).norm() <= 1e-12 * expected.norm(),
                        "{label}: {fi:?} vs {expected:?}"
                    );
                    assert!((fi + fj).norm() <= 1e-12 * fi.norm(), "{label}: reaction");
                }
            }
        }
    }
}

#[test]
fn unlike_charges_flip_the_law_only_with_the_sign_factor() {
    let far = 1.0; // beyond r* = ᾱ2/ᾱ1 = 0.02 m: the like-signed law attracts
    let (_, like, _) = pair_forces(NearFieldBasis::Mass, true, (1.0, 1.0), far, 0.0);
    let (_, unlike, _) = pair_forces(NearFieldBasis::Mass, true, (1.0, -1.0), far, 0.0);
    let (_, spec, _) = pair_forces(NearFieldBasis::Mass, false, (1.0, -1.0), far, 0.0);
    let toward = Vector3::new(1.0, 2.0, -2.0) / 3.0;
    assert!(like.dot(&toward) > 0.0, "like charges attract");
    assert!(
        unlike.dot(&toward) < 0.0,
        "unlike charges repel with c_i c_j"
    );
    assert_eq!(unlike, -like);
    assert_eq!(spec, like, "without the factor the sign does not matter");
}

#[test]
fn cutoff_reading_keeps_the_pair_force_inside_and_drops_it_outside() {
    for (distance, inside) in [(0.3, true), (0.6, false)] {
        let (p, fi, fj) = pair_forces(NearFieldBasis::Mass, false, (1.0, 1.0), distance, 0.5);
        let (_, exact, _) = pair_forces(NearFieldBasis::Mass, false, (1.0, 1.0), distance, 0.0);
        assert_eq!(fi, if inside { exact } else { Vector3::zeros() }, "{p:?}");
        assert_eq!(fi + fj, Vector3::zeros());
    }
}

/// The single-precision all-pairs near field follows the exact run of the interacting model
/// (every term on, mixed charges with the sign factor): after 0.05 s (about 200 adaptive
/// steps) its positions lie within 10⁻⁶ particle radii of the exact run's, and on the final cloud its near field is within 10⁻⁶ of the exact sum.
#[test]
fn single_precision_follows_the_exact_run() {
    use magopt::models::blast::interact::near_field_error;
    use magopt::models::blast::{run, NearFieldPrecision};
    let mut p = BlastParams::source_example();
    p.particles = 300;
    p.interactions = Interactions::all();
    p.negative_fraction = 0.3;
    p.near_field.charge_sign = true;
    p.duration = 0.05;
    p.near_field.precision = NearFieldPrecision::Double;
    let exact = run(&p, 3, &|_| {}, None).unwrap();
    p.near_field.precision = NearFieldPrecision::Single;
    let single = run(&p, 3, &|_| {}, None).unwrap();
    assert!(exact.failure.is_none() && single.failure.is_none());
    let apart = exact
        .cloud
        .positions
        .iter()
        .zip(&single.cloud.positions)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let (largest, rms) = near_field_error(&p, &single.cloud);
    eprintln!(
        "steps {} apart {apart:.2e} m; error {largest:.1e} {rms:.1e}",
        exact.stats.steps
    );
    assert!(apart < 1e-6 * p.radius, "{apart:.2e} m");
    assert!(largest < 1e-6 && rms < 1e-6, "{largest:.1e} {rms:.1e}");
}

/// Two 4 × 4 × 4 lattices of the source's spheres (spacing 1.05 diameters, each site nudged
/// off the lattice), their centres `apart` m apart along x; half the charges negative.
fn two_clusters(p: &BlastParams, apart: f64) -> Cloud {
    let spacing = 2.1 * p.radius;
    let mut positions = Vec::new();
    for side in [-0.5, 0.5] {
        for k in 0..64 {
            let (i, j, l) = ((k % 4) as f64, ((k / 4) % 4) as f64, (k / 16) as f64);
            let nudge = 0.1 * p.radius * ((k * 37 % 11) as f64 / 11.0 - 0.5);
            let site = Vector3::new(i + nudge, j - nudge, l) * spacing;
            positions.push(site + Vector3::x() * side * apart);
        }
    }
    let mut cloud = Cloud::at_rest(positions, p);
    for (k, q) in cloud.charge_per_mass.iter_mut().enumerate() {
        *q *= if k % 2 == 0 { 1.0 } else { -1.0 };
    }
    cloud
}

/// The near-field forces of `precision` on `cloud`, N.
fn near_field_forces(
    p: &BlastParams,
    precision: magopt::models::blast::NearFieldPrecision,
    cloud: &Cloud,
) -> Vec<Vector3<f64>> {
    let mut p = p.clone();
    p.near_field.precision = precision;
    Interactor::new(&p, cloud.len()).near_field(cloud)
}

/// The default precision (`auto`) sums in single precision while the cloud is at most 1000
/// particle diameters across, and there its error stays within the bound that sets the limit
/// (10⁻³ of the largest force; two clusters at the ends of a 997-diameter box, where the
/// rounding of the coordinates is largest); beyond the limit it gives the exact sum's bits.
#[test]
fn auto_precision_is_single_within_the_extent_limit_and_exact_beyond() {
    use magopt::models::blast::interact::near_field_error;
    use magopt::models::blast::NearFieldPrecision::{Auto, Double, Single};
    let mut p = BlastParams::source_example();
    p.interactions = Interactions::parse("near-field").unwrap();
    p.near_field.charge_sign = true;
    let diameter = 2.0 * p.radius;
    let cluster = 3.0 * 1.05 * diameter + diameter;
    for (across, single) in [(997.0, true), (1003.0, false)] {
        let cloud = two_clusters(&p, across * diameter - cluster);
        let auto = near_field_forces(&p, Auto, &cloud);
        let expected = near_field_forces(&p, if single { Single } else { Double }, &cloud);
        assert_eq!(auto, expected, "{across} diameters");
        let (largest, rms) = near_field_error(&p, &cloud);
        eprintln!("{across} diameters: error {largest:.1e} largest, {rms:.1e} rms");
        assert!(largest < 1e-3, "{largest:.1e}");
    }
}
