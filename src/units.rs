//! Physical units at the input boundary.
//!
//! Everything inside the crate is SI. Quantities typed by a user ("40 kOe", "0.5atm",
//! "380 emu/cm3") are converted to SI here, once, by [`parse_quantity`]; results are shown in
//! a chosen unit with [`to_unit`].
//!
//! Conventions:
//! - 1 Oe = 1000/(4π) A/m ([`OERSTED`]) for the field H.
//! - A field given in tesla means μ0·H, so 1 T = 1/μ0 A/m, with μ0 = 4π·10⁻⁷ T·m/A ([`MU0`]).
//! - A magnetization in tesla means μ0·M; in gauss (`G`) it means 4πM, so 1 G ⇒ M = 1000/(4π) A/m.
//! - 1 emu/cm³ = 1000 A/m; 1 erg/cm³ = 0.1 J/m³; 1 atm = 101325 Pa; 1 bar = 10⁵ Pa.
//!
//! | dimension | units |
//! |---|---|
//! | magnetic field | Oe, kOe, T, mT, A/m, kA/m, MA/m |
//! | magnetization | emu/cm3, A/m, kA/m, MA/m, T, G |
//! | energy density | J/m3, kJ/m3, MJ/m3, erg/cm3 |
//! | pressure | Pa, kPa, MPa, GPa, bar, atm |
//! | density | kg/m3, g/cm3 |
//! | length | nm, um (also µm, μm), mm, cm, m |
//! | time | s, ms, us (also µs, μs), min, h |
//! | velocity | m/s, mm/s, um/s (also µm/s, μm/s) |
//! | acceleration | m/s2 |
//! | mass | mg, g, kg |
//! | energy | J, kJ, MJ |
//! | electric field | V/m, kV/m, MV/m |
//! | charge per mass | C/kg, mC/kg, uC/kg |
//! | dynamic viscosity | Pa*s, mPa*s |
//! | damping coefficient | N*s/m, kg/s |
//! | angle | rad, mrad, deg |
//! | temperature | K |
//!
//! A magnetic flux density B is entered as a field in tesla (`10 T` means μ0·H = 10 T) and
//! recovered as μ0·H.

use std::f64::consts::PI;

/// Vacuum permeability μ0 = 4π·10⁻⁷ T·m/A (the pre-2019 exact value, used throughout).
pub const MU0: f64 = 4.0e-7 * PI;

/// A/m per oersted: 1 Oe = 1000/(4π) A/m.
pub const OERSTED: f64 = 1000.0 / (4.0 * PI);

/// The physical dimension a user-supplied quantity must have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    /// Magnetic field H (SI: A/m).
    MagneticField,
    /// Magnetization M (SI: A/m).
    Magnetization,
    /// Energy density, e.g. an anisotropy constant (SI: J/m³).
    EnergyDensity,
    /// Pressure or elastic modulus (SI: Pa).
    Pressure,
    /// Mass density (SI: kg/m³).
    Density,
    /// Length (SI: m).
    Length,
    /// Time (SI: s).
    Time,
    /// Velocity (SI: m/s).
    Velocity,
    /// Acceleration (SI: m/s²).
    Acceleration,
    /// Mass (SI: kg).
    Mass,
    /// Energy (SI: J).
    Energy,
    /// Electric field (SI: V/m).
    ElectricField,
    /// Charge per unit mass (SI: C/kg).
    ChargePerMass,
    /// Dynamic viscosity (SI: Pa·s).
    Viscosity,
    /// Damping coefficient, force per velocity (SI: N·s/m = kg/s).
    Damping,
    /// Plane angle (SI: rad).
    Angle,
    /// Thermodynamic temperature (SI: K).
    Temperature,
}

