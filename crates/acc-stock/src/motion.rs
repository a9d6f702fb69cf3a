//! The tool path as this crate takes it: straight moves of the tool tip (arcs already
//! linearised), the equivalent of the NC interpreter's `PathSegment` without its line and
//! block numbers.

use crate::cutter::{Cutter, Shape};

/// One straight move of the tool tip (centre of the flat end face), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Start point `[x, y, z]`, mm.
    pub from: [f64; 3],
    /// End point `[x, y, z]`, mm.
    pub to: [f64; 3],
    /// Feed along the move, mm/min (for a rapid: the rapid rate if known, else 0; used for
    /// the feed per tooth and the removal rate only).
    pub feed_mm_min: f64,
    /// A rapid (G0) move: engagement on it is reported as a collision.
    pub rapid: bool,
}

impl Move {
    /// A feed move (G1) from `from` to `to` (mm) at `feed_mm_min` (mm/min).
    pub fn feed(from: [f64; 3], to: [f64; 3], feed_mm_min: f64) -> Self {
        Move {
            from,
            to,
            feed_mm_min,
            rapid: false,
        }
    }

    /// A rapid move (G0) from `from` to `to` (mm), rate unknown.
    pub fn rapid(from: [f64; 3], to: [f64; 3]) -> Self {
        Move {
            from,
            to,
            feed_mm_min: 0.0,
            rapid: true,
        }
    }

    /// Length of the move, mm.
    pub fn length_mm(&self) -> f64 {
        let d = self.delta();
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    }

    /// `to − from`, mm.
    pub fn delta(&self) -> [f64; 3] {
        [
            self.to[0] - self.from[0],
            self.to[1] - self.from[1],
            self.to[2] - self.from[2],
        ]
    }

    /// The point at fraction `t` (0 = from, 1 = to) of the move, mm.
    pub fn at(&self, t: f64) -> [f64; 3] {
        let d = self.delta();
        [
            self.from[0] + t * d[0],
            self.from[1] + t * d[1],
            self.from[2] + t * d[2],
        ]
    }

