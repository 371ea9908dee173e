//! The non-friction force F_T on every particle (B1 pairs, B2 walls, gravity), the plate normal
//! force N_i of the dry friction (B4), the force on the piston, and the closest-approach data
//! the time step and the run checks need. Every particle's sums are gathered over its own
//! neighbours in a fixed order (exact sums: over its tiles in tile order, [`ExactSums`]), so
//! results are bit-identical whatever the thread count.

use nalgebra::Vector2;
use rayon::prelude::*;
use std::f64::consts::PI;

use super::exact::ExactSums;
use super::far_field::FarField;
use super::list_gather::{pair_sums, Partner, Partners};
use super::list_pairs::HalfList;
use super::params::{BedParams, Neighbors, WallLaw};
use super::state::{Geometry, Particles, State};
use super::tail::Tail;
use super::walls::{Walls, WALL_NORMALS};
use crate::neighbor::{NeighborList, Watch};
use crate::numerics::fold_items;
use crate::units::MU0;

/// From this many particles on, the per-particle gather runs on the rayon pool.
const PARALLEL_FROM: usize = 256;

/// The most particles one task of the per-particle gather takes: rayon's own split gives
/// each of two threads about two pieces, and the discs' costs differ (walls, the tail's
/// bands), so one thread was left waiting at the end of each pass.
const PIECE: usize = 256;

/// What the force evaluation gives for one particle, SI.
#[derive(Debug, Clone, Copy, Default)]
pub struct ParticleForce {
    /// F_T = F_pp + F_pw + gravity (the non-friction force), N.
    pub force: Vector2<f64>,
    /// Normal force N_i of the plates on i (B4), N (0 when dry friction is off).
    pub normal: f64,
    /// Force i exerts on the piston (upwards), N.
    pub on_piston: f64,
    /// max_j ((D_i + D_j)/2 / r_ij)²: above 1/0.9² means a pair closer than 0.9 D.
    pub closeness: f64,
    /// Largest stiffness over mass, k/m_i (pair or wall), 1/s².
    pub stiffness: f64,
    /// Wall stiffness of i towards the piston, N/m (for a moving piston's time step).
    pub piston_stiffness: f64,
}

/// Which pairs enter the sums.
#[derive(Debug, Clone)]
enum Pairs {
    All(ExactSums),
    Cut {
        list: NeighborList<2>,
        radii: Vec<f64>,
        cutoff2: f64,
        every_step: bool,
        split: Option<Box<Split>>,
        /// The pair terms of `list` (of its far pairs in a split evaluation).
        half: HalfList,
    },
    /// Pairs closer than r_s from a list every step, every pair beyond r_s from the quadtree
    /// every `interval` steps (no cut-off).
    Tree {
        split: Box<Split>,
        tree: FarField,
    },
}

/// Multiple time stepping of the pair sums: pairs closer than the near cut-off r_s are summed
/// every step, pairs in r_s ≤ r < r_c every `interval` steps and held in between. Far pairs
/// are soft and change slowly (their force varies like r⁻⁴ over a displacement that is a small
/// fraction of r), while the near pairs set the time step; walls and gravity are evaluated
/// every step.
#[derive(Debug, Clone)]
struct Split {
    interval: usize,
    near: NeighborList<2>,
    near_radii: Vec<f64>,
    near2: f64,
    near_half: HalfList,
    far: Vec<PairSums>,
    due: usize,
}

impl Split {
    /// Near list of radius r_s with the skin r_v − r_c, far sums every `far_field_interval`.
    fn new(params: &BedParams, d1: f64, n: usize) -> Self {
        let (rc, rv) = (
            params.cutoff.diameters(d1) * d1,
            params.list_radius.diameters(d1) * d1,
        );
        let rs = params.near_cutoff.diameters(d1) * d1;
        Self {
            interval: params.far_field_interval,
            near: NeighborList::new(rv - rc),
            near_radii: vec![0.5 * rs; n],
            near2: rs * rs,
            near_half: HalfList::default(),
            far: Vec::new(),
            due: 0,
        }
    }

    /// Brings the near list and its pair terms up to date; returns whether the far sums are
    /// due this step.
    fn step(&mut self, position: &[Vector2<f64>]) -> bool {
        let due = self.due == 0;
        self.due = if due { self.interval } else { self.due } - 1;
        self.near.update(position, &self.near_radii);
        self.near_half
            .evaluate(&self.near, position, (0.0, self.near2));
        due
    }
}

