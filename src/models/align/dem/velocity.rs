//! The overdamped velocity problem of one integrator stage, solved implicitly (spec align.md,
//! "Equations of motion", A5–A7).
//!
//! In reduced units (γ = 1, γ* R_i² = r_i²) the velocities u_i = (v_i, ω_i) of a stage minimize
//! the strictly convex function
//!
//! ```text
//! Φ(u) = Σ_i [½|v_i|² + ½ r_i²|ω_i|² − F_i·v_i − T_i·ω_i]
//!      + Σ_contacts [ U(δ_c + dt (v_i − v_j)·e_c) / dt + μ F_n(δ_c) √(|v_t,c|² + v_ε²) ]
//! ```
//!
//! with U(δ) = (2/5) k δ^{5/2} the Hertz energy (so the normal force is taken at the *end* of the
//! step: implicit, no stiffness limit on dt), F_n(δ_c) the normal force at the start of the stage
//! (it sets the friction bound), and √(|v_t|² + v_ε²) the regularized Coulomb law (A5). Its
//! stationarity conditions are (A6)–(A7) with these forces. Block Gauss–Seidel: each particle in
//! turn minimizes Φ over its own six unknowns (damped Newton with a 6×6 Cholesky solve and
//! Armijo backtracking) with its neighbours held, and the move is over-relaxed
//! (`OVER_RELAXATION`); sweeps repeat until no velocity moves by more than the tolerance.
//! Warm-started from the previous stage, few sweeps are needed.

use std::marker::PhantomData;

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use rayon::prelude::*;

use super::contacts::{Contact, ContactLaw, ContactSet, LID};
use crate::numerics::roots::bisect;

/// Translational and angular velocity of one particle (reduced units).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Motion {
    /// Centre velocity.
    pub v: Vector3<f64>,
    /// Angular velocity (spatial frame).
    pub w: Vector3<f64>,
}

/// The data of one stage's velocity problem.
pub struct Stage<'a> {
    /// Contacts at the stage's positions.
    pub contacts: &'a ContactSet,
    /// The contact laws (friction coefficients of pairs and walls).
    pub law: &'a ContactLaw,
    /// Reduced radii.
    pub radius: &'a [f64],
    /// External forces (pressure, gravity).
    pub force: &'a [Vector3<f64>],
    /// Magnetic torques.
    pub torque: &'a [Vector3<f64>],
    /// Step length: normal forces are evaluated at the overlap after dt.
    pub dt: f64,
    /// Friction regularization v_ε.
    pub slip_scale: f64,
    /// The punch's lid, if the pressure is applied by one.
    pub lid: Option<Lid>,
}

/// The punch's lid in the velocity problem: a rigid plate moving along z only, overdamped
/// like a particle (drag γ, 1 in reduced units) and pushed down by the force P L_x L_y. Its
/// term in Φ is ½ drag w² + load · w (w its upward velocity); its contacts are the particles'
/// contacts with partner `LID`, whose normal is +z.
#[derive(Debug, Clone, Copy)]
pub struct Lid {
    /// Drag coefficient of the lid (reduced units).
    pub drag: f64,
    /// Downward force P L_x L_y on the lid (reduced units).
    pub load: f64,
}

impl Stage<'_> {
    /// Velocity of contact c's partner surface at the contact: a particle's surface velocity,
    /// zero for a wall, (0, 0, w) for the lid moving at `lid_velocity` w.
    pub fn partner_velocity(
        &self,
        c: &Contact,
        lid_velocity: f64,
        motion_of: impl FnOnce(usize) -> Motion,
    ) -> Vector3<f64> {
        match c.particle() {
            Some(j) => {
                let m = motion_of(j);
                m.v - self.radius[j] * m.w.cross(&c.normal)
            }
            None if c.partner == LID => Vector3::new(0.0, 0.0, lid_velocity),
            None => Vector3::zeros(),
        }
    }

    /// The lid's contacts: (particle, the contact) for every contact with partner `LID`.
    pub(super) fn lid_contacts(&self) -> Vec<(usize, Contact)> {
        if self.lid.is_none() {
            return Vec::new();
        }
        (0..self.radius.len())
            .flat_map(|i| {
                self.contacts
                    .of(i)
                    .filter(|c| c.partner == LID)
                    .map(move |c| (i, c))
            })
            .collect()
    }

    /// Upward force the particles exert on the lid at velocity w: the Hertz forces at the
    /// overlaps at the end of the step (as in Φ), given the particles' motion.
    pub fn lid_force(&self, motion: &[Motion], lid_velocity: f64) -> f64 {
        lid_force_on(self.dt, &self.lid_contacts(), motion, lid_velocity)
    }
}

