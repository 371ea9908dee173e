//! Closed-form results of the source for one particle (Zohdi 2016 §2, §4.2, §5, App. A): the
//! force ratio λ and the field for parity (C11), the Stokes/quadratic drag ratio (C12), the
//! turning radius and its inverse (C13), and the spiral of a charge under Stokes drag and B
//! with its terminal displacement (C14). Every run reports them (study metrics), and the
//! tests hold the simulation against them.

use nalgebra::Vector3;

/// A charged sphere in a fluid with quadratic drag, as §5 of the source sees it (C11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargedSphere {
    /// Charge per mass q̄, C/kg.
    pub charge_per_mass: f64,
    /// Particle density ρ_p, kg/m³.
    pub density: f64,
    /// Radius R, m.
    pub radius: f64,
    /// Drag coefficient C_D.
    pub drag_coefficient: f64,
    /// Fluid density ρ_f, kg/m³.
    pub fluid_density: f64,
}

impl ChargedSphere {
    /// 8 |q̄| ρ_p R / (3 C_D ρ_f), the prefactor of Eq. (5.4), m/(s·T): λ is this times
    /// |E + v × B| / |v|².
    fn prefactor(&self) -> f64 {
        8.0 * self.charge_per_mass.abs() * self.density * self.radius
            / (3.0 * self.drag_coefficient * self.fluid_density)
    }

    /// λ(v) = |Ψ^{e+m}| / |Ψ^drag| (C11, Zohdi 2016 Eq. (5.4)): the Lorentz force
    /// |q̄ m (E + v × B)| over the quadratic drag ½ C_D ρ_f π R² |v|², v (m/s) relative to
    /// still fluid, E (V/m), B (T).
    pub fn force_ratio(&self, e: &Vector3<f64>, b: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
        self.prefactor() * (e + v.cross(b)).norm() / v.norm_squared()
    }

    /// The bound of λ with |E + v × B| ≤ |E| + |v||B| (C11, Eq. (5.5)) at speed `speed`
    /// (m/s), fields |E| (V/m), |B| (T): the ratio for v ⊥ B, the number the source quotes at
    /// t = 0 (its Eq. (6.3)).
    pub fn force_ratio_bound(&self, e: f64, b: f64, speed: f64) -> f64 {
        self.prefactor() * (e + speed * b) / (speed * speed)
    }

    /// |B| for parity with the drag, λ = 1 at E = 0 (C11, Eq. (5.8)):
    /// 3 C_D ρ_f |v| / (8 |q̄| ρ_p R), T.
    pub fn parity_magnetic_field(&self, speed: f64) -> f64 {
        speed / self.prefactor()
    }

    /// |E| for parity with the drag at B = 0 (C11, Eq. (5.7)):
    /// 3 C_D ρ_f |v|² / (8 |q̄| ρ_p R), V/m.
    pub fn parity_electric_field(&self, speed: f64) -> f64 {
        speed * speed / self.prefactor()
    }
}

/// |Ψ^Stokes| / |Ψ^drag| = 12 μ_f / (ρ_a C_D R |v|) (C12, Eq. (4.14)): above 1 the Stokes
/// (viscous) drag dominates, below 1 the quadratic (inertial) drag.
pub fn stokes_ratio(
    viscosity: f64,
    fluid_density: f64,
    drag_coefficient: f64,
    radius: f64,
    speed: f64,
) -> f64 {
    12.0 * viscosity / (fluid_density * drag_coefficient * radius * speed)
}

/// Turning (cyclotron) radius v⊥ / (|q̄| |B|) of a charge with speed `speed_across` (m/s)
/// across B (C13, Eq. (2.6)), m.
pub fn turning_radius(speed_across: f64, charge_per_mass: f64, field: f64) -> f64 {
    speed_across / (charge_per_mass.abs() * field)
}

/// The field that gives a wanted turning radius, B = v0 / (q̄ R) = v0 m / (q R) (C13,
/// Eq. (2.6) inverted), T.
pub fn turning_field(speed: f64, charge_per_mass: f64, radius: f64) -> f64 {
    speed / (charge_per_mass.abs() * radius)
}

