//! Material parameters: a small built-in database of hard-magnetic materials, extensible by
//! user TOML files.
//!
//! All values are SI and at room temperature. Derived quantities: the anisotropy field
//! H_K = 2K/(μ0 Ms) (SI) = 2K/Ms (CGS), and the reduced anisotropy β = 2K/Ms² in CGS units
//! (K in erg/cm³, Ms in emu/cm³; the SI equivalent 2K/(μ0 Ms²) is 4π times smaller).
//! Inter-particle dipolar interaction is neglected by the models, which is justified for
//! β ≳ 10; [`MaterialDb::table`] flags materials below that.
//!
//! # Built-in materials and their sources
//!
//! | name | Ms | K1 | E | ν | ρ | source |
//! |---|---|---|---|---|---|---|
//! | `srfe12o19` | 380 emu/cm³ | 3.5e6 erg/cm³ | 1.8e11 Pa | 0.28 | 5100 kg/m³ | Ms, K1: Erokhin & Berkov, phys. stat. sol. (b) 2020, doi:10.1002/pssb.202000404, §2.2 ("Ms = 380 G" read as emu/cm³, K = 3.5e6 erg/cm³); E, ν: same paper, §2.3; ρ: not in the paper, the spec's value (align.md; only gravity uses it) |
//! | `bafe12o19` | μ0Ms = 0.48 T | 0.33 MJ/m³ | 1.8e11 Pa | 0.28 | 5280 kg/m³ | Ms, K1: Coey (2010), ch. 11, table of hard magnetic materials; ρ: X-ray density, typical handbook value; E, ν: typical value, taken equal to Sr ferrite (same M-type hexaferrite) |
//! | `nd2fe14b` | μ0Ms = 1.61 T | 4.9 MJ/m³ | 1.6e11 Pa | 0.24 | 7600 kg/m³ | Ms, K1: Coey (2010), ch. 11; ρ: typical handbook value; E, ν: typical manufacturer data-sheet values for sintered NdFeB magnets |
//! | `smco5` | μ0Ms = 1.07 T | 17.2 MJ/m³ | 1.2e11 Pa | 0.27 | 8600 kg/m³ | Ms, K1: Coey (2010), ch. 11; ρ: typical handbook value; E, ν: typical manufacturer data-sheet values for sintered SmCo5 magnets |
//!
//! Coey (2010) = J. M. D. Coey, *Magnetism and Magnetic Materials*, Cambridge University
//! Press 2010. The elastic constants of sintered magnets depend on porosity and grade; data
//! sheets quote a spread of some tens of percent around these typical values.
//!
//! # User files
//!
//! ```toml
//! [[material]]
//! name = "myferrite"                    # case-insensitive key
//! description = "my ferrite powder"     # optional
//! source = "own VSM measurement, 2024"  # optional
//! saturation_magnetization = "380 emu/cm3"
//! anisotropy_constant = "3.5e6 erg/cm3"
//! youngs_modulus = "1.8e11 Pa"
//! poisson_ratio = 0.28
//! density = "5100 kg/m3"
//! ```
//!
//! Quantities are strings with units (see [`crate::units`]) or bare numbers in SI units.
//! A new material needs all five physical keys; for an existing name (a built-in or one
//! loaded earlier) the keys given override and the others keep their values.

use std::fmt::Write as _;
use std::path::Path;

use serde::Deserialize;

use crate::output::guard::{read_text_limited, MAX_TEXT_INPUT};
use crate::units::{self, Dimension};
use crate::{Error, Result};

/// One magnetic material's parameters, SI units.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Material {
    /// Lower-case key, e.g. `"srfe12o19"`.
    pub name: String,
    /// Human description, e.g. "Sr hexaferrite SrFe12O19 (M-type)".
    pub description: String,
    /// Saturation magnetization Ms, A/m.
    pub saturation_magnetization: f64,
    /// First uniaxial anisotropy constant K (K1), J/m³.
    pub anisotropy_constant: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Poisson ratio ν, dimensionless.
    pub poisson_ratio: f64,
    /// Mass density ρ, kg/m³.
    pub density: f64,
    /// Citation for the numbers.
    pub source: String,
}

