//! `acc-spindle`: the cutting force from the spindle drive's own signals.
//!
//! Seed 000 (physics.md §2) estimates the tangential cutting force of a milling cutter from
//! the induction spindle motor, three ways; seed 004 (§3) adds the feed drive current for
//! the fast part. This crate implements them as pure signal processing:
//!
//! * [`power`]: Blondel two-wattmeter power, RMS current and voltage, power factor of one
//!   block of samples — one pass, no allocation;
//! * [`noload`]: the no-load (air-cut) power and current as a function of speed, learned
//!   from air cuts and adapted while running under a documented rule;
//! * [`estimate`]: the force estimators (power, power with load-dependent efficiency,
//!   conventional current, current with motor characteristics) and their validity checks;
//! * [`calibrate`]: fitting each method's constants from a calibration cut with a reference
//!   force; saving and loading them as TOML;
//! * [`fusion`]: spindle + feed-drive current fusion (seed 004);
//! * [`source`] and [`stream`]: the [`acc_core::ForceSource`] implementations the loop
//!   uses (three-phase blocks, the board's power register, a recorded sample stream);
//! * [`datasets`] and [`eval`]: readers of the two public data sets and the error metrics
//!   used by `acc estimate-eval` (the only file I/O besides [`stream`]).
//!
//! Garbage in never becomes a force that could raise the feed: a block that cannot be
//! trusted gives an error or a sample flagged invalid ([`acc_core::ForceSample::INVALID`]).
//!
//! ```
//! use acc_spindle::estimate::{EstimatorConfig, Method, SpindleEstimator};
//! use acc_spindle::noload::{AdaptRule, NoLoadModel};
//! use acc_spindle::calibrate::Constants;
//! // No-load power 600 W at 1500 rpm; tool radius 40 mm.
//! let mut nl = NoLoadModel::new(AdaptRule::default());
//! nl.learn(1500.0, 600.0, 25.0).unwrap();
//! let cfg = EstimatorConfig { method: Method::Power, tool_radius_mm: 40.0, ..Default::default() };
//! let mut est = SpindleEstimator::new(cfg, Constants::default(), nl).unwrap();
//! // 600 W + 1 kW of cutting: F = 1000 / (ω·r) = 1000 / (157.08 · 0.04) = 159.15 N (eq. 14).
//! let e = est.estimate(1500.0, Some(1600.0), Some(26.0)).unwrap();
//! assert!((e.force_n - 159.15).abs() < 0.01);
//! ```

#![cfg_attr(test, allow(clippy::unwrap_used))]
#![deny(missing_docs)]

pub mod calibrate;
pub mod datasets;
pub mod estimate;
pub mod eval;
pub mod fusion;
pub mod noload;
pub mod power;
pub mod source;
pub mod stream;

pub use calibrate::{CalPoint, Constants, SpindleCalibration};
pub use estimate::{Estimate, EstimatorConfig, Invalid, Method, NoLoadMode, SpindleEstimator};
pub use noload::{AdaptRule, NoLoadModel, NoLoadPoint};
pub use power::{block_stats, BlockStats, PhaseSamples};
pub use source::{SpindleInput, SpindleSource};
pub use stream::{SampleFormat, SampleStream, StreamError, StreamForceSource};

/// Errors of the spindle signal processing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpindleError {
    /// The four channels of a block have different lengths.
    #[error("channel lengths differ: i_u {i_u}, i_v {i_v}, v_uw {v_uw}, v_vw {v_vw} samples")]
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
    #[error("empty block: no samples")]
    EmptyBlock,
    /// A NaN or infinite sample.
    #[error("non-finite sample in channel {channel} at index {index}")]
    NonFinite {
        /// Channel name (`i_u`, `i_v`, `v_uw`, `v_vw`).
        channel: &'static str,
        /// Sample index within the block.
        index: usize,
    },
    /// Finite samples whose products overflow.
    #[error("sample values overflow the power sums")]
    Overflow,
    /// A no-load point with a non-positive speed or non-finite values.
    #[error("invalid no-load point at {rpm} rpm (speed must be > 0, power finite, current >= 0)")]
    BadNoLoadPoint {
        /// Speed of the point, rpm.
        rpm: f64,
    },
    /// The no-load table is full.
    #[error("no-load model holds at most {max} speeds")]
    TooManySpeeds {
        /// Capacity.
        max: usize,
    },
    /// A calibration fit failed.
    #[error("calibration of {method}: {reason}")]
    Fit {
        /// Method being fitted.
        method: &'static str,
        /// What is wrong (too few points, degenerate data, non-physical result).
        reason: String,
    },
    /// The estimator's method needs a signal the chosen input does not carry (the board
    /// reports spindle power only, no phase currents).
    #[error(
        "input `{input}` carries spindle power only; method `{method}` needs phase currents: \
         use method `power` or `power-efficiency`"
    )]
    InputLacksSignal {
        /// The input (`board-power`).
        input: &'static str,
        /// The estimator method that needs the missing signal.
        method: &'static str,
    },
    /// A parameter outside its allowed range (the key as in the configuration).
    #[error("{0}")]
    OutOfRange(acc_core::RangeError),
}
