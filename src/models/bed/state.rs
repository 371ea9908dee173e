//! The state of a bed: per-particle constants (species, mass, moment, tilt geometry), the cell
//! geometry with its packing-fraction heights, positions and velocities, and the initial
//! perturbed grid (protocol step 1).

use nalgebra::Vector2;
use rand::RngExt;
use rand_distr::StandardNormal;

use super::params::{BedParams, Heights, TiltOrder};
use crate::rng::{run_stream, Purpose};

/// Per-particle constants, SI.
#[derive(Debug, Clone)]
pub struct Particles {
    /// Species index (0 = reference/big).
    pub species: Vec<usize>,
    /// Diameter D_i, m.
    pub diameter: Vec<f64>,
    /// Mass m_i, kg.
    pub mass: Vec<f64>,
    /// Dipole moment μ_i, A·m².
    pub moment: Vec<f64>,
    /// sin θ_i of the tilt (B4): the factor particle i contributes to its neighbours' N.
    pub tilt_sin: Vec<f64>,
    /// Own factor of N_i (B4): (cos θ_i [+ 1/3 second order]) / (cos(φ_i+θ_i) √(D_i²+ε²)), 1/m.
    pub tilt_own: Vec<f64>,
}

impl Particles {
    /// Constants of n particles with the given species assignment.
    pub fn new(params: &BedParams, species: Vec<usize>) -> Self {
        let list = params.species_list();
        let diameter: Vec<f64> = species.iter().map(|&s| list[s].diameter).collect();
        let (eps, gap) = (params.thickness, params.gap);
        let second = if params.tilt_order == TiltOrder::Second {
            1.0 / 3.0
        } else {
            0.0
        };
        let tilt = |d: f64| {
            let hyp = (d * d + eps * eps).sqrt();
            let phi = (eps / d).atan();
            let theta = (gap / hyp).min(1.0).asin() - phi;
            (
                theta.sin(),
                (theta.cos() + second) / ((phi + theta).cos() * hyp),
            )
        };
        Self {
            mass: diameter.iter().map(|&d| params.mass(d)).collect(),
            moment: diameter.iter().map(|&d| params.moment(d)).collect(),
            tilt_sin: diameter.iter().map(|&d| tilt(d).0).collect(),
            tilt_own: diameter.iter().map(|&d| tilt(d).1).collect(),
            diameter,
            species,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.diameter.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.diameter.is_empty()
    }

    /// Total disc area Σ π D_i²/4, m².
    pub fn disc_area(&self) -> f64 {
        self.diameter
            .iter()
            .map(|d| std::f64::consts::PI * d * d / 4.0)
            .sum()
    }
}

/// Species of particle k (protocol step 1). Two species follow the spec's interleaving rule
/// with R the fraction of the second (small) one: R < ½ every ⌊1/R⌋-th particle is small,
/// R > ½ every ⌊1/(1−R)⌋-th is big, R = ½ alternates. More species: each particle goes to the
/// species furthest below its share so far (a deterministic generalization).
pub fn assign_species(n: usize, fractions: &[f64]) -> Vec<usize> {
    match fractions {
        [_] => vec![0; n],
        [_, r] => {
            let r = *r;
            (0..n)
                .map(|k| {
                    if r <= 0.0 {
                        0
                    } else if r >= 1.0 {
                        1
                    } else if r < 0.5 {
                        usize::from((k + 1) % (1.0 / r).floor() as usize == 0)
                    } else if r > 0.5 {
                        usize::from((k + 1) % (1.0 / (1.0 - r)).floor() as usize != 0)
                    } else {
                        k % 2
                    }
                })
                .collect()
        }
        _ => {
            let mut counts = vec![0usize; fractions.len()];
            (0..n)
                .map(|k| {
                    let deficit = |s: usize| (k + 1) as f64 * fractions[s] - counts[s] as f64;
                    let s = (0..fractions.len())
                        .max_by(|&a, &b| deficit(a).total_cmp(&deficit(b)).then(b.cmp(&a)))
                        .expect("species");
                    counts[s] += 1;
                    s
                })
                .collect()
        }
    }
}

/// The cell and the piston heights of the protocol, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Width W.
    pub width: f64,
    /// Height H (initial piston height).
    pub height: f64,
    /// H0: piston height at the start of compression (H, or at φ_start).
    pub start_height: f64,
    /// H_f: piston height at maximum compression (φ_max); for a bi-disperse bed this is
    /// [1 + R(p − 1)] H_r with R the realized small fraction.
    pub final_height: f64,
}

