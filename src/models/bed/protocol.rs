//! The compression cycle (spec "Protocol of one compression cycle"): perturbed grid, damped
//! relaxation under the exponentially slowing piston, rest at H0, compression at V_c to H_f,
//! expansion back to H0, optional final rest. [`Simulation`] holds a running bed and is shared
//! with the damper.

use std::time::Instant;

use super::forces::ForceField;
use super::integrator::{step, Kick, StepScan};
use super::observables::{
    area_fraction_profile, mean_distance, min_piston_distance, Extremes, Snapshot,
    AREA_FRACTION_SERIES,
};
use super::pair_work::PairWork;
use super::params::BedParams;
use super::state::{species_of, Geometry, Particles, State};
use super::{BedOutcome, Series};
use crate::output::snapshots::Recorder;

/// A bed being integrated, with its run checks and records.
pub struct Simulation<'a> {
    /// Parameters.
    pub params: &'a BedParams,
    /// Per-particle constants.
    pub particles: Particles,
    /// Cell and protocol heights.
    pub geometry: Geometry,
    /// Positions, velocities, piston, time.
    pub state: State,
    /// Forces of the current state.
    pub field: ForceField,
    /// Steps taken.
    pub steps: usize,
    /// What the steps' pair sums cost (benchmarks).
    pub pair_work: PairWork,
    /// Recorded time series.
    pub series: Series,
    /// Smallest pair distance over the run, in units of the pair's mean diameter.
    pub closest_pair: f64,
    /// Smallest centre–fixed-wall distance over the run, m.
    pub closest_wall: f64,
    /// Smallest centre–piston distance over the run, m.
    pub closest_piston: f64,
    /// Number-mean diameter ⟨D⟩, m (the unit of D̂ in "D units").
    pub mean_diameter: f64,
    next_record: f64,
    progress: &'a dyn Fn(f64),
    /// Writes the particle frames of a run with an output directory.
    pub recorder: Option<Recorder<'a>>,
}

impl<'a> Simulation<'a> {
    /// Protocol step 1 for (parameters, seed); forces evaluated.
    pub fn new(params: &'a BedParams, seed: u64, progress: &'a dyn Fn(f64)) -> Self {
        let geometry = Geometry::of(params);
        let particles = Particles::new(params, species_of(params));
        let state = State::initial(params, &geometry, seed);
        let mut field = ForceField::new(params, &particles, geometry);
        field.evaluate(&particles, &state);
        let mean_diameter = particles.diameter.iter().sum::<f64>() / particles.len() as f64;
        let pair_work = PairWork::new(particles.disc_area(), geometry.width);
        Self {
            params,
            particles,
            geometry,
            state,
            field,
            steps: 0,
            pair_work,
            series: Series::default(),
            closest_pair: f64::INFINITY,
            closest_wall: f64::INFINITY,
            closest_piston: f64::INFINITY,
            mean_diameter,
            next_record: 0.0,
            progress,
            recorder: None,
        }
    }

    /// Writes a scheduled frame if one is due now.
    fn offer_frame(&mut self) {
        if let Some(mut recorder) = self.recorder.take() {
            let step = self.steps as u64;
            if recorder.due(step, self.state.time) {
                recorder.frame(step, &self.snapshot("").frame());
            }
            self.recorder = Some(recorder);
        }
    }

    /// A moment of the protocol: kept in `out` (with `params.snapshots`) and written.
    pub fn moment(&mut self, label: &str, out: &mut BedOutcome) {
        let snapshot = self.snapshot(label);
        if let Some(recorder) = &mut self.recorder {
            recorder.moment(label, self.steps as u64, &snapshot.frame());
        }
        if self.params.snapshots {
            out.snapshots.push(snapshot);
        }
    }

    /// Integrates for `duration` with the piston at `piston(t since start of the stage)`,
    /// calling `each` after every step (with the piston displacement of that step).
    pub fn advance(
        &mut self,
        duration: f64,
        damped: bool,
        piston: &dyn Fn(f64) -> f64,
        each: &mut dyn FnMut(&Self, f64),
    ) -> Result<(), String> {
        self.advance_until(duration, damped, piston, each, &|_| false)
            .map(|_| ())
    }

    /// [`Self::advance`] that ends early, after the first step at which `stop` holds; returns
    /// the time advanced, s.
    pub fn advance_until(
        &mut self,
        duration: f64,
        damped: bool,
        piston: &dyn Fn(f64) -> f64,
        each: &mut dyn FnMut(&Self, f64),
        stop: &dyn Fn(&Self) -> bool,
    ) -> Result<f64, String> {
        let kick = Kick::of(self.params, damped);
        let (start, end) = (self.state.time, self.state.time + duration);
        let mut scan = self.scan(&kick);
        while end - self.state.time > 1e-12 * end.max(1.0) && !stop(self) {
            let dt = self.time_step(&scan).min(end - self.state.time);
            let before = self.state.piston;
            let after = piston(self.state.time + dt - start);
            scan = step(
                &mut self.state,
                &self.particles,
                &mut self.field,
                &kick,
                dt,
                after,
            );
            self.after_step(&scan.extremes)?;
            each(self, after - before);
        }
        Ok(self.state.time - start)
    }

