//! Whole-snapshot analysis as `magopt analyze` runs it: structure metrics, coordination,
//! force distributions and fluctuations, optional g(r); tables and pictures for `--out`.

use std::path::Path;

use super::distribution::{force_distributions, relative_fluctuations, SpeciesForces};
use super::force_chain::{force_chain_metrics, ForceChainMetrics};
use super::pair::{coordination, radial_distribution, RadialDistribution};
use super::picture::{cells_picture, force_pdf_figure, force_vector_picture, value_picture};
use super::snapshot::{FrameInfo, Snapshot};
use super::structure::{analyze_full, modulus, Structure, StructureMetrics};
use super::voronoi::TessellationSettings;
use crate::output::atomic::write_json_atomic;
use crate::output::table::{write_parquet_with, ColumnData, Table};
use crate::study::records::VERSION;
use crate::Result;

/// Default relative contact tolerance of the coordination number.
pub const DEFAULT_CONTACT_TOLERANCE: f64 = 0.01;

/// Options of a snapshot analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotOptions {
    /// g(r) up to this distance (m); None: no g(r).
    pub rdf_max: Option<f64>,
    /// Number of g(r) bins (default 100).
    pub rdf_bins: usize,
    /// Two particles touch when closer than (1 + tolerance)(d_i + d_j)/2 (default
    /// [`DEFAULT_CONTACT_TOLERANCE`]).
    pub contact_tolerance: f64,
    /// Tessellation settings.
    pub tessellation: TessellationSettings,
}

impl Default for SnapshotOptions {
    fn default() -> Self {
        Self {
            rdf_max: None,
            rdf_bins: 100,
            contact_tolerance: DEFAULT_CONTACT_TOLERANCE,
            tessellation: TessellationSettings::default(),
        }
    }
}

/// The summary `magopt analyze --json` prints.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SnapshotSummary {
    /// Structure metrics (n5, n6, n7, side histogram, Ψ6, hexagon regularity, counts).
    #[serde(flatten)]
    pub metrics: StructureMetrics,
    /// Mean contact coordination over the counted cells' particles (needs diameters).
    pub coordination_mean: Option<f64>,
    /// Per-species force distributions (needs forces).
    pub forces: Option<Vec<SpeciesForces>>,
    /// Force direction order and neighbour correlation of the fluctuations (needs force
    /// vectors).
    pub force_chains: Option<ForceChainMetrics>,
    /// Radial distribution function (with `rdf_max`).
    pub rdf: Option<RadialDistribution>,
}

/// Everything computed for one snapshot.
#[derive(Debug, Clone)]
pub struct SnapshotAnalysis {
    /// The summary.
    pub summary: SnapshotSummary,
    /// Cells and per-particle order.
    pub structure: Structure,
    /// Contact count per particle (with diameters).
    pub coordination: Option<Vec<usize>>,
    /// |F − F̄_s| / F̄_s per particle (with forces).
    pub fluctuations: Option<Vec<f64>>,
}

/// Analyses one snapshot.
///
/// # Errors
/// [`crate::Error::Input`] for degenerate centres (see [`analyze_full`]), bad diameters or
/// forces, or a g(r) range larger than the sample allows.
pub fn analyze_snapshot(
    snapshot: &Snapshot,
    options: &SnapshotOptions,
) -> Result<SnapshotAnalysis> {
    let structure = analyze_full(&snapshot.positions, &options.tessellation)?;
    let cells = &structure.tessellation.cells;
    let coordination = match &snapshot.diameter {
        Some(d) => Some(coordination(
            &snapshot.positions,
            d,
            options.contact_tolerance,
        )?),
        None => None,
    };
    let coordination_mean = coordination.as_ref().map(|z| {
        let counted: Vec<usize> = (0..z.len()).filter(|i| cells[*i].counted).collect();
        counted.iter().map(|i| z[*i] as f64).sum::<f64>() / counted.len() as f64
    });
    let species = snapshot.species_or_zero();
    let (forces, fluctuations) = match &snapshot.force {
        Some(f) => (
            Some(force_distributions(f, &species)?),
            Some(relative_fluctuations(f, &species)?),
        ),
        None => (None, None),
    };
    let force_chains = match (&snapshot.force_vector, &fluctuations) {
        (Some(v), Some(fl)) => Some(force_chain_metrics(&snapshot.positions, v, fl, cells)),
        _ => None,
    };
    let rdf = match options.rdf_max {
        Some(r) => Some(radial_distribution(
            &snapshot.positions,
            r,
            options.rdf_bins,
        )?),
        None => None,
    };
    Ok(SnapshotAnalysis {
        summary: SnapshotSummary {
            metrics: structure.metrics.clone(),
            coordination_mean,
            forces,
            force_chains,
            rdf,
        },
        structure,
        coordination,
        fluctuations,
    })
}

