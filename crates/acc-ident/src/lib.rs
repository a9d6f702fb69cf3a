//! `acc-ident`: the model-discrepancy workflow — find where the simulated
//! machine and a measured run log disagree, name the missing effect, add it to the model
//! and show the gap shrink on a sealed part of the log.
//!
//! Pipeline ([`workflow::analyse`]): read a run log ([`runlog`]; a production log from
//! `acc run` with its engagement rebuilt from the workpiece, [`engagement`]; or an importer
//! in [`import`]) → replay the model open loop on the recorded inputs ([`replay`]) →
//! residuals, noise (AR(1)), regimes and correlations ([`segment`], [`stats`]) → fit each
//! candidate effect ([`effects`]) jointly with the nominal parameters it can be confused
//! with ([`fit`], Levenberg–Marquardt) → select by contiguous-fold held-out prediction →
//! sealed-part comparison → [`report::Report`] and an updated model file ([`model`]), whose
//! cutting-force law the planner reads ([`cutting`]).
//!
//! ```
//! use acc_ident::{synth, workflow};
//! // A log from the paper machine with no hidden effect: nothing may be named.
//! let case = synth::Case { duration_s: 120.0, ..synth::Case::default() };
//! let (model, log, _truth) = synth::generate(&case, &[], 1);
//! let a = workflow::analyse(&model, &log, &workflow::Options::default()).unwrap();
//! assert!(a.report.accepted.is_empty());
//! ```

pub mod cutting;
pub mod dead;
pub mod effects;
pub mod engagement;
pub mod fit;
pub mod import;
pub mod model;
pub mod physics;
pub mod replay;
pub mod report;
mod report_model_error;
mod report_verdict;
pub mod runlog;
pub mod segment;
pub mod stats;
pub mod synth;
pub mod testcut;
pub mod twin;
pub mod workflow;

pub use effects::EffectKind;
pub use model::Model;
pub use report::Report;
pub use runlog::RunLog;
pub use workflow::{analyse, Analysis, Options};
