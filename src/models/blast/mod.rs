//! The `blast` model (spec blast.md): a blasted cloud of charged spheres in uniform static E
//! and B fields with drag and, optionally, contact, damping, friction, bonding, near-field
//! forces and rotation.
//!
//! - `params`, `switches`: parameters, defaults (the source's examples), validation, and the
//!   interaction switches.
//! - `cloud`: the state and the blast initial condition (C1).
//! - `field`: Lorentz force (C2), drag laws (C3), Boris rotation, exact drag decay.
//! - `pairs`, `interact`, `tree`: pair forces (C4–C8), the per-particle force gather, and
//!   the Barnes–Hut tree for the long-ranged near field.
//! - `explicit`, `trapezoid`: the integrators (Boris–Strang, forward Euler; C9 + C10).
//! - `observe`, `snapshot`: observables and snapshot writers; `study`: the study model.

pub mod all_pairs;
pub mod bond_lanes;
pub mod bonds;
pub mod cloud;
pub mod explicit;
pub mod field;
pub mod interact;
pub mod observe;
pub mod pairs;
pub mod params;
pub mod single;
mod single_lanes;
pub mod snapshot;
pub mod study;
pub mod switches;
pub mod theory;
pub mod trapezoid;
pub mod tree;

use std::time::Instant;

use crate::output::snapshots::Recorder;

use cloud::Cloud;
use explicit::Explicit;
use interact::{Interactor, StageTimes};
use observe::{clusters, kinetic_energy, Envelope, Motion};
pub use params::{
    BlastParams, DragLaw, Integrator, Interactions, NearFieldBasis, NearFieldPrecision,
};
use trapezoid::{StepStats, Trapezoid};

/// A cloud with its time and stepper.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The particles.
    pub cloud: Cloud,
    /// Current time, s.
    pub time: f64,
    params: BlastParams,
    stepper: Stepper,
}

#[derive(Debug, Clone)]
enum Stepper {
    Explicit(Explicit, usize),
    Implicit(Box<(Trapezoid, Interactor)>),
}

impl Simulation {
    /// Starts from a given cloud at t = 0.
    pub fn new(params: &BlastParams, cloud: Cloud) -> Self {
        let stepper = match params.integrator() {
            Integrator::Euler => Stepper::Explicit(Explicit::Euler, 0),
            Integrator::Boris | Integrator::Auto => Stepper::Explicit(Explicit::Boris, 0),
            Integrator::Trapezoidal => Stepper::Implicit(Box::new((
                Trapezoid::new(&params.step, &cloud),
                Interactor::new(params, cloud.len()),
            ))),
        };
        Self {
            cloud,
            time: 0.0,
            params: params.clone(),
            stepper,
        }
    }

    /// Advances to time `t` (s). Explicit schemes take equal steps no longer than Δt; the
    /// trapezoidal scheme clips its adaptive step at `t`. Err: why the run failed.
    pub fn advance_to(&mut self, t: f64) -> Result<(), String> {
        self.advance_observed(t, None, &mut |_, _, _| {})
    }

    /// [`advance_to`](Self::advance_to), calling `observe(steps, time, cloud)` after every
    /// step of the trapezoidal scheme and, for the explicit schemes (which take their steps in
    /// runs), after every step whose count is a multiple of `stride`.
    pub fn advance_observed(
        &mut self,
        t: f64,
        stride: Option<u64>,
        observe: &mut dyn FnMut(u64, f64, &Cloud),
    ) -> Result<(), String> {
        match &mut self.stepper {
            Stepper::Explicit(scheme, steps) => {
                let span = t - self.time;
                if span > 0.0 {
                    let n = (span / self.params.step.dt * (1.0 - 1e-12)).ceil().max(1.0) as usize;
                    let (h, start) = (span / n as f64, self.time);
                    let mut done = 0;
                    while done < n {
                        let run = stride.map_or(n - done, |k| {
                            (k as usize - *steps % k as usize).min(n - done)
                        });
                        explicit::advance(&mut self.cloud, &self.params, *scheme, h, run);
                        (*steps, done) = (*steps + run, done + run);
                        observe(*steps as u64, start + done as f64 * h, &self.cloud);
                    }
                }
                self.time = t;
                let finite = self
                    .cloud
                    .positions
                    .iter()
                    .all(|r| r.iter().all(|x| x.is_finite()));
                finite
                    .then_some(())
                    .ok_or_else(|| "non-finite state".to_string())
            }
            Stepper::Implicit(boxed) => {
                let (stepper, forces) = &mut **boxed;
                while t - self.time > 1e-12 * t.abs().max(1e-300) {
                    let h = stepper.step(&mut self.cloud, forces, t - self.time)?;
                    if self.time + h == self.time {
                        return Err(format!(
                            "time no longer advances at t = {} s with steps of {h:.3e} s",
                            self.time
                        ));
                    }
                    self.time += h;
                    observe(stepper.stats.steps as u64, self.time, &self.cloud);
                }
                self.time = t;
                Ok(())
            }
        }
    }

