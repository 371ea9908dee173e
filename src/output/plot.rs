//! One generic XY figure type ([`Figure`]) reused by every model's plots, rendered to PNG
//! with plotters and the bundled DejaVu Sans font (no system fonts are used).
//!
//! Rendering rules:
//! - axis ranges come from everything drawn (points, error bars, band, marker lines) with a
//!   5 % margin on each side (in log space on log axes);
//! - NaN and infinite values are skipped, and so are non-positive values on a log axis (a
//!   line is broken at a skipped point); an error bar reaching below zero on a log axis is
//!   cut at the bottom of the plot;
//! - a figure with nothing drawable (no series, all-NaN data) renders empty axes with a
//!   "no data" note instead of failing;
//! - the legend (series, band, marker lines; entries with an empty label are left out) sits
//!   in the corner holding the fewest data points, on a white background.

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{
    KeyPointHint, KeyPointWeight, NoDefaultFormatting, ValueFormatter,
};
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::atomic::{commit_temp, parent_dir, temp_path_for};
use crate::{Error, Result};

/// Bundled font, registered with plotters as "sans-serif" on first use.
const FONT: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));

/// Default PNG width in pixels.
pub const DEFAULT_WIDTH: u32 = 1000;
/// Default PNG height in pixels.
pub const DEFAULT_HEIGHT: u32 = 700;

/// Series colours (Matplotlib's "tab10" palette), cycled.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
/// Colours of vertical marker lines, cycled.
const V_LINE_COLORS: [RGBColor; 3] = [
    RGBColor(0, 0, 0),
    RGBColor(128, 0, 128),
    RGBColor(0, 100, 0),
];
/// Colours of horizontal reference lines, cycled.
const H_LINE_COLORS: [RGBColor; 3] = [
    RGBColor(90, 90, 90),
    RGBColor(160, 82, 45),
    RGBColor(0, 0, 139),
];
/// Colour of the "no data" note.
const NO_DATA_COLOR: RGBColor = RGBColor(110, 110, 110);
/// Colour of the shaded band (drawn translucent).
const BAND_COLOR: RGBColor = RGBColor(120, 170, 120);

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SeriesStyle {
    /// Solid line through the points (broken at skipped points).
    Line,
    /// Filled circles.
    Points,
    /// Line and circles.
    LinePoints,
}

/// One data series: `x`, `y` (and `y_err`, if any) have the same length.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (empty: no legend entry).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// Symmetric error bars (half-lengths), drawn as vertical bars with caps.
    pub y_err: Option<Vec<f64>>,
    /// Line, points, or both.
    pub style: SeriesStyle,
}

/// A 2-D XY figure with optional log axes, a shaded vertical band and marker lines.
#[derive(Debug, Clone, Default)]
pub struct Figure {
    /// Title above the plot (empty: none).
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Data series, drawn in order, coloured from a fixed palette.
    pub series: Vec<Series>,
    /// Shaded vertical band `[lo, hi]` with its legend label (e.g. the near-optimal field band).
    pub x_band: Option<(f64, f64, String)>,
    /// Vertical dashed marker lines with legend labels (e.g. the optimum).
    pub v_lines: Vec<(f64, String)>,
    /// Horizontal dashed reference lines with legend labels (e.g. target alignment 0.95).
    pub h_lines: Vec<(f64, String)>,
}

/// Render to a PNG of [`DEFAULT_WIDTH`] × [`DEFAULT_HEIGHT`] px, atomically (see
/// [`render_png_sized`]).
///
/// # Errors
/// As [`render_png_sized`].
pub fn render_png(path: &Path, fig: &Figure) -> Result<()> {
    render_png_sized(path, fig, DEFAULT_WIDTH, DEFAULT_HEIGHT)
}

/// Render to a PNG of `width` × `height` px atomically: the image is written to a temporary
/// file in the same directory, fsynced and renamed to `path`. See the module documentation
/// for how ranges, skipped values and empty figures are handled.
///
/// # Errors
/// [`Error::Output`] if the size is outside 200..=20000 × 150..=20000 px, a series' `x`,
/// `y` and `y_err` lengths differ, or drawing fails; [`Error::Io`] if the file cannot be
/// written or renamed.
pub fn render_png_sized(path: &Path, fig: &Figure, width: u32, height: u32) -> Result<()> {
    let fail = |msg: String| Error::Output(format!("cannot render '{}': {msg}", path.display()));
    if !(200..=20_000).contains(&width) || !(150..=20_000).contains(&height) {
        return Err(fail(format!(
            "image size {width}x{height} px is outside 200..=20000 x 150..=20000"
        )));
    }
    check_series(fig).map_err(fail)?;
    ready_to_render(path)?;
    write_png_atomic(path, (width, height), |root| {
        draw_figure(root, fig, (width, height))
    })
}

