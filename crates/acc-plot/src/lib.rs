//! `acc-plot`: SVG and PNG plots with an embedded font.
//!
//! Every figure is written twice, as `<stem>.svg` and `<stem>.png`, from one description.
//! The DejaVu Sans font (crate `dejavu`) is registered with plotters' `ab_glyph` text
//! renderer under the family `"sans-serif"`, so PNGs get their labels on a machine without
//! any system font. Non-finite points (NaN, ±inf) are skipped (a line breaks there); empty
//! series or panels draw an empty frame instead of failing.
//!
//! Three shapes:
//! - [`time_series`]: stacked panels sharing the x axis, each with named line series,
//!   horizontal reference lines (e.g. `Fr`) and shaded x-intervals (e.g. air cuts);
//! - [`xy_chart`]: an x-y chart with lines and markers, optionally with equal aspect
//!   (pole maps: [`unit_circle`], points, pole paths), also used for overlays;
//! - [`grouped_bars`]: grouped bars for comparisons (controllers × scenarios).
//!
//! ```
//! use acc_plot::{time_series, Figure, HLine, Panel, Series, Shade};
//! let dir = std::env::temp_dir().join("acc-plot-doc");
//! std::fs::create_dir_all(&dir).unwrap();
//! let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
//! let force: Vec<(f64, f64)> = t.iter().map(|&t| (t, 800.0 * (1.0 - (-t).exp()))).collect();
//! let fig = Figure {
//!     title: "Force".into(),
//!     x_label: "time [s]".into(),
//!     panels: vec![Panel {
//!         y_label: "force [N]".into(),
//!         series: vec![Series::line("Fc", force)],
//!         hlines: vec![HLine::new("Fr", 800.0)],
//!         shades: vec![Shade::new("air cut", 0.0, 1.0)],
//!         ..Panel::default()
//!     }],
//!     ..Figure::default()
//! };
//! let written = time_series(&fig, dir.join("force.svg")).unwrap();
//! assert!(written.svg.exists() && written.png.exists());
//! ```

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Plotting errors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlotError {
    /// The embedded font could not be registered.
    #[error("cannot register the embedded DejaVu font")]
    Font,
    /// The output directory could not be created.
    #[error("{path}: cannot create directory: {reason}")]
    Io {
        /// Directory path.
        path: PathBuf,
        /// OS error text.
        reason: String,
    },
    /// The drawing backend failed (file not writable, encoder error, ...).
    #[error("{path}: drawing failed: {reason}")]
    Draw {
        /// Output file.
        path: PathBuf,
        /// Backend message.
        reason: String,
    },
    /// The figure description is unusable.
    #[error("invalid figure: {0}")]
    Invalid(String),
}

/// The two files written for one figure.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The SVG file.
    pub svg: PathBuf,
    /// The PNG file.
    pub png: PathBuf,
}

/// An RGB colour.
pub type Rgb = (u8, u8, u8);

/// The default colour cycle (colour-blind friendly, Okabe–Ito order).
pub const PALETTE: [Rgb; 8] = [
    (0, 114, 178),
    (213, 94, 0),
    (0, 158, 115),
    (204, 121, 167),
    (230, 159, 0),
    (86, 180, 233),
    (0, 0, 0),
    (240, 228, 66),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// Solid line.
    #[default]
    Line,
    /// Dashed line.
    Dashed,
    /// Markers only.
    Markers,
    /// Line with a marker on every point.
    LineMarkers,
    /// Text: the series name written next to every point (up and to the right, in the
    /// series colour), e.g. the plant gain at markers of a pole path; no legend entry.
    Text,
    /// As [`Style::Text`], written down and to the right of every point (for a second set
    /// of labels along the same line).
    TextBelow,
}

/// A named series of (x, y) points.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend name (empty: no legend entry).
    pub name: String,
    /// Points; non-finite points are skipped and break the line.
    pub points: Vec<(f64, f64)>,
    /// Colour; `None` takes the next one from [`PALETTE`].
    pub color: Option<Rgb>,
    /// Drawing style.
    pub style: Style,
}

impl Series {
    /// A solid line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            color: None,
            style: Style::Line,
        }
    }

    /// Markers only.
    pub fn markers(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            color: None,
            style: Style::Markers,
        }
    }

    /// Set the drawing style.
    pub fn with_style(mut self, style: Style) -> Self {
        self.style = style;
        self
    }

    /// Set the colour.
    pub fn with_color(mut self, color: Rgb) -> Self {
        self.color = Some(color);
        self
    }
}