/// `Some(value)` where `keep`, else None (a missing value is null, never NaN).
fn where_(keep: impl Iterator<Item = bool>, values: impl Iterator<Item = f64>) -> ColumnData {
    ColumnData::OptF64(keep.zip(values).map(|(k, v)| k.then_some(v)).collect())
}

/// Per-cell table: particle, sides, bounded, counted, area (m²), perimeter (m), regularity;
/// area, perimeter and regularity are null for an unbounded cell.
pub fn cell_table(structure: &Structure) -> Table {
    let cells = &structure.tessellation.cells;
    let bounded = || cells.iter().map(|c| c.bounded);
    Table::new()
        .with_unit(
            "particle",
            ColumnData::U64((0..cells.len() as u64).collect()),
            "1",
        )
        .with_unit(
            "sides",
            ColumnData::I64(cells.iter().map(|c| c.sides() as i64).collect()),
            "1",
        )
        .with(
            "bounded",
            ColumnData::Bool(cells.iter().map(|c| c.bounded).collect()),
        )
        .with(
            "counted",
            ColumnData::Bool(cells.iter().map(|c| c.counted).collect()),
        )
        .with_unit(
            "area",
            where_(bounded(), cells.iter().map(|c| c.area())),
            "m2",
        )
        .with_unit(
            "perimeter",
            where_(
                bounded(),
                cells.iter().map(|c| c.side_lengths().iter().sum()),
            ),
            "m",
        )
        .with_unit(
            "regularity",
            where_(bounded(), cells.iter().map(|c| c.regularity())),
            "1",
        )
}

/// Cell corners, one row per corner: particle, corner (counter-clockwise), x, y (m).
pub fn cell_vertex_table(structure: &Structure) -> Table {
    let (mut particle, mut corner, mut x, mut y) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, c) in structure.tessellation.cells.iter().enumerate() {
        for (k, v) in c.vertices.iter().enumerate() {
            particle.push(i as u64);
            corner.push(k as i64);
            x.push(v.x);
            y.push(v.y);
        }
    }
    Table::new()
        .with_unit("particle", ColumnData::U64(particle), "1")
        .with_unit("corner", ColumnData::I64(corner), "1")
        .with_unit("x", ColumnData::F64(x), "m")
        .with_unit("y", ColumnData::F64(y), "m")
}

/// Per-particle table: position, the snapshot's optional columns, side count, counted, |ψ6|
/// (plain and weighted; the weighted one null for an unbounded cell) and its phase,
/// coordination and relative force fluctuation (null where the species' mean force is 0).
pub fn particle_table(snapshot: &Snapshot, analysis: &SnapshotAnalysis) -> Table {
    let s = &analysis.structure;
    let p = &snapshot.positions;
    let mut t = Table::new()
        .with_unit("x", ColumnData::F64(p.iter().map(|v| v.x).collect()), "m")
        .with_unit("y", ColumnData::F64(p.iter().map(|v| v.y).collect()), "m");
    if let Some(d) = &snapshot.diameter {
        t.push_unit("diameter", ColumnData::F64(d.clone()), "m");
    }
    if let Some(sp) = &snapshot.species {
        t.push_unit("species", ColumnData::I64(sp.clone()), "1");
    }
    if let Some(f) = &snapshot.force {
        t.push_unit("force", ColumnData::F64(f.clone()), "N");
    }
    let cells = &s.tessellation.cells;
    t.push_unit(
        "sides",
        ColumnData::I64(cells.iter().map(|c| c.sides() as i64).collect()),
        "1",
    );
    t.push(
        "counted",
        ColumnData::Bool(cells.iter().map(|c| c.counted).collect()),
    );
    t.push_unit(
        "psi6",
        ColumnData::F64(s.order.iter().map(|o| modulus(o.psi6)).collect()),
        "1",
    );
    t.push_unit(
        "psi6_phase",
        ColumnData::F64(s.order.iter().map(|o| o.psi6.1.atan2(o.psi6.0)).collect()),
        "rad",
    );
    t.push_unit(
        "psi6_weighted",
        where_(
            cells.iter().map(|c| c.bounded),
            s.order.iter().map(|o| modulus(o.psi6_weighted)),
        ),
        "1",
    );
    if let Some(z) = &analysis.coordination {
        t.push_unit(
            "coordination",
            ColumnData::I64(z.iter().map(|v| *v as i64).collect()),
            "1",
        );
    }
    if let Some(fl) = &analysis.fluctuations {
        t.push_unit(
            "relative_fluctuation",
            ColumnData::OptF64(
                fl.iter()
                    .map(|v| Some(*v).filter(|v| !v.is_nan()))
                    .collect(),
            ),
            "1",
        );
    }
    t
}

