//! Observables of the alignment stage (spec align.md, "Observables"): the alignment degree
//! A(t) and the times τ_x at which it reaches x, the sticking fraction, the contact count, the
//! solver's effort, the signs of a numerical breakdown, and the run's outcome built from them.

use nalgebra::{UnitQuaternion, Vector3};
use rayon::prelude::*;

use super::contacts::{ContactSet, Container};
use super::packing::{bed_top, packing_fraction};
use super::velocity::{Motion, SolveStats, Stage};
use crate::models::align::params::AlignParams;
use crate::models::align::{AlignOutcome, Status};

/// Samples of A(t) kept in the output series (the run itself checks A every step).
const SERIES_POINTS: usize = 400;
/// An overlap beyond this fraction of R_av means the contact mechanics broke down.
const RUNAWAY_OVERLAP: f64 = 0.5;

/// A = ⟨|n_i · ẑ|⟩, the alignment degree.
pub fn alignment_degree(orientation: &[UnitQuaternion<f64>]) -> f64 {
    let sum: f64 = orientation.iter().map(|q| (q * Vector3::z()).z.abs()).sum();
    sum / orientation.len() as f64
}

/// First time the series reaches `level`, interpolated linearly between samples.
pub fn crossing_time(series: &[(f64, f64)], level: f64) -> Option<f64> {
    if series.first()?.1 >= level {
        return Some(series[0].0);
    }
    series.windows(2).find(|w| w[1].1 >= level).map(|w| {
        let ((t0, a0), (t1, a1)) = (w[0], w[1]);
        t0 + (level - a0) / (a1 - a0) * (t1 - t0)
    })
}