fn lid_force_on(dt: f64, contacts: &[(usize, Contact)], motion: &[Motion], w: f64) -> f64 {
    contacts
        .iter()
        .map(|(i, c)| c.normal_force_at(c.overlap + dt * (motion[*i].v.z - w)))
        .sum()
}

/// The lid's velocity with every particle held: the root of drag w + load − F_up(w) = 0, which
/// increases strictly in w (F_up falls as the lid rises), found by bisection between the free
/// fall w = −load/drag (where it is ≤ 0) and the speed at which every contact opens (> 0).
pub(super) fn relax_lid(
    lid: &Lid,
    dt: f64,
    contacts: &[(usize, Contact)],
    motion: &[Motion],
) -> f64 {
    let free_fall = -lid.load / lid.drag;
    let opening = contacts
        .iter()
        .map(|(i, c)| motion[*i].v.z + c.overlap / dt)
        .fold(free_fall, f64::max);
    let residual = |w: f64| lid.drag * w + lid.load - lid_force_on(dt, contacts, motion, w);
    if residual(free_fall) >= 0.0 {
        return free_fall;
    }
    bisect(
        residual,
        free_fall,
        opening + free_fall.abs() + f64::MIN_POSITIVE,
        1e-15,
    )
}

/// Convergence control of the Gauss–Seidel sweeps.
#[derive(Debug, Clone, Copy)]
pub struct SolverControl {
    /// Largest allowed change |Δv| + r|Δω| of any particle in the last sweep.
    pub tolerance: f64,
    /// Sweep cap.
    pub max_sweeps: usize,
    /// Over-relaxation factor ω of the sweeps (1: plain Gauss–Seidel; `OVER_RELAXATION` in
    /// the alignment runs).
    pub over_relaxation: f64,
}

/// Over-relaxation of the alignment runs' sweeps: about 40 % fewer sweeps than plain
/// Gauss–Seidel at N = 1000 (a scan of 1.0–1.8, results/bench/README.md); the answer is the
/// same minimizer of Φ (test `over_relaxed_sweeps_reach_the_gauss_seidel_velocities`).
pub const OVER_RELAXATION: f64 = 1.6;

/// A particle's local Newton stops once its step is below this fraction of the sweep
/// tolerance: converging it further cannot move the sweep's answer by a visible amount
/// (quadratic convergence leaves an error far below the step). At 0.1 most visits took a
/// second Newton iteration only to confirm the first; at 1 a quarter fewer iterations, the
/// same sweeps, and τ_0.95 moves by < 1e-6 relative (results/bench/README.md).
const LOCAL_TOLERANCE: f64 = 1.0;

/// What a solve did.
#[derive(Debug, Clone, Copy, Default)]
pub struct SolveStats {
    /// Sweeps performed.
    pub sweeps: usize,
    /// Whether the tolerance was met within the cap.
    pub converged: bool,
}

/// Solves the stage problem by block Gauss–Seidel in the order of `schedule`, starting from
/// (and overwriting) `motion` and the lid's velocity `lid_velocity` (relaxed after each sweep
/// of the particles; ignored without a lid).
pub fn solve(
    stage: &Stage,
    schedule: &Schedule,
    motion: &mut [Motion],
    lid_velocity: &mut f64,
    control: SolverControl,
) -> SolveStats {
    let mut stats = SolveStats::default();
    let lid_contacts = stage.lid_contacts();
    while stats.sweeps < control.max_sweeps {
        stats.sweeps += 1;
        let w = *lid_velocity;
        let mut largest_change = sweep(stage, schedule, motion, w, control);
        if let Some(lid) = &stage.lid {
            *lid_velocity = relax_lid(lid, stage.dt, &lid_contacts, motion);
            largest_change = largest_change.max((*lid_velocity - w).abs());
        }
        if largest_change <= control.tolerance {
            stats.converged = true;
            break;
        }
    }
    stats
}

