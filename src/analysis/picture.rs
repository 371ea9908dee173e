//! Pictures of a 2D snapshot: Voronoi cells coloured by side count (hexagons shaded by their
//! regularity), particles coloured by force or by its relative fluctuation, force vectors as
//! arrows, force PDFs.

use std::path::Path;

use super::distribution::SpeciesForces;
use nalgebra::Vector2;

use super::snapshot::Snapshot;
use super::structure::Structure;
use super::voronoi::Cell;
use crate::output::plot::{render_png, Figure, Series, SeriesStyle};
use crate::output::shapes::{render_canvas_png, viridis, Canvas, ColorBar, Rgb, Shape};
use crate::Result;

/// Picture width in pixels.
const WIDTH: u32 = 1600;
/// Cells that fail the border rule.
const NOT_COUNTED: Rgb = (228, 228, 228);
/// Side counts ≤ 4, 5, 7, ≥ 8.
const FEW: Rgb = (130, 90, 170);
const FIVE: Rgb = (70, 120, 210);
const SEVEN: Rgb = (220, 60, 50);
const MANY: Rgb = (245, 160, 40);
/// Hexagon shades from most to least regular, with their lower regularity bounds.
const HEXAGONS: [(f64, Rgb); 4] = [
    (0.98, (0, 100, 30)),
    (0.95, (40, 150, 60)),
    (0.90, (120, 200, 110)),
    (f64::NEG_INFINITY, (200, 235, 185)),
];

/// Fill colour of a cell.
fn cell_colour(cell: &Cell) -> Rgb {
    if !cell.counted {
        return NOT_COUNTED;
    }
    match cell.sides() {
        0..=4 => FEW,
        5 => FIVE,
        6 => {
            let r = cell.regularity();
            HEXAGONS
                .iter()
                .find(|(lo, _)| r >= *lo)
                .map_or(HEXAGONS[3].1, |(_, c)| *c)
        }
        7 => SEVEN,
        _ => MANY,
    }
}

/// Mean distance between Voronoi neighbours (m).
fn mean_bond(snapshot: &Snapshot, structure: &Structure) -> f64 {
    let p = &snapshot.positions;
    let (mut sum, mut count) = (0.0, 0usize);
    for (i, c) in structure.tessellation.cells.iter().enumerate() {
        for &j in &c.neighbors {
            sum += (p[j as usize] - p[i]).norm();
            count += 1;
        }
    }
    sum / count.max(1) as f64
}

/// Drawing radius of each particle: half its diameter, or `fraction` of the mean neighbour
/// distance when the snapshot has no diameters.
fn radii(snapshot: &Snapshot, structure: &Structure, fraction: f64) -> Vec<f64> {
    match &snapshot.diameter {
        Some(d) => d.iter().map(|v| 0.5 * v).collect(),
        None => vec![fraction * mean_bond(snapshot, structure); snapshot.len()],
    }
}

/// Voronoi cells coloured by side count, particles as grey discs. Cells not counted are drawn
/// only when they lie within one mean neighbour distance of the rectangle of the centres (hull
/// cells can reach far out).
pub fn cells_picture(path: &Path, snapshot: &Snapshot, structure: &Structure) -> Result<()> {
    let margin = mean_bond(snapshot, structure);
    let (lo, hi) = structure.tessellation.bounds;
    let in_view = |c: &&Cell| {
        c.counted
            || c.vertices.iter().all(|v| {
                v.x >= lo.x - margin
                    && v.x <= hi.x + margin
                    && v.y >= lo.y - margin
                    && v.y <= hi.y + margin
            })
    };
    let mut shapes: Vec<Shape> = structure
        .tessellation
        .cells
        .iter()
        .filter(|c| c.bounded)
        .filter(in_view)
        .map(|c| Shape::Polygon {
            points: c.vertices.iter().map(|v| (v.x, v.y)).collect(),
            fill: cell_colour(c),
            stroke: (90, 90, 90),
        })
        .collect();
    let r = radii(snapshot, structure, 0.2);
    shapes.extend(
        snapshot
            .positions
            .iter()
            .zip(&r)
            .map(|(p, r)| Shape::Circle {
                centre: (p.x, p.y),
                radius: 0.35 * r,
                fill: (60, 60, 60),
            }),
    );
    let m = &structure.metrics;
    let legend = vec![
        ("≤ 4 sides".to_string(), FEW),
        ("5 sides".to_string(), FIVE),
        ("6, R ≥ 0.98".to_string(), HEXAGONS[0].1),
        ("6, 0.95 ≤ R < 0.98".to_string(), HEXAGONS[1].1),
        ("6, 0.90 ≤ R < 0.95".to_string(), HEXAGONS[2].1),
        ("6, R < 0.90".to_string(), HEXAGONS[3].1),
        ("7 sides".to_string(), SEVEN),
        ("≥ 8 sides".to_string(), MANY),
        ("not counted".to_string(), NOT_COUNTED),
    ];
    render_map(
        path,
        format!(
            "Voronoi cells: n5 = {:.3}, n6 = {:.3}, n7 = {:.3}, Ψ6 = {:.3}",
            m.n5, m.n6, m.n7, m.psi6
        ),
        shapes,
        legend,
        None,
    )
}