/// A horizontal reference line (e.g. the force reference `Fr`).
#[derive(Debug, Clone, PartialEq)]
pub struct HLine {
    /// Legend name.
    pub name: String,
    /// y value.
    pub y: f64,
}

impl HLine {
    /// A reference line at `y`.
    pub fn new(name: impl Into<String>, y: f64) -> Self {
        Self {
            name: name.into(),
            y,
        }
    }
}

/// A shaded x-interval (e.g. an air cut or a depth step).
#[derive(Debug, Clone, PartialEq)]
pub struct Shade {
    /// Legend name (shades with the same name share one legend entry).
    pub name: String,
    /// Start, x units.
    pub x0: f64,
    /// End, x units.
    pub x1: f64,
}

impl Shade {
    /// Shade `[x0, x1]`.
    pub fn new(name: impl Into<String>, x0: f64, x1: f64) -> Self {
        Self {
            name: name.into(),
            x0,
            x1,
        }
    }
}

/// One panel of a [`Figure`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    /// y-axis label with unit.
    pub y_label: String,
    /// Line series.
    pub series: Vec<Series>,
    /// Horizontal reference lines.
    pub hlines: Vec<HLine>,
    /// Shaded x-intervals.
    pub shades: Vec<Shade>,
    /// Fixed y range; `None` fits the data and reference lines.
    pub y_range: Option<(f64, f64)>,
}

/// Stacked time-series panels sharing the x axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Title above the first panel.
    pub title: String,
    /// x-axis label with unit (drawn under the last panel).
    pub x_label: String,
    /// Panels, top to bottom.
    pub panels: Vec<Panel>,
    /// Fixed x range; `None` fits all panels.
    pub x_range: Option<(f64, f64)>,
    /// Width, px (default 1000).
    pub width_px: u32,
    /// Height of one panel, px (default 260).
    pub panel_height_px: u32,
}

impl Default for Figure {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            panels: Vec::new(),
            x_range: None,
            width_px: 1000,
            panel_height_px: 260,
        }
    }
}

/// An x-y chart: lines, markers, optional equal aspect (pole maps) — also used to overlay
/// runs for comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct XyChart {
    /// Title.
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// Series.
    pub series: Vec<Series>,
    /// Horizontal reference lines.
    pub hlines: Vec<HLine>,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    /// One x unit is as long as one y unit on screen (ranges are widened to achieve it).
    pub equal_aspect: bool,
    /// Width, px (default 800).
    pub width_px: u32,
    /// Height, px (default 800).
    pub height_px: u32,
}

impl Default for XyChart {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            series: Vec::new(),
            hlines: Vec::new(),
            x_range: None,
            y_range: None,
            equal_aspect: false,
            width_px: 800,
            height_px: 800,
        }
    }
}

/// Grouped bars: one group of bars per category, one bar per named group.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupedBars {
    /// Title.
    pub title: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// Category names along x (e.g. scenarios).
    pub categories: Vec<String>,
    /// (name, one value per category) for each group (e.g. controllers); NaN leaves a gap.
    pub groups: Vec<(String, Vec<f64>)>,
    /// Width, px (default 1000).
    pub width_px: u32,
    /// Height, px (default 500).
    pub height_px: u32,
}

impl Default for GroupedBars {
    fn default() -> Self {
        Self {
            title: String::new(),
            y_label: String::new(),
            categories: Vec::new(),
            groups: Vec::new(),
            width_px: 1000,
            height_px: 500,
        }
    }
}

/// The unit circle as a closed line (for pole maps), `n` segments.
pub fn unit_circle(n: usize) -> Series {
    let n = n.max(8);
    let points = (0..=n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            (a.cos(), a.sin())
        })
        .collect();
    Series {
        name: "unit circle".into(),
        points,
        color: Some((110, 110, 110)),
        style: Style::Line,
    }
}

const FONT: &str = "sans-serif";
const TITLE_PX: u32 = 22;
const LABEL_PX: u32 = 16;
const X_LABEL_AREA: u32 = 45;
const Y_LABEL_AREA: u32 = 75;
const MARGIN: u32 = 12;