/// One Gauss–Seidel sweep over the particles with the lid moving at w; returns the largest
/// change of a particle's velocity.
fn sweep(
    stage: &Stage,
    schedule: &Schedule,
    motion: &mut [Motion],
    w: f64,
    control: SolverControl,
) -> f64 {
    let velocities = Velocities::new(motion);
    let mut largest_change: f64 = 0.0;
    for colour in &schedule.colours {
        let sweep_cell = |cell: &Vec<u32>| {
            let mut change: f64 = 0.0;
            let mut terms = Terms::default();
            for &i in cell {
                let at = (i as usize, w);
                // SAFETY: the colouring invariant of `Schedule`: while this colour's cells
                // are relaxed concurrently, particle i and its listed partners are written
                // by this task alone (same cell) or by no task (other colours).
                let relaxed = unsafe { relax(stage, &velocities, at, &mut terms, control) };
                change = change.max(relaxed);
            }
            change
        };
        let change = if schedule.parallel {
            colour.par_iter().map(sweep_cell).reduce(|| 0.0, f64::max)
        } else {
            colour.iter().map(sweep_cell).fold(0.0, f64::max)
        };
        largest_change = largest_change.max(change);
    }
    largest_change
}

/// The Gauss–Seidel order: particles grouped by cubic cells of side ≥ the neighbour cut-off
/// (2 r_max + skin, as in the neighbour list), cells grouped in 8 colours by the parity of their
/// integer coordinates. Two cells of one colour are never adjacent, so the particles of one
/// cell neither touch nor list the particles of another cell of its colour: a colour's cells can
/// be relaxed concurrently, and the result does not depend on the number of threads.
#[derive(Debug, Clone, Default)]
pub struct Schedule {
    colours: [Vec<Vec<u32>>; 8],
    parallel: bool,
}

impl Schedule {
    /// The particles in Gauss–Seidel order (colour by colour, cell by cell).
    pub(super) fn order(&self) -> impl Iterator<Item = usize> + '_ {
        self.colours.iter().flatten().flatten().map(|&i| i as usize)
    }

    /// Builds the order for the positions at which the neighbour list was built; cells of a
    /// colour are relaxed concurrently from `parallel_from` particles on (same result either way).
    pub fn new(positions: &[Vector3<f64>], cell: f64, parallel_from: usize) -> Self {
        // cells keyed z first: a colour's cells then run bottom to top, as the particles are
        // numbered (`Numerics::cell_order_from`), so the halves the pool splits a colour into
        // hold runs of neighbouring particles in memory, not interleaved ones; the order of a
        // colour's cells does not change the sweep (they share no particles)
        let mut cells: std::collections::BTreeMap<[i64; 3], Vec<u32>> = Default::default();
        for (i, p) in positions.iter().enumerate() {
            let key = [2, 1, 0].map(|a| (p[a] / cell).floor() as i64);
            cells.entry(key).or_default().push(i as u32);
        }
        let mut colours: [Vec<Vec<u32>>; 8] = Default::default();
        for ([z, y, x], members) in cells {
            let colour = [x, y, z]
                .iter()
                .enumerate()
                .map(|(a, k)| (k.rem_euclid(2) as usize) << a)
                .sum::<usize>();
            colours[colour].push(members);
        }
        Self {
            colours,
            parallel: positions.len() >= parallel_from,
        }
    }
}

/// The velocity array shared by the tasks of one coloured sweep.
///
/// Tasks relax different cells of one colour at the same time, so several threads write into
/// the array at once. No reference to the array (or to any element) is formed while they run:
/// each access copies one element in or out through the raw pointer, so it suffices that no
/// element is written by one thread while another thread reads or writes it. The colouring of
/// `Schedule` guarantees exactly that: a particle and its listed partners lie in its own cell
/// (relaxed by its own task, one particle after another) or in a cell of another colour (not
/// relaxed during this colour's pass), never in another cell of the same colour.
struct Velocities<'a> {
    first: *mut Motion,
    len: usize,
    /// Holds the exclusive borrow of the array for the whole solve.
    _array: PhantomData<&'a mut [Motion]>,
}

// SAFETY: the pointer targets an exclusively borrowed array of `Send + Sync` values;
// concurrent element accesses are confined by the colouring invariant (see above).
unsafe impl Send for Velocities<'_> {}
unsafe impl Sync for Velocities<'_> {}

impl<'a> Velocities<'a> {
    fn new(motion: &'a mut [Motion]) -> Self {
        Self {
            first: motion.as_mut_ptr(),
            len: motion.len(),
            _array: PhantomData,
        }
    }

