//! Particle frames of an alignment run (SI, see [`crate::output::particles`]): centres, radii,
//! velocities and masses, plus the columns the source's picture of a bed coloured by alignment
//! needs (docs/align.md, "Particle frames"):
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `easy_axis` | 1 | unit easy axis n (the sign is arbitrary: the axis is non-polar) |
//! | `moment` | A m² | M_s V times the Stoner–Wohlfarth direction (A2): at ψ from n toward H |
//! | `cos_theta` | 1 | \|n · ẑ\|, the particle's alignment (A = its mean) |
//! | `angular_velocity` | rad/s | ω of the latest velocity solve |
//! | `contacts` | 1 | touching partners, die walls included |
//!
//! The cell is the die, [0, L_x] × [0, L_y] × [0, top], its top the lid where there is one, else
//! the highest particle surface.

use nalgebra::{UnitQuaternion, Vector3};

use super::contacts::{ContactSet, Container};
use super::packing::bed_top;
use super::state::State;
use crate::models::align::params::AlignParams;
use crate::models::align::stoner_wohlfarth::equilibrium;
use crate::output::particles::{Cell, ParticleFrame, Property};

/// The run's state at `time` (s) as a particle frame of the particles with `radius` in
/// `container`; every particle is type 1.
pub fn frame(
    params: &AlignParams,
    (radius, container): (&[f64], &Container),
    state: &State,
    contacts: &ContactSet,
    time: f64,
) -> ParticleFrame {
    let scales = params.scales();
    let (length, speed) = (scales.length, scales.length / scales.time);
    let n = radius.len();
    let die = cell((radius, container), state, length);
    let mut frame = ParticleFrame::new(time, die, vec![1; n]);
    frame.position = state.position.iter().map(|p| p * length).collect();
    frame.radius = radius.iter().map(|r| r * length).collect();
    frame.velocity = state.motion.iter().map(|m| m.v * speed).collect();
    let volume: Vec<f64> = frame
        .radius
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .collect();
    frame.mass = volume.iter().map(|v| v * params.material.density).collect();
    let h = params.reduced_field();
    let ms = params.material.saturation_magnetization;
    let axes: Vec<Vector3<f64>> = state.orientation.iter().map(easy_axis).collect();
    let moment = axes
        .iter()
        .zip(&volume)
        .map(|(a, v)| ms * v * moment_direction(a, h))
        .collect();
    let cos_theta = axes.iter().map(|a| a.z.abs()).collect();
    let omega = state.motion.iter().map(|m| m.w / scales.time).collect();
    let touching = (0..n)
        .map(|i| contacts.of(i).filter(|c| c.overlap > 0.0).count() as f64)
        .collect();
    frame
        .with(Property::vector("easy_axis", "1", axes))
        .with(Property::vector("moment", "A_m2", moment))
        .with(Property::scalar("cos_theta", "1", cos_theta))
        .with(Property::vector("angular_velocity", "rad_per_s", omega))
        .with(Property::scalar("contacts", "1", touching))
}

/// The easy axis n = q·ẑ.
fn easy_axis(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    q * Vector3::z()
}

/// Unit moment direction of a particle with easy axis `axis` in the reduced field `h` along
/// +z: on the axis's half toward the field (n' = ±n, n'·ẑ ≥ 0), turned by ψ of (A2) toward ẑ.
fn moment_direction(axis: &Vector3<f64>, h: f64) -> Vector3<f64> {
    let n = if axis.z < 0.0 { -axis } else { *axis };
    let sin_theta = n.x.hypot(n.y);
    if sin_theta == 0.0 {
        return n;
    }
    let toward_field = (Vector3::z() - n.z * n) / sin_theta;
    let psi = equilibrium(sin_theta, n.z, h).psi;
    psi.cos() * n + psi.sin() * toward_field
}

/// The die, up to its lid or to the highest particle surface, m.
fn cell((radius, c): (&[f64], &Container), state: &State, length: f64) -> Cell {
    let top = state
        .lid
        .map(|l| l.height)
        .or(c.top)
        .unwrap_or_else(|| bed_top(&state.position, radius));
    Cell::aligned(Vector3::zeros(), Vector3::new(c.lx, c.ly, top) * length)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moment_lies_between_axis_and_field() {
        let axis = Vector3::new(0.6, 0.0, -0.8);
        for h in [0.0, 0.3, 2.0, 1e6] {
            let m = moment_direction(&axis, h);
            assert!((m.norm() - 1.0).abs() < 1e-12);
            // On the field's side of the folded axis (−0.6, 0, 0.8), in the x–z plane.
            assert!(m.y.abs() < 1e-15 && m.z >= 0.8 - 1e-12, "h = {h}: {m:?}");
        }
        // No field: along the folded axis; huge field: along the field.
        assert!((moment_direction(&axis, 0.0) - Vector3::new(-0.6, 0.0, 0.8)).norm() < 1e-12);
        let m = moment_direction(&axis, 1e9);
        assert!((m - Vector3::z()).norm() < 1e-6, "{m:?}");
    }
}
