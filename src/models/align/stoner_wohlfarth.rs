//! Quasi-static Stoner–Wohlfarth moment of one uniaxial particle (spec align.md, A1–A3).
//!
//! Given the angle θ ∈ [0, π/2] between the field and the (non-polar) easy axis and the reduced
//! field h = H/H_K, the moment sits at the angle ψ ∈ [0, θ] from the easy axis that solves
//!
//! ```text
//! h sin(θ − ψ) = ½ sin 2ψ                                                  (A2)
//! ```
//!
//! and the anisotropy torque on the particle is |T| = K V sin 2ψ (A3), turning the axis toward H.
//!
//! Numerics: a safeguarded Newton iteration (Newton inside a sign-changing bracket, bisection
//! whenever Newton would leave it). For θ ≤ 45° the unknown is ψ itself; for θ > 45° it is the
//! complement η = 90° − ψ, with ε = 90° − θ passed in directly. Then (A2) reads
//! h sin(η − ε) = ½ sin 2η, and the small torques near θ = 90° (where sin 2ψ = sin 2η → 0 for
//! h > 1) keep their full relative precision. The root in the bracket is unique (the stable
//! branch between easy axis and field); the global-minimum choice assumes that particles with
//! h below their switching field have switched (relevant only for h ≲ 1).

/// The equilibrium of (A2) for one particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equilibrium {
    /// ψ, angle between moment and easy axis, rad.
    pub psi: f64,
    /// sin 2ψ: the torque in units of K V (A3); ≥ 0, turning the axis toward the field.
    pub torque_factor: f64,
}

/// Solves (A2) for an axis at angle θ from the field, given by `(sin θ, cos θ)` (both ≥ 0, not
/// necessarily normalized) so that callers holding vectors never round-trip through an angle,
/// and the reduced field `h` ≥ 0.
pub fn equilibrium(sin_theta: f64, cos_theta: f64, h: f64) -> Equilibrium {
    let theta = sin_theta.atan2(cos_theta);
    if theta <= std::f64::consts::FRAC_PI_4 {
        let psi = solve_small_angle(theta, h);
        Equilibrium {
            psi,
            torque_factor: (2.0 * psi).sin(),
        }
    } else {
        let eps = cos_theta.atan2(sin_theta);
        let eta = solve_near_perpendicular(eps, h);
        Equilibrium {
            psi: std::f64::consts::FRAC_PI_2 - eta,
            torque_factor: (2.0 * eta).sin(),
        }
    }
}

/// The metastable equilibrium of a moment whose easy direction d points *away* from the field:
/// the angle between −d and H is α ∈ [0, 90°], given by `(sin α, cos α)` (both ≥ 0), so d makes
/// the angle φ = 180° − α with H. With ψ the moment's angle from d toward H, (A2) reads
/// f(ψ) = h sin(α + ψ) − ½ sin 2ψ = 0, and the energy e(ψ) has a local minimum where f falls
/// through zero. f(0) = h sin α ≥ 0; f'(0) = h cos α − 1 and f'(90°) = 1 − h sin α. For h < 1
/// f first falls, then rises to f(90°) = h cos α ≥ 0: the branch survives while f dips below
/// zero, i.e. f(ψ*) < 0 at the turning point ψ* (f'(ψ*) = 0); the field at which it stops is the
/// switching field h_sw(α) of the Stoner–Wohlfarth astroid (tested against
/// (cos^⅔ α + sin^⅔ α)^−3/2). Returns None once the branch is gone (the moment has switched
/// to the global-minimum branch near −d). The torque, K V sin 2ψ, turns d toward H.
pub fn metastable_equilibrium(sin_alpha: f64, cos_alpha: f64, h: f64) -> Option<Equilibrium> {
    let alpha = sin_alpha.atan2(cos_alpha);
    let f = |psi: f64| h * (alpha + psi).sin() - 0.5 * (2.0 * psi).sin();
    let slope = |psi: f64| h * (alpha + psi).cos() - (2.0 * psi).cos();
    use std::f64::consts::FRAC_PI_2;
    if slope(0.0) >= 0.0 || slope(FRAC_PI_2) <= 0.0 {
        return None; // f rises from the start or falls to the end: no minimum below 90°
    }
    let turning = crate::numerics::roots::bisect(slope, 0.0, FRAC_PI_2, 1e-15);
    if f(turning) >= 0.0 {
        return None;
    }
    let psi = if f(0.0) == 0.0 {
        0.0
    } else {
        let g = |psi: f64| (-f(psi), -slope(psi));
        safeguarded_newton(g, 0.0, turning, 0.5 * turning)
    };
    Some(Equilibrium {
        psi,
        torque_factor: (2.0 * psi).sin(),
    })
}