/// Renders figures side by side as panels of one PNG of `width` × `height` px (each panel
/// `width / n` wide), atomically; every panel follows the rules of [`render_png_sized`].
///
/// # Errors
/// As [`render_png_sized`] (the size limits apply to each panel).
pub fn render_png_panels(path: &Path, figs: &[Figure], width: u32, height: u32) -> Result<()> {
    let fail = |msg: String| Error::Output(format!("cannot render '{}': {msg}", path.display()));
    let n = figs.len().max(1) as u32;
    let panel = width / n;
    if !(200..=20_000).contains(&panel) || !(150..=20_000).contains(&height) {
        return Err(fail(format!(
            "panel size {panel}x{height} px is outside 200..=20000 x 150..=20000"
        )));
    }
    for fig in figs {
        check_series(fig).map_err(fail)?;
    }
    ready_to_render(path)?;
    write_png_atomic(path, (panel * n, height), |root| {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((1, n as usize));
        for (area, fig) in areas.iter().zip(figs) {
            draw_figure(area, fig, (panel, height))?;
        }
        Ok(())
    })
}

/// Checks that each series has as many x as y (and y_err) values.
fn check_series(fig: &Figure) -> std::result::Result<(), String> {
    for s in &fig.series {
        let err_len = s.y_err.as_ref().map_or(s.y.len(), Vec::len);
        if s.x.len() != s.y.len() || err_len != s.y.len() {
            return Err(format!(
                "series '{}' has {} x, {} y and {} y_err values",
                s.label,
                s.x.len(),
                s.y.len(),
                err_len
            ));
        }
    }
    Ok(())
}

/// Draws a `size` bitmap into a temporary file next to `path` and renames it into place, so no
/// half-written PNG ever carries the final name; a drawing error removes the temporary file.
pub(crate) fn write_png_atomic(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(
        &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    ) -> std::result::Result<(), String>,
) -> Result<()> {
    let tmp = temp_path_for(path, ".png");
    let drawn = {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        draw(&root).and_then(|()| root.present().map_err(|e| e.to_string()))
    };
    match drawn {
        Ok(()) => commit_temp(&tmp, path),
        Err(msg) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::Output(format!(
                "cannot render '{}': {msg}",
                path.display()
            )))
        }
    }
}

/// Checks what every PNG writer needs before drawing: the bundled font is registered and the
/// target's directory exists (an [`Error::Io`] naming the path otherwise).
pub(crate) fn ready_to_render(path: &Path) -> Result<()> {
    ensure_font()?;
    let dir = parent_dir(path);
    if !dir.is_dir() {
        let e = std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("directory '{}' does not exist", dir.display()),
        );
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// Registers the bundled font exactly once per process.
fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, FONT)
                .map_err(|_| "the bundled font assets/DejaVuSans.ttf is invalid".to_string())
        })
        .clone()
        .map_err(Error::Output)
}

/// A value that can be drawn on an axis.
fn usable(v: f64, log: bool) -> bool {
    v.is_finite() && (!log || v > 0.0)
}

/// Running min/max of the usable values on one axis.
#[derive(Clone, Copy)]
struct Extent {
    log: bool,
    lo: f64,
    hi: f64,
}

impl Extent {
    fn new(log: bool) -> Self {
        Self {
            log,
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, v: f64) {
        if usable(v, self.log) {
            self.lo = self.lo.min(v);
            self.hi = self.hi.max(v);
        }
    }

    fn is_empty(&self) -> bool {
        self.lo > self.hi
    }

    /// The axis range: the extent plus 5 % on each side (in log10 space for log axes), with
    /// defaults for an empty extent and a widening for a single value.
    fn padded(&self) -> (f64, f64) {
        let to = |v: f64| if self.log { v.log10() } else { v };
        let from = |t: f64| if self.log { 10f64.powf(t) } else { t };
        // An empty extent gets [0, 1] (linear) or [1, 10] (log).
        let (mut lo, mut hi) = if self.is_empty() {
            (0.0, 1.0)
        } else {
            (to(self.lo), to(self.hi))
        };
        if hi - lo <= f64::EPSILON * lo.abs().max(hi.abs()).max(1e-300) {
            let d = if self.log || lo == 0.0 {
                0.5
            } else {
                0.1 * lo.abs()
            };
            lo -= d;
            hi += d;
        } else if !self.is_empty() {
            let m = 0.05 * (hi - lo);
            lo -= m;
            hi += m;
        }
        // Keep the range inside f64 (extreme data could overflow after padding).
        let (lo, hi) = (from(lo), from(hi));
        let lo = if lo.is_finite() { lo } else { -f64::MAX };
        let hi = if hi.is_finite() { hi } else { f64::MAX };
        if self.log {
            (lo.max(f64::MIN_POSITIVE), hi)
        } else {
            (lo, hi)
        }
    }
}

/// Tick-label style of an axis.
#[derive(Clone, Copy, Debug)]
enum TickStyle {
    /// Evenly spaced values with this step.
    Linear(f64),
    /// Powers of ten (possibly every `n`-th) or 1-2-5 / 1..9 multiples of them.
    Log,
}

/// A linear or logarithmic axis with its own tick placement and labels.
#[derive(Clone, Debug)]
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    bold: Vec<f64>,
    light: Vec<f64>,
    style: TickStyle,
}

/// Smallest "nice" step (1, 2, 2.5 or 5 × 10^k) at least `raw`.
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag)
}

