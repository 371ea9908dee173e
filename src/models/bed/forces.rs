//! The non-friction force F_T on every particle (B1 pairs, B2 walls, gravity), the plate normal
//! force N_i of the dry friction (B4), the force on the piston, and the closest-approach data
//! the time step and the run checks need. Every particle's sums are gathered over its own
//! neighbours in a fixed order, so results are bit-identical whatever the thread count.

use nalgebra::Vector2;
use rayon::prelude::*;
use std::f64::consts::PI;

use super::params::{BedParams, Neighbors, WallLaw};
use super::state::{Geometry, Particles, State};
use crate::neighbor::NeighborList;
use crate::units::MU0;

/// From this many particles on, the per-particle gather runs on the rayon pool.
const PARALLEL_FROM: usize = 256;

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
    All,
    Cut {
        list: NeighborList<2>,
        radii: Vec<f64>,
        cutoff2: f64,
        every_step: bool,
    },
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
    moment_sin: Vec<f64>,
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
            Neighbors::Exact => Pairs::All,
            kind => {
                let (rc, rv) = (params.cutoff * d1, params.list_radius * d1);
                let every_step = kind == Neighbors::Cells;
                Pairs::Cut {
                    list: NeighborList::new(if every_step { 0.0 } else { rv - rc }),
                    radii: vec![0.5 * rc; n],
                    cutoff2: rc * rc,
                    every_step,
                }
            }
        };
        Self {
            pair: 3.0 * MU0 / (4.0 * PI),
            wall_law: params.wall_law,
            wall,
            gravity: params.gravity,
            dry: params.friction.dry(),
            geometry,
            pairs,
            moment_sin: particles
                .moment
                .iter()
                .zip(&particles.tilt_sin)
                .map(|(m, s)| m * s)
                .collect(),
            out: vec![ParticleForce::default(); n],
        }
    }

    /// Number of neighbour-list builds so far (0 for exact sums).
    pub fn list_builds(&self) -> usize {
        match &self.pairs {
            Pairs::All => 0,
            Pairs::Cut { list, .. } => list.builds(),
        }
    }

    /// Evaluates every particle's forces at the state into `self.out`.
    pub fn evaluate(&mut self, particles: &Particles, state: &State) {
        if let Pairs::Cut {
            list,
            radii,
            every_step,
            ..
        } = &mut self.pairs
        {
            if *every_step {
                list.build(&state.position, radii);
            } else {
                list.update(&state.position, radii);
            }
        }
        let mut out = std::mem::take(&mut self.out);
        let this = &*self;
        let one = |i: usize| this.particle(i, particles, state);
        if out.len() >= PARALLEL_FROM {
            (0..out.len())
                .into_par_iter()
                .map(one)
                .collect_into_vec(&mut out);
        } else {
            out.iter_mut().enumerate().for_each(|(i, o)| *o = one(i));
        }
        self.out = out;
    }

    /// Total force on the piston (upwards), summed in index order, N.
    pub fn piston_force(&self) -> f64 {
        self.out.iter().map(|o| o.on_piston).sum()
    }

    fn particle(&self, i: usize, particles: &Particles, state: &State) -> ParticleForce {
        let mut acc = PairSums::default();
        match &self.pairs {
            Pairs::All => (0..state.position.len())
                .for_each(|j| self.add_pair(&mut acc, i, j, particles, state, f64::INFINITY)),
            Pairs::Cut { list, cutoff2, .. } => list
                .of(i)
                .iter()
                .for_each(|&j| self.add_pair(&mut acc, i, j as usize, particles, state, *cutoff2)),
        }
        let (mu, m) = (particles.moment[i], particles.mass[i]);
        let mut out = ParticleForce {
            force: acc.force * (self.pair * mu),
            normal: if self.dry {
                self.pair * mu * particles.tilt_own[i] * acc.normal
            } else {
                0.0
            },
            closeness: acc.closeness,
            stiffness: 4.0 * self.pair * mu * acc.stiffest / m,
            ..ParticleForce::default()
        };
        out.force.y -= m * self.gravity;
        self.add_walls(&mut out, i, m, state);
        out
    }

    #[inline]
    fn add_pair(
        &self,
        acc: &mut PairSums,
        i: usize,
        j: usize,
        particles: &Particles,
        state: &State,
        cutoff2: f64,
    ) {
        if j == i {
            return;
        }
        let d = state.position[i] - state.position[j];
        let r2 = d.norm_squared();
        if r2 >= cutoff2 {
            return;
        }
        let inv_r2 = 1.0 / r2;
        let inv_r3 = inv_r2 * inv_r2.sqrt();
        let mu_r5 = particles.moment[j] * inv_r3 * inv_r2;
        acc.force += d * mu_r5;
        acc.normal += self.moment_sin[j] * inv_r3;
        acc.stiffest = acc.stiffest.max(mu_r5);
        let mean_d = 0.5 * (particles.diameter[i] + particles.diameter[j]);
        acc.closeness = acc.closeness.max(mean_d * mean_d * inv_r2);
    }

    /// Wall forces (B2 or its alternatives) of the bottom, the two sides and the piston.
    fn add_walls(&self, out: &mut ParticleForce, i: usize, m: f64, state: &State) {
        let g = &self.geometry;
        let p = state.position[i];
        let walls = [
            (p.y, Vector2::y(), p.x / g.width, g.width),
            (p.x, Vector2::x(), p.y / g.height, g.height),
            (g.width - p.x, -Vector2::x(), p.y / g.height, g.height),
            (state.piston - p.y, -Vector2::y(), p.x / g.width, g.width),
        ];
        for (k, (w, normal, f, length)) in walls.into_iter().enumerate() {
            let w = w.max(1e-9);
            let (magnitude, exponent) = self.wall_force(i, w, f.clamp(0.0, 1.0), length);
            out.force += normal * magnitude;
            let k_wall = exponent * magnitude / w;
            out.stiffness = out.stiffness.max(k_wall / m);
            if k == 3 {
                out.on_piston = magnitude;
                out.piston_stiffness = k_wall;
            }
        }
    }

    /// Magnitude of a wall's repulsion at distance w, N, and its power-law exponent.
    fn wall_force(&self, i: usize, w: f64, f: f64, length: f64) -> (f64, f64) {
        let c = self.wall[i];
        match self.wall_law {
            WallLaw::Empirical => (c / (w * w * w * w.sqrt()), 3.5),
            WallLaw::InfiniteRow => (c / (w * w * w), 3.0),
            WallLaw::FiniteBar => {
                // Each end term, written with t = fL/ℓ so that f → 0 is regular:
                // (1/√(A²+1))(3A²+2)/(3A²+3) = t(3+2t²)/(√(1+t²)(3+3t²)), A = 1/t.
                let end =
                    |t: f64| t * (3.0 + 2.0 * t * t) / ((1.0 + t * t).sqrt() * (3.0 + 3.0 * t * t));
                let bracket = end(f * length / w) + end((1.0 - f) * length / w);
                (c * bracket / (w * w * w), 4.0)
            }
        }
    }
}

/// Running sums of one particle's pair loop (without the μ_i and 3μ0/4π factors).
#[derive(Debug, Default)]
struct PairSums {
    force: Vector2<f64>,
    normal: f64,
    stiffest: f64,
    closeness: f64,
}

/// The B1 force of j on i, N (for the action = reaction test and diagnostics).
pub fn pair_force(mu_i: f64, mu_j: f64, r_i: Vector2<f64>, r_j: Vector2<f64>) -> Vector2<f64> {
    let d = r_i - r_j;
    let r2 = d.norm_squared();
    d * (3.0 * MU0 / (4.0 * PI) * mu_i * mu_j / (r2 * r2 * r2.sqrt()))
}