/// The force model of one run: constants, neighbour structure and the per-particle output.
#[derive(Debug, Clone)]
pub struct ForceField {
    pair: f64,
    wall_law: WallLaw,
    wall: Vec<f64>,
    gravity: f64,
    dry: bool,
    geometry: Geometry,
    pairs: Pairs,
    /// The mean-field tail beyond the cut-off, where asked for.
    tail: Option<Tail>,
    partner: Vec<Partner>,
    /// Whether every particle's `partner` record is the same (one species).
    uniform_partners: bool,
    /// Per-particle results of the last evaluation.
    pub out: Vec<ParticleForce>,
}

impl ForceField {
    /// The force model for these parameters and particles.
    pub fn new(params: &BedParams, particles: &Particles, geometry: Geometry) -> Self {
        let d1 = params.reference_diameter();
        let mu1 = params.moment(d1);
        let wall = particles
            .moment
            .iter()
            .map(|&mu| match params.wall_law {
                WallLaw::Empirical => MU0 * mu * params.wall_strength() / (2.0 * PI),
                WallLaw::InfiniteRow => MU0 * mu * (mu1 / d1) / PI,
                WallLaw::FiniteBar => 3.0 * MU0 * mu * (mu1 / d1) / (4.0 * PI),
            })
            .collect();
        let n = particles.len();
        let pairs = match params.neighbors {
            Neighbors::Exact => Pairs::All(ExactSums::new(particles)),
            Neighbors::Tree => Pairs::Tree {
                split: Box::new(Split::new(params, d1, n)),
                tree: FarField::new(
                    params.opening_angle,
                    params.near_cutoff.diameters(d1) * d1,
                    &particles.moment,
                    &particles.tilt_sin,
                ),
            },
            Neighbors::SourceVerlet => {
                let rv = params.list_radius.diameters(d1) * d1;
                Pairs::Cut {
                    list: NeighborList::with_rebuild_distance(
                        0.0,
                        params.rebuild_skin.diameters(d1) * d1,
                    ),
                    radii: vec![0.5 * rv; n],
                    cutoff2: f64::INFINITY,
                    every_step: false,
                    split: None,
                    half: HalfList::default(),
                }
            }
            kind => {
                let (rc, rv) = (
                    params.cutoff.diameters(d1) * d1,
                    params.list_radius.diameters(d1) * d1,
                );
                let every_step = kind == Neighbors::Cells;
                Pairs::Cut {
                    list: NeighborList::new(if every_step { 0.0 } else { rv - rc }),
                    radii: vec![0.5 * rc; n],
                    cutoff2: rc * rc,
                    every_step,
                    split: (params.far_field_interval > 1)
                        .then(|| Box::new(Split::new(params, d1, n))),
                    half: HalfList::default(),
                }
            }
        };
        let partner: Vec<Partner> = (0..n)
            .map(|j| Partner {
                moment: particles.moment[j],
                moment_sin: particles.moment[j] * particles.tilt_sin[j],
                diameter: particles.diameter[j],
            })
            .collect();
        let tail = params
            .tail_correction
            .applies(params.neighbors)
            .then(|| Tail::new(params.cutoff.diameters(d1) * d1));
        Self {
            pair: 3.0 * MU0 / (4.0 * PI),
            wall_law: params.wall_law,
            wall,
            gravity: params.gravity,
            dry: params.friction.dry(),
            geometry,
            pairs,
            tail,
            uniform_partners: Partners::new(&partner).uniform,
            partner,
            out: vec![ParticleForce::default(); n],
        }
    }

    /// Number of neighbour-list builds so far (0 for exact sums).
    pub fn list_builds(&self) -> usize {
        match &self.pairs {
            Pairs::All(_) => 0,
            Pairs::Cut { list, .. } => list.builds(),
            Pairs::Tree { split, .. } => split.near.builds(),
        }
    }

    /// Evaluates every particle's forces at the state into `self.out`.
    pub fn evaluate(&mut self, particles: &Particles, state: &State) {
        self.evaluate_watched(particles, state, None);
    }

