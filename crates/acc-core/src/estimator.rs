//! Integral Kc estimator (seed 002, eqs. 11–12).

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

/// The integral estimator state.
#[derive(Debug, Clone)]
pub struct KcEstimator {
    // implementation-defined
}
