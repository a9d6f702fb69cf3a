//! Plausibility judge: *is this period's sample usable?* The line guard's verdict
//! ([`crate::guard`]) and the power's: a read the guard held (unconfirmed or implausible) is
//! no status at all, and the force sample is valid only when the status was accepted, the
//! sensor is not stale, the force source says valid, and the force and the power (the
//! source's and the board's raw register) are finite, non-negative and within
//! `max_power_w`. An invalid sample never raises the command; more than
//! `invalid_power_periods` in a row release ([`super::Release::PowerInvalid`]).

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
