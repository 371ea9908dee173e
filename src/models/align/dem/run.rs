//! The alignment loop. Each stage of a Heun step refreshes the neighbour data (and with it the
//! loads), rebuilds the contacts, sets the torques and solves the velocity problem; the
//! integrator advances the state and the record observes it. The physics lives in the modules
//! called here.

use std::borrow::Cow;

use nalgebra::Vector3;

use super::contacts::{ContactLaw, ContactSet, Container};
use super::coulomb::{self, FrictionForces};
use super::explicit_friction::add_previous_iterate_friction;
use super::integrator::{fastest_rotation, time_step, Heun};
use super::loads::Loads;
use super::observables::{check_overlaps, check_velocities, sticking_fraction, Record};
use super::packing::{bed_top, Packing};
use super::snapshot::frame;
use super::state::{LidState, State};
use super::torque::Anisotropy;
use super::velocity::{self, Lid, Schedule, SolverControl, Stage};
use crate::models::align::params::{AlignParams, FrictionScheme, PressureMode};
use crate::models::align::AlignOutcome;
use crate::neighbor::NeighborList;
use crate::output::particles::ParticleFrame;
use crate::output::snapshots::Recorder;

/// Most alignment steps a run may take (a typical run takes tens): a run that would need more
/// fails with its reason instead of running for days.
const MAX_STEPS: usize = 10_000_000;

/// Neighbour-list skin during alignment, R_av (particles hardly move).
const SKIN: f64 = 0.2;
/// Smallest gap (R_av) below which a pair enters the implicit velocity problem; the margin
/// follows twice the largest displacement of the previous step (starting at the list skin).
const MIN_CONTACT_MARGIN: f64 = 0.02;
/// Deepest halving of a step whose moves outrun the skin (`Run::heun_step`): 2¹² substeps.
const MAX_SPLITS: u32 = 12;

/// One alignment run: its fixed data, evolving state and the work buffers of its stages.
pub struct Run<'a> {
    params: &'a AlignParams,
    /// The particles' radii (R_av), in sweep order from `cell_order_from` particles on.
    radius: Cow<'a, [f64]>,
    /// The die.
    container: Container,
    /// The bed's top at the start (R_av).
    start_top: f64,
    /// Each particle's index in the packing as given, where the run renumbered it: frames
    /// name the particles by it.
    packing_index: Option<Vec<usize>>,
    state: State,
    heun: Heun,
    record: Record,
    list: NeighborList,
    schedule: Schedule,
    contacts: ContactSet,
    law: ContactLaw,
    loads: Loads,
    anisotropy: Anisotropy,
    /// External force of the stage: the loads, plus the explicit friction in the source's
    /// scheme.
    force: Vec<Vector3<f64>>,
    torque: Vec<Vector3<f64>>,
    /// Friction regularization v_ε; in the Coulomb limit, the solver tolerance (the slip
    /// below which a contact counts as sticking).
    slip_scale: f64,
    control: SolverControl,
    /// The contacts' friction forces (Coulomb limit only), carried from solve to solve.
    friction: FrictionForces,
    /// The punch's lid (pressure mode `punch`), resting at first on the highest particle.
    lid: Option<Lid>,
    /// Upward force the particles exert on the lid in the latest velocity solve.
    lid_force: f64,
}

