//! Closed-loop stability analysis: poles, Jury test, stable Kc ranges.
//!
//! The PI law of eq. 4 on the plant of eq. 6 gives the characteristic polynomial
//! (physics.md §1)
//!
//! ```text
//! P(z) = z² + a1·z + a0,   a1 = g·(Kp + Ki·T) − 1,   a0 = −g·Kp,   g = Km·Kc
//! ```
//!
//! Its roots are computed numerically as the eigenvalues of the companion matrix
//! `[[−a1, −a0], [1, 0]]` (nalgebra's Schur decomposition). The Jury conditions for a
//! second-order polynomial are `P(1) > 0`, `P(−1) > 0`, `|a0| < 1`; for fixed gains they give
//! `0 < g < 2/(2·Kp + Ki·T)` (the paper's bound, from `P(−1) > 0`) and `g < 1/|Kp|` (from
//! `|a0| < 1`, never the binding one for the paper's gains).
//!
//! For adaptive gains computed at `Kc_hat` by eq. 14 while the true gain is
//! `Kc = r·Kc_hat`, the polynomial is `z² + (r·(1 − s) − 1)·z + r·p` with `s = z1 + z2`,
//! `p = z1·z2`; Jury gives `0 < r < min(2/(1 − s − p), 1/|p|)` (the first term only where
//! `1 − s − p > 0`): the estimator may under-estimate Kc by at most that ratio.
//!
//! ```
//! use acc_core::stability::{fixed_gain_stable_range, spectral_radius, pi_poles};
//! let r = fixed_gain_stable_range(0.05, 2.5, 0.1).unwrap();
//! assert!((r.analytic_max - 2.0 / 0.35).abs() < 1e-12);
//! assert!((r.numeric_max - r.analytic_max).abs() < 1e-9);
//! assert!(spectral_radius(&pi_poles(0.05, 2.5, 4.0, 0.1)) < 1.0);
//! assert!(spectral_radius(&pi_poles(0.05, 2.5, 6.0, 0.1)) > 1.0);
//! ```

use nalgebra::{Complex, Matrix1, Matrix2};

use crate::poles::{validate_single, DesiredPoles, PoleError};
use crate::CoreError;
use crate::RangeError;

/// A pole in the z-plane, `re + j·im`.
pub type Pole = Complex<f64>;

/// Roots of the monic polynomial `z² + a1·z + a0`: eigenvalues of its companion matrix.
pub fn quadratic_roots(a1: f64, a0: f64) -> [Pole; 2] {
    let companion = Matrix2::new(-a1, -a0, 1.0, 0.0);
    let ev = companion.complex_eigenvalues();
    [ev[0], ev[1]]
}

/// Closed-loop poles of the PI loop (eq. 4 on eq. 6) for gains `kp` ((mm/min)/N), `ki`
/// ((mm/min)/(N·s)), plant gain `km_kc` (Km·Kc, N/(mm/min)) and period `period_s` (s).
pub fn pi_poles(kp: f64, ki: f64, km_kc: f64, period_s: f64) -> [Pole; 2] {
    let (a1, a0) = pi_coefficients(kp, ki, km_kc, period_s);
    quadratic_roots(a1, a0)
}

/// Coefficients `(a1, a0)` of the characteristic polynomial `z² + a1·z + a0` of the PI loop.
pub fn pi_coefficients(kp: f64, ki: f64, km_kc: f64, period_s: f64) -> (f64, f64) {
    (km_kc * (kp + ki * period_s) - 1.0, -km_kc * kp)
}

/// The single closed-loop pole of the integral-only loop, `1 − Km·Kc·Ki·T` (paper
/// conclusion 5), computed as the eigenvalue of its 1 × 1 companion matrix.
pub fn integral_pole(ki: f64, km_kc: f64, period_s: f64) -> Pole {
    let companion = Matrix1::new(1.0 - km_kc * ki * period_s);
    companion.complex_eigenvalues()[0]
}

/// Largest pole magnitude (the loop is stable iff it is < 1).
pub fn spectral_radius(poles: &[Pole]) -> f64 {
    poles.iter().map(|z| z.norm()).fold(0.0, f64::max)
}

/// The three Jury conditions of a second-order polynomial `z² + a1·z + a0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jury {
    /// `P(1) = 1 + a1 + a0` (must be > 0).
    pub p_at_1: f64,
    /// `P(−1) = 1 − a1 + a0` (must be > 0).
    pub p_at_minus_1: f64,
    /// `|a0|` (must be < 1).
    pub abs_a0: f64,
}

impl Jury {
    /// Whether all three conditions hold (both roots strictly inside the unit circle).
    pub fn is_stable(&self) -> bool {
        self.p_at_1 > 0.0 && self.p_at_minus_1 > 0.0 && self.abs_a0 < 1.0
    }
}

