//! Straight cuts against their analytic engagement: a slot (a_e = D, 180°), up and down
//! side milling at a_e = D/4 (the arc `acos(1 − 2a_e/D)`), the mirrored spindle, chip load.

use std::f64::consts::PI;

use crate::common::*;
use acc_stock::{Move, Rotation, Spindle, StepKind, Sweep, SweepOptions};

/// One angular bin (default 180 over the leading half), rad.
const BIN: f64 = PI / 180.0;

#[test]
fn slot_is_full_width_and_half_a_turn() {
    let mut s = sweep(block(100.0, 40.0));
    let steps = feed(&mut s, [-10.0, 20.0, -3.0], [110.0, 20.0, -3.0]);
    // Tool wholly inside the stock: 5 ≤ x ≤ 95.
    let inside = x_between(&steps, 6.0, 95.0);
    assert!(inside.len() > 300);
    for e in &inside {
        assert_eq!(e.kind, StepKind::Cut);
        assert_eq!(e.arcs, 1);
        assert!(e.entry_rad.abs() < 1e-12 && (e.exit_rad - PI).abs() < 1e-12);
        assert!((e.span_rad - PI).abs() < 1e-12, "{}", e.span_rad);
        assert!((e.ae_mm - 10.0).abs() < 1e-9 && (e.radial_mm - 10.0).abs() < 1e-9);
        assert!((e.ap_mm - 3.0).abs() < 1e-5);
        // 400 mm/min at 1000 rpm with 4 flutes; the chip is thickest straight ahead.
        assert!((e.feed_per_tooth_mm - 0.1).abs() < 1e-12);
        assert!((e.chip_max_mm - 0.1).abs() < 1e-12);
        // Removal rate a_e·a_p·v_f = 10·3·400 within the cells' error.
        assert!(
            (e.removal_rate_mm3_min / 12_000.0 - 1.0).abs() < 0.1,
            "{e:?}"
        );
    }
    // Entering the block from outside: the front touches first (a centred arc), then grows.
    let entry = x_between(&steps, -5.0, 4.0);
    let first = entry
        .iter()
        .find(|e| e.kind == StepKind::Cut)
        .expect("engages");
    // Centred on straight ahead, at most ±18° after one 0.25 mm step (sin φ > 0.95).
    assert!((first.entry_rad + first.exit_rad - PI).abs() <= 2.0 * BIN + 1e-9);
    assert!(first.span_rad < 0.7, "{first:?}");
    assert!(entry
        .windows(2)
        .all(|w| w[1].span_rad >= w[0].span_rad - 1e-12));
}

/// Engagement of a side cut `ae` (mm) wide into the wall y ≥ 0 of a block, the tool moving
/// along +X (material on the left) or −X (material on the right).
fn side_cut(ae: f64, plus_x: bool, rotation: Rotation) -> Vec<acc_stock::StepEngagement> {
    let stock = block(100.0, 40.0);
    let spindle = Spindle {
        rpm: 1000.0,
        rotation,
    };
    let mut s = Sweep::new(stock, mill(), spindle, SweepOptions::default()).expect("sweep");
    let y = -5.0 + ae;
    let (a, b) = if plus_x {
        (-10.0, 110.0)
    } else {
        (110.0, -10.0)
    };
    let steps = feed(&mut s, [a, y, -4.0], [b, y, -4.0]);
    x_between(&steps, 10.0, 90.0)
}

#[test]
fn up_milling_side_cut_exits_at_the_analytic_angle() {
    let ae: f64 = 2.5; // D/4
    let arc = (1.0 - 2.0 * ae / 10.0).acos(); // 60°
    let steps = side_cut(ae, true, Rotation::Clockwise);
    assert!(steps.len() > 300);
    for e in &steps {
        // Material on the left of +X with a clockwise spindle: up milling, from φ = 0.
        assert_eq!((e.kind, e.arcs), (StepKind::Cut, 1));
        assert!(e.entry_rad.abs() < 1e-12);
        assert!(
            (e.exit_rad - arc).abs() <= BIN + 1e-9,
            "{} vs {arc}",
            e.exit_rad
        );
        assert!((e.ae_mm - ae).abs() < 0.1, "{}", e.ae_mm);
        assert!((e.ap_mm - 4.0).abs() < 1e-5);
        // Chip thickest at the exit: f_z·sin 60°.
        assert!((e.chip_max_mm - 0.1 * e.exit_rad.sin()).abs() < 1e-12);
    }
}

#[test]
fn down_milling_side_cut_enters_at_the_analytic_angle() {
    let ae: f64 = 2.5;
    let arc = (1.0 - 2.0 * ae / 10.0).acos();
    let steps = side_cut(ae, false, Rotation::Clockwise);
    assert!(steps.len() > 300);
    for e in &steps {
        // Along −X the wall is on the right: down milling, ending at φ = π.
        assert_eq!((e.kind, e.arcs), (StepKind::Cut, 1));
        assert!(
            (e.entry_rad - (PI - arc)).abs() <= BIN + 1e-9,
            "{}",
            e.entry_rad
        );
        assert!((e.exit_rad - PI).abs() < 1e-12);
        assert!((e.span_rad - arc).abs() <= BIN + 1e-9);
        assert!((e.ae_mm - ae).abs() < 0.1);
    }
    // The counter-clockwise spindle mirrors it: the same cut is up milling.
    for e in &side_cut(ae, false, Rotation::CounterClockwise) {
        assert!(e.entry_rad.abs() < 1e-12);
        assert!((e.exit_rad - arc).abs() <= BIN + 1e-9);
    }
}

#[test]
fn side_cut_widths_follow_the_analytic_arc() {
    for ae in [0.5f64, 1.0, 2.0, 5.0, 7.5] {
        let arc = (1.0 - 2.0 * ae / 10.0).acos();
        for e in &side_cut(ae, true, Rotation::Clockwise) {
            assert!((e.span_rad - arc).abs() <= BIN + 1e-9, "ae {ae}: {e:?}");
            assert!((e.ae_mm - ae).abs() <= 5.0 * BIN + 1e-9, "ae {ae}: {e:?}");
        }
    }
}

#[test]
fn stopped_spindle_has_no_chip_load() {
    let mut s = Sweep::new(
        block(50.0, 40.0),
        mill(),
        Spindle::cw(0.0),
        SweepOptions::default(),
    )
    .expect("sweep");
    let mut out = Vec::new();
    s.cut(
        &Move::feed([0.0, 20.0, -1.0], [40.0, 20.0, -1.0], 300.0),
        &mut out,
    );
    assert!(out.iter().any(|e| e.kind == StepKind::Cut));
    assert!(out
        .iter()
        .all(|e| e.feed_per_tooth_mm == 0.0 && e.chip_max_mm == 0.0));
}
