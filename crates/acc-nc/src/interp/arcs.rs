//! The centre of a G2/G3 block in the active plane (G17 / G18 / G19), from its centre words
//! (I J in XY, K I in XZ, J K in YZ; relative to the start, or absolute after G90.1) or its
//! radius R, as LinuxCNC's `arc_data_ijk` and `arc_data_r` find it. Points are on the
//! plane's first and second axis ([`Plane::axes`]), mm.

use super::{Block, State, Val};
use crate::canon::{Canon, Plane};
use crate::error::{At, ErrorKind};

/// LinuxCNC's `TINY` for the R-arc geometry.
const TINY: f64 = 1e-12;

impl State<'_> {
    /// The arc of block `b` from `from` to `to` (work coordinates, mm) in the active plane;
    /// `cw` for G2; `at` names the block's motion for errors.
    pub(super) fn arc(
        &self,
        cw: bool,
        from: [f64; 3],
        to: [f64; 3],
        b: &Block,
        at: &Val,
    ) -> Result<Canon, At> {
        let plane = self.plane;
        let (center, turns) = self.arc_centre(cw, plane.project(from), plane.project(to), b, at)?;
        Ok(Canon::Arc {
            from,
            to,
            center,
            plane,
            clockwise: cw,
            turns,
            feed_mm_min: self.feed_mm_min,
        })
    }

    /// The centre (plane coordinates, mm) and the turns (P, at least 1) of the arc of block
    /// `b` from `start` to `end` (plane coordinates, mm) in the active plane.
    pub(super) fn arc_centre(
        &self,
        cw: bool,
        start: [f64; 2],
        end: [f64; 2],
        b: &Block,
        at: &Val,
    ) -> Result<([f64; 2], u32), At> {
        let f = self.units.mm_per_unit();
        let plane = self.plane;
        let [first, second, other] = plane.centre_letters();
        if let Some(w) = b.word(other) {
            return Err(w.err(ErrorKind::Conflict {
                what: format!(
                    "{other} in an arc in {} ({} takes {first} and {second})",
                    plane_name(plane),
                    plane.code()
                ),
            }));
        }
        let bad = |w: &Val, detail: String| w.err(ErrorKind::BadArc { detail });
        let turns = match b.word('P') {
            None => 1,
            Some(p) if p.v >= 1.0 && p.v.fract() == 0.0 && p.v < 1e6 => p.v as u32,
            Some(p) => {
                return Err(p.err(ErrorKind::Range {
                    allowed: "P (turns) a whole number >= 1".into(),
                }))
            }
        };
        let (i, j) = (b.word(first), b.word(second));
        if let Some(r) = b.word('R') {
            if let Some(w) = i.or(j) {
                return Err(w.err(ErrorKind::Conflict {
                    what: format!(
                        "R and {first}/{second} in one arc: give the centre or the radius"
                    ),
                }));
            }
            let c = r_center(cw, r.v * f, start, end).map_err(|d| bad(r, d))?;
            return Ok((c, turns));
        }
        if i.is_none() && j.is_none() {
            return Err(Self::missing(
                at,
                &format!(
                    "{first} and/or {second} (centre) or R (radius) for the arc in {}",
                    plane.code()
                ),
            ));
        }
        if self.arc_absolute {
            for (v, l) in [(i, first), (j, second)] {
                if v.is_none() {
                    return Err(Self::missing(
                        i.or(j).unwrap_or(at),
                        &format!("{l} (an absolute centre after G90.1 takes both words)"),
                    ));
                }
            }
        }
        let (iv, jv) = (i.map_or(0.0, |w| w.v) * f, j.map_or(0.0, |w| w.v) * f);
        let c = if self.arc_absolute {
            [iv, jv]
        } else {
            [start[0] + iv, start[1] + jv]
        };
        let r1 = (start[0] - c[0]).hypot(start[1] - c[1]);
        let r2 = (end[0] - c[0]).hypot(end[1] - c[1]);
        let w = i.or(j).unwrap_or(at);
        if r1 < 1e-9 || r2 < 1e-9 {
            return Err(bad(
                w,
                format!("zero radius (start {r1:.4} mm, end {r2:.4} mm)"),
            ));
        }
        let tol = self.setup.arc_radius_tolerance_mm;
        if (r1 - r2).abs() > tol {
            return Err(bad(
                w,
                format!(
                    "radius to the start {r1:.4} mm and to the end {r2:.4} mm differ by \
                     {:.4} mm (allowed {tol} mm)",
                    (r1 - r2).abs()
                ),
            ));
        }
        Ok((c, turns))
    }
}

/// The plane's name in messages (`the XY plane`, ...).
pub(super) fn plane_name(plane: Plane) -> &'static str {
    match plane {
        Plane::Xy => "the XY plane",
        Plane::Xz => "the XZ plane",
        Plane::Yz => "the YZ plane",
    }
}

/// Centre of an R arc (LinuxCNC `arc_data_r`) from `from` to `to` (plane coordinates):
/// positive R takes the short way, negative R the long way; the end point must not equal
/// the start point.
fn r_center(cw: bool, radius: f64, from: [f64; 2], to: [f64; 2]) -> Result<[f64; 2], String> {
    if (to[0] - from[0]).abs() < 1e-12 && (to[1] - from[1]).abs() < 1e-12 {
        return Err(
            "an R arc needs an end point other than its start (full circles take I/J)".into(),
        );
    }
    let abs_r = radius.abs();
    let mid = [(to[0] + from[0]) / 2.0, (to[1] + from[1]) / 2.0];
    let mut half = (mid[0] - to[0]).hypot(mid[1] - to[1]);
    if abs_r == 0.0 || half / abs_r > 1.0 + TINY {
        return Err(format!(
            "radius {abs_r:.4} mm is too small to reach the end point ({:.4} mm away)",
            2.0 * half
        ));
    }
    if half / abs_r > 1.0 - TINY {
        half = abs_r;
    }
    let dir = (to[1] - from[1]).atan2(to[0] - from[0]);
    let theta = if cw == (radius > 0.0) {
        dir - std::f64::consts::FRAC_PI_2
    } else {
        dir + std::f64::consts::FRAC_PI_2
    };
    let offset = abs_r * (half / abs_r).asin().cos();
    Ok([mid[0] + offset * theta.cos(), mid[1] + offset * theta.sin()])
}
