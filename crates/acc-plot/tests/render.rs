//! Every figure shape is written as SVG and PNG; PNGs are real images with the requested
//! dimensions; NaN and empty data do not fail.
#![allow(clippy::unwrap_used)]

use std::path::Path;

use acc_plot::{
    grouped_bars, time_series, unit_circle, xy_chart, Figure, GroupedBars, HLine, Panel, Series,
    Shade, Style, XyChart,
};

/// PNG signature and the IHDR width/height (bytes 16..24, big-endian).
fn png_dimensions(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR");
    assert_eq!(
        &bytes[bytes.len() - 8..bytes.len() - 4],
        b"IEND",
        "truncated PNG"
    );
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h)
}

/// With `ACC_PLOT_KEEP=<dir>` the PNG is copied there for a look.
fn keep(png: &Path, name: &str) {
    if let Ok(dir) = std::env::var("ACC_PLOT_KEEP") {
        std::fs::copy(png, Path::new(&dir).join(name)).unwrap();
    }
}

fn size(path: &Path) -> u64 {
    std::fs::metadata(path).unwrap().len()
}

fn ramp(n: usize, f: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
    (0..n).map(|i| i as f64 * 0.1).map(|t| (t, f(t))).collect()
}

#[test]
fn time_series_writes_svg_and_png_with_labels() {
    let dir = tempfile::tempdir().unwrap();
    let mut force = ramp(200, |t| 800.0 + 100.0 * (3.0 * t).sin());
    force[50].1 = f64::NAN; // a gap, not a failure
    let fig = Figure {
        title: "Closed loop, case III".into(),
        x_label: "time [s]".into(),
        panels: vec![
            Panel {
                y_label: "force [N]".into(),
                series: vec![Series::line("Fc", force)],
                hlines: vec![HLine::new("Fr = 800 N", 800.0)],
                shades: vec![
                    Shade::new("air cut", 0.0, 2.0),
                    Shade::new("air cut", 15.0, 20.0),
                ],
                ..Panel::default()
            },
            Panel {
                y_label: "override [%]".into(),
                series: vec![
                    Series::line(
                        "command",
                        ramp(200, |t| (10.0 * (t / 2.0).floor()).min(150.0)),
                    ),
                    Series::line("unquantized", ramp(200, |t| (5.0 * t).min(150.0)))
                        .with_style(Style::Dashed),
                ],
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    let w = time_series(&fig, dir.path().join("sub/ts.svg")).unwrap();
    assert_eq!(w.png, dir.path().join("sub/ts.png"));
    assert!(size(&w.svg) > 5_000, "svg only {} bytes", size(&w.svg));
    assert!(size(&w.png) > 10_000, "png only {} bytes", size(&w.png));
    assert_eq!(png_dimensions(&w.png), (1000, 2 * 260 + 38));
    let svg = std::fs::read_to_string(&w.svg).unwrap();
    for label in [
        "Closed loop, case III",
        "force [N]",
        "override [%]",
        "time [s]",
        "Fr = 800 N",
        "air cut",
    ] {
        assert!(svg.contains(label), "svg lacks {label:?}");
    }
    keep(&w.png, "ts.png");
}

#[test]
fn pole_map_has_equal_aspect_and_markers() {
    let dir = tempfile::tempdir().unwrap();
    let path: Vec<(f64, f64)> = (0..50)
        .map(|k| (0.5 - 0.03 * k as f64, 0.02 * k as f64))
        .collect();
    let chart = XyChart {
        title: "Pole map".into(),
        x_label: "Re z".into(),
        y_label: "Im z".into(),
        series: vec![
            unit_circle(100),
            Series::markers("desired", vec![(0.2, 0.0), (-0.05, 0.0)]),
            Series::line("path", path).with_style(Style::LineMarkers),
        ],
        equal_aspect: true,
        width_px: 700,
        height_px: 600,
        ..XyChart::default()
    };
    let w = xy_chart(&chart, dir.path().join("poles")).unwrap();
    assert_eq!(png_dimensions(&w.png), (700, 600));
    assert!(size(&w.svg) > 3_000 && size(&w.png) > 8_000);
    assert!(std::fs::read_to_string(&w.svg).unwrap().contains("desired"));
    keep(&w.png, "poles.png");
}

#[test]
fn grouped_bars_render_category_names() {
    let dir = tempfile::tempdir().unwrap();
    let chart = GroupedBars {
        title: "RMS force error".into(),
        y_label: "error [N]".into(),
        categories: vec!["steps".into(), "ramp".into(), "air".into()],
        groups: vec![
            ("adaptive".into(), vec![20.0, 15.0, f64::NAN]),
            ("fixed".into(), vec![80.0, 60.0, 10.0]),
        ],
        ..GroupedBars::default()
    };
    let w = grouped_bars(&chart, dir.path().join("bars.png")).unwrap();
    assert_eq!(png_dimensions(&w.png), (1000, 500));
    let svg = std::fs::read_to_string(&w.svg).unwrap();
    for label in ["steps", "ramp", "air", "adaptive", "fixed"] {
        assert!(svg.contains(label), "svg lacks {label:?}");
    }
    keep(&w.png, "bars.png");
}

#[test]
fn empty_and_all_nan_data_draw_a_frame() {
    let dir = tempfile::tempdir().unwrap();
    let fig = Figure {
        panels: vec![
            Panel::default(),
            Panel {
                series: vec![Series::line("nan", vec![(f64::NAN, 1.0), (2.0, f64::NAN)])],
                ..Panel::default()
            },
        ],
        ..Figure::default()
    };
    let w = time_series(&fig, dir.path().join("empty")).unwrap();
    assert!(png_dimensions(&w.png).0 == 1000);
    let w = xy_chart(&XyChart::default(), dir.path().join("empty-xy")).unwrap();
    assert!(w.svg.exists());
    let err = xy_chart(
        &XyChart {
            width_px: 10,
            ..XyChart::default()
        },
        dir.path().join("tiny"),
    );
    assert!(err.is_err());
}
