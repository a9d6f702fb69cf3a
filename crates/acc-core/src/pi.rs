//! PI controller (seed 002, eq. 4) with saturation, quantization, anti-windup and bumpless start.
//!
//! Position form of eq. 4, `U(i) = [Kp + Ki·T/(1 − z⁻¹)]·E(i)`:
//!
//! ```text
//! I(i) = I(i−1) + Ki·T·E(i)        integrator state, mm/min
//! U(i) = Kp·E(i) + I(i)            feed command, mm/min
//! override(i) = quantize(100·U(i)/F_programmed)
//! ```
//!
//! **Anti-windup** (conditional integration against the clamped output): the board can
//! only apply `[min_pct, max_pct]`, i.e. feeds `[U_min, U_max] = [min_pct, max_pct]·F/100`.
//! When the new output would lie beyond a limit *and* the integration pushes further that
//! way, the integrator only moves up to the value that puts the output on the limit
//! (`U_max − Kp·E`), never further, and never backwards because of the P term; the state
//! itself stays inside `[U_min, U_max]`. Quantization is not windup: inside the range the
//! integrator keeps its unquantized value so that sub-step corrections accumulate until the
//! board's next position is reached. The limits `min_pct`/`max_pct` are on the step grid, so
//! the clamped output is also the quantized one.
//!
//! ```
//! use acc_core::pi::PiState;
//! use acc_core::{OverrideSpec, PiGains, Saturation};
//! let gains = PiGains { kp: 0.05, ki: 2.5 };
//! let spec = OverrideSpec::paper();
//! let mut pi = PiState::new(200.0); // bumpless: starts from the feed in force
//! // Air cut (E = 800 N) for 50 periods: the output sits at 150 % = 300 mm/min.
//! for _ in 0..50 {
//!     let s = pi.step(gains, 800.0, 0.1, 200.0, &spec, true, true);
//!     assert_eq!(s.command.pct(), 150);
//!     assert_eq!(s.saturation, Saturation::High);
//! }
//! // The integrator stopped where the output meets the limit: 300 − 0.05·800 = 260 mm/min.
//! assert!((pi.integral_mm_min() - 260.0).abs() < 1e-9);
//! ```

use crate::{FeedOverride, OverrideSpec, PiGains, Saturation};

/// Result of one PI period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiStep {
    /// Feed command `U(i)` before quantization and clamping, mm/min.
    pub feed_cmd_mm_min: f64,
    /// `100·U(i)/F_programmed` before quantization and clamping, percent.
    pub unquantized_pct: f64,
    /// Quantized, clamped override.
    pub command: FeedOverride,
    /// Whether the unconstrained demand `Kp·E + I(i−1) + Ki·T·E` (before anti-windup)
    /// lay beyond a limit.
    pub saturation: Saturation,
    /// Contribution of the P term `Kp·E`, mm/min.
    pub p_term_mm_min: f64,
    /// Integrator state after the step, mm/min.
    pub integral_mm_min: f64,
}

/// The PI integrator state, mm/min (the I part of the feed command).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiState {
    integral_mm_min: f64,
}

impl PiState {
    /// Start with the integrator at `feed_mm_min`: with E = 0 the output equals the feed in
    /// force (bumpless start).
    pub fn new(feed_mm_min: f64) -> Self {
        Self {
            integral_mm_min: feed_mm_min,
        }
    }

    /// Integrator state, mm/min.
    pub fn integral_mm_min(&self) -> f64 {
        self.integral_mm_min
    }

    /// Set the integrator (bumpless transfer), mm/min.
    pub fn set_integral_mm_min(&mut self, feed_mm_min: f64) {
        if feed_mm_min.is_finite() {
            self.integral_mm_min = feed_mm_min;
        }
    }