    /// A copy of particle j's motion.
    ///
    /// # Safety
    /// No other thread may write particle j meanwhile.
    unsafe fn read(&self, j: usize) -> Motion {
        assert!(j < self.len, "particle {j} of {}", self.len);
        // SAFETY: in bounds; no concurrent write (the caller's contract).
        unsafe { self.first.add(j).read() }
    }

    /// Stores particle i's motion.
    ///
    /// # Safety
    /// No other thread may read or write particle i meanwhile.
    unsafe fn write(&self, i: usize, motion: Motion) {
        assert!(i < self.len, "particle {i} of {}", self.len);
        // SAFETY: in bounds; no concurrent access (the caller's contract).
        unsafe { self.first.add(i).write(motion) }
    }
}

/// Relaxes particle i (the lid moving at `lid_velocity`) and returns the size of its change.
///
/// # Safety
/// No other thread may write particle i or any of its listed partners, nor read particle i,
/// meanwhile.
unsafe fn relax(
    stage: &Stage,
    velocities: &Velocities,
    (i, lid_velocity): (usize, f64),
    terms: &mut Terms,
    control: SolverControl,
) -> f64 {
    // SAFETY: particle i is this task's alone (the caller's contract).
    let old = unsafe { velocities.read(i) };
    let partner_velocity = |c: &Contact| {
        // SAFETY: j is a listed partner of i (the caller's contract).
        stage.partner_velocity(c, lid_velocity, |j| unsafe { velocities.read(j) })
    };
    let loads = (stage.force[i], stage.torque[i]);
    let local = Local::new(stage, i, loads, terms, partner_velocity);
    let new = solve_particle(&local, old, control);
    // SAFETY: as for the read of `old`.
    unsafe { velocities.write(i, new) };
    (new.v - old.v).norm() + stage.radius[i] * (new.w - old.w).norm()
}

/// The local problem of particle i with every other particle's motion held fixed.
pub(super) struct Local<'a> {
    stage: &'a Stage<'a>,
    radius: f64,
    force: Vector3<f64>,
    torque: Vector3<f64>,
    terms: &'a Terms,
    /// v_ε².
    slip_scale_squared: f64,
}

/// A particle's contact terms in list order: each contact with what its partner and the
/// start of the stage fix. Room reused from visit to visit (a task's particles one after
/// another): the first 32 in place, any further ones in `overflow`.
#[derive(Default)]
pub(super) struct Terms {
    listed: [(Contact, Partner); 32],
    count: usize,
    overflow: Vec<(Contact, Partner)>,
}

impl Terms {
    /// Particle i's contacts, the partners' surface velocities held at `partner_velocity`.
    fn fill(
        &mut self,
        stage: &Stage,
        i: usize,
        partner_velocity: impl Fn(&Contact) -> Vector3<f64>,
    ) {
        self.count = 0;
        self.overflow.clear();
        for c in stage.contacts.of(i) {
            let bound = stage.law.friction_of(&c) * c.normal_force_at(c.overlap);
            let term = (
                c,
                Partner {
                    velocity: partner_velocity(&c),
                    bound,
                },
            );
            match self.listed.get_mut(self.count) {
                Some(slot) => {
                    *slot = term;
                    self.count += 1;
                }
                None => self.overflow.push(term),
            }
        }
    }

    fn iter(&self) -> impl Iterator<Item = (&Contact, &Partner)> {
        self.listed[..self.count]
            .iter()
            .chain(&self.overflow)
            .map(|(c, p)| (c, p))
    }
}

/// What a contact's terms of the local Φ hold fixed: the partner's surface velocity and the
/// friction bound μ F_n(δ_c) (taken once per visit, not at every evaluation).
#[derive(Debug, Clone, Copy, Default)]
struct Partner {
    /// Surface velocity of the partner at the contact.
    velocity: Vector3<f64>,
    /// μ F_n(δ_c) at the overlap at the start of the stage.
    bound: f64,
}

impl<'a> Local<'a> {
    /// Particle i's problem under the external `force` and `torque`, the surface velocity of
    /// each contact's partner held at `partner_velocity` (taken once per contact); `terms`
    /// holds the contact terms.
    pub(super) fn new(
        stage: &'a Stage<'a>,
        i: usize,
        (force, torque): (Vector3<f64>, Vector3<f64>),
        terms: &'a mut Terms,
        partner_velocity: impl Fn(&Contact) -> Vector3<f64>,
    ) -> Self {
        terms.fill(stage, i, partner_velocity);
        Self {
            stage,
            radius: stage.radius[i],
            force,
            torque,
            terms,
            slip_scale_squared: stage.slip_scale.powi(2),
        }
    }

