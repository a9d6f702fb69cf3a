//! What every chart shares: the embedded font, the output files, colours, finite runs of
//! points, axis ranges and tick labels, and drawing a chart's series, reference lines and
//! shades.

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::{HLine, PlotError, Series, Shade, Style, Written, PALETTE};

pub(crate) const FONT: &str = "sans-serif";
pub(crate) const TITLE_PX: u32 = 22;
pub(crate) const LABEL_PX: u32 = 16;
pub(crate) const X_LABEL_AREA: u32 = 45;
pub(crate) const Y_LABEL_AREA: u32 = 75;
pub(crate) const MARGIN: u32 = 12;

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
pub(crate) fn outputs(out: &Path) -> Result<Written, PlotError> {
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

pub(crate) fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

pub(crate) fn color_of(series: &Series, index: usize) -> RGBColor {
    let (r, g, b) = series.color.unwrap_or(PALETTE[index % PALETTE.len()]);
    RGBColor(r, g, b)
}

pub(crate) fn finite(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.1.is_finite()
}

/// Runs of consecutive finite points.
pub(crate) fn segments(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
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
pub(crate) fn extend(range: &mut Option<(f64, f64)>, v: f64) {
    if v.is_finite() {
        *range = Some(match *range {
            None => (v, v),
            Some((lo, hi)) => (lo.min(v), hi.max(v)),
        });
    }
}

/// A drawable range: padded by `pad` of its span, never empty.
pub(crate) fn padded(range: Option<(f64, f64)>, pad: f64) -> (f64, f64) {
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
pub(crate) fn tick(v: f64, span: f64) -> String {
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

pub(crate) fn valid_range(r: (f64, f64)) -> bool {
    r.0.is_finite() && r.1.is_finite() && r.1 > r.0
}

pub(crate) type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draw series, reference lines and shades into a chart; returns whether anything carries
/// a legend entry.
pub(crate) fn draw_content<'a, DB: DrawingBackend + 'a>(
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

#[cfg(test)]
mod tests {
    use super::tick;

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
