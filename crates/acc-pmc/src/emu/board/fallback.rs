//! `ACC_ACTIVE` and what happens when it falls: the watchdog, the fallback clamp (v2) and
//! the board's own feed holds, with the override the machine obeys.

use super::BoardLogic;
use crate::regs::{FallbackMode, FALLBACK_NONE_PCT};

impl BoardLogic {
    /// Re-evaluate `ACC_ACTIVE` after a state change: a fall engages the clamp (v2, in a
    /// cycle) unless the operator's switch is off or the override is locked; a rise ends it.
    pub(super) fn update_active(&mut self) {
        let active = self.acc_active();
        if active {
            self.clamp_pct = None;
        } else if self.was_active
            && self.protocol.is_v2()
            && self.cycle_active
            && self.acc_switch
            && !self.override_locked
        {
            // ACC was active until this change, so the applied override was the command.
            self.clamp_pct = Some(self.override_cmd_pct);
        }
        self.was_active = active;
    }

    /// Advance the watchdog to `now_ms`: trips when `ACC_REQUEST` is set and `HEARTBEAT` has
    /// not changed for `WATCHDOG_MS` (spec, "Board behaviour"). A trip engages the clamp and,
    /// with `FALLBACK_MODE` = 1, the feed hold (v2). Call it at least once per millisecond of
    /// interest; [`BoardLogic::handle`] calls it before every request.
    pub fn tick(&mut self, now_ms: u64) {
        if !self.acc_request || self.watchdog_tripped {
            return;
        }
        let since = *self.watchdog_since_ms.get_or_insert(now_ms);
        if now_ms.saturating_sub(since) >= u64::from(self.watchdog_ms) {
            self.watchdog_tripped = true;
            if self.protocol.is_v2() && self.fallback_mode == FallbackMode::ClampAndFeedHold {
                self.watchdog_feed_hold = true;
            }
            self.update_active();
        }
    }

    /// `ACC_ACTIVE` = `ACC_SWITCH` ∧ `ACC_REQUEST` ∧ ¬`WATCHDOG_TRIPPED` ∧ ¬`OVERRIDE_LOCKED`.
    pub fn acc_active(&self) -> bool {
        self.acc_switch && self.acc_request && !self.watchdog_tripped && !self.override_locked
    }

    /// `OVERRIDE_APPLIED`, percent: `OVERRIDE_CMD` while `ACC_ACTIVE`; otherwise the
    /// operator's switch, limited by the fallback clamp when it is engaged (v2:
    /// `min(OPERATOR_OVERRIDE, FALLBACK_OVERRIDE)`). This is what the machine's feed drive
    /// should obey (the NC itself forces 100 % while `OVERRIDE_LOCKED`; that is the
    /// machine's business, not the board's).
    pub fn override_applied_pct(&self) -> u16 {
        if self.acc_active() {
            self.override_cmd_pct
        } else {
            match self.clamp_pct {
                Some(clamp) => self.operator_override_pct.min(clamp),
                None => self.operator_override_pct,
            }
        }
    }

    /// `FALLBACK_OVERRIDE` (v2), percent: the clamp when engaged, else 150.
    pub fn fallback_override_pct(&self) -> u16 {
        self.clamp_pct.unwrap_or(FALLBACK_NONE_PCT)
    }

    /// `FALLBACK_ACTIVE` (v2): the clamp is engaged.
    pub fn fallback_active(&self) -> bool {
        self.clamp_pct.is_some()
    }

    /// `FALLBACK_MODE` (v2) as last written.
    pub fn fallback_mode(&self) -> FallbackMode {
        self.fallback_mode
    }

    /// `BOARD_RESTARTED` (v2): set by [`BoardLogic::power_cycle`], cleared by `ALARM_RESET`.
    pub fn board_restarted(&self) -> bool {
        self.board_restarted
    }

    /// `FEED_HOLD_ACTIVE`: the controller's `FEED_HOLD_REQUEST`, the operator's feed hold,
    /// or (v2) the board's own feed hold after a watchdog trip with `FALLBACK_MODE` = 1 or a
    /// power-up in a cycle (both until `ALARM_RESET`).
    pub fn feed_hold_active(&self) -> bool {
        self.feed_hold_request
            || self.operator_feed_hold
            || self.watchdog_feed_hold
            || self.restart_feed_hold
    }
}
