//! Points and arcs on a plane's first and second axis (`[u, v]`, mm): the 2-D geometry
//! cutter radius compensation ([`super::comp`]) works in.

use std::f64::consts::TAU;

/// The unit vector at angle `a` (rad) from the plane's first axis.
pub(super) fn dir(a: f64) -> [f64; 2] {
    [a.cos(), a.sin()]
}

/// `p` moved by `r` along the unit vector `d`.
pub(super) fn add(p: [f64; 2], r: f64, d: [f64; 2]) -> [f64; 2] {
    [p[0] + r * d[0], p[1] + r * d[1]]
}

/// The distance of two points, mm.
pub(super) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The angle (rad, from the plane's first axis) of the direction from `from` to `to`.
pub(super) fn angle(from: [f64; 2], to: [f64; 2]) -> f64 {
    (to[1] - from[1]).atan2(to[0] - from[0])
}

/// Signed sweep (rad, positive counter-clockwise) of an arc about `c` from `a` to `b` with
/// `turn` (+n counter-clockwise, -n clockwise) turns (LinuxCNC's `find_turn`).
pub(super) fn sweep(a: [f64; 2], c: [f64; 2], turn: i64, b: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let (mut alpha, mut beta) = (angle(c, a), angle(c, b));
    let extra = (turn.unsigned_abs() - 1) as f64 * TAU;
    if turn > 0 {
        if beta <= alpha {
            beta += TAU;
        }
        beta - alpha + extra
    } else {
        if alpha <= beta {
            alpha += TAU;
        }
        beta - alpha - extra
    }
}

/// An arc's turns signed as LinuxCNC's `turn`: positive counter-clockwise (G3), negative
/// clockwise (G2).
pub(super) fn signed_turn(turns: u32, clockwise: bool) -> i64 {
    i64::from(turns) * if clockwise { -1 } else { 1 }
}
