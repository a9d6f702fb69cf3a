//! Watchdog judge: *did the board's watchdog trip, and may ACC take the cut back over it?*
//! A trip releases and latches (re-arming writes `ALARM_RESET`), except a trip that
//! followed a link outage (the heartbeat could not get through) while the cut is still on,
//! the override not locked and a command known: that re-arms at the last command, as a
//! restored link does.

use acc_pmc::BoardStatus;

/// What a tripped watchdog asks of an active policy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum WatchdogVerdict {
    /// Re-arm at the last command ([`super::Rearm::LinkRestored`]).
    Rearm,
    /// Release, latched ([`super::Release::Watchdog`]).
    Release,
}

/// Judge `WATCHDOG_TRIPPED` of an active policy. `outage`: link failures since ACC was
/// last confirmed; `has_command`: a last command is known. `None`: not tripped.
pub(crate) fn judge(s: &BoardStatus, outage: bool, has_command: bool) -> Option<WatchdogVerdict> {
    if !s.watchdog_tripped {
        return None;
    }
    Some(
        if outage && s.cycle_active && !s.override_locked && has_command {
            WatchdogVerdict::Rearm
        } else {
            WatchdogVerdict::Release
        },
    )
}