/// Multiples of `step` inside `[lo, hi]`.
fn multiples(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(step.is_finite() && step > 0.0) {
        return Vec::new();
    }
    let first = (lo / step - 1e-9).ceil();
    let last = (hi / step + 1e-9).floor();
    if !(first.is_finite() && last.is_finite()) || last - first > 10_000.0 {
        return Vec::new();
    }
    // Count, not `k += 1.0`: beyond 2^53 that increment is lost and the loop never ends
    // (an almost constant series far from zero, e.g. a conserved energy, gets here).
    (0..=(last - first) as usize)
        .map(|i| {
            let v = (first + i as f64) * step;
            // Snap round-off like 0.30000000000000004 and -0.
            if v.abs() < step * 1e-9 {
                0.0
            } else {
                v
            }
        })
        .collect()
}

/// Linear ticks: at most `n` bold ticks at a nice step, light ticks subdividing it.
fn linear_ticks(lo: f64, hi: f64, n: usize) -> (Vec<f64>, Vec<f64>, f64) {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return (vec![lo], Vec::new(), 1.0);
    }
    let mut step = nice_step(span / n.max(2) as f64);
    let mut bold = multiples(lo, hi, step);
    while bold.len() > n.max(2) {
        step = nice_step(step * 1.01);
        bold = multiples(lo, hi, step);
    }
    let mantissa = step / 10f64.powf(step.log10().floor());
    let sub = if (mantissa - 2.0).abs() < 1e-6 {
        4.0
    } else {
        5.0
    };
    let light = multiples(lo, hi, step / sub);
    (bold, light, step)
}

impl Axis {
    /// An axis over `[lo, hi]` (both > 0 for a log axis) with at most about `n` labels.
    fn new(lo: f64, hi: f64, log: bool, n: usize) -> Self {
        if !log {
            let (bold, light, step) = linear_ticks(lo, hi, n);
            return Self {
                lo,
                hi,
                log,
                bold,
                light,
                style: TickStyle::Linear(step),
            };
        }
        let in_range = |v: &f64| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9);
        let (elo, ehi) = (lo.log10(), hi.log10());
        let first = (elo - 1e-9).ceil() as i32;
        let last = (ehi + 1e-9).floor() as i32;
        let decades: Vec<i32> = (first..=last).collect();
        let multiples_of = |ms: &[f64]| -> Vec<f64> {
            (first - 1..=last)
                .flat_map(|k| ms.iter().map(move |m| m * 10f64.powi(k)))
                .filter(in_range)
                .collect()
        };
        let all_minor = multiples_of(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        let one_two_five = multiples_of(&[1.0, 2.0, 5.0]);
        if decades.len() <= 3 && one_two_five.len() >= 3 && one_two_five.len() <= n.max(2) {
            return Self {
                lo,
                hi,
                log,
                bold: one_two_five,
                light: all_minor,
                style: TickStyle::Log,
            };
        }
        if decades.len() >= 2 {
            let stride = decades.len().div_ceil(n.max(2));
            let bold: Vec<f64> = decades
                .iter()
                .filter(|k| ((**k - first) as usize).is_multiple_of(stride))
                .map(|k| 10f64.powi(*k))
                .collect();
            let light = if stride == 1 {
                all_minor
            } else {
                decades.iter().map(|k| 10f64.powi(*k)).collect()
            };
            return Self {
                lo,
                hi,
                log,
                bold,
                light,
                style: TickStyle::Log,
            };
        }
        if one_two_five.len() >= 3 {
            return Self {
                lo,
                hi,
                log,
                bold: one_two_five,
                light: all_minor,
                style: TickStyle::Log,
            };
        }
        if all_minor.len() >= 3 && all_minor.len() <= n.max(2) {
            let light = all_minor.clone();
            return Self {
                lo,
                hi,
                log,
                bold: all_minor,
                light,
                style: TickStyle::Log,
            };
        }
        // Less than a factor of ~3 between the ends: plain values at a linear nice step.
        let (bold, light, step) = linear_ticks(lo, hi, n.min(6));
        Self {
            lo,
            hi,
            log,
            bold,
            light,
            style: TickStyle::Linear(step),
        }
    }

    fn transform(&self, v: f64) -> f64 {
        if self.log {
            v.log10()
        } else {
            v
        }
    }

