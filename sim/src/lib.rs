//! `acc-sim`: the simulated machine.
//!
//! The embedded default machine of `acc`: workpieces along the tool path
//! ([`workpiece`]), the mean-force and tooth-level cutting process with tool wear
//! ([`process`]), the feed drive and override path ([`machine`]), the PMC interface board
//! ([`board`], the PMC crate's `BoardLogic` behind the `Pmc` trait), measurement channels
//! ([`channel`], `ForceSource`s), comparison baselines ([`baselines`]), scenario files
//! ([`scenario`]), the closed loop ([`run`]), the run log ([`runlog`], shared with the real
//! runtime) and summaries ([`summary`]).
//!
//! Everything runs on the machine's own manual clock and a seeded RNG: the same scenario
//! and seed give a byte-identical run log, many times faster than real time.
//!
//! Background: `../shared/docs/physics.md` §1 (seed 002) and §3 (seed 004).
#![deny(missing_docs)]

pub mod baselines;
pub mod board;
pub mod channel;
pub mod config;
pub mod machine;
pub mod motor;
pub mod process;
pub mod run;
pub mod runlog;
pub mod scenario;
pub mod summary;
pub mod workpiece;

pub use board::SimBoard;
pub use machine::{ForceModel, Machine, PeriodRecord};
pub use run::{run, RunResult};
pub use scenario::{LawKind, Scenario};
pub use summary::{summarize, Summary};
pub use workpiece::Workpiece;

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A configuration file is invalid.
    #[error(transparent)]
    Config(#[from] acc_config::ConfigError),
    /// The controller refused its parameters.
    #[error("controller: {0:?}")]
    Core(acc_core::CoreError),
    /// The simulated board answered with a Modbus exception.
    #[error("board: {0}")]
    Board(#[from] acc_pmc::board::Exception),
    /// The measurement channel could not be built (e.g. its calibration cut failed).
    #[error("measurement channel: {0}")]
    Channel(String),
    /// Writing the run log failed.
    #[error(transparent)]
    Log(#[from] runlog::RunLogError),
}

impl From<acc_core::CoreError> for SimError {
    fn from(e: acc_core::CoreError) -> Self {
        SimError::Core(e)
    }
}