impl Material {
    /// Anisotropy field H_K = 2K/(μ0 Ms), A/m (≈ 1.466e6 A/m ≈ 18.4 kOe for Sr ferrite).
    pub fn anisotropy_field(&self) -> f64 {
        2.0 * self.anisotropy_constant / (units::MU0 * self.saturation_magnetization)
    }

    /// Reduced anisotropy β = 2K/Ms² in CGS units (K in erg/cm³, Ms in emu/cm³);
    /// ≈ 48.5 for Sr ferrite.
    pub fn reduced_anisotropy_cgs(&self) -> f64 {
        let k = units::to_unit(self.anisotropy_constant, "erg/cm3");
        let ms = units::to_unit(self.saturation_magnetization, "emu/cm3");
        2.0 * k / (ms * ms)
    }

    /// Checks that Ms, K, E and ρ are positive and finite and 0 ≤ ν < 0.5.
    /// The error names the material, the field, the value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            (
                "saturation_magnetization",
                self.saturation_magnetization,
                "A/m",
            ),
            ("anisotropy_constant", self.anisotropy_constant, "J/m3"),
            ("youngs_modulus", self.youngs_modulus, "Pa"),
            ("density", self.density, "kg/m3"),
        ];
        for (field, value, unit) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::input(format!(
                    "material '{}': {field} = {value} {unit} is not allowed \
                     (must be positive and finite)",
                    self.name.escape_debug()
                )));
            }
        }
        let nu = self.poisson_ratio;
        if !(nu.is_finite() && (0.0..0.5).contains(&nu)) {
            return Err(Error::input(format!(
                "material '{}': poisson_ratio = {nu} is not allowed (must be in [0, 0.5))",
                self.name.escape_debug()
            )));
        }
        Ok(())
    }
}

/// An ordered collection of materials: the built-ins first, then user additions in the order
/// they were loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialDb {
    materials: Vec<Material>,
}

/// Source string of the project's reference material.
const EROKHIN_BERKOV: &str =
    "Erokhin & Berkov, phys. stat. sol. (b) 2020, doi:10.1002/pssb.202000404 (Table 1)";

/// Coey's textbook, for the intrinsic magnetic constants.
const COEY: &str = "J. M. D. Coey, Magnetism and Magnetic Materials (Cambridge University Press, \
                    2010), ch. 11, table of intrinsic properties of hard magnetic materials";

impl MaterialDb {
    /// The built-in materials: `srfe12o19`, `bafe12o19`, `nd2fe14b`, `smco5`
    /// (sources in the module documentation and in each material's `source`).
    pub fn builtin() -> Self {
        let mu0 = units::MU0;
        let materials = vec![
            Material {
                name: "srfe12o19".into(),
                description: "Sr hexaferrite SrFe12O19 (M-type)".into(),
                saturation_magnetization: 380.0 * units::si_per_unit("emu/cm3"),
                anisotropy_constant: 3.5e6 * units::si_per_unit("erg/cm3"),
                youngs_modulus: 1.8e11,
                poisson_ratio: 0.28,
                density: 5100.0,
                source: EROKHIN_BERKOV.into(),
            },
            Material {
                name: "bafe12o19".into(),
                description: "Ba hexaferrite BaFe12O19 (M-type)".into(),
                saturation_magnetization: 0.48 / mu0,
                anisotropy_constant: 0.33e6,
                youngs_modulus: 1.8e11,
                poisson_ratio: 0.28,
                density: 5280.0,
                source: format!(
                    "Ms (mu0 Ms = 0.48 T), K1: {COEY}; density: X-ray density, typical \
                     handbook value; E, nu: typical value, taken equal to Sr ferrite \
                     (same M-type hexaferrite structure)"
                ),
            },
            Material {
                name: "nd2fe14b".into(),
                description: "Nd2Fe14B (NdFeB magnet phase)".into(),
                saturation_magnetization: 1.61 / mu0,
                anisotropy_constant: 4.9e6,
                youngs_modulus: 1.6e11,
                poisson_ratio: 0.24,
                density: 7600.0,
                source: format!(
                    "Ms (mu0 Ms = 1.61 T), K1: {COEY}; density: typical handbook value; \
                     E, nu: typical manufacturer data-sheet values for sintered NdFeB magnets"
                ),
            },
            Material {
                name: "smco5".into(),
                description: "SmCo5 (1:5 samarium-cobalt)".into(),
                saturation_magnetization: 1.07 / mu0,
                anisotropy_constant: 17.2e6,
                youngs_modulus: 1.2e11,
                poisson_ratio: 0.27,
                density: 8600.0,
                source: format!(
                    "Ms (mu0 Ms = 1.07 T), K1: {COEY}; density: typical handbook value; \
                     E, nu: typical manufacturer data-sheet values for sintered SmCo5 magnets"
                ),
            },
        ];
        MaterialDb { materials }
    }