    /// The contacts with their fixed partner data, in list order.
    fn terms(&self) -> impl Iterator<Item = (&Contact, &Partner)> {
        self.terms.iter()
    }

    /// Whether no contact of the particle can carry friction (μ F_n = 0 at every contact).
    fn frictionless(&self) -> bool {
        self.terms().all(|(_, p)| p.bound == 0.0)
    }

    /// Φ restricted to this particle, up to a constant: its own terms.
    fn own_value(&self, u: &Motion) -> f64 {
        0.5 * u.v.norm_squared() + 0.5 * self.radius * self.radius * u.w.norm_squared()
            - self.force.dot(&u.v)
            - self.torque.dot(&u.w)
    }

    /// Φ restricted to this particle, up to a constant.
    fn value(&self, u: &Motion) -> f64 {
        let dt = self.stage.dt;
        let mut phi = self.own_value(u);
        for (c, p) in self.terms() {
            let rel = u.v + self.radius * u.w.cross(&c.normal) - p.velocity;
            let normal_rate = rel.dot(&c.normal);
            let end = c.overlap + dt * normal_rate;
            if end > 0.0 {
                phi += 0.4 * c.hertz * end * end * end.sqrt() / dt;
            }
            if p.bound > 0.0 {
                let slip = rel - normal_rate * c.normal;
                phi += p.bound * (slip.norm_squared() + self.slip_scale_squared).sqrt();
            }
        }
        phi
    }

    /// Value (as [`Local::value`], the same bits), gradient and Hessian at u, in one pass
    /// over the contacts.
    fn expansion(&self, u: &Motion) -> (f64, Vector6<f64>, Matrix6<f64>) {
        let (dt, r) = (self.stage.dt, self.radius);
        let mut phi = self.own_value(u);
        let mut gv = u.v - self.force;
        let mut gw = r * r * u.w - self.torque;
        // the Hessian's blocks: vv, ω-v (its transpose is v-ω) and ωω
        let (mut hvv, mut hwv, mut hww) = (Matrix3::zeros(), Matrix3::zeros(), Matrix3::zeros());
        for (c, p) in self.terms() {
            let e = c.normal;
            let rel = u.v + r * u.w.cross(&e) - p.velocity;
            let normal_rate = rel.dot(&e);
            let end = c.overlap + dt * normal_rate;
            let outer = e * e.transpose();
            if end > 0.0 {
                phi += 0.4 * c.hertz * end * end * end.sqrt() / dt;
                gv += c.normal_force_at(end) * e;
                hvv += (dt * c.stiffness_at(end)) * outer;
            }
            let bound = p.bound;
            if bound > 0.0 {
                let slip = rel - normal_rate * e;
                let rho = (slip.norm_squared() + self.slip_scale_squared).sqrt();
                phi += bound * rho;
                // Hessian of μF_n ρ(P (v + S ω)), S = −r [e]×: Jᵀ Q J with
                // Q = a (I − s sᵀ/ρ²), a = μF_n/ρ; since s ⊥ e, P s = s and P S = S, the
                // blocks reduce to vv = a P − c s sᵀ, ωv = a Sᵀ − c t sᵀ and
                // ωω = a r² P − c t tᵀ (c = a/ρ², `along_slip`; t = Sᵀ s = r e × s, `turn`).
                let a = bound / rho;
                let along_slip = a / (rho * rho);
                let turn = r * e.cross(&slip);
                gv += a * slip;
                gw += a * turn;
                let projector = Matrix3::identity() - outer;
                hvv += a * projector - along_slip * slip * slip.transpose();
                hwv += (a * r) * e.cross_matrix() - along_slip * turn * slip.transpose();
                hww += (a * r * r) * projector - along_slip * turn * turn.transpose();
            }
        }
        let mut hess = Matrix6::zeros();
        hess.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() + hvv));
        hess.fixed_view_mut::<3, 3>(3, 0).copy_from(&hwv);
        hess.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&hwv.transpose());
        hess.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::from_diagonal_element(r * r) + hww));
        let mut grad = Vector6::zeros();
        grad.fixed_rows_mut::<3>(0).copy_from(&gv);
        grad.fixed_rows_mut::<3>(3).copy_from(&gw);
        (phi, grad, hess)
    }
}

