//! The cutter (flat or ball-nose end mill) and the spindle that turns it.

use crate::error::{in_range, StockError};

/// The end of the cutter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// Flat end face at the tip.
    Flat,
    /// Hemispherical end of radius R = D/2, its lowest point at the tip; cylindrical above
    /// the equator (tip + R).
    Ball,
}

/// An end mill: a cylinder of diameter D with a flat or hemispherical end, the tool tip at
/// its lowest point, with cutting edges up to the flute length above the tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cutter {
    diameter_mm: f64,
    flutes: usize,
    flute_length_mm: f64,
    shape: Shape,
}

impl Cutter {
    /// Allowed diameter, mm.
    pub const DIAMETER_RANGE_MM: (f64, f64) = (0.1, 200.0);
    /// Allowed number of flutes.
    pub const FLUTES_RANGE: (usize, usize) = (1, 32);
    /// Allowed flute length, mm.
    pub const FLUTE_LENGTH_RANGE_MM: (f64, f64) = (0.1, 500.0);

    /// A flat end mill of diameter `diameter_mm` (mm), `flutes` cutting edges and flute
    /// length `flute_length_mm` (mm); errors name the argument and its allowed range
    /// ([`Cutter::DIAMETER_RANGE_MM`], [`Cutter::FLUTES_RANGE`],
    /// [`Cutter::FLUTE_LENGTH_RANGE_MM`]).
    pub fn flat(diameter_mm: f64, flutes: usize, flute_length_mm: f64) -> Result<Self, StockError> {
        Self::new(Shape::Flat, diameter_mm, flutes, flute_length_mm)
    }

    /// A ball-nose end mill; arguments and ranges as [`Cutter::flat`].
    pub fn ball(diameter_mm: f64, flutes: usize, flute_length_mm: f64) -> Result<Self, StockError> {
        Self::new(Shape::Ball, diameter_mm, flutes, flute_length_mm)
    }

    /// An end mill of `shape`; arguments and ranges as [`Cutter::flat`].
    pub fn new(
        shape: Shape,
        diameter_mm: f64,
        flutes: usize,
        flute_length_mm: f64,
    ) -> Result<Self, StockError> {
        let (lo, hi) = Self::DIAMETER_RANGE_MM;
        in_range("cutter.diameter_mm", diameter_mm, lo, hi)?;
        let (flo, fhi) = Self::FLUTES_RANGE;
        in_range("cutter.flutes", flutes as f64, flo as f64, fhi as f64)?;
        let (llo, lhi) = Self::FLUTE_LENGTH_RANGE_MM;
        in_range("cutter.flute_length_mm", flute_length_mm, llo, lhi)?;
        Ok(Cutter {
            diameter_mm,
            flutes,
            flute_length_mm,
            shape,
        })
    }

    /// The end's shape.
    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// Height of the cutter's lowest surface above the tip at distance `r_mm` (mm) from the
    /// axis, mm: 0 for a flat end; `R − √(R² − r²)` for a ball nose (R at and beyond the
    /// equator).
    #[inline]
    pub fn surface_mm(&self, r_mm: f64) -> f64 {
        match self.shape {
            Shape::Flat => 0.0,
            Shape::Ball => {
                let r = self.radius_mm();
                r - (r * r - r_mm * r_mm).max(0.0).sqrt()
            }
        }
    }

    /// Diameter D, mm.
    pub fn diameter_mm(&self) -> f64 {
        self.diameter_mm
    }

    /// Radius R = D/2, mm.
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }

    /// Number of flutes z.
    pub fn flutes(&self) -> usize {
        self.flutes
    }

    /// Flute length above the tip, mm: the most axial depth the cutter can take.
    pub fn flute_length_mm(&self) -> f64 {
        self.flute_length_mm
    }

    /// Feed per tooth `f_z = v_f / (n · z)`, mm, at feed `feed_mm_min` (mm/min) and spindle
    /// speed `rpm` (rev/min); 0 when either is not positive.
    pub fn feed_per_tooth_mm(&self, feed_mm_min: f64, rpm: f64) -> f64 {
        if feed_mm_min > 0.0 && rpm > 0.0 {
            feed_mm_min / (rpm * self.flutes as f64)
        } else {
            0.0
        }
    }
}

/// Sense of rotation of the spindle, seen from above (from the spindle looking down −Z).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rotation {
    /// Clockwise (M3, right-hand cutter): material on the left of the feed direction is
    /// up milling, on the right down milling.
    #[default]
    Clockwise,
    /// Counter-clockwise (M4): mirrored.
    CounterClockwise,
}

/// The spindle: speed and sense of rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spindle {
    /// Speed, rev/min (used for the feed per tooth; 0 = stopped, then `f_z` = 0).
    pub rpm: f64,
    /// Sense of rotation (default clockwise, M3).
    pub rotation: Rotation,
}

impl Spindle {
    /// Clockwise (M3) at `rpm` rev/min.
    pub fn cw(rpm: f64) -> Self {
        Spindle {
            rpm,
            rotation: Rotation::Clockwise,
        }
    }
}
