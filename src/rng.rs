//! Portable, seeded random streams. Every stochastic ingredient of a run comes from
//! `run_stream(seed, purpose)`: ChaCha8 with the run seed as key and a fixed stream number per
//! purpose, so adding a new random ingredient never shifts the numbers of the others, and the
//! same (parameters, seed) gives bit-identical results on every platform and thread count.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What a random stream is used for (its stream number).
#[derive(Debug, Clone, Copy)]
#[repr(u64)]
pub enum Purpose {
    /// Particle sizes.
    Sizes = 1,
    /// Initial positions.
    Positions = 2,
    /// Initial orientations.
    Orientations = 3,
    /// Initial velocities.
    Velocities = 4,
    /// Charges (e.g. the sign mix of a charged cloud).
    Charges = 5,
    /// Additive noise on the objectives of a test function (the `analytic` model).
    Noise = 6,
}

/// The stream for one purpose of one run.
pub fn run_stream(seed: u64, purpose: Purpose) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(purpose as u64);
    rng
}
