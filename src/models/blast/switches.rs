//! The interaction switches of the blast model (C4–C8, rotation, thermal softening), as a
//! set parsed from and printed as a comma-separated list.

/// Which interaction terms are on (interacting model only); all off = non-interacting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Interactions {
    /// Normal contact force with contact area (C4).
    pub contact: bool,
    /// Contact damping (C5).
    pub damping: bool,
    /// Regularized stick/slip friction at the contact point (C6).
    pub friction: bool,
    /// Bonding past the strain ε* (C7).
    pub bonding: bool,
    /// Near-field attraction/repulsion (C8).
    pub near_field: bool,
    /// Rotational degrees of freedom (I = 2/5 m R²) driven by contact moments.
    pub rotation: bool,
    /// Thermal softening of the contact stiffness (C4).
    pub thermal_softening: bool,
}

/// Names of the interaction terms, as `interactions` lists them.
pub const INTERACTION_NAMES: [&str; 7] = [
    "contact",
    "damping",
    "friction",
    "bonding",
    "near-field",
    "rotation",
    "thermal-softening",
];

impl Interactions {
    /// Every term of the spec's interacting example.
    pub fn all() -> Self {
        Self {
            contact: true,
            damping: true,
            friction: true,
            bonding: true,
            near_field: true,
            rotation: true,
            thermal_softening: true,
        }
    }

    /// Whether any interaction is on.
    pub fn any(&self) -> bool {
        self.contact || self.damping || self.friction || self.bonding || self.near_field
    }

    /// Parses "none", "all" or a comma-separated list of [`INTERACTION_NAMES`].
    pub fn parse(text: &str) -> std::result::Result<Self, String> {
        let text = text.trim();
        match text {
            "none" | "" => return Ok(Self::default()),
            "all" => return Ok(Self::all()),
            _ => {}
        }
        let mut s = Self::default();
        for name in text.split(',').map(str::trim) {
            let flag = match name {
                "contact" => &mut s.contact,
                "damping" => &mut s.damping,
                "friction" => &mut s.friction,
                "bonding" => &mut s.bonding,
                "near-field" => &mut s.near_field,
                "rotation" => &mut s.rotation,
                "thermal-softening" => &mut s.thermal_softening,
                other => {
                    return Err(format!(
                        "'{other}' is not an interaction (allowed: none, all, or a list of {})",
                        INTERACTION_NAMES.join(", ")
                    ))
                }
            };
            *flag = true;
        }
        Ok(s)
    }

    /// Canonical text ("none" or the list in [`INTERACTION_NAMES`] order).
    pub fn label(&self) -> String {
        let flags = [
            self.contact,
            self.damping,
            self.friction,
            self.bonding,
            self.near_field,
            self.rotation,
            self.thermal_softening,
        ];
        let on: Vec<&str> = INTERACTION_NAMES
            .iter()
            .zip(flags)
            .filter(|(_, f)| *f)
            .map(|(n, _)| *n)
            .collect();
        if on.is_empty() {
            "none".into()
        } else {
            on.join(",")
        }
    }
}
