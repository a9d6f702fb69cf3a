//! What the judges' answers do to the board: arm, re-arm mid-cut, release, latch, feed hold,
//! and the command held through a fault. [`FaultPolicy::step`] (`period.rs`) and the rules
//! by state (`by_state.rs`) call these; none of them asks a judge.

use acc_core::{FeedOverride, OverrideLaw, OverrideSpec};
use acc_pmc::{BoardStatus, ControlBits};

use super::{AccState, Alarms, Event, FaultPolicy, PolicyOutput, Rearm, Release};

impl FaultPolicy {
    /// The `CONTROL` bits wanted on the board: from the request, the feed hold and this
    /// period's `ALARM_RESET` pulse.
    pub(super) fn control(&self) -> ControlBits {
        ControlBits {
            acc_request: self.acc_request,
            feed_hold_request: self.feed_hold,
            alarm_reset: self.alarm_reset_pulse,
        }
    }

    /// The configured command range on a board grid of `step` percent (0 = unknown: 10 %):
    /// every command of the policy is floored onto it by the override spec.
    pub(super) fn grid(&self, step: u16) -> OverrideSpec {
        let step = if step == 0 { 10 } else { step };
        OverrideSpec::range(self.cfg.min_override_pct, self.cfg.max_override_pct).on_grid(step)
    }

    /// The last command, floored to the board's step as last reported (never above it).
    pub(super) fn held(&mut self) -> Option<FeedOverride> {
        let grid = self.grid(self.board_step);
        self.last_cmd = self.last_cmd.map(|c| grid.floor(c).0.min(c));
        self.last_cmd.map(FeedOverride)
    }

    /// Request feed hold (once).
    pub(super) fn hold_feed(&mut self, out: &mut PolicyOutput) -> bool {
        if self.feed_hold {
            return false;
        }
        self.feed_hold = true;
        out.events.push(Event::FeedHold(true));
        true
    }

    /// Let go of the override for `why`: release an active policy, or latch an idle or
    /// latched one with the alarm (its switch must go off, then on again).
    pub(super) fn let_go<L: OverrideLaw + ?Sized>(
        &mut self,
        why: Release,
        s: &BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        if self.state == AccState::Active {
            self.release(why, out, law);
        } else {
            self.alarms.raise(why);
            self.state = AccState::Latched(why);
            self.operator.switch_seen_off = !s.acc_switch;
        }
    }

    /// Release an active policy for `why`: the law thawed, idle or latched (as `why` says),
    /// and a feed hold unless the operator asked it or it cannot raise the feed (see the
    /// module docs, "A fault release never raises the feed"); the alarm raised.
    pub(super) fn release(
        &mut self,
        why: Release,
        out: &mut PolicyOutput,
        law: &mut (impl OverrideLaw + ?Sized),
    ) {
        out.events.push(Event::Released(why));
        tracing::info!(reason = why.as_str(), "ACC released to the operator");
        self.acc_request = false;
        self.reset.released();
        if self.lock.thaw() {
            law.set_frozen(false);
        }
        self.state = if why.latches() {
            self.operator.switch_seen_off = false;
            AccState::Latched(why)
        } else {
            AccState::Idle
        };
        let operator = matches!(why, Release::SwitchOff | Release::OperatorHandback);
        // A v2 board clamps the applied override to min(knob, last applied) on a release.
        let raising = !self.board_clamps()
            && match (self.operator.last_knob_pct, self.last_cmd) {
                (Some(op), Some(cmd)) => op > cmd,
                _ => true,
            };
        // A release that is not the operator's while the NC cuts is a feed hold, on every
        // board: nobody else is there to take the cut (the clamp holds the override, not
        // the force). Out of the cut, only a release that would raise the feed holds.
        let hold =
            !operator && (self.cycle_active || (raising && self.cfg.hold_on_raising_release));
        if hold && self.hold_feed(out) {
            tracing::warn!(
                reason = why.as_str(),
                "feed hold: ACC let go of the cut for a reason that is not the operator's"
            );
        }
        self.alarms.raise(why);
    }

    /// Arm at the override in force (bumpless, on the board's grid): feed hold cleared,
    /// alarms cleared, `ALARM_RESET` with the request when the watchdog is tripped or the
    /// board restarted.
    pub(super) fn arm<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        let at = self
            .grid(s.override_step_pct)
            .floor(s.override_applied_pct)
            .0;
        if self.feed_hold {
            self.feed_hold = false;
            out.events.push(Event::FeedHold(false));
        }
        law.engage(FeedOverride(at));
        self.settle.clear();
        let alarm_reset = s.watchdog_tripped || s.board_restarted;
        self.alarm_reset_pulse = alarm_reset;
        self.alarms = Alarms::default();
        self.link.close_outage();
        self.reset.armed_fresh();
        self.operator.armed(&s);
        self.acc_request = true;
        self.last_cmd = Some(at);
        self.state = AccState::Active;
        out.write_override = Some(FeedOverride(at));
        out.events.push(Event::Armed {
            at_pct: at,
            alarm_reset,
        });
        tracing::info!(at_pct = at, "ACC armed");
    }

    /// Re-arm mid-cut without a period above the last command: `OVERRIDE_CMD` first (the
    /// last command; on a v1 board at most the override applied now), then `ACC_REQUEST |
    /// ALARM_RESET` (the loop writes the override before `CONTROL`).
    pub(super) fn rearm<L: OverrideLaw + ?Sized>(
        &mut self,
        why: Rearm,
        s: BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        out.fault = true;
        if self.reset.too_many_rearms(self.cfg.ack_periods) {
            return self.release(Release::BoardReset, out, law);
        }
        let applied = self
            .grid(s.override_step_pct)
            .floor(s.override_applied_pct)
            .0;
        let last = self.held().map_or(applied, |c| c.0);
        // v2: the board holds the feed (power-up feed hold, or the clamp ≤ last); v1: the
        // knob is already applied, so never go above it either.
        let at = if self.board_clamps() {
            last
        } else {
            last.min(applied)
        };
        if at != last {
            law.engage(FeedOverride(at));
        }
        if self.lock.thaw() {
            law.set_frozen(false);
        }
        if self.feed_hold && !self.alarms.overload {
            self.feed_hold = false;
            out.events.push(Event::FeedHold(false));
        }
        self.alarm_reset_pulse = true;
        self.alarms = Alarms::default();
        self.acc_request = true;
        self.reset.armed();
        self.last_cmd = Some(at);
        self.state = AccState::Active;
        out.write_override = Some(FeedOverride(at));
        out.events.push(Event::Rearmed {
            reason: why,
            at_pct: at,
        });
        tracing::warn!(
            reason = why.as_str(),
            at_pct = at,
            "ACC re-armed mid-cut at the last command (OVERRIDE_CMD first, then ACC_REQUEST | ALARM_RESET)"
        );
    }
}
