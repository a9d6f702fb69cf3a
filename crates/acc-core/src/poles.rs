//! Pole assignment (seed 002, eq. 14).
//!
//! With the plant `Fc/U ≈ Km·Kc·z⁻¹` (eq. 6) and the PI law of eq. 4 the closed loop has the
//! characteristic polynomial `z² + (Km·Kc·(Kp + Ki·T) − 1)·z − Km·Kc·Kp` (physics.md §1).
//! Matching it to `(z − z1)(z − z2)` gives eq. 14:
//!
//! ```text
//! Kp = −z1·z2 / (Km·Kc_hat)
//! Ki = (1 − (z1 + z2) + z1·z2) / (T·Km·Kc_hat)
//! ```
//!
//! The integral-only law `U(i) = U(i−1) + Ki·T·E(i)` has the single pole
//! `p = 1 − Km·Kc·Ki·T` (paper conclusion 5), hence `Ki = (1 − p) / (T·Km·Kc_hat)`.
//!
//! ```
//! use acc_core::poles::{assign, DesiredPoles};
//! // Case I of the paper at Kc_hat = 4 N/(mm/min), Km = 1, T = 0.1 s.
//! let g = assign(DesiredPoles::Real(0.2, -0.05), 1.0, 4.0, 0.1).unwrap();
//! assert!((g.kp - 0.0025).abs() < 1e-15);
//! assert!((g.ki - 2.1).abs() < 1e-12);
//! ```

use std::fmt;

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

impl DesiredPoles {
    /// Paper case I: z1 = 0.2, z2 = −0.05.
    pub const PAPER_CASE_I: DesiredPoles = DesiredPoles::Real(0.2, -0.05);
    /// Paper case II: z1 = 0.1, z2 = −0.6.
    pub const PAPER_CASE_II: DesiredPoles = DesiredPoles::Real(0.1, -0.6);
    /// Paper cases III and IV: z1 = 0.001, z2 = −0.001 (practically integral control).
    pub const PAPER_CASE_III: DesiredPoles = DesiredPoles::Real(0.001, -0.001);

    /// Sum z1 + z2 (real for both real and conjugate pairs).
    pub fn sum(&self) -> f64 {
        match *self {
            DesiredPoles::Real(a, b) => a + b,
            DesiredPoles::Complex { re, .. } => 2.0 * re,
        }
    }

    /// Product z1·z2 (real for both real and conjugate pairs).
    pub fn product(&self) -> f64 {
        match *self {
            DesiredPoles::Real(a, b) => a * b,
            DesiredPoles::Complex { re, im } => re * re + im * im,
        }
    }

    /// The two poles as (re, im) pairs; the second of a complex pair is re − j·im.
    pub fn as_pairs(&self) -> [(f64, f64); 2] {
        match *self {
            DesiredPoles::Real(a, b) => [(a, 0.0), (b, 0.0)],
            DesiredPoles::Complex { re, im } => [(re, im), (re, -im)],
        }
    }

    /// Largest pole magnitude.
    pub fn max_magnitude(&self) -> f64 {
        let [p, q] = self.as_pairs();
        p.0.hypot(p.1).max(q.0.hypot(q.1))
    }

    /// Refuse poles that are not finite or not strictly inside the unit circle.
    ///
    /// ```
    /// use acc_core::poles::{DesiredPoles, PoleError};
    /// assert!(DesiredPoles::Real(0.2, -0.05).validate().is_ok());
    /// assert_eq!(
    ///     DesiredPoles::Real(0.2, -1.0).validate(),
    ///     Err(PoleError::NotInsideUnitCircle { magnitude: 1.0 })
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), PoleError> {
        let [p, q] = self.as_pairs();
        if ![p.0, p.1, q.0, q.1].iter().all(|v| v.is_finite()) {
            return Err(PoleError::NotFinite);
        }
        let m = self.max_magnitude();
        if m >= 1.0 {
            return Err(PoleError::NotInsideUnitCircle { magnitude: m });
        }
        Ok(())
    }

    /// The gain-free numerators of eq. 14: `(−z1·z2, 1 − (z1 + z2) + z1·z2)`, so that
    /// `Kp = a / (Km·Kc_hat)` and `Ki = b / (T·Km·Kc_hat)`.
    pub fn numerators(&self) -> (f64, f64) {
        let s = self.sum();
        let p = self.product();
        (-p, 1.0 - s + p)
    }
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
    /// A plant or timing parameter of the assignment is not strictly positive and finite
    /// (`Km·Kc_hat` or `T`).
    NonPositive {
        /// Parameter name: `"km_kc_hat"` or `"period_s"`.
        name: &'static str,
        /// Offending value.
        value: f64,
    },
}

