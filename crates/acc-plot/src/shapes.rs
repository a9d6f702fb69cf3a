//! The three chart layouts: stacked time-series panels, the x-y chart and grouped bars.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::legend::{legend, legend_corner};
use crate::render::{
    draw_content, extend, finite, padded, tick, valid_range, FONT, LABEL_PX, MARGIN, TITLE_PX,
    X_LABEL_AREA, Y_LABEL_AREA,
};
use crate::{Figure, GroupedBars, XyChart, PALETTE};

pub(crate) fn time_series_on<DB: DrawingBackend>(
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
pub(crate) fn xy_ranges(c: &XyChart) -> ((f64, f64), (f64, f64)) {
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
pub(crate) fn single_chart<'a, 'b, DB: DrawingBackend>(
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

pub(crate) fn xy_on<DB: DrawingBackend>(
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

pub(crate) fn bars_on<DB: DrawingBackend>(
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