/// Jury test of `z² + a1·z + a0`.
///
/// ```
/// use acc_core::stability::{jury, pi_coefficients};
/// let (a1, a0) = pi_coefficients(0.05, 2.5, 4.0, 0.1);
/// assert!(jury(a1, a0).is_stable());
/// let (a1, a0) = pi_coefficients(0.05, 2.5, 6.0, 0.1);
/// assert!(!jury(a1, a0).is_stable());
/// ```
pub fn jury(a1: f64, a0: f64) -> Jury {
    Jury {
        p_at_1: 1.0 + a1 + a0,
        p_at_minus_1: 1.0 - a1 + a0,
        abs_a0: a0.abs(),
    }
}

/// A stable interval `0 < x < max` of a loop parameter, analytic and numerically checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableRange {
    /// Upper bound from the Jury conditions.
    pub analytic_max: f64,
    /// Upper bound found by bisection on the spectral radius of the companion-matrix
    /// eigenvalues (within 1e-12 relative).
    pub numeric_max: f64,
}

/// Bisection for the first `x` in `(lo, hi)` where `radius(x)` reaches 1, assuming stable
/// at `lo` and unstable at `hi`. Stops at relative width 1e-13 (at most 200 halvings).
pub fn bisect_boundary(radius: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        if hi - lo <= 1e-13 * hi.abs().max(1e-300) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if radius(mid) < 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Find the stable interval `(0, max)` of `radius` by scanning geometrically from `start`
/// up to `limit` and bisecting the first crossing; `None` if `radius` never reaches 1.
fn numeric_upper(radius: impl Fn(f64) -> f64, start: f64, limit: f64) -> Option<f64> {
    let mut lo = start;
    if radius(lo) >= 1.0 {
        return Some(bisect_boundary(&radius, 0.0, lo));
    }
    while lo < limit {
        let hi = lo * 1.05;
        if radius(hi) >= 1.0 {
            return Some(bisect_boundary(&radius, lo, hi));
        }
        lo = hi;
    }
    None
}

fn check(name: &'static str, value: f64, ok: bool, allowed: &'static str) -> Result<(), CoreError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(CoreError::OutOfRange(RangeError::new(name, value, allowed)))
    }
}

/// The stable range of the process gain `g = Km·Kc` for a PI controller with fixed gains:
/// analytic (Jury) `min(2/(2·Kp + Ki·T), 1/|Kp|)` — the first term only where
/// `2·Kp + Ki·T > 0`, the second only where `Kp ≠ 0` — and numeric (bisection on the
/// eigenvalues). `Kp` may be negative: pole assignment gives `Kp < 0` whenever
/// `z1·z2 > 0` (e.g. a complex pair), and such gains frozen at `Kc_hat` are analysed here.
pub fn fixed_gain_stable_range(kp: f64, ki: f64, period_s: f64) -> Result<StableRange, CoreError> {
    check("kp", kp, true, "finite")?;
    check("ki", ki, ki > 0.0, "> 0")?;
    check("period_s", period_s, period_s > 0.0, "> 0")?;
    let d = 2.0 * kp + ki * period_s;
    let from_p_minus_1 = if d > 0.0 { 2.0 / d } else { f64::INFINITY };
    let from_a0 = if kp != 0.0 {
        1.0 / kp.abs()
    } else {
        f64::INFINITY
    };
    // Finite: with Kp = 0 the first term is 2/(Ki·T).
    let analytic_max = from_p_minus_1.min(from_a0);
    let radius = |g: f64| spectral_radius(&pi_poles(kp, ki, g, period_s));
    let numeric_max =
        numeric_upper(radius, analytic_max * 1e-3, analytic_max * 1e3).unwrap_or(f64::INFINITY);
    Ok(StableRange {
        analytic_max,
        numeric_max,
    })
}

/// The range of `r = Kc / Kc_hat` (true over estimated process gain) for which adaptive PI
/// gains placed at `poles` on `Kc_hat` (eq. 14) keep the loop stable: `0 < r < max`.
pub fn kc_ratio_margin(poles: DesiredPoles) -> Result<StableRange, PoleError> {
    poles.validate()?;
    let s = poles.sum();
    let p = poles.product();
    let d = 1.0 - s - p;
    let from_p_minus_1 = if d > 0.0 { 2.0 / d } else { f64::INFINITY };
    let from_a0 = if p != 0.0 {
        1.0 / p.abs()
    } else {
        f64::INFINITY
    };
    let analytic_max = from_p_minus_1.min(from_a0);
    // Coefficients at ratio r: a1 = r·(1 − s) − 1, a0 = r·p.
    let radius = |r: f64| spectral_radius(&quadratic_roots(r * (1.0 - s) - 1.0, r * p));
    let numeric_max = numeric_upper(radius, 1.0, 1e12).unwrap_or(f64::INFINITY);
    Ok(StableRange {
        analytic_max,
        numeric_max,
    })
}

