//! The rules by state (9–17 of the module docs), after the rules of every period
//! (`period.rs`). Active with a status: the first rule that acts ends the period
//! ([`ControlFlow::Break`]); the last one steps the law within the bounds judged here.

use std::ops::ControlFlow;

use acc_core::{FeedOverride, Measurement, OverrideLaw, OverrideSpec};
use acc_pmc::BoardStatus;

use super::operator::OperatorVerdict;
use super::period::Seen;
use super::reset::Ack;
use super::settle::SettleJudge;
use super::watchdog::{self, WatchdogVerdict};
use super::{
    delay_exceeded, log, tool_limits, AccState, Event, FaultPolicy, PolicyInput, PolicyOutput,
    Rearm, Release,
};

/// A rule acted: the period ends here.
type Acted<T = ()> = ControlFlow<(), T>;

impl FaultPolicy {
    /// 9.–17. The rules of the state the policy is in, on what the rules of every period
    /// found.
    pub(super) fn by_state<L: OverrideLaw + ?Sized>(
        &mut self,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        match (self.state, seen.status) {
            (AccState::Active, None) => self.active_without_status(out, law),
            (AccState::Active, Some(s)) => {
                let _ = self.active_with_status(s, seen, out, law);
            }
            (AccState::Idle, Some(s)) => self.idle_with_status(s, seen, out, law),
            (AccState::Latched(why), Some(s)) => self.latched_with_status(why, s, seen, out, law),
            (AccState::Idle | AccState::Latched(_), None) => {}
        }
    }

    /// Active, no status this period: release over the link budget or the power budget,
    /// else hold the last command.
    fn active_without_status<L: OverrideLaw + ?Sized>(
        &mut self,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        if self.link.over_budget(self.cfg.link_hold_periods) {
            self.release(Release::LinkLost, out, law);
        } else if self.power.over_budget(self.cfg.invalid_power_periods) {
            self.release(Release::PowerInvalid, out, law);
        } else {
            out.write_override = self.held();
        }
    }