/// Fraction of friction-loaded contacts (F_n > 0, μ > 0) whose slip speed is below 3 v_ε: there
/// the regularized law acts as a viscous creep law and the rotation rate depends on v_ε. Near 1
/// the run is in the creep regime (spec align.md, "Observables"). NaN without loaded contacts.
pub fn sticking_fraction(stage: &Stage, motion: &[Motion]) -> f64 {
    // counts, so the same on the pool at any thread count
    let (loaded, sticking) = (motion.par_iter().enumerate())
        .map(|(i, m)| {
            let (mut loaded, mut sticking) = (0usize, 0usize);
            for c in stage.contacts.of(i) {
                if stage.law.friction_of(&c) > 0.0 && c.overlap > 0.0 {
                    // the lid moves along its normal only: its speed adds no slip
                    let partner = stage.partner_velocity(&c, 0.0, |j| motion[j]);
                    let rel = m.v + stage.radius[i] * m.w.cross(&c.normal) - partner;
                    let slip = rel - rel.dot(&c.normal) * c.normal;
                    loaded += 1;
                    sticking += usize::from(slip.norm() < 3.0 * stage.slip_scale);
                }
            }
            (loaded, sticking)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    sticking as f64 / loaded as f64
}

/// Number of touching pairs (each listed from both sides, counted once) plus touching wall
/// contacts.
pub fn touching(contacts: &ContactSet) -> usize {
    let touching =
        (0..contacts.particles()).flat_map(|i| contacts.of(i).filter(|c| c.overlap > 0.0));
    let (mut pairs, mut walls) = (0, 0);
    for c in touching {
        match c.particle() {
            Some(_) => pairs += 1,
            None => walls += 1,
        }
    }
    pairs / 2 + walls
}

/// Fails once an overlap is too deep (or not finite) for the contact law to be trusted.
pub fn check_overlaps(contacts: &ContactSet) -> Result<(), String> {
    let overlap = contacts.max_overlap();
    if !overlap.is_finite() || overlap > RUNAWAY_OVERLAP {
        return Err(format!(
            "runaway overlap {overlap:.3} R_av (contact mechanics broke down)"
        ));
    }
    Ok(())
}

/// Fails on a non-finite velocity.
pub fn check_velocities(motion: &[Motion]) -> Result<(), String> {
    if motion
        .iter()
        .any(|m| !(m.v.norm() + m.w.norm()).is_finite())
    {
        return Err("non-finite velocity (numerical blow-up)".into());
    }
    Ok(())
}

/// What a run has observed so far: A after every step, solver effort and the latest sticking
/// fraction.
#[derive(Debug)]
pub struct Record {
    /// (t in s, A) at the start and after every step.
    series: Vec<(f64, f64)>,
    /// Step length, t_char.
    dt: f64,
    /// t_char, s.
    time_unit: f64,
    sweeps: usize,
    unconverged: usize,
    /// Sticking fraction of the latest velocity solve.
    sticking: f64,
    failure: Option<String>,
}

impl Record {
    /// Starts the record at the initial orientations.
    pub fn new(orientation: &[UnitQuaternion<f64>], dt: f64, time_unit: f64) -> Self {
        Self {
            series: vec![(0.0, alignment_degree(orientation))],
            dt,
            time_unit,
            sweeps: 0,
            unconverged: 0,
            sticking: f64::NAN,
            failure: None,
        }
    }

    /// Steps recorded.
    pub fn steps(&self) -> usize {
        self.series.len() - 1
    }

    /// The latest A.
    pub fn alignment(&self) -> f64 {
        self.series.last().unwrap().1
    }

    /// Records A after one more step.
    pub fn step(&mut self, orientation: &[UnitQuaternion<f64>]) {
        let steps = self.steps() + 1;
        let t = steps as f64 * self.dt * self.time_unit;
        self.series.push((t, alignment_degree(orientation)));
    }

    /// Records one velocity solve and the sticking fraction of its result.
    pub fn solved(&mut self, stats: SolveStats, sticking: f64) {
        self.sweeps += stats.sweeps;
        self.unconverged += usize::from(!stats.converged);
        self.sticking = sticking;
    }

    /// Records why the run stopped early.
    pub fn fail(&mut self, reason: String) {
        self.failure = Some(reason);
    }

    /// The outcome in physical units, from the record, the particles' radii, the die and the
    /// final state.
    pub fn outcome(
        mut self,
        params: &AlignParams,
        (radius, c): (&[f64], &Container),
        position: &[Vector3<f64>],
        contacts: &ContactSet,
        applied_force: f64,
    ) -> AlignOutcome {
        let scales = params.scales();
        let tau = crossing_time(&self.series, params.target);
        let status = match self.failure.take() {
            Some(reason) => Status::Failed(reason),
            None if tau.is_some() => Status::Reached,
            None => Status::NotReached,
        };
        let top = bed_top(position, radius);
        AlignOutcome {
            status,
            alignment_time_s: tau,
            alignment_time_90_s: crossing_time(&self.series, 0.9),
            final_alignment: self.alignment(),
            steps: self.steps(),
            series: thin(self.series, SERIES_POINTS),
            time_step_s: self.dt * scales.time,
            packing_fraction: Some(packing_fraction(radius, position, c)),
            contacts: Some(touching(contacts)),
            bed_height_m: Some(top * scales.length),
            applied_force_n: Some(applied_force * scales.force),
            lid_travel_m: None,
            nominal_force_n: Some(params.pressure * c.lx * c.ly * scales.length.powi(2)),
            solver_sweeps: self.sweeps,
            unconverged_solves: self.unconverged,
            sticking_fraction: Some(self.sticking).filter(|f| f.is_finite()),
            wall_time_s: 0.0,
        }
    }
}

/// Keeps at most about `points` evenly spaced samples (always the last).
fn thin(series: Vec<(f64, f64)>, points: usize) -> Vec<(f64, f64)> {
    let stride = series.len().div_ceil(points).max(1);
    let last = *series.last().unwrap();
    let mut kept: Vec<_> = series.into_iter().step_by(stride).collect();
    if kept.last() != Some(&last) {
        kept.push(last);
    }
    kept
}
