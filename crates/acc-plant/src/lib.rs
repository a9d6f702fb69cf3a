//! `acc-plant`: the simulated machine, without a control loop.
//!
//! Workpieces along the tool path ([`workpiece`]) and the engagement the plant asks for at
//! its position ([`engagement`]: one value type, one source trait), the mean-force and
//! tooth-level cutting process with tool wear ([`process`]), the feed drive and override
//! path ([`machine`]), the induction spindle motor ([`motor`]), measurement channels
//! ([`channel`]), the PMC interface board of the simulated machine ([`board`]: the PMC
//! crate's `BoardLogic` behind the `Board` trait) and the open-loop replay of a log on the
//! same machine ([`replay`], the twin's only plant).
//!
//! The plant knows nothing of the control loop: `acc-sim` runs the production loop on it
//! through the runtime's period driver, `acc board-sim` serves its board over a pty, and
//! `acc-ident` replays logs on it. Everything runs on the machine's own time and a seeded
//! RNG: the same inputs give the same outputs, bit for bit.
//!
//! Background: `../shared/docs/physics.md` §1 (seed 002) and §3 (seed 004).
#![deny(missing_docs)]

pub mod accel;
pub mod board;
pub mod channel;
pub mod config;
pub mod engagement;
mod exact;
pub mod machine;
pub mod motor;
pub mod process;
pub mod replay;
pub mod workpiece;

pub use board::SimBoard;
pub use machine::{ForceModel, Machine, PeriodRecord};

/// The repository's `configs/` directory (for tests, benches and the CLI's fallbacks).
pub fn configs_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}
