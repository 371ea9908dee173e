//! Parameters of the `bed` model (spec bed.md): geometry, particles, physics switches,
//! protocol and numerics, all SI. [`BedParams::resolve`] turns them into the concrete cell and
//! species of one run (presets, size scaling by √a, packing-fraction heights).

use serde::{Deserialize, Serialize};

use crate::units::MU0;

/// Which geometry and species defaults apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// N = 368 discs of D = 6 mm in W × H = 0.36 m × 0.45 m.
    Mono,
    /// N = 400, big D1 = 5 mm, small a·D1, W = 66 D1 = 0.33 m, H = 0.445 m.
    Bidisperse,
}

/// Friction with the glass plates (B3, B5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Friction {
    /// No friction (the relaxation stage is still damped).
    None,
    /// Viscous F = −γ v (B3).
    Viscous,
    /// Regularized Coulomb with the stick rule (B4, B5).
    Dry,
    /// Viscous and dry together.
    Both,
}

impl Friction {
    /// Whether the viscous law (B3) acts.
    pub fn viscous(self) -> bool {
        matches!(self, Friction::Viscous | Friction::Both)
    }
    /// Whether dry friction (B4–B5) acts.
    pub fn dry(self) -> bool {
        matches!(self, Friction::Dry | Friction::Both)
    }
}

/// Order of the tilt-torque normal force (B4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TiltOrder {
    /// cos θ_i sin θ_j (the spec's first-order law).
    First,
    /// Adds the (μ̂_i × μ̂_j) torque: sin 2θ → sin 2θ + (2/3) sin θ for equal discs.
    Second,
}

/// Particle–wall law (B2 and its physical alternatives).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WallLaw {
    /// (μ0 μ_i M_w / 2π) / w^3.5 with M_w = 2 μ_1/√D_1 unless `wall_strength` is set (B2).
    Empirical,
    /// Infinite row of touching reference magnets: μ0 μ_i (μ_1/D_1)/(π w³).
    InfiniteRow,
    /// Finite bar of the wall's length (the spec's closed form).
    FiniteBar,
}

/// Neighbour handling of the pair sums (B1, B4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Neighbors {
    /// Every pair (the reference).
    Exact,
    /// Cell list with cut-off r_c, rebuilt every step.
    Cells,
    /// Verlet list of radius r_v ≥ r_c, rebuilt on half-skin displacement.
    Verlet,
    /// The source's variant (de Paula 2025, §5.1, Eq. (5.4)): every pair in a list of radius
    /// r_v is summed (r_c = r_v, no distance check), and the list is rebuilt only once some
    /// disc has moved `rebuild_skin` since the last build (its Eq. (5.3)). Between builds it
    /// keeps pairs that have left r_v and misses pairs that have entered it.
    SourceVerlet,
    /// No cut-off: pairs closer than `near_cutoff` r_s from a Verlet list every step, every
    /// pair beyond it from a Barnes–Hut quadtree with quadrupoles (opening angle
    /// `opening_angle`) every `far_field_interval` steps (docs/bed.md, "Far field").
    Tree,
}

/// What stands for the pairs beyond the cut-off r_c of a list (docs/bed.md, "Tail correction").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TailCorrection {
    /// `mean-field` where the sums are cut off sharply (`verlet`, `cells`), `none` otherwise
    /// (the default since 2026-12-04; before it, `none`).
    Auto,
    /// Nothing: the sums are truncated at r_c.
    None,
    /// The discs beyond r_c spread evenly within height bands of r_c/2 of the bed's region
    /// (its discs' bounding box widened by half their mean spacing): closed-form tails of the
    /// B1 and B4 sums, added to every disc's list sums (`verlet` and `cells` only).
    MeanField,
}

impl Neighbors {
    /// Whether the pair sums stop sharply at r_c (`verlet`, `cells`): the modes a tail
    /// beyond r_c stands for the rest of.
    pub fn cuts_sharply(self) -> bool {
        matches!(self, Self::Verlet | Self::Cells)
    }
}

impl TailCorrection {
    /// Whether the mean-field tail is added to the list sums of `neighbors`.
    pub fn applies(self, neighbors: Neighbors) -> bool {
        match self {
            Self::Auto => neighbors.cuts_sharply(),
            Self::None => false,
            Self::MeanField => true,
        }
    }
}

