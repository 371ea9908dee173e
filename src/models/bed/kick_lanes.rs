//! The semi-implicit dry-friction half kick (and the drift after it) of four discs per AVX
//! instruction.
//!
//! Why: the kick takes three or four square roots and two or three divisions per disc, each
//! behind a data-dependent branch (stick or slip). Four discs side by side, both branches
//! computed and the right one selected, keep the divider busy and take no branch. Every
//! lane runs the operations of [`Kick::velocity_with`] in its order, none fused, so the
//! velocities are its bits.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use nalgebra::Vector2;

use super::forces::ParticleForce;
use super::integrator::{FrictionScheme, Kick};

/// One block of discs: positions, velocities, their forces and masses (equal lengths).
pub(super) struct Discs<'a> {
    pub(super) position: &'a mut [Vector2<f64>],
    pub(super) velocity: &'a mut [Vector2<f64>],
    pub(super) force: &'a [ParticleForce],
    pub(super) mass: &'a [f64],
}

/// Half-kicks (and drifts) the leading discs of the block in fours where the processor has
/// AVX and the kick is the semi-implicit dry one; returns how many it did (a multiple of
/// four, 0 otherwise), the rest being left to [`Kick::velocity_with`].
#[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
pub(super) fn kick_fours(
    kick: &Kick,
    discs: &mut Discs,
    length: (f64, Option<(f64, f64)>),
    drift: Option<f64>,
) -> usize {
    if !kick.dry || kick.scheme != FrictionScheme::SemiImplicit {
        return 0;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx() {
        let fours = discs.mass.len() / 4 * 4;
        for k in (0..fours).step_by(4) {
            // SAFETY: the processor has AVX; k + 4 ≤ the block's length.
            unsafe { kick_four(kick, discs, k, length, drift) };
        }
        return fours;
    }
    0
}

/// Discs k..k + 4 of the block.
///
/// # Safety
/// Only where the processor has AVX, with k + 4 ≤ the block's length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn kick_four(
    kick: &Kick,
    discs: &mut Discs,
    k: usize,
    (h, viscous): (f64, Option<(f64, f64)>),
    drift: Option<f64>,
) {
    let v = &mut discs.velocity[k..k + 4];
    let o = &discs.force[k..k + 4];
    let lanes = |f: &dyn Fn(usize) -> f64| _mm256_set_pd(f(3), f(2), f(1), f(0));
    let (vx, vy) = (lanes(&|l| v[l].x), lanes(&|l| v[l].y));
    let (fx, fy) = (lanes(&|l| o[l].force.x), lanes(&|l| o[l].force.y));
    let normal = lanes(&|l| o[l].normal);
    // SAFETY: the block holds discs k..k + 4.
    let m = unsafe { _mm256_loadu_pd(discs.mass[k..k + 4].as_ptr()) };
    let vt = _mm256_set1_pd(kick.threshold_speed);
    let stick = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_LT_OQ>(norm(vx, vy), vt),
        _mm256_cmp_pd::<_CMP_LE_OQ>(
            norm(fx, fy),
            _mm256_mul_pd(_mm256_set1_pd(kick.static_friction), normal),
        ),
    );
    let (ux, uy) = match viscous {
        Some((tau, decay)) => {
            let (decay, gain) = (
                _mm256_set1_pd(decay),
                _mm256_div_pd(_mm256_set1_pd(tau * (1.0 - decay)), m),
            );
            let step = |v, f| _mm256_add_pd(_mm256_mul_pd(v, decay), _mm256_mul_pd(f, gain));
            (step(vx, fx), step(vy, fy))
        }
        None => {
            let gain = _mm256_div_pd(_mm256_set1_pd(h), m);
            let step = |v, f| _mm256_add_pd(v, _mm256_mul_pd(f, gain));
            (step(vx, fx), step(vy, fy))
        }
    };
    // s (1 + c/(s + v_t)) = |u|: s = (b + √(b² + 4|u| v_t))/2, b = |u| − v_t − c.
    let speed = norm(ux, uy);
    let c = _mm256_div_pd(
        _mm256_mul_pd(_mm256_set1_pd(h * kick.dynamic_friction), normal),
        m,
    );
    let b = _mm256_sub_pd(_mm256_sub_pd(speed, vt), c);
    let root = _mm256_sqrt_pd(_mm256_add_pd(
        _mm256_mul_pd(b, b),
        _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(4.0), speed), vt),
    ));
    let s = _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(b, root));
    let scale = _mm256_div_pd(s, speed);
    let at_rest = _mm256_cmp_pd::<_CMP_EQ_OQ>(speed, _mm256_setzero_pd());
    let slip = |u| _mm256_andnot_pd(stick, _mm256_blendv_pd(_mm256_mul_pd(u, scale), u, at_rest));
    let new = interleave(slip(ux), slip(uy));
    // SAFETY: the block holds discs k..k + 4, 2 f64 each, contiguous.
    unsafe {
        let at = v.as_mut_ptr().cast::<f64>();
        _mm256_storeu_pd(at, new[0]);
        _mm256_storeu_pd(at.add(4), new[1]);
    }
    if let Some(dt) = drift {
        let dt = _mm256_set1_pd(dt);
        // SAFETY: as for the velocities.
        unsafe {
            let at = discs.position[k..k + 4].as_mut_ptr().cast::<f64>();
            for (half, new) in new.into_iter().enumerate() {
                let x = at.add(4 * half);
                _mm256_storeu_pd(x, _mm256_add_pd(_mm256_loadu_pd(x), _mm256_mul_pd(new, dt)));
            }
        }
    }
}