/// The switching field h_sw(α) = (cos^⅔ α + sin^⅔ α)^−3/2 of the Stoner–Wohlfarth astroid: the
/// reduced field along a direction at α from the easy axis at which the moment's metastable
/// branch (pointing away from the field) ceases to exist (½ at 45°, 1 at 0° and 90°).
pub fn switching_field(alpha: f64) -> f64 {
    (alpha.cos().abs().powf(2.0 / 3.0) + alpha.sin().abs().powf(2.0 / 3.0)).powf(-1.5)
}

/// Residual of (A2) scaled by max(1, h), the size of its largest term: the solver's accuracy
/// measure (used by tests).
pub fn scaled_residual(theta: f64, psi: f64, h: f64) -> f64 {
    (h * (theta - psi).sin() - 0.5 * (2.0 * psi).sin()).abs() / h.max(1.0)
}

/// θ ≤ 45°: f(ψ) = h sin(θ − ψ) − ½ sin 2ψ decreases strictly on [0, θ] (f' < 0 there since
/// cos 2ψ ≥ 0), f(0) ≥ 0 ≥ f(θ). Start from the Newton step taken at ψ = 0.
fn solve_small_angle(theta: f64, h: f64) -> f64 {
    if theta == 0.0 || h == 0.0 {
        return 0.0;
    }
    let guess = (h * theta.sin() / (h * theta.cos() + 1.0)).min(theta);
    let f = |psi: f64| {
        let value = h * (theta - psi).sin() - 0.5 * (2.0 * psi).sin();
        let slope = -h * (theta - psi).cos() - (2.0 * psi).cos();
        (-value, -slope)
    };
    safeguarded_newton(f, 0.0, theta, guess)
}

/// θ > 45°, unknown η = 90° − ψ ∈ [ε, 90°]: g(η) = h sin(η − ε) − ½ sin 2η, g(ε) ≤ 0 ≤ g(90°).
fn solve_near_perpendicular(eps: f64, h: f64) -> f64 {
    use std::f64::consts::FRAC_PI_2;
    if h == 0.0 {
        return FRAC_PI_2;
    }
    if eps == 0.0 {
        // Exactly perpendicular: g(η) = sin η (h − cos η). η = 0 is the energy maximum for
        // h < 1; the stable root is cos η = h (sin ψ = h). For h ≥ 1 the moment lies along H.
        return if h < 1.0 { h.acos() } else { 0.0 };
    }
    let guess = if h > 1.0 {
        eps + 0.5 * (2.0 * eps).sin() / (h - (2.0 * eps).cos())
    } else {
        h.acos()
    }
    .clamp(eps, FRAC_PI_2);
    let g = |eta: f64| {
        let value = h * (eta - eps).sin() - 0.5 * (2.0 * eta).sin();
        let slope = h * (eta - eps).cos() - (2.0 * eta).cos();
        (value, slope)
    };
    safeguarded_newton(g, eps, FRAC_PI_2, guess)
}