/// How dry friction is integrated (see `integrator`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrictionScheme {
    /// Stick rule + backward-Euler slip law (the production scheme).
    SemiImplicit,
    /// Forward-Euler B5 (the small-step reference; Δt also limited by m v_t/(μ_d N)).
    Explicit,
}

/// φ_max of the source's mono-disperse protocol: with H0 = H, φ(H0 − ¾(H0 − H_f)) = 0.14 gives
/// H_f = (A/(0.14 W) − H/4)/0.75, i.e. φ_max = 0.2307 at every N (docs/bed-protocol.md).
pub const SOURCE_MONO_MAX_PACKING: f64 = 0.2307;

/// How a cycle sets the piston heights H0 (start of compression) and H_f (maximum
/// compression); docs/bed-protocol.md derives the source's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Heights {
    /// The source's protocol: H0 = H, the top of the cell (every run of de Paula 2025,
    /// Table A.1 compresses over H − H_f), H_f at `max_packing_fraction` [mono-disperse
    /// default 0.2307, derived in docs/bed-protocol.md; bi-disperse 0.34].
    Source,
    /// H0 at `start_packing_fraction`, H_f at `max_packing_fraction` (the spec's first
    /// defaults, 0.12 → 0.34).
    PackingFractions,
}

/// A distance given in units of D_1 (the usual way) or as an absolute length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Reach {
    /// Multiples of the reference diameter D_1.
    Diameters(f64),
    /// An absolute length, m.
    Length(f64),
}

impl Reach {
    /// The reach in units of D_1.
    pub fn diameters(self, d1: f64) -> f64 {
        match self {
            Reach::Diameters(x) => x,
            Reach::Length(l) => l / d1,
        }
    }
}

/// One species: diameter and number fraction (same material and thickness for all).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Species {
    /// Disc diameter D_s, m.
    pub diameter: f64,
    /// Number fraction (normalized over the species list).
    pub fraction: f64,
}

