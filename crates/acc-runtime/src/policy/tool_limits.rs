//! Tool-limits judge: *what may the law's command become this period?* The law's command
//! floored onto the board's grid ([`OverrideSpec::floor`], the configured range on the
//! board's `OVERRIDE_STEP`), then, in this order:
//! 1. on an invalid sample, never above the last command;
//! 2. never above the operator's knob when it caps ACC (a v1 board, `operator.rs`);
//! 3. the shop layer's [`CommandLimits`] (tool table, entry control): the floor (only while
//!    the sample is valid; ceiled onto the grid), then the cap (floored onto the grid).
//!
//! A command the limits change re-engages the law at the written value (bumpless, no
//! windup against the limit).

use acc_core::OverrideSpec;

/// Limits on the law's command set from outside the law for one period (the tool table and
/// entry control of [`crate::shop`]): applied after the board-step quantization, the cap
/// last. A command the limits change re-engages the law at the written value (bumpless,
/// no windup against the limit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommandLimits {
    /// Highest command this period, percent (floored to the board step).
    pub cap_pct: Option<u16>,
    /// Lowest command this period while the force sample is valid, percent (rounded up to
    /// the board step; never above the cap).
    pub floor_pct: Option<u16>,
}

/// The command written this period and the law's own command after the guards (before
/// the shop layer's limits), percent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Limited {
    /// The command to write, percent.
    pub(crate) cmd: u16,
    /// The law's command on the grid, after the no-raise and knob guards, percent.
    pub(crate) law_cmd: u16,
}

impl Limited {
    /// The limits changed the law's command: re-engage the law at the written value.
    pub(crate) fn changed(&self) -> bool {
        self.cmd != self.law_cmd
    }
}

/// Limit the law's command `law_pct` on `grid`: `valid` sample, `last` command, knob
/// ceiling `knob`, shop limits `limits` (percent throughout).
pub(crate) fn limit(
    grid: &OverrideSpec,
    law_pct: u16,
    valid: bool,
    last: u16,
    knob: Option<u16>,
    limits: CommandLimits,
) -> Limited {
    let mut cmd = grid.floor(law_pct).0;
    if !valid {
        cmd = cmd.min(last);
    }
    if let Some(knob) = knob {
        cmd = cmd.min(grid.floor(knob).0);
    }
    let law_cmd = cmd;
    if let Some(f) = limits.floor_pct.filter(|_| valid) {
        cmd = cmd.max(grid.ceil(f).0);
    }
    if let Some(c) = limits.cap_pct {
        cmd = cmd.min(grid.floor(c).0);
    }
    Limited { cmd, law_cmd }
}
