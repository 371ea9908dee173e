//! The DEM model of `align` (spec align.md): settled packing, then alignment of the easy axes
//! under field and pressure with Hertz contacts and regularized Coulomb friction, overdamped.
//!
//! Time stepping of the alignment stage: Heun (explicit trapezoid) on positions and
//! orientations (q ← exp(½ ω dt) ⊗ q), where each stage's velocities solve the implicit velocity
//! problem of `velocity` (contact forces at the end of the step). The step is set by rotation
//! accuracy alone: dt = `rotation_step` / ω_max with ω_max the angular speed of the largest
//! particle under the largest possible torque K V.

pub mod contacts;
pub mod packing;
pub mod velocity;

use nalgebra::{UnitQuaternion, Vector3};
use std::time::Instant;

use super::params::{AlignParams, PressureMode};
use super::stoner_wohlfarth::equilibrium;
use super::{AlignOutcome, Status};
use crate::neighbor::NeighborList;
use contacts::{ContactLaw, ContactSet};
pub use packing::Packing;
use velocity::{Motion, Schedule, SolveStats, SolverControl, Stage};

/// Neighbour-list skin during alignment, R_av (particles hardly move).
const SKIN: f64 = 0.2;
/// Smallest gap (R_av) below which a pair enters the implicit velocity problem; the margin
/// follows twice the largest displacement of the previous step (starting at the list skin).
const MIN_CONTACT_MARGIN: f64 = 0.02;
/// Samples of A(t) kept in the output series (the run itself checks A every step).
const SERIES_POINTS: usize = 400;
/// An overlap beyond this fraction of R_av means the contact mechanics broke down.
const RUNAWAY_OVERLAP: f64 = 0.5;

/// Runs the alignment stage on a settled packing (not modified).
pub fn align(params: &AlignParams, packing: &Packing) -> AlignOutcome {
    let started = Instant::now();
    let mut run = Run::new(params, packing);
    let mut outcome = run.integrate();
    outcome.wall_time_s = started.elapsed().as_secs_f64();
    outcome
}

/// Positions, orientations and predictor velocities at the start of a Heun step.
#[derive(Default)]
struct StepStart {
    position: Vec<Vector3<f64>>,
    orientation: Vec<UnitQuaternion<f64>>,
    motion: Vec<Motion>,
}

/// The evolving state and fixed data of one alignment run, in reduced units.
struct Run<'a> {
    params: &'a AlignParams,
    packing: &'a Packing,
    position: Vec<Vector3<f64>>,
    orientation: Vec<UnitQuaternion<f64>>,
    motion: Vec<Motion>,
    /// State and predictor velocities at the start of the current step.
    start: StepStart,
    list: NeighborList,
    schedule: Schedule,
    contacts: ContactSet,
    law: ContactLaw,
    force: Vec<Vector3<f64>>,
    torque: Vec<Vector3<f64>>,
    /// K V_i in units of E R_av³.
    torque_scale: Vec<f64>,
    h: f64,
    dt: f64,
    slip_scale: f64,
    control: SolverControl,
    applied_force: f64,
    solves: SolveStats,
    unconverged: usize,
    /// Sticking fraction of the latest velocity solve.
    sticking: f64,
}

/// Fastest possible angular speed (largest particle, torque K V), in 1/t_char, and the
/// largest radius.
fn fastest_rotation(params: &AlignParams, packing: &Packing) -> (f64, f64) {
    let k_red = params.material.anisotropy_constant / params.scales().stress();
    let r_max = packing.radius.iter().cloned().fold(0.0, f64::max);
    (k_red * 4.0 / 3.0 * std::f64::consts::PI * r_max, r_max)
}

/// The alignment time step, s.
pub fn time_step_s(params: &AlignParams, packing: &Packing) -> f64 {
    params.numerics.rotation_step / fastest_rotation(params, packing).0 * params.scales().time
}

