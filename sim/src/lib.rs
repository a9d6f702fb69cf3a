//! `acc-sim`: the production loop on the simulated machine.
//!
//! This crate runs `acc`'s own control loop ([`acc_runtime::ControlLoop`] on the runtime's
//! period driver) against the simulated plant of `acc-plant`: scenario files
//! ([`scenario`]), the closed loop ([`mod@run`]: one [`run`] with a [`RunSetup`], logging
//! acc-runtime's `RunRecord` with the plant's truth, [`truth`]), comparison baselines
//! ([`baselines`]), summaries ([`summary`], [`program_summary`]), what-if runs on a
//! recorded cut ([`whatif`]), NC programs on the simulated machine ([`program`]), the
//! planner of `acc plan` and the feed optimizer of `acc optimize` ([`plan`], [`optimize`]),
//! the plan follower ([`plan_follower`]) and the oracle rows ([`oracle`],
//! [`oracle_program`]).
//!
//! It re-exports the simulated machine itself from `acc-plant`, so that a user of the
//! simulator needs one crate: workpieces along the tool path ([`workpiece`]) behind the
//! plant's engagement source ([`engagement`]), the mean-force and tooth-level cutting
//! process with tool wear ([`process`]), the feed drive and override path ([`machine`]),
//! the spindle motor ([`motor`]), the PMC interface board ([`board`], the PMC crate's
//! `BoardLogic` behind the `Board` trait), measurement channels ([`channel`],
//! `ForceSource`s), the plant's configuration ([`config`]) and the open-loop replay
//! ([`replay`]).
//!
//! Everything runs on the machine's own manual clock and a seeded RNG: the same scenario
//! and seed give a byte-identical run log, many times faster than real time.
//!
//! Background: `../shared/docs/physics.md` §1 (seed 002) and §3 (seed 004).
//!
//! ```
//! use acc_sim::{run::configs_dir, LawKind, Scenario};
//! // The paper's case III on the 2-3-4 mm steps, with the adaptive controller.
//! let sc = Scenario::load(configs_dir().join("scenarios/paper_case3.toml")).unwrap();
//! let (result, summary) = sc.run_law(LawKind::Ours).unwrap();
//! assert!(result.finished);
//! // Every cutting segment settles to Fr = 800 N within ±5 %.
//! for seg in summary.segments.iter().filter(|s| s.is_cut) {
//!     assert!((seg.mean_force_n - 800.0).abs() < 40.0);
//! }
//! // One run-log row per 0.1 s period.
//! assert!((result.rows[9].t_s - 1.0).abs() < 1e-9);
//! ```
#![deny(missing_docs)]

pub use acc_plant::{
    accel, board, channel, config, engagement, machine, motor, process, replay, workpiece,
};

pub mod baselines;
pub mod optimize;
pub mod oracle;
pub mod oracle_program;
pub mod plan;
pub mod plan_follower;
pub mod program;
pub mod program_summary;
pub mod program_visits;
pub mod run;
pub mod scenario;
pub mod summary;
pub mod truth;
pub mod whatif;

pub use board::SimBoard;
pub use machine::{ForceModel, Machine, PeriodRecord};
pub use run::{run, Pace, RunLog, RunResult, RunSetup, ShopLayer};
pub use scenario::{LawKind, Scenario};
pub use summary::{summarize, Summary};
pub use workpiece::Workpiece;

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// An NC program, its tool table or its stock is invalid (the message names the file,
    /// line and column, or the key and its range).
    #[error("{0}")]
    Program(String),
    /// A configuration file is invalid.
    #[error(transparent)]
    Config(#[from] acc_config::ConfigError),
    /// The controller refused its parameters.
    #[error("controller: {0}")]
    Core(acc_core::CoreError),
    /// The simulated board answered with a Modbus exception.
    #[error("board: {0}")]
    Board(#[from] acc_pmc::emu::Exception),
    /// The measurement channel could not be built (e.g. its calibration cut failed).
    #[error("measurement channel: {0}")]
    Channel(String),
    /// Writing the run log failed.
    #[error(transparent)]
    Log(#[from] acc_runtime::record::RunLogError),
    /// The run log's writer failed during the run (the first error).
    #[error("writing the run log: {0}")]
    LogWrite(String),
    /// The period driver could not run.
    #[error("the period driver: {0}")]
    Driver(#[from] acc_runtime::RunError),
    /// A paced run's time scale is not a finite number > 0.
    #[error("time scale {0}: expected a finite number > 0 (machine seconds per wall second)")]
    TimeScale(f64),
}

impl From<acc_core::CoreError> for SimError {
    fn from(e: acc_core::CoreError) -> Self {
        SimError::Core(e)
    }
}