    /// Step counters (explicit schemes: steps only).
    pub fn stats(&self) -> StepStats {
        match &self.stepper {
            Stepper::Explicit(_, steps) => StepStats {
                steps: *steps,
                dt_min: self.params.step.dt,
                dt_max: self.params.step.dt,
                ..Default::default()
            },
            Stepper::Implicit(boxed) => StepStats {
                all_pairs_evaluations: boxed.1.all_pairs_evaluations(),
                ..boxed.0.stats.clone()
            },
        }
    }

    /// The step the trapezoidal scheme will try next, or the fixed explicit step, s.
    pub fn time_step(&self) -> f64 {
        match &self.stepper {
            Stepper::Implicit(boxed) => boxed.0.dt,
            Stepper::Explicit(..) => self.params.step.dt,
        }
    }

    /// The interactions (None for the non-interacting model).
    pub fn interactor(&self) -> Option<&Interactor> {
        match &self.stepper {
            Stepper::Implicit(boxed) => Some(&boxed.1),
            Stepper::Explicit(..) => None,
        }
    }

    /// The observables now.
    pub fn sample(&self) -> Sample {
        let envelope = Envelope::of(&self.cloud, &self.params.field_axis());
        let bonds = self.interactor().map_or(0, Interactor::bond_count);
        let pairs: Vec<(usize, usize)> = self
            .interactor()
            .map(|f| f.bonded_pairs().collect())
            .unwrap_or_default();
        let (clusters, largest_cluster) = if self.params.interactions.any() {
            clusters(&self.cloud, pairs.into_iter())
        } else {
            (0, 1)
        };
        Sample {
            time: self.time,
            envelope,
            kinetic_energy: kinetic_energy(&self.cloud),
            motion: Motion::of(&self.cloud, &self.params),
            bonds,
            clusters,
            largest_cluster,
        }
    }
}

/// Observables at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub time: f64,
    /// Envelope of the cloud.
    pub envelope: Envelope,
    /// Kinetic energy, J.
    pub kinetic_energy: f64,
    /// Swirl, velocity components, turning radius and force ratio.
    pub motion: Motion,
    /// Bonded pairs.
    pub bonds: usize,
    /// Clusters of ≥ 2 touching or bonded particles (0 for the non-interacting model).
    pub clusters: usize,
    /// Largest cluster size.
    pub largest_cluster: usize,
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct BlastOutcome {
    /// None: ok; Some(reason): failed.
    pub failure: Option<String>,
    /// Samples at t = k T / samples, k = 0…samples (up to a failure).
    pub samples: Vec<Sample>,
    /// The cloud where the run ended.
    pub cloud: Cloud,
    /// Step counters.
    pub stats: StepStats,
    /// Wall-clock time of the integration, s.
    pub wall_time_s: f64,
    /// Wall-clock time of each force stage within it (zeros without interactions), s.
    pub stage_times: StageTimes,
    /// First sample time at which the kinetic energy had fallen to `stop_energy_fraction`
    /// of its initial value (the run stops there), s; None if not reached or not asked.
    pub terminal_time: Option<f64>,
}

/// Relative band about the terminal semi-axes within which the envelope counts as settled.
const SETTLED_BAND: f64 = 0.01;

impl BlastOutcome {
    /// The last sample.
    pub fn last(&self) -> &Sample {
        self.samples.last().expect("t = 0 is always sampled")
    }

    /// Earliest sample time from which both gyration semi-axes stay within 1 % of their
    /// values at the terminal state, s: when the envelope became stationary. None unless the
    /// run reached its terminal state (an envelope that is still moving when the time budget
    /// ends has not settled, whatever its last samples show).
    pub fn envelope_settled_time(&self) -> Option<f64> {
        self.terminal_time?;
        let end = self.last().envelope;
        let settled = |s: &Sample| {
            (s.envelope.along - end.along).abs() <= SETTLED_BAND * end.along
                && (s.envelope.across - end.across).abs() <= SETTLED_BAND * end.across
        };
        let first = self
            .samples
            .iter()
            .rposition(|s| !settled(s))
            .map_or(0, |k| k + 1);
        Some(self.samples[first].time)
    }
}