/// Root of an increasing-through-zero function on [lo, hi] (value(lo) ≤ 0 ≤ value(hi)), given
/// `f(x) = (value, slope)`. Newton steps are taken while they stay inside the shrinking bracket,
/// bisection otherwise; converges to a few ulps.
fn safeguarded_newton(f: impl Fn(f64) -> (f64, f64), mut lo: f64, mut hi: f64, guess: f64) -> f64 {
    let mut x = guess.clamp(lo, hi);
    for _ in 0..200 {
        let (value, slope) = f(x);
        if value == 0.0 {
            return x;
        }
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let newton = x - value / slope;
        let next = if newton > lo && newton < hi && newton.is_finite() {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let step = (next - x).abs();
        x = next;
        if step <= 2.0 * f64::EPSILON * x.abs() || hi - lo <= 2.0 * f64::EPSILON * hi.abs() {
            return x;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

    fn solve(theta: f64, h: f64) -> Equilibrium {
        equilibrium(theta.sin(), theta.cos(), h)
    }

    fn dense_angles() -> Vec<f64> {
        let mut angles: Vec<f64> = (0..=180).map(|k| k as f64 * FRAC_PI_2 / 180.0).collect();
        for e in 1..=15 {
            let tiny = 10f64.powi(-e);
            angles.push(tiny);
            angles.push(FRAC_PI_2 - tiny);
        }
        angles
    }

    fn dense_fields() -> Vec<f64> {
        let mut fields = vec![0.0, 1.0, 0.5, 2.0];
        for k in -80..=80 {
            fields.push(10f64.powf(k as f64 / 10.0));
        }
        fields
    }

    #[test]
    fn residual_below_1e_12_on_dense_grid() {
        let mut worst: f64 = 0.0;
        for &theta in &dense_angles() {
            for &h in &dense_fields() {
                let eq = solve(theta, h);
                assert!(
                    eq.psi >= 0.0 && eq.psi <= theta + 1e-15,
                    "ψ={} θ={theta}",
                    eq.psi
                );
                worst = worst.max(scaled_residual(theta, eq.psi, h));
            }
        }
        assert!(worst < 1e-12, "worst scaled residual {worst}");
    }

    #[test]
    fn root_is_the_unique_equilibrium_in_the_bracket() {
        // Count sign changes of (A2) on a fine ψ grid: exactly one root in (0, θ) or at an end.
        for &theta in &[0.3, 0.7, 1.0, 1.3, 1.5, 1.56] {
            for &h in &[0.05, 0.3, 0.9, 1.1, 3.0, 30.0] {
                let f = |psi: f64| h * (theta - psi).sin() - 0.5 * (2.0 * psi).sin();
                let n = 20_000;
                let changes = (0..n)
                    .filter(|&k| {
                        let a = f(theta * k as f64 / n as f64);
                        let b = f(theta * (k + 1) as f64 / n as f64);
                        a > 0.0 && b <= 0.0 || a < 0.0 && b >= 0.0
                    })
                    .count();
                assert_eq!(changes, 1, "θ={theta} h={h}");
            }
        }
    }

    #[test]
    fn perpendicular_axis_below_anisotropy_field_has_sin_psi_equal_h() {
        for &h in &[1e-9, 1e-3, 0.1, 0.5, 0.9, 0.999] {
            let eq = equilibrium(1.0, 0.0, h);
            assert!((eq.psi.sin() - h).abs() < 1e-14, "h={h}");
            // and just off perpendicular the solution is continuous
            let near = solve(FRAC_PI_2 - 1e-12, h);
            assert!((near.psi - eq.psi).abs() < 1e-9, "h={h}");
        }
    }

    #[test]
    fn strong_field_pulls_moment_onto_the_field() {
        for &theta in &[1e-6, 0.2, FRAC_PI_4, 1.2, FRAC_PI_2 - 1e-6] {
            let eq = solve(theta, 1e9);
            assert!((theta - eq.psi).abs() < 1e-9 * theta.max(1e-3), "θ={theta}");
        }
    }

    #[test]
    fn torque_maximum_above_45_degrees_is_at_h_star() {
        // For θ > 45° the torque sin 2ψ(h) peaks at h* = 1/(2 sin(θ − 45°)).
        for &deg in &[50.0f64, 60.0, 70.0, 80.0, 89.0] {
            let theta = deg.to_radians();
            let h_star = 1.0 / (2.0 * (theta - FRAC_PI_4).sin());
            let torque = |ln_h: f64| solve(theta, ln_h.exp()).torque_factor;
            // golden-section maximum in ln h
            let (mut a, mut b) = ((h_star / 4.0).ln(), (h_star * 4.0).ln());
            let r = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..200 {
                let c = b - r * (b - a);
                let d = a + r * (b - a);
                if torque(c) > torque(d) {
                    b = d;
                } else {
                    a = c;
                }
            }
            let h_max = (0.5 * (a + b)).exp();
            assert!(
                (h_max / h_star - 1.0).abs() < 1e-5,
                "θ={deg}° h_max={h_max} h*={h_star}"
            );
            // at the peak the torque factor is 1 (ψ = 45°)
            assert!((torque(h_star.ln()) - 1.0).abs() < 1e-12);
        }
    }

    /// The metastable branch ends on the astroid: bisecting the field at which
    /// `metastable_equilibrium` stops returning a solution reproduces h_sw(α), with
    /// h_sw(45°) = ½ and h_sw(0°) = h_sw(90°) = 1.
    #[test]
    fn metastable_branch_ends_at_the_astroid_switching_field() {
        let exists = |alpha: f64, h: f64| metastable_equilibrium(alpha.sin(), alpha.cos(), h);
        let numeric_switching = |alpha: f64| {
            let (mut lo, mut hi) = (0.0, 1.5);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if exists(alpha, mid).is_some() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        assert!((numeric_switching(FRAC_PI_4) - 0.5).abs() < 1e-6);
        assert!((numeric_switching(0.0) - 1.0).abs() < 1e-6);
        assert!((numeric_switching(FRAC_PI_2) - 1.0).abs() < 1e-6);
        for deg in 1..90 {
            let alpha = (deg as f64).to_radians();
            let h_sw = switching_field(alpha);
            assert!(
                (numeric_switching(alpha) / h_sw - 1.0).abs() < 1e-6,
                "α={deg}°: {} vs astroid {h_sw}",
                numeric_switching(alpha)
            );
        }
        assert!((switching_field(FRAC_PI_4) - 0.5).abs() < 1e-15);
    }

    /// Below the switching field the metastable moment solves (A2) in the frame of d (angle
    /// φ = 180° − α to the field) and is a minimum of the energy; at α = 90° it meets the
    /// global-minimum branch (sin ψ = h).
    #[test]
    fn metastable_moment_is_a_stable_equilibrium() {
        for deg in [0.0f64, 10.0, 30.0, 45.0, 60.0, 80.0, 89.0] {
            let alpha = deg.to_radians();
            for frac in [0.1, 0.5, 0.9, 0.99] {
                let h = frac * switching_field(alpha);
                let eq = metastable_equilibrium(alpha.sin(), alpha.cos(), h).unwrap();
                let phi = std::f64::consts::PI - alpha;
                assert!(scaled_residual(phi, eq.psi, h) < 1e-12, "α={deg} h={h}");
                let curvature = h * (phi - eq.psi).cos() + (2.0 * eq.psi).cos();
                assert!(curvature > 0.0, "α={deg} h={h}: not a minimum");
            }
        }
        for h in [0.2, 0.7] {
            let eq = metastable_equilibrium(1.0, 0.0, h).unwrap();
            assert!((eq.psi.sin() - h).abs() < 1e-12);
        }
    }

    #[test]
    fn small_angles_keep_relative_precision() {
        // Linearized (A2): h(θ − ψ) = ψ ⇒ ψ = θ h/(1 + h), torque ≈ 2ψ.
        for &h in &[0.1, 1.0, 10.0] {
            let theta = 1e-10;
            let eq = solve(theta, h);
            let expected = theta * h / (1.0 + h);
            assert!((eq.psi / expected - 1.0).abs() < 1e-12);
            assert!((eq.torque_factor / (2.0 * expected) - 1.0).abs() < 1e-12);
        }
        // Near θ = 90° with h > 1: η = ε h/(h − 1) to first order, torque ≈ 2η.
        let eps = 1e-10;
        let eq = equilibrium(1.0, eps, 3.0);
        let expected = 2.0 * eps * 3.0 / 2.0;
        assert!((eq.torque_factor / expected - 1.0).abs() < 1e-9);
    }
}