    /// Tick label for `v`.
    fn label(&self, v: f64) -> String {
        match self.style {
            TickStyle::Linear(step) => format_linear(v, step, self.lo.abs().max(self.hi.abs())),
            TickStyle::Log => format_log(v),
        }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let (a, b) = (self.transform(self.lo), self.transform(self.hi));
        let mut f = (self.transform(*value) - a) / (b - a);
        if f.is_nan() {
            f = 0.0;
        }
        // Stay near the plotting area even for out-of-range values.
        let f = f.clamp(-0.05, 1.05);
        let px = f64::from(limit.0) + f * f64::from(limit.1 - limit.0);
        px.round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let pts = match hint.weight() {
            KeyPointWeight::Bold => &self.bold,
            KeyPointWeight::Any => &self.light,
        };
        if pts.len() <= hint.max_num_points().max(2) {
            pts.clone()
        } else {
            Vec::new()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        self.label(*value)
    }
}

/// Formats a tick of a linear axis whose ticks are `step` apart and whose largest absolute
/// end is `scale`: plain decimals for moderate magnitudes, scientific notation otherwise.
fn format_linear(v: f64, step: f64, scale: f64) -> String {
    let v = if v == 0.0 { 0.0 } else { v }; // no "-0"
    if !(1e-3..1e5).contains(&scale) {
        if v == 0.0 {
            return "0".to_string();
        }
        // Enough mantissa digits to tell neighbouring ticks apart.
        let exp = v.abs().log10().floor();
        let digits = (exp - step.log10().floor()).clamp(0.0, 10.0) as usize;
        let s = format!("{:.*e}", digits, v);
        return tidy_sci(&s);
    }
    let mut decimals = (-step.log10().floor()).max(0.0) as usize;
    let mantissa = step / 10f64.powf(step.log10().floor());
    if (mantissa - 2.5).abs() < 1e-6 {
        decimals += 1;
    }
    format!("{:.*}", decimals.min(12), v)
}

/// Turns Rust's `1.50e-5` into `1.50×10⁻⁵`.
fn tidy_sci(s: &str) -> String {
    match s.split_once('e') {
        Some((m, e)) => format!("{m}×10{}", superscript(e.parse().unwrap_or(0))),
        None => s.to_string(),
    }
}

/// Unicode superscript digits for an exponent.
fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// Formats a tick of a log axis (a small multiple of a power of ten).
fn format_log(v: f64) -> String {
    let exp = (v.log10() + 1e-9).floor();
    let mantissa = (v / 10f64.powf(exp) * 1e6).round() / 1e6;
    if (-3.0..=4.0).contains(&exp) {
        let decimals = (-exp).max(0.0) as usize;
        format!("{:.*}", decimals, v)
    } else if mantissa == 1.0 {
        format!("10{}", superscript(exp as i32))
    } else {
        format!("{mantissa}×10{}", superscript(exp as i32))
    }
}

/// Font sizes and label-area sizes scaled to the image size.
struct Layout {
    title: f64,
    axis_desc: f64,
    ticks: f64,
    legend: f64,
    scale: f64,
}

impl Layout {
    fn new(width: u32, height: u32) -> Self {
        let scale = (f64::from(width) / f64::from(DEFAULT_WIDTH))
            .min(f64::from(height) / f64::from(DEFAULT_HEIGHT))
            .clamp(0.5, 4.0);
        // Text shrinks and grows more slowly than the image, to stay readable.
        let text = scale.sqrt();
        Self {
            title: 26.0 * text,
            axis_desc: 21.0 * text,
            ticks: 17.0 * text,
            legend: 17.0 * text,
            scale,
        }
    }

    fn px(&self, v: f64) -> i32 {
        (v * self.scale).round() as i32
    }
}

type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<Axis, Axis>>;

/// Draws the whole figure; errors are returned as messages.
fn draw_figure(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    fig: &Figure,
    (width, height): (u32, u32),
) -> std::result::Result<(), String> {
    let de = |e: DrawingAreaErrorKind<_>| e.to_string();
    let layout = Layout::new(width, height);
    root.fill(&WHITE).map_err(de)?;

    // Axis ranges from everything that will be drawn.
    let (mut ex, mut ey) = (Extent::new(fig.log_x), Extent::new(fig.log_y));
    for s in &fig.series {
        for i in 0..s.x.len() {
            let (x, y) = (s.x[i], s.y[i]);
            if !(usable(x, fig.log_x) && usable(y, fig.log_y)) {
                continue;
            }
            ex.add(x);
            ey.add(y);
            if let Some(e) = s.y_err.as_ref().map(|e| e[i].abs()) {
                if e.is_finite() {
                    ey.add(y - e);
                    ey.add(y + e);
                }
            }
        }
    }
    if let Some((lo, hi, _)) = &fig.x_band {
        ex.add(*lo);
        ex.add(*hi);
    }
    fig.v_lines.iter().for_each(|(x, _)| ex.add(*x));
    fig.h_lines.iter().for_each(|(y, _)| ey.add(*y));
    let has_data = !(ex.is_empty() && ey.is_empty());
    let (x0, x1) = ex.padded();
    let (y0, y1) = ey.padded();
    let x_axis = Axis::new(x0, x1, fig.log_x, 9);
    let y_axis = Axis::new(y0, y1, fig.log_y, 8);

    // Room for the y tick labels: measure the widest one.
    let tick_font = TextStyle::from(("sans-serif", layout.ticks).into_font());
    let widest = y_axis
        .bold
        .iter()
        .map(|v| {
            root.estimate_text_size(&y_axis.label(*v), &tick_font)
                .map_or(0, |(w, _)| w as i32)
        })
        .max()
        .unwrap_or(0);
    let desc_room = |label: &str| {
        if label.is_empty() {
            0
        } else {
            layout.axis_desc.round() as i32 + layout.px(8.0)
        }
    };
    let y_area = widest + layout.px(14.0) + desc_room(&fig.y_label);
    let x_area = layout.ticks.round() as i32 + layout.px(14.0) + desc_room(&fig.x_label);
    // The last x tick label is centred on the right edge of the plot: leave room for it.
    let last_x_label = x_axis.bold.last().map_or(0, |v| {
        root.estimate_text_size(&x_axis.label(*v), &tick_font)
            .map_or(0, |(w, _)| w as i32)
    });
    let right = (last_x_label / 2 + layout.px(6.0)).max(layout.px(20.0));
    // Likewise the top y tick label when there is no title above it.
    let top = (layout.ticks * 0.6).round() as i32 + layout.px(8.0);

    let mut builder = ChartBuilder::on(root);
    builder
        .margin_top(top)
        .margin_bottom(layout.px(10.0))
        .margin_left(layout.px(14.0))
        .margin_right(right)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area);
    if !fig.title.is_empty() {
        builder.caption(&fig.title, ("sans-serif", layout.title));
    }
    let mut chart = builder
        .build_cartesian_2d(x_axis.clone(), y_axis.clone())
        .map_err(de)?;