impl<'a> Run<'a> {
    fn new(params: &'a AlignParams, packing: &'a Packing) -> Self {
        let k_red = params.material.anisotropy_constant / params.scales().stress();
        let (omega_max, r_max) = fastest_rotation(params, packing);
        let surface_speed = omega_max * r_max;
        let n = packing.radius.len();
        let nu = params.material.poisson_ratio;
        Self {
            params,
            packing,
            position: packing.position.clone(),
            orientation: packing.orientation.clone(),
            motion: vec![Motion::default(); n],
            start: StepStart::default(),
            list: NeighborList::new(SKIN),
            schedule: Schedule::default(),
            contacts: ContactSet::default(),
            law: ContactLaw {
                effective_modulus: 1.0 / (2.0 * (1.0 - nu * nu)),
                friction: params.friction,
                wall_friction: params.wall_friction,
                skin: SKIN,
            },
            force: vec![Vector3::zeros(); n],
            torque: vec![Vector3::zeros(); n],
            torque_scale: packing
                .radius
                .iter()
                .map(|r| k_red * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
                .collect(),
            h: params.reduced_field(),
            dt: params.numerics.rotation_step / omega_max,
            slip_scale: params.numerics.friction_regularization * surface_speed,
            control: SolverControl {
                tolerance: params.numerics.solver_tolerance * surface_speed,
                max_sweeps: params.numerics.max_sweeps,
            },
            applied_force: 0.0,
            solves: SolveStats::default(),
            unconverged: 0,
            sticking: f64::NAN,
        }
    }

    fn integrate(&mut self) -> AlignOutcome {
        let time_unit = self.params.scales().time;
        let max_steps = (self.params.max_time / time_unit / self.dt).ceil() as usize;
        let stop_at = self.params.target.max(0.9);
        let mut series = vec![(0.0, alignment_degree(&self.orientation))];
        let mut steps = 0;
        let mut failure = None;
        while steps < max_steps && series.last().unwrap().1 < stop_at {
            if let Err(reason) = self.heun_step() {
                failure = Some(reason);
                break;
            }
            steps += 1;
            series.push((
                steps as f64 * self.dt * time_unit,
                alignment_degree(&self.orientation),
            ));
        }
        self.outcome(series, steps, failure)
    }

    /// One Heun step: predictor velocities at the current state, corrector at the predicted one.
    fn heun_step(&mut self) -> Result<(), String> {
        self.stage_velocities()?;
        // keep the step's start (buffers reused: no allocation per step)
        self.start.position.clone_from(&self.position);
        self.start.orientation.clone_from(&self.orientation);
        self.start.motion.clone_from(&self.motion);
        self.advance(false);
        self.stage_velocities()?;
        // Pairs closer than twice the last step's largest displacement enter the next velocity
        // problems (at least MIN_CONTACT_MARGIN, at most the list skin); wider gaps cannot close.
        let largest_move = self
            .start
            .motion
            .iter()
            .chain(&self.motion)
            .map(|m| m.v.norm())
            .fold(0.0, f64::max)
            * self.dt;
        self.law.skin = (2.0 * largest_move).clamp(MIN_CONTACT_MARGIN, SKIN);
        self.advance(true);
        Ok(())
    }

    /// Sets the state to the step's start advanced by dt with the predictor velocities, or
    /// (`corrected`) with the mean of predictor and current (corrector) velocities.
    fn advance(&mut self, corrected: bool) {
        let dt = self.dt;
        let start = &self.start;
        for i in 0..start.position.len() {
            let a = start.motion[i];
            let b = if corrected { self.motion[i] } else { a };
            let (v, w) = (0.5 * (a.v + b.v), 0.5 * (a.w + b.w));
            self.position[i] = start.position[i] + dt * v;
            let q = UnitQuaternion::from_scaled_axis(dt * w) * start.orientation[i];
            self.orientation[i] = UnitQuaternion::new_normalize(q.into_inner());
        }
    }

    /// Solves the velocity problem at the current state (warm-started).
    fn stage_velocities(&mut self) -> Result<(), String> {
        if self.list.update(&self.position, &self.packing.radius) {
            self.update_external_forces();
            let r_max = self.packing.radius.iter().cloned().fold(0.0, f64::max);
            self.schedule = Schedule::new(
                &self.position,
                2.0 * r_max + SKIN,
                self.params.numerics.parallel_from,
            );
        }
        self.contacts.rebuild(
            &self.position,
            &self.packing.radius,
            &self.list,
            &self.packing.container,
            &self.law,
        );
        let overlap = self.contacts.max_overlap();
        if !overlap.is_finite() || overlap > RUNAWAY_OVERLAP {
            return Err(format!(
                "runaway overlap {overlap:.3} R_av (contact mechanics broke down)"
            ));
        }
        for i in 0..self.torque.len() {
            self.torque[i] = magnetic_torque(&self.orientation[i], self.torque_scale[i], self.h);
        }
        let stage = Stage {
            contacts: &self.contacts,
            law: &self.law,
            radius: &self.packing.radius,
            force: &self.force,
            torque: &self.torque,
            dt: self.dt,
            slip_scale: self.slip_scale,
        };
        let stats = velocity::solve(&stage, &self.schedule, &mut self.motion, self.control);
        self.solves.sweeps += stats.sweeps;
        self.unconverged += usize::from(!stats.converged);
        self.sticking = velocity::sticking_fraction(&stage, &self.motion);
        if self
            .motion
            .iter()
            .any(|m| !(m.v.norm() + m.w.norm()).is_finite())
        {
            return Err("non-finite velocity (numerical blow-up)".into());
        }
        Ok(())
    }

    /// Pressure forces on the loaded particles (spec: exposed-layer or source-layer rule) and
    /// true gravity.
    fn update_external_forces(&mut self) {
        let scales = self.params.scales();
        let p_red = self.params.pressure / scales.stress();
        let g_red = self.params.material.density * 9.80665 * scales.length / scales.stress();
        let loaded = match self.params.pressure_mode {
            PressureMode::ExposedLayer => exposed_particles(&self.position, &self.packing.radius),
            PressureMode::SourceLayer => source_layer(&self.position),
        };
        self.applied_force = 0.0;
        for (i, f) in self.force.iter_mut().enumerate() {
            let r = self.packing.radius[i];
            let load = if loaded[i] {
                std::f64::consts::PI * r * r * p_red
            } else {
                0.0
            };
            self.applied_force += load;
            *f = Vector3::new(
                0.0,
                0.0,
                -load - g_red * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
            );
        }
    }

    fn outcome(
        &self,
        series: Vec<(f64, f64)>,
        steps: usize,
        failure: Option<String>,
    ) -> AlignOutcome {
        let scales = self.params.scales();
        let target = self.params.target;
        let tau = crossing_time(&series, target);
        let final_alignment = series.last().unwrap().1;
        let status = match failure {
            Some(reason) => Status::Failed(reason),
            None if tau.is_some() => Status::Reached,
            None => Status::NotReached,
        };
        let radius = &self.packing.radius;
        let top = self
            .position
            .iter()
            .zip(radius)
            .map(|(p, r)| p.z + r)
            .fold(0.0, f64::max);
        let c = &self.packing.container;
        AlignOutcome {
            status,
            alignment_time_s: tau,
            alignment_time_90_s: crossing_time(&series, 0.9),
            final_alignment,
            series: thin(series, SERIES_POINTS),
            steps,
            time_step_s: self.dt * scales.time,
            packing_fraction: Some(packing::packing_fraction(radius, &self.position, c)),
            contacts: Some(self.contacts.touching()),
            bed_height_m: Some(top * scales.length),
            applied_force_n: Some(self.applied_force * scales.force),
            nominal_force_n: Some(self.params.pressure * c.lx * c.ly * scales.length.powi(2)),
            solver_sweeps: self.solves.sweeps,
            unconverged_solves: self.unconverged,
            sticking_fraction: Some(self.sticking).filter(|f| f.is_finite()),
            wall_time_s: 0.0,
        }
    }
}

/// A = ⟨|n_i · ẑ|⟩, the alignment degree.
pub fn alignment_degree(orientation: &[UnitQuaternion<f64>]) -> f64 {
    let sum: f64 = orientation.iter().map(|q| (q * Vector3::z()).z.abs()).sum();
    sum / orientation.len() as f64
}

/// The anisotropy torque (A3) on a particle with easy axis n = q·ẑ in a field along +z:
/// magnitude K V sin 2ψ, about n' × ẑ (n' = ±n with n'·ẑ ≥ 0), turning the axis toward H.
pub fn magnetic_torque(q: &UnitQuaternion<f64>, kv: f64, h: f64) -> Vector3<f64> {
    let n = q * Vector3::z();
    let n = if n.z < 0.0 { -n } else { n };
    let sin_theta = n.x.hypot(n.y);
    if sin_theta == 0.0 {
        return Vector3::zeros();
    }
    let eq = equilibrium(sin_theta, n.z, h);
    kv * eq.torque_factor / sin_theta * Vector3::new(n.y, -n.x, 0.0)
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

/// Particles with no sphere above them: the vertical ray up from the centre meets no other
/// sphere (no higher centre within horizontal distance R_j).
fn exposed_particles(position: &[Vector3<f64>], radius: &[f64]) -> Vec<bool> {
    let r_max = radius.iter().cloned().fold(0.0, f64::max);
    let column = 2.0 * r_max;
    let key = |p: &Vector3<f64>| ((p.x / column).floor() as i64, (p.y / column).floor() as i64);
    let mut columns: std::collections::BTreeMap<(i64, i64), Vec<usize>> = Default::default();
    for (i, p) in position.iter().enumerate() {
        columns.entry(key(p)).or_default().push(i);
    }
    position
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (cx, cy) = key(p);
            !(-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    columns.get(&(cx + dx, cy + dy)).is_some_and(|members| {
                        members.iter().any(|&j| {
                            let d = position[j] - p;
                            j != i && d.z > 0.0 && d.x * d.x + d.y * d.y < radius[j] * radius[j]
                        })
                    })
                })
            })
        })
        .collect()
}

/// The source's rule: centres above 0.9 of the highest centre.
fn source_layer(position: &[Vector3<f64>]) -> Vec<bool> {
    let z_max = position
        .iter()
        .map(|p| p.z)
        .fold(f64::NEG_INFINITY, f64::max);
    position.iter().map(|p| p.z > 0.9 * z_max).collect()
}
