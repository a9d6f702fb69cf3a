//! A top view of a height field (the stock after a program): one coloured cell per grid
//! cell, low = dark blue, high = yellow, with x/y axes in mm and a colour scale.

use std::path::Path;

use plotters::prelude::*;

use crate::render::{draw_err, ensure_font, outputs, FONT, LABEL_PX, TITLE_PX};
use crate::{PlotError, Written};

/// A grid of heights seen from above.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightField<'a> {
    /// Title above the picture.
    pub title: String,
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Heights, mm, row by row from the smallest y (`heights[j·nx + i]`).
    pub heights: &'a [f32],
    /// x of the grid's left edge and y of its bottom edge, mm.
    pub corner_mm: (f64, f64),
    /// Cell edge, mm.
    pub cell_mm: f64,
}

/// At most this many drawn cells along a side (larger grids are drawn with the lowest
/// height of each block of cells, so that a cut never disappears).
const MAX_CELLS: usize = 400;

/// Viridis-like ramp from dark blue (0) through green to yellow (1).
fn ramp(t: f64) -> RGBColor {
    const STOPS: [(f64, (f64, f64, f64)); 5] = [
        (0.0, (68.0, 1.0, 84.0)),
        (0.25, (59.0, 82.0, 139.0)),
        (0.5, (33.0, 145.0, 140.0)),
        (0.75, (94.0, 201.0, 98.0)),
        (1.0, (253.0, 231.0, 37.0)),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let k = STOPS.iter().position(|s| s.0 >= t).unwrap_or(4).max(1);
    let (t0, a) = STOPS[k - 1];
    let (t1, b) = STOPS[k];
    let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    let c = |x: f64, y: f64| (x + u * (y - x)).round() as u8;
    RGBColor(c(a.0, b.0), c(a.1, b.1), c(a.2, b.2))
}

/// Draw `field` to `out` (`.svg` and `.png`).
pub fn height_field(field: &HeightField<'_>, out: &Path) -> Result<Written, PlotError> {
    if field.nx == 0 || field.ny == 0 || field.heights.len() != field.nx * field.ny {
        return Err(PlotError::Invalid(format!(
            "height field of {}×{} cells with {} heights",
            field.nx,
            field.ny,
            field.heights.len()
        )));
    }
    ensure_font()?;
    let written = outputs(out)?;
    let block = field.nx.max(field.ny).div_ceil(MAX_CELLS).max(1);
    let (bx, by) = (field.nx.div_ceil(block), field.ny.div_ceil(block));
    let mut cells = vec![f32::INFINITY; bx * by];
    for j in 0..field.ny {
        for i in 0..field.nx {
            let c = &mut cells[(j / block) * bx + i / block];
            *c = c.min(field.heights[j * field.nx + i]);
        }
    }
    let (lo, hi) = cells
        .iter()
        .filter(|h| h.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), h| {
            (a.min(*h), b.max(*h))
        });
    let span = f64::from(hi - lo).max(1e-9);
    let w = field.cell_mm * field.nx as f64;
    let h = field.cell_mm * field.ny as f64;
    let (x0, y0) = field.corner_mm;
    let side = 640u32;
    let size = (side + 170, side + 60);
    let grid = Grid {
        cells: &cells,
        bx,
        by,
        cw: field.cell_mm * block as f64,
        lo: f64::from(lo),
        span,
        x: (x0, x0 + w),
        y: (y0, y0 + h),
        side,
    };
    draw_on(
        SVGBackend::new(&written.svg, size).into_drawing_area(),
        &field.title,
        &grid,
    )
    .map_err(|e| draw_err(&written.svg, e))?;
    draw_on(
        BitMapBackend::new(&written.png, size).into_drawing_area(),
        &field.title,
        &grid,
    )
    .map_err(|e| draw_err(&written.png, e))?;
    Ok(written)
}

/// The cells to draw (blocks of the field) and the axes.
struct Grid<'a> {
    cells: &'a [f32],
    bx: usize,
    by: usize,
    /// Drawn cell edge, mm.
    cw: f64,
    /// Lowest height and the height span, mm.
    lo: f64,
    span: f64,
    x: (f64, f64),
    y: (f64, f64),
    side: u32,
}

fn draw_on<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    g: &Grid<'_>,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (plot, scale) = root.split_horizontally(g.side + 60);
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, (FONT, TITLE_PX))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(g.x.0..g.x.1, g.y.0..g.y.1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x, mm")
        .y_desc("y, mm")
        .label_style((FONT, LABEL_PX))
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series((0..g.by).flat_map(|j| {
            (0..g.bx).map(move |i| {
                let v = (f64::from(g.cells[j * g.bx + i]) - g.lo) / g.span;
                let (xa, ya) = (g.x.0 + i as f64 * g.cw, g.y.0 + j as f64 * g.cw);
                Rectangle::new(
                    [(xa, ya), ((xa + g.cw).min(g.x.1), (ya + g.cw).min(g.y.1))],
                    ramp(v).filled(),
                )
            })
        }))
        .map_err(|e| e.to_string())?;
    // The colour scale: a bar with its top and bottom heights written beside it.
    let mut bar = ChartBuilder::on(&scale)
        .margin_top(40)
        .margin_bottom(50)
        .margin_right(90)
        .build_cartesian_2d(0.0..1.0, g.lo..g.lo + g.span)
        .map_err(|e| e.to_string())?;
    bar.draw_series((0..100).map(|k| {
        let z = g.lo + g.span * k as f64 / 100.0;
        Rectangle::new(
            [(0.0, z), (1.0, z + g.span / 100.0)],
            ramp(k as f64 / 100.0).filled(),
        )
    }))
    .map_err(|e| e.to_string())?;
    let style = TextStyle::from((FONT, LABEL_PX).into_font());
    for (z, label) in [
        (g.lo + g.span, format!("{:.2} mm", g.lo + g.span)),
        (g.lo + 0.5 * g.span, "z".to_string()),
        (g.lo, format!("{:.2} mm", g.lo)),
    ] {
        let (px, py) = bar.backend_coord(&(1.0, z));
        root.draw(&Text::new(label, (px + 6, py - 8), style.clone()))
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_runs_from_blue_to_yellow() {
        assert_eq!(ramp(0.0), RGBColor(68, 1, 84));
        assert_eq!(ramp(1.0), RGBColor(253, 231, 37));
        assert_eq!(ramp(f64::NAN), ramp(0.0));
    }

    #[test]
    fn a_cut_stock_is_drawn_to_both_files() {
        let dir = tempfile::tempdir().expect("dir");
        let (nx, ny) = (900, 500);
        let mut heights = vec![10.0f32; nx * ny];
        for h in heights.iter_mut().skip(nx * 200).take(nx * 50) {
            *h = 5.0;
        }
        let f = HeightField {
            title: "stock".into(),
            nx,
            ny,
            heights: &heights,
            corner_mm: (0.0, 0.0),
            cell_mm: 0.25,
        };
        let w = height_field(&f, &dir.path().join("stock")).expect("drawn");
        assert!(std::fs::metadata(&w.png).expect("png").len() > 1000);
        let svg = std::fs::read_to_string(&w.svg).expect("svg");
        assert!(
            svg.contains("rgb(68,1,84)") || svg.contains("#440154"),
            "the cut is drawn dark"
        );
        let bad = HeightField {
            heights: &heights[1..],
            ..f
        };
        assert!(height_field(&bad, &dir.path().join("bad")).is_err());
    }
}