impl Geometry {
    /// The geometry of a parameter set (species assignment is deterministic).
    pub fn of(params: &BedParams) -> Self {
        let (width, height) = params.cell();
        let particles = Particles::new(params, species_of(params));
        let area = particles.disc_area();
        Self {
            width,
            height,
            start_height: match params.heights {
                Heights::Source => height,
                Heights::PackingFractions => area / (params.start_packing_fraction * width),
            },
            final_height: area / (params.max_packing_fraction() * width),
        }
    }

    /// Packing fraction φ = Σ π D_i²/4 / (W × piston height).
    pub fn packing_fraction(&self, disc_area: f64, piston: f64) -> f64 {
        disc_area / (self.width * piston)
    }
}

/// The species assignment of a parameter set.
pub fn species_of(params: &BedParams) -> Vec<usize> {
    let fractions: Vec<f64> = params.species_list().iter().map(|s| s.fraction).collect();
    assign_species(params.particle_count(), &fractions)
}

/// Grid columns and rows for n particles in a w × h cell (about square cells).
fn grid_shape(n: usize, w: f64, h: f64) -> (usize, usize) {
    let nx = ((n as f64 * w / h).sqrt().ceil() as usize).clamp(1, n.max(1));
    (nx, n.div_ceil(nx).max(1))
}

/// Grid spacing of the initial grid, m (the smaller of the two directions).
pub fn grid_spacing(n: usize, w: f64, h: f64) -> f64 {
    let (nx, ny) = grid_shape(n, w, h);
    (w / (nx as f64 + 1.2)).min(h / (ny as f64 + 1.2))
}

/// Positions, velocities and the piston.
#[derive(Debug, Clone)]
pub struct State {
    /// Centres r_i = (x_i, y_i), m (bottom-left corner of the cell at the origin).
    pub position: Vec<Vector2<f64>>,
    /// Velocities, m/s.
    pub velocity: Vec<Vector2<f64>>,
    /// Piston height (its lower face), m.
    pub piston: f64,
    /// Time, s.
    pub time: f64,
}

impl State {
    /// Protocol step 1: a perturbed grid filled row by row from the bottom, outer rows at
    /// least one grid spacing from every wall (perturbation ±0.1 spacing, from
    /// `Purpose::Positions`), Gaussian velocity components of standard deviation
    /// `initial_speed` (from `Purpose::Velocities`); the piston at the top of the cell.
    pub fn initial(params: &BedParams, geometry: &Geometry, seed: u64) -> Self {
        let n = params.particle_count();
        let (w, h) = (geometry.width, geometry.height);
        let (nx, ny) = grid_shape(n, w, h);
        let (sx, sy) = (w / (nx as f64 + 1.2), h / (ny as f64 + 1.2));
        let mut rng = run_stream(seed, Purpose::Positions);
        let position = (0..n)
            .map(|k| {
                let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                let dx = 0.1 * sx * (2.0 * rng.random::<f64>() - 1.0);
                let dy = 0.1 * sy * (2.0 * rng.random::<f64>() - 1.0);
                Vector2::new((i + 1.1) * sx + dx, (j + 1.1) * sy + dy)
            })
            .collect();
        let mut rng = run_stream(seed, Purpose::Velocities);
        let velocity = (0..n)
            .map(|_| {
                let vx: f64 = rng.sample(StandardNormal);
                let vy: f64 = rng.sample(StandardNormal);
                Vector2::new(vx, vy) * params.initial_speed
            })
            .collect();
        Self {
            position,
            velocity,
            piston: h,
            time: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interleaving_follows_the_spec_rule() {
        assert_eq!(assign_species(6, &[0.75, 0.25]), vec![0, 0, 0, 1, 0, 0]);
        assert_eq!(assign_species(4, &[0.5, 0.5]), vec![0, 1, 0, 1]);
        assert_eq!(assign_species(6, &[0.25, 0.75]), vec![1, 1, 1, 0, 1, 1]);
        assert_eq!(assign_species(3, &[1.0, 0.0]), vec![0, 0, 0]);
        assert_eq!(assign_species(3, &[0.0, 1.0]), vec![1, 1, 1]);
        let three = assign_species(60, &[0.5, 0.3, 0.2]);
        let count = |s| three.iter().filter(|&&x| x == s).count();
        assert_eq!((count(0), count(1), count(2)), (30, 18, 12));
    }

    #[test]
    fn outer_rows_keep_one_grid_spacing_from_the_walls() {
        let params = BedParams::defaults();
        let g = Geometry::of(&params);
        let s = State::initial(&params, &g, 5);
        let spacing = grid_spacing(params.particle_count(), g.width, g.height);
        for p in &s.position {
            let wall = p.x.min(g.width - p.x).min(p.y).min(g.height - p.y);
            assert!(wall >= spacing * (1.0 - 1e-12), "{p:?}");
        }
    }
}