/// Everything one `bed` or `damper` run needs. Optional fields fall back on the preset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BedParams {
    /// Geometry and species defaults.
    pub preset: Preset,
    /// Particle count N [preset: 368 mono, 400 bi-disperse]; the cell scales by √(N/N_preset).
    pub particles: Option<usize>,
    /// Reference (big) diameter D_1, m [preset: 6 mm mono, 5 mm bi-disperse].
    pub big_diameter: Option<f64>,
    /// Mixing ratio R = fraction of small particles (bi-disperse), in [0, 1].
    pub mixing_ratio: f64,
    /// Aspect ratio a = D_2/D_1 of the bi-disperse species, in (0, 1].
    pub aspect_ratio: f64,
    /// Explicit species list (overrides the preset's species); the first is the reference.
    pub species: Option<Vec<Species>>,
    /// Cell width W for the preset's N, m [preset: 0.36 m mono, 66 D_1 bi-disperse].
    pub width: Option<f64>,
    /// Cell height H for the preset's N, m [preset: 0.45 m mono, 0.445 m bi-disperse].
    pub height: Option<f64>,
    /// Gap E between the glass plates, m (3.1 mm); must exceed the thickness.
    pub gap: f64,
    /// Disc thickness ε, m (3 mm).
    pub thickness: f64,
    /// Density ρ, kg/m³ (7368).
    pub density: f64,
    /// Remanence B_r, T (1.3).
    pub remanence: f64,
    /// Static friction coefficient μ_e (0.6).
    pub static_friction: f64,
    /// Dynamic friction coefficient μ_d (0.45).
    pub dynamic_friction: f64,
    /// Gravity g, m/s² (9.8); 0 is the no-gravity variant.
    pub gravity: f64,
    /// Friction model.
    pub friction: Friction,
    /// Tilt-torque order of the normal force (B4).
    pub tilt_order: TiltOrder,
    /// Viscous time τ_v = m/γ, s (0.1 s, B3); also damps every relaxation.
    pub viscous_time: f64,
    /// Threshold speed v_t of the regularized Coulomb law, m/s (1e-6, B5).
    pub threshold_speed: f64,
    /// Dry-friction integration scheme (semi-implicit; explicit is the reference).
    pub friction_scheme: FrictionScheme,
    /// Particle–wall law.
    pub wall_law: WallLaw,
    /// Wall strength M_w of the empirical law, A·m^1.5 [default 2 μ_1/√D_1].
    pub wall_strength: Option<f64>,
    /// Piston speed V_c during compression and expansion, m/s (5.63 mm/s).
    pub piston_speed: f64,
    /// How H0 and H_f are set (source: H0 = H; packing-fractions: from φ_start).
    pub heights: Heights,
    /// Packing fraction at the start of compression (piston at H0) with
    /// `heights = packing-fractions` (0.12).
    pub start_packing_fraction: f64,
    /// Packing fraction at maximum compression (piston at H_f) [see
    /// [`BedParams::max_packing_fraction`]].
    pub max_packing_fraction: Option<f64>,
    /// Piston force at which the compression stops instead of at H_f (which is then only the
    /// lowest the piston may go), N [none; the experiments de Paula 2025, §4.2.2 cites
    /// compressed to 110 N].
    pub target_force: Option<f64>,
    /// Duration of the piston's exponentially slowing descent to H0, s (3 s).
    pub relaxation_time: f64,
    /// Decay time of that descent, s (0.5 s).
    pub piston_decay_time: f64,
    /// Rest at H0 after the descent, before compression, s (1 s).
    pub settle_time: f64,
    /// Optional rest after the expansion, s (0).
    pub final_rest: f64,
    /// Standard deviation of each initial velocity component, m/s (1e-2).
    pub initial_speed: f64,
    /// Neighbour strategy.
    pub neighbors: Neighbors,
    /// Cut-off r_c in units of D_1 (7.13: r_v − r_s of the source's runs; the source itself
    /// summed its whole list, see `Neighbors::SourceVerlet`).
    pub cutoff: Reach,
    /// Verlet list radius r_v in units of D_1 (8; the source used 11.26). With `verlet` r_v
    /// changes no result, only the speed: the pairs inside r_c are the same and are summed in
    /// the same order; with `source-verlet` it is the radius of the sums. A thinner skin means a shorter pair loop and more frequent rebuilds;
    /// 8 D was the faster of 8, 9 and 11.26 at N = 10⁴ (README, bed benchmark).
    pub list_radius: Reach,
    /// Skin r_s of the source's Verlet variant in units of D_1 (4.13, de Paula 2025, §5.1: the
    /// distance at which the pair force equals a disc's weight): its list is rebuilt when some
    /// disc has moved r_s since the last build.
    pub rebuild_skin: Reach,
    /// Multiple time stepping: pairs beyond `near_cutoff` are summed every this many steps and
    /// held in between (1: every pair every step, the default; needs Verlet lists).
    pub far_field_interval: usize,
    /// Near cut-off r_s in units of D_1 of the multiple time stepping and of `tree` (3;
    /// 0 < r_s, and r_s < r_c with `verlet`).
    pub near_cutoff: Reach,
    /// What stands for the pairs beyond r_c of `verlet` and `cells` (auto: the mean-field
    /// tail with them, nothing with the other neighbour modes).
    pub tail_correction: TailCorrection,
    /// Opening angle θ of `tree`: a group of discs acts through its multipoles when its extent
    /// is below θ times its gap to the summing leaf (0.5; 0 sums every pair exactly).
    pub opening_angle: f64,
    /// Δt = factor / ω_max, ω_max² the stiffest repulsion (pair or wall) at the closest
    /// approach over the lightest mass; the step is chosen anew every step [default: 0.4 with
    /// dry friction, 0.2 without it and for the damper; see [`Self::time_step_factor`]].
    pub time_step_factor: Option<f64>,
    /// Upper bound on Δt, s (1 ms).
    pub max_time_step: f64,
    /// Interval between recorded series points, s [default 0.05 s up to the preset's N, then
    /// × √(N/N_preset)]: with the √N size scaling the cycle lasts ∝ √N, so every size gets the
    /// same number of points per cycle, and the O(N²) D̂ of each point stays affordable.
    pub record_interval: Option<f64>,
    /// Flag a run when two discs come closer than this fraction of their mean diameter (0.9).
    pub min_distance_ratio: f64,
    /// Steps after which a run fails instead of going on (1e7: a 10⁴-disc cycle at the
    /// defaults takes 8.5e5), so that no setting can make a run hang.
    pub max_steps: usize,
    /// Collect snapshots (start of compression, maximum compression, end).
    pub snapshots: bool,
    /// Damper: piston mass, kg (200 g; a piston much heavier than the bed can carry crushes it).
    pub piston_mass: f64,
    /// Damper: duration of each of the two free motions, s (2 s).
    pub damper_time: f64,
    /// Damper: sampling interval of z(t), s (1 ms).
    pub damper_record_interval: f64,
}

