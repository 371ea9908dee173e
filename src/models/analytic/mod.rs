//! Standard test functions with known answers, for validating designs, sensitivity analysis
//! and optimizers on problems whose solution is exact (see docs/analytic.md).
//!
//! Every function reads the inputs x1…x6 it needs (the rest are ignored) and must be given
//! inputs inside its domain ([`Function::check`]):
//!
//! - `ishigami` (Ishigami & Homma 1990): f = sin x1 + a sin² x2 + b x3⁴ sin x1 with a = 7,
//!   b = 0.1, on x ∈ [−π, π]³. Its variance and Sobol' indices are known in closed form
//!   ([`ishigami_sobol`]).
//! - `branin` (Branin–Hoo, as in Dixon & Szegő 1978): f = a (x2 − b x1² + c x1 − r)² +
//!   s (1 − t) cos x1 + s with a = 1, b = 5.1/(4π²), c = 5/π, r = 6, s = 10, t = 1/(8π), on
//!   x1 ∈ [−5, 10], x2 ∈ [0, 15]. Global minimum s·t = 5/(4π) ≈ 0.397887 at (−π, 12.275),
//!   (π, 2.275) and (3π, 2.475).
//! - `hartmann6` (Dixon & Szegő 1978): f = −Σᵢ αᵢ exp(−Σⱼ Aᵢⱼ (xⱼ − Pᵢⱼ)²) on [0, 1]⁶ with the
//!   standard α, A, P ([`HARTMANN6_ALPHA`], [`HARTMANN6_A`], [`HARTMANN6_P`]). Global minimum
//!   ≈ −3.32237 at [`HARTMANN6_ARGMIN`].
//! - `zdt1` (Zitzler, Deb & Thiele 2000) with n = 6 inputs on [0, 1]⁶: f1 = x1,
//!   g = 1 + 9/(n − 1) Σ_{i≥2} xᵢ, f2 = g (1 − √(f1/g)). Pareto front: g = 1, f2 = 1 − √f1 for
//!   f1 ∈ [0, 1]; its hypervolume is [`zdt1_front_hypervolume`].

pub mod study;

use rand::RngExt;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

use crate::rng::{run_stream, Purpose};

/// Number of inputs the model declares (x1…x6).
pub const INPUTS: usize = 6;

/// Ishigami constant a.
pub const ISHIGAMI_A: f64 = 7.0;
/// Ishigami constant b.
pub const ISHIGAMI_B: f64 = 0.1;

/// Branin constant a.
pub const BRANIN_A: f64 = 1.0;
/// Branin constant b = 5.1/(4π²).
pub const BRANIN_B: f64 = 5.1 / (4.0 * PI * PI);
/// Branin constant c = 5/π.
pub const BRANIN_C: f64 = 5.0 / PI;
/// Branin constant r.
pub const BRANIN_R: f64 = 6.0;
/// Branin constant s.
pub const BRANIN_S: f64 = 10.0;
/// Branin constant t = 1/(8π).
pub const BRANIN_T: f64 = 1.0 / (8.0 * PI);
/// Branin global minimum s·t = 5/(4π) ≈ 0.397887.
pub const BRANIN_MIN: f64 = BRANIN_S * BRANIN_T;
/// The three global minimizers of Branin: x1 ∈ {−π, π, 3π}, x2 = b x1² − c x1 + r.
pub const BRANIN_ARGMIN: [[f64; 2]; 3] = [
    [-PI, BRANIN_B * PI * PI + BRANIN_C * PI + BRANIN_R],
    [PI, BRANIN_B * PI * PI - BRANIN_C * PI + BRANIN_R],
    [
        3.0 * PI,
        BRANIN_B * 9.0 * PI * PI - BRANIN_C * 3.0 * PI + BRANIN_R,
    ],
];