    /// The neighbour list's rebuild check for a caller that moves the `n` particles (see
    /// [`NeighborList::watch`]): for a list updated every step on the particles' moves.
    pub fn watch(&self, n: usize) -> Option<Watch<'_, 2>> {
        match &self.pairs {
            Pairs::Cut {
                list,
                every_step: false,
                split: None,
                ..
            } => list.watch(n),
            _ => None,
        }
    }

    /// [`Self::evaluate`] after moves that ran [`Self::watch`] over every particle: `beyond`
    /// is whether some particle went beyond (None: no watch ran).
    pub fn evaluate_watched(&mut self, particles: &Particles, state: &State, beyond: Option<bool>) {
        let (position, n) = (&state.position, state.position.len());
        if let Pairs::All(exact) = &mut self.pairs {
            exact.evaluate(position);
        }
        if self.update_lists(position, beyond) {
            // the held far sums are refilled in place (no allocation after the first)
            let mut far = self
                .split_mut()
                .map(|s| std::mem::take(&mut s.far))
                .unwrap_or_default();
            per_particle(&mut far, n, |i| self.far_sums(i));
            if let Some(split) = self.split_mut() {
                split.far = far;
            }
        }
        if let Some(tail) = &mut self.tail {
            tail.update(position, &self.partner, |out, f| per_particle(out, n, f));
        }
        let mut out = std::mem::take(&mut self.out);
        per_particle(&mut out, n, |i| self.particle(i, particles, state));
        self.out = out;
    }

    fn split_mut(&mut self) -> Option<&mut Split> {
        match &mut self.pairs {
            Pairs::Cut {
                split: Some(split), ..
            }
            | Pairs::Tree { split, .. } => Some(split),
            _ => None,
        }
    }

    /// Brings the neighbour lists and their pair terms up to date for this step; returns
    /// whether the far part of a split evaluation is due (its list is then updated too).
    fn update_lists(&mut self, position: &[Vector2<f64>], beyond: Option<bool>) -> bool {
        let (list, radii, cutoff2, every_step, split, half) = match &mut self.pairs {
            Pairs::All(_) => return false,
            Pairs::Tree { split, tree } => {
                if split.step(position) {
                    tree.evaluate(position, &mut split.far);
                }
                return false;
            }
            Pairs::Cut {
                list,
                radii,
                cutoff2,
                every_step,
                split,
                half,
            } => (list, radii, cutoff2, every_step, split, half),
        };
        let Some(split) = split else {
            match (*every_step, beyond) {
                (true, _) => list.build(position, radii),
                (false, Some(beyond)) => _ = list.update_watched(position, radii, beyond),
                (false, None) => _ = list.update(position, radii),
            }
            half.evaluate(list, position, (0.0, *cutoff2));
            return false;
        };
        let due = split.step(position);
        if due {
            list.update(position, radii);
            half.evaluate(list, position, (split.near2, *cutoff2));
        }
        due
    }

    /// The cell the forces are evaluated in.
    pub(super) fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Total force on the piston (upwards), summed in index order, N.
    pub fn piston_force(&self) -> f64 {
        self.out.iter().map(|o| o.on_piston).sum()
    }

    fn particle(&self, i: usize, particles: &Particles, state: &State) -> ParticleForce {
        // The walls first: they need no pair sums, so their divisions can run during the gather.
        let walls = Walls::on(
            self.wall_law,
            self.wall[i],
            state.position[i],
            &self.geometry,
            state.piston,
        );
        let acc = match &self.pairs {
            Pairs::All(exact) => exact.of(i),
            Pairs::Cut {
                list,
                half,
                split: None,
                ..
            } => self.list_sums(i, half, list),
            Pairs::Cut {
                split: Some(split), ..
            }
            | Pairs::Tree { split, .. } => self
                .list_sums(i, &split.near_half, &split.near)
                .plus(&split.far[i]),
        };
        let acc = match &self.tail {
            Some(tail) => acc.with_tail(tail.at(i)),
            None => acc,
        };
        let (mu, m) = (particles.moment[i], particles.mass[i]);
        let mut out = ParticleForce {
            force: acc.force * (self.pair * mu),
            normal: if self.dry {
                self.pair * mu * particles.tilt_own[i] * acc.normal
            } else {
                0.0
            },
            closeness: acc.closeness,
            on_piston: walls.magnitude[3],
            piston_stiffness: walls.stiffness[3],
            ..ParticleForce::default()
        };
        out.force.y -= m * self.gravity;
        for (normal, magnitude) in WALL_NORMALS.iter().zip(walls.magnitude) {
            out.force += normal * magnitude;
        }
        let stiffest_wall = walls
            .stiffness
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max);
        // max(a/m, b/m) = max(a, b)/m for m > 0 (rounding is monotone): one division.
        out.stiffness = (4.0 * self.pair * mu * acc.stiffest).max(stiffest_wall) / m;
        out
    }

    /// The far part of i's pair sums (pairs in r_s ≤ r < r_c) of a split evaluation.
    fn far_sums(&self, i: usize) -> PairSums {
        match &self.pairs {
            Pairs::Cut {
                list,
                half,
                split: Some(_),
                ..
            } => self.list_sums(i, half, list),
            _ => PairSums::default(),
        }
    }

    /// The pair sums of i over its partners in `list`, added one by one in list order. Pairs
    /// outside the distance range have zero inverse powers and add exact zeros, so the sums
    /// equal those over the pairs inside alone.
    fn list_sums(&self, i: usize, half: &HalfList, list: &NeighborList<2>) -> PairSums {
        let partners = Partners {
            each: &self.partner,
            uniform: self.uniform_partners,
        };
        pair_sums(&half.row(list, i), partners, self.partner[i].diameter)
    }

    /// Ordered pair terms (i, j) the last evaluation's loops ran over, masked ones included
    /// (a benchmark count): every listed partner of every particle, so each unordered pair
    /// twice (the lists are full); N(N − 1) for exact sums; with multiple time stepping the
    /// near list, plus the far list (the tree's pair and node terms) on the steps its sums
    /// were due.
    pub fn pair_terms(&self) -> usize {
        let n = self.out.len();
        match &self.pairs {
            Pairs::All(_) => n * n.saturating_sub(1),
            Pairs::Cut {
                list, split: None, ..
            } => list.len(),
            Pairs::Cut {
                list,
                split: Some(split),
                ..
            } => split.near.len() + usize::from(split.due + 1 == split.interval) * list.len(),
            Pairs::Tree { split, tree } => {
                split.near.len() + usize::from(split.due + 1 == split.interval) * tree.terms()
            }
        }
    }

    /// Ordered pairs (i, j) closer than the cut-off at these positions (a benchmark count):
    /// N(N − 1) for exact sums and the tree (no cut-off), every entry of a list rebuilt each step without skin, else one
    /// pass over the list (sample it at list builds, not every step).
    pub fn pairs_within_cutoff(&self, position: &[Vector2<f64>]) -> usize {
        let n = position.len();
        match &self.pairs {
            Pairs::All(_) | Pairs::Tree { .. } => n * n.saturating_sub(1),
            Pairs::Cut {
                list,
                every_step: true,
                ..
            } => list.len(),
            Pairs::Cut { list, cutoff2, .. } => {
                let inside = |i: usize| {
                    let near =
                        |&&j: &&u32| (position[i] - position[j as usize]).norm_squared() < *cutoff2;
                    list.of(i).iter().filter(near).count()
                };
                fold_items(n, 0, inside, |a, b| a + b)
            }
        }
    }
}