    chart
        .configure_mesh()
        .x_desc(fig.x_label.as_str())
        .y_desc(fig.y_label.as_str())
        .x_labels(20)
        .y_labels(20)
        .max_light_lines(10)
        .label_style(("sans-serif", layout.ticks))
        .axis_desc_style(("sans-serif", layout.axis_desc))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.05))
        .axis_style(BLACK.mix(0.8))
        .draw()
        .map_err(de)?;

    if !has_data {
        let (cx, cy) = ((x_axis.lo + x_axis.hi) / 2.0, (y_axis.lo + y_axis.hi) / 2.0);
        let (cx, cy) = (
            if fig.log_x {
                (x_axis.lo * x_axis.hi).sqrt()
            } else {
                cx
            },
            if fig.log_y {
                (y_axis.lo * y_axis.hi).sqrt()
            } else {
                cy
            },
        );
        let style = TextStyle::from(("sans-serif", layout.axis_desc).into_font())
            .color(&NO_DATA_COLOR)
            .pos(Pos::new(HPos::Center, VPos::Center));
        chart
            .draw_series(std::iter::once(Text::new("no data", (cx, cy), style)))
            .map_err(de)?;
        return Ok(());
    }

    draw_band(&mut chart, fig, &x_axis, &y_axis).map_err(de)?;
    for (i, s) in fig.series.iter().enumerate() {
        draw_series(
            &mut chart,
            s,
            PALETTE[i % PALETTE.len()],
            fig,
            &y_axis,
            &layout,
        )
        .map_err(de)?;
    }
    draw_marker_lines(&mut chart, fig, &x_axis, &y_axis, &layout).map_err(de)?;
    draw_legend(&mut chart, fig, &x_axis, &y_axis, &layout).map_err(de)?;
    Ok(())
}

type DrawResult = std::result::Result<
    (),
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

/// The shaded band, clipped to the plot.
fn draw_band(chart: &mut Chart<'_, '_>, fig: &Figure, x: &Axis, y: &Axis) -> DrawResult {
    let Some((a, b, _)) = &fig.x_band else {
        return Ok(());
    };
    let clip = |v: f64| {
        if v.is_nan() || (fig.log_x && v <= 0.0) {
            x.lo
        } else {
            v.clamp(x.lo, x.hi)
        }
    };
    if a.is_nan() || b.is_nan() {
        return Ok(());
    }
    let (lo, hi) = (clip(a.min(*b)), clip(a.max(*b)));
    chart.draw_series(std::iter::once(Rectangle::new(
        [(lo, y.lo), (hi, y.hi)],
        BAND_COLOR.mix(0.25).filled(),
    )))?;
    Ok(())
}

/// One series: line segments between usable points, markers, error bars.
fn draw_series(
    chart: &mut Chart<'_, '_>,
    s: &Series,
    color: RGBColor,
    fig: &Figure,
    y_axis: &Axis,
    layout: &Layout,
) -> DrawResult {
    let ok = |i: usize| usable(s.x[i], fig.log_x) && usable(s.y[i], fig.log_y);
    let line_style = color.stroke_width(layout.px(2.0).max(1) as u32);
    if matches!(s.style, SeriesStyle::Line | SeriesStyle::LinePoints) {
        let mut segment: Vec<(f64, f64)> = Vec::new();
        for i in 0..=s.x.len() {
            if i < s.x.len() && ok(i) {
                segment.push((s.x[i], s.y[i]));
            } else if !segment.is_empty() {
                if segment.len() == 1 && s.style == SeriesStyle::Line {
                    // An isolated point would be invisible as a line.
                    chart.draw_series(std::iter::once(Circle::new(
                        segment[0],
                        layout.px(2.0),
                        color.filled(),
                    )))?;
                } else {
                    chart.draw_series(LineSeries::new(std::mem::take(&mut segment), line_style))?;
                }
                segment.clear();
            }
        }
    }
    if let Some(err) = &s.y_err {
        let bar_style = color.stroke_width(layout.px(1.5).max(1) as u32);
        let cap = layout.px(5.0).max(2);
        let mut bars = Vec::new();
        for i in (0..s.x.len()).filter(|i| ok(*i)) {
            let e = err[i].abs();
            if !e.is_finite() || e == 0.0 {
                continue;
            }
            let (x, y) = (s.x[i], s.y[i]);
            let lo = if fig.log_y && y - e <= 0.0 {
                y_axis.lo
            } else {
                y - e
            };
            bars.push(PathElement::new(vec![(x, lo), (x, y + e)], bar_style));
        }
        chart.draw_series(bars)?;
        let caps: Vec<_> = (0..s.x.len())
            .filter(|i| ok(*i))
            .filter_map(|i| {
                let e = err[i].abs();
                if !e.is_finite() || e == 0.0 {
                    return None;
                }
                let (x, y) = (s.x[i], s.y[i]);
                let mut ends = vec![y + e];
                if !(fig.log_y && y - e <= 0.0) {
                    ends.push(y - e);
                }
                Some(ends.into_iter().map(move |end| {
                    EmptyElement::at((x, end))
                        + PathElement::new(vec![(-cap, 0), (cap, 0)], bar_style)
                }))
            })
            .flatten()
            .collect();
        chart.draw_series(caps)?;
    }
    if matches!(s.style, SeriesStyle::Points | SeriesStyle::LinePoints) {
        let r = layout.px(if s.style == SeriesStyle::Points {
            4.0
        } else {
            3.5
        });
        chart.draw_series(
            (0..s.x.len())
                .filter(|i| ok(*i))
                .map(|i| Circle::new((s.x[i], s.y[i]), r, color.filled())),
        )?;
    }
    Ok(())
}

