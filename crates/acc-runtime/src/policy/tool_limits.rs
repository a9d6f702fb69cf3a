//! Tool-limits judge: *what bounds the law's command this period?* Judged before the law
//! steps, and handed to the law's one quantization step ([`acc_core::OverrideSpec::place`],
//! [`CommandBounds::place`]), which puts the command on the board's grid once:
//! 1. the configured range on the board's `OVERRIDE_STEP` (floored onto it);
//! 2. on an invalid sample, never above the last command;
//! 3. never above the operator's knob when it caps ACC (a v1 board, `operator.rs`);
//! 4. the shop layer's and the plan's [`CommandLimits`] (tool table, entry control,
//!    look-ahead cap): the floor (only while the sample is valid; ceiled onto the grid),
//!    then the cap (floored onto the grid).
//!
//! A command the limits change re-engages the law at the written value (bumpless, no
//! windup against the limit).

pub use acc_core::CommandLimits;
use acc_core::{CommandBounds, OverrideSpec};

/// The bounds on the law's command on `grid`: `valid` sample, `last` command, knob ceiling
/// `knob`, shop and plan limits `limits` (percent throughout).
pub(crate) fn bounds(
    grid: OverrideSpec,
    valid: bool,
    last: u16,
    knob: Option<u16>,
    limits: CommandLimits,
) -> CommandBounds {
    CommandBounds {
        grid,
        valid,
        hold_pct: (!valid).then_some(last),
        knob_pct: knob,
        limits,
    }
}
