//! A generated zig-zag pocketing program (for the benchmark, the docs and tests).

use crate::motion::Move;

/// A rectangular pocket cleared level by level in zig-zag rows along X.
#[derive(Debug, Clone, PartialEq)]
pub struct ZigZag {
    /// Tool-centre rectangle: lowest corner `[x, y]`, mm.
    pub min_mm: [f64; 2],
    /// Tool-centre rectangle: highest corner `[x, y]`, mm.
    pub max_mm: [f64; 2],
    /// Tip height of each level, in order, mm.
    pub levels_mm: Vec<f64>,
    /// Distance between rows (the radial width of every row after the first), mm.
    pub stepover_mm: f64,
    /// Longest block: rows are split into equal blocks no longer than this, mm.
    pub block_mm: f64,
    /// Feed of the rows, mm/min.
    pub feed_mm_min: f64,
    /// Feed of the plunge at the start of each level, mm/min.
    pub plunge_mm_min: f64,
    /// Height of the rapids between levels, mm.
    pub clearance_mm: f64,
}

/// The moves of the pocket: per level a rapid over the start corner, a plunge, the rows
/// (first along +X, then alternating) joined by step-overs along +Y, one contour around the
/// rectangle (it takes off the cusps the row ends leave along the X ends) and a rapid
/// retract. The first row of each level is a full slot; the others cut `stepover_mm` wide.
pub fn zigzag_pocket(z: &ZigZag) -> Vec<Move> {
    let mut out = Vec::new();
    let [x0, y0] = z.min_mm;
    let [x1, y1] = z.max_mm;
    let rows = ((y1 - y0) / z.stepover_mm).ceil().max(0.0) as usize + 1;
    let pieces = ((x1 - x0) / z.block_mm).ceil().max(1.0) as usize;
    let mut at = [x0, y0, z.clearance_mm];
    let mut go = |to: [f64; 3], feed: f64, rapid: bool, at: &mut [f64; 3]| {
        if to == *at {
            return;
        }
        out.push(Move {
            from: *at,
            to,
            feed_mm_min: feed,
            rapid,
        });
        *at = to;
    };
    for &level in &z.levels_mm {
        go([x0, y0, z.clearance_mm], 0.0, true, &mut at);
        go([x0, y0, level], z.plunge_mm_min, false, &mut at);
        for r in 0..rows {
            let y = (y0 + r as f64 * z.stepover_mm).min(y1);
            if r > 0 {
                go([at[0], y, level], z.feed_mm_min, false, &mut at);
            }
            let (from_x, to_x) = if r % 2 == 0 { (x0, x1) } else { (x1, x0) };
            for k in 1..=pieces {
                let x = from_x + (to_x - from_x) * k as f64 / pieces as f64;
                go([x, y, level], z.feed_mm_min, false, &mut at);
            }
        }
        // The contour, from the last row's end: to its Y end, then around.
        let corners = [[x0, y1], [x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        let first = if (at[0] - x0).abs() < (at[0] - x1).abs() {
            0
        } else {
            3
        };
        for c in &corners[first..] {
            go([c[0], c[1], level], z.feed_mm_min, false, &mut at);
        }
        if first == 3 {
            for c in &corners[1..4] {
                go([c[0], c[1], level], z.feed_mm_min, false, &mut at);
            }
        }
        go([at[0], at[1], z.clearance_mm], 0.0, true, &mut at);
    }
    out
}