/// Every dimension, for tests.
#[cfg(test)]
const ALL_DIMENSIONS: [Dimension; 17] = [
    Dimension::MagneticField,
    Dimension::Magnetization,
    Dimension::EnergyDensity,
    Dimension::Pressure,
    Dimension::Density,
    Dimension::Length,
    Dimension::Time,
    Dimension::Velocity,
    Dimension::Acceleration,
    Dimension::Mass,
    Dimension::Energy,
    Dimension::ElectricField,
    Dimension::ChargePerMass,
    Dimension::Viscosity,
    Dimension::Damping,
    Dimension::Angle,
    Dimension::Temperature,
];

impl Dimension {
    /// Lower-case human name, e.g. "magnetic field".
    pub fn name(self) -> &'static str {
        match self {
            Dimension::MagneticField => "magnetic field",
            Dimension::Magnetization => "magnetization",
            Dimension::EnergyDensity => "energy density",
            Dimension::Pressure => "pressure",
            Dimension::Density => "density",
            Dimension::Length => "length",
            Dimension::Time => "time",
            Dimension::Velocity => "velocity",
            Dimension::Acceleration => "acceleration",
            Dimension::Mass => "mass",
            Dimension::Energy => "energy",
            Dimension::ElectricField => "electric field",
            Dimension::ChargePerMass => "charge per mass",
            Dimension::Viscosity => "dynamic viscosity",
            Dimension::Damping => "damping coefficient",
            Dimension::Angle => "angle",
            Dimension::Temperature => "temperature",
        }
    }

    /// The unit symbols accepted for this dimension (case-sensitive). The micro-sign
    /// spellings `µm`/`μm`, `µs`/`μs`, `µm/s`/`μm/s` are also accepted but not listed.
    pub fn units(self) -> &'static [&'static str] {
        match self {
            Dimension::MagneticField => &["Oe", "kOe", "T", "mT", "A/m", "kA/m", "MA/m"],
            Dimension::Magnetization => &["emu/cm3", "A/m", "kA/m", "MA/m", "T", "G"],
            Dimension::EnergyDensity => &["J/m3", "kJ/m3", "MJ/m3", "erg/cm3"],
            Dimension::Pressure => &["Pa", "kPa", "MPa", "GPa", "bar", "atm"],
            Dimension::Density => &["kg/m3", "g/cm3"],
            Dimension::Length => &["nm", "um", "mm", "cm", "m"],
            Dimension::Time => &["s", "ms", "us", "min", "h"],
            Dimension::Velocity => &["m/s", "mm/s", "um/s"],
            Dimension::Acceleration => &["m/s2"],
            Dimension::Mass => &["mg", "g", "kg"],
            Dimension::Energy => &["J", "kJ", "MJ"],
            Dimension::ElectricField => &["V/m", "kV/m", "MV/m"],
            Dimension::ChargePerMass => &["C/kg", "mC/kg", "uC/kg"],
            Dimension::Viscosity => &["Pa*s", "mPa*s"],
            Dimension::Damping => &["N*s/m", "kg/s"],
            Dimension::Angle => &["rad", "mrad", "deg"],
            Dimension::Temperature => &["K"],
        }
    }

    /// "a magnetic field", "an energy density".
    fn with_article(self) -> String {
        let name = self.name();
        let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) {
            "an"
        } else {
            "a"
        };
        format!("{article} {name}")
    }
}

/// Maps the micro-sign spellings onto the ASCII symbols; other symbols are returned as is.
fn canonical(unit: &str) -> &str {
    match unit {
        "µm" | "μm" => "um",
        "µs" | "μs" => "us",
        "µm/s" | "μm/s" => "um/s",
        other => other,
    }
}