/// Hartmann-6 weights α.
pub const HARTMANN6_ALPHA: [f64; 4] = [1.0, 1.2, 3.0, 3.2];
/// Hartmann-6 matrix A (rows i, columns j).
pub const HARTMANN6_A: [[f64; 6]; 4] = [
    [10.0, 3.0, 17.0, 3.5, 1.7, 8.0],
    [0.05, 10.0, 17.0, 0.1, 8.0, 14.0],
    [3.0, 3.5, 1.7, 10.0, 17.0, 8.0],
    [17.0, 8.0, 0.05, 10.0, 0.1, 14.0],
];
/// Hartmann-6 matrix P (rows i, columns j), 10⁻⁴ × the published integers.
pub const HARTMANN6_P: [[f64; 6]; 4] = [
    [0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886],
    [0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991],
    [0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650],
    [0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381],
];
/// Hartmann-6 global minimum as published (−3.32237, to the digits given).
pub const HARTMANN6_MIN: f64 = -3.32237;
/// Hartmann-6 global minimizer as published (to the digits given).
pub const HARTMANN6_ARGMIN: [f64; 6] = [0.20169, 0.150011, 0.476874, 0.275332, 0.311652, 0.6573];

/// Number of ZDT1 inputs n.
pub const ZDT1_INPUTS: usize = 6;

/// A test function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Function {
    /// Ishigami & Homma (1990), 3 inputs on [−π, π]³, a = 7, b = 0.1.
    Ishigami,
    /// Branin (Dixon & Szegő 1978), x1 ∈ [−5, 10], x2 ∈ [0, 15].
    Branin,
    /// Hartmann-6 (Dixon & Szegő 1978), 6 inputs on [0, 1]⁶.
    Hartmann6,
    /// ZDT1 (Zitzler, Deb & Thiele 2000), two objectives, 6 inputs on [0, 1]⁶.
    Zdt1,
}

/// The objectives of one evaluation: `value` (the scalar function; for ZDT1, f1) and, for a
/// two-objective function, (f1, f2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Objectives {
    /// The scalar function (f1 for ZDT1).
    pub value: f64,
    /// Both objectives of a two-objective function.
    pub pair: Option<(f64, f64)>,
}

impl Function {
    /// Every function, in the order of the `function` choice.
    pub const ALL: [Function; 4] = [
        Function::Ishigami,
        Function::Branin,
        Function::Hartmann6,
        Function::Zdt1,
    ];

    /// Its name in study files.
    pub fn name(self) -> &'static str {
        match self {
            Function::Ishigami => "ishigami",
            Function::Branin => "branin",
            Function::Hartmann6 => "hartmann6",
            Function::Zdt1 => "zdt1",
        }
    }

    /// How many of x1…x6 it reads.
    pub fn dimension(self) -> usize {
        match self {
            Function::Ishigami => 3,
            Function::Branin => 2,
            Function::Hartmann6 => 6,
            Function::Zdt1 => ZDT1_INPUTS,
        }
    }

    /// The closed interval input `i` (0-based) must lie in, and how it is written.
    pub fn domain(self, i: usize) -> (f64, f64, &'static str) {
        match (self, i) {
            (Function::Ishigami, _) => (-PI, PI, "[-π, π]"),
            (Function::Branin, 0) => (-5.0, 10.0, "[-5, 10]"),
            (Function::Branin, _) => (0.0, 15.0, "[0, 15]"),
            (Function::Hartmann6 | Function::Zdt1, _) => (0.0, 1.0, "[0, 1]"),
        }
    }

    /// Checks that every input it reads lies in its domain; the message names the input, its
    /// value and the domain.
    pub fn check(self, x: &[f64; INPUTS]) -> Result<(), String> {
        for (i, &xi) in x.iter().enumerate().take(self.dimension()) {
            let (low, high, shown) = self.domain(i);
            if !(low..=high).contains(&xi) {
                return Err(format!(
                    "x{}: {xi} is outside the domain of {} (need x{} in {shown})",
                    i + 1,
                    self.name(),
                    i + 1
                ));
            }
        }
        Ok(())
    }

    /// Evaluates the function at `x` (inputs beyond its dimension are ignored).
    pub fn evaluate(self, x: &[f64; INPUTS]) -> Objectives {
        match self {
            Function::Ishigami => scalar(ishigami(x[0], x[1], x[2])),
            Function::Branin => scalar(branin(x[0], x[1])),
            Function::Hartmann6 => scalar(hartmann6(x)),
            Function::Zdt1 => {
                let (f1, f2) = zdt1(x);
                Objectives {
                    value: f1,
                    pair: Some((f1, f2)),
                }
            }
        }
    }
}

