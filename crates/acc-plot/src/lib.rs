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

mod heightmap;
mod legend;
mod render;
mod shapes;

use std::path::{Path, PathBuf};

use plotters::prelude::*;

pub use heightmap::{height_field, HeightField};
pub use render::ensure_font;
use render::{draw_err, outputs, TITLE_PX};
use shapes::{bars_on, time_series_on, xy_on};

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