/// Whether the last sample is at rest in the sense of `stop_energy_fraction`: kinetic energy
/// at most that fraction of the first sample's (never when the fraction is 0).
fn at_rest(params: &BlastParams, samples: &[Sample]) -> bool {
    let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
        return false;
    };
    params.stop_energy_fraction > 0.0
        && last.kinetic_energy <= params.stop_energy_fraction * first.kinetic_energy
}

/// The moments every run with an output directory writes: start, middle and end.
const MOMENTS: [(&str, f64); 3] = [("start", 0.0), ("middle", 0.5), ("end", 1.0)];

/// One run: blast the cloud for `seed`, integrate to the duration and sample the observables
/// at `samples` equal intervals; `recorder` writes the particle frames (the start, middle and
/// end, and those its schedule asks for) as the run goes. `progress` hears the fraction of
/// the duration done at every stop. An input error (a cloud too small for its particles) is
/// an Err; a blow-up is a failed outcome.
pub fn run(
    params: &BlastParams,
    seed: u64,
    progress: &dyn Fn(f64),
    mut recorder: Option<&mut Recorder>,
) -> crate::Result<BlastOutcome> {
    params.validate()?;
    let cloud = Cloud::blast(params, seed)?;
    let started = Instant::now();
    let mut sim = Simulation::new(params, cloud);
    let t_end = params.duration;
    // The moments and scheduled times are stops only for a run that writes frames (a stop
    // splits the adaptive step sequence, so a run without files keeps the sample stops only).
    let scheduled = recorder.as_ref().map_or(&[][..], |r| r.times());
    let moments = if recorder.is_some() {
        &MOMENTS[..]
    } else {
        &[]
    };
    let mut stops: Vec<f64> = (0..=params.samples)
        .map(|k| t_end * k as f64 / params.samples as f64)
        .chain(moments.iter().map(|(_, f)| f * t_end))
        .chain(scheduled.iter().copied().filter(|t| *t <= t_end))
        .collect();
    stops.sort_by(f64::total_cmp);
    stops.dedup();
    let is_sample = |t: f64| {
        let k = t / t_end * params.samples as f64;
        (k - k.round()).abs() < 1e-9
    };
    let mut outcome = BlastOutcome {
        failure: None,
        samples: Vec::new(),
        cloud: Cloud::default(),
        stats: StepStats::default(),
        wall_time_s: 0.0,
        stage_times: StageTimes::default(),
        terminal_time: None,
    };
    let axis = params.field_axis();
    let stride = recorder.as_ref().and_then(|r| r.every());
    for t in stops {
        let mut observe = |step: u64, time: f64, cloud: &Cloud| {
            if let Some(r) = recorder.as_deref_mut() {
                if time < t && r.due(step, time) {
                    r.frame(step, &snapshot::frame(cloud, time));
                }
            }
        };
        if let Err(reason) = sim.advance_observed(t, stride, &mut observe) {
            outcome.failure = Some(format!("{reason} at t = {:.4e} s", sim.time));
            break;
        }
        if is_sample(t) {
            outcome.samples.push(sim.sample());
            if at_rest(params, &outcome.samples) {
                outcome.terminal_time = Some(t);
            }
        }
        if let Some(r) = recorder.as_deref_mut() {
            let step = sim.stats().steps as u64;
            if r.due(step, t) {
                r.frame(step, &snapshot::frame(&sim.cloud, t));
            }
            if let Some((label, _)) = MOMENTS.iter().find(|(_, f)| f * t_end == t) {
                snapshot::moment(r, label, step, t, &sim.cloud, &axis);
            }
        }
        progress(t / t_end);
        if outcome.terminal_time.is_some() {
            break;
        }
    }
    if outcome.samples.is_empty() {
        outcome.samples.push(sim.sample());
    }
    outcome.cloud = sim.cloud.clone();
    outcome.stats = sim.stats();
    outcome.stage_times = sim
        .interactor()
        .map_or_else(StageTimes::default, Interactor::stage_times);
    outcome.wall_time_s = started.elapsed().as_secs_f64();
    Ok(outcome)
}
