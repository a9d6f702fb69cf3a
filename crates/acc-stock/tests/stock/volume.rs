//! Removed volume against the analytic volume, and conservation (what the steps report is
//! what the stock lost).

use std::f64::consts::PI;

use crate::common::*;
use acc_stock::{zigzag_pocket, Move, ZigZag};

#[test]
fn zigzag_pocket_removes_the_analytic_volume() {
    let stock = block(100.0, 100.0);
    let before = stock.volume_mm3();
    let mut s = sweep(stock);
    let program = zigzag_pocket(&ZigZag {
        min_mm: [5.0, 5.0],
        max_mm: [95.0, 95.0],
        levels_mm: vec![-1.5, -3.0],
        stepover_mm: 4.0,
        block_mm: 7.0,
        feed_mm_min: 600.0,
        plunge_mm_min: 100.0,
        clearance_mm: 5.0,
    });
    let steps = s.run(&program);
    let removed: f64 = steps.iter().map(|e| e.removed_mm3).sum();
    // 100 × 100 × 3 mm less the four corners the Ø10 tool cannot reach: R² − πR²/4 each.
    let analytic = (100.0 * 100.0 - 4.0 * (25.0 - PI * 25.0 / 4.0)) * 3.0;
    assert!(
        (removed / analytic - 1.0).abs() < 1e-3,
        "{removed} vs {analytic}"
    );
    // Conservation: the steps' volumes are exactly what the stock lost.
    let lost = before - s.stock().volume_mm3();
    assert!(
        (removed - lost).abs() < 1e-6 * before,
        "{removed} vs {lost}"
    );
    // No rapid touched the stock; the first row of each level is a full slot.
    assert!(steps.iter().all(|e| !e.rapid || !e.engaged()));
    assert!(steps.iter().any(|e| (e.ae_mm - 10.0).abs() < 1e-9));
    // Mid-row on the later rows of the first level the previous row is long out of the exact
    // window: its wall comes from the cells, so a_e = stepover within about a cell.
    let rows: Vec<_> = steps
        .iter()
        .filter(|e| {
            let [x, y, z] = e.position_mm;
            z == -1.5 && y > 10.0 && y < 90.0 && x > 20.0 && x < 80.0 && (y - 5.0) % 4.0 == 0.0
        })
        .collect();
    assert!(rows.len() > 4000, "{}", rows.len());
    let worst = rows
        .iter()
        .map(|e| (e.ae_mm - 4.0).abs())
        .fold(0.0, f64::max);
    eprintln!("zig-zag rows: worst |a_e − stepover| = {worst:.3} mm");
    assert!(worst <= 0.25, "{worst}");
}

#[test]
fn oblique_slot_removes_its_analytic_volume() {
    // Plunge at A, slot 60 mm at 30° to X, 2 mm deep: D·L·a_p + πR²·a_p.
    let mut s = sweep(block(100.0, 100.0));
    let (a, len, ang) = ([20.0, 20.0], 60.0, 30f64.to_radians());
    let b = [a[0] + len * ang.cos(), a[1] + len * ang.sin()];
    let mut out = Vec::new();
    s.cut(
        &Move::feed([a[0], a[1], 3.0], [a[0], a[1], -2.0], 100.0),
        &mut out,
    );
    s.cut(
        &Move::feed([a[0], a[1], -2.0], [b[0], b[1], -2.0], 400.0),
        &mut out,
    );
    let removed: f64 = out.iter().map(|e| e.removed_mm3).sum();
    let analytic = (10.0 * len + PI * 25.0) * 2.0;
    assert!(
        (removed / analytic - 1.0).abs() < 5e-3,
        "{removed} vs {analytic}"
    );
    // Every step of the slot proper sees a_e = D over 180°.
    let n = out.len();
    for e in &out[n - 200..] {
        assert!((e.ae_mm - 10.0).abs() < 1e-9 && (e.span_rad - PI).abs() < 1e-9);
    }
}
