//! Explicit schemes of the non-interacting model. Particles are independent, so each is
//! advanced on its own (in parallel, bit-identical at any thread count).
//!
//! - Boris–Strang (default): v ← D(h/2) v; r += h/2 v; v ← Boris(v; E, B, h); r += h/2 v;
//!   v ← D(h/2) v, with D the exact drag decay. Second order (symmetric splitting), |v|
//!   exactly conserved under B alone, stable for any drag strength. The two half decays of
//!   consecutive steps are merged into one D(h) (exact for the exact decay within a branch).
//! - Forward Euler (the source's update): v ← v + h/m Ψ(t), r ← r + h v(t). Under B alone
//!   |v|² grows by (1 + (ωh)²) every step.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::cloud::Cloud;
use super::field::{lorentz_acceleration, Boris, Drag};
use super::params::BlastParams;

/// Particles per rayon task.
const CHUNK: usize = 64;

/// Which explicit scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Explicit {
    /// Boris rotation with exact drag, Strang split.
    Boris,
    /// The source's forward Euler.
    Euler,
}

/// Advances every particle by `steps` steps of size `h`.
pub fn advance(cloud: &mut Cloud, params: &BlastParams, scheme: Explicit, h: f64, steps: usize) {
    let drag = Drag::new(params);
    let (e, b) = (params.electric_field(), params.field());
    cloud
        .positions
        .par_iter_mut()
        .zip(cloud.velocities.par_iter_mut())
        .zip(cloud.charge_per_mass.par_iter())
        .with_min_len(CHUNK)
        .for_each(|((r, v), &qm)| match scheme {
            Explicit::Boris => boris_strang(r, v, &Boris::new(qm, &e, &b, h), &drag, h, steps),
            Explicit::Euler => {
                for _ in 0..steps {
                    let a = lorentz_acceleration(qm, &e, &b, v) + drag.acceleration(v);
                    *r += h * *v;
                    *v += h * a;
                }
            }
        });
}

/// `steps` Boris–Strang steps of one particle.
fn boris_strang(
    r: &mut Vector3<f64>,
    v: &mut Vector3<f64>,
    push: &Boris,
    drag: &Drag,
    h: f64,
    steps: usize,
) {
    *v = drag.decay(v, 0.5 * h);
    for k in 0..steps {
        *r += 0.5 * h * *v;
        *v = push.apply(v);
        *r += 0.5 * h * *v;
        *v = drag.decay(v, if k + 1 == steps { 0.5 * h } else { h });
    }
}
