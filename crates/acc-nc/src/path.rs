//! The path as straight pieces (what a stock model consumes) and the program's summary.
//!
//! Both read only the canonical stream ([`Program::calls`]), never the text.

use std::f64::consts::TAU;

use crate::canon::{Canon, Plane};
use crate::Program;

/// One straight piece of the tool path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSegment {
    /// Start of the tool tip, mm, in the machine frame without the tool length (work
    /// coordinates + the active work offset; equal to work coordinates with zero offsets).
    pub from: [f64; 3],
    /// End of the tool tip, mm, same frame as `from`.
    pub to: [f64; 3],
    /// Programmed feed, mm/min (0 for rapids).
    pub feed_mm_min: f64,
    /// A rapid (G0): not overridden, not cutting by intent.
    pub rapid: bool,
    /// Source line, 1-based.
    pub line: u32,
    /// The block's N number, if any.
    pub block: Option<u32>,
    /// The tool in the spindle (0 = none).
    pub tool: u32,
}

impl PathSegment {
    /// Length of the piece, mm.
    pub fn length_mm(&self) -> f64 {
        dist(self.from, self.to)
    }
}

/// Totals of a program.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    /// Program lines that made at least one motion.
    pub motion_blocks: usize,
    /// Motions (traverses, feeds, arcs).
    pub motions: usize,
    /// Path length at feed (G1, G2, G3), mm.
    pub feed_length_mm: f64,
    /// Path length of rapids (G0), mm.
    pub rapid_length_mm: f64,
    /// Time of the feed moves at the programmed feed (100 % override), s. Rapids and
    /// acceleration are not included.
    pub feed_time_s: f64,
    /// Total dwell (G4), s.
    pub dwell_s: f64,
    /// Tool changes (M6).
    pub tool_changes: usize,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

/// Angles of an arc in `plane` (`center` on the plane's first and second axis,
/// [`Plane::axes`]): start angle (rad, from the plane's first axis about the centre) and
/// signed sweep (rad, negative clockwise), and the radii at start and end (mm).
pub fn arc_angles(
    plane: Plane,
    from: [f64; 3],
    to: [f64; 3],
    center: [f64; 2],
    clockwise: bool,
    turns: u32,
) -> (f64, f64, f64, f64) {
    let (from, to) = (plane.project(from), plane.project(to));
    let a0 = (from[1] - center[1]).atan2(from[0] - center[0]);
    let a1 = (to[1] - center[1]).atan2(to[0] - center[0]);
    let mut d = if clockwise { a0 - a1 } else { a1 - a0 }.rem_euclid(TAU);
    if d < 1e-9 {
        d = TAU;
    }
    d += TAU * f64::from(turns.max(1) - 1);
    let r0 = (from[0] - center[0]).hypot(from[1] - center[1]);
    let r1 = (to[0] - center[0]).hypot(to[1] - center[1]);
    (a0, if clockwise { -d } else { d }, r0, r1)
}

impl Canon {
    /// The point of a motion at fraction `t` (0 ..= 1) of it, work coordinates, mm: along
    /// the line, or along the arc at the angle `t` of its sweep (radius and the coordinate
    /// along the plane's normal linear in `t`); exactly the end at `t = 1`. `None` for other
    /// calls.
    pub fn point_at(&self, t: f64) -> Option<[f64; 3]> {
        match self {
            Canon::Traverse { from, to } | Canon::Feed { from, to, .. } => {
                Some([0, 1, 2].map(|k| from[k] + (to[k] - from[k]) * t))
            }
            Canon::Arc {
                from,
                to,
                center,
                plane,
                clockwise,
                turns,
                ..
            } => {
                if t >= 1.0 {
                    return Some(*to);
                }
                let (a0, sweep, r0, r1) =
                    arc_angles(*plane, *from, *to, *center, *clockwise, *turns);
                let a = a0 + sweep * t;
                let r = r0 + (r1 - r0) * t;
                let n = plane.axes()[2];
                Some(plane.point(
                    [center[0] + r * a.cos(), center[1] + r * a.sin()],
                    from[n] + (to[n] - from[n]) * t,
                ))
            }
            _ => None,
        }
    }

    /// Path length of a motion, mm (helical length for arcs); 0 for other calls.
    pub fn length_mm(&self) -> f64 {
        match self {
            Canon::Traverse { from, to } | Canon::Feed { from, to, .. } => dist(*from, *to),
            Canon::Arc {
                from,
                to,
                center,
                plane,
                clockwise,
                turns,
                ..
            } => {
                let (_, sweep, r0, r1) =
                    arc_angles(*plane, *from, *to, *center, *clockwise, *turns);
                let planar = 0.5 * (r0 + r1) * sweep.abs();
                let n = plane.axes()[2];
                planar.hypot(to[n] - from[n])
            }
            _ => 0.0,
        }
    }
}

/// Most chords per arc (a guard against a tiny tolerance on a huge arc).
const MAX_CHORDS: f64 = 100_000.0;

