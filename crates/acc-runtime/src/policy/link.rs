//! Link judge: *has the link failed for longer than ACC may hold the override?*
//!
//! Read errors and the previous period's write errors (timeout, CRC, exception, protocol,
//! disconnected) count alike. While the count is within `link_hold_periods` the policy
//! holds the last command; beyond it, it releases ([`super::Release::LinkLost`]). A failure
//! while ACC is not idle opens an *outage*, which lets a watchdog trip that follows it (the
//! heartbeat could not get through) re-arm instead of latching.

use acc_pmc::BoardErrorKind;

use super::Event;

/// Consecutive link failures and the open outage.
#[derive(Debug, Clone, Default)]
pub(crate) struct LinkJudge {
    /// Consecutive periods with a read or write error.
    failures: u32,
    /// Link failures since ACC was last seen confirmed on a clean period.
    outage: bool,
}

impl LinkJudge {
    /// Count this period's read or write error (`fault`); `driving`: ACC is not idle. The
    /// [`Event::LinkError`] of a failing period.
    pub(crate) fn observe(
        &mut self,
        fault: Option<BoardErrorKind>,
        driving: bool,
    ) -> Option<Event> {
        let Some(kind) = fault else {
            self.failures = 0;
            return None;
        };
        self.failures = self.failures.saturating_add(1);
        if driving {
            self.outage = true;
        }
        Some(Event::LinkError {
            kind,
            consecutive: self.failures,
        })
    }

    /// The link failed this period (hold the last command).
    pub(crate) fn failing(&self) -> bool {
        self.failures > 0
    }

    /// More consecutive failures than `hold_periods`: release.
    pub(crate) fn over_budget(&self, hold_periods: u32) -> bool {
        self.failures > hold_periods
    }

    /// An outage is open (failures since ACC was last confirmed on a clean period).
    pub(crate) fn outage(&self) -> bool {
        self.outage
    }

    /// ACC confirmed on a clean period, or armed afresh: the outage is over.
    pub(crate) fn close_outage(&mut self) {
        self.outage = false;
    }
}