/// Vertical and horizontal dashed lines across the plot.
fn draw_marker_lines(
    chart: &mut Chart<'_, '_>,
    fig: &Figure,
    x: &Axis,
    y: &Axis,
    layout: &Layout,
) -> DrawResult {
    let (dash, gap) = (layout.px(10.0).max(2), layout.px(6.0).max(2));
    let width = layout.px(2.0).max(1) as u32;
    for (i, (v, _)) in fig.v_lines.iter().enumerate() {
        if usable(*v, fig.log_x) {
            let style = V_LINE_COLORS[i % V_LINE_COLORS.len()].stroke_width(width);
            chart.draw_series(DashedLineSeries::new(
                vec![(*v, y.lo), (*v, y.hi)],
                dash,
                gap,
                style,
            ))?;
        }
    }
    for (i, (v, _)) in fig.h_lines.iter().enumerate() {
        if usable(*v, fig.log_y) {
            let style = H_LINE_COLORS[i % H_LINE_COLORS.len()].stroke_width(width);
            chart.draw_series(DashedLineSeries::new(
                vec![(x.lo, *v), (x.hi, *v)],
                dash,
                gap,
                style,
            ))?;
        }
    }
    Ok(())
}

/// Chooses the legend corner with the fewest data points nearby.
fn legend_corner(fig: &Figure, x: &Axis, y: &Axis) -> SeriesLabelPosition {
    let norm = |a: &Axis, v: f64| {
        (a.transform(v) - a.transform(a.lo)) / (a.transform(a.hi) - a.transform(a.lo))
    };
    // [upper-right, upper-left, lower-right, lower-left], in order of preference.
    let mut counts = [0usize; 4];
    for s in &fig.series {
        let pts: Vec<(f64, f64)> =
            s.x.iter()
                .zip(&s.y)
                .filter(|(a, b)| usable(**a, fig.log_x) && usable(**b, fig.log_y))
                .map(|(a, b)| (norm(x, *a), norm(y, *b)))
                .collect();
        // Points and segment midpoints, so that lines count too.
        let mids = pts
            .windows(2)
            .map(|w| ((w[0].0 + w[1].0) / 2.0, (w[0].1 + w[1].1) / 2.0));
        for (u, v) in pts.iter().copied().chain(mids) {
            let (right, left, top, bottom) = (u > 0.55, u < 0.45, v > 0.55, v < 0.45);
            counts[0] += usize::from(right && top);
            counts[1] += usize::from(left && top);
            counts[2] += usize::from(right && bottom);
            counts[3] += usize::from(left && bottom);
        }
    }
    match (0..4).min_by_key(|i| counts[*i]).unwrap_or(0) {
        0 => SeriesLabelPosition::UpperRight,
        1 => SeriesLabelPosition::UpperLeft,
        2 => SeriesLabelPosition::LowerRight,
        _ => SeriesLabelPosition::LowerLeft,
    }
}

