//! Integral Kc estimator (seed 002, eqs. 11–12).
//!
//! ```text
//! E_f(i)    = Fc(i) − Km·Kc_hat(i−1)·U_applied        (11)
//! Kc_hat(i) = Kc_hat(i−1) + g_c·E_f(i)                (12)
//! ```
//!
//! `U_applied` is the feed that actually produced `Fc(i)` (`Measurement::feed_mm_min`),
//! not the feed just commanded. The estimation error contracts by `(1 − g_c·Km·U)` per
//! step; with the normalized gain `g_c = μ/(Km·U)` it contracts by `(1 − μ)` whatever the
//! feed. Guards for a real machine: the update runs only while cutting (force and feed above
//! thresholds), and `Kc_hat` is clamped to `[kc_min, kc_max]`.
//!
//! ```
//! use acc_core::{EstimatorConfig, EstimatorGain, KcEstimator};
//! let cfg = EstimatorConfig { kc_initial: 0.4, gain: EstimatorGain::Normalized { mu: 0.5 },
//!                             ..EstimatorConfig::paper() };
//! let mut est = KcEstimator::new(cfg, 1.0).unwrap();
//! // True Kc = 4 N/(mm/min) at 200 mm/min: 800 N.
//! for _ in 0..40 {
//!     est.update(800.0, 200.0);
//! }
//! assert!((est.kc_hat() - 4.0).abs() < 1e-9);
//! // Air cut: no force, the estimate does not move.
//! assert!(!est.update(0.0, 300.0));
//! assert!((est.kc_hat() - 4.0).abs() < 1e-9);
//! ```

use crate::CoreError;

/// Estimator gain choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EstimatorGain {
    /// Fixed g_c (eq. 12).
    Fixed {
        /// g_c, 1/(mm/min).
        g_c: f64,
    },
    /// Normalized g_c = μ/(Km·U), 0 < μ < 2: contraction (1 − μ) independent of the feed.
    Normalized {
        /// μ in (0, 2).
        mu: f64,
    },
}

/// Estimator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorConfig {
    /// Initial Kc_hat, N/(mm/min).
    pub kc_initial: f64,
    /// Lower bound of Kc_hat, N/(mm/min).
    pub kc_min: f64,
    /// Upper bound of Kc_hat, N/(mm/min).
    pub kc_max: f64,
    /// Gain.
    pub gain: EstimatorGain,
    /// Runs only while the measured force is above this, N.
    pub min_force_n: f64,
    /// Runs only while the applied feed is above this, mm/min.
    pub min_feed_mm_min: f64,
}

impl EstimatorConfig {
    /// Defaults for the paper's set-up: `kc_initial` = 4 N/(mm/min) (800 N at 200 mm/min),
    /// bounds 0.05 … 100 N/(mm/min), normalized gain μ = 0.5, runs above 100 N and 5 mm/min.
    pub const fn paper() -> Self {
        Self {
            kc_initial: 4.0,
            kc_min: 0.05,
            kc_max: 100.0,
            gain: EstimatorGain::Normalized { mu: 0.5 },
            min_force_n: 100.0,
            min_feed_mm_min: 5.0,
        }
    }

    /// Check every value; errors name the configuration key and the allowed range.
    pub fn validate(&self) -> Result<(), CoreError> {
        let pos = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(CoreError::OutOfRange {
                    name,
                    value,
                    allowed: "> 0",
                })
            }
        };
        let nonneg = |name, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(CoreError::OutOfRange {
                    name,
                    value,
                    allowed: ">= 0",
                })
            }
        };
        pos("estimator.kc_min", self.kc_min)?;
        if !(self.kc_max.is_finite() && self.kc_max > self.kc_min) {
            return Err(CoreError::OutOfRange {
                name: "estimator.kc_max",
                value: self.kc_max,
                allowed: "> kc_min",
            });
        }
        if !(self.kc_initial >= self.kc_min && self.kc_initial <= self.kc_max) {
            return Err(CoreError::OutOfRange {
                name: "estimator.kc_initial",
                value: self.kc_initial,
                allowed: "kc_min ..= kc_max",
            });
        }
        match self.gain {
            EstimatorGain::Fixed { g_c } => pos("estimator.g_c", g_c)?,
            EstimatorGain::Normalized { mu } => {
                if !(mu.is_finite() && mu > 0.0 && mu < 2.0) {
                    return Err(CoreError::OutOfRange {
                        name: "estimator.mu",
                        value: mu,
                        allowed: "0 < mu < 2",
                    });
                }
            }
        }
        nonneg("estimator.min_force_n", self.min_force_n)?;
        nonneg("estimator.min_feed_mm_min", self.min_feed_mm_min)?;
        Ok(())
    }
}

