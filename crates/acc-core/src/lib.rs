//! `acc-core`: the pure control core of `acc`.
//!
//! Everything here is a function of its inputs: no I/O, no clock, no logging and no
//! allocation on the step path. The sampling period `T` is data (`period_s` in
//! [`ControllerConfig`]); equations cite `../shared/docs/physics.md` (seed 002).
//!
//! CONTRACT NOTE (remove when implemented): the public names in this file are shared
//! with the simulator and runtime crates. Add, but do not rename.

pub mod controller;
pub mod estimator;
pub mod override_spec;
pub mod pi;
pub mod poles;
pub mod source;
pub mod stability;

pub use controller::{
    Controller, ControllerConfig, Measurement, Mode, ModeConfig, OverrideLaw, Saturation,
    StepOutput, Trace,
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