/// Damped Newton on a particle's local problem, started at `start`; then over-relaxed to start + ω (minimizer − start) where that keeps at
/// least half of the minimizer's decrease of Φ (as it does for ω ≤ 1 + 1/√2 on a quadratic):
/// every visit lowers Φ, and the fixed point, the minimizer of Φ, is the same.
pub(super) fn solve_particle(local: &Local, start: Motion, control: SolverControl) -> Motion {
    let (mut u, [phi_start, phi_end]) = newton(local, start, LOCAL_TOLERANCE * control.tolerance);
    let omega = control.over_relaxation;
    if omega != 1.0 {
        let beyond = Motion {
            v: start.v + omega * (u.v - start.v),
            w: start.w + omega * (u.w - start.w),
        };
        if local.value(&beyond) <= phi_end + 0.5 * (phi_start - phi_end) {
            u = beyond;
        }
    }
    if local.frictionless() {
        // Φ separates: the rotation is r² ω = T exactly, whatever the contacts do (so with
        // μ = 0 every particle turns as if alone, to round-off; spec align.md, "Studies").
        u.w = local.torque / (local.radius * local.radius);
    }
    u
}

/// The local minimizer (to a step below `tolerance`), and Φ at the start and there.
fn newton(local: &Local, start: Motion, tolerance: f64) -> (Motion, [f64; 2]) {
    let mut u = start;
    let (mut phi, mut grad, mut hess) = local.expansion(&u);
    let phi_start = phi;
    for iteration in 0..50 {
        if iteration > 0 {
            // Φ at u is the line search's accepted value (the same bits)
            (_, grad, hess) = local.expansion(&u);
        }
        let Some(step) = cholesky_solve(&hess, &(-grad)) else {
            break;
        };
        let slope = grad.dot(&step);
        let mut t = 1.0;
        let mut trial;
        loop {
            trial = Motion {
                v: u.v + t * step.fixed_rows::<3>(0),
                w: u.w + t * step.fixed_rows::<3>(3),
            };
            let value = local.value(&trial);
            if value <= phi + 1e-4 * t * slope || t < 1e-3 {
                phi = value;
                break;
            }
            t *= 0.5;
        }
        u = trial;
        let moved =
            t * (step.fixed_rows::<3>(0).norm() + local.radius * step.fixed_rows::<3>(3).norm());
        if moved <= tolerance {
            break;
        }
    }
    (u, [phi_start, phi])
}