impl BedParams {
    /// The documented defaults (mono-disperse cycle).
    pub fn defaults() -> Self {
        Self {
            preset: Preset::Mono,
            particles: None,
            big_diameter: None,
            mixing_ratio: 0.0,
            aspect_ratio: 0.5,
            species: None,
            width: None,
            height: None,
            gap: 3.1e-3,
            thickness: 3.0e-3,
            density: 7368.0,
            remanence: 1.3,
            static_friction: 0.6,
            dynamic_friction: 0.45,
            gravity: 9.8,
            friction: Friction::Dry,
            tilt_order: TiltOrder::First,
            viscous_time: 0.1,
            threshold_speed: 1e-6,
            friction_scheme: FrictionScheme::SemiImplicit,
            wall_law: WallLaw::Empirical,
            wall_strength: None,
            piston_speed: 5.63e-3,
            heights: Heights::Source,
            start_packing_fraction: 0.12,
            max_packing_fraction: None,
            target_force: None,
            relaxation_time: 3.0,
            piston_decay_time: 0.5,
            settle_time: 1.0,
            final_rest: 0.0,
            initial_speed: 1e-2,
            neighbors: Neighbors::Verlet,
            cutoff: Reach::Diameters(7.13),
            list_radius: Reach::Diameters(8.0),
            rebuild_skin: Reach::Diameters(4.13),
            far_field_interval: 1,
            near_cutoff: Reach::Diameters(3.0),
            tail_correction: TailCorrection::Auto,
            opening_angle: 0.5,
            time_step_factor: None,
            max_time_step: 1e-3,
            record_interval: None,
            min_distance_ratio: 0.9,
            max_steps: 10_000_000,
            snapshots: true,
            piston_mass: 0.2,
            damper_time: 2.0,
            damper_record_interval: 1e-3,
        }
    }

    /// The species list of this run (reference first), normalized fractions.
    pub fn species_list(&self) -> Vec<Species> {
        let d1 = self.reference_diameter();
        let list = match (&self.species, self.preset) {
            (Some(list), _) => list.clone(),
            (None, Preset::Mono) => vec![Species {
                diameter: d1,
                fraction: 1.0,
            }],
            (None, Preset::Bidisperse) => vec![
                Species {
                    diameter: d1,
                    fraction: 1.0 - self.mixing_ratio,
                },
                Species {
                    diameter: self.aspect_ratio * d1,
                    fraction: self.mixing_ratio,
                },
            ],
        };
        let total: f64 = list.iter().map(|s| s.fraction).sum();
        list.into_iter()
            .map(|s| Species {
                diameter: s.diameter,
                fraction: s.fraction / total,
            })
            .collect()
    }

    /// D_1: the explicit big diameter, else the first listed species, else the preset's.
    pub fn reference_diameter(&self) -> f64 {
        match (self.big_diameter, &self.species, self.preset) {
            (Some(d), ..) => d,
            (None, Some(list), _) if !list.is_empty() => list[0].diameter,
            (None, _, Preset::Mono) => 6e-3,
            (None, _, Preset::Bidisperse) => 5e-3,
        }
    }

    /// The preset's particle count (the size-scaling reference).
    pub fn reference_particles(&self) -> usize {
        match self.preset {
            Preset::Mono => 368,
            Preset::Bidisperse => 400,
        }
    }

    /// Particle count N of this run.
    pub fn particle_count(&self) -> usize {
        self.particles.unwrap_or(self.reference_particles())
    }

    /// Cell (W, H), m, scaled by √(N/N_preset) (packing fraction unchanged).
    pub fn cell(&self) -> (f64, f64) {
        let d1 = self.reference_diameter();
        let (w, h) = match self.preset {
            Preset::Mono => (0.36, 0.45),
            Preset::Bidisperse => (66.0 * d1, 0.445),
        };
        let scale = (self.particle_count() as f64 / self.reference_particles() as f64).sqrt();
        (
            self.width.unwrap_or(w) * scale,
            self.height.unwrap_or(h) * scale,
        )
    }

