//! Plausibility judge: *is this period's sample usable?* The line guard's verdict
//! ([`crate::guard`]) and the power's: a read the guard held (unconfirmed or implausible) is
//! no status at all, and the force sample is valid only when the status was accepted, the
//! sensor is not stale, the force source says valid, and the force and the power (the
//! source's and the board's raw register) are finite, non-negative and within
//! `max_power_w`. An invalid sample never raises the command; more than
//! `invalid_power_periods` in a row release ([`super::Release::PowerInvalid`]).
//!
//! An invalid sample while the spindle is off ([`spindle_off`]: no speed and no power, an
//! `M5` before a tool change, at a program's end, an abort) is no sensor fault: no chip can
//! be cut, there is nothing to estimate. It is not used (the command is held) and does not
//! count against the budget: the count neither grows nor restarts. Without this a program's
//! `M5` released ACC (latched) and the program after it ran uncontrolled (found on
//! LinuxCNC: an abort, then the same program again: 3.4 Fr at the heavy slot's re-entry).

use acc_core::ForceSample;
use acc_pmc::BoardStatus;

use super::{Event, PolicyInput};

/// The status the rules may read this period: `None` after a link error or when the line
/// guard held the read (nothing is concluded from the last accepted status: it is stale).
pub(crate) fn accepted(input: &PolicyInput) -> Option<BoardStatus> {
    input.link.ok().filter(|_| !input.held)
}

/// Whether the force sample `f` of this period is valid (see the module docs).
pub(crate) fn force_valid(
    status: Option<&BoardStatus>,
    stale: bool,
    f: &ForceSample,
    max_power_w: f64,
) -> bool {
    let power_ok = f
        .power_w
        .is_none_or(|p| p.is_finite() && p >= 0.0 && p <= max_power_w);
    let board_power_ok = status.is_none_or(|s| f64::from(s.spindle_power_w) <= max_power_w);
    status.is_some()
        && board_power_ok
        && !stale
        && f.valid
        && f.force_n.is_finite()
        && f.force_n >= 0.0
        && power_ok
}

/// The spindle is off: the status reports no speed (`SPINDLE_RPM` 0) and no more than 1 % of
/// `max_power_w` on the power register (a de-energized motor; a stalled one under load still
/// draws power and counts as invalid power as before).
pub(crate) fn spindle_off(s: &BoardStatus, max_power_w: f64) -> bool {
    s.spindle_rpm == 0 && f64::from(s.spindle_power_w) <= 0.01 * max_power_w
}

/// Consecutive invalid samples.
#[derive(Debug, Clone, Default)]
pub(crate) struct PowerJudge {
    invalid: u32,
}

impl PowerJudge {
    /// Count a judged sample (a status was read, accepted or held): the
    /// [`Event::PowerInvalid`] of an invalid one.
    pub(crate) fn count(&mut self, valid: bool, stale: bool) -> Option<Event> {
        if valid {
            self.invalid = 0;
            return None;
        }
        self.invalid = self.invalid.saturating_add(1);
        Some(Event::PowerInvalid {
            stale,
            consecutive: self.invalid,
        })
    }

    /// More invalid samples in a row than `budget_periods`: release.
    pub(crate) fn over_budget(&self, budget_periods: u32) -> bool {
        self.invalid > budget_periods
    }
}
