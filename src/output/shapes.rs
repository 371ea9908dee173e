//! Pictures of 2D particle configurations: filled polygons and circles in data coordinates on
//! axes with equal scales, with a legend of colour swatches and an optional colour bar,
//! rendered to PNG with plotters and the bundled font (see [`super::plot`]).

use std::path::Path;

use plotters::prelude::*;

use super::plot::{ready_to_render, write_png_atomic};
use crate::{Error, Result};

/// An RGB colour.
pub type Rgb = (u8, u8, u8);

/// A filled shape in data coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A closed polygon (corners in order) with its fill and outline colours.
    Polygon {
        /// Corners (x, y).
        points: Vec<(f64, f64)>,
        /// Fill colour.
        fill: Rgb,
        /// Outline colour.
        stroke: Rgb,
    },
    /// An open polyline (e.g. an arrow: tail, tip, one barb, tip, the other barb).
    Path {
        /// Points (x, y), in order.
        points: Vec<(f64, f64)>,
        /// Line colour.
        stroke: Rgb,
    },
    /// A filled circle.
    Circle {
        /// Centre (x, y).
        centre: (f64, f64),
        /// Radius in data units.
        radius: f64,
        /// Fill colour.
        fill: Rgb,
    },
}

/// A colour bar: the colour map sampled from `lo` to `hi`.
#[derive(Debug, Clone)]
pub struct ColorBar {
    /// Label (quantity and unit).
    pub label: String,
    /// Value at the bottom.
    pub lo: f64,
    /// Value at the top.
    pub hi: f64,
    /// Colour of a fraction t ∈ [0, 1] of the range.
    pub map: fn(f64) -> Rgb,
}

/// A picture of shapes with equal x and y scales.
#[derive(Debug, Clone, Default)]
pub struct Canvas {
    /// Title above the picture.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Shapes, drawn in order.
    pub shapes: Vec<Shape>,
    /// Legend entries (label, swatch colour), in the side panel.
    pub legend: Vec<(String, Rgb)>,
    /// Colour bar, in the side panel below the legend.
    pub color_bar: Option<ColorBar>,
}

/// Width of the side panel (legend, colour bar) in pixels.
const PANEL: u32 = 230;

/// Data extent of the shapes: (x range, y range), padded by 2 %.
fn extent(shapes: &[Shape]) -> ((f64, f64), (f64, f64)) {
    let (mut x, mut y) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    let mut add = |px: f64, py: f64, r: f64| {
        if px.is_finite() && py.is_finite() {
            x = (x.0.min(px - r), x.1.max(px + r));
            y = (y.0.min(py - r), y.1.max(py + r));
        }
    };
    for s in shapes {
        match s {
            Shape::Polygon { points, .. } | Shape::Path { points, .. } => {
                points.iter().for_each(|p| add(p.0, p.1, 0.0))
            }
            Shape::Circle { centre, radius, .. } => add(centre.0, centre.1, *radius),
        }
    }
    let empty = |r: (f64, f64)| r.0.is_nan() || r.1.is_nan() || r.0 >= r.1;
    if empty(x) || empty(y) {
        let c = if x.0.is_finite() {
            (x.0, y.0)
        } else {
            (0.0, 0.0)
        };
        return ((c.0 - 1.0, c.0 + 1.0), (c.1 - 1.0, c.1 + 1.0));
    }
    let pad = 0.02 * (x.1 - x.0).max(y.1 - y.0);
    ((x.0 - pad, x.1 + pad), (y.0 - pad, y.1 + pad))
}