/// SI value of one `unit`, or `None` for a symbol not in the table.
fn factor(unit: &str) -> Option<f64> {
    let f = match canonical(unit) {
        // magnetic field (H) and magnetization (M), both A/m in SI
        "Oe" | "G" => OERSTED,
        "kOe" => 1.0e3 * OERSTED,
        "T" => 1.0 / MU0,
        "mT" => 1.0e-3 / MU0,
        "A/m" => 1.0,
        "kA/m" => 1.0e3,
        "MA/m" => 1.0e6,
        "emu/cm3" => 1.0e3,
        // energy density
        "J/m3" => 1.0,
        "kJ/m3" => 1.0e3,
        "MJ/m3" => 1.0e6,
        "erg/cm3" => 0.1,
        // pressure
        "Pa" => 1.0,
        "kPa" => 1.0e3,
        "MPa" => 1.0e6,
        "GPa" => 1.0e9,
        "bar" => 1.0e5,
        "atm" => 101_325.0,
        // density
        "kg/m3" => 1.0,
        "g/cm3" => 1.0e3,
        // length
        "nm" => 1.0e-9,
        "um" => 1.0e-6,
        "mm" => 1.0e-3,
        "cm" => 1.0e-2,
        "m" => 1.0,
        // time
        "s" => 1.0,
        "ms" => 1.0e-3,
        "us" => 1.0e-6,
        "min" => 60.0,
        "h" => 3600.0,
        // velocity
        "m/s" => 1.0,
        "mm/s" => 1.0e-3,
        "um/s" => 1.0e-6,
        "m/s2" => 1.0,
        // mass
        "mg" => 1.0e-6,
        "g" => 1.0e-3,
        "kg" => 1.0,
        // energy
        "J" => 1.0,
        "kJ" => 1.0e3,
        "MJ" => 1.0e6,
        // electric field
        "V/m" => 1.0,
        "kV/m" => 1.0e3,
        "MV/m" => 1.0e6,
        // charge per mass
        "C/kg" => 1.0,
        "mC/kg" => 1.0e-3,
        "uC/kg" => 1.0e-6,
        // dynamic viscosity
        "Pa*s" => 1.0,
        "mPa*s" => 1.0e-3,
        // damping coefficient
        "N*s/m" | "kg/s" => 1.0,
        // angle
        "rad" => 1.0,
        "mrad" => 1.0e-3,
        "deg" => PI / 180.0,
        // temperature
        "K" => 1.0,
        _ => return None,
    };
    Some(f)
}

/// SI value of 1 `unit` (e.g. `si_per_unit("kOe")` = 10⁶/(4π) A/m).
///
/// # Panics
/// On a unit symbol not in the table (a programmer error; user text goes through
/// [`parse_quantity`]).
pub fn si_per_unit(unit: &str) -> f64 {
    factor(unit).unwrap_or_else(|| panic!("units::si_per_unit: unknown unit symbol '{unit}'"))
}

/// Converts an SI value to the given unit of any dimension
/// (e.g. `to_unit(1.466e6, "kOe")` ≈ 18.42).
///
/// # Panics
/// On a unit symbol not in the table (a programmer error).
pub fn to_unit(si: f64, unit: &str) -> f64 {
    si / si_per_unit(unit)
}

/// The text quoted for an error message, kept on one line.
fn quoted(text: &str) -> String {
    format!("'{}'", text.escape_debug())
}

/// Splits `text` (already trimmed, non-empty) into the longest leading part that parses as
/// an `f64` and the rest (trimmed).
fn split_number(text: &str) -> Option<(f64, &str)> {
    // Only ASCII can be part of a number, so the candidates end at ASCII char boundaries.
    let ascii_len = text
        .char_indices()
        .find(|&(_, c)| !c.is_ascii() || c.is_ascii_whitespace())
        .map_or(text.len(), |(i, _)| i);
    (1..=ascii_len).rev().find_map(|end| {
        text[..end]
            .parse::<f64>()
            .ok()
            .map(|v| (v, text[end..].trim()))
    })
}

