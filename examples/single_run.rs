//! One DEM alignment run and the ensemble prediction for the same material and field.
//! `cargo run --release --example single_run -- [particles] [field_kOe] [friction] [pressure_atm]`

use magopt::materials::MaterialDb;
use magopt::models::align::{dem, run_ensemble, AlignParams};
use magopt::units::si_per_unit;

fn main() -> magopt::Result<()> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let arg = |k: usize, default: f64| args.get(k).copied().unwrap_or(default);
    let material = MaterialDb::builtin().get("srfe12o19")?.clone();
    let mut params = AlignParams::paper_defaults(material, arg(1, 40.0) * si_per_unit("kOe"));
    params.particles = arg(0, 200.0) as usize;
    params.friction = arg(2, 0.2);
    params.wall_friction = params.friction;
    params.pressure = arg(3, 0.5) * si_per_unit("atm");
    params.numerics.solver_tolerance = arg(4, params.numerics.solver_tolerance);
    params.numerics.friction_regularization = arg(5, params.numerics.friction_regularization);
    params.numerics.rotation_step = arg(6, params.numerics.rotation_step);
    params.numerics.rest_speed = arg(7, params.numerics.rest_speed);
    params.numerics.settling_force = arg(8, params.numerics.settling_force);
    let started = std::time::Instant::now();
    let packing = dem::Packing::generate(&params.packing(), 1).map_err(magopt::Error::Output)?;
    println!(
        "packing: {:?} steps in {:.2} s",
        packing.steps,
        started.elapsed().as_secs_f64()
    );
    let outcome = dem::align(&params, &packing, None);
    println!(
        "DEM: status {:?}, tau {:?} s, tau90 {:?} s, A_end {:.4}, steps {}, sweeps {}, unconverged {}, phi {:?}, applied/nominal force {:?}/{:?} N, {:.2} s wall",
        outcome.status.label(), outcome.alignment_time_s, outcome.alignment_time_90_s, outcome.final_alignment,
        outcome.steps, outcome.solver_sweeps, outcome.unconverged_solves, outcome.packing_fraction,
        outcome.applied_force_n, outcome.nominal_force_n, outcome.wall_time_s
    );
    let ensemble = run_ensemble(&params);
    println!(
        "ensemble: tau {:?} s, tau90 {:?} s",
        ensemble.alignment_time_s, ensemble.alignment_time_90_s
    );
    Ok(())
}
