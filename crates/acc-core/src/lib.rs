//! `acc-core`: the pure control core of `acc`.
//!
//! Everything here is a function of its inputs: no I/O, no clock, no logging and no
//! allocation on the step path (checked by `tests/control/no_alloc.rs`). The sampling period `T` is
//! data (`period_s` in [`ControllerConfig`]); equations cite the seed papers as restated in
//! `physics.md` §1 (seed 002: eqs. 2, 4, 6, 11, 12, 14 and conclusion 5).
//!
//! | module | what |
//! | --- | --- |
//! | [`controller`] | [`Controller::step`]: one period — error (eq. 2), estimator, gains, PI, quantizer |
//! | [`estimator`] | integral Kc estimator (eqs. 11–12), thresholds, bounds, normalized gain, health |
//! | [`poles`] | pole assignment (eq. 14) and the integral-only pole (conclusion 5) |
//! | [`pi`] | PI law (eq. 4) with anti-windup against the clamped output and bumpless start |
//! | [`override_spec`] | [`FeedOverride`], board step (10 % or 1 %) and range 0 … 150 % |
//! | [`stability`] | companion-matrix poles (nalgebra), Jury test, stable Kc ranges and margins |
//! | [`delay`] | delay margin: Schur–Cohn test of the PI loop with extra dead time, its poles |
//! | [`roots`] | roots of a real polynomial (Aberth–Ehrlich; always ends) |
//! | [`source`] | the [`ForceSource`] measurement-channel trait |
//! | [`spindle_force`] | the force from spindle power (or current) per period: block power, no-load model, estimators, [`spindle_force::SpindleSource`] |
//! | [`force_law`] | [`force_law::feed_for_force`]: the force law (seed 002 eq. 1) solved for the feed that gives Fr |
//! | [`filter`] | [`filter::FirstOrderLag`]: the one first-order lag (exact ZOH discretisation) |
//! | [`stats`] | [`stats::rms`]: the one root mean square |
//!
//! ```
//! use acc_core::stability::{kc_ratio_margin, pi_poles, spectral_radius};
//! use acc_core::{Controller, ControllerConfig, DesiredPoles, FeedOverride, Measurement,
//!                OverrideLaw, PaperCase};
//!
//! // Paper case I: poles 0.2 / −0.05, T = 0.1 s, Fr = 800 N, Km = 1, 10 % board.
//! let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::I)).unwrap();
//! ctl.engage(FeedOverride(100));
//! let m = Measurement { force_n: 1200.0, feed_mm_min: 200.0,
//!                       programmed_feed_mm_min: 200.0, valid: true };
//! let out = ctl.step(&m);
//! // Kc_hat moved halfway (μ = 0.5) from 4 toward 1200/200 = 6 N/(mm/min) ...
//! assert!((out.trace.kc_hat - 5.0).abs() < 1e-12);
//! // ... the gains follow eq. 14 at Kc_hat = 5 ...
//! assert!((out.trace.kp - 0.01 / 5.0).abs() < 1e-15);
//! assert!((out.trace.ki - 0.84 / 0.5).abs() < 1e-12);
//! // ... and the feed drops: U = 200 + (Kp + Ki·T)·(800 − 1200) = 132 mm/min → 66 % → 70 %.
//! assert!((out.trace.feed_cmd_mm_min - 132.0).abs() < 1e-9);
//! assert_eq!(out.command, FeedOverride(70));
//!
//! // With Kc_hat = Kc the closed loop has exactly the desired poles ...
//! let p = pi_poles(out.trace.kp, out.trace.ki, 5.0, 0.1);
//! assert!(spectral_radius(&p) < 0.2 + 1e-12);
//! // ... and stays stable while the true Kc is below 2/0.86 = 2.33 times the estimate.
//! let margin = kc_ratio_margin(DesiredPoles::PAPER_CASE_I).unwrap();
//! assert!((margin.analytic_max - 2.0 / 0.86).abs() < 1e-12);
//! ```

#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used))]

pub mod clock;
pub mod controller;
pub mod delay;
pub mod estimator;
pub mod filter;
pub mod force_law;
pub mod override_spec;
pub mod pi;
pub mod poles;
pub mod roots;
pub mod source;
pub mod spindle_force;
pub mod stability;
pub mod stats;

pub use controller::{
    Controller, ControllerConfig, Measurement, Mode, ModeConfig, OverrideLaw, PaperCase,
    Saturation, StepOutput, Trace,
};
pub use estimator::{EstimatorConfig, EstimatorGain, KcEstimator};
pub use override_spec::{
    CommandBounds, CommandLimits, Demand, FeedOverride, OverrideSpec, Placed, Quantizer, SigmaDelta,
};
pub use poles::{DesiredPoles, PiGains, PoleError};
pub use source::{ForceSample, ForceSource, PeriodInput, PhaseBlock};

/// A value outside its allowed range — the one shape of this error in the workspace (core
/// parameters, configuration files, policy, spindle parameters, command-line options).
/// Displays as `FILE: key `K` = V is out of range: allowed A` (without `FILE: ` when the
/// value did not come from a file).
///
/// ```
/// use acc_core::RangeError;
/// let e = RangeError::new("period_s", -1.0, "0 < T <= 10");
/// assert_eq!(e.to_string(), "key `period_s` = -1 is out of range: allowed 0 < T <= 10");
/// let e = e.prefixed("controller").in_file("m.toml");
/// assert_eq!(
///     e.to_string(),
///     "m.toml: key `controller.period_s` = -1 is out of range: allowed 0 < T <= 10"
/// );
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RangeError {
    /// The file the value came from, if any.
    pub file: Option<std::path::PathBuf>,
    /// Dotted key path as written in the configuration (or the option name).
    pub key: String,
    /// Offending value as written.
    pub value: String,
    /// Allowed range in words, e.g. `0.001 ..= 10`.
    pub allowed: String,
}

impl RangeError {
    /// `key` = `value` is outside `allowed` (no file yet; see [`RangeError::in_file`]).
    pub fn new(
        key: impl Into<String>,
        value: impl std::fmt::Display,
        allowed: impl Into<String>,
    ) -> Self {
        Self {
            file: None,
            key: key.into(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }

    /// The same error, naming the file the value came from.
    pub fn in_file(self, file: impl AsRef<std::path::Path>) -> Self {
        Self {
            file: Some(file.as_ref().to_path_buf()),
            ..self
        }
    }

    /// The same error with the key inside `table` (`table.key`).
    pub fn prefixed(self, table: &str) -> Self {
        Self {
            key: format!("{table}.{}", self.key),
            ..self
        }
    }
}

impl std::fmt::Display for RangeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(file) = &self.file {
            write!(f, "{}: ", file.display())?;
        }
        write!(
            f,
            "key `{}` = {} is out of range: allowed {}",
            self.key, self.value, self.allowed
        )
    }
}

impl std::error::Error for RangeError {}

/// Errors raised when building controller parts from parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum CoreError {
    /// A desired pole set is not strictly inside the unit circle.
    Pole(PoleError),
    /// A parameter is outside its allowed range (the key is the configuration name).
    OutOfRange(RangeError),
}

impl std::fmt::Display for CoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CoreError::Pole(e) => write!(f, "{e}"),
            CoreError::OutOfRange(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for CoreError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CoreError::Pole(e) => Some(e),
            CoreError::OutOfRange(e) => Some(e),
        }
    }
}

impl From<PoleError> for CoreError {
    fn from(e: PoleError) -> Self {
        CoreError::Pole(e)
    }
}
