//! Single-particle forces: the Lorentz force (C2) and the drag laws (C3), with the exact
//! per-step drag decay and the Boris rotation used by the orbit-preserving explicit scheme.

use nalgebra::Vector3;
use std::f64::consts::PI;

use super::params::{BlastParams, DragLaw};

/// Chow's piecewise drag coefficient C_D(Re) (C3). Continuous at Re = 1, nearly so at 400
/// (0.501 → 0.5) and 2e6 (0.181 → 0.18); it drops at Re = 3e5 (0.5 → 0.080, the drag crisis).
pub fn chow_drag_coefficient(reynolds: f64) -> f64 {
    let (a, b) = chow_branch(reynolds);
    a * reynolds.powf(-b)
}

/// Chow's branches: upper Reynolds bound, a and b of C_D = a Re^{−b}.
const CHOW: [(f64, f64, f64); 5] = [
    (1.0, 24.0, 1.0),
    (400.0, 24.0, 0.646),
    (3e5, 0.5, 0.0),
    (2e6, 0.000366, -0.4275),
    (f64::INFINITY, 0.18, 0.0),
];

/// Index of the Chow branch containing `reynolds`.
fn chow_index(reynolds: f64) -> usize {
    CHOW.iter()
        .position(|&(upper, ..)| reynolds <= upper)
        .unwrap_or(CHOW.len() - 1)
}

/// (a, b) of the branch C_D = a Re^{−b} containing `reynolds`.
fn chow_branch(reynolds: f64) -> (f64, f64) {
    let (_, a, b) = CHOW[chow_index(reynolds)];
    (a, b)
}

/// The drag of one particle as a local power law: deceleration |dv/dt| = κ |v|^n along −v.
/// Quadratic: κ = K = 3 C_D ρ_a/(8 ρ R), n = 2; Stokes: κ = c/m with c = 6π μ_f R, n = 1;
/// Chow: κ and n of the branch C_D = a Re^{−b} holding the current Re.
#[derive(Debug, Clone, Copy)]
pub struct Drag {
    law: DragLaw,
    /// ½ ρ_a A / m, 1/m (so that |a| = this · C_D · |v|²).
    quadratic_factor: f64,
    /// C_D of the quadratic law.
    coefficient: f64,
    /// Stokes constant over mass c/m, 1/s.
    stokes_rate: f64,
    /// Re per unit speed, 2 R ρ_a / μ_f, s/m.
    reynolds_per_speed: f64,
    /// (κ, n) of each Chow branch, precomputed (no powf per step).
    chow: [(f64, f64); 5],
}

impl Drag {
    /// The drag of the particles of `params`.
    pub fn new(params: &BlastParams) -> Self {
        let mass = params.particle_mass();
        let area = PI * params.radius * params.radius;
        let quadratic_factor = 0.5 * params.air_density * area / mass;
        let reynolds_per_speed = 2.0 * params.radius * params.air_density / params.air_viscosity;
        Self {
            law: params.drag,
            quadratic_factor,
            coefficient: params.drag_coefficient,
            stokes_rate: 6.0 * PI * params.air_viscosity * params.radius / mass,
            reynolds_per_speed,
            chow: CHOW
                .map(|(_, a, b)| (quadratic_factor * a * reynolds_per_speed.powf(-b), 2.0 - b)),
        }
    }

    /// (κ, n) of the law at speed `speed` (m/s).
    pub fn power_law(&self, speed: f64) -> (f64, f64) {
        match self.law {
            DragLaw::None => (0.0, 2.0),
            DragLaw::Quadratic => (self.quadratic_factor * self.coefficient, 2.0),
            DragLaw::Stokes => (self.stokes_rate, 1.0),
            DragLaw::Chow => self.chow[chow_index(speed * self.reynolds_per_speed)],
        }
    }

    /// The drag coefficient of the quadratic form ½ C_D ρ_a A |v|² that gives this law's
    /// drag at speed `speed` (m/s): C_D itself for quadratic and Chow, 24/Re for Stokes; NaN
    /// without air.
    pub fn effective_coefficient(&self, speed: f64) -> f64 {
        let (kappa, n) = self.power_law(speed);
        kappa * speed.powf(n - 2.0) / self.quadratic_factor
    }