    /// Adds or overrides materials from a TOML file (format in the module documentation).
    /// Errors name the file and the bad key/value. Nothing is changed on error.
    pub fn load_file(&mut self, path: &Path) -> Result<()> {
        let text = read_text_limited(path, MAX_TEXT_INPUT, "materials file")?;
        self.load_str(&text, &path.display().to_string())
    }

    /// Adds or overrides materials from TOML text; `origin` (a file name) prefixes errors.
    /// Nothing is changed on error.
    pub fn load_str(&mut self, text: &str, origin: &str) -> Result<()> {
        let file: MaterialFile = toml::from_str(text).map_err(|e| {
            let message = one_line(e.message());
            match e.span() {
                Some(span) => {
                    let end = span.start.min(text.len());
                    let line = 1 + text.as_bytes()[..end]
                        .iter()
                        .filter(|&&b| b == b'\n')
                        .count();
                    Error::input(format!("{origin}: line {line}: {message}"))
                }
                None => Error::input(format!("{origin}: {message}")),
            }
        })?;
        let mut materials = self.materials.clone();
        for raw in file.material {
            raw.merge_into(&mut materials, origin)
                .map_err(|msg| Error::input(format!("{origin}: {msg}")))?;
        }
        self.materials = materials;
        Ok(())
    }

    /// Case-insensitive lookup. An unknown name gives an input error listing the known ones.
    pub fn get(&self, name: &str) -> Result<&Material> {
        let key = name.trim().to_lowercase();
        self.materials
            .iter()
            .find(|m| m.name == key)
            .ok_or_else(|| {
                Error::input(format!(
                    "unknown material '{}' (known: {})",
                    name.escape_debug(),
                    self.names().join(", ")
                ))
            })
    }

    /// The materials in order (built-ins first).
    pub fn iter(&self) -> impl Iterator<Item = &Material> {
        self.materials.iter()
    }

    /// The names in order.
    fn names(&self) -> Vec<&str> {
        self.materials.iter().map(|m| m.name.as_str()).collect()
    }

    /// A human-readable table: name, Ms (emu/cm³), K (erg/cm³ and MJ/m³), H_K (kOe),
    /// β (CGS), E (GPa), ν, ρ (kg/m³); then one line per material with its description and
    /// source.
    pub fn table(&self) -> String {
        let header = [
            "name",
            "Ms emu/cm3",
            "K erg/cm3",
            "K MJ/m3",
            "H_K kOe",
            "beta CGS",
            "E GPa",
            "nu",
            "rho kg/m3",
        ];
        let rows: Vec<[String; 9]> = self
            .materials
            .iter()
            .map(|m| {
                let beta = m.reduced_anisotropy_cgs();
                let flag = if beta < 10.0 { "*" } else { "" };
                [
                    m.name.clone(),
                    format!(
                        "{:.0}",
                        units::to_unit(m.saturation_magnetization, "emu/cm3")
                    ),
                    format!("{:.3e}", units::to_unit(m.anisotropy_constant, "erg/cm3")),
                    format!("{:.3}", units::to_unit(m.anisotropy_constant, "MJ/m3")),
                    format!("{:.2}", units::to_unit(m.anisotropy_field(), "kOe")),
                    format!("{beta:.1}{flag}"),
                    format!("{:.0}", units::to_unit(m.youngs_modulus, "GPa")),
                    format!("{:.2}", m.poisson_ratio),
                    format!("{:.0}", m.density),
                ]
            })
            .collect();
        let mut widths = header.map(|h| h.chars().count());
        for row in &rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let mut out = String::new();
        let mut line = |cells: &[&str]| {
            let mut s = String::new();
            for (i, (cell, w)) in cells.iter().zip(widths).enumerate() {
                if i == 0 {
                    let _ = write!(s, "{cell:<w$}");
                } else {
                    let _ = write!(s, "  {cell:>w$}");
                }
            }
            out.push_str(s.trim_end());
            out.push('\n');
        };
        line(&header);
        for row in &rows {
            line(&row.each_ref().map(String::as_str));
        }
        out.push('\n');
        for m in &self.materials {
            let _ = writeln!(out, "{}: {}. Source: {}", m.name, m.description, m.source);
        }
        if rows.iter().any(|r| r[5].ends_with('*')) {
            out.push_str(
                "* beta < 10: inter-particle dipolar interaction, which the models neglect, \
                 is not negligible for this material\n",
            );
        }
        out
    }
}