/// Displacement after time t (s; `f64::INFINITY` for the terminal one) of a charge launched
/// with velocity v0 (m/s) under Stokes drag with relaxation time τ = m/c (s) and the field
/// B (T), E = 0 (C14): along B, v0∥ τ (1 − e^{−t/τ}); across B, in the complex plane of the
/// across-B velocity w (dw/dt = −(1/τ + iΩ) w, Ω = q̄|B|),
/// w0 τ (1 − e^{−(1 + iΩτ) t/τ}) / (1 + iΩτ), whose terminal length is |w0| τ/√(1 + (Ωτ)²).
pub fn stokes_spiral_displacement(
    v0: &Vector3<f64>,
    charge_per_mass: f64,
    b: &Vector3<f64>,
    tau: f64,
    t: f64,
) -> Vector3<f64> {
    let relax = -(-t / tau).exp_m1(); // 1 − e^{−t/τ}, exact to round-off for small t
    let Some(axis) = b.try_normalize(0.0) else {
        return v0 * tau * relax;
    };
    let along = v0.dot(&axis) * axis;
    let across = v0 - along;
    // orthonormal frame (b̂, e1, e2 = b̂ × e1) with e1 along the launch velocity across B:
    // w × b̂ = −i w in it, so the Lorentz term is −iΩ w with Ω = q̄ |B|
    let w0 = across.norm();
    let e1 = across
        .try_normalize(0.0)
        .unwrap_or_else(|| any_normal(&axis));
    let e2 = axis.cross(&e1);
    let omega_tau = charge_per_mass * b.norm() * tau;
    // (1 − e^{−(1+iΩτ)s}) / (1 + iΩτ), s = t/τ, as real and imaginary parts
    let decay = (-t / tau).exp();
    let phase = if t.is_finite() {
        omega_tau * t / tau
    } else {
        0.0
    };
    let (num_re, num_im) = (1.0 - decay * phase.cos(), decay * phase.sin());
    let den = 1.0 + omega_tau * omega_tau;
    let re = (num_re + num_im * omega_tau) / den;
    let im = (num_im - num_re * omega_tau) / den;
    along * tau * relax + w0 * tau * (re * e1 + im * e2)
}

/// A unit vector normal to `axis`.
fn any_normal(axis: &Vector3<f64>) -> Vector3<f64> {
    let helper = if axis.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    axis.cross(&helper).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spiral_terminal_length_and_direction() {
        let (tau, qm, b) = (0.5, 4.0, Vector3::new(0.0, 0.0, 1.5)); // Ωτ = 3
        let v0 = Vector3::new(2.0, 0.0, 1.0);
        let d = stokes_spiral_displacement(&v0, qm, &b, tau, f64::INFINITY);
        assert!((d.z - 1.0 * tau).abs() < 1e-15);
        let across = (d.x * d.x + d.y * d.y).sqrt();
        assert!((across - 2.0 * tau / 10f64.sqrt()).abs() < 1e-15);
        // a positive charge with B along +z turns clockwise (towards −y), as Eq. (2.8)
        assert!(d.y < 0.0);
        let late = stokes_spiral_displacement(&v0, qm, &b, tau, 40.0 * tau);
        assert!((late - d).norm() < 1e-15);
        assert_eq!(
            stokes_spiral_displacement(&v0, qm, &b, tau, 0.0),
            Vector3::zeros()
        );
    }

    #[test]
    fn parity_field_makes_the_bound_one() {
        let sphere = ChargedSphere {
            charge_per_mass: 10.0,
            density: 7000.0,
            radius: 0.05,
            drag_coefficient: 1.0,
            fluid_density: 1.225,
        };
        let v = 1.65;
        let b = sphere.parity_magnetic_field(v);
        assert!((sphere.force_ratio_bound(0.0, b, v) - 1.0).abs() < 1e-14);
        let e = sphere.parity_electric_field(v);
        assert!((sphere.force_ratio_bound(e, 0.0, v) - 1.0).abs() < 1e-14);
        // v ⊥ B attains the bound
        let exact = sphere.force_ratio(&Vector3::zeros(), &(b * Vector3::z()), &(v * Vector3::x()));
        assert!((exact - 1.0).abs() < 1e-14);
    }
}
