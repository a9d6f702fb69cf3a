//! Pole assignment (seed 002, eq. 14).

/// Desired closed-loop poles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DesiredPoles {
    /// Two real poles z1, z2.
    Real(f64, f64),
    /// A complex-conjugate pair re ± j·im.
    Complex {
        /// Real part.
        re: f64,
        /// Imaginary part (the pair is re ± j·im).
        im: f64,
    },
}

/// Why a pole set was refused.
#[derive(Debug, Clone, PartialEq)]
pub enum PoleError {
    /// A pole lies on or outside the unit circle.
    NotInsideUnitCircle {
        /// Its magnitude.
        magnitude: f64,
    },
    /// Not finite.
    NotFinite,
}

/// PI gains from pole assignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiGains {
    /// Kp, (mm/min)/N.
    pub kp: f64,
    /// Ki, (mm/min)/(N·s).
    pub ki: f64,
}
