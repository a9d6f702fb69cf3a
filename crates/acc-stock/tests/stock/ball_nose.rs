//! The ball-nose end mill against its analytic geometry: slot width and cross-section,
//! spherical-cap plunge, a second pass, a side cut.

use std::f64::consts::PI;

use crate::common::*;
use acc_stock::{Cutter, Move, Spindle, StepKind, Sweep, SweepOptions};

fn ball_sweep() -> Sweep {
    let ball = Cutter::ball(10.0, 2, 20.0).expect("cutter");
    Sweep::new(
        block(100.0, 40.0),
        ball,
        Spindle::cw(2000.0),
        SweepOptions::default(),
    )
    .expect("sweep")
}

#[test]
fn shallow_ball_slot_is_as_wide_as_the_sphere_at_the_top() {
    let mut s = ball_sweep();
    let ap: f64 = 2.0;
    let r = 5.0f64;
    let mut out = Vec::new();
    s.cut(
        &Move::feed([-10.0, 20.0, -ap], [110.0, 20.0, -ap], 400.0),
        &mut out,
    );
    // Width at the top: 2√(2R·a_p − a_p²) = 8 mm.
    let width = 2.0 * (2.0 * r * ap - ap * ap).sqrt();
    for e in x_between(&out, 10.0, 90.0) {
        assert_eq!((e.kind, e.arcs), (StepKind::Cut, 1));
        assert!((e.span_rad - PI).abs() < 1e-9, "{e:?}");
        // The outermost engaged ring lies within one ring spacing (a cell) of the edge.
        assert!((e.ae_mm - width).abs() <= 2.0 * CELL, "{e:?}");
        assert!((e.ap_mm - ap).abs() < 1e-3, "{e:?}");
    }
    // Cross-section: the circular segment R²·acos((R − a_p)/R) − (R − a_p)·w/2, over the
    // 100 mm of stock.
    let area = r * r * ((r - ap) / r).acos() - (r - ap) * 0.5 * width;
    let removed: f64 = out.iter().map(|e| e.removed_mm3).sum();
    let analytic = area * 100.0;
    assert!(
        (removed / analytic - 1.0).abs() < 5e-3,
        "{removed} vs {analytic}"
    );
    // Over the same line again: nothing.
    let mut again = Vec::new();
    s.cut(
        &Move::feed([110.0, 20.0, -ap], [-10.0, 20.0, -ap], 400.0),
        &mut again,
    );
    for e in &again {
        assert!(e.kind == StepKind::Air && e.removed_mm3 < 1e-3, "{e:?}");
    }
}

#[test]
fn ball_plunge_removes_a_spherical_cap() {
    let mut s = ball_sweep();
    let h = 3.0;
    let mut out = Vec::new();
    s.cut(
        &Move::feed([50.0, 20.0, 5.0], [50.0, 20.0, -h], 100.0),
        &mut out,
    );
    assert!(out
        .iter()
        .all(|e| e.kind == StepKind::Air || e.kind == StepKind::Plunge));
    let removed: f64 = out.iter().map(|e| e.removed_mm3).sum();
    let cap = PI * h * h * (3.0 * 5.0 - h) / 3.0;
    assert!((removed / cap - 1.0).abs() < 0.01, "{removed} vs {cap}");
}

#[test]
fn ball_side_cut_below_the_equator_is_cylindrical() {
    // Deeper than R the ball's flank is the cylinder: a side cut a_e = 2 at a_p = 8 looks
    // like the flat end mill's, acos(1 − 2a_e/D) of arc.
    let mut s = ball_sweep();
    let ae: f64 = 2.0;
    let mut out = Vec::new();
    s.cut(
        &Move::feed([-10.0, -5.0 + ae, -8.0], [110.0, -5.0 + ae, -8.0], 400.0),
        &mut out,
    );
    let arc = (1.0 - 2.0 * ae / 10.0).acos();
    for e in x_between(&out, 10.0, 90.0) {
        assert!(e.entry_rad.abs() < 1e-12);
        assert!((e.exit_rad - arc).abs() <= PI / 180.0 + 1e-9, "{e:?}");
        assert!((e.ae_mm - ae).abs() < 0.1);
        assert!((e.ap_mm - 8.0).abs() < 1e-5);
    }
}

#[test]
fn ball_second_pass_read_from_the_cells_is_air() {
    // Without the exact window the first pass is known from the cells only; the probes read
    // the cells at their centres, where the cells were cut, so no slope shows as material.
    let ball = Cutter::ball(10.0, 2, 20.0).expect("cutter");
    let options = SweepOptions {
        exact_moves: 0,
        ..SweepOptions::default()
    };
    let mut s = Sweep::new(block(100.0, 40.0), ball, Spindle::cw(2000.0), options).expect("sweep");
    let mut out = Vec::new();
    s.cut(
        &Move::feed([-10.0, 20.0, -2.0], [110.0, 20.0, -2.0], 400.0),
        &mut out,
    );
    assert!(out.iter().any(|e| e.kind == StepKind::Cut));
    for (a, b) in [
        ([110.0, 20.0, -2.0], [-10.0, 20.0, -2.0]),
        ([-10.0, 20.0, -2.0], [110.0, 20.0, -2.0]),
    ] {
        let mut again = Vec::new();
        s.cut(&Move::feed(a, b, 400.0), &mut again);
        for e in &again {
            assert!(e.kind == StepKind::Air && e.removed_mm3 < 1e-3, "{e:?}");
        }
    }
}