    /// One period of eq. 4 with error `error_n` (N, eq. 2), period `period_s` (s) and the
    /// programmed feed `programmed_feed_mm_min` (> 0, mm/min). `integrate = false` holds the
    /// integrator (frozen); `anti_windup = false` integrates unconditionally (for
    /// demonstrating windup only).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        gains: PiGains,
        error_n: f64,
        period_s: f64,
        programmed_feed_mm_min: f64,
        spec: &OverrideSpec,
        anti_windup: bool,
        integrate: bool,
    ) -> PiStep {
        let per_pct = programmed_feed_mm_min / 100.0;
        let u_min = f64::from(spec.min_pct) * per_pct;
        let u_max = f64::from(spec.max_pct) * per_pct;
        let p_term = gains.kp * error_n;
        let held = self.integral_mm_min;
        let mut integral = held;
        let mut demand = p_term + held;
        if integrate {
            let delta = gains.ki * period_s * error_n;
            integral = held + delta;
            demand = p_term + integral;
            if anti_windup {
                let u = p_term + integral;
                if u > u_max && delta > 0.0 {
                    integral = held.max(u_max - p_term).min(integral);
                } else if u < u_min && delta < 0.0 {
                    integral = held.min(u_min - p_term).max(integral);
                }
                integral = integral.clamp(u_min, u_max);
            }
        }
        if integral.is_finite() {
            self.integral_mm_min = integral;
        }
        let u = p_term + self.integral_mm_min;
        let pct = u / per_pct;
        let demand_pct = demand / per_pct;
        let saturation = if demand_pct > f64::from(spec.max_pct) {
            Saturation::High
        } else if demand_pct < f64::from(spec.min_pct) {
            Saturation::Low
        } else {
            Saturation::None
        };
        PiStep {
            feed_cmd_mm_min: u,
            unquantized_pct: pct,
            command: spec.quantize(pct),
            saturation,
            p_term_mm_min: p_term,
            integral_mm_min: self.integral_mm_min,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: PiGains = PiGains { kp: 0.05, ki: 2.5 };

    #[test]
    fn without_anti_windup_the_integrator_winds_up() {
        let spec = OverrideSpec::paper();
        let mut pi = PiState::new(200.0);
        for _ in 0..50 {
            pi.step(G, 800.0, 0.1, 200.0, &spec, false, true);
        }
        // 200 + 50 · 2.5 · 0.1 · 800 = 10 200 mm/min.
        assert!((pi.integral_mm_min() - 10_200.0).abs() < 1e-6);
    }

    #[test]
    fn frozen_integrator_holds() {
        let spec = OverrideSpec::paper();
        let mut pi = PiState::new(150.0);
        let s = pi.step(G, 100.0, 0.1, 200.0, &spec, true, false);
        assert_eq!(pi.integral_mm_min(), 150.0);
        assert!((s.feed_cmd_mm_min - 155.0).abs() < 1e-12);
        assert_eq!(s.command, FeedOverride(80));
    }

    #[test]
    fn lower_limit_stops_integration_too() {
        let spec = OverrideSpec::paper();
        let mut pi = PiState::new(200.0);
        for _ in 0..30 {
            let s = pi.step(G, -2000.0, 0.1, 200.0, &spec, true, true);
            assert!(s.integral_mm_min >= 0.0);
        }
        assert_eq!(pi.integral_mm_min(), 100.0); // 0 − 0.05·(−2000)
    }

    #[test]
    fn inside_the_range_sub_step_corrections_accumulate() {
        let spec = OverrideSpec::paper();
        let mut pi = PiState::new(120.0);
        let g = PiGains { kp: 0.0, ki: 0.5 };
        // +0.5 mm/min per period: 60 % (120 mm/min) moves to 70 % once U >= 130.
        let mut steps = 0;
        while pi
            .step(g, 10.0, 0.1, 200.0, &spec, true, true)
            .command
            .pct()
            == 60
        {
            steps += 1;
        }
        assert_eq!(steps, 19);
    }
}
