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
//! **Confirmed estimate (air-cut restore).** While the cutter leaves the part it is only
//! partly engaged, so the true `Kc` falls towards 0 and eqs. 11–12 follow it down (to
//! ≈ 0.8 N/(mm/min) from 8 on the paper's 4 mm step before the force drops below
//! `min_force_n`). Held through the following air cut, such a value is no tool-wear
//! indicator and gives the next entry gains ten times too high (eq. 14: `Ki ∝ 1/Kc_hat`).
//! Therefore the estimator keeps a *confirmed* value: once the estimate has stayed within a
//! relative spread `confirm_tol` (`(max − min)/max`) over at least `confirm_periods`
//! consecutive cutting periods, that estimate is confirmed (and keeps being confirmed while
//! the run stays inside the spread). When the estimator stops because the cut ended (force
//! or feed below its threshold: an air cut), `Kc_hat` returns to the last confirmed value
//! once, at the first idle period, and then holds for the whole air cut. During the exit
//! itself nothing changes (the gains must follow the partial engagement), and invalid
//! samples ([`KcEstimator::hold`]) only hold. `confirm_periods = 0` turns the rule off.
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
use crate::RangeError;

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
///
/// ```
/// use acc_core::{EstimatorConfig, KcEstimator};
/// let mut est = KcEstimator::new(EstimatorConfig::paper(), 1.0).unwrap();
/// // A steady cut at Kc = 8 N/(mm/min) (4 mm): the estimate converges and is confirmed.
/// for _ in 0..40 {
///     est.update(800.0, 100.0);
/// }
/// assert!((est.kc_confirmed() - 8.0).abs() < 1e-6);
/// // Tool exit: engagement and force fall, the estimate follows the partial engagement ...
/// for f in [600.0, 400.0, 250.0, 150.0, 110.0] {
///     est.update(f, 100.0);
/// }
/// assert!(est.kc_hat() < 2.0);
/// // ... and the air cut brings back the confirmed 8, held until the next cut.
/// assert!(!est.update(0.0, 300.0));
/// assert!((est.kc_hat() - 8.0).abs() < 1e-6);
/// ```
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
    /// Consecutive cutting periods the estimate must stay within `confirm_tol` before it is
    /// confirmed, periods (default 10 = 1 s at T = 0.1 s; 0 = no air-cut restore, at most
    /// 10 000). See the module docs.
    pub confirm_periods: u16,
    /// Largest relative spread `(max − min)/max` of the estimate over such a run, 0 < x < 1
    /// (default 0.03 = 3 %).
    pub confirm_tol: f64,
}

impl EstimatorConfig {
    /// Defaults for the paper's set-up: `kc_initial` = 4 N/(mm/min) (800 N at 200 mm/min),
    /// bounds 0.05 … 100 N/(mm/min), normalized gain μ = 0.5, runs above 100 N and 5 mm/min,
    /// confirmed after 10 periods within 3 %.
    pub const fn paper() -> Self {
        Self {
            kc_initial: 4.0,
            kc_min: 0.05,
            kc_max: 100.0,
            gain: EstimatorGain::Normalized { mu: 0.5 },
            min_force_n: 100.0,
            min_feed_mm_min: 5.0,
            confirm_periods: Self::DEFAULT_CONFIRM_PERIODS,
            confirm_tol: Self::DEFAULT_CONFIRM_TOL,
        }
    }

    /// Default of [`EstimatorConfig::confirm_periods`]: 10 periods.
    pub const DEFAULT_CONFIRM_PERIODS: u16 = 10;
    /// Default of [`EstimatorConfig::confirm_tol`]: 3 %.
    pub const DEFAULT_CONFIRM_TOL: f64 = 0.03;

