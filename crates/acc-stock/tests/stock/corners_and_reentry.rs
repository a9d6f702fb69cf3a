//! Engagement where it jumps: the inside and outside corners of a pocket, re-entry across a
//! cut-through slot (air → partial → full), a second pass, a second level, plunges, ramps
//! and rapids.

use std::f64::consts::PI;

use crate::common::*;
use acc_stock::{Cutter, Move, Spindle, StepKind, Sweep, SweepOptions};

#[test]
fn inside_corner_of_a_pocket_peaks_the_engagement() {
    // A pocket roughed out to z = −5 over x ≤ 50, y ≥ 10: walls along y < 10 and x > 50.
    let mut stock = block(60.0, 60.0);
    stock.lower_rect([0.0, 10.0], [50.0, 60.0], -5.0);
    let mut s = sweep(stock);
    // Finishing 1 mm off both walls (down milling, the wall on the right), around the corner.
    let along_x = feed(&mut s, [10.0, 14.0, -3.0], [46.0, 14.0, -3.0]);
    let along_y = feed(&mut s, [46.0, 14.0, -3.0], [46.0, 50.0, -3.0]);
    let steady: Vec<_> = x_between(&along_x, 15.0, 38.0);
    for e in &steady {
        assert_eq!(e.arcs, 1);
        assert!((e.ae_mm - 1.0).abs() < 0.1, "{e:?}");
        assert!((e.exit_rad - PI).abs() < 1e-12);
    }
    // Approaching the corner the front meets the second wall: a second arc, centred
    // straight ahead, and the effective radial depth grows to about 7 mm at the corner
    // (arcs 53°..127° and 143°..180°: 6 + 1 mm), the width to 8 mm.
    let last = along_x.last().expect("steps");
    assert_eq!(last.arcs, 2, "{last:?}");
    assert!((last.radial_mm - 7.0).abs() < 0.3, "{last:?}");
    assert!((last.ae_mm - 8.0).abs() < 0.3, "{last:?}");
    let peak = along_x
        .iter()
        .chain(&along_y)
        .map(|e| e.radial_mm)
        .fold(0.0, f64::max);
    assert!(peak > 5.0 * 1.0, "peak {peak}");
    // The peak is at the corner: nothing before x = 44 or after y = 20 comes near it.
    let before = x_between(&along_x, 0.0, 44.0);
    assert!(before.iter().all(|e| e.radial_mm < 0.5 * peak));
    let after: Vec<_> = along_y.iter().filter(|e| e.position_mm[1] > 20.0).collect();
    assert!(after.iter().all(|e| e.radial_mm < 0.5 * peak));
    // Along the second wall the cut settles back to 1 mm.
    for e in along_y
        .iter()
        .filter(|e| (25.0..45.0).contains(&e.position_mm[1]))
    {
        assert_eq!(e.arcs, 1);
        assert!((e.ae_mm - 1.0).abs() < 0.1, "{e:?}");
    }
}

#[test]
fn outside_corner_drops_the_engagement() {
    // A step: material only over x ≤ 40, y ≤ 10 (above z = −5).
    let mut stock = block(60.0, 60.0);
    stock.lower_rect([0.0, 10.0], [60.0, 60.0], -5.0);
    stock.lower_rect([40.0, 0.0], [60.0, 60.0], -5.0);
    let mut s = sweep(stock);
    let along_x = feed(&mut s, [5.0, 14.0, -3.0], [44.0, 14.0, -3.0]);
    let down_y = feed(&mut s, [44.0, 14.0, -3.0], [44.0, -10.0, -3.0]);
    assert!(x_between(&along_x, 10.0, 34.0)
        .iter()
        .all(|e| (e.ae_mm - 1.0).abs() < 0.1));
    // Wrapping around the edge at (40, 10) the tool loses the material ...
    let gap = along_x
        .iter()
        .chain(&down_y)
        .filter(|e| e.position_mm[0] > 40.0 && e.kind == StepKind::Air)
        .count();
    assert!(gap > 4, "{gap}");
    // ... and takes 1 mm off the face x ≤ 40 going down Y.
    for e in down_y
        .iter()
        .filter(|e| (3.5..8.0).contains(&e.position_mm[1]))
    {
        assert_eq!(e.arcs, 1);
        assert!((e.ae_mm - 1.0).abs() < 0.1, "{e:?}");
    }
}

#[test]
fn crossing_a_cut_slot_goes_full_partial_air_partial_full() {
    let mut stock = block(100.0, 40.0);
    stock.lower_rect([40.0, 0.0], [60.0, 40.0], -10.0);
    let mut s = sweep(stock);
    let steps = feed(&mut s, [10.0, 20.0, -3.0], [90.0, 20.0, -3.0]);
    let at = |lo: f64, hi: f64| x_between(&steps, lo, hi);
    assert!(at(10.0, 34.5)
        .iter()
        .all(|e| e.arcs == 1 && (e.span_rad - PI).abs() < 1e-9));
    // The front runs into the cleared band first: both sides still cut, two arcs.
    let leaving = at(35.5, 39.5);
    assert!(leaving.iter().all(|e| e.arcs == 2), "{leaving:?}");
    assert!(leaving.windows(2).all(|w| w[1].span_rad <= w[0].span_rad));
    assert!(leaving.iter().all(|e| (e.ae_mm - 10.0).abs() < 1e-9));
    assert!(at(40.5, 54.5).iter().all(|e| e.kind == StepKind::Air));
    // Re-entry: the front meets the far side, one arc around straight ahead, growing until
    // the whole leading half is past x = 60.
    let entering = at(55.5, 59.5);
    assert!(entering.iter().all(|e| e.arcs == 1 && e.span_rad < PI));
    assert!(entering.windows(2).all(|w| w[1].span_rad >= w[0].span_rad));
    assert!(at(60.25, 90.0)
        .iter()
        .all(|e| e.arcs == 1 && (e.span_rad - PI).abs() < 1e-9));
}

