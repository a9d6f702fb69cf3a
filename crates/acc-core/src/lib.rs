//! `acc-core`: the pure control core of `acc`.
//!
//! Everything here is a function of its inputs: no I/O, no clock, no logging and no
//! allocation on the step path. The sampling period `T` is data (`period_s` in
//! [`ControllerConfig`]); equations cite `../shared/docs/physics.md` (seed 002).

#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used))]

pub mod controller;
pub mod estimator;
pub mod override_spec;
pub mod pi;
pub mod poles;
pub mod source;
pub mod stability;

pub use controller::{
    Controller, ControllerConfig, Measurement, Mode, ModeConfig, OverrideLaw, PaperCase,
    Saturation, StepOutput, Trace,
};
pub use estimator::{EstimatorConfig, EstimatorGain, KcEstimator};
pub use override_spec::{FeedOverride, OverrideSpec};
pub use poles::{DesiredPoles, PiGains, PoleError};
pub use source::{ForceSample, ForceSource, PeriodInput, PhaseBlock};

/// Errors raised when building controller parts from parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum CoreError {
    /// A desired pole set is not strictly inside the unit circle.
    Pole(PoleError),
    /// A parameter is outside its allowed range.
    OutOfRange {
        /// Parameter name as used in configuration files.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Human-readable allowed range, e.g. `"(0, 2)"`.
        allowed: &'static str,
    },
}

impl std::fmt::Display for CoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CoreError::Pole(e) => write!(f, "{e}"),
            CoreError::OutOfRange {
                name,
                value,
                allowed,
            } => {
                write!(f, "`{name}` = {value} is out of range: allowed {allowed}")
            }
        }
    }
}

impl std::error::Error for CoreError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CoreError::Pole(e) => Some(e),
            CoreError::OutOfRange { .. } => None,
        }
    }
}

impl From<PoleError> for CoreError {
    fn from(e: PoleError) -> Self {
        CoreError::Pole(e)
    }
}