    /// The lowest height (mm) the cutter's end reaches at the point `(x, y)` (mm) over the
    /// part `t ∈ [0, t_max]` of the move (t = 0 at `from`, 1 at `to`) during which the point
    /// lies strictly inside the cutter's circle, or `None` when it never does. The material
    /// column at `(x, y)` is cut down to it.
    ///
    /// Flat end: the lowest tip height over that part. Ball nose: the minimum over t of
    /// `z(t) + R − √(R² − d(t)²)` (d the distance from the axis), a convex function of t,
    /// taken at the ends of the part and where its derivative vanishes (closed form).
    pub(crate) fn swept_min_surface(
        &self,
        x_mm: f64,
        y_mm: f64,
        cutter: &Cutter,
        t_max: f64,
    ) -> Option<f64> {
        let radius_mm = cutter.radius_mm();
        let d = self.delta();
        let (wx, wy) = (self.from[0] - x_mm, self.from[1] - y_mm);
        let a = d[0] * d[0] + d[1] * d[1];
        let w2 = wx * wx + wy * wy;
        let r2 = radius_mm * radius_mm;
        // Strictly inside: a point on the circle itself keeps its material.
        let tol = 1e-9 * r2;
        let b = 2.0 * (wx * d[0] + wy * d[1]);
        let (t0, t1) = if a <= 1e-18 {
            if w2 - r2 < -tol {
                (0.0, t_max)
            } else {
                return None;
            }
        } else {
            let disc = b * b - 4.0 * a * (w2 - r2 + tol);
            if disc <= 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let (r0, r1) = ((-b - s) / (2.0 * a), (-b + s) / (2.0 * a));
            let (t0, t1) = (r0.max(0.0), r1.min(t_max));
            if t0 > t1 {
                return None;
            }
            (t0, t1)
        };
        let z = |t: f64| self.from[2] + t * d[2];
        match cutter.shape() {
            Shape::Flat => Some(z(t0).min(z(t1))),
            Shape::Ball => {
                let f = |t: f64| {
                    let dist2 = (a * t * t + b * t + w2).max(0.0);
                    z(t) + radius_mm - (r2 - dist2).max(0.0).sqrt()
                };
                if d[2] == 0.0 {
                    // Level move: the lowest surface is at the closest approach.
                    let closest = if a > 1e-18 { -b / (2.0 * a) } else { t0 };
                    return Some(f(closest.clamp(t0, t1)));
                }
                let mut best = f(t0).min(f(t1));
                // f'(t) = dz + (2at + b)/(2√(R² − d²)) = 0, squared:
                // a(a + dz²)t² + b(a + dz²)t + b²/4 − dz²(R² − w²) = 0.
                // Without a slope its root is double (closest approach, −b/2a) and rounding
                // may push the discriminant below 0: clamp it, and try −b/2a as well. Any
                // t in the part is a fair candidate (f is attained there), so extra ones
                // cannot make the minimum wrong.
                let dz2 = d[2] * d[2];
                let (qa, qb, qc) = (a * (a + dz2), b * (a + dz2), 0.25 * b * b - dz2 * (r2 - w2));
                if qa > 1e-18 {
                    let s = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
                    let closest = -b / (2.0 * a);
                    for t in [(-qb - s) / (2.0 * qa), (-qb + s) / (2.0 * qa), closest] {
                        if t > t0 && t < t1 {
                            best = best.min(f(t));
                        }
                    }
                }
                Some(best)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swept_min_z_of_a_ramp() {
        // A ramp from z 0 down to −10 over x 0..10, radius 1.
        let m = Move::feed([0.0, 0.0, 0.0], [10.0, 0.0, -10.0], 100.0);
        // (5, 0.5) is covered for x in about 4.13..5.87: lowest tip about −5.87.
        let flat = Cutter::flat(2.0, 2, 5.0).expect("cutter");
        let z = m.swept_min_surface(5.0, 0.5, &flat, 1.0).expect("covered");
        assert!((z + 5.0 + 0.75f64.sqrt()).abs() < 1e-9, "{z}");
        assert_eq!(m.swept_min_surface(5.0, 1.5, &flat, 1.0), None);
        assert_eq!(m.swept_min_surface(12.0, 0.0, &flat, 1.0), None);
        // Only the first half of the move: the tip got down to −5 at x = 5.
        let z = m.swept_min_surface(5.0, 0.5, &flat, 0.5).expect("covered");
        assert!((z + 5.0).abs() < 1e-9, "{z}");
        // A plunge covers its whole circle for its whole length.
        let p = Move::feed([0.0, 0.0, 5.0], [0.0, 0.0, -3.0], 100.0);
        assert_eq!(p.swept_min_surface(0.5, 0.0, &flat, 1.0), Some(-3.0));
        assert_eq!(p.swept_min_surface(1.0, 0.0, &flat, 1.0), None);
    }

    #[test]
    fn ball_surface_minimum_matches_a_fine_search() {
        let ball = Cutter::ball(10.0, 2, 20.0).expect("cutter");
        let moves = [
            Move::feed([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], 100.0),
            Move::feed([0.0, 0.0, 0.0], [20.0, 3.0, -4.0], 100.0),
            Move::feed([0.0, 0.0, -6.0], [20.0, -2.0, 1.0], 100.0),
            Move::feed([3.0, 1.0, 2.0], [3.0, 1.0, -2.0], 100.0),
        ];
        for m in &moves {
            for (x, y) in [
                (10.0, 2.0),
                (4.0, -3.0),
                (19.0, 4.5),
                (3.0, 1.0),
                (0.5, 0.0),
            ] {
                let got = m.swept_min_surface(x, y, &ball, 1.0);
                let mut best: Option<f64> = None;
                for k in 0..=200_000 {
                    let p = m.at(k as f64 / 200_000.0);
                    let r = (p[0] - x).hypot(p[1] - y);
                    if r < 5.0 {
                        let s = p[2] + ball.surface_mm(r);
                        best = Some(best.map_or(s, |b: f64| b.min(s)));
                    }
                }
                match (got, best) {
                    (Some(g), Some(b)) => {
                        assert!((g - b).abs() < 1e-3, "{m:?} ({x},{y}): {g} vs {b}")
                    }
                    (g, b) => assert_eq!(g.is_some(), b.is_some(), "{m:?} ({x},{y})"),
                }
            }
        }
    }
}