    /// The scan of the current state and forces (what a step returns) for `kick`.
    pub fn scan(&self, kick: &Kick) -> StepScan {
        StepScan::of(&self.state, &self.particles, &self.field, kick)
    }

    /// The step the rule gives for the scanned forces.
    pub fn time_step(&self, scan: &StepScan) -> f64 {
        scan.time_step(self.params.time_step_factor(), self.params.max_time_step)
    }

    /// Counters, extremes, checks, recording and particle frames after a step whose state
    /// has the given extremes.
    pub fn after_step(&mut self, extremes: &Extremes) -> Result<(), String> {
        self.steps += 1;
        self.pair_work
            .record(&self.field, &self.state.position, self.state.piston);
        if self.steps > self.params.max_steps {
            return Err(format!(
                "step budget of {} steps spent at t = {:.4e} s: raise max_steps, or check the \
                 settings that shrink the time step (time_step_factor, viscous_time, \
                 piston_mass) or lengthen the run (final_rest, piston_speed)",
                self.params.max_steps, self.state.time
            ));
        }
        self.check(extremes)?;
        if self.state.time >= self.next_record {
            self.record();
            self.next_record = self.state.time + self.params.record_interval();
        }
        self.offer_frame();
        Ok(())
    }

    /// Flags blow-ups, discs closer than the allowed ratio and centres crossing a wall.
    fn check(&mut self, extremes: &Extremes) -> Result<(), String> {
        let t = self.state.time;
        let closest = if extremes.closeness > 0.0 {
            1.0 / extremes.closeness.sqrt()
        } else {
            f64::INFINITY
        };
        self.closest_pair = self.closest_pair.min(closest);
        self.closest_wall = self.closest_wall.min(extremes.wall);
        self.closest_piston = self.closest_piston.min(extremes.piston);
        if !extremes.finite {
            return Err(format!(
                "non-finite position or velocity at t = {t:.4} s (blow-up)"
            ));
        }
        if closest < self.params.min_distance_ratio {
            return Err(format!(
                "discs closer than {} D (closest pair at {closest:.3} D) at t = {t:.4} s",
                self.params.min_distance_ratio
            ));
        }
        if self.closest_wall < 0.0 || self.closest_piston < 0.0 {
            let wall = if self.closest_piston < 0.0 {
                "the piston"
            } else {
                "a wall"
            };
            return Err(format!(
                "bed collapse: a particle centre crossed {wall} at t = {t:.4} s (the wall law \
                 does not hold the bed)"
            ));
        }
        Ok(())
    }

    /// Appends one point to every series.
    pub fn record(&mut self) {
        let s = &self.state;
        let d_hat = mean_distance(&s.position);
        let phi = self.packing_fraction();
        let t = s.time;
        self.series.push("piston_height", t, s.piston);
        self.series
            .push("stroke", t, self.geometry.start_height - s.piston);
        self.series
            .push("piston_force", t, self.field.piston_force());
        self.series.push("packing_fraction", t, phi);
        self.series.push("mean_distance", t, d_hat);
        self.series
            .push("mean_distance_D", t, d_hat / self.mean_diameter);
        self.series
            .push("min_piston_distance", t, min_piston_distance(s));
        let ke: f64 = s
            .velocity
            .iter()
            .zip(&self.particles.mass)
            .map(|(v, m)| 0.5 * m * v.norm_squared())
            .sum();
        self.series.push("kinetic_energy", t, ke);
        let profile = area_fraction_profile(s, &self.particles.diameter, self.geometry.width);
        for (name, phi) in AREA_FRACTION_SERIES.iter().zip(profile) {
            self.series.push(name, t, phi);
        }
        (self.progress)(t);
    }

    /// D̂ in ⟨D⟩ of the latest recorded point (each record computes the O(N²) sum once).
    pub fn last_mean_distance(&self) -> Option<f64> {
        self.series.get("mean_distance_D").last().map(|&(_, d)| d)
    }

    /// φ at the current piston height.
    pub fn packing_fraction(&self) -> f64 {
        self.geometry
            .packing_fraction(self.particles.disc_area(), self.state.piston)
    }

    /// A snapshot of the current state.
    pub fn snapshot(&self, label: &str) -> Snapshot {
        Snapshot::take(
            label,
            &self.state,
            &self.particles,
            &self.field,
            (&self.geometry, self.params.gravity),
        )
    }

