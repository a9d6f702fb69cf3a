//! The cutting force from the spindle drive's own signals, one control period at a time
//! (seed 000, physics.md §2): spindle power minus the no-load power at the speed gives the
//! cutting torque, the torque over the tool radius the force.
//!
//! This is the per-period half of the spindle work; it sits in the core beside the law so
//! that one crate holds every piece of math a force sample meets between the board's
//! register and the override. What is not per period — fitting the constants from a
//! calibration cut, the calibration file, reading recorded sample streams and the public
//! data sets, the error metrics — is `acc-spindle`.
//!
//! | module | what |
//! | --- | --- |
//! | [`power`] | Blondel two-wattmeter power, RMS current and voltage, power factor of one block of samples — one pass, no allocation |
//! | [`noload`] | the no-load (air-cut) power and current as a function of speed, adapted while running under a documented rule |
//! | [`constants`] | the calibrated constants of the estimators ([`Constants`]) |
//! | [`estimate`] | the four estimators (power, power with load-dependent efficiency, conventional current, current with motor characteristics) and their validity checks |
//! | [`source`] | [`SpindleSource`], the [`crate::ForceSource`] the loop uses on the three-phase block or on the board's power register |
//!
//! Garbage in never becomes a force that could raise the feed: a block that cannot be
//! trusted gives an error or a sample flagged invalid ([`crate::ForceSample::INVALID`]).
//!
//! ```
//! use acc_core::spindle_force::{
//!     AdaptRule, Constants, EstimatorConfig, Method, NoLoadModel, SpindleEstimator,
//! };
//! // No-load power 600 W at 1500 rpm; tool radius 40 mm.
//! let mut nl = NoLoadModel::new(AdaptRule::default());
//! nl.learn(1500.0, 600.0, 25.0).unwrap();
//! let cfg = EstimatorConfig { method: Method::Power, tool_radius_mm: 40.0, ..Default::default() };
//! let mut est = SpindleEstimator::new(cfg, Constants::default(), nl).unwrap();
//! // 600 W + 1 kW of cutting: F = 1000 / (ω·r) = 1000 / (157.08 · 0.04) = 159.15 N (eq. 14).
//! let e = est.estimate(1500.0, Some(1600.0), Some(26.0)).unwrap();
//! assert!((e.force_n - 159.15).abs() < 0.01);
//! ```

pub mod constants;
pub mod estimate;
pub mod noload;
pub mod power;
pub mod source;

pub use constants::{Constants, CurrentConstant, MotorCharacteristic, PowerEfficiency};
pub use estimate::{Estimate, EstimatorConfig, Invalid, Method, NoLoadMode, SpindleEstimator};
pub use noload::{AdaptOutcome, AdaptRule, NoLoadModel, NoLoadPoint};
pub use power::{block_stats, BlockStats, PhaseSamples};
pub use source::{SpindleInput, SpindleSource};

use crate::RangeError;

/// Errors of the spindle signal processing and of fitting its constants.
#[derive(Debug, Clone, PartialEq)]
pub enum SpindleError {
    /// The four channels of a block have different lengths.
    LengthMismatch {
        /// Samples in `i_u`.
        i_u: usize,
        /// Samples in `i_v`.
        i_v: usize,
        /// Samples in `v_uw`.
        v_uw: usize,
        /// Samples in `v_vw`.
        v_vw: usize,
    },
    /// A block without samples.
    EmptyBlock,
    /// A NaN or infinite sample.
    NonFinite {
        /// Channel name (`i_u`, `i_v`, `v_uw`, `v_vw`).
        channel: &'static str,
        /// Sample index within the block.
        index: usize,
    },
    /// Finite samples whose products overflow.
    Overflow,
    /// A no-load point with a non-positive speed or non-finite values.
    BadNoLoadPoint {
        /// Speed of the point, rpm.
        rpm: f64,
    },
    /// The no-load table is full.
    TooManySpeeds {
        /// Capacity.
        max: usize,
    },
    /// A calibration fit failed, or the calibration lacks the method's constants.
    Fit {
        /// Method being fitted.
        method: &'static str,
        /// What is wrong (too few points, degenerate data, non-physical result).
        reason: String,
    },
    /// The estimator's method needs a signal the chosen input does not carry (the board
    /// reports spindle power only, no phase currents).
    InputLacksSignal {
        /// The input (`board-power`).
        input: &'static str,
        /// The estimator method that needs the missing signal.
        method: &'static str,
    },
    /// A parameter outside its allowed range (the key as in the configuration).
    OutOfRange(RangeError),
}

impl std::fmt::Display for SpindleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SpindleError::LengthMismatch {
                i_u,
                i_v,
                v_uw,
                v_vw,
            } => write!(
                f,
                "channel lengths differ: i_u {i_u}, i_v {i_v}, v_uw {v_uw}, v_vw {v_vw} samples"
            ),
            SpindleError::EmptyBlock => write!(f, "empty block: no samples"),
            SpindleError::NonFinite { channel, index } => {
                write!(f, "non-finite sample in channel {channel} at index {index}")
            }
            SpindleError::Overflow => write!(f, "sample values overflow the power sums"),
            SpindleError::BadNoLoadPoint { rpm } => write!(
                f,
                "invalid no-load point at {rpm} rpm (speed must be > 0, power finite, \
                 current >= 0)"
            ),
            SpindleError::TooManySpeeds { max } => {
                write!(f, "no-load model holds at most {max} speeds")
            }
            SpindleError::Fit { method, reason } => {
                write!(f, "calibration of {method}: {reason}")
            }
            SpindleError::InputLacksSignal { input, method } => write!(
                f,
                "input `{input}` carries spindle power only; method `{method}` needs phase \
                 currents: use method `power` or `power-efficiency`"
            ),
            SpindleError::OutOfRange(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SpindleError {}