fn scalar(value: f64) -> Objectives {
    Objectives { value, pair: None }
}

/// Ishigami: sin x1 + a sin² x2 + b x3⁴ sin x1 (a = 7, b = 0.1).
pub fn ishigami(x1: f64, x2: f64, x3: f64) -> f64 {
    x1.sin() + ISHIGAMI_A * x2.sin().powi(2) + ISHIGAMI_B * x3.powi(4) * x1.sin()
}

/// Branin: a (x2 − b x1² + c x1 − r)² + s (1 − t) cos x1 + s.
pub fn branin(x1: f64, x2: f64) -> f64 {
    BRANIN_A * (x2 - BRANIN_B * x1 * x1 + BRANIN_C * x1 - BRANIN_R).powi(2)
        + BRANIN_S * (1.0 - BRANIN_T) * x1.cos()
        + BRANIN_S
}

/// Hartmann-6: −Σᵢ αᵢ exp(−Σⱼ Aᵢⱼ (xⱼ − Pᵢⱼ)²).
pub fn hartmann6(x: &[f64; INPUTS]) -> f64 {
    -(0..4)
        .map(|i| {
            let inner: f64 = (0..6)
                .map(|j| HARTMANN6_A[i][j] * (x[j] - HARTMANN6_P[i][j]).powi(2))
                .sum();
            HARTMANN6_ALPHA[i] * (-inner).exp()
        })
        .sum::<f64>()
}

/// ZDT1 with n = 6: (f1, f2) = (x1, g (1 − √(x1/g))), g = 1 + 9/(n − 1) Σ_{i≥2} xᵢ.
pub fn zdt1(x: &[f64; INPUTS]) -> (f64, f64) {
    let n = ZDT1_INPUTS;
    let f1 = x[0];
    let g = 1.0 + 9.0 / (n - 1) as f64 * x[1..n].iter().sum::<f64>();
    (f1, g * (1.0 - (f1 / g).sqrt()))
}

/// The ZDT1 Pareto front: f2 = 1 − √f1 for f1 ∈ [0, 1] (reached where x2…x6 = 0).
pub fn zdt1_front(f1: f64) -> f64 {
    1.0 - f1.sqrt()
}

/// Hypervolume (area) dominated by the true ZDT1 front and bounded by the reference point
/// (r1, r2), both ≥ 1 (so that the whole front dominates it), by integration:
/// ∫₀¹ (r2 − f2(f1)) df1 + (r1 − 1) r2. The integral is taken after the substitution
/// f1 = u² (which removes the √ singularity of the slope at 0) with composite Simpson, exact
/// for the resulting polynomial. For (1.1, 1.1): 0.1 + 2/3 + 0.11 = 0.876667.
pub fn zdt1_front_hypervolume(r1: f64, r2: f64) -> f64 {
    assert!(r1 >= 1.0 && r2 >= 1.0, "reference point must be ≥ (1, 1)");
    // ∫₀¹ (r2 − 1 + √f1) df1 = ∫₀¹ (r2 − 1 + u) 2u du
    let integrand = |u: f64| (r2 - zdt1_front(u * u)) * 2.0 * u;
    simpson(integrand, 0.0, 1.0, 1000) + (r1 - 1.0) * r2
}

/// Composite Simpson rule with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n)
        .map(|k| {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            w * f(a + k as f64 * h)
        })
        .sum();
    (f(a) + f(b) + inner) * h / 3.0
}