/// Collapses a possibly multi-line message into one line.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The whole user file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    #[serde(default)]
    material: Vec<RawMaterial>,
}

/// One `[[material]]` entry as written by the user.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    name: String,
    description: Option<String>,
    source: Option<String>,
    saturation_magnetization: Option<Quantity>,
    anisotropy_constant: Option<Quantity>,
    youngs_modulus: Option<Quantity>,
    poisson_ratio: Option<f64>,
    density: Option<Quantity>,
}

/// A quantity as written in the file: a string with a unit, or a bare number (SI).
struct Quantity(String);

impl<'de> Deserialize<'de> for Quantity {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Quantity;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(
                    "a quantity with a unit such as \"380 emu/cm3\", or a number in SI units",
                )
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<Quantity, E> {
                Ok(Quantity(v.to_owned()))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> std::result::Result<Quantity, E> {
                Ok(Quantity(v.to_string()))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> std::result::Result<Quantity, E> {
                Ok(Quantity(v.to_string()))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> std::result::Result<Quantity, E> {
                Ok(Quantity(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

/// The physical keys: name, dimension and SI unit for bare numbers.
const QUANTITY_KEYS: [(&str, Dimension, &str); 4] = [
    ("saturation_magnetization", Dimension::Magnetization, "A/m"),
    ("anisotropy_constant", Dimension::EnergyDensity, "J/m3"),
    ("youngs_modulus", Dimension::Pressure, "Pa"),
    ("density", Dimension::Density, "kg/m3"),
];

impl RawMaterial {
    /// Adds this entry to `materials` or overrides the existing one of the same name.
    /// Errors are one line without the origin prefix.
    fn merge_into(
        self,
        materials: &mut Vec<Material>,
        origin: &str,
    ) -> std::result::Result<(), String> {
        let name = self.name.trim().to_lowercase();
        if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(format!(
                "material name '{}' is not allowed (must be non-empty, without spaces)",
                self.name.escape_debug()
            ));
        }
        let quoted = name.escape_debug().to_string();
        let quantities = [
            &self.saturation_magnetization,
            &self.anisotropy_constant,
            &self.youngs_modulus,
            &self.density,
        ];
        let mut values = [None; 4];
        for (slot, (q, (key, dim, si_unit))) in values
            .iter_mut()
            .zip(quantities.into_iter().zip(QUANTITY_KEYS))
        {
            if let Some(Quantity(text)) = q {
                let v = units::parse_quantity(text, dim, si_unit)
                    .map_err(|e| format!("material '{quoted}': {key}: {e}"))?;
                *slot = Some(v);
            }
        }
        let [ms, k, e, rho] = values;
        let nu = self.poisson_ratio;
        let mut given: Vec<&str> = QUANTITY_KEYS
            .iter()
            .zip(values)
            .filter(|(_, v)| v.is_some())
            .map(|((key, _, _), _)| *key)
            .collect();
        if nu.is_some() {
            given.push("poisson_ratio");
        }

        let material = match materials.iter_mut().find(|m| m.name == name) {
            Some(existing) => {
                let mut m = existing.clone();
                m.saturation_magnetization = ms.unwrap_or(m.saturation_magnetization);
                m.anisotropy_constant = k.unwrap_or(m.anisotropy_constant);
                m.youngs_modulus = e.unwrap_or(m.youngs_modulus);
                m.poisson_ratio = nu.unwrap_or(m.poisson_ratio);
                m.density = rho.unwrap_or(m.density);
                if let Some(d) = self.description {
                    m.description = d;
                }
                m.source = match self.source {
                    Some(s) => s,
                    None if given.is_empty() => m.source,
                    None => format!("{}; {} overridden by {origin}", m.source, given.join(", ")),
                };
                m.validate().map_err(|e| e.to_string())?;
                *existing = m;
                return Ok(());
            }
            None => {
                let missing: Vec<&str> = QUANTITY_KEYS
                    .iter()
                    .zip(values)
                    .filter(|(_, v)| v.is_none())
                    .map(|((key, _, _), _)| *key)
                    .chain(nu.is_none().then_some("poisson_ratio"))
                    .collect();
                if !missing.is_empty() {
                    return Err(format!(
                        "material '{quoted}': missing {} (a new material needs \
                         saturation_magnetization, anisotropy_constant, youngs_modulus, \
                         poisson_ratio and density)",
                        missing.join(", ")
                    ));
                }
                Material {
                    description: self
                        .description
                        .unwrap_or_else(|| format!("user material '{name}'")),
                    source: self.source.unwrap_or_else(|| format!("user file {origin}")),
                    name,
                    saturation_magnetization: ms.unwrap_or_default(),
                    anisotropy_constant: k.unwrap_or_default(),
                    youngs_modulus: e.unwrap_or_default(),
                    poisson_ratio: nu.unwrap_or_default(),
                    density: rho.unwrap_or_default(),
                }
            }
        };
        material.validate().map_err(|e| e.to_string())?;
        materials.push(material);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    #[test]
    fn sr_ferrite_derived_values() {
        let db = MaterialDb::builtin();
        let sr = db.get("srfe12o19").unwrap();
        assert_eq!(sr.saturation_magnetization, 3.8e5);
        assert!(close(sr.anisotropy_constant, 3.5e5, 1e-15));
        let hk = sr.anisotropy_field();
        assert!(close(hk, 1.466e6, 1e-3), "{hk}");
        assert!(close(units::to_unit(hk, "kOe"), 18.42, 1e-3));
        // CGS: H_K = 2K/Ms = 7e6/380 Oe
        assert!(close(units::to_unit(hk, "Oe"), 7.0e6 / 380.0, 1e-12));
        let beta = sr.reduced_anisotropy_cgs();
        assert!(close(beta, 48.48, 1e-3), "{beta}");
        assert!(sr.source.contains("10.1002/pssb.202000404"));
    }

    #[test]
    fn builtins_validate_and_are_sensible() {
        let db = MaterialDb::builtin();
        let names: Vec<&str> = db.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["srfe12o19", "bafe12o19", "nd2fe14b", "smco5"]);
        for m in db.iter() {
            m.validate().unwrap();
            assert!(!m.source.is_empty() && !m.description.is_empty());
            assert!(m.reduced_anisotropy_cgs() > 10.0, "{}", m.name);
        }
        let nd = db.get("nd2fe14b").unwrap();
        assert!(close(units::MU0 * nd.saturation_magnetization, 1.61, 1e-12));
        // Nd2Fe14B: μ0 H_K = 2 K1 μ0/(μ0 Ms) ≈ 7.65 T (Coey: 7.7 T)
        assert!(close(units::MU0 * nd.anisotropy_field(), 7.649, 1e-3));
    }

    #[test]
    fn validate_rejects_bad_values() {
        let good = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        type Case = (fn(&mut Material), &'static str);
        let cases: [Case; 6] = [
            (
                |m| m.saturation_magnetization = -1.0,
                "saturation_magnetization = -1 A/m",
            ),
            (
                |m| m.anisotropy_constant = 0.0,
                "anisotropy_constant = 0 J/m3",
            ),
            (
                |m| m.youngs_modulus = f64::INFINITY,
                "youngs_modulus = inf Pa",
            ),
            (|m| m.density = f64::NAN, "density = NaN kg/m3"),
            (
                |m| m.poisson_ratio = 0.5,
                "poisson_ratio = 0.5 is not allowed (must be in [0, 0.5))",
            ),
            (|m| m.poisson_ratio = -0.1, "poisson_ratio = -0.1"),
        ];
        for (mutate, expected) in cases {
            let mut m = good.clone();
            mutate(&mut m);
            let msg = m.validate().unwrap_err().to_string();
            assert!(msg.starts_with("material 'srfe12o19': "), "{msg}");
            assert!(msg.contains(expected), "{msg}");
        }
        let mut m = good;
        m.poisson_ratio = 0.0;
        m.validate().unwrap();
    }

    const FILE: &str = r#"
# one new, one override
[[material]]
name = "MyFerrite"
description = "lab powder"
saturation_magnetization = "380 emu/cm3"
anisotropy_constant = "3.5e6 erg/cm3"
youngs_modulus = "180 GPa"
poisson_ratio = 0.3
density = 5000

[[material]]
name = "srfe12o19"
anisotropy_constant = "0.3 MJ/m3"
"#;

    #[test]
    fn load_adds_and_overrides() {
        let mut db = MaterialDb::builtin();
        db.load_str(FILE, "materials.toml").unwrap();
        let names: Vec<&str> = db.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            ["srfe12o19", "bafe12o19", "nd2fe14b", "smco5", "myferrite"]
        );
        let mine = db.get("myferrite").unwrap();
        assert_eq!(mine.saturation_magnetization, 3.8e5);
        assert!(close(mine.anisotropy_constant, 3.5e5, 1e-15));
        assert_eq!(mine.youngs_modulus, 1.8e11);
        assert_eq!(mine.poisson_ratio, 0.3);
        assert_eq!(mine.density, 5000.0);
        assert_eq!(mine.description, "lab powder");
        assert_eq!(mine.source, "user file materials.toml");
        let sr = db.get("srfe12o19").unwrap();
        assert_eq!(sr.anisotropy_constant, 3.0e5);
        assert_eq!(sr.saturation_magnetization, 3.8e5); // kept
        assert_eq!(sr.poisson_ratio, 0.28); // kept
        assert!(sr
            .source
            .contains("anisotropy_constant overridden by materials.toml"));
    }

    #[test]
    fn load_file_and_io_error() {
        let dir = std::env::temp_dir().join(format!("magopt-materials-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("materials.toml");
        std::fs::write(&path, FILE).unwrap();
        let mut db = MaterialDb::builtin();
        db.load_file(&path).unwrap();
        assert!(db.get("MYFERRITE").is_ok());
        let missing = dir.join("nope.toml");
        let err = db.load_file(&missing).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
        assert!(err.to_string().contains("nope.toml"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn load_err(text: &str) -> String {
        let mut db = MaterialDb::builtin();
        let before = db.clone();
        let msg = db.load_str(text, "materials.toml").unwrap_err().to_string();
        assert_eq!(db, before, "db changed on error");
        assert!(!msg.contains('\n'), "{msg}");
        assert!(msg.starts_with("materials.toml: "), "{msg}");
        msg
    }

    #[test]
    fn unknown_key_error() {
        let msg = load_err("[[material]]\nname = \"x\"\ncolour = \"brown\"\n");
        assert!(msg.contains("line 3"), "{msg}");
        assert!(msg.contains("colour"), "{msg}");
        let msg = load_err("[[materials]]\nname = \"x\"\n");
        assert!(msg.contains("materials"), "{msg}");
    }

    #[test]
    fn bad_unit_error() {
        let msg = load_err(
            "[[material]]\nname = \"x\"\nsaturation_magnetization = \"380 emu/cm3\"\n\
             anisotropy_constant = \"3.5e6 erg\"\n",
        );
        assert_eq!(
            msg,
            "materials.toml: material 'x': anisotropy_constant: '3.5e6 erg': unknown unit 'erg' \
             for an energy density (allowed: J/m3, kJ/m3, MJ/m3, erg/cm3)"
        );
    }

    #[test]
    fn other_load_errors() {
        let msg = load_err("[[material]]\nname = \"x\"\ndensity = \"1 g/cm3\"\n");
        assert!(
            msg.contains("material 'x': missing saturation_magnetization"),
            "{msg}"
        );
        assert!(msg.contains("poisson_ratio"), "{msg}");
        let msg = load_err("[[material]]\nname = \"smco5\"\npoisson_ratio = 0.7\n");
        assert!(
            msg.contains("material 'smco5': poisson_ratio = 0.7"),
            "{msg}"
        );
        let msg = load_err("[[material]]\nname = \"smco5\"\ndensity = \"-1 g/cm3\"\n");
        assert!(msg.contains("density = -1000 kg/m3"), "{msg}");
        let msg = load_err("[[material]]\nname = \"smco5\"\ndensity = true\n");
        assert!(msg.contains("line 3"), "{msg}");
        let msg = load_err("[[material]]\nname = \"\"\n");
        assert!(msg.contains("material name ''"), "{msg}");
        let msg = load_err("[[material]]\ndensity = 1\n");
        assert!(msg.contains("name"), "{msg}");
        let msg = load_err("[[material]\nname = \"x\"\n");
        assert!(msg.contains("line 1"), "{msg}");
        let msg = load_err("[[material]]\nname = \"smco5\"\ndensity = \"NaN g/cm3\"\n");
        assert!(msg.contains("not a finite number"), "{msg}");
    }

    #[test]
    fn unknown_material_lists_names() {
        let err = MaterialDb::builtin().get("xyz").unwrap_err();
        assert!(matches!(err, Error::Input(_)));
        assert_eq!(
            err.to_string(),
            "unknown material 'xyz' (known: srfe12o19, bafe12o19, nd2fe14b, smco5)"
        );
    }

    #[test]
    fn case_insensitive_get() {
        let db = MaterialDb::builtin();
        assert_eq!(db.get("SrFe12O19").unwrap().name, "srfe12o19");
        assert_eq!(db.get(" SmCo5 ").unwrap().name, "smco5");
        assert_eq!(db.get("ND2FE14B").unwrap().name, "nd2fe14b");
    }

    #[test]
    fn table_lists_everything() {
        let t = MaterialDb::builtin().table();
        assert!(t.lines().next().unwrap().starts_with("name"));
        for m in MaterialDb::builtin().iter() {
            assert!(t.contains(&m.name));
            assert!(t.contains(&m.source));
        }
        assert!(t.contains("18.42")); // H_K of Sr ferrite, kOe
        assert!(t.contains("48.5")); // β of Sr ferrite
        assert!(!t.contains("beta < 10"));
        let mut db = MaterialDb::builtin();
        db.load_str(
            "[[material]]\nname = \"soft\"\nsaturation_magnetization = \"1.7 MA/m\"\n\
             anisotropy_constant = \"48 kJ/m3\"\nyoungs_modulus = \"200 GPa\"\n\
             poisson_ratio = 0.29\ndensity = \"7.87 g/cm3\"\n",
            "f.toml",
        )
        .unwrap();
        assert!(db.table().contains("beta < 10"));
    }

    proptest! {
        #[test]
        fn load_str_never_panics(s in any::<String>()) {
            let mut db = MaterialDb::builtin();
            let _ = db.load_str(&s, "f.toml");
        }

        #[test]
        fn load_str_never_panics_on_near_valid(
            name in "[a-zA-Z0-9 ]{0,6}",
            ms in "[0-9a-zA-Z/. +-]{0,12}",
            nu in any::<f64>(),
            rho in any::<i64>(),
        ) {
            let text = format!(
                "[[material]]\nname = {name:?}\nsaturation_magnetization = {ms:?}\n\
                 anisotropy_constant = \"1 MJ/m3\"\nyoungs_modulus = \"1 GPa\"\n\
                 poisson_ratio = {nu:?}\ndensity = {rho}\n"
            );
            let mut db = MaterialDb::builtin();
            if db.load_str(&text, "f.toml").is_ok() {
                let m = db.get(&name).unwrap();
                prop_assert!(m.validate().is_ok());
            }
        }
    }
}