/// The ratio range `0 < r < 2/(1 − p)` for the integral-only law placed at `pole` on
/// `Kc_hat` (its pole at ratio `r` is `1 − r·(1 − p)`).
pub fn integral_kc_ratio_margin(pole: f64) -> Result<StableRange, PoleError> {
    validate_single(pole)?;
    let analytic_max = 2.0 / (1.0 - pole);
    let radius = |r: f64| integral_pole(1.0 - pole, r, 1.0).norm();
    let numeric_max = numeric_upper(radius, 1.0, 1e12).unwrap_or(f64::INFINITY);
    Ok(StableRange {
        analytic_max,
        numeric_max,
    })
}

/// Pole magnitude, damping ratio and natural frequency of a discrete pole.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoleInfo {
    /// The pole.
    pub z: Pole,
    /// |z|.
    pub magnitude: f64,
    /// Damping ratio ζ of the equivalent continuous pole `s = ln(z)/T` (1 for z = 0 and
    /// for positive real poles inside the circle; −ζ for unstable poles).
    pub damping: f64,
    /// Natural frequency |s| of `s = ln(z)/T`, rad/s (infinite for z = 0).
    pub natural_freq_rad_s: f64,
}

/// Describe a discrete pole with the sampling period `period_s` (s).
///
/// ```
/// use acc_core::stability::{describe_pole, Pole};
/// let d = describe_pole(Pole::new(0.5, 0.0), 0.1);
/// assert!((d.damping - 1.0).abs() < 1e-12);
/// assert!((d.natural_freq_rad_s - 2f64.ln() / 0.1).abs() < 1e-9);
/// ```
pub fn describe_pole(z: Pole, period_s: f64) -> PoleInfo {
    let magnitude = z.norm();
    if magnitude == 0.0 {
        return PoleInfo {
            z,
            magnitude,
            damping: 1.0,
            natural_freq_rad_s: f64::INFINITY,
        };
    }
    let s = Complex::new(magnitude.ln(), z.im.atan2(z.re)) / period_s;
    let wn = s.norm();
    let damping = if wn > 0.0 { -s.re / wn } else { 0.0 };
    PoleInfo {
        z,
        magnitude,
        damping,
        natural_freq_rad_s: wn,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn companion_roots_match_the_quadratic_formula() {
        let [a, b] = quadratic_roots(-0.15, -0.01);
        let mut re = [a.re, b.re];
        re.sort_by(f64::total_cmp);
        assert!((re[0] + 0.05).abs() < 1e-12 && (re[1] - 0.2).abs() < 1e-12);
        let [c, _] = quadratic_roots(-0.6, 0.25);
        assert!((c.norm() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn paper_fixed_gain_boundary() {
        let r = fixed_gain_stable_range(0.05, 2.5, 0.1).unwrap();
        assert!((r.analytic_max - 5.714_285_714_285_714).abs() < 1e-12);
        assert!((r.numeric_max - r.analytic_max).abs() < 1e-6);
    }

    #[test]
    fn kc_ratio_margin_for_the_paper_cases() {
        let m1 = kc_ratio_margin(DesiredPoles::PAPER_CASE_I).unwrap();
        assert!((m1.analytic_max - 2.0 / 0.86).abs() < 1e-12);
        assert!((m1.numeric_max - m1.analytic_max).abs() < 1e-9);
        let m2 = kc_ratio_margin(DesiredPoles::PAPER_CASE_II).unwrap();
        assert!((m2.analytic_max - 2.0 / 1.56).abs() < 1e-12);
        assert!((m2.numeric_max - m2.analytic_max).abs() < 1e-9);
        // Slow poles: the |a0| < 1 condition binds.
        let m = kc_ratio_margin(DesiredPoles::Complex { re: 0.9, im: 0.3 }).unwrap();
        assert!((m.analytic_max - 1.0 / 0.9).abs() < 1e-12);
        assert!((m.numeric_max - m.analytic_max).abs() < 1e-9);
        let mi = integral_kc_ratio_margin(0.5).unwrap();
        assert!((mi.analytic_max - 4.0).abs() < 1e-12);
        assert!((mi.numeric_max - 4.0).abs() < 1e-9);
    }

    #[test]
    fn oscillating_pole_has_low_damping() {
        let d = describe_pole(Pole::new(-0.6, 0.0), 0.1);
        assert!(d.damping > 0.0 && d.damping < 0.2, "{d:?}");
        assert!(describe_pole(Pole::new(1.2, 0.0), 0.1).damping < 0.0);
    }
}