/// Register DejaVu Sans (regular and bold) as `"sans-serif"` once per process.
pub fn ensure_font() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        let regular =
            plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let bold = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
        regular.is_ok() && bold.is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// `out` with `.svg` and `.png` extensions; the parent directory is created.
fn outputs(out: &Path) -> Result<Written, PlotError> {
    if out.file_name().is_none() {
        return Err(PlotError::Invalid(format!(
            "{}: not a file name",
            out.display()
        )));
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| PlotError::Io {
            path: dir.to_path_buf(),
            reason: e.to_string(),
        })?;
    }
    Ok(Written {
        svg: out.with_extension("svg"),
        png: out.with_extension("png"),
    })
}

fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

fn color_of(series: &Series, index: usize) -> RGBColor {
    let (r, g, b) = series.color.unwrap_or(PALETTE[index % PALETTE.len()]);
    RGBColor(r, g, b)
}

fn finite(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.1.is_finite()
}

/// Runs of consecutive finite points.
fn segments(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for p in points {
        if finite(p) {
            cur.push(*p);
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Extend (lo, hi) over `v` (finite values only).
fn extend(range: &mut Option<(f64, f64)>, v: f64) {
    if v.is_finite() {
        *range = Some(match *range {
            None => (v, v),
            Some((lo, hi)) => (lo.min(v), hi.max(v)),
        });
    }
}

/// A drawable range: padded by `pad` of its span, never empty.
fn padded(range: Option<(f64, f64)>, pad: f64) -> (f64, f64) {
    match range {
        None => (0.0, 1.0),
        Some((lo, hi)) if hi - lo <= f64::EPSILON * lo.abs().max(hi.abs()).max(1.0) => {
            let d = lo.abs().max(1.0) * 0.05;
            (lo - d, hi + d)
        }
        Some((lo, hi)) => {
            let d = (hi - lo) * pad;
            (lo - d, hi + d)
        }
    }
}

/// Tick label with as many decimals as the axis span needs, and no "-0"; axes with a span
/// below 1e-3 or values above 1e6 use the exponent form (`1.5e-6`) to stay narrow.
fn tick(v: f64, span: f64) -> String {
    let is_zero = |s: &str| {
        s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
    };
    if span.is_finite() && span > 0.0 && (span < 1e-3 || v.abs() >= 1e6) {
        // Mantissa digits for ticks about span/10 apart.
        let digits = (v.abs().max(span) / (span / 10.0))
            .log10()
            .floor()
            .clamp(0.0, 6.0) as usize;
        let s = format!("{v:.digits$e}");
        return if is_zero(s.split('e').next().unwrap_or("")) {
            "0".into()
        } else {
            s
        };
    }
    let decimals = if span > 0.0 && span.is_finite() {
        (-(span / 10.0).log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        2
    };
    let s = format!("{v:.decimals$}");
    if is_zero(&s) {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

fn valid_range(r: (f64, f64)) -> bool {
    r.0.is_finite() && r.1.is_finite() && r.1 > r.0
}

type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draw series, reference lines and shades into a chart; returns whether anything carries
/// a legend entry.
fn draw_content<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    series: &[Series],
    hlines: &[HLine],
    shades: &[Shade],
    x: (f64, f64),
    y: (f64, f64),
) -> Result<bool, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut legend = false;
    // One tint per distinct shade name, in order of first appearance (grey, blue, amber).
    const SHADE_COLORS: [RGBColor; 3] = [
        RGBColor(120, 120, 120),
        RGBColor(60, 120, 220),
        RGBColor(230, 160, 20),
    ];
    let mut order: Vec<&str> = Vec::new();
    for s in shades {
        if !order.contains(&s.name.as_str()) {
            order.push(&s.name);
        }
    }
    let mut shade_names: Vec<&str> = Vec::new();
    for s in shades {
        if !(s.x0.is_finite() && s.x1.is_finite()) {
            continue;
        }
        let k = order.iter().position(|n| *n == s.name).unwrap_or(0);
        let shade_color = SHADE_COLORS[k % SHADE_COLORS.len()];
        let rect = Rectangle::new([(s.x0, y.0), (s.x1, y.1)], shade_color.mix(0.15).filled());
        let ann = chart.draw_series(std::iter::once(rect))?;
        if !s.name.is_empty() && !shade_names.contains(&s.name.as_str()) {
            shade_names.push(&s.name);
            legend = true;
            ann.label(s.name.clone()).legend(move |(px, py)| {
                Rectangle::new(
                    [(px, py - 5), (px + 20, py + 5)],
                    shade_color.mix(0.3).filled(),
                )
            });
        }
    }
    for (k, h) in hlines.iter().enumerate() {
        if !h.y.is_finite() {
            continue;
        }
        let c = RGBColor(200, 0, 0).mix(0.8 - 0.2 * (k % 3) as f64);
        let style = ShapeStyle {
            color: c.to_rgba(),
            filled: false,
            stroke_width: 2,
        };
        let ann = chart.draw_series(DashedLineSeries::new(
            vec![(x.0, h.y), (x.1, h.y)],
            10,
            6,
            style,
        ))?;
        if !h.name.is_empty() {
            legend = true;
            ann.label(h.name.clone())
                .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 20, py)], style));
        }
    }
    for (i, s) in series.iter().enumerate() {
        let color = color_of(s, i);
        let line = ShapeStyle {
            color: color.to_rgba(),
            filled: false,
            stroke_width: 2,
        };
        if matches!(s.style, Style::Text | Style::TextBelow) {
            let font = (FONT, LABEL_PX - 3).into_font().color(&color);
            let dy = if s.style == Style::Text { -17 } else { 4 };
            chart.draw_series(
                segments(&s.points).into_iter().flatten().map(|p| {
                    EmptyElement::at(p) + Text::new(s.name.clone(), (5, dy), font.clone())
                }),
            )?;
            continue;
        }
        let mut labelled = s.name.is_empty();
        for seg in segments(&s.points) {
            let ann = match s.style {
                Style::Text | Style::TextBelow => continue,
                Style::Line | Style::LineMarkers => {
                    chart.draw_series(LineSeries::new(seg.clone(), line))?
                }
                Style::Dashed => {
                    chart.draw_series(DashedLineSeries::new(seg.clone(), 8, 5, line))?
                }
                Style::Markers => {
                    chart.draw_series(seg.iter().map(|p| Circle::new(*p, 4, color.filled())))?
                }
            };
            if !labelled {
                labelled = true;
                legend = true;
                let ann = ann.label(s.name.clone());
                if s.style == Style::Markers {
                    ann.legend(move |(px, py)| Circle::new((px + 10, py), 4, color.filled()));
                } else {
                    ann.legend(move |(px, py)| {
                        PathElement::new(vec![(px, py), (px + 20, py)], line)
                    });
                }
            }
            if s.style == Style::LineMarkers {
                chart.draw_series(seg.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
            }
        }
    }
    Ok(legend)
}

/// Legend entries and the longest label of a chart's content (as [`draw_content`] labels it).
fn legend_entries(series: &[Series], hlines: &[HLine], shades: &[Shade]) -> (usize, usize) {
    let mut names: Vec<&str> = Vec::new();
    for s in shades.iter().filter(|s| !s.name.is_empty()) {
        if !names.contains(&s.name.as_str()) {
            names.push(&s.name);
        }
    }
    names.extend(
        hlines
            .iter()
            .filter(|h| !h.name.is_empty() && h.y.is_finite())
            .map(|h| h.name.as_str()),
    );
    names.extend(
        series
            .iter()
            .filter(|s| {
                !s.name.is_empty()
                    && !matches!(s.style, Style::Text | Style::TextBelow)
                    && s.points.iter().any(finite)
            })
            .map(|s| s.name.as_str()),
    );
    let longest = names.iter().map(|n| n.chars().count()).max().unwrap_or(0);
    (names.len(), longest)
}

/// The plot corner where the legend box covers the least data: every series point and
/// points along each line segment inside the box count 1, a reference line through it
/// counts 20. Ties keep the order upper right, upper left, lower right, lower left.
fn legend_corner(
    series: &[Series],
    hlines: &[HLine],
    shades: &[Shade],
    x: (f64, f64),
    y: (f64, f64),
    plot_px: (u32, u32),
) -> SeriesLabelPosition {
    let (entries, longest) = legend_entries(series, hlines, shades);
    // Label font LABEL_PX − 2: about 0.6 em per character, one row per entry, plus the
    // sample glyph and the box padding.
    let font = f64::from(LABEL_PX - 2);
    let box_w = 45.0 + 0.6 * font * longest as f64;
    let box_h = 12.0 + (font + 6.0) * entries as f64;
    let fx = (box_w / f64::from(plot_px.0.max(1))).min(1.0) * (x.1 - x.0);
    let fy = (box_h / f64::from(plot_px.1.max(1))).min(1.0) * (y.1 - y.0);
    let corners = [
        (SeriesLabelPosition::UpperRight, x.1 - fx, y.1 - fy),
        (SeriesLabelPosition::UpperLeft, x.0, y.1 - fy),
        (SeriesLabelPosition::LowerRight, x.1 - fx, y.0),
        (SeriesLabelPosition::LowerLeft, x.0, y.0),
    ];
    let mut best = (SeriesLabelPosition::UpperRight, usize::MAX);
    for (pos, x0, y0) in corners {
        let inside = |p: (f64, f64)| p.0 >= x0 && p.0 <= x0 + fx && p.1 >= y0 && p.1 <= y0 + fy;
        let mut n = 0usize;
        for s in series {
            for seg in segments(&s.points) {
                n += seg.iter().filter(|p| inside(**p)).count();
                if s.style != Style::Markers {
                    for w in seg.windows(2) {
                        n += (1..8)
                            .map(|k| f64::from(k) / 8.0)
                            .map(|t| {
                                (
                                    w[0].0 + t * (w[1].0 - w[0].0),
                                    w[0].1 + t * (w[1].1 - w[0].1),
                                )
                            })
                            .filter(|p| inside(*p))
                            .count();
                    }
                }
            }
        }
        n += 20
            * hlines
                .iter()
                .filter(|h| h.y >= y0 && h.y <= y0 + fy)
                .count();
        if n < best.1 {
            best = (pos, n);
        }
    }
    best.0
}

fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    position: SeriesLabelPosition,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT, LABEL_PX - 2))
        .draw()
}

