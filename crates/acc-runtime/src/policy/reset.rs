//! Board-reset judge: *does the board confirm ACC, or did it restart under us?*
//! - A board that dropped `ACC_ACTIVE` after confirming it (v2: `BOARD_RESTARTED`; v1:
//!   `ACC_ACTIVE` dropped with no watchdog, lock or switch to explain it) restarted: mid-cut
//!   the policy re-arms at the last command ([`super::Rearm::BoardRestart`]), out of the
//!   cut it releases ([`super::Release::BoardReset`]).
//! - A board that never confirms `ACC_ACTIVE` within `ack_periods` after arming is
//!   released ([`super::Release::NoBoardAck`]).
//! - A board that keeps restarting (more than `ack_periods` re-arms without a clean
//!   confirmation) is released ([`super::Release::BoardReset`]).

use acc_pmc::BoardStatus;

/// What the board's `ACC_ACTIVE` says this period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ack {
    /// Confirmed; `clean`: no restart flag and no write error (re-arms and the outage are
    /// over).
    Confirmed {
        /// A clean confirmation.
        clean: bool,
    },
    /// Not confirmed yet, within `ack_periods`.
    Waiting,
    /// Not confirmed within `ack_periods`: release.
    Missing,
}

/// The board's confirmation of ACC and the re-arms without one.
#[derive(Debug, Clone, Default)]
pub(crate) struct ResetJudge {
    /// The board confirmed `ACC_ACTIVE` since the last (re-)arm.
    confirmed: bool,
    /// Periods since the last (re-)arm without a confirmation.
    arm_age: u32,
    /// Consecutive re-arms without a clean confirmation.
    rearms: u32,
}

impl ResetJudge {
    /// ACC (re-)armed: wait for the board's confirmation again.
    pub(crate) fn armed(&mut self) {
        self.confirmed = false;
        self.arm_age = 0;
    }

    /// ACC armed by the operator: the count of re-arms starts again.
    pub(crate) fn armed_fresh(&mut self) {
        self.armed();
        self.rearms = 0;
    }

    /// ACC released.
    pub(crate) fn released(&mut self) {
        self.confirmed = false;
    }

    /// Count a re-arm; `true` when there have been more than `ack_periods` without a clean
    /// confirmation (release instead).
    pub(crate) fn too_many_rearms(&mut self, ack_periods: u32) -> bool {
        self.rearms = self.rearms.saturating_add(1);
        self.rearms > ack_periods
    }

    /// The board restarted under an active ACC that it had confirmed.
    pub(crate) fn restarted(&self, s: &BoardStatus) -> bool {
        self.confirmed && (s.board_restarted || (!s.acc_active && !s.override_locked))
    }

    /// Judge `ACC_ACTIVE` of an active, unlocked policy (`write_ok`: last period's writes
    /// went through).
    pub(crate) fn ack(&mut self, s: &BoardStatus, write_ok: bool, ack_periods: u32) -> Ack {
        if s.acc_active {
            self.confirmed = true;
            let clean = !s.board_restarted && write_ok;
            if clean {
                self.rearms = 0;
            }
            return Ack::Confirmed { clean };
        }
        self.arm_age = self.arm_age.saturating_add(1);
        if self.arm_age > ack_periods {
            Ack::Missing
        } else {
            Ack::Waiting
        }
    }
}