    /// Protocol step 2: piston from H down to H0 along
    /// H0 + (H − H0)(e^{−t/τ} − e^{−T/τ})/(1 − e^{−T/τ}) (exponentially slowing, exactly at H0
    /// at T), then at rest for the settle time; damped throughout; velocities zeroed at the end
    /// so compression starts from rest. Returns the largest speed just before zeroing.
    pub fn relax(&mut self) -> Result<f64, String> {
        let p = self.params;
        let (top, h0) = (self.geometry.height, self.geometry.start_height);
        let (total, tau) = (p.relaxation_time, p.piston_decay_time);
        let tail = (-total / tau).exp();
        let descent =
            move |t: f64| h0 + (top - h0) * (((-t / tau).exp() - tail) / (1.0 - tail)).max(0.0);
        self.advance(total, true, &descent, &mut |_, _| {})?;
        self.state.piston = h0;
        self.field.evaluate(&self.particles, &self.state);
        self.advance(p.settle_time, true, &|_| h0, &mut |_, _| {})?;
        let speed = self
            .state
            .velocity
            .iter()
            .map(|v| v.norm())
            .fold(0.0, f64::max);
        self.state
            .velocity
            .iter_mut()
            .for_each(|v| *v = nalgebra::Vector2::zeros());
        Ok(speed)
    }
}

/// Running extremes of the piston force during compression and expansion.
#[derive(Debug, Clone, Copy)]
struct Cycle {
    max_force: f64,
    work: f64,
    last_force: f64,
    min_mean_distance: f64,
}

/// One full compression cycle of (parameters, seed). `progress` receives the simulated time.
pub fn run_cycle(params: &BedParams, seed: u64, progress: &dyn Fn(f64)) -> BedOutcome {
    recorded(params, seed, progress, None, cycle).0
}

/// A run of `protocol` on a new bed whose frames `recorder` writes (handed back at the end).
pub fn recorded<'a>(
    params: &'a BedParams,
    seed: u64,
    progress: &'a dyn Fn(f64),
    recorder: Option<Recorder<'a>>,
    protocol: fn(&mut Simulation, &mut BedOutcome) -> Result<(), String>,
) -> (BedOutcome, Option<Recorder<'a>>) {
    let started = Instant::now();
    let mut sim = Simulation::new(params, seed, progress);
    sim.recorder = recorder;
    sim.offer_frame();
    let mut out = BedOutcome::new(&sim);
    let result = protocol(&mut sim, &mut out);
    out.finish(&sim, result, started.elapsed().as_secs_f64());
    (out, sim.recorder)
}

/// The compression cycle after the start (protocol steps 2–4).
pub fn cycle(sim: &mut Simulation, out: &mut BedOutcome) -> Result<(), String> {
    out.relaxation_speed = Some(sim.relax()?);
    sim.record();
    let compression_start = sim.state.time;
    let p = sim.params;
    let (h0, hf, v) = (
        sim.geometry.start_height,
        sim.geometry.final_height,
        p.piston_speed,
    );
    out.mean_distance_start = sim.last_mean_distance();
    out.record_structure(0, &sim.state.position);
    sim.moment("compression-start", out);
    let mut c = Cycle {
        max_force: sim.field.piston_force(),
        work: 0.0,
        last_force: sim.field.piston_force(),
        min_mean_distance: f64::INFINITY,
    };
    let mut track = |s: &Simulation, dp: f64| {
        let f = s.field.piston_force();
        c.max_force = c.max_force.max(f);
        c.work -= 0.5 * (f + c.last_force) * dp;
        c.last_force = f;
    };
    // with a target force the compression ends at the first step where F reaches it
    let target = p.target_force.unwrap_or(f64::INFINITY);
    let reached = |s: &Simulation| s.field.piston_force() >= target;
    let travel = sim.advance_until(
        (h0 - hf) / v,
        false,
        &|t| (h0 - v * t).max(hf),
        &mut track,
        &reached,
    )?;
    if !reached(sim) && p.target_force.is_some() {
        return Err(format!(
            "target_force: {target} N not reached before H_f = {hf:.4} m (piston force {:.3} N \
             there): raise max_packing_fraction or lower the target",
            sim.field.piston_force()
        ));
    }
    let bottom = sim.state.piston;
    out.stroke = h0 - bottom;
    sim.record();
    out.force_at_max_compression = Some(sim.field.piston_force());
    out.record_structure(1, &sim.state.position);
    sim.moment("max-compression", out);
    sim.advance(travel, false, &|t| (bottom + v * t).min(h0), &mut track)?;
    if p.final_rest > 0.0 {
        sim.advance(p.final_rest, false, &|_| h0, &mut |_, _| {})?;
    }
    sim.record();
    for &(t, d) in sim.series.get("mean_distance_D") {
        if t >= compression_start {
            c.min_mean_distance = c.min_mean_distance.min(d);
        }
    }
    out.max_force = Some(c.max_force);
    out.cycle_work = Some(c.work);
    out.mean_distance_min = Some(c.min_mean_distance);
    out.mean_distance_end = sim.last_mean_distance();
    out.record_structure(2, &sim.state.position);
    sim.moment("end", out);
    Ok(())
}
