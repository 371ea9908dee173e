//! The metastable Stoner–Wohlfarth branch in the DEM (issue 12 item 5; docs/align.md, "Moment
//! branch"): above H_K every metastable moment has already passed its switching field (h_sw ≤ 1),
//! so the run is the global-minimum run bit for bit; below H_K the moments that start pointing
//! away from H must first turn through 90° (or reach their switching field), so alignment is
//! slower.

use magopt::materials::MaterialDb;
use magopt::models::align::dem::{self, Packing};
use magopt::models::align::{AlignParams, MomentBranch};
use magopt::units::si_per_unit;

fn run(field_koe: f64, branch: MomentBranch) -> f64 {
    let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
    let mut params = AlignParams::paper_defaults(material, field_koe * si_per_unit("kOe"));
    params.particles = 60;
    params.moment_branch = branch;
    let packing = Packing::generate(&params.packing(), 1).unwrap();
    dem::align(&params, &packing, None)
        .alignment_time_s
        .unwrap()
}

#[test]
fn metastable_branch_matters_only_below_the_anisotropy_field() {
    // H_K ≈ 18.4 kOe for Sr ferrite
    let high = (
        run(40.0, MomentBranch::GlobalMinimum),
        run(40.0, MomentBranch::Metastable),
    );
    assert_eq!(high.0.to_bits(), high.1.to_bits(), "40 kOe: {high:?}");
    let low = (
        run(5.0, MomentBranch::GlobalMinimum),
        run(5.0, MomentBranch::Metastable),
    );
    assert!(low.1 > 1.1 * low.0, "5 kOe: {low:?}");
}