/// Parses a quantity such as `"40kOe"`, `"40 kOe"`, `"1e3 A/m"`, `" 0.5atm "` or `"2.5e-6"`
/// and returns its SI value.
///
/// The number may carry a sign and an exponent; the unit follows directly or after
/// whitespace and must be one of `dim.units()` (or a micro-sign spelling of `um`/`us`).
/// A bare number is in `default_unit`. NaN and infinities are rejected, as is a value that
/// overflows when converted to SI. Range checks are the caller's job.
///
/// Errors are one line that quotes the text and says what is allowed, e.g.
/// `'40kOhm': unknown unit 'kOhm' for a magnetic field (allowed: Oe, kOe, T, mT, A/m, kA/m, MA/m)`;
/// the caller prefixes the option name.
///
/// # Panics
/// If `default_unit` is not one of `dim.units()` (a programmer error).
pub fn parse_quantity(text: &str, dim: Dimension, default_unit: &str) -> Result<f64, String> {
    assert!(
        dim.units().contains(&canonical(default_unit)),
        "units::parse_quantity: default unit '{default_unit}' is not a unit of {}",
        dim.with_article()
    );
    let trimmed = text.trim();
    if trimmed.is_empty() {
        return Err(format!("{}: empty value", quoted(trimmed)));
    }
    let Some((value, unit)) = split_number(trimmed) else {
        return Err(format!(
            "{}: not a number (expected a number optionally followed by a unit of {}: {})",
            quoted(trimmed),
            dim.with_article(),
            dim.units().join(", ")
        ));
    };
    if !value.is_finite() {
        return Err(format!("{}: not a finite number", quoted(trimmed)));
    }
    let unit = if unit.is_empty() { default_unit } else { unit };
    if !dim.units().contains(&canonical(unit)) {
        return Err(format!(
            "{}: unknown unit {} for {} (allowed: {})",
            quoted(trimmed),
            quoted(unit),
            dim.with_article(),
            dim.units().join(", ")
        ));
    }
    let si = value * si_per_unit(unit);
    if !si.is_finite() {
        return Err(format!(
            "{}: out of range (the value in SI units overflows)",
            quoted(trimmed)
        ));
    }
    Ok(si)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        a == b || (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    #[test]
    fn constants() {
        assert_eq!(MU0, 4.0e-7 * PI);
        assert!(close(OERSTED, 79.577_471_545_947_67, 1e-15));
        assert!(close(MU0 * OERSTED, 1.0e-4, 1e-15)); // 1 Oe ↔ 1e-4 T in vacuum
    }

    #[test]
    fn every_unit_factor() {
        let expected: &[(&str, f64)] = &[
            ("Oe", 1000.0 / (4.0 * PI)),
            ("kOe", 1.0e6 / (4.0 * PI)),
            ("T", 1.0 / (4.0e-7 * PI)),
            ("mT", 1.0e-3 / (4.0e-7 * PI)),
            ("A/m", 1.0),
            ("kA/m", 1.0e3),
            ("MA/m", 1.0e6),
            ("emu/cm3", 1.0e3),
            ("G", 1000.0 / (4.0 * PI)),
            ("J/m3", 1.0),
            ("kJ/m3", 1.0e3),
            ("MJ/m3", 1.0e6),
            ("erg/cm3", 0.1),
            ("Pa", 1.0),
            ("kPa", 1.0e3),
            ("MPa", 1.0e6),
            ("GPa", 1.0e9),
            ("bar", 1.0e5),
            ("atm", 101_325.0),
            ("kg/m3", 1.0),
            ("g/cm3", 1.0e3),
            ("nm", 1.0e-9),
            ("um", 1.0e-6),
            ("µm", 1.0e-6),
            ("μm", 1.0e-6),
            ("mm", 1.0e-3),
            ("cm", 1.0e-2),
            ("m", 1.0),
            ("s", 1.0),
            ("ms", 1.0e-3),
            ("us", 1.0e-6),
            ("min", 60.0),
            ("h", 3600.0),
            ("m/s", 1.0),
            ("mm/s", 1.0e-3),
            ("um/s", 1.0e-6),
            ("m/s2", 1.0),
            ("mg", 1.0e-6),
            ("g", 1.0e-3),
            ("kg", 1.0),
            ("J", 1.0),
            ("kJ", 1.0e3),
            ("MJ", 1.0e6),
            ("V/m", 1.0),
            ("kV/m", 1.0e3),
            ("MV/m", 1.0e6),
            ("C/kg", 1.0),
            ("mC/kg", 1.0e-3),
            ("uC/kg", 1.0e-6),
            ("Pa*s", 1.0),
            ("mPa*s", 1.0e-3),
            ("N*s/m", 1.0),
            ("kg/s", 1.0),
            ("rad", 1.0),
            ("mrad", 1.0e-3),
            ("deg", PI / 180.0),
            ("K", 1.0),
        ];
        for &(unit, f) in expected {
            assert!(close(si_per_unit(unit), f, 1e-15), "{unit}");
        }
        // every listed unit is in the table and covered above
        for dim in ALL_DIMENSIONS {
            for unit in dim.units() {
                assert!(factor(unit).is_some(), "{unit}");
                assert!(expected.iter().any(|(u, _)| u == unit), "{unit} untested");
            }
            assert!(!dim.name().is_empty());
        }
    }

    #[test]
    fn examples() {
        let h = |s: &str| parse_quantity(s, Dimension::MagneticField, "kOe").unwrap();
        assert!(close(h("40kOe"), 40.0e6 / (4.0 * PI), 1e-15));
        assert!(close(h("40 kOe"), 40.0e6 / (4.0 * PI), 1e-15));
        assert!(close(h("  40\tkOe  "), 40.0e6 / (4.0 * PI), 1e-15));
        assert!(close(h("40"), 40.0e6 / (4.0 * PI), 1e-15));
        assert_eq!(h("1e3 A/m"), 1.0e3);
        assert_eq!(h("1e3A/m"), 1.0e3);
        assert!(close(h("1 T"), 1.0 / MU0, 1e-15));
        assert!(close(h("-2.5mT"), -2.5e-3 / MU0, 1e-15));
        let p = |s: &str| parse_quantity(s, Dimension::Pressure, "Pa").unwrap();
        assert_eq!(p(" 0.5atm "), 0.5 * 101_325.0);
        assert_eq!(p("2bar"), 2.0e5);
        assert_eq!(p("+1.8e11"), 1.8e11);
        let l = |s: &str| parse_quantity(s, Dimension::Length, "m").unwrap();
        assert_eq!(l("2.5e-6"), 2.5e-6);
        assert!(close(l("1µm"), 1.0e-6, 1e-15));
        assert!(close(l("1 μm"), 1.0e-6, 1e-15));
        assert!(close(l("3nm"), 3.0e-9, 1e-15));
        let e = |s: &str| parse_quantity(s, Dimension::EnergyDensity, "J/m3").unwrap();
        assert!(close(e("3.5e6 erg/cm3"), 3.5e5, 1e-15));
        assert!(close(e("3.5e6erg/cm3"), 3.5e5, 1e-15));
        assert!(close(e("3.5erg/cm3"), 0.35, 1e-15));
        let m = |s: &str| parse_quantity(s, Dimension::Magnetization, "A/m").unwrap();
        assert_eq!(m("380emu/cm3"), 3.8e5);
        assert!(close(m("4776 G"), 4776.0 * OERSTED, 1e-15));
        let t = |s: &str| parse_quantity(s, Dimension::Time, "s").unwrap();
        assert_eq!(t("2 min"), 120.0);
        assert_eq!(t("1h"), 3600.0);
        let v = |s: &str| parse_quantity(s, Dimension::Velocity, "m/s").unwrap();
        assert!(close(v("5 um/s"), 5.0e-6, 1e-15));
        let d = |s: &str| parse_quantity(s, Dimension::Density, "kg/m3").unwrap();
        assert_eq!(d("5.1 g/cm3"), 5100.0);
    }

    #[test]
    fn bare_number_uses_default() {
        assert_eq!(
            parse_quantity("12", Dimension::MagneticField, "Oe").unwrap(),
            12.0 * OERSTED
        );
        assert_eq!(
            parse_quantity("12", Dimension::Time, "ms").unwrap(),
            12.0e-3
        );
        assert_eq!(
            parse_quantity("12", Dimension::Length, "µm").unwrap(),
            12.0e-6
        );
    }

    #[test]
    fn errors() {
        let h = |s: &str| parse_quantity(s, Dimension::MagneticField, "kOe").unwrap_err();
        assert_eq!(
            h("40kOhm"),
            "'40kOhm': unknown unit 'kOhm' for a magnetic field \
             (allowed: Oe, kOe, T, mT, A/m, kA/m, MA/m)"
        );
        assert!(h("abc").starts_with("'abc': not a number"), "{}", h("abc"));
        assert!(h("kOe").starts_with("'kOe': not a number"));
        assert_eq!(h("NaN kOe"), "'NaN kOe': not a finite number");
        assert_eq!(h("nan"), "'nan': not a finite number");
        assert_eq!(h("inf"), "'inf': not a finite number");
        assert_eq!(h("-infinity Oe"), "'-infinity Oe': not a finite number");
        assert_eq!(h("+InfkOe"), "'+InfkOe': not a finite number");
        assert_eq!(h(""), "'': empty value");
        assert_eq!(h("   "), "'': empty value");
        assert!(h("1e308 kOe").contains("out of range"));
        assert!(h("40 k Oe").contains("unknown unit 'k Oe'"));
        assert!(h("40 emu/cm3").contains("unknown unit 'emu/cm3' for a magnetic field"));
        assert!(h("1,5 kOe").contains("unknown unit"));
        let e = parse_quantity("3.5e6 erg", Dimension::EnergyDensity, "J/m3").unwrap_err();
        assert_eq!(
            e,
            "'3.5e6 erg': unknown unit 'erg' for an energy density \
             (allowed: J/m3, kJ/m3, MJ/m3, erg/cm3)"
        );
        // one line, even for text with a newline in it
        assert!(!h("4\n0 kOe").contains('\n'));
        // case-sensitive symbols
        assert!(h("40 koe").contains("unknown unit 'koe'"));
    }

    #[test]
    #[should_panic(expected = "unknown unit symbol")]
    fn to_unit_panics_on_unknown_symbol() {
        to_unit(1.0, "furlong");
    }

    #[test]
    fn round_trips() {
        assert!(close(to_unit(1.466e6, "kOe"), 18.42, 1e-3));
        for dim in ALL_DIMENSIONS {
            for unit in dim.units() {
                for x in [1.0, -3.25, 0.0, 1.234e-5, 6.02e23] {
                    let si = parse_quantity(&format!("{x} {unit}"), dim, dim.units()[0]).unwrap();
                    assert!(close(to_unit(si, unit), x, 1e-14), "{x} {unit}");
                }
            }
        }
    }

    fn any_unit() -> impl Strategy<Value = (Dimension, &'static str)> {
        let pairs: Vec<(Dimension, &'static str)> = ALL_DIMENSIONS
            .iter()
            .flat_map(|&d| d.units().iter().map(move |&u| (d, u)))
            .collect();
        proptest::sample::select(pairs)
    }

    proptest! {
        #[test]
        fn parser_never_panics(s in any::<String>(), idx in 0usize..ALL_DIMENSIONS.len()) {
            let dim = ALL_DIMENSIONS[idx];
            let _ = parse_quantity(&s, dim, dim.units()[0]);
        }

        #[test]
        fn parser_never_panics_on_number_like(s in "[ +\\-0-9.eEinfatyINFATYµμ]{0,12}[a-zA-Z/0-9 µμ]{0,8}") {
            let _ = parse_quantity(&s, Dimension::Length, "m");
        }

        #[test]
        fn number_then_unit(v in any::<f64>().prop_filter("finite", |v| v.is_finite()),
                            (dim, unit) in any_unit()) {
            let expected = v * si_per_unit(unit);
            for text in [format!("{v}{unit}"), format!("{v} {unit}"), format!("{v:e}{unit}")] {
                let got = parse_quantity(&text, dim, dim.units()[0]);
                if expected.is_finite() {
                    let got = got.unwrap();
                    prop_assert!(close(got, expected, 1e-12), "{text}: {got} vs {expected}");
                } else {
                    prop_assert!(got.is_err());
                }
            }
        }
    }
}