/// max(a, b) for a running maximum a that is never NaN: one compare-and-select, where
/// `f64::max` adds NaN handling to the pair loop (the result is the same: a NaN b keeps a).
#[inline(always)]
pub(super) fn larger(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

/// Running sums of one particle's pair loop (without the μ_i and 3μ0/4π factors).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct PairSums {
    /// Σ_j μ_j d/r⁵ with d = r_i − r_j, A·m²/m⁴.
    pub(super) force: Vector2<f64>,
    /// Σ_j μ_j sin θ_j/r³ (B4), A·m²/m³.
    pub(super) normal: f64,
    /// max_j μ_j/r⁵, A·m²/m⁵.
    pub(super) stiffest: f64,
    /// max_j ((D_i + D_j)/2)²/r².
    pub(super) closeness: f64,
}

impl PairSums {
    /// The sums with the tails (of the force sum, of the normal sum) of the pairs beyond the
    /// cut-off added; the maxima come from the pairs summed.
    fn with_tail(self, (force, normal): (Vector2<f64>, f64)) -> PairSums {
        PairSums {
            force: self.force + force,
            normal: self.normal + normal,
            ..self
        }
    }

    /// The sums over the union of two disjoint sets of pairs.
    fn plus(self, other: &PairSums) -> PairSums {
        PairSums {
            force: self.force + other.force,
            normal: self.normal + other.normal,
            stiffest: larger(self.stiffest, other.stiffest),
            closeness: larger(self.closeness, other.closeness),
        }
    }
}

/// Sets `out` to f(0), …, f(n − 1), on the rayon pool from `PARALLEL_FROM` particles on (each
/// entry depends on its index alone, so the result is thread-count independent), in tasks of
/// at most `PIECE` particles.
fn per_particle<T: Send>(out: &mut Vec<T>, n: usize, f: impl Fn(usize) -> T + Sync + Send) {
    if n >= PARALLEL_FROM {
        (0..n)
            .into_par_iter()
            .with_max_len(PIECE)
            .map(f)
            .collect_into_vec(out);
    } else {
        out.clear();
        out.extend((0..n).map(f));
    }
}

/// The B1 force of j on i, N (for the action = reaction test and diagnostics).
pub fn pair_force(mu_i: f64, mu_j: f64, r_i: Vector2<f64>, r_j: Vector2<f64>) -> Vector2<f64> {
    let d = r_i - r_j;
    let r2 = d.norm_squared();
    d * (3.0 * MU0 / (4.0 * PI) * mu_i * mu_j / (r2 * r2 * r2.sqrt()))
}