fn time_series_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    fig: &Figure,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let area = if fig.title.is_empty() {
        root.clone()
    } else {
        root.titled(&fig.title, (FONT, TITLE_PX))?
    };
    let mut xr = fig.x_range;
    if xr.is_none() {
        for p in &fig.panels {
            for s in &p.series {
                for pt in s.points.iter().filter(|p| finite(p)) {
                    extend(&mut xr, pt.0);
                }
            }
            for s in &p.shades {
                extend(&mut xr, s.x0);
                extend(&mut xr, s.x1);
            }
        }
    }
    let x = match xr {
        Some(r) if valid_range(r) => r,
        other => padded(other, 0.0),
    };
    let n = fig.panels.len().max(1);
    let areas = area.split_evenly((n, 1));
    for (k, (panel, sub)) in fig.panels.iter().zip(areas.iter()).enumerate() {
        let mut yr = None;
        for s in &panel.series {
            for pt in s
                .points
                .iter()
                .filter(|p| finite(p) && p.0 >= x.0 && p.0 <= x.1)
            {
                extend(&mut yr, pt.1);
            }
        }
        for h in &panel.hlines {
            extend(&mut yr, h.y);
        }
        let y = match panel.y_range {
            Some(r) if valid_range(r) => r,
            _ => padded(yr, 0.08),
        };
        let last = k + 1 == fig.panels.len();
        let mut chart = ChartBuilder::on(sub)
            .margin(MARGIN)
            .x_label_area_size(if last { X_LABEL_AREA } else { 25 })
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        let (xs, ys) = (x.1 - x.0, y.1 - y.0);
        let fx = move |v: &f64| tick(*v, xs);
        let fy = move |v: &f64| tick(*v, ys);
        let mut mesh = chart.configure_mesh();
        mesh.y_desc(panel.y_label.as_str())
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style((FONT, LABEL_PX - 2))
            .axis_desc_style((FONT, LABEL_PX))
            .light_line_style(BLACK.mix(0.05));
        if last {
            mesh.x_desc(fig.x_label.as_str());
        }
        mesh.draw()?;
        if draw_content(
            &mut chart,
            &panel.series,
            &panel.hlines,
            &panel.shades,
            x,
            y,
        )? {
            let px = chart.plotting_area().dim_in_pixel();
            let at = legend_corner(&panel.series, &panel.hlines, &panel.shades, x, y, px);
            legend(&mut chart, at)?;
        }
    }
    root.present()
}