/// Solves H x = b for a symmetric positive definite H by its Cholesky factor L Lᵀ (lower
/// triangle of H read); None if H is not positive definite. Written out for 6×6: the local
/// Newton's solve, where nalgebra's generic factorization cost ~18 % of a run.
fn cholesky_solve(h: &Matrix6<f64>, b: &Vector6<f64>) -> Option<Vector6<f64>> {
    // s − Σ_k x_k y_k, the terms subtracted one by one
    let reduce = |s: f64, x: &[f64], y: &[f64]| x.iter().zip(y).fold(s, |s, (a, b)| s - a * b);
    let mut l = [[0.0_f64; 6]; 6];
    let mut inverse_diagonal = [0.0_f64; 6];
    for j in 0..6 {
        let d = reduce(h[(j, j)], &l[j][..j], &l[j][..j]);
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        inverse_diagonal[j] = 1.0 / d.sqrt();
        for i in j + 1..6 {
            l[i][j] = reduce(h[(i, j)], &l[i][..j], &l[j][..j]) * inverse_diagonal[j];
        }
    }
    let mut y = [0.0_f64; 6];
    for i in 0..6 {
        y[i] = reduce(b[i], &l[i][..i], &y[..i]) * inverse_diagonal[i];
    }
    let mut x = [0.0_f64; 6];
    for i in (0..6).rev() {
        x[i] = (i + 1..6).fold(y[i], |s, k| s - l[k][i] * x[k]) * inverse_diagonal[i];
    }
    Some(Vector6::from(x))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::contacts::pressed_pair;
    use crate::neighbor::NeighborList;

    /// Two spheres pressed together along x, each spun by an opposite-sign torque about z, one
    /// wall-free configuration: checks the friction torque opposes spin and forces balance.
    #[test]
    fn friction_opposes_spin_and_pair_forces_balance() {
        let (positions, radius, law, contacts) = pressed_pair(0.5);
        let fn0 = contacts.contact(0, 0).normal_force_at(0.01);
        // Same-sense spin about z: surfaces slide against each other at the contact.
        let torque = vec![Vector3::new(0.0, 0.0, 1e-3), Vector3::new(0.0, 0.0, 1e-3)];
        // Equal and opposite pushes hold the overlap steady.
        let force = vec![Vector3::new(fn0, 0.0, 0.0), Vector3::new(-fn0, 0.0, 0.0)];
        let stage = Stage {
            contacts: &contacts,
            law: &law,
            radius: &radius,
            force: &force,
            torque: &torque,
            dt: 1.0,
            slip_scale: 1e-9,
            lid: None,
        };
        let mut motion = vec![Motion::default(); 2];
        let schedule = Schedule::new(&positions, 3.0, usize::MAX);
        let stats = solve(
            &stage,
            &schedule,
            &mut motion,
            &mut 0.0,
            SolverControl {
                tolerance: 1e-14,
                max_sweeps: 500,
                over_relaxation: OVER_RELAXATION,
            },
        );
        assert!(stats.converged);
        // μF_n = 0.5·fn0 ≈ 5e-4 < torque: sliding; friction torque R μ F_n each opposes the spin.
        let bound = 0.5 * fn0;
        for m in &motion {
            let expected = 1e-3 - bound;
            assert!(
                (m.w.z - expected).abs() < 1e-8 * 1e-3,
                "{} vs {expected}",
                m.w.z
            );
        }
        // Equal and opposite tangential forces: centres drift in ±y by equal amounts.
        assert!((motion[0].v + motion[1].v).norm() < 1e-12);
    }

    /// A settled bed of 150 spheres, pushed down and twisted by random torques: the
    /// over-relaxed sweeps converge to the plain Gauss–Seidel velocities (the same minimizer of
    /// Φ) within the solver tolerance.
    #[test]
    fn over_relaxed_sweeps_reach_the_gauss_seidel_velocities() {
        use crate::materials::MaterialDb;
        use crate::models::align::dem::contacts::Container;
        use crate::models::align::dem::Packing;
        use crate::models::align::AlignParams;
        use rand::{RngExt, SeedableRng};
        let material = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        let mut params = AlignParams::paper_defaults(material, 3.2e6);
        params.particles = 150;
        let packing = Packing::generate(&params.packing(), 1).unwrap();
        let (positions, radius) = (&packing.position, &packing.radius);
        let law = ContactLaw {
            effective_modulus: 0.55,
            friction: 0.2,
            wall_friction: 0.2,
            skin: 0.1,
        };
        let mut list = NeighborList::new(0.3);
        list.build(positions, radius);
        let container = Container {
            top: None,
            ..packing.container
        };
        let mut contacts = ContactSet::default();
        contacts.rebuild(positions, radius, &list, &container, &law);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut spin = || 1e-3 * (2.0 * rng.random::<f64>() - 1.0);
        let torque: Vec<_> = radius
            .iter()
            .map(|r| r.powi(3) * Vector3::new(spin(), spin(), spin()))
            .collect();
        let force = vec![Vector3::new(0.0, 0.0, -1e-4); radius.len()];
        let stage = Stage {
            contacts: &contacts,
            law: &law,
            radius,
            force: &force,
            torque: &torque,
            dt: 20.0,
            slip_scale: 1e-5,
            lid: None,
        };
        let schedule = Schedule::new(positions, 3.0, usize::MAX);
        let tolerance = 1e-10;
        let solved = |over_relaxation| {
            let mut motion = vec![Motion::default(); radius.len()];
            let control = SolverControl {
                tolerance,
                max_sweeps: 5000,
                over_relaxation,
            };
            let stats = solve(&stage, &schedule, &mut motion, &mut 0.0, control);
            assert!(stats.converged, "ω = {over_relaxation}");
            motion
        };
        let (plain, over) = (solved(1.0), solved(OVER_RELAXATION));
        for ((a, b), r) in plain.iter().zip(&over).zip(radius) {
            let gap = (a.v - b.v).norm() + r * (a.w - b.w).norm();
            assert!(gap < 100.0 * tolerance, "{gap:e}");
        }
    }

    /// The local expansion of a compressed, sliding contact: its value has the bits of
    /// `Local::value`, and its gradient and (reduced) Hessian match central differences of
    /// the value and of the gradient.
    #[test]
    fn local_expansion_matches_finite_differences() {
        let (_, radius, law, contacts) = pressed_pair(0.5);
        let (force, torque) = (vec![Vector3::zeros(); 2], vec![Vector3::zeros(); 2]);
        let stage = Stage {
            contacts: &contacts,
            law: &law,
            radius: &radius,
            force: &force,
            torque: &torque,
            dt: 0.5,
            slip_scale: 1e-3,
            lid: None,
        };
        let loads = (
            Vector3::new(1e-4, -2e-4, 3e-4),
            Vector3::new(-2e-4, 1e-4, 5e-4),
        );
        let mut terms = Terms::default();
        let local = Local::new(&stage, 0, loads, &mut terms, |_| {
            Vector3::new(-1e-3, 2e-3, 1e-3)
        });
        let at = |x: &Vector6<f64>| Motion {
            v: x.fixed_rows::<3>(0).into(),
            w: x.fixed_rows::<3>(3).into(),
        };
        let x = Vector6::new(2e-3, -1e-3, 3e-3, 1e-3, -4e-3, 2e-3);
        let (phi, grad, hess) = local.expansion(&at(&x));
        assert_eq!(phi, local.value(&at(&x)));
        let h = 1e-7;
        for k in 0..6 {
            let dx = Vector6::from_fn(|i, _| if i == k { h } else { 0.0 });
            let (plus, minus) = (at(&(x + dx)), at(&(x - dx)));
            let slope = (local.value(&plus) - local.value(&minus)) / (2.0 * h);
            assert!(
                (slope - grad[k]).abs() < 1e-6 * grad.amax(),
                "{k}: {slope} vs {grad}"
            );
            let column = (local.expansion(&plus).1 - local.expansion(&minus).1) / (2.0 * h);
            let gap = (column - hess.column(k)).amax();
            assert!(gap < 1e-5 * hess.amax(), "{k}: {column} vs {hess}");
        }
    }

    /// The written-out 6×6 Cholesky solve agrees with nalgebra's and refuses an indefinite
    /// matrix.
    #[test]
    fn cholesky_solve_matches_nalgebra() {
        let a = Matrix6::from_fn(|i, j| ((3 * i + 5 * j) % 7) as f64 - 3.0 + (i == j) as u8 as f64);
        let h = a.transpose() * a + Matrix6::identity();
        let b = Vector6::new(1.0, -2.0, 0.5, 3.0, -1.0, 2.0);
        let ours = cholesky_solve(&h, &b).unwrap();
        let reference = h.cholesky().unwrap().solve(&b);
        assert!(
            (ours - reference).amax() < 1e-12 * reference.amax(),
            "{ours} vs {reference}"
        );
        let mut indefinite = h;
        indefinite[(4, 4)] = -1.0;
        assert!(cholesky_solve(&indefinite, &b).is_none());
    }

    #[test]
    fn cells_of_one_colour_share_no_neighbours() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let positions: Vec<Vector3<f64>> = (0..2000)
            .map(|_| {
                Vector3::new(
                    rng.random::<f64>() * 30.0,
                    rng.random::<f64>() * 30.0,
                    rng.random::<f64>() * 15.0,
                )
            })
            .collect();
        let radius: Vec<f64> = (0..2000).map(|_| 0.7 + 0.6 * rng.random::<f64>()).collect();
        let skin = 0.2;
        let mut list = NeighborList::new(skin);
        list.build(&positions, &radius);
        let r_max = radius.iter().cloned().fold(0.0, f64::max);
        let schedule = Schedule::new(&positions, 2.0 * r_max + skin, 0);
        let mut seen = vec![false; positions.len()];
        for colour in &schedule.colours {
            let mut cell_of = std::collections::HashMap::new();
            for (c, cell) in colour.iter().enumerate() {
                for &i in cell {
                    cell_of.insert(i, c);
                    seen[i as usize] = true;
                }
            }
            for (&i, &c) in &cell_of {
                for j in list.of(i as usize) {
                    assert!(
                        cell_of.get(j).is_none_or(|&d| d == c),
                        "{i} and {j} share a colour across cells"
                    );
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "every particle is scheduled once");
    }
}