impl<'a> Run<'a> {
    /// A run from the settled packing at rest.
    pub fn new(params: &'a AlignParams, given: &'a Packing) -> Self {
        let (renumbered, packing_index) = in_sweep_order(params, given).unzip();
        let packing = renumbered.as_ref().unwrap_or(given);
        // v_ε and the solver tolerance are fractions of the fastest possible surface speed.
        let (omega_max, r_max) = fastest_rotation(params, packing);
        let surface_speed = omega_max * r_max;
        let mut state = State::at_rest(packing);
        let start_top = bed_top(&state.position, &packing.radius);
        let lid = (params.pressure_mode == PressureMode::Punch).then(|| {
            state.lid = Some(LidState {
                height: start_top,
                velocity: 0.0,
            });
            let scales = params.scales();
            let c = &packing.container;
            Lid {
                drag: 1.0,
                load: params.pressure / scales.stress() * c.lx * c.ly,
            }
        });
        let dt = time_step(params, packing);
        let n = packing.radius.len();
        let anisotropy = Anisotropy::new(params, packing);
        let container = packing.container;
        // the renumbered copy's centres and orientations now live in `state`: only its radii stay
        let radius = match renumbered {
            Some(copy) => Cow::Owned(copy.radius),
            None => Cow::Borrowed(&given.radius[..]),
        };
        let tolerance = params.numerics.solver_tolerance * surface_speed;
        let slip_scale = match params.numerics.friction_scheme {
            FrictionScheme::CoulombLimit => tolerance,
            _ => params.numerics.friction_regularization * surface_speed,
        };
        Self {
            params,
            radius,
            container,
            start_top,
            packing_index,
            record: Record::new(&state.orientation, dt, params.scales().time),
            state,
            heun: Heun::new(dt),
            list: NeighborList::new(SKIN),
            schedule: Schedule::default(),
            contacts: ContactSet::default(),
            law: contact_law(params),
            loads: Loads::none(n),
            anisotropy,
            force: vec![Vector3::zeros(); n],
            torque: vec![Vector3::zeros(); n],
            slip_scale,
            control: SolverControl {
                tolerance,
                max_sweeps: params.numerics.max_sweeps,
                over_relaxation: velocity::OVER_RELAXATION,
            },
            friction: FrictionForces::default(),
            lid,
            lid_force: 0.0,
        }
    }

    /// Steps until A reaches max(target, 0.9) (so τ_0.90 is always measured), the time limit
    /// passes or the run breaks down; `recorder` writes the particle frames (start, end and
    /// those its schedule asks for) as the run goes.
    pub fn integrate(mut self, mut recorder: Option<&mut Recorder>) -> AlignOutcome {
        let steps_allowed = self.params.max_time / self.params.scales().time / self.heun.dt;
        let max_steps = if steps_allowed > MAX_STEPS as f64 {
            self.record.fail(format!(
                "max_time {} s needs {steps_allowed:.2e} steps of {:.3e} s (budget {MAX_STEPS}): \
                 shorten max_time or raise rotation_step",
                self.params.max_time,
                self.heun.dt * self.params.scales().time
            ));
            0
        } else {
            steps_allowed.ceil() as usize
        };
        let stop_at = self.params.target.max(0.9);
        if let Some(r) = recorder.as_deref_mut() {
            self.refresh_neighbours();
            self.rebuild_contacts();
            self.offer_frame(r, Some("start"));
            self.offer_frame(r, None);
        }
        while self.record.steps() < max_steps && self.record.alignment() < stop_at {
            if let Err(reason) = self.step() {
                self.record.fail(reason);
                break;
            }
            self.record.step(&self.state.orientation);
            if let Some(r) = recorder.as_deref_mut() {
                self.offer_frame(r, None);
            }
        }
        if let Some(r) = recorder {
            self.offer_frame(r, Some("end"));
        }
        let (applied, travel) = match (self.lid, self.state.lid) {
            (Some(_), Some(lid)) => (self.lid_force, Some(self.start_top - lid.height)),
            _ => (self.loads.applied, None),
        };
        let position = &self.state.position;
        let mut outcome = self.record.outcome(
            self.params,
            (&self.radius, &self.container),
            position,
            &self.contacts,
            applied,
        );
        outcome.lid_travel_m = travel.map(|t| t * self.params.scales().length);
        outcome
    }

    /// One step of the run's length (its Heun steps, split where `heun_step` asks).
    fn step(&mut self) -> Result<(), String> {
        let dt = self.heun.dt;
        let result = self.heun_step(dt, 0);
        self.heun.dt = dt;
        result
    }

    /// One Heun step of length dt. Pairs farther apart than the contact margin are not in the
    /// velocity problems, so nothing may move more than half the margin in the step, or an
    /// unresisted pair could close. A step that would is taken again with a wider margin (up
    /// to the list skin), and past that as two halves, at most `MAX_SPLITS` deep (beyond, the
    /// overlap check is the arbiter). The loaded lid of a punch, resting at first on one
    /// particle, would otherwise move several R_av in the first step at 10 atm.
    fn heun_step(&mut self, dt: f64, splits: u32) -> Result<(), String> {
        self.heun.dt = dt;
        self.solve_stage()?; // predictor velocities, at the step's start
        let moved = self.heun.stage_move(&self.state);
        if self.too_far(moved, splits) {
            return self.retry(dt, splits, moved);
        }
        self.heun.predict(&mut self.state);
        self.solve_stage()?; // corrector velocities, at the predicted state
        let moved = self.heun.largest_move(&self.state);
        if self.too_far(moved, splits) {
            self.heun.restore(&mut self.state);
            return self.retry(dt, splits, moved);
        }
        self.law.skin = contact_margin(moved);
        self.heun.correct(&mut self.state);
        Ok(())
    }