#[test]
fn second_pass_over_cut_material_engages_nothing() {
    let mut s = sweep(block(100.0, 40.0));
    let path = ([-10.0, 20.0, -3.0], [110.0, 20.0, -3.0]);
    let first = feed(&mut s, path.0, path.1);
    assert!(first.iter().any(|e| e.kind == StepKind::Cut));
    // Back along the same line (the reverse move), then forward again.
    for (a, b) in [(path.1, path.0), path] {
        let again = feed(&mut s, a, b);
        assert!(again.iter().all(|e| e.kind == StepKind::Air && e.arcs == 0));
        assert!(again.iter().all(|e| e.ae_mm == 0.0 && e.removed_mm3 == 0.0));
    }
}

#[test]
fn second_level_sees_only_the_new_depth() {
    for exact_moves in [0, 4] {
        let options = SweepOptions {
            exact_moves,
            ..SweepOptions::default()
        };
        let mut s =
            Sweep::new(block(100.0, 40.0), mill(), Spindle::cw(1000.0), options).expect("sweep");
        feed(&mut s, [-10.0, 20.0, -2.0], [110.0, 20.0, -2.0]);
        let level2 = feed(&mut s, [110.0, 20.0, -4.5], [-10.0, 20.0, -4.5]);
        for e in x_between(&level2, 10.0, 90.0) {
            assert!((e.ap_mm - 2.5).abs() < 1e-5, "{exact_moves}: {e:?}");
            assert!((e.ae_mm - 10.0).abs() < 1e-9);
        }
    }
}

#[test]
fn plunge_is_axial_only() {
    let mut s = sweep(block(50.0, 50.0));
    let steps = feed(&mut s, [25.0, 25.0, 5.0], [25.0, 25.0, -4.0]);
    let plunging: Vec<_> = steps
        .iter()
        .filter(|e| e.kind == StepKind::Plunge)
        .collect();
    assert_eq!(plunging.len(), 16); // 4 mm in 0.25 mm steps
    for e in &plunging {
        assert_eq!((e.arcs, e.ae_mm, e.span_rad), (0, 0.0, 0.0));
        assert!((e.ap_mm - 0.25).abs() < 1e-5);
        // π·R²·v_f within the cells' error.
        let rate = PI * 25.0 * 400.0;
        assert!((e.removal_rate_mm3_min / rate - 1.0).abs() < 0.02, "{e:?}");
    }
    assert!(steps
        .iter()
        .filter(|e| e.position_mm[2] > 0.0)
        .all(|e| e.kind == StepKind::Air));
    // Moving off sideways from the plunged hole: a slot at once.
    let out = feed(&mut s, [25.0, 25.0, -4.0], [45.0, 25.0, -4.0]);
    let e = out[4];
    assert_eq!(e.arcs, 1);
    assert!((e.span_rad - PI).abs() < 1e-9 && (e.ap_mm - 4.0).abs() < 1e-5);
}

#[test]
fn ramp_deepens_the_axial_depth() {
    let mut s = sweep(block(100.0, 40.0));
    let steps = feed(&mut s, [-10.0, 20.0, 1.0], [90.0, 20.0, -4.0]);
    // The tip is at z = 0.5 − x/20; material up to z = 0 in front.
    for e in x_between(&steps, 20.0, 85.0) {
        let tip = e.position_mm[2];
        assert_eq!(e.kind, StepKind::Cut);
        assert!((e.ap_mm + tip).abs() < 1e-5, "{e:?}");
        assert!((e.span_rad - PI).abs() < 1e-9);
    }
}

#[test]
fn rapids_in_air_are_air_and_through_material_are_collisions() {
    let mut s = sweep(block(50.0, 50.0));
    let mut out = Vec::new();
    let air = s.cut(
        &Move::rapid([-10.0, 25.0, 5.0], [60.0, 25.0, 5.0]),
        &mut out,
    );
    assert!(!air.rapid_collision && air.removed_mm3 == 0.0);
    assert!(out
        .iter()
        .all(|e| e.rapid && e.kind == StepKind::Air && e.ae_mm == 0.0));
    out.clear();
    let crash = s.cut(
        &Move::rapid([-10.0, 25.0, -1.0], [60.0, 25.0, -1.0]),
        &mut out,
    );
    assert!(crash.rapid_collision && crash.removed_mm3 > 400.0);
    assert!(out
        .iter()
        .any(|e| e.kind == StepKind::RapidCollision && e.ae_mm > 9.9));
}

#[test]
fn material_above_the_flutes_is_flagged() {
    let short = Cutter::flat(10.0, 2, 2.0).expect("cutter");
    let mut s = Sweep::new(
        block(50.0, 50.0),
        short,
        Spindle::cw(1000.0),
        SweepOptions::default(),
    )
    .expect("sweep");
    let mut out = Vec::new();
    let sum = s.cut(
        &Move::feed([-10.0, 25.0, -3.0], [60.0, 25.0, -3.0], 200.0),
        &mut out,
    );
    assert!(sum.beyond_flutes && (sum.max_ap_mm - 2.0).abs() < 1e-9);
}