impl Default for EstimatorConfig {
    /// [`EstimatorConfig::paper`].
    fn default() -> Self {
        Self::paper()
    }
}

/// Smoothing factor of the health indicator per period (≈ 10 periods = 1 s at T = 0.1 s).
const HEALTH_ALPHA: f64 = 0.1;

/// The integral estimator state.
#[derive(Debug, Clone)]
pub struct KcEstimator {
    cfg: EstimatorConfig,
    km: f64,
    kc_hat: f64,
    last_error_n: f64,
    health: f64,
}

impl KcEstimator {
    /// A validated estimator for the loop gain `km` (feed drive × force measurement).
    pub fn new(cfg: EstimatorConfig, km: f64) -> Result<Self, CoreError> {
        cfg.validate()?;
        if !(km.is_finite() && km > 0.0) {
            return Err(CoreError::OutOfRange {
                name: "km",
                value: km,
                allowed: "> 0",
            });
        }
        Ok(Self {
            cfg,
            km,
            kc_hat: cfg.kc_initial,
            last_error_n: 0.0,
            health: 0.0,
        })
    }

    /// Current estimate Kc_hat, N/(mm/min).
    pub fn kc_hat(&self) -> f64 {
        self.kc_hat
    }

    /// The settings.
    pub fn config(&self) -> &EstimatorConfig {
        &self.cfg
    }

    /// Prediction error `E_f` of the last active update, N (eq. 11).
    pub fn last_error_n(&self) -> f64 {
        self.last_error_n
    }

    /// Excitation / health indicator in [0, 1]: an exponential average (factor 0.1 per
    /// period) of `active · (1 − min(1, |E_f| / Fc))`. Near 1 when the estimator has been
    /// running recently and predicts the force well; it decays toward 0 during air cuts or
    /// invalid data, i.e. when `Kc_hat` is no longer being confirmed by the process.
    pub fn excitation(&self) -> f64 {
        self.health
    }

    /// Restart from `kc_hat` (clamped to the bounds).
    pub fn reset(&mut self, kc_hat: f64) {
        if kc_hat.is_finite() {
            self.kc_hat = kc_hat.clamp(self.cfg.kc_min, self.cfg.kc_max);
        }
        self.last_error_n = 0.0;
        self.health = 0.0;
    }

    /// Whether a sample is usable: force and applied feed finite and above the thresholds.
    pub fn is_cutting(&self, force_n: f64, feed_mm_min: f64) -> bool {
        force_n.is_finite()
            && feed_mm_min.is_finite()
            && force_n > self.cfg.min_force_n
            && feed_mm_min > self.cfg.min_feed_mm_min
            && feed_mm_min > 0.0
    }

    /// One period of eqs. 11–12 with the measured force `force_n` (N) and the applied feed
    /// that produced it `feed_mm_min` (mm/min). Returns whether the estimate was updated
    /// (`false` during air cuts, below the thresholds, or on non-finite input).
    pub fn update(&mut self, force_n: f64, feed_mm_min: f64) -> bool {
        if !self.is_cutting(force_n, feed_mm_min) {
            self.hold();
            return false;
        }
        let regressor = self.km * feed_mm_min;
        let e_f = force_n - self.kc_hat * regressor; // eq. 11
        let g_c = match self.cfg.gain {
            EstimatorGain::Fixed { g_c } => g_c,
            EstimatorGain::Normalized { mu } => mu / regressor,
        };
        let next = self.kc_hat + g_c * e_f; // eq. 12
        self.kc_hat = if next.is_finite() {
            next.clamp(self.cfg.kc_min, self.cfg.kc_max)
        } else {
            self.kc_hat
        };
        self.last_error_n = e_f;
        let fit = 1.0 - (e_f.abs() / force_n).min(1.0);
        self.health += HEALTH_ALPHA * (fit - self.health);
        true
    }

    /// A period without a usable sample: the estimate holds and the health decays.
    pub fn hold(&mut self) {
        self.health -= HEALTH_ALPHA * self.health;
    }
}
