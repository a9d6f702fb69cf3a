//! The look-ahead: the cutting plan read by the control loop (docs/plan.md). One period,
//! [`LookAhead::step`] in `state` (with its input and decision), runs these in order:
//! 1. `position`: where the tool is (the block's visit, the path the NC reports, the drift);
//! 2. `block_start`: how far the tool can be past the start of a block just reported;
//! 3. `band`: the plan's force band of the period, and a disagreement with the measurement;
//! 4. `cap`: the lowest planned override the tool meets before the next command acts;
//! 5. `entry`: whether a cut's entry lifts the cap, and when its position is the command;
//! 6. `scale`: the plan's scale (measured over planned force) of the cut and of the tool;
//! 7. `lead`: the lead's command, the highest grid position under the ceiling.
//!
//! Beside the period: `config` (the tuning), `plan` (`plan.csv` read, checked, written and
//! walked) and `plan_error` (the plan's force error of a run log, `acc plan --measured`).

mod band;
pub mod block_start;
mod cap;
mod config;
mod entry;
pub mod lead;
pub mod plan;
pub mod plan_error;
mod position;
pub mod scale;
mod state;
#[cfg(test)]
mod tests;

pub use config::LookAheadConfig;
pub use state::{Disagreement, LookAhead, LookAheadInput, LookAheadStep};