    /// The time-step factor (see the field `time_step_factor`). Its default is 0.4 where dry
    /// friction acts (0.2 until 2026-12-05): dry friction damps the fast modes, and exact-sum
    /// cycles at 0.4 keep factor 0.2's F_max to 0.02 % and the work to 0.06 % (sd over 12 seeds
    /// at N = 368), 50× below the scatter between seeds, in 0.7 of the time. Without it 0.2: the
    /// small work left in a frictionless cycle falls by 10 % at 0.4 and a viscous cycle's rises
    /// by 3.5 % (8 seeds); the damper sets 0.2 itself (docs/bed.md, "Integration").
    pub fn time_step_factor(&self) -> f64 {
        let damped = self.friction.dry() && self.dynamic_friction > 0.0;
        self.time_step_factor
            .unwrap_or(if damped { 0.4 } else { 0.2 })
    }

    /// Interval between recorded series points, s (see the field `record_interval`).
    pub fn record_interval(&self) -> f64 {
        let scale = self.particle_count() as f64 / self.reference_particles() as f64;
        self.record_interval.unwrap_or(0.05 * scale.max(1.0).sqrt())
    }

    /// Dipole moment μ = B_r V/μ0 of a disc of diameter d, A·m².
    pub fn moment(&self, d: f64) -> f64 {
        self.remanence * self.disc_volume(d) / MU0
    }

    /// Mass ρ V of a disc of diameter d, kg.
    pub fn mass(&self, d: f64) -> f64 {
        self.density * self.disc_volume(d)
    }

    fn disc_volume(&self, d: f64) -> f64 {
        std::f64::consts::PI * d * d * self.thickness / 4.0
    }

    /// φ at maximum compression: the given value, else 0.2307 for the mono-disperse preset with
    /// `heights = source` (docs/bed-protocol.md: φ ≈ 0.14 at 3/4 of the stroke from H0 = H,
    /// de Paula 2025, Figs. 3.9–3.10) and 0.34 otherwise (its §4.3 and Table A.1: H_r = 14 D1).
    pub fn max_packing_fraction(&self) -> f64 {
        let source_mono = self.heights == Heights::Source && self.preset == Preset::Mono;
        self.max_packing_fraction.unwrap_or(if source_mono {
            SOURCE_MONO_MAX_PACKING
        } else {
            0.34
        })
    }

    /// Wall strength M_w of the empirical law (B2), A·m^1.5.
    pub fn wall_strength(&self) -> f64 {
        let d1 = self.reference_diameter();
        self.wall_strength
            .unwrap_or(2.0 * self.moment(d1) / d1.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `auto` adds the tail exactly where the sums have a sharp cut-off; `mean-field` is
    /// refused elsewhere by validation (tests/inputs/bad/study-bed-tail-without-cutoff.toml).
    #[test]
    fn the_automatic_tail_goes_with_the_cut_off_lists_only() {
        use Neighbors::*;
        let cut = [
            (Exact, false),
            (Cells, true),
            (Verlet, true),
            (SourceVerlet, false),
            (Tree, false),
        ];
        for (neighbors, sharp) in cut {
            assert_eq!(
                TailCorrection::Auto.applies(neighbors),
                sharp,
                "{neighbors:?}"
            );
            assert!(!TailCorrection::None.applies(neighbors));
        }
        assert_eq!(BedParams::defaults().tail_correction, TailCorrection::Auto);
    }

    /// The longer default step only where dry friction damps the fast modes; a given factor
    /// always wins.
    #[test]
    fn the_default_time_step_factor_follows_the_dry_friction() {
        let with = |friction, dynamic_friction, factor| {
            let p = BedParams {
                friction,
                dynamic_friction,
                time_step_factor: factor,
                ..BedParams::defaults()
            };
            p.time_step_factor()
        };
        assert_eq!(with(Friction::Dry, 0.45, None), 0.4);
        assert_eq!(with(Friction::Both, 0.45, None), 0.4);
        assert_eq!(with(Friction::Dry, 0.0, None), 0.2);
        assert_eq!(with(Friction::Viscous, 0.45, None), 0.2);
        assert_eq!(with(Friction::None, 0.45, None), 0.2);
        assert_eq!(with(Friction::Dry, 0.45, Some(0.1)), 0.1);
    }
}
