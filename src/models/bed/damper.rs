//! The magnetic granular damper (spec "Damper"): after the relaxation to H0 the piston, a free
//! body of mass M, is released and falls under gravity onto the bed (particles damped
//! viscously, plus dry friction if the friction model has it), comes to rest, is nudged up by
//! 0.2 D_1 and released again. The first fall ends when the piston rests (speed < 1e-4 m/s,
//! bed force within 1 % of its weight; at most 20 `damper_time`s, else a failed run). The outputs
//! are the first fall z(t) (series `piston_fall_z`, time from the first release), fitted in the
//! source's normalization (`damper_fall_fit`), and the second motion z(t): series `piston_z`
//! and `piston_displacement` (z − z_rest), time measured from the second release. A piston
//! heavy enough to crush the bed (discs closer than the allowed ratio, a centre through the
//! piston) is a failed run.

use super::damper_fall_fit::{fit_first_fall, FALL_FIT_SAMPLES, SERIES as FALL_SERIES};
use super::damper_fit::{fit_damper, FIT_SAMPLES};
use super::integrator::{half_kick, kick_and_drift, Kick};
use super::protocol::{recorded, Simulation};
use super::{BedOutcome, BedParams};

/// Piston height and velocity.
#[derive(Debug, Clone, Copy)]
struct Piston {
    velocity: f64,
    mass: f64,
    gravity: f64,
}

impl Piston {
    fn kick(&mut self, force: f64, h: f64) {
        self.velocity += h * (force / self.mass - self.gravity);
    }
}

/// One damper run of (parameters, seed).
pub fn run_damper(params: &BedParams, seed: u64, progress: &dyn Fn(f64)) -> BedOutcome {
    recorded(params, seed, progress, None, damper).0
}

/// The damper protocol after the start: relaxation, free fall to rest, the released drop.
pub fn damper(sim: &mut Simulation, out: &mut BedOutcome) -> Result<(), String> {
    out.relaxation_speed = Some(sim.relax()?);
    let p = sim.params;
    let mut piston = Piston {
        velocity: 0.0,
        mass: p.piston_mass,
        gravity: p.gravity,
    };
    let release = sim.state.time;
    if !fall(sim, &mut piston, None)? {
        return Err(format!(
            "the piston did not come to rest within {} s (speed ≥ {REST_SPEED} m/s or force \
             off balance by ≥ {} of its weight)",
            REST_LIMIT * p.damper_time,
            REST_FORCE
        ));
    }
    match fit_first_fall(&sim.series, p.gravity, FALL_FIT_SAMPLES) {
        Ok(fit) => out.damper_fall_fit = Some(fit),
        Err(e) => out.warnings.push(format!("first-fall fit failed: {e}")),
    }
    let rest = sim.state.piston;
    out.damper_rest_height = Some(rest);
    sim.moment("rest", out);
    sim.state.piston += 0.2 * p.reference_diameter();
    piston.velocity = 0.0;
    sim.field.evaluate(&sim.particles, &sim.state);
    fall(sim, &mut piston, Some(rest))?;
    sim.moment("end", out);
    match fit_damper(&sim.series, rest, p.reference_diameter(), FIT_SAMPLES) {
        Ok(fits) => out.damper_fits = Some(fits),
        Err(e) => out.warnings.push(format!("damper fits failed: {e}")),
    }
    out.max_force = Some(
        sim.series
            .get("piston_force")
            .iter()
            .filter(|&&(t, _)| t >= release)
            .map(|&(_, f)| f)
            .fold(0.0, f64::max),
    );
    Ok(())
}

/// The first fall ends at rest: piston speed below this, m/s …
const REST_SPEED: f64 = 1e-4;
/// … and the bed's force within this fraction of the piston's weight;
const REST_FORCE: f64 = 1e-2;
/// it may last this many `damper_time`s.
pub const REST_LIMIT: f64 = 20.0;

/// Without `rest`: the first fall, until the piston rests (returns whether it did), recording
/// z(t) as `piston_fall_z`. With `rest`: the second motion for `damper_time`, recording z(t)
/// from the release.
fn fall(sim: &mut Simulation, piston: &mut Piston, rest: Option<f64>) -> Result<bool, String> {
    let kick = Kick::of(sim.params, true);
    let limit = if rest.is_some() { 1.0 } else { REST_LIMIT };
    let (start, end) = (
        sim.state.time,
        sim.state.time + limit * sim.params.damper_time,
    );
    let weight = piston.mass * piston.gravity;
    let mut next_record = start;
    if rest.is_none() {
        sim.series.push(FALL_SERIES, 0.0, sim.state.piston);
        next_record += sim.params.damper_record_interval;
    }
    let mut scan = sim.scan(&kick);
    while end - sim.state.time > 1e-12 * end.max(1.0) {
        let omega2 = sim
            .field
            .out
            .iter()
            .map(|o| o.piston_stiffness)
            .sum::<f64>()
            / piston.mass;
        let dt = sim
            .time_step(&scan)
            .min(sim.params.time_step_factor() / omega2.sqrt())
            .min(end - sim.state.time);
        piston.kick(sim.field.piston_force(), 0.5 * dt);
        let beyond = kick_and_drift(
            &mut sim.state,
            &sim.particles,
            &sim.field,
            &kick,
            0.5 * dt,
            dt,
        );
        sim.state.piston += piston.velocity * dt;
        sim.state.time += dt;
        sim.field
            .evaluate_watched(&sim.particles, &sim.state, beyond);
        scan = half_kick(&mut sim.state, &sim.particles, &sim.field, &kick, 0.5 * dt);
        piston.kick(sim.field.piston_force(), 0.5 * dt);
        sim.after_step(&scan.extremes)
            .map_err(|r| format!("bed crushed by the piston of mass {} kg: {r}", piston.mass))?;
        let resting = piston.velocity.abs() < REST_SPEED
            && (sim.field.piston_force() - weight).abs() < REST_FORCE * weight;
        if rest.is_none() && resting && sim.state.time - start > 0.1 * sim.params.damper_time {
            return Ok(true);
        }
        if sim.state.time >= next_record {
            let (t, z) = (sim.state.time - start, sim.state.piston);
            match rest {
                Some(rest) => {
                    sim.series.push("piston_z", t, z);
                    sim.series.push("piston_displacement", t, z - rest);
                }
                None => sim.series.push(FALL_SERIES, t, z),
            }
            next_record = sim.state.time + sim.params.damper_record_interval;
        }
    }
    Ok(rest.is_some())
}