/// Fit data ranges of an x-y chart, widening for equal aspect.
fn xy_ranges(c: &XyChart) -> ((f64, f64), (f64, f64)) {
    let mut xr = None;
    let mut yr = None;
    for s in &c.series {
        for p in s.points.iter().filter(|p| finite(p)) {
            extend(&mut xr, p.0);
            extend(&mut yr, p.1);
        }
    }
    for h in &c.hlines {
        extend(&mut yr, h.y);
    }
    let mut x = c
        .x_range
        .filter(|r| valid_range(*r))
        .unwrap_or_else(|| padded(xr, 0.05));
    let mut y = c
        .y_range
        .filter(|r| valid_range(*r))
        .unwrap_or_else(|| padded(yr, 0.05));
    if c.equal_aspect {
        let title = if c.title.is_empty() { 0 } else { TITLE_PX + 16 };
        let w = f64::from(c.width_px.saturating_sub(2 * MARGIN + Y_LABEL_AREA).max(1));
        let h = f64::from(
            c.height_px
                .saturating_sub(2 * MARGIN + X_LABEL_AREA + title)
                .max(1),
        );
        let ux = (x.1 - x.0) / w;
        let uy = (y.1 - y.0) / h;
        if ux > uy {
            let mid = 0.5 * (y.0 + y.1);
            let half = 0.5 * ux * h;
            y = (mid - half, mid + half);
        } else {
            let mid = 0.5 * (x.0 + x.1);
            let half = 0.5 * uy * w;
            x = (mid - half, mid + half);
        }
    }
    (x, y)
}

