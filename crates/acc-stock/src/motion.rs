//! The tool path as this crate takes it: straight moves of the tool tip (arcs already
//! linearised), the equivalent of the NC interpreter's `PathSegment` without its line and
//! block numbers.

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

    /// The lowest tip height (mm) over the part of the move during which a tool of radius
    /// `radius_mm` (mm) covers the point `(x, y)` (mm) strictly inside its circle, or `None`
    /// when it never does. The material column at `(x, y)` is cut down to it (flat end).
    pub(crate) fn swept_min_z(&self, x_mm: f64, y_mm: f64, radius_mm: f64) -> Option<f64> {
        let d = self.delta();
        let (wx, wy) = (self.from[0] - x_mm, self.from[1] - y_mm);
        let a = d[0] * d[0] + d[1] * d[1];
        let c = wx * wx + wy * wy - radius_mm * radius_mm;
        // Strictly inside: a point on the circle itself keeps its material.
        let tol = 1e-9 * radius_mm * radius_mm;
        let (t0, t1) = if a <= 1e-18 {
            if c < -tol {
                (0.0, 1.0)
            } else {
                return None;
            }
        } else {
            let b = 2.0 * (wx * d[0] + wy * d[1]);
            let disc = b * b - 4.0 * a * (c + tol);
            if disc <= 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let (r0, r1) = ((-b - s) / (2.0 * a), (-b + s) / (2.0 * a));
            let (t0, t1) = (r0.max(0.0), r1.min(1.0));
            if t0 > t1 {
                return None;
            }
            (t0, t1)
        };
        let z = |t: f64| self.from[2] + t * d[2];
        Some(z(t0).min(z(t1)))
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
        let z = m.swept_min_z(5.0, 0.5, 1.0).expect("covered");
        assert!((z + 5.0 + 0.75f64.sqrt()).abs() < 1e-9, "{z}");
        assert_eq!(m.swept_min_z(5.0, 1.5, 1.0), None);
        assert_eq!(m.swept_min_z(12.0, 0.0, 1.0), None);
        // A plunge covers its whole circle for its whole length.
        let p = Move::feed([0.0, 0.0, 5.0], [0.0, 0.0, -3.0], 100.0);
        assert_eq!(p.swept_min_z(0.5, 0.0, 1.0), Some(-3.0));
        assert_eq!(p.swept_min_z(1.0, 0.0, 1.0), None);
    }
}