impl fmt::Display for PoleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PoleError::NotInsideUnitCircle { magnitude } => write!(
                f,
                "desired pole has magnitude {magnitude}, on or outside the unit circle: \
                 poles must satisfy |z| < 1"
            ),
            PoleError::NotFinite => write!(f, "desired pole is not finite"),
            PoleError::NonPositive { name, value } => {
                write!(f, "{name} = {value} must be finite and > 0")
            }
        }
    }
}

impl std::error::Error for PoleError {}

/// PI gains from pole assignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiGains {
    /// Kp, (mm/min)/N.
    pub kp: f64,
    /// Ki, (mm/min)/(N·s).
    pub ki: f64,
}

fn check_positive(name: &'static str, value: f64) -> Result<f64, PoleError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(PoleError::NonPositive { name, value })
    }
}

/// PI gains that place the closed-loop poles at `poles` for the plant gain
/// `km·kc_hat` (seed 002, eq. 14).
///
/// Errors: a pole on or outside the unit circle, non-finite poles, `km·kc_hat <= 0` or
/// `period_s <= 0`.
pub fn assign(
    poles: DesiredPoles,
    km: f64,
    kc_hat: f64,
    period_s: f64,
) -> Result<PiGains, PoleError> {
    poles.validate()?;
    let g = check_positive("km_kc_hat", km * kc_hat)?;
    let t = check_positive("period_s", period_s)?;
    let (a, b) = poles.numerators();
    Ok(PiGains {
        kp: a / g,
        ki: b / (t * g),
    })
}

/// Integral gain that places the single closed-loop pole of the integral-only law at
/// `pole`: `Ki = (1 − p) / (T·Km·Kc_hat)` (seed 002, conclusion 5; from `p = 1 − Km·Kc·Ki·T`).
///
/// ```
/// let ki = acc_core::poles::assign_integral(0.5, 1.0, 4.0, 0.1).unwrap();
/// assert!((ki - 1.25).abs() < 1e-12);
/// ```
pub fn assign_integral(pole: f64, km: f64, kc_hat: f64, period_s: f64) -> Result<f64, PoleError> {
    validate_single(pole)?;
    let g = check_positive("km_kc_hat", km * kc_hat)?;
    let t = check_positive("period_s", period_s)?;
    Ok((1.0 - pole) / (t * g))
}

/// Refuse a single real pole that is not finite or not strictly inside the unit circle.
pub fn validate_single(pole: f64) -> Result<(), PoleError> {
    if !pole.is_finite() {
        return Err(PoleError::NotFinite);
    }
    if pole.abs() >= 1.0 {
        return Err(PoleError::NotInsideUnitCircle {
            magnitude: pole.abs(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complex_pair_sum_and_product_are_real() {
        let p = DesiredPoles::Complex { re: 0.3, im: 0.4 };
        assert!((p.sum() - 0.6).abs() < 1e-15);
        assert!((p.product() - 0.25).abs() < 1e-15);
        assert!((p.max_magnitude() - 0.5).abs() < 1e-15);
    }

    #[test]
    fn poles_on_or_outside_the_circle_are_refused() {
        for p in [
            DesiredPoles::Real(1.0, 0.0),
            DesiredPoles::Real(0.0, -1.2),
            DesiredPoles::Complex { re: 0.6, im: 0.8 },
            DesiredPoles::Complex { re: 0.9, im: 0.9 },
        ] {
            let err = assign(p, 1.0, 4.0, 0.1).unwrap_err();
            assert!(
                matches!(err, PoleError::NotInsideUnitCircle { .. }),
                "{p:?}"
            );
            assert!(err.to_string().contains("outside the unit circle"));
        }
        assert_eq!(
            assign(DesiredPoles::Real(f64::NAN, 0.0), 1.0, 4.0, 0.1),
            Err(PoleError::NotFinite)
        );
        assert!(assign_integral(1.0, 1.0, 4.0, 0.1).is_err());
        assert!(assign_integral(-1.5, 1.0, 4.0, 0.1).is_err());
    }

    #[test]
    fn non_positive_plant_gain_is_refused() {
        assert_eq!(
            assign(DesiredPoles::PAPER_CASE_I, 1.0, 0.0, 0.1),
            Err(PoleError::NonPositive {
                name: "km_kc_hat",
                value: 0.0
            })
        );
        assert!(assign(DesiredPoles::PAPER_CASE_I, 1.0, 4.0, -0.1).is_err());
    }
}