/// The variance decomposition of the Ishigami function for inputs uniform on [−π, π]³
/// (Sobol' & Levitan 1999): total variance, first-order indices S and total indices ST.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IshigamiIndices {
    /// Mean E[f] = a/2.
    pub mean: f64,
    /// Variance V = a²/8 + bπ⁴/5 + b²π⁸/18 + 1/2.
    pub variance: f64,
    /// First-order indices S1, S2, S3.
    pub first: [f64; 3],
    /// Total indices ST1, ST2, ST3.
    pub total: [f64; 3],
}

/// The Ishigami variance and Sobol' indices for constants (a, b), from the closed forms:
/// V1 = ½ (1 + bπ⁴/5)², V2 = a²/8, V3 = 0, V13 = b²π⁸ (1/18 − 1/50) = 8b²π⁸/225, all other
/// partial variances 0; S_i = V_i / V, ST1 = (V1 + V13)/V, ST2 = V2/V, ST3 = V13/V.
/// For a = 7, b = 0.1: S = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437).
pub fn ishigami_indices(a: f64, b: f64) -> IshigamiIndices {
    let pi4 = PI.powi(4);
    let pi8 = PI.powi(8);
    let v1 = 0.5 * (1.0 + b * pi4 / 5.0).powi(2);
    let v2 = a * a / 8.0;
    let v13 = b * b * pi8 * (1.0 / 18.0 - 1.0 / 50.0);
    let variance = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi8 / 18.0 + 0.5;
    IshigamiIndices {
        mean: a / 2.0,
        variance,
        first: [v1 / variance, v2 / variance, 0.0],
        total: [(v1 + v13) / variance, v2 / variance, v13 / variance],
    }
}

/// [`ishigami_indices`] for the model's constants a = 7, b = 0.1.
pub fn ishigami_sobol() -> IshigamiIndices {
    ishigami_indices(ISHIGAMI_A, ISHIGAMI_B)
}

/// The parameters of one `analytic` run.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyticParams {
    /// The test function.
    pub function: Function,
    /// Input x1.
    pub x1: f64,
    /// Input x2.
    pub x2: f64,
    /// Input x3.
    pub x3: f64,
    /// Input x4.
    pub x4: f64,
    /// Input x5.
    pub x5: f64,
    /// Input x6.
    pub x6: f64,
    /// Standard deviation of the Gaussian noise added to every objective (0: exact).
    pub noise: f64,
}

impl Default for AnalyticParams {
    /// Ishigami at x = (0.5, …, 0.5), inside every function's domain, without noise.
    fn default() -> Self {
        Self {
            function: Function::Ishigami,
            x1: 0.5,
            x2: 0.5,
            x3: 0.5,
            x4: 0.5,
            x5: 0.5,
            x6: 0.5,
            noise: 0.0,
        }
    }
}

impl AnalyticParams {
    /// The inputs x1…x6.
    pub fn inputs(&self) -> [f64; INPUTS] {
        [self.x1, self.x2, self.x3, self.x4, self.x5, self.x6]
    }

    /// Checks the inputs the function reads against its domain (one line naming the input,
    /// its value and the domain).
    pub fn validate(&self) -> Result<(), String> {
        self.function.check(&self.inputs())
    }