/// A chart builder for a single-chart figure with the house margins and optional title.
fn single_chart<'a, 'b, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA);
    if !title.is_empty() {
        builder.caption(title, (FONT, TITLE_PX));
    }
    builder
}

fn xy_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    c: &XyChart,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (x, y) = xy_ranges(c);
    let mut builder = single_chart(&root, &c.title);
    let mut chart = builder.build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    let (xs, ys) = (x.1 - x.0, y.1 - y.0);
    chart
        .configure_mesh()
        .x_label_formatter(&|v| tick(*v, xs))
        .y_label_formatter(&|v| tick(*v, ys))
        .x_desc(c.x_label.as_str())
        .y_desc(c.y_label.as_str())
        .label_style((FONT, LABEL_PX - 2))
        .axis_desc_style((FONT, LABEL_PX))
        .light_line_style(BLACK.mix(0.05))
        .draw()?;
    if draw_content(&mut chart, &c.series, &c.hlines, &[], x, y)? {
        let px = chart.plotting_area().dim_in_pixel();
        let at = legend_corner(&c.series, &c.hlines, &[], x, y, px);
        legend(&mut chart, at)?;
    }
    root.present()
}

fn bars_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    c: &GroupedBars,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let n = c.categories.len().max(1);
    let mut yr = Some((0.0, 0.0));
    for (_, vals) in &c.groups {
        for v in vals {
            extend(&mut yr, *v);
        }
    }
    let (lo, hi) = padded(yr, 0.08);
    let y = (
        if yr.is_some_and(|r| r.0 >= 0.0) {
            0.0
        } else {
            lo
        },
        hi,
    );
    let mut builder = single_chart(&root, &c.title);
    let mut chart = builder.build_cartesian_2d(0.0..n as f64, y.0..y.1)?;
    let names = c.categories.clone();
    let label = move |v: &f64| -> String {
        let i = v.floor();
        if (v - i - 0.5).abs() < 1e-6 && i >= 0.0 {
            names.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(2 * n + 1)
        .x_label_formatter(&label)
        .y_label_formatter(&|v| tick(*v, y.1 - y.0))
        .y_desc(c.y_label.as_str())
        .label_style((FONT, LABEL_PX - 2))
        .axis_desc_style((FONT, LABEL_PX))
        .light_line_style(BLACK.mix(0.05))
        .draw()?;
    let g = c.groups.len().max(1) as f64;
    let width = 0.8 / g;
    for (j, (name, vals)) in c.groups.iter().enumerate() {
        let (r, g, b) = PALETTE[j % PALETTE.len()];
        let color = RGBColor(r, g, b);
        let rects: Vec<_> = vals
            .iter()
            .enumerate()
            .take(n)
            .filter(|(_, v)| v.is_finite())
            .map(|(i, v)| {
                let x0 = i as f64 + 0.1 + j as f64 * width;
                Rectangle::new(
                    [(x0, 0.0_f64.max(y.0)), (x0 + width * 0.9, *v)],
                    color.filled(),
                )
            })
            .collect();
        chart
            .draw_series(rects)?
            .label(name.clone())
            .legend(move |(px, py)| {
                Rectangle::new([(px, py - 5), (px + 20, py + 5)], color.filled())
            });
    }
    if !c.groups.is_empty() {
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    }
    root.present()
}

macro_rules! both {
    ($out:expr, $size:expr, $draw:ident, $what:expr) => {{
        ensure_font()?;
        let w = outputs($out)?;
        if $size.0 < 100 || $size.1 < 100 {
            return Err(PlotError::Invalid(format!(
                "size {:?} px is below 100 × 100",
                $size
            )));
        }
        $draw(SVGBackend::new(&w.svg, $size).into_drawing_area(), $what)
            .map_err(|e| draw_err(&w.svg, e))?;
        $draw(BitMapBackend::new(&w.png, $size).into_drawing_area(), $what)
            .map_err(|e| draw_err(&w.png, e))?;
        Ok(w)
    }};
}

/// Write stacked time-series panels to `out` with extensions `.svg` and `.png`.
pub fn time_series(fig: &Figure, out: impl AsRef<Path>) -> Result<Written, PlotError> {
    let n = u32::try_from(fig.panels.len().max(1)).unwrap_or(u32::MAX);
    let title = if fig.title.is_empty() {
        0
    } else {
        TITLE_PX + 16
    };
    let size = (
        fig.width_px,
        fig.panel_height_px.saturating_mul(n).saturating_add(title),
    );
    both!(out.as_ref(), size, time_series_on, fig)
}

/// Write an x-y chart to `out` with extensions `.svg` and `.png`.
pub fn xy_chart(chart: &XyChart, out: impl AsRef<Path>) -> Result<Written, PlotError> {
    let size = (chart.width_px, chart.height_px);
    both!(out.as_ref(), size, xy_on, chart)
}

/// Write a grouped bar chart to `out` with extensions `.svg` and `.png`.
pub fn grouped_bars(chart: &GroupedBars, out: impl AsRef<Path>) -> Result<Written, PlotError> {
    let size = (chart.width_px, chart.height_px);
    both!(out.as_ref(), size, bars_on, chart)
}

#[cfg(test)]
mod tests {
    use super::{legend_corner, tick, HLine, Series, SeriesLabelPosition};

    fn corner(series: &[Series], hlines: &[HLine]) -> SeriesLabelPosition {
        legend_corner(series, hlines, &[], (0.0, 60.0), (0.0, 1000.0), (900, 200))
    }

    #[test]
    fn the_legend_goes_where_it_covers_the_least_data() {
        // A run that ends high on the right (the upper-right default would cover it).
        let rising: Vec<(f64, f64)> = (0..=600)
            .map(|k| (0.1 * f64::from(k), 900.0 * f64::from(k) / 600.0))
            .collect();
        let pos = corner(&[Series::line("force", rising)], &[]);
        assert!(matches!(pos, SeriesLabelPosition::UpperLeft), "{pos:?}");
        // Data along the top, and a sparse line (two points) across the bottom: the segment
        // between the points counts, so the legend stays off both.
        let top: Vec<(f64, f64)> = (0..=600).map(|k| (0.1 * f64::from(k), 950.0)).collect();
        let bottom = vec![(0.0, 30.0), (60.0, 30.0)];
        let pos = corner(
            &[Series::line("a", top), Series::line("b", bottom)],
            &[HLine::new("Fr", 800.0)],
        );
        assert!(
            !matches!(
                pos,
                SeriesLabelPosition::UpperRight | SeriesLabelPosition::UpperLeft
            ),
            "{pos:?}"
        );
    }

    #[test]
    fn tick_labels_are_short_and_never_negative_zero() {
        assert_eq!(tick(-0.0001, 2.4), "0.0");
        assert_eq!(tick(0.5, 2.4), "0.5");
        assert_eq!(tick(800.0, 300.0), "800");
        assert_eq!(tick(1.5e-6, 1.6e-6), "1.5e-6");
        assert_eq!(tick(0.0, 1.6e-6), "0");
        assert_eq!(tick(2.5e6, 1e6), "2.5e6");
    }
}
