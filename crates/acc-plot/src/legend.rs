//! The legend: its entries, and the corner of the plot where it covers the least data.

use plotters::prelude::*;

use crate::render::{finite, segments, Chart, FONT, LABEL_PX};
use crate::{HLine, Series, Shade, Style};

/// Legend entries and the longest label of a chart's content (as [`draw_content`] labels it).
pub(crate) fn legend_entries(
    series: &[Series],
    hlines: &[HLine],
    shades: &[Shade],
) -> (usize, usize) {
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
pub(crate) fn legend_corner(
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

pub(crate) fn legend<'a, DB: DrawingBackend + 'a>(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