/// Legend entries (series, band, lines), registered through empty series so that their
/// order is independent of the drawing order.
fn draw_legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    fig: &Figure,
    x: &Axis,
    y: &Axis,
    layout: &Layout,
) -> DrawResult {
    let nothing = || std::iter::empty::<PathElement<(f64, f64)>>();
    let (len, half, r) = (layout.px(24.0), layout.px(7.0), layout.px(4.0));
    let width = layout.px(2.0).max(1) as u32;
    let mut any = false;
    for (i, s) in fig.series.iter().enumerate() {
        if s.label.is_empty() {
            continue;
        }
        any = true;
        let color = PALETTE[i % PALETTE.len()];
        let anno = chart.draw_series(nothing())?;
        anno.label(s.label.as_str());
        match s.style {
            SeriesStyle::Line => {
                anno.legend(move |(px, py)| {
                    PathElement::new(vec![(px, py), (px + len, py)], color.stroke_width(width))
                });
            }
            SeriesStyle::Points => {
                anno.legend(move |(px, py)| Circle::new((px + len / 2, py), r, color.filled()));
            }
            SeriesStyle::LinePoints => {
                anno.legend(move |(px, py)| {
                    EmptyElement::at((px, py))
                        + PathElement::new(vec![(0, 0), (len, 0)], color.stroke_width(width))
                        + Circle::new((len / 2, 0), r, color.filled())
                });
            }
        }
    }
    if let Some((_, _, label)) = &fig.x_band {
        if !label.is_empty() {
            any = true;
            chart
                .draw_series(nothing())?
                .label(label.as_str())
                .legend(move |(px, py)| {
                    Rectangle::new(
                        [(px, py - half), (px + len, py + half)],
                        BAND_COLOR.mix(0.35).filled(),
                    )
                });
        }
    }
    let (dash, gap) = (layout.px(6.0).max(2), layout.px(4.0).max(2));
    let lines = fig
        .v_lines
        .iter()
        .enumerate()
        .map(|(i, (_, l))| (l, V_LINE_COLORS[i % V_LINE_COLORS.len()]))
        .chain(
            fig.h_lines
                .iter()
                .enumerate()
                .map(|(i, (_, l))| (l, H_LINE_COLORS[i % H_LINE_COLORS.len()])),
        );
    for (label, color) in lines {
        if label.is_empty() {
            continue;
        }
        any = true;
        chart
            .draw_series(nothing())?
            .label(label.as_str())
            .legend(move |(px, py)| {
                DashedPathElement::new(
                    vec![(px, py), (px + len, py)],
                    dash,
                    gap,
                    color.stroke_width(width),
                )
            });
    }
    if any {
        chart
            .configure_series_labels()
            .position(legend_corner(fig, x, y))
            .margin(layout.px(12.0))
            .legend_area_size(len + layout.px(8.0))
            .label_font(("sans-serif", layout.legend))
            .background_style(WHITE.mix(0.92).filled())
            .border_style(BLACK.mix(0.4))
            .draw()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_of_an_almost_constant_range_far_from_zero_terminate() {
        let (bold, ..) = linear_ticks(9978.355613635358, 9978.355613635359, 6);
        assert!(bold.len() <= 10_001);
    }
    use crate::output::atomic::tests::test_dir;

    fn check_png(path: &Path) {
        let bytes = std::fs::read(path).unwrap();
        assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
        assert!(bytes.len() > 1024, "PNG too small: {} bytes", bytes.len());
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    fn series(label: &str, style: SeriesStyle, f: impl Fn(f64) -> f64, err: bool) -> Series {
        let x: Vec<f64> = (0..20)
            .map(|i| 10f64.powf(-1.0 + 0.2 * f64::from(i)))
            .collect();
        let y: Vec<f64> = x.iter().map(|v| f(*v)).collect();
        let y_err = err.then(|| y.iter().map(|v| 0.05 * v.abs() + 0.01).collect());
        Series {
            label: label.to_string(),
            x,
            y,
            y_err,
            style,
        }
    }

    fn full_figure(log_x: bool, log_y: bool) -> Figure {
        Figure {
            title: "Alignment vs field".into(),
            x_label: "B (mT)".into(),
            y_label: "alignment".into(),
            log_x,
            log_y,
            series: vec![
                series("small", SeriesStyle::LinePoints, |b| b / (1.0 + b), true),
                series(
                    "medium",
                    SeriesStyle::Line,
                    |b| b * b / (1.0 + b * b),
                    false,
                ),
                series(
                    "large",
                    SeriesStyle::Points,
                    |b| (b / 3.0).tanh() + 0.01,
                    true,
                ),
            ],
            x_band: Some((0.8, 2.5, "near-optimal".into())),
            v_lines: vec![(1.3, "optimum".into())],
            h_lines: vec![(0.95, "target 0.95".into())],
        }
    }

    #[test]
    fn renders_lin_and_log_axes() {
        let dir = test_dir("plot-axes");
        for (lx, ly) in [(false, false), (true, false), (false, true), (true, true)] {
            let path = dir.join(format!("fig-{lx}-{ly}.png"));
            render_png(&path, &full_figure(lx, ly)).unwrap();
            check_png(&path);
        }
        assert!(leftovers(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn renders_replaces_existing_and_custom_size() {
        let dir = test_dir("plot-size");
        let path = dir.join("fig.png");
        std::fs::write(&path, b"old").unwrap();
        render_png_sized(&path, &full_figure(true, false), 640, 480).unwrap();
        check_png(&path);
        let bytes = std::fs::read(&path).unwrap();
        // IHDR width and height.
        assert_eq!(&bytes[16..24], &[0, 0, 2, 128, 0, 0, 1, 224]);
        assert!(leftovers(&dir).is_empty());
        assert!(matches!(
            render_png_sized(&path, &full_figure(false, false), 10, 10),
            Err(Error::Output(_))
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn renders_nan_and_nonpositive_values() {
        let dir = test_dir("plot-nan");
        let mut fig = full_figure(true, true);
        fig.series.push(Series {
            label: "gappy".into(),
            x: vec![-1.0, 0.0, 0.5, f64::NAN, 1.0, 2.0, f64::INFINITY, 3.0],
            y: vec![1.0, 1.0, 0.2, 0.3, f64::NAN, 0.5, 0.6, -0.1],
            y_err: Some(vec![0.1, f64::NAN, 0.5, 0.0, 0.1, f64::INFINITY, 0.1, 0.1]),
            style: SeriesStyle::LinePoints,
        });
        fig.x_band = Some((-5.0, 2.0, "band from negative".into()));
        fig.v_lines.push((f64::NAN, "nan line".into()));
        fig.h_lines.push((-1.0, "negative line".into()));
        for (lx, ly) in [(false, false), (true, true)] {
            fig.log_x = lx;
            fig.log_y = ly;
            let path = dir.join(format!("nan-{lx}.png"));
            render_png(&path, &fig).unwrap();
            check_png(&path);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn renders_empty_and_degenerate_figures() {
        let dir = test_dir("plot-empty");
        let all_nan = Series {
            label: "all NaN".into(),
            x: vec![f64::NAN; 3],
            y: vec![1.0, 2.0, 3.0],
            y_err: None,
            style: SeriesStyle::Line,
        };
        let single = Series {
            label: "one point".into(),
            x: vec![5.0],
            y: vec![5.0],
            y_err: Some(vec![0.0]),
            style: SeriesStyle::Line,
        };
        let figures = [
            Figure::default(),
            Figure {
                log_x: true,
                log_y: true,
                ..Figure::default()
            },
            Figure {
                title: "nan".into(),
                series: vec![all_nan.clone()],
                log_y: true,
                ..Figure::default()
            },
            Figure {
                series: vec![single.clone()],
                ..Figure::default()
            },
            Figure {
                series: vec![single, all_nan],
                log_x: true,
                log_y: true,
                ..Figure::default()
            },
            Figure {
                h_lines: vec![(0.0, String::new())],
                ..Figure::default()
            },
            Figure {
                series: vec![Series {
                    label: "huge".into(),
                    x: vec![-1e300, 1e300],
                    y: vec![f64::MAX, -f64::MAX],
                    y_err: None,
                    style: SeriesStyle::LinePoints,
                }],
                ..Figure::default()
            },
            Figure {
                series: vec![Series {
                    label: "narrow log".into(),
                    x: vec![0.95, 0.96, 0.97],
                    y: vec![1e-12, 1e12, 1.0],
                    y_err: None,
                    style: SeriesStyle::Points,
                }],
                log_x: true,
                log_y: true,
                ..Figure::default()
            },
        ];
        for (i, fig) in figures.iter().enumerate() {
            let path = dir.join(format!("empty-{i}.png"));
            render_png(&path, fig).unwrap_or_else(|e| panic!("figure {i}: {e}"));
            check_png(&path);
        }
        assert!(leftovers(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn mismatched_lengths_are_an_error() {
        let dir = test_dir("plot-bad");
        let fig = Figure {
            series: vec![Series {
                label: "bad".into(),
                x: vec![1.0, 2.0],
                y: vec![1.0],
                y_err: None,
                style: SeriesStyle::Line,
            }],
            ..Figure::default()
        };
        let err = render_png(&dir.join("bad.png"), &fig).unwrap_err();
        assert!(
            matches!(err, Error::Output(ref m) if m.contains("'bad'")),
            "{err:?}"
        );
        let err = render_png(&dir.join("missing").join("x.png"), &Figure::default()).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn tick_labels() {
        assert_eq!(format_log(1e-3), "0.001");
        assert_eq!(format_log(100.0), "100");
        assert_eq!(format_log(1e-6), "10⁻⁶");
        assert_eq!(format_log(2e6), "2×10⁶");
        assert_eq!(format_linear(0.5, 0.25, 1.0), "0.50");
        assert_eq!(format_linear(2.0, 1.0, 10.0), "2");
        assert_eq!(format_linear(0.0, 0.1, 1.0), "0.0");
        assert_eq!(format_linear(-0.0, 1.0, 10.0), "0");
        assert_eq!(format_linear(0.0, 1e6, 5e6), "0");
        assert_eq!(format_linear(2e6, 1e6, 5e6), "2×10⁶");
        assert_eq!(format_linear(1e6, 1e6, 5e6), "1×10⁶");
        assert_eq!(format_linear(1.5e-5, 5e-6, 1e-4), "1.5×10⁻⁵");
        let ax = Axis::new(0.1, 1000.0, true, 9);
        assert_eq!(ax.bold, vec![0.1, 1.0, 10.0, 100.0, 1000.0]);
        let ax = Axis::new(-0.05, 1.05, false, 8);
        assert_eq!(ax.bold.first(), Some(&0.0));
        assert!(ax.bold.len() <= 8 && ax.bold.len() >= 3);
        let ax = Axis::new(0.9, 1.1, true, 8);
        assert!(ax.bold.len() >= 2, "{ax:?}");
    }
}