/// Renders the canvas to a PNG `width` px wide (the height follows the data's aspect ratio,
/// kept within 300..=6000 px by widening the shorter axis), atomically.
///
/// # Errors
/// [`Error::Output`] if the width is outside 400..=8000 px or drawing fails; [`Error::Io`] if
/// the directory does not exist or the file cannot be written.
pub fn render_canvas_png(path: &Path, canvas: &Canvas, width: u32) -> Result<()> {
    let fail = |msg: String| Error::Output(format!("cannot render '{}': {msg}", path.display()));
    if !(400..=8000).contains(&width) {
        return Err(fail(format!(
            "image width {width} px is outside 400..=8000"
        )));
    }
    ready_to_render(path)?;
    let (mut xr, mut yr) = extent(&canvas.shapes);
    // Plot area: width minus panel and label areas; margins as in `draw` below.
    let plot_w = f64::from(width - PANEL - 90 - 20);
    let ideal_h = plot_w * (yr.1 - yr.0) / (xr.1 - xr.0);
    let plot_h = ideal_h.clamp(300.0, 6000.0);
    // Widen the shorter range so that one data unit is the same number of pixels on both axes.
    let units_per_px = ((xr.1 - xr.0) / plot_w).max((yr.1 - yr.0) / plot_h);
    let grow = |r: (f64, f64), px: f64| {
        let half = 0.5 * units_per_px * px;
        let mid = 0.5 * (r.0 + r.1);
        (mid - half, mid + half)
    };
    xr = grow(xr, plot_w);
    yr = grow(yr, plot_h);
    let height = (plot_h + 60.0 + 60.0 + 20.0) as u32;
    write_png_atomic(path, (width, height), |root| {
        draw(root, canvas, xr, yr, units_per_px)
    })
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A drawing error as a message.
fn err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> String {
    e.to_string()
}

fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

fn draw(
    root: &Area<'_>,
    canvas: &Canvas,
    xr: (f64, f64),
    yr: (f64, f64),
    units_per_px: f64,
) -> std::result::Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let (w, _) = root.dim_in_pixel();
    let (left, right) = root.split_horizontally(w - PANEL);
    let mut chart = ChartBuilder::on(&left)
        .caption(canvas.title.as_str(), ("sans-serif", 26))
        .margin(10)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(canvas.x_label.as_str())
        .y_desc(canvas.y_label.as_str())
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .draw()
        .map_err(err)?;
    for shape in &canvas.shapes {
        match shape {
            Shape::Polygon {
                points,
                fill,
                stroke,
            } => {
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        points.clone(),
                        rgb(*fill).filled(),
                    )))
                    .map_err(err)?;
                let mut outline = points.clone();
                outline.extend(points.first());
                chart
                    .draw_series(std::iter::once(PathElement::new(outline, rgb(*stroke))))
                    .map_err(err)?;
            }
            Shape::Path { points, stroke } => {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        points.clone(),
                        rgb(*stroke).stroke_width(2),
                    )))
                    .map_err(err)?;
            }
            Shape::Circle {
                centre,
                radius,
                fill,
            } => {
                let r_px = (radius / units_per_px).round().max(1.0) as i32;
                chart
                    .draw_series(std::iter::once(Circle::new(
                        *centre,
                        r_px,
                        rgb(*fill).filled(),
                    )))
                    .map_err(err)?;
            }
        }
    }
    draw_panel(&right, canvas).map_err(err)
}

/// Legend swatches and the colour bar.
fn draw_panel(
    area: &Area<'_>,
    canvas: &Canvas,
) -> std::result::Result<
    (),
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
> {
    let font = ("sans-serif", 17).into_font();
    let mut y = 70;
    for (label, colour) in &canvas.legend {
        area.draw(&Rectangle::new(
            [(10, y), (34, y + 18)],
            rgb(*colour).filled(),
        ))?;
        area.draw(&Rectangle::new([(10, y), (34, y + 18)], BLACK))?;
        area.draw(&Text::new(label.as_str(), (42, y), font.clone()))?;
        y += 28;
    }
    if let Some(bar) = &canvas.color_bar {
        y += 20;
        area.draw(&Text::new(bar.label.as_str(), (10, y), font.clone()))?;
        y += 28;
        let steps = 200;
        let (top, bottom) = (y + 10, y + 10 + steps);
        for k in 0..steps {
            let t = 1.0 - f64::from(k) / f64::from(steps - 1);
            area.draw(&Rectangle::new(
                [(10, top + k), (40, top + k + 1)],
                rgb((bar.map)(t)).filled(),
            ))?;
        }
        area.draw(&Text::new(
            format!("{:.3e}", bar.hi),
            (46, top - 8),
            font.clone(),
        ))?;
        area.draw(&Text::new(
            format!("{:.3e}", bar.lo),
            (46, bottom - 10),
            font,
        ))?;
    }
    Ok(())
}

/// The viridis colour map, linear between 9 of its tabulated colours; t clamped to [0, 1].
pub fn viridis(t: f64) -> Rgb {
    const STOPS: [Rgb; 9] = [
        (68, 1, 84),
        (71, 45, 123),
        (59, 82, 139),
        (44, 114, 142),
        (33, 145, 140),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let s = t * (STOPS.len() - 1) as f64;
    let k = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - k as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + f * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    (mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::atomic::tests::test_dir;

    #[test]
    fn renders_shapes_and_rejects_bad_sizes() {
        let dir = test_dir("shapes");
        let path = dir.join("c.png");
        let canvas = Canvas {
            title: "cells".into(),
            x_label: "x (m)".into(),
            y_label: "y (m)".into(),
            shapes: vec![
                Shape::Polygon {
                    points: vec![(0.0, 0.0), (1.0, 0.0), (0.5, 0.8)],
                    fill: (200, 30, 30),
                    stroke: (0, 0, 0),
                },
                Shape::Circle {
                    centre: (0.5, 0.3),
                    radius: 0.1,
                    fill: viridis(0.5),
                },
            ],
            legend: vec![("triangle".into(), (200, 30, 30))],
            color_bar: Some(ColorBar {
                label: "F (N)".into(),
                lo: 0.0,
                hi: 2.0,
                map: viridis,
            }),
        };
        render_canvas_png(&path, &canvas, 800).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 1024);
        render_canvas_png(&dir.join("empty.png"), &Canvas::default(), 800).unwrap();
        assert!(render_canvas_png(&path, &canvas, 10).is_err());
        assert_eq!(viridis(0.0), (68, 1, 84));
        assert_eq!(viridis(1.0), (253, 231, 37));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