    /// The objectives of run `seed`: the function plus, when `noise` > 0, independent
    /// Gaussian noise of that standard deviation on each objective, drawn from the run's
    /// [`Purpose::Noise`] stream (so replicates differ and (parameters, seed) fix the
    /// result). For ZDT1 `value` is the noisy f1.
    pub fn evaluate(&self, seed: u64) -> Objectives {
        let exact = self.function.evaluate(&self.inputs());
        if self.noise == 0.0 {
            return exact;
        }
        let mut rng = run_stream(seed, Purpose::Noise);
        let mut noisy = |x: f64| {
            let z: f64 = rng.sample(StandardNormal);
            x + self.noise * z
        };
        match exact.pair {
            Some((f1, f2)) => {
                let f1 = noisy(f1);
                let f2 = noisy(f2);
                Objectives {
                    value: f1,
                    pair: Some((f1, f2)),
                }
            }
            None => scalar(noisy(exact.value)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn at(values: &[f64]) -> [f64; INPUTS] {
        let mut x = [0.5; INPUTS];
        x[..values.len()].copy_from_slice(values);
        x
    }

    #[test]
    fn ishigami_at_known_points() {
        assert_eq!(ishigami(0.0, 0.0, 0.0), 0.0);
        // sin(π/2) + 7 sin²(π/2) + 0.1·1⁴·1 = 8.1
        assert!((ishigami(PI / 2.0, PI / 2.0, 1.0) - 8.1).abs() < 1e-12);
        // x3 = 2: 1 + 0 + 0.1·16 = 2.6
        assert!((ishigami(PI / 2.0, 0.0, 2.0) - 2.6).abs() < 1e-12);
        assert!((ishigami(-PI / 2.0, PI / 2.0, 2.0) - (-1.0 + 7.0 - 1.6)).abs() < 1e-12);
    }

    #[test]
    fn branin_at_known_points_and_minimizers() {
        // (0, 0): (−6)² + 10(1 − t) + 10
        let expected = 36.0 + 10.0 * (1.0 - BRANIN_T) + 10.0;
        assert!((branin(0.0, 0.0) - expected).abs() < 1e-12);
        assert!((branin(0.0, 0.0) - 55.602113).abs() < 1e-6);
        assert!((BRANIN_MIN - 0.397887).abs() < 1e-6);
        assert!((BRANIN_MIN - 5.0 / (4.0 * PI)).abs() < 1e-15);
        let published = [[-PI, 12.275], [PI, 2.275], [9.42478, 2.475]];
        for (argmin, published) in BRANIN_ARGMIN.iter().zip(&published) {
            assert!((argmin[0] - published[0]).abs() < 1e-5, "{argmin:?}");
            assert!((argmin[1] - published[1]).abs() < 1e-12, "{argmin:?}");
            assert!((branin(argmin[0], argmin[1]) - BRANIN_MIN).abs() < 1e-12);
            assert!((branin(published[0], published[1]) - 0.397887).abs() < 1e-6);
            assert!(Function::Branin.check(&at(argmin)).is_ok());
        }
        // no point of a fine grid over the domain is lower
        let mut lowest = f64::INFINITY;
        for i in 0..=600 {
            for j in 0..=600 {
                let x1 = -5.0 + 15.0 * i as f64 / 600.0;
                let x2 = 15.0 * j as f64 / 600.0;
                lowest = lowest.min(branin(x1, x2));
            }
        }
        assert!(
            (BRANIN_MIN..BRANIN_MIN + 0.01).contains(&lowest),
            "{lowest}"
        );
    }

    #[test]
    fn hartmann6_minimum_at_its_known_point() {
        let x = HARTMANN6_ARGMIN;
        let f = hartmann6(&x);
        assert!((f - HARTMANN6_MIN).abs() < 1e-5, "{f}");
        // at the published point to more digits, and at the centre (both computed
        // independently, in double precision, from the published α, A, P)
        assert!((f - -3.322368011391339).abs() < 1e-12, "{f}");
        assert!((hartmann6(&[0.5; 6]) - -0.5053149917022333).abs() < 1e-12);
        // a local minimum: nothing nearby is lower (beyond the published digits)
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..2000 {
            let mut y = x;
            for v in &mut y {
                *v += 0.02 * (rng.random::<f64>() - 0.5);
            }
            assert!(hartmann6(&y) > f - 1e-6, "{y:?}");
        }
        // and nothing on a random sample of the domain is
        for _ in 0..100_000 {
            let y: [f64; 6] = std::array::from_fn(|_| rng.random::<f64>());
            assert!(hartmann6(&y) > HARTMANN6_MIN - 1e-5);
        }
    }

    #[test]
    fn zdt1_objectives_and_front() {
        // on the front: x2…x6 = 0
        for f1 in [0.0, 0.25, 0.5, 1.0] {
            let (a, b) = zdt1(&[f1, 0.0, 0.0, 0.0, 0.0, 0.0]);
            assert_eq!(a, f1);
            assert!((b - zdt1_front(f1)).abs() < 1e-15);
        }
        // off the front: g = 1 + 9/5 · 5 · 0.5 = 5.5
        let (f1, f2) = zdt1(&[0.25, 0.5, 0.5, 0.5, 0.5, 0.5]);
        assert_eq!(f1, 0.25);
        assert!((f2 - 5.5 * (1.0 - (0.25f64 / 5.5).sqrt())).abs() < 1e-12);
        assert!(f2 > zdt1_front(f1));
        let o = Function::Zdt1.evaluate(&at(&[0.25, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert_eq!(o.value, 0.25);
        assert_eq!(o.pair, Some((0.25, 0.5)));
    }

    #[test]
    fn zdt1_hypervolume_by_integration_matches_the_closed_form() {
        let exact = 0.1 + 2.0 / 3.0 + 0.1 * 1.1;
        let hv = zdt1_front_hypervolume(1.1, 1.1);
        assert!((hv - exact).abs() < 1e-12, "{hv}");
        assert!((hv - 0.876667).abs() < 1e-6);
        // a fine staircase of front points converges to it from below
        let n = 100_000;
        let stair: f64 = (0..n)
            .map(|k| {
                let f1 = k as f64 / n as f64;
                (1.1 - zdt1_front(f1)) / n as f64
            })
            .sum::<f64>()
            + 0.1 * 1.1;
        assert!(stair < hv && hv - stair < 1e-4, "{stair}");
    }

    #[test]
    fn ishigami_indices_from_the_formulas() {
        let s = ishigami_sobol();
        let expect = |x: f64, y: f64| assert!((x - y).abs() < 5e-5, "{x} vs {y}");
        expect(s.first[0], 0.3139);
        expect(s.first[1], 0.4424);
        expect(s.first[2], 0.0);
        expect(s.total[0], 0.5576);
        expect(s.total[1], 0.4424);
        expect(s.total[2], 0.2437);
        assert!((s.variance - 13.8446).abs() < 1e-4, "{}", s.variance);
        // the partial variances add up: V1 + V2 + V13 = V
        let parts = s.first[0] + s.first[1] + s.total[2];
        assert!((parts - 1.0).abs() < 1e-12);
    }

    /// Pick-freeze Monte Carlo (Janon et al. 2014 for S_i, Jansen 1999 for ST_i) with 2e5
    /// samples agrees with the formulas within 0.01.
    #[test]
    fn ishigami_indices_agree_with_pick_freeze_monte_carlo() {
        let n = 200_000;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut draw =
            || -> [f64; 3] { std::array::from_fn(|_| PI * (2.0 * rng.random::<f64>() - 1.0)) };
        let f = |x: &[f64; 3]| ishigami(x[0], x[1], x[2]);
        let (mut sum, mut sum2) = (0.0, 0.0);
        // per input i: Σ y y', Σ (y + y'), Σ (y² + y'²) of the pick-freeze pair, and
        // Σ (y − y_i)² of the total-effect pair
        let mut sums = [[0.0; 4]; 3];
        for _ in 0..n {
            let a = draw();
            let b = draw();
            let ya = f(&a);
            sum += ya;
            sum2 += ya * ya;
            for (i, s) in sums.iter_mut().enumerate() {
                // c: x_i from a, the rest from b (pick-freeze on x_i)
                let c: [f64; 3] = std::array::from_fn(|j| if j == i { a[j] } else { b[j] });
                let yc = f(&c);
                s[0] += ya * yc;
                s[1] += ya + yc;
                s[2] += ya * ya + yc * yc;
                // d: a with x_i from b (for the total index)
                let d: [f64; 3] = std::array::from_fn(|j| if j == i { b[j] } else { a[j] });
                s[3] += (ya - f(&d)).powi(2);
            }
        }
        let nf = n as f64;
        let mean = sum / nf;
        let variance = sum2 / nf - mean * mean;
        let exact = ishigami_sobol();
        assert!((mean - exact.mean).abs() < 0.05, "{mean}");
        assert!((variance / exact.variance - 1.0).abs() < 0.02, "{variance}");
        for (i, [yy, ysum, ysq, dd]) in sums.into_iter().enumerate() {
            let m = ysum / (2.0 * nf);
            let s = (yy / nf - m * m) / (ysq / (2.0 * nf) - m * m);
            let st = dd / (2.0 * nf) / variance;
            let (s_exact, st_exact) = (exact.first[i], exact.total[i]);
            assert!((s - s_exact).abs() < 0.01, "S{}: {s} vs {s_exact}", i + 1);
            assert!(
                (st - st_exact).abs() < 0.01,
                "ST{}: {st} vs {st_exact}",
                i + 1
            );
        }
    }

    #[test]
    fn noise_is_fixed_by_the_seed() {
        let exact = AnalyticParams {
            function: Function::Branin,
            x1: PI,
            x2: 2.275,
            ..AnalyticParams::default()
        };
        assert_eq!(exact.evaluate(1).value, branin(PI, 2.275));
        assert_eq!(exact.evaluate(1), exact.evaluate(2), "noise 0 is exact");
        let noisy = AnalyticParams {
            noise: 0.5,
            ..exact.clone()
        };
        assert_eq!(
            noisy.evaluate(7),
            noisy.evaluate(7),
            "same seed, same value"
        );
        assert_ne!(noisy.evaluate(7).value, noisy.evaluate(8).value);
        // the noise has the stated standard deviation
        let n = 20_000;
        let draws: Vec<f64> = (0..n)
            .map(|seed| noisy.evaluate(seed).value - exact.evaluate(seed).value)
            .collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let sd = (draws.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(mean.abs() < 0.02 && (sd - 0.5).abs() < 0.02, "{mean} {sd}");
        // ZDT1: value is the noisy f1, f2 has its own draw
        let zdt = AnalyticParams {
            function: Function::Zdt1,
            noise: 0.1,
            ..AnalyticParams::default()
        };
        let o = zdt.evaluate(3);
        let (f1, f2) = o.pair.unwrap();
        assert_eq!(o.value, f1);
        let (e1, e2) = zdt1(&zdt.inputs());
        assert!(f1 != e1 && f2 != e2 && (f1 - e1) != (f2 - e2));
    }

    #[test]
    fn domains_are_checked_by_name_value_and_range() {
        assert!(Function::Ishigami.check(&at(&[PI, -PI, 0.0])).is_ok());
        assert_eq!(
            Function::Ishigami.check(&at(&[0.0, 0.0, 4.0])).unwrap_err(),
            "x3: 4 is outside the domain of ishigami (need x3 in [-π, π])"
        );
        assert_eq!(
            Function::Branin.check(&at(&[12.0, 1.0])).unwrap_err(),
            "x1: 12 is outside the domain of branin (need x1 in [-5, 10])"
        );
        assert_eq!(
            Function::Branin.check(&at(&[1.0, -0.5])).unwrap_err(),
            "x2: -0.5 is outside the domain of branin (need x2 in [0, 15])"
        );
        // inputs a function does not read are not checked
        assert!(Function::Branin.check(&at(&[10.0, 15.0, 99.0])).is_ok());
        assert!(Function::Hartmann6
            .check(&at(&[0.0, 0.0, 0.0, 0.0, 0.0, 1.5]))
            .unwrap_err()
            .starts_with("x6: 1.5 is outside the domain of hartmann6"));
        // the default point (0.5 everywhere) is inside every domain
        for f in Function::ALL {
            assert!(f.check(&[0.5; INPUTS]).is_ok(), "{}", f.name());
        }
    }
}