    /// Drag acceleration at velocity `v` relative to still air, m/s².
    pub fn acceleration(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let speed = v.norm();
        if speed == 0.0 {
            return Vector3::zeros();
        }
        let (kappa, n) = self.power_law(speed);
        let factor = match n {
            2.0 => speed,
            1.0 => 1.0,
            _ => speed.powf(n - 1.0),
        };
        -kappa * factor * v
    }

    /// Exact drag-only update over `h` seconds: the direction is kept and the speed solves
    /// ds/dt = −κ s^n of the branch at the start (for Chow, a branch change inside the step is
    /// seen from the next step on). Unconditionally stable: the speed never changes sign.
    pub fn decay(&self, v: &Vector3<f64>, h: f64) -> Vector3<f64> {
        if self.law == DragLaw::None {
            return *v;
        }
        let speed = v.norm();
        if speed == 0.0 {
            return *v;
        }
        let (kappa, n) = self.power_law(speed);
        v * (decayed_speed(speed, kappa, n, h) / speed)
    }
}

/// Solution of ds/dt = −κ s^n (n ≥ 1) after time h from s0.
pub fn decayed_speed(s0: f64, kappa: f64, n: f64, h: f64) -> f64 {
    if n == 2.0 {
        s0 / (1.0 + kappa * s0 * h)
    } else if n == 1.0 {
        s0 * (-kappa * h).exp()
    } else {
        (s0.powf(1.0 - n) + (n - 1.0) * kappa * h).powf(1.0 / (1.0 - n))
    }
}

/// Lorentz acceleration (q/m)(E + v × B) (C2), m/s².
pub fn lorentz_acceleration(
    charge_per_mass: f64,
    e: &Vector3<f64>,
    b: &Vector3<f64>,
    v: &Vector3<f64>,
) -> Vector3<f64> {
    charge_per_mass * (e + v.cross(b))
}

/// The Boris update of v over a step h for one charge per mass: half electric kick,
/// rotation by 2 atan(ω h/2) about B, half electric kick. With E = 0 it conserves |v| to
/// round-off. The constant vectors are computed once per particle and step size.
#[derive(Debug, Clone, Copy)]
pub struct Boris {
    half_kick: Vector3<f64>,
    t: Vector3<f64>,
    s: Vector3<f64>,
}

impl Boris {
    /// The update for charge per mass `qm` (C/kg), fields E (V/m), B (T) and step h (s).
    pub fn new(qm: f64, e: &Vector3<f64>, b: &Vector3<f64>, h: f64) -> Self {
        let t = b * (0.5 * h * qm);
        Self {
            half_kick: e * (0.5 * h * qm),
            t,
            s: t * (2.0 / (1.0 + t.norm_squared())),
        }
    }

    /// v after one step.
    pub fn apply(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let minus = v + self.half_kick;
        let prime = minus + minus.cross(&self.t);
        minus + prime.cross(&self.s) + self.half_kick
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_law_decay_solves_its_ode() {
        for n in [1.0, 1.354, 2.0, 2.4275] {
            let (s0, kappa, h): (f64, f64, f64) = (3.0, 0.7, 0.2);
            // fine forward-Euler reference
            let mut s = s0;
            let steps = 200_000;
            for _ in 0..steps {
                s -= kappa * s.powf(n) * h / steps as f64;
            }
            assert!((decayed_speed(s0, kappa, n, h) - s).abs() < 1e-5, "n = {n}");
        }
    }

    #[test]
    fn effective_coefficient_is_cd_for_quadratic_laws_and_24_over_re_for_stokes() {
        let mut p = BlastParams::source_example();
        let speed = 1.65;
        let re = 2.0 * p.radius * p.air_density * speed / p.air_viscosity;
        let cd = |p: &BlastParams| Drag::new(p).effective_coefficient(speed);
        assert!((cd(&p) - chow_drag_coefficient(re)).abs() < 1e-12);
        p.drag = DragLaw::Quadratic;
        assert!((cd(&p) - p.drag_coefficient).abs() < 1e-12);
        p.drag = DragLaw::Stokes;
        assert!((cd(&p) / (24.0 / re) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn boris_conserves_speed_without_electric_field() {
        let b = Vector3::new(1.0, 2.0, -3.0);
        let mut v = Vector3::new(0.3, -1.0, 2.0);
        let speed = v.norm();
        let push = Boris::new(7.0, &Vector3::zeros(), &b, 0.05);
        for _ in 0..10_000 {
            v = push.apply(&v);
        }
        assert!((v.norm() - speed).abs() < 1e-12 * speed * 100.0);
    }
}
