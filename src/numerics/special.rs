//! Special functions.

/// ln Γ(x) for x > 0 by the Lanczos approximation (g = 7, 9 terms; relative error ≲ 1e-15 on
/// the values tested); NaN for x ≤ 0 or NaN.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx), with both factors positive here.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + G + 0.5;
    let series = C[1..]
        .iter()
        .enumerate()
        .fold(C[0], |acc, (k, c)| acc + c / (x + (k + 1) as f64));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + series.ln()
}

/// The standard normal CDF Φ(x), with relative accuracy ≲ 1e-14 in both tails (to
/// x ≈ −37, where it underflows).
///
/// Φ(x) = erfc(−x/√2)/2, with erf from its positive-term series (Abramowitz & Stegun 7.1.6)
/// for |x| ≤ 3 and erfc from its continued fraction (A&S 7.1.14, evaluated backwards) beyond.
pub fn normal_cdf(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    let z = x.abs() * std::f64::consts::FRAC_1_SQRT_2;
    // Upper-tail mass Q = Φ(−|x|) = erfc(z)/2.
    let tail = if x.abs() <= 3.0 {
        0.5 * (1.0 - erf_series(z))
    } else {
        0.5 * erfc_fraction(z)
    };
    if x < 0.0 {
        tail
    } else {
        1.0 - tail
    }
}

/// erf(z) = 2/√π · e^(−z²) · Σ 2ⁿ z^(2n+1) / (1·3·…·(2n+1)), all terms positive (z ≥ 0).
fn erf_series(z: f64) -> f64 {
    let z2 = z * z;
    let (mut term, mut sum) = (z, z);
    let mut n = 0.0;
    while term > sum * 1e-17 {
        n += 1.0;
        term *= 2.0 * z2 / (2.0 * n + 1.0);
        sum += term;
    }
    2.0 / std::f64::consts::PI.sqrt() * (-z2).exp() * sum
}

/// erfc(z) = e^(−z²)/√π · 1/(z + (1/2)/(z + 1/(z + (3/2)/(z + …)))) for z > 2.
fn erfc_fraction(z: f64) -> f64 {
    let mut t = z;
    for k in (1..=60).rev() {
        t = z + f64::from(k) / 2.0 / t;
    }
    (-z * z).exp() / (std::f64::consts::PI.sqrt() * t)
}