    /// Idle with a status: a tripped watchdog latches; the switch on in a clean period
    /// arms.
    fn idle_with_status<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        if s.watchdog_tripped {
            out.events.push(Event::WatchdogTripped);
            self.let_go(Release::Watchdog, &s, out, law);
        } else if s.acc_switch && seen.clean() {
            self.arm(s, out, law);
        }
    }

    /// Latched for `why` with a status: after a link loss, the link restored mid-cut with
    /// the switch on and the knob kept re-arms at the last command; otherwise the switch
    /// off and on again in a clean period arms.
    fn latched_with_status<L: OverrideLaw + ?Sized>(
        &mut self,
        why: Release,
        s: BoardStatus,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        if why == Release::LinkLost
            && !self.operator.switch_seen_off
            && s.acc_switch
            && s.cycle_active
            && !s.override_locked
            && seen.link_fault.is_none()
            && self.operator.knob_kept(&s, self.cfg.operator_handback_pct)
            && self.last_cmd.is_some()
        {
            self.rearm(Rearm::LinkRestored, s, out, law);
        } else if self.operator.switch_cycled(&s) && seen.clean() {
            self.arm(s, out, law);
        }
    }

    /// Rules 9–17 for an active policy with a status, in order; the first that acts ends
    /// the period.
    fn active_with_status<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        self.operator_priority(&s, out, law)?;
        self.judge_watchdog(s, out, law)?;
        self.judge_restart(s, out, law)?;
        self.judge_lock(&s, out, law)?;
        self.judge_ack(&s, seen.input, out, law)?;
        let (grid, last) = self.judge_link_budget(&s, out, law)?;
        self.judge_log(seen.input, out, law)?;
        self.judge_delay(seen.input, out, law)?;
        self.judge_standstill(&s, out)?;
        self.step_law(seen, grid, last, out, law);
        ControlFlow::Continue(())
    }

    /// 9. Operator priority (`operator.rs`): the switch off releases; the knob turned down
    ///    hands the override back (on a v1 board below ACC's command it caps it).
    fn operator_priority<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        let board_clamps = self.board_clamps();
        match self.operator.judge(
            s,
            self.cfg.operator_handback_pct,
            board_clamps,
            self.last_cmd,
        ) {
            OperatorVerdict::SwitchOff => self.release(Release::SwitchOff, out, law),
            OperatorVerdict::Handback => self.release(Release::OperatorHandback, out, law),
            OperatorVerdict::Keep => return ControlFlow::Continue(()),
        }
        ControlFlow::Break(())
    }

    /// 10. The board's watchdog (`watchdog.rs`): tripped, it releases, or re-arms after a
    ///     link outage mid-cut.
    fn judge_watchdog<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        let Some(v) = watchdog::judge(&s, self.link.outage(), self.last_cmd.is_some()) else {
            return ControlFlow::Continue(());
        };
        out.events.push(Event::WatchdogTripped);
        match v {
            WatchdogVerdict::Rearm => self.rearm(Rearm::LinkRestored, s, out, law),
            WatchdogVerdict::Release => self.release(Release::Watchdog, out, law),
        }
        ControlFlow::Break(())
    }

    /// 11. The board restarted under us (`reset.rs`): re-arm mid-cut, else release.
    fn judge_restart<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        if !self.reset.restarted(&s) {
            return ControlFlow::Continue(());
        }
        if s.cycle_active {
            self.rearm(Rearm::BoardRestart, s, out, law);
        } else {
            out.fault = true;
            self.release(Release::BoardReset, out, law);
        }
        ControlFlow::Break(())
    }

    /// 12. The NC locked the override (`lock.rs`): freeze (or thaw) the law; while locked,
    ///     hold the last command.
    fn judge_lock<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        if let Some(frozen) = self.lock.judge(s.override_locked) {
            law.set_frozen(frozen);
            out.events.push(Event::Frozen(frozen));
        }
        if s.override_locked {
            out.write_override = self.held();
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    }

    /// 13. The board's confirmation of ACC (`reset.rs`) within `ack_periods`: a clean one
    ///     closes a link outage, a missing one releases.
    fn judge_ack<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        input: &PolicyInput,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        let write_ok = input.write_error.is_none();
        match self.reset.ack(s, write_ok, self.cfg.ack_periods) {
            Ack::Confirmed { clean: true } => self.link.close_outage(),
            Ack::Confirmed { clean: false } | Ack::Waiting => {}
            Ack::Missing => {
                out.fault = true;
                self.release(Release::NoBoardAck, out, law);
                return ControlFlow::Break(());
            }
        }
        ControlFlow::Continue(())
    }

    /// 14. The link and power budgets (`link.rs`, `plausibility.rs`): over either, release;
    ///     a failing link (a write error with a good read) holds the last command. Else the
    ///     board's grid and the last command (floored onto it) for the law's step.
    fn judge_link_budget<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted<(OverrideSpec, u16)> {
        if self.link.over_budget(self.cfg.link_hold_periods) {
            self.release(Release::LinkLost, out, law);
            return ControlFlow::Break(());
        }
        if self.power.over_budget(self.cfg.invalid_power_periods) {
            self.release(Release::PowerInvalid, out, law);
            return ControlFlow::Break(());
        }
        let grid = self.grid(s.override_step_pct);
        let last = self
            .held()
            .map_or_else(|| grid.floor(s.override_applied_pct).0, |c| c.0);
        if self.link.failing() {
            out.write_override = Some(FeedOverride(last));
            return ControlFlow::Break(());
        }
        ControlFlow::Continue((grid, last))
    }

    /// 15. No record, no cut (`log.rs`): the run log's writer stalled past its buffer
    ///     holds the feed and releases.
    fn judge_log<L: OverrideLaw + ?Sized>(
        &mut self,
        input: &PolicyInput,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        if log::recordable(input) {
            return ControlFlow::Continue(());
        }
        out.events.push(Event::LogStalled);
        tracing::error!("the run log's writer has stalled past its buffer: feed hold");
        out.fault = true;
        self.release(Release::LogStalled, out, law);
        ControlFlow::Break(())
    }

    /// 16. The line's delay against what the gains in use tolerate (`delay.rs`): never
    ///     drive on into an oscillation (feed hold, release).
    fn judge_delay<L: OverrideLaw + ?Sized>(
        &mut self,
        input: &PolicyInput,
        out: &mut PolicyOutput,
        law: &mut L,
    ) -> Acted {
        let Some((extra, margin)) = delay_exceeded(&input.delay, || law.delay_margin_periods())
        else {
            return ControlFlow::Continue(());
        };
        out.events.push(Event::DelayExceeded {
            extra_periods: extra,
            margin_periods: margin,
        });
        tracing::warn!(
            extra_periods = extra,
            margin_periods = margin,
            "loop delay beyond the gains' margin: feed hold"
        );
        out.fault = true;
        self.release(Release::Delay, out, law);
        ControlFlow::Break(())
    }

    /// 16b. The axes stand still (`FEED_HOLD_ACTIVE`: the NC's feed hold, a paused program,
    ///     ACC's own hold): the law is not stepped and the last command is written again
    ///     (the heartbeat goes on). Without a chip the force reads as an air cut, and a law
    ///     stepped on it would wind up to the maximum override for the moment the cut
    ///     resumes; held, the cut resumes at the command that was cutting it.
    fn judge_standstill(&mut self, s: &BoardStatus, out: &mut PolicyOutput) -> Acted {
        if !s.feed_hold_active {
            return ControlFlow::Continue(());
        }
        match self.held() {
            Some(cmd) => {
                out.write_override = Some(cmd);
                ControlFlow::Break(())
            }
            None => ControlFlow::Continue(()),
        }
    }

    /// 17. The control step on the feed the loop computed once for this period, its
    ///     command placed on `grid` within the bounds of `tool_limits.rs` (range, invalid
    ///     sample, knob, the shop layer's and the plan's limits, the caps of `settle.rs`
    ///     and `restart.rs`): one quantization.
    fn step_law<L: OverrideLaw + ?Sized>(
        &mut self,
        seen: &Seen<'_>,
        grid: OverrideSpec,
        last: u16,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        let (input, force_valid) = (seen.input, seen.force_valid);
        let m = Measurement {
            force_n: if force_valid {
                input.force.force_n
            } else {
                0.0
            },
            feed_mm_min: input.feed_mm_min,
            programmed_feed_mm_min: input.programmed_feed_mm_min,
            valid: force_valid,
        };
        let mut limits = self.shop_limits;
        let cutting =
            SettleJudge::cutting(force_valid, input.force.force_n, self.breakage.force_ref_n);
        out.settle_cap = self.settle.cap(cutting);
        out.restart_cap = self.restart.cap();
        for c in [out.settle_cap, out.restart_cap].into_iter().flatten() {
            limits.cap_pct = Some(limits.cap_pct.map_or(c, |l| l.min(c)));
        }
        let bounds =
            tool_limits::bounds(grid, force_valid, last, self.operator.knob_ceiling, limits);
        let step = law.step_within(&m, &bounds);
        self.breakage.force_ref_n = Some(step.trace.force_ref_n);
        self.last_cmd = Some(step.command.0);
        if !out.fault {
            self.settle.written(step.command.0);
        }
        self.restart.stepped(
            cutting,
            step.command.0,
            seen.status.map(|s| s.override_applied_pct),
        );
        out.write_override = Some(step.command);
        out.step = Some(step);
        out.measurement = Some(m);
    }
}