impl Program {
    /// The path as straight pieces: lines as they are, arcs as chords that stay within
    /// `chord_tol_mm` (mm, at least 1e-6) of the arc. Tool tip in the machine frame
    /// without the tool length (see [`PathSegment::from`]).
    ///
    /// ```
    /// use acc_nc::{interpret, Setup};
    /// let p = interpret("c.ngc", "G21 G0 X10\nG2 I-10 F500\nM2\n", &Setup::default()).expect("ok");
    /// let path = p.path(0.01);
    /// let arc_len: f64 = path.iter().filter(|s| !s.rapid).map(|s| s.length_mm()).sum();
    /// assert!((arc_len - 2.0 * std::f64::consts::PI * 10.0).abs() < 0.05);
    /// ```
    pub fn path(&self, chord_tol_mm: f64) -> Vec<PathSegment> {
        let tol = chord_tol_mm.max(1e-6);
        let mut out = Vec::new();
        let mut offset = [0.0; 3];
        let mut tool = 0;
        let shift = |p: [f64; 3], o: [f64; 3]| [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
        for c in &self.calls {
            let seg = |from, to, feed_mm_min, rapid| PathSegment {
                from: shift(from, offset),
                to: shift(to, offset),
                feed_mm_min,
                rapid,
                line: c.line,
                block: c.block,
                tool,
            };
            match &c.call {
                Canon::WorkOffset { offset_mm, .. } => offset = *offset_mm,
                Canon::ToolChange { tool: t } => tool = *t,
                Canon::Traverse { from, to } => out.push(seg(*from, *to, 0.0, true)),
                Canon::Feed {
                    from,
                    to,
                    feed_mm_min,
                } => out.push(seg(*from, *to, *feed_mm_min, false)),
                Canon::Arc {
                    from,
                    to,
                    center,
                    plane,
                    clockwise,
                    turns,
                    feed_mm_min,
                } => {
                    let (_, sweep, r0, r1) =
                        arc_angles(*plane, *from, *to, *center, *clockwise, *turns);
                    let r = r0.max(r1).max(1e-9);
                    let step = (2.0 * (1.0 - (tol / r).min(1.0)).acos()).clamp(1e-9, TAU / 4.0);
                    let n = (sweep.abs() / step).ceil().clamp(1.0, MAX_CHORDS) as usize;
                    let mut prev = *from;
                    for k in 1..=n {
                        let p = c.call.point_at(k as f64 / n as f64).unwrap_or(*to);
                        out.push(seg(prev, p, *feed_mm_min, false));
                        prev = p;
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// Totals: motions, feed and rapid length, time at programmed feed, dwell, tool changes.
    pub fn summary(&self) -> Summary {
        let mut s = Summary::default();
        let mut last_line = None;
        for c in &self.calls {
            let len = c.call.length_mm();
            match &c.call {
                Canon::Traverse { .. } => s.rapid_length_mm += len,
                Canon::Feed { feed_mm_min, .. } | Canon::Arc { feed_mm_min, .. } => {
                    s.feed_length_mm += len;
                    if *feed_mm_min > 0.0 {
                        s.feed_time_s += len / feed_mm_min * 60.0;
                    }
                }
                Canon::Dwell { seconds } => s.dwell_s += seconds,
                Canon::ToolChange { .. } => s.tool_changes += 1,
                _ => {}
            }
            if c.call.end().is_some() {
                s.motions += 1;
                if last_line != Some(c.line) {
                    s.motion_blocks += 1;
                    last_line = Some(c.line);
                }
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_angles_cover_quarter_full_and_turns() {
        let xy = Plane::Xy;
        let (_, s, _, _) = arc_angles(xy, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0], false, 1);
        assert!((s - TAU / 4.0).abs() < 1e-12);
        let (_, s, _, _) = arc_angles(xy, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0], true, 1);
        assert!((s + 3.0 * TAU / 4.0).abs() < 1e-12);
        let (_, s, _, _) = arc_angles(xy, [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0], true, 2);
        assert!((s + 2.0 * TAU).abs() < 1e-12);
    }

    #[test]
    fn arcs_in_xz_and_yz_turn_about_their_normal() {
        // G18 G3 from X10 to Z10 about the origin: (z, x) from (0, 10) to (10, 0) is a
        // clockwise quarter in the plane's axes, so counter-clockwise it is three quarters.
        let arc = |plane, from, to, center, clockwise| Canon::Arc {
            from,
            to,
            center,
            plane,
            clockwise,
            turns: 1,
            feed_mm_min: 100.0,
        };
        let a = arc(
            Plane::Xz,
            [10.0, 5.0, 0.0],
            [0.0, 7.0, 10.0],
            [0.0, 0.0],
            true,
        );
        let quarter = TAU / 4.0 * 10.0;
        assert!((a.length_mm() - quarter.hypot(2.0)).abs() < 1e-9);
        let mid = a.point_at(0.5).expect("a motion");
        let h = 10.0 * std::f64::consts::FRAC_1_SQRT_2;
        assert!((mid[0] - h).abs() < 1e-9 && (mid[2] - h).abs() < 1e-9);
        assert!((mid[1] - 6.0).abs() < 1e-9);
        // G19 G3 from Y10 to Z10: (y, z) from (10, 0) to (0, 10), a counter-clockwise quarter
        // with the helix along X.
        let a = arc(
            Plane::Yz,
            [3.0, 10.0, 0.0],
            [1.0, 0.0, 10.0],
            [0.0, 0.0],
            false,
        );
        let mid = a.point_at(0.5).expect("a motion");
        assert!((mid[1] - h).abs() < 1e-9 && (mid[2] - h).abs() < 1e-9);
        assert!((mid[0] - 2.0).abs() < 1e-9);
        assert!((a.length_mm() - quarter.hypot(2.0)).abs() < 1e-9);
    }
}