/// The standard normal quantile Φ⁻¹(p) by Wichura's algorithm AS 241 (PPND16, Appl. Statist.
/// 37 (1988) 477–484; relative accuracy about 1e-16): −∞ at 0, +∞ at 1, NaN outside [0, 1].
// The coefficients keep AS 241's published 20 digits, so they can be checked against it.
#[allow(clippy::excessive_precision)]
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 8] = [
        3.387_132_872_796_366_608,
        1.331_416_678_917_843_774_5e2,
        1.971_590_950_306_551_442_7e3,
        1.373_169_376_550_946_112_5e4,
        4.592_195_393_154_987_145_7e4,
        6.726_577_092_700_870_085_3e4,
        3.343_057_558_358_812_810_5e4,
        2.509_080_928_730_122_672_7e3,
    ];
    const B: [f64; 8] = [
        1.0,
        4.231_333_070_160_091_125_2e1,
        6.871_870_074_920_579_083e2,
        5.394_196_021_424_751_107_7e3,
        2.121_379_430_158_659_586_7e4,
        3.930_789_580_009_271_061e4,
        2.872_908_573_572_194_267_4e4,
        5.226_495_278_852_854_561e3,
    ];
    const C: [f64; 8] = [
        1.423_437_110_749_683_577_34,
        4.630_337_846_156_545_295_9,
        5.769_497_221_460_691_405_5,
        3.647_848_324_763_204_605_04,
        1.270_458_252_452_368_382_58,
        2.417_807_251_774_506_117_7e-1,
        2.272_384_498_926_918_458_33e-2,
        7.745_450_142_783_414_076_4e-4,
    ];
    const D: [f64; 8] = [
        1.0,
        2.053_191_626_637_758_821_87,
        1.676_384_830_183_803_849_4,
        6.897_673_349_851_000_045_5e-1,
        1.481_039_764_274_800_745_9e-1,
        1.519_866_656_361_645_719_66e-2,
        5.475_938_084_995_344_946e-4,
        1.050_750_071_644_416_843_24e-9,
    ];
    const E: [f64; 8] = [
        6.657_904_643_501_103_777_2,
        5.463_784_911_164_114_369_9,
        1.784_826_539_917_291_335_8,
        2.965_605_718_285_048_912_3e-1,
        2.653_218_952_657_612_309_3e-2,
        1.242_660_947_388_078_438_6e-3,
        2.711_555_568_743_487_578_15e-5,
        2.010_334_399_292_288_132_65e-7,
    ];
    const F: [f64; 8] = [
        1.0,
        5.998_322_065_558_879_376_9e-1,
        1.369_298_809_227_358_053_1e-1,
        1.487_536_129_085_061_485_25e-2,
        7.868_691_311_456_132_591e-4,
        1.846_318_317_510_054_681_8e-5,
        1.421_511_758_316_445_888_7e-7,
        2.044_263_103_389_939_785_64e-15,
    ];
    let poly = |c: &[f64; 8], r: f64| c.iter().rev().fold(0.0, |acc, &k| acc * r + k);
    if p.is_nan() || !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    let q = p - 0.5;
    if q.abs() <= 0.425 {
        let r = 0.180_625 - q * q;
        return q * poly(&A, r) / poly(&B, r);
    }
    let r = if q < 0.0 { p } else { 1.0 - p };
    if r == 0.0 {
        return if q < 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
    }
    let r = (-r.ln()).sqrt();
    let x = if r <= 5.0 {
        let r = r - 1.6;
        poly(&C, r) / poly(&D, r)
    } else {
        let r = r - 5.0;
        poly(&E, r) / poly(&F, r)
    };
    if q < 0.0 {
        -x
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factorials_and_half_integers() {
        // Γ(n) = (n − 1)!, accumulated as a sum of logs.
        let mut ln_fact = 0.0f64;
        for n in 1..=170u32 {
            let got = ln_gamma(f64::from(n));
            assert!(
                (got - ln_fact).abs() <= 1e-13 * ln_fact.abs().max(1.0),
                "n = {n}"
            );
            ln_fact += f64::from(n).ln();
        }
        // Γ(k + 1/2) = √π Π_{j<k} (j + 1/2).
        let mut ln_half = 0.5 * std::f64::consts::PI.ln();
        for k in 0..200u32 {
            let got = ln_gamma(f64::from(k) + 0.5);
            assert!(
                (got - ln_half).abs() <= 1e-13 * ln_half.abs().max(1.0),
                "k = {k}"
            );
            ln_half += (f64::from(k) + 0.5).ln();
        }
        assert!((ln_gamma(0.1) - 2.252_712_651_734_206).abs() < 1e-14);
        assert!(ln_gamma(0.0).is_nan() && ln_gamma(-1.0).is_nan());
    }

    #[test]
    fn normal_quantiles_and_cdf() {
        assert_eq!(normal_quantile(0.5), 0.0);
        assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-15);
        assert!((normal_quantile(0.025) + 1.959_963_984_540_054).abs() < 1e-15);
        assert!((normal_quantile(0.841_344_746_068_542_9) - 1.0).abs() < 1e-14);
        // Φ⁻¹(1e-10) = −6.361340902404056 (R: qnorm(1e-10)).
        assert!((normal_quantile(1e-10) + 6.361_340_902_404_056).abs() < 1e-13);
        assert_eq!(normal_quantile(0.0), f64::NEG_INFINITY);
        assert_eq!(normal_quantile(1.0), f64::INFINITY);
        assert!(normal_quantile(1.5).is_nan() && normal_quantile(f64::NAN).is_nan());
        // Φ(1.96) = 0.9750021048517795, Φ(−5) = 2.866515718791939e-7 (R: pnorm).
        assert!((normal_cdf(1.96) - 0.975_002_104_851_779_5).abs() < 1e-15);
        assert!((normal_cdf(-5.0) / 2.866_515_718_791_939e-7 - 1.0).abs() < 1e-13);
        assert_eq!(normal_cdf(0.0), 0.5);
        for k in -80..=80 {
            let x = f64::from(k) / 10.0;
            let back = normal_quantile(normal_cdf(x));
            // The upper tail lives in 1 − Φ, which f64 resolves to ~1e-16 only: δx ≈ δΦ/φ(x).
            let pdf = (-x * x / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt();
            let tol = 1e-12 * (1.0 + x.abs()) + if x > 0.0 { 2e-16 / pdf } else { 0.0 };
            assert!((back - x).abs() < tol, "x {x}: {back}");
        }
    }
}
