//! The first-order lag, written once for the whole workspace.
//!
//! `τ·dy/dt + y = u` with the input `u` held constant over a step of length `dt`
//! (zero-order hold) has the exact discretisation
//!
//! ```text
//! y[k+1] = y[k] + (u[k] − y[k])·α,   α = 1 − e^(−dt/τ)
//! ```
//!
//! (seed 002 eq. 5 for the feed drive, restated in `physics.md` §1; the same law serves the
//! spindle drive's torque lag, the power sensor's low-pass and the dynamometer's low-pass).
//! Its step response is `1 − e^(−t/τ)`: 63.2 % at `t = τ`, and its DC gain is 1. A
//! non-positive `τ` is "no lag" (`α = 1`, the output is the input).
//!
//! ```
//! use acc_core::filter::FirstOrderLag;
//!
//! let lag = FirstOrderLag::new(0.5); // τ = 0.5 s
//! let (mut y, dt) = (0.0, 0.01);
//! for _ in 0..50 {
//!     y = lag.step(y, 1.0, dt); // a unit step, 50 steps of 10 ms = τ
//! }
//! assert!((y - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
//! assert_eq!(FirstOrderLag::new(0.0).step(3.0, 7.0, dt), 7.0);
//! ```

/// A first-order lag with time constant `τ` (s), discretised exactly for a held input
/// (module docs; seed 002 eq. 5). The state (the last output) stays with the caller, so a
/// lag costs nothing to copy and the same value serves many channels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstOrderLag {
    /// Time constant τ, s; `≤ 0` means no lag.
    pub tau_s: f64,
}

impl FirstOrderLag {
    /// A lag with time constant `tau_s` (s; `≤ 0`: no lag).
    pub const fn new(tau_s: f64) -> Self {
        Self { tau_s }
    }

    /// The lag whose −3 dB corner is `cutoff_hz` (Hz): `τ = 1/(2π·f_c)`; a non-positive
    /// corner is "no lag".
    pub fn from_cutoff_hz(cutoff_hz: f64) -> Self {
        if cutoff_hz > 0.0 {
            Self::new(1.0 / (2.0 * std::f64::consts::PI * cutoff_hz))
        } else {
            Self::new(0.0)
        }
    }

    /// The step gain `α = 1 − e^(−dt/τ)` for a step of `dt_s` (s); 1 without lag.
    pub fn alpha(&self, dt_s: f64) -> f64 {
        if self.tau_s > 0.0 {
            1.0 - (-dt_s / self.tau_s).exp()
        } else {
            1.0
        }
    }

    /// One step with a precomputed `alpha` (from [`FirstOrderLag::alpha`]):
    /// `y + (u − y)·α`. Callers that take many steps of one length compute α once. (With
    /// `α = 1` the result is `u` up to rounding; [`FirstOrderLag::step`] returns `u` exactly
    /// when there is no lag.)
    pub fn advance(y: f64, u: f64, alpha: f64) -> f64 {
        y + (u - y) * alpha
    }

    /// One step of length `dt_s` (s) from output `y` with held input `u`; returns the new
    /// output.
    pub fn step(&self, y: f64, u: f64, dt_s: f64) -> f64 {
        if self.tau_s > 0.0 {
            Self::advance(y, u, self.alpha(dt_s))
        } else {
            u
        }
    }

    /// One step on a state that starts empty: the first input passes through (the filter
    /// starts settled on it), later ones are lagged. Stores and returns the new output.
    pub fn step_from(&self, state: &mut Option<f64>, u: f64, dt_s: f64) -> f64 {
        let y = match *state {
            Some(prev) => self.step(prev, u, dt_s),
            None => u,
        };
        *state = Some(y);
        y
    }

    /// The unit step response `1 − e^(−t/τ)` at `t_s` (s) after the step: 0 for `t ≤ 0`,
    /// 1 after it without lag.
    pub fn step_response(&self, t_s: f64) -> f64 {
        if t_s <= 0.0 {
            0.0
        } else if self.tau_s > 0.0 {
            1.0 - (-t_s / self.tau_s).exp()
        } else {
            1.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Sampled at `dt`, a unit step crosses 1 − 1/e (63.2 %) within one sample of τ.
        #[test]
        fn step_response_reaches_63_percent_at_tau(tau in 0.01f64..100.0, per_tau in 4usize..400) {
            let lag = FirstOrderLag::new(tau);
            let dt = tau / per_tau as f64;
            let target = 1.0 - (-1.0f64).exp();
            let (mut y, mut k) = (0.0, 0usize);
            while y < target {
                y = lag.step(y, 1.0, dt);
                k += 1;
                prop_assert!(k < 10 * per_tau, "never reached 63 %");
            }
            let t_cross = k as f64 * dt;
            prop_assert!((t_cross - tau).abs() <= dt * (1.0 + 1e-9), "crossed at {t_cross}, τ = {tau}");
            // The discrete response is the sampled continuous one.
            prop_assert!((y - lag.step_response(t_cross)).abs() < 1e-9);
        }

        /// A constant input is a fixed point (DC gain 1), and the output converges to it.
        #[test]
        fn unity_dc_gain(tau in 0.0f64..1.0, u in -1e4f64..1e4, y0 in -1e4f64..1e4, dt in 1e-2f64..1.0) {
            let lag = FirstOrderLag::new(tau);
            prop_assert_eq!(lag.step(u, u, dt), u);
            let mut y = y0;
            // 40 τ: e^(−40) ≈ 4e−18 of the initial error remains.
            for _ in 0..=(40.0 * tau / dt).ceil() as usize {
                y = lag.step(y, u, dt);
            }
            prop_assert!((y - u).abs() <= 1e-9 * (1.0 + u.abs()), "{y} vs {u}");
        }
    }

    #[test]
    fn no_lag_passes_through_and_state_starts_settled() {
        let off = FirstOrderLag::new(0.0);
        assert_eq!(off.alpha(0.1), 1.0);
        assert_eq!(off.step(5.0, 2.0, 0.1), 2.0);
        assert_eq!(off.step_response(0.3), 1.0);
        let lag = FirstOrderLag::new(0.3);
        let mut s = None;
        assert_eq!(lag.step_from(&mut s, 4.0, 0.1), 4.0);
        let y = lag.step_from(&mut s, 0.0, 0.1);
        assert!((y - 4.0 * (-0.1f64 / 0.3).exp()).abs() < 1e-12);
        assert_eq!(s, Some(y));
    }

    #[test]
    fn cutoff_gives_tau_of_one_over_two_pi_fc() {
        let lag = FirstOrderLag::from_cutoff_hz(10.0);
        assert!((lag.tau_s - 1.0 / (20.0 * std::f64::consts::PI)).abs() < 1e-15);
        assert_eq!(FirstOrderLag::from_cutoff_hz(0.0).tau_s, 0.0);
    }
}
