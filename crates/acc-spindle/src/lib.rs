//! `acc-spindle`: the spindle work that is not done every control period.
//!
//! The per-period force estimate — block power, the no-load model, the four estimators of
//! seed 000 and the [`acc_core::ForceSource`] over them — is
//! [`acc_core::spindle_force`]. This crate holds what feeds it from outside the loop:
//!
//! * [`calibrate`]: fitting each method's constants from a calibration cut with a reference
//!   force (least squares); saving and loading them, with the no-load model, as TOML;
//! * [`stream`]: a recorded or piped DAQ sample stream as a force source (file I/O, then
//!   [`acc_core::spindle_force::SpindleSource`] per period);
//! * [`fusion`]: spindle + feed-drive current fusion (seed 004);
//! * [`datasets`], [`eval`] and [`turning`]: readers of the two public data sets, the error
//!   metrics and the force models validated on real turning data by `acc estimate-eval`.
//!
//! ```
//! use acc_core::spindle_force::{AdaptRule, EstimatorConfig, Method, NoLoadModel};
//! use acc_spindle::calibrate::{calibrate, CalPoint, SpindleCalibration};
//! // A motor whose extra input power is 1.05 × the cutting power, at 1100 rpm, r = 40 mm.
//! let mut nl = NoLoadModel::new(AdaptRule::default());
//! nl.learn(1100.0, 500.0, 20.0).unwrap();
//! let omega = 2.0 * std::f64::consts::PI * 1100.0 / 60.0;
//! let cut: Vec<CalPoint> = [50.0, 100.0, 150.0, 200.0]
//!     .iter()
//!     .map(|&f| CalPoint {
//!         rpm: 1100.0,
//!         power_w: 500.0 + 1.05 * f * 0.04 * omega,
//!         current_a: 20.0 + 0.01 * f,
//!         force_ref_n: f,
//!     })
//!     .collect();
//! let constants = calibrate(&cut, &nl, 40.0).unwrap();
//! assert!((constants.power_efficiency.unwrap().gain - 1.05).abs() < 1e-9);
//! // The calibration file's content gives the loop's estimator.
//! let cal = SpindleCalibration::new("doc", 40.0, &nl, constants);
//! let cfg = EstimatorConfig { method: Method::PowerEfficiency, ..Default::default() };
//! let mut est = cal.estimator(cfg).unwrap();
//! let e = est.estimate(1100.0, Some(500.0 + 1.05 * 120.0 * 0.04 * omega), None).unwrap();
//! assert!((e.force_n - 120.0).abs() < 1e-6);
//! ```

#![cfg_attr(test, allow(clippy::unwrap_used))]
#![deny(missing_docs)]

pub mod calibrate;
pub mod datasets;
pub mod eval;
pub mod fusion;
pub mod stream;
pub mod turning;

pub use calibrate::{CalPoint, SpindleCalibration};
pub use stream::{SampleFormat, SampleStream, StreamError, StreamForceSource};