/// |(x, y)| lane by lane as nalgebra's `norm` takes it: √(x² + y²).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn norm(x: __m256d, y: __m256d) -> __m256d {
    _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y)))
}

/// Lanes (x0..x3), (y0..y3) as the vectors' memory order: (x0, y0, x1, y1), (x2, y2, x3, y3).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn interleave(x: __m256d, y: __m256d) -> [__m256d; 2] {
    let (low, high) = (_mm256_unpacklo_pd(x, y), _mm256_unpackhi_pd(x, y));
    [
        _mm256_permute2f128_pd::<0x20>(low, high),
        _mm256_permute2f128_pd::<0x31>(low, high),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{run_stream, Purpose};
    use rand::RngExt;

    fn kick(viscous_time: Option<f64>) -> Kick {
        Kick {
            viscous_time,
            dry: true,
            static_friction: 0.6,
            dynamic_friction: 0.45,
            threshold_speed: 1e-4,
            scheme: FrictionScheme::SemiImplicit,
        }
    }

    /// A test block's owned data: positions, velocities, forces, masses.
    struct Owned {
        x: Vec<Vector2<f64>>,
        v: Vec<Vector2<f64>>,
        o: Vec<ParticleForce>,
        m: Vec<f64>,
    }

    /// Discs at rest, creeping below v_t, sliding, and forces below and above static
    /// friction: every branch of the kick, in every lane.
    fn block(n: usize, seed: u64) -> Owned {
        let mut rng = run_stream(seed, Purpose::Positions);
        let mut pick = |scale: f64| scale * (2.0 * rng.random::<f64>() - 1.0);
        let mut b = Owned {
            x: vec![],
            v: vec![],
            o: vec![],
            m: vec![],
        };
        for k in 0..n {
            b.x.push(Vector2::new(pick(1e-2), pick(1e-2)));
            let speed = [0.0, 5e-5, 1e-3, 0.0][k % 4];
            b.v.push(Vector2::new(pick(speed), pick(speed)));
            let normal = pick(1e-3).abs();
            let force = [0.1, 2.0, 0.5, 0.0][(k / 4 + k) % 4] * normal;
            b.o.push(ParticleForce {
                force: Vector2::new(pick(force), pick(force)),
                normal,
                ..ParticleForce::default()
            });
            b.m.push(1e-3 * (1.0 + pick(0.5)));
        }
        b
    }

    #[test]
    fn four_lanes_give_the_bits_of_the_portable_kick() {
        if !crate::numerics::has_avx() {
            return;
        }
        for (seed, viscous, drift) in [
            (1, None, None),
            (2, Some(0.02), Some(1e-4)),
            (3, Some(0.5), None),
            (4, None, Some(3e-5)),
        ] {
            let k = kick(viscous);
            let Owned { mut x, mut v, o, m } = block(23, seed);
            let (mut x0, mut v0) = (x.clone(), v.clone());
            let h = 2e-4;
            let length = (h, viscous.map(|tau| (tau, (-h / tau).exp())));
            let mut discs = Discs {
                position: &mut x,
                velocity: &mut v,
                force: &o,
                mass: &m,
            };
            let done = kick_fours(&k, &mut discs, length, drift);
            assert_eq!(done, 20);
            for i in 0..done {
                v0[i] = k.velocity(v0[i], o[i].force, o[i].normal, m[i], h);
                if let Some(dt) = drift {
                    x0[i] += v0[i] * dt;
                }
            }
            let sticks = (0..done).filter(|&i| v0[i] == Vector2::zeros()).count();
            assert!(
                sticks > 0 && sticks < done,
                "seed {seed}: {sticks} of {done} stuck"
            );
            for i in 0..done {
                assert_eq!(
                    v[i].map(f64::to_bits),
                    v0[i].map(f64::to_bits),
                    "seed {seed}, disc {i}"
                );
                assert_eq!(
                    x[i].map(f64::to_bits),
                    x0[i].map(f64::to_bits),
                    "seed {seed}, disc {i}"
                );
            }
        }
    }
}
