//! Times the neighbour-list build (cell grid and Verlet list, `magopt::neighbor`) on N spheres
//! of radius 0.9–1.1 with centres on a cubic lattice of spacing 1.75, each jittered by up to
//! 0.3 per axis (~7 partners within R_i + R_j + skin, about a settled bed's count): the build
//! the packing stages of `align` repeat every ~25 FIRE steps. With `lognormal`, the radii are
//! drawn as `align` draws them, exp(σ z − σ²/2) with σ = 0.1 (the largest of 10⁵ near 1.5,
//! which sets the grid's cells).
//! `RAYON_NUM_THREADS=1 cargo run --release --example neighbor_build -- [particles] [builds] [lognormal]`

use magopt::neighbor::NeighborList;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n = args.first().copied().unwrap_or(10_000);
    let builds = args.get(1).copied().unwrap_or(200).max(1);
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let side = (n as f64).cbrt().ceil() as usize;
    let lattice =
        (0..side).flat_map(|z| (0..side).flat_map(move |y| (0..side).map(move |x| [x, y, z])));
    let position: Vec<_> = lattice
        .take(n)
        .map(|c| {
            Vector3::from(c.map(|k| k as f64 * 1.75))
                + 0.3 * Vector3::from([(); 3].map(|_| rng.random::<f64>()))
        })
        .collect();
    let lognormal = std::env::args().any(|a| a == "lognormal");
    let radius: Vec<f64> = (0..n)
        .map(|_| {
            if lognormal {
                let z: f64 = rng.sample(rand_distr::StandardNormal);
                (0.1 * z - 0.005_f64).exp()
            } else {
                0.9 + 0.2 * rng.random::<f64>()
            }
        })
        .collect();
    let mut list = NeighborList::<3>::new(0.3);
    let started = std::time::Instant::now();
    for _ in 0..builds {
        list.build(&position, &radius);
    }
    let per_build = started.elapsed().as_secs_f64() / builds as f64;
    println!(
        "N = {n}: {:.2} list entries per particle, {:.3} ms per build, {:.0} ns per particle",
        list.len() as f64 / n as f64,
        per_build * 1e3,
        per_build * 1e9 / n as f64
    );
}