    /// Whether a move of the step could close a gap left out of its velocity problems, with a
    /// remedy left.
    fn too_far(&self, moved: f64, splits: u32) -> bool {
        2.0 * moved > self.law.skin && (self.law.skin < SKIN || splits < MAX_SPLITS)
    }

    /// Takes a step that moved too far again: with the margin doubled past the move (at most
    /// the skin), or once it is the skin, as two halves.
    fn retry(&mut self, dt: f64, splits: u32, moved: f64) -> Result<(), String> {
        if self.law.skin < SKIN {
            self.law.skin = contact_margin(2.0 * moved);
            return self.heun_step(dt, splits);
        }
        self.heun_step(0.5 * dt, splits + 1)?;
        self.heun_step(0.5 * dt, splits + 1)
    }

    /// Writes the current state as the moment `label`, or as a scheduled frame if one is due.
    fn offer_frame(&self, recorder: &mut Recorder, label: Option<&str>) {
        let step = self.record.steps() as u64;
        let time = step as f64 * self.heun.dt * self.params.scales().time;
        let take = || self.frame_at(time);
        match label {
            Some(label) => recorder.moment(label, step, &take()),
            None if recorder.due(step, time) => recorder.frame(step, &take()),
            None => {}
        }
    }

    /// The current state as a particle frame at `time` (s), its particles named by their
    /// index in the packing as given.
    fn frame_at(&self, time: f64) -> ParticleFrame {
        let mut taken = frame(
            self.params,
            (&self.radius, &self.container),
            &self.state,
            &self.contacts,
            time,
        );
        if let Some(index) = &self.packing_index {
            taken.id = index.iter().map(|&i| i as u64 + 1).collect();
        }
        taken
    }

    /// The contacts of the current state (the lid, if any, as the die's ceiling).
    fn rebuild_contacts(&mut self) {
        let container = Container {
            top: self.state.lid.map(|l| l.height),
            ..self.container
        };
        let (position, radius) = (&self.state.position, &self.radius);
        self.contacts
            .rebuild(position, radius, &self.list, &container, &self.law);
    }

    /// Solves the velocity problem at the current state, warm-started from the last solve.
    fn solve_stage(&mut self) -> Result<(), String> {
        self.refresh_neighbours();
        self.rebuild_contacts();
        let radius = &self.radius;
        check_overlaps(&self.contacts)?;
        let state = &mut self.state;
        self.anisotropy.apply(
            &state.orientation,
            &mut state.moment_sense,
            &mut self.torque,
        );
        self.force.copy_from_slice(&self.loads.force);
        let law = match self.params.numerics.friction_scheme {
            FrictionScheme::Implicit | FrictionScheme::CoulombLimit => self.law,
            FrictionScheme::SourceExplicit => {
                let (force, torque) = (&mut self.force, &mut self.torque);
                add_previous_iterate_friction(
                    &self.contacts,
                    &self.law,
                    radius,
                    &state.motion,
                    force,
                    torque,
                );
                ContactLaw {
                    friction: 0.0,
                    wall_friction: 0.0,
                    ..self.law
                }
            }
        };
        let stage = Stage {
            contacts: &self.contacts,
            law: &law,
            radius,
            force: &self.force,
            torque: &self.torque,
            dt: self.heun.dt,
            slip_scale: self.slip_scale,
            lid: self.lid,
        };
        let motion = &mut self.state.motion;
        let mut lid_velocity = self.state.lid.map_or(0.0, |l| l.velocity);
        let (schedule, control) = (&self.schedule, self.control);
        let stats = match self.params.numerics.friction_scheme {
            FrictionScheme::CoulombLimit => coulomb::solve(
                &stage,
                schedule,
                motion,
                &mut lid_velocity,
                control,
                &mut self.friction,
            ),
            _ => velocity::solve(&stage, schedule, motion, &mut lid_velocity, control),
        };
        if let Some(lid) = self.state.lid.as_mut() {
            lid.velocity = lid_velocity;
            self.lid_force = stage.lid_force(motion, lid_velocity);
        }
        self.record.solved(stats, sticking_fraction(&stage, motion));
        check_velocities(motion)
    }