/// Particles coloured by a per-particle value (viridis, linear from its min to its max; NaN
/// values get the bottom colour), e.g. the force (N) or its relative fluctuation.
pub fn value_picture(
    path: &Path,
    snapshot: &Snapshot,
    structure: &Structure,
    values: &[f64],
    title: &str,
    label: &str,
) -> Result<()> {
    let finite = values.iter().copied().filter(|v| v.is_finite());
    let lo = finite.clone().fold(f64::INFINITY, f64::min);
    let hi = finite.fold(f64::NEG_INFINITY, f64::max);
    let span = if hi > lo { hi - lo } else { 1.0 };
    let r = radii(snapshot, structure, 0.5);
    let shapes = snapshot
        .positions
        .iter()
        .zip(&r)
        .zip(values)
        .map(|((p, r), v)| Shape::Circle {
            centre: (p.x, p.y),
            radius: *r,
            fill: viridis((v - lo) / span),
        })
        .collect();
    render_map(
        path,
        title,
        shapes,
        Vec::new(),
        Some(ColorBar {
            label: label.into(),
            lo,
            hi,
            map: viridis,
        }),
    )
}

/// Renders a picture of the sample in metres (equal scales): title, shapes, legend entries and
/// an optional colour bar.
fn render_map(
    path: &Path,
    title: impl Into<String>,
    shapes: Vec<Shape>,
    legend: Vec<(String, Rgb)>,
    color_bar: Option<ColorBar>,
) -> Result<()> {
    let canvas = Canvas {
        title: title.into(),
        x_label: "x (m)".into(),
        y_label: "y (m)".into(),
        shapes,
        legend,
        color_bar,
    };
    render_canvas_png(path, &canvas, WIDTH)
}

/// Species colours of the arrows (cycled).
const SPECIES: [Rgb; 4] = [(30, 90, 200), (215, 60, 40), (40, 150, 60), (150, 80, 170)];

/// Force vectors as arrows from the particle centres (de Paula 2025, Fig. 4.23): each species'
/// arrows scaled by its largest force in the snapshot, the largest one mean neighbour distance
/// long; particles as grey discs, arrows only for particles of counted cells (the source
/// draws those inside its Voronoi box).
pub fn force_vector_picture(
    path: &Path,
    snapshot: &Snapshot,
    structure: &Structure,
    force: &[Vector2<f64>],
) -> Result<()> {
    let species = snapshot.species_or_zero();
    // each species' largest force, in one pass
    let mut largest_of = std::collections::BTreeMap::new();
    for (f, s) in force.iter().zip(&species) {
        let m: &mut f64 = largest_of.entry(*s).or_insert(0.0);
        *m = m.max(f.norm());
    }
    let largest = |s: i64| largest_of[&s];
    let length = mean_bond(snapshot, structure);
    let r = radii(snapshot, structure, 0.3);
    let mut shapes: Vec<Shape> = (snapshot.positions.iter().zip(&r))
        .map(|(p, r)| Shape::Circle {
            centre: (p.x, p.y),
            radius: *r,
            fill: (215, 215, 215),
        })
        .collect();
    let cells = &structure.tessellation.cells;
    for (k, (p, f)) in snapshot.positions.iter().zip(force).enumerate() {
        let scale = largest(species[k]);
        if cells[k].counted && scale > 0.0 {
            let colour = SPECIES[species[k].rem_euclid(SPECIES.len() as i64) as usize];
            shapes.push(arrow(*p, f * (length / scale), colour));
        }
    }
    let legend = largest_of
        .iter()
        .map(|(s, m)| {
            let colour = SPECIES[s.rem_euclid(SPECIES.len() as i64) as usize];
            (format!("species {s}: {m:.3e} N"), colour)
        })
        .collect();
    render_map(
        path,
        "Force vectors, per species over its largest force",
        shapes,
        legend,
        None,
    )
}

/// An arrow from `tail` along `v`: shaft and two barbs of a quarter of its length at ±25°.
fn arrow(tail: Vector2<f64>, v: Vector2<f64>, stroke: Rgb) -> Shape {
    let tip = tail + v;
    let barb = |angle: f64| {
        let (s, c) = angle.to_radians().sin_cos();
        let b = -0.25 * Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y);
        (tip.x + b.x, tip.y + b.y)
    };
    Shape::Path {
        points: vec![
            (tail.x, tail.y),
            (tip.x, tip.y),
            barb(25.0),
            (tip.x, tip.y),
            barb(-25.0),
        ],
        stroke,
    }
}

/// Force PDFs, one line per species, against the bin centres.
pub fn force_pdf_figure(path: &Path, forces: &[SpeciesForces]) -> Result<()> {
    let series = forces
        .iter()
        .map(|d| {
            let h = &d.histogram;
            Series {
                label: format!(
                    "species {} (N = {}, mean {:.3e} N)",
                    d.species, d.count, d.mean
                ),
                x: h.edges.windows(2).map(|e| 0.5 * (e[0] + e[1])).collect(),
                y: h.density.clone(),
                y_err: None,
                style: SeriesStyle::LinePoints,
            }
        })
        .collect();
    let figure = Figure {
        title: "Force distribution per species (Knuth bins)".into(),
        x_label: "force (N)".into(),
        y_label: "probability density (1/N)".into(),
        series,
        ..Figure::default()
    };
    render_png(path, &figure)
}