/// Force PDFs, one row per (species, bin): species, lower and upper bin edge (N), count,
/// density (1/N).
fn force_pdf_table(forces: &[SpeciesForces]) -> Table {
    let mut t = Table::new();
    for d in forces {
        let h = &d.histogram;
        let part = Table::new()
            .with_unit(
                "species",
                ColumnData::I64(vec![d.species; h.counts.len()]),
                "1",
            )
            .with_unit(
                "force_lo",
                ColumnData::F64(h.edges[..h.counts.len()].to_vec()),
                "N",
            )
            .with_unit("force_hi", ColumnData::F64(h.edges[1..].to_vec()), "N")
            .with_unit(
                "count",
                ColumnData::U64(h.counts.iter().map(|c| *c as u64).collect()),
                "1",
            )
            .with_unit("density", ColumnData::F64(h.density.clone()), "1/N");
        t.append(&part).expect("same layout for every species");
    }
    t
}

/// Writes into `dir`: summary.json, cells.parquet, cell_vertices.parquet, particles.parquet,
/// cells.png; with forces force_pdf.parquet, force_pdf.png, forces.png and fluctuations.png,
/// with force vectors force_vectors.png;
/// with g(r) rdf.parquet. summary.json and every table record the magopt version and the
/// input (`source`: path, format, size, frame) — the tables as Parquet key-value metadata
/// `magopt.version` and `magopt.input` (JSON).
///
/// # Errors
/// [`crate::Error::Io`] or [`crate::Error::Output`] if a file cannot be written.
pub fn write_outputs(
    dir: &Path,
    snapshot: &Snapshot,
    analysis: &SnapshotAnalysis,
    source: &FrameInfo,
) -> Result<()> {
    let mut summary = serde_json::to_value(&analysis.summary)
        .map_err(|e| crate::Error::Output(format!("cannot serialize the summary: {e}")))?;
    let input = serde_json::to_value(source)
        .map_err(|e| crate::Error::Output(format!("cannot serialize the input: {e}")))?;
    summary["magopt_version"] = VERSION.into();
    summary["input"] = input.clone();
    write_json_atomic(&dir.join("summary.json"), &summary)?;
    let meta = [
        ("magopt.version".to_string(), VERSION.to_string()),
        ("magopt.input".to_string(), input.to_string()),
    ];
    let write_parquet = |path: &Path, table: &Table| write_parquet_with(path, table, &meta);
    write_parquet(&dir.join("cells.parquet"), &cell_table(&analysis.structure))?;
    write_parquet(
        &dir.join("cell_vertices.parquet"),
        &cell_vertex_table(&analysis.structure),
    )?;
    write_parquet(
        &dir.join("particles.parquet"),
        &particle_table(snapshot, analysis),
    )?;
    cells_picture(&dir.join("cells.png"), snapshot, &analysis.structure)?;
    if let (Some(f), Some(dists)) = (&snapshot.force, &analysis.summary.forces) {
        let s = &analysis.structure;
        write_parquet(&dir.join("force_pdf.parquet"), &force_pdf_table(dists))?;
        force_pdf_figure(&dir.join("force_pdf.png"), dists)?;
        value_picture(
            &dir.join("forces.png"),
            snapshot,
            s,
            f,
            "Particles coloured by force",
            "force (N)",
        )?;
        if let Some(v) = &snapshot.force_vector {
            force_vector_picture(&dir.join("force_vectors.png"), snapshot, s, v)?;
        }
        if let Some(fl) = &analysis.fluctuations {
            let title = "Relative force fluctuation |F − F̄_s| / F̄_s";
            value_picture(
                &dir.join("fluctuations.png"),
                snapshot,
                s,
                fl,
                title,
                "|F − F̄_s| / F̄_s",
            )?;
        }
    }
    if let Some(rdf) = &analysis.summary.rdf {
        let t = Table::new()
            .with_unit("r", ColumnData::F64(rdf.r.clone()), "m")
            .with_unit("g", ColumnData::F64(rdf.g.clone()), "1");
        write_parquet(&dir.join("rdf.parquet"), &t)?;
    }
    Ok(())
}