    /// Rebuilds the neighbour list when particles have moved far enough, and with it the
    /// Gauss–Seidel order and the loads (which particles carry the pressure changes only as
    /// the bed rearranges).
    fn refresh_neighbours(&mut self) {
        let (position, radius) = (&self.state.position, &self.radius);
        if self.list.update(position, radius) {
            self.loads.update(self.params, position, radius);
            let parallel_from = self.params.numerics.parallel_from;
            self.schedule = Schedule::new(position, schedule_cell(radius), parallel_from);
        }
    }
}

/// The side of the Gauss–Seidel schedule's cells: the neighbour list's reach.
fn schedule_cell(radius: &[f64]) -> f64 {
    2.0 * radius.iter().cloned().fold(0.0, f64::max) + SKIN
}

/// From `cell_order_from` particles on, the packing renumbered in the order the schedule at
/// its positions visits the particles (colour by colour, cell by cell), so that a sweep reads
/// each particle's own data (contacts, loads) in memory order, with the index each particle
/// had in `given`; None below that size (the run keeps the given numbering). The particles
/// hardly move while they align, so the later schedules keep that order. A run's bits change
/// (its sums run in another order), its answers only by the velocity solve's tolerance
/// (results/bench/README.md, "The alignment stage in sweep order").
fn in_sweep_order(params: &AlignParams, given: &Packing) -> Option<(Packing, Vec<usize>)> {
    if given.radius.len() < params.numerics.cell_order_from {
        return None;
    }
    let cell = schedule_cell(&given.radius);
    let order: Vec<usize> = Schedule::new(&given.position, cell, usize::MAX)
        .order()
        .collect();
    Some((given.renumbered(&order), order))
}

/// Contacts between particles and with the die walls, both of the particle material; pairs
/// start within the list skin.
fn contact_law(params: &AlignParams) -> ContactLaw {
    let nu = params.material.poisson_ratio;
    ContactLaw {
        effective_modulus: 1.0 / (2.0 * (1.0 - nu * nu)),
        friction: params.friction,
        wall_friction: params.wall_friction,
        skin: SKIN,
    }
}

/// Gap below which pairs enter the next velocity problems: twice the last step's largest
/// displacement (wider gaps cannot close within a step), at least MIN_CONTACT_MARGIN, at most
/// the list skin (beyond it pairs are not listed).
fn contact_margin(largest_move: f64) -> f64 {
    (2.0 * largest_move).clamp(MIN_CONTACT_MARGIN, SKIN)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;

    fn params(cell_order_from: usize) -> AlignParams {
        let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        let mut params = AlignParams::paper_defaults(material, 40.0);
        params.particles = 200;
        params.numerics.cell_order_from = cell_order_from;
        params
    }

    #[test]
    fn a_run_in_sweep_order_sweeps_its_particles_in_memory_order() {
        let given = Packing::generate(&params(usize::MAX).packing(), 2).unwrap();
        let swept = params(0);
        let run = Run::new(&swept, &given);
        let index = run.packing_index.as_ref().expect("renumbered");
        let cell = schedule_cell(&run.radius);
        let order: Vec<usize> = Schedule::new(&run.state.position, cell, usize::MAX)
            .order()
            .collect();
        assert_eq!(order, (0..given.radius.len()).collect::<Vec<_>>());
        assert_ne!(index, &order, "the start is not already in sweep order");
        for (k, &i) in index.iter().enumerate() {
            assert_eq!(run.state.position[k], given.position[i]);
            assert_eq!(run.radius[k], given.radius[i]);
            assert_eq!(run.state.orientation[k], given.orientation[i]);
        }
    }

    #[test]
    fn frames_name_the_particles_by_their_index_in_the_given_packing() {
        let given = Packing::generate(&params(usize::MAX).packing(), 2).unwrap();
        let frame_of = |cell_order_from| {
            let params = params(cell_order_from);
            let mut run = Run::new(&params, &given);
            run.refresh_neighbours();
            run.rebuild_contacts();
            let f = run.frame_at(0.0);
            let mut by_id: Vec<_> = (0..given.radius.len())
                .map(|k| (f.id[k], f.position[k], f.radius[k]))
                .collect();
            by_id.sort_by_key(|row| row.0);
            by_id
        };
        assert_eq!(frame_of(0), frame_of(usize::MAX));
    }
}
