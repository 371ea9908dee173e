//! `magopt analyze FILE`: structure, order and force analysis of a 2D snapshot.

use clap::Args;
use std::path::PathBuf;

use super::count;
use crate::analysis::report::{analyze_snapshot, write_outputs, SnapshotOptions, SnapshotSummary};
use crate::analysis::snapshot::Snapshot;
use crate::analysis::voronoi::TessellationSettings;
use crate::output::atomic;
use crate::units::{parse_quantity, Dimension};
use crate::{Error, Result};

/// `magopt analyze` options.
#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// Snapshot, by extension: Parquet (.parquet/.pq) or CSV (.csv) with columns x, y (m) and
    /// optional diameter (m), species (integer), force (N), or magopt's particle table; extended
    /// XYZ (.xyz/.extxyz) or LAMMPS dump (.dump/.lammpstrj) as magopt writes them.
    file: PathBuf,
    /// Frame of a multi-frame XYZ or dump file: 0 the first, negative counted from the end
    /// (-1, the default, the last).
    #[arg(long, allow_hyphen_values = true, default_value_t = -1, value_name = "K")]
    frame: isize,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Directory for tables (Parquet), pictures (PNG) and summary.json.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Compute g(r) up to this distance (nm, um, mm, m; bare number: m).
    #[arg(long, allow_hyphen_values = true, value_name = "LENGTH")]
    rdf_max: Option<String>,
    /// Number of g(r) bins.
    #[arg(long, allow_hyphen_values = true, default_value = "100")]
    rdf_bins: String,
    /// Relative contact tolerance of the coordination number: touching when closer than
    /// (1 + tolerance)(d_i + d_j)/2.
    #[arg(long, allow_hyphen_values = true, default_value_t = crate::analysis::report::DEFAULT_CONTACT_TOLERANCE)]
    contact_tolerance: f64,
    /// Voronoi sides shorter than this fraction of the mean neighbour distance are merged into
    /// a corner (only exactly co-circular centres are affected at the default).
    #[arg(long, allow_hyphen_values = true, default_value_t = crate::analysis::voronoi::DEFAULT_MERGE_TOLERANCE)]
    merge_tolerance: f64,
}

impl AnalyzeArgs {
    fn options(&self) -> Result<SnapshotOptions> {
        let rdf_max = match &self.rdf_max {
            Some(text) => {
                let r = parse_quantity(text, Dimension::Length, "m")
                    .map_err(|e| Error::input(format!("--rdf-max: {e}")))?;
                if !(r.is_finite() && r > 0.0) {
                    return Err(Error::input(format!(
                        "--rdf-max: {text} is not allowed (need a length > 0)"
                    )));
                }
                Some(r)
            }
            None => None,
        };
        if !(self.contact_tolerance.is_finite() && self.contact_tolerance >= 0.0) {
            return Err(Error::input(format!(
                "--contact-tolerance: {} is not allowed (need a number ≥ 0)",
                self.contact_tolerance
            )));
        }
        if !(self.merge_tolerance.is_finite() && (0.0..1.0).contains(&self.merge_tolerance)) {
            return Err(Error::input(format!(
                "--merge-tolerance: {} is not allowed (need a number in [0, 1))",
                self.merge_tolerance
            )));
        }
        Ok(SnapshotOptions {
            rdf_max,
            rdf_bins: count("rdf-bins", &self.rdf_bins)?,
            contact_tolerance: self.contact_tolerance,
            tessellation: TessellationSettings {
                merge_tolerance: self.merge_tolerance,
            },
        })
    }
}

/// Runs the analysis and prints the summary (or JSON); writes tables and pictures to --out.
pub fn run(args: &AnalyzeArgs) -> Result<()> {
    let options = args.options()?;
    let (snapshot, source) = Snapshot::read_frame(&args.file, args.frame)?;
    let analysis = analyze_snapshot(&snapshot, &options)
        .map_err(|e| Error::input(format!("{}: {e}", args.file.display())))?;
    if let Some(dir) = &args.out {
        atomic::prepare_output_dir(dir)?;
        write_outputs(dir, &snapshot, &analysis, &source)?;
    }
    if args.json {
        let text = serde_json::to_string(&analysis.summary)
            .map_err(|e| Error::Output(format!("cannot serialize the summary: {e}")))?;
        println!("{text}");
    } else {
        print_summary(&args.file, &analysis.summary);
    }
    Ok(())
}

fn print_summary(file: &std::path::Path, s: &SnapshotSummary) {
    let m = &s.metrics;
    println!(
        "{}: {} particles, {} cells counted (border rule)",
        file.display(),
        m.particles,
        m.cells_counted
    );
    println!(
        "n5 (≤5 sides) = {:.4}, n6 = {:.4}, n7 (≥7 sides) = {:.4}",
        m.n5, m.n6, m.n7
    );
    let hist: Vec<String> = m
        .side_histogram
        .iter()
        .map(|(k, v)| format!("{k}: {v}"))
        .collect();
    println!("side counts: {}", hist.join(", "));
    println!(
        "Ψ6 = {:.4} (side-length weighted: {:.4})",
        m.psi6, m.psi6_weighted
    );
    println!(
        "hexagon regularity R = {:.4} ± {:.4} over {} hexagons",
        m.hexagon_regularity_mean, m.hexagon_regularity_std, m.hexagons
    );
    if let Some(z) = s.coordination_mean {
        println!("mean coordination (counted cells) = {z:.3}");
    }
    for d in s.forces.iter().flatten() {
        println!(
            "species {}: {} particles, mean force {:.4e} N, {} Knuth bins",
            d.species,
            d.count,
            d.mean,
            d.histogram.counts.len()
        );
    }
    if let Some(rdf) = &s.rdf {
        let (k, g) = rdf
            .g
            .iter()
            .enumerate()
            .fold(
                (0, f64::NEG_INFINITY),
                |b, (k, g)| if *g > b.1 { (k, *g) } else { b },
            );
        println!(
            "g(r): highest peak g = {g:.3} at r = {:.4e} m ({} reference particles)",
            rdf.r[k], rdf.reference_particles
        );
    }
}
