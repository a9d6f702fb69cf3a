//! Shared set-up of the integration tests: a box stock, a Ø10 mm 4-flute end mill.

#![allow(dead_code)]

use acc_stock::{Cutter, Move, Spindle, StepEngagement, Sweep, SweepOptions, ZMap};

/// Cell size of the tests, mm.
pub const CELL: f64 = 0.25;

/// A box `[0, x1] × [0, y1] × [−20, 0]` (top at z = 0) on 0.25 mm cells.
pub fn block(x1: f64, y1: f64) -> ZMap {
    ZMap::from_box([0.0, 0.0, -20.0], [x1, y1, 0.0], CELL).expect("box")
}

/// Ø10 mm, 4 flutes, 25 mm flute length.
pub fn mill() -> Cutter {
    Cutter::flat(10.0, 4, 25.0).expect("cutter")
}

/// A sweep of `stock` with [`mill`] at 1000 rpm clockwise, default options.
pub fn sweep(stock: ZMap) -> Sweep {
    Sweep::new(stock, mill(), Spindle::cw(1000.0), SweepOptions::default()).expect("sweep")
}

/// The steps of one feed move at 400 mm/min.
pub fn feed(s: &mut Sweep, from: [f64; 3], to: [f64; 3]) -> Vec<StepEngagement> {
    let mut out = Vec::new();
    s.cut(&Move::feed(from, to, 400.0), &mut out);
    out
}

/// The steps whose tool centre x lies in `[lo, hi]`.
pub fn x_between(steps: &[StepEngagement], lo: f64, hi: f64) -> Vec<StepEngagement> {
    steps
        .iter()
        .filter(|e| e.position_mm[0] >= lo && e.position_mm[0] <= hi)
        .copied()
        .collect()
}