    /// Check every value; errors name the configuration key and the allowed range.
    pub fn validate(&self) -> Result<(), CoreError> {
        let pos = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(CoreError::OutOfRange(RangeError::new(name, value, "> 0")))
            }
        };
        let nonneg = |name, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(CoreError::OutOfRange(RangeError::new(name, value, ">= 0")))
            }
        };
        pos("estimator.kc_min", self.kc_min)?;
        if !(self.kc_max.is_finite() && self.kc_max > self.kc_min) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "estimator.kc_max",
                self.kc_max,
                "> kc_min",
            )));
        }
        if !(self.kc_initial >= self.kc_min && self.kc_initial <= self.kc_max) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "estimator.kc_initial",
                self.kc_initial,
                "kc_min ..= kc_max",
            )));
        }
        match self.gain {
            EstimatorGain::Fixed { g_c } => pos("estimator.g_c", g_c)?,
            EstimatorGain::Normalized { mu } => {
                if !(mu.is_finite() && mu > 0.0 && mu < 2.0) {
                    return Err(CoreError::OutOfRange(RangeError::new(
                        "estimator.mu",
                        mu,
                        "0 < mu < 2",
                    )));
                }
            }
        }
        nonneg("estimator.min_force_n", self.min_force_n)?;
        nonneg("estimator.min_feed_mm_min", self.min_feed_mm_min)?;
        if self.confirm_periods > 10_000 {
            return Err(CoreError::OutOfRange(RangeError::new(
                "estimator.confirm_periods",
                f64::from(self.confirm_periods),
                "0 ..= 10000",
            )));
        }
        if !(self.confirm_tol.is_finite() && self.confirm_tol > 0.0 && self.confirm_tol < 1.0) {
            return Err(CoreError::OutOfRange(RangeError::new(
                "estimator.confirm_tol",
                self.confirm_tol,
                "0 < x < 1",
            )));
        }
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
    /// Last confirmed estimate, N/(mm/min).
    kc_confirmed: f64,
    /// Current run of cutting periods: its length and the estimate's min and max.
    run_len: u16,
    run_min: f64,
    run_max: f64,
}

impl KcEstimator {
    /// A validated estimator for the loop gain `km` (feed drive × force measurement).
    pub fn new(cfg: EstimatorConfig, km: f64) -> Result<Self, CoreError> {
        cfg.validate()?;
        if !(km.is_finite() && km > 0.0) {
            return Err(CoreError::OutOfRange(RangeError::new("km", km, "> 0")));
        }
        Ok(Self {
            cfg,
            km,
            kc_hat: cfg.kc_initial,
            last_error_n: 0.0,
            health: 0.0,
            kc_confirmed: cfg.kc_initial,
            run_len: 0,
            run_min: cfg.kc_initial,
            run_max: cfg.kc_initial,
        })
    }

    /// The last confirmed estimate, N/(mm/min): the value `Kc_hat` returns to when an air
    /// cut starts (module docs); `kc_initial` until a cut has confirmed one.
    pub fn kc_confirmed(&self) -> f64 {
        self.kc_confirmed
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

    /// Restart from `kc_hat` (clamped to the bounds; also the confirmed value).
    pub fn reset(&mut self, kc_hat: f64) {
        if kc_hat.is_finite() {
            self.kc_hat = kc_hat.clamp(self.cfg.kc_min, self.cfg.kc_max);
        }
        self.kc_confirmed = self.kc_hat;
        self.run_len = 0;
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
    /// (`false` during air cuts, below the thresholds, or on non-finite input). The first
    /// period that is not cutting after a cut returns `Kc_hat` to the confirmed value
    /// (module docs).
    pub fn update(&mut self, force_n: f64, feed_mm_min: f64) -> bool {
        if !self.is_cutting(force_n, feed_mm_min) {
            if self.cfg.confirm_periods > 0 && self.run_len > 0 {
                self.kc_hat = self.kc_confirmed;
            }
            self.run_len = 0;
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
        self.confirm();
        true
    }

    /// Extend the run of cutting periods with the new estimate (restart it when the spread
    /// exceeds `confirm_tol`) and confirm the estimate once the run is long enough.
    fn confirm(&mut self) {
        let k = self.kc_hat;
        let (lo, hi) = if self.run_len == 0 {
            (k, k)
        } else {
            (self.run_min.min(k), self.run_max.max(k))
        };
        if hi - lo > self.cfg.confirm_tol * hi {
            self.run_len = 1;
            self.run_min = k;
            self.run_max = k;
        } else {
            self.run_len = self.run_len.saturating_add(1);
            self.run_min = lo;
            self.run_max = hi;
        }
        if self.cfg.confirm_periods > 0 && self.run_len >= self.cfg.confirm_periods {
            self.kc_confirmed = k;
        }
    }

    /// A period without a usable sample: the estimate holds and the health decays.
    pub fn hold(&mut self) {
        self.health -= HEALTH_ALPHA * self.health;
    }
}
