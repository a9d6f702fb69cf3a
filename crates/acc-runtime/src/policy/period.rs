//! One period of the fault policy: [`FaultPolicy::step`] asks the rules in the order of the
//! module docs. The rules of every period (1–8) are here; the rules by state (9–17) are in
//! `by_state.rs`; what an answer does to the board is in `actions.rs`.

use acc_core::OverrideLaw;
use acc_pmc::{BoardErrorKind, BoardProtocol, BoardStatus};

use super::overload::OverloadVerdict;
use super::{
    log, plausibility, AccState, Event, Events, FaultPolicy, PolicyInput, PolicyOutput, Release,
};

/// What the rules of every period (1–8) found, for the rules by state (9–17).
#[derive(Debug, Clone, Copy)]
pub(super) struct Seen<'a> {
    /// The period's input.
    pub input: &'a PolicyInput,
    /// The status the rules may read: `None` after a link error or when the line guard held
    /// the read.
    pub status: Option<BoardStatus>,
    /// This period's read error, else the previous period's write error.
    pub link_fault: Option<BoardErrorKind>,
    /// The force sample is valid this period.
    pub force_valid: bool,
}

impl Seen<'_> {
    /// A clean period, which arming needs: the link answered, the force is valid, the run
    /// log's writer is not stalled, the override is not locked.
    pub(super) fn clean(&self) -> bool {
        self.link_fault.is_none()
            && self.force_valid
            && log::recordable(self.input)
            && self.status.is_some_and(|s| !s.override_locked)
    }

    /// A fault of the line or the board this period (link, held read, tripped watchdog,
    /// locked override): the settle judge starts its periods again.
    fn line_or_board_fault(&self) -> bool {
        self.link_fault.is_some()
            || self.input.held
            || self
                .status
                .is_some_and(|s| s.watchdog_tripped || s.override_locked)
    }
}

impl FaultPolicy {
    /// Advance one period: ask the judges in the order of the module docs and act on their
    /// answers. `law` is the controller (stepped only while active and unlocked).
    pub fn step<L: OverrideLaw + ?Sized>(
        &mut self,
        input: &PolicyInput,
        law: &mut L,
    ) -> PolicyOutput {
        let mut out = self.begin_period();
        let link_fault = self.judge_link(input, &mut out);
        let status = self.accept_status(input);
        let stale = self.judge_staleness(status.as_ref(), &mut out);
        let force_valid = self.judge_force(input, status.as_ref(), stale, &mut out);
        self.drain.observe(input);
        let seen = Seen {
            input,
            status,
            link_fault,
            force_valid,
        };
        if let Some(s) = status {
            self.observe_board(&s, &mut out);
            self.judge_overload(&s, &seen, &mut out, law);
            self.judge_breakage(&s, &seen, &mut out, law);
        }
        self.settle.observe(seen.line_or_board_fault());
        self.by_state(&seen, &mut out, law);
        self.end_period(out)
    }

    /// The period's output before any rule: nothing to write, the state and `CONTROL` bits
    /// in force (this period's `ALARM_RESET` pulse cleared).
    fn begin_period(&mut self) -> PolicyOutput {
        self.alarm_reset_pulse = false;
        PolicyOutput {
            state: self.state,
            write_override: None,
            control: self.control(),
            alarms: self.alarms,
            events: Events::default(),
            step: None,
            measurement: None,
            force_valid: false,
            fault: false,
            sample_advance: None,
            settle_cap: None,
            restart_cap: None,
        }
    }

    /// 1. Link (`link.rs`): this period's read error, else the previous period's write
    ///    error, counted against the link budget; returns it.
    fn judge_link(
        &mut self,
        input: &PolicyInput,
        out: &mut PolicyOutput,
    ) -> Option<BoardErrorKind> {
        let link_fault = input.link.err().or(input.write_error);
        if let Some(e) = self.link.observe(link_fault, self.state != AccState::Idle) {
            out.events.push(e);
            out.fault = true;
        }
        link_fault
    }

    /// 2. The line guard's verdict (`plausibility.rs`): the status the rules may read (a
    ///    held read is none), and from it the board's step, protocol and `CYCLE_ACTIVE`.
    fn accept_status(&mut self, input: &PolicyInput) -> Option<BoardStatus> {
        let status = plausibility::accepted(input);
        if let Some(s) = status {
            if s.override_step_pct > 0 {
                self.board_step = s.override_step_pct;
            }
            self.protocol = Some(if s.is_v2() {
                BoardProtocol::V2
            } else {
                BoardProtocol::V1
            });
            self.cycle_active = s.cycle_active;
            self.restart.cycle(s.cycle_active);
        }
        status
    }

    /// 3. Staleness (`staleness.rs`): whether the power sensor's `SAMPLE_SEQ` has stood
    ///    still too long; logs how far it moved.
    fn judge_staleness(&mut self, status: Option<&BoardStatus>, out: &mut PolicyOutput) -> bool {
        status.is_some_and(|s| {
            let (advance, stale) = self
                .staleness
                .observe(s.sample_seq, self.cfg.stale_seq_periods);
            out.sample_advance = advance;
            stale
        })
    }

    /// 4. The force sample's validity (`plausibility.rs`, the power's): a held read counts
    ///    as invalid; a judged invalid sample counts against the power budget, except with
    ///    the spindle off (no cut possible: the count neither grows nor restarts).
    fn judge_force(
        &mut self,
        input: &PolicyInput,
        status: Option<&BoardStatus>,
        stale: bool,
        out: &mut PolicyOutput,
    ) -> bool {
        let force_valid =
            plausibility::force_valid(status, stale, &input.force, self.cfg.max_power_w);
        out.force_valid = force_valid;
        let spindle_off =
            status.is_some_and(|s| plausibility::spindle_off(s, self.cfg.max_power_w));
        if (status.is_some() || input.held) && (force_valid || !spindle_off) {
            if let Some(e) = self.power.count(force_valid, stale) {
                out.events.push(e);
                out.fault = true;
            }
        }
        force_valid
    }

    /// 6. The operator's switch and knob as seen (`operator.rs`); a tripped watchdog or a
    ///    locked override is a fault input.
    fn observe_board(&mut self, s: &BoardStatus, out: &mut PolicyOutput) {
        self.operator.observe(s);
        if s.watchdog_tripped || s.override_locked {
            out.fault = true;
        }
    }

    /// 7. Overload (`overload.rs`), in any state: the force above the tool's overload limit
    ///    for its time warns, or holds the feed and lets go (the tool table's reaction).
    fn judge_overload<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        let f = seen.input.force;
        match self
            .overload
            .judge(seen.force_valid, f.force_n, seen.input.held, &self.cfg)
        {
            OverloadVerdict::Quiet => {}
            OverloadVerdict::ClearWarning => {
                if self.state != AccState::Latched(Release::Overload) {
                    self.alarms.overload = false;
                }
            }
            OverloadVerdict::Warn => {
                if !self.alarms.overload {
                    tracing::warn!(force_n = f.force_n, "overload: warning (tool table)");
                }
                self.alarms.overload = true;
            }
            OverloadVerdict::Hold { spindle_stop } if !self.feed_hold => {
                if spindle_stop {
                    out.events.push(Event::SpindleStopRequest);
                }
                self.hold_feed(out);
                tracing::warn!(force_n = f.force_n, "overload: feed hold requested");
                out.fault = true;
                self.let_go(Release::Overload, s, out, law);
            }
            OverloadVerdict::Hold { .. } => {}
        }
    }

    /// 8. Breakage watch (`breakage.rs`): tool gone or spike, judged on valid samples only,
    ///    and not where the plan says the tool may be leaving the material this period; a
    ///    drop while a block or tool change waits for confirmation is held until it is
    ///    judged. A break holds the feed and lets go.
    fn judge_breakage<L: OverrideLaw + ?Sized>(
        &mut self,
        s: &BoardStatus,
        seen: &Seen<'_>,
        out: &mut PolicyOutput,
        law: &mut L,
    ) {
        let f = seen.input.force;
        let broken = (seen.force_valid && !self.exit_planned)
            .then(|| {
                self.breakage
                    .judge(f.force_n, s, self.feed_hold, !self.context_pending)
            })
            .flatten();
        if let Some(b) = broken {
            out.events.push(Event::Breakage(b));
            tracing::warn!(
                kind = b.kind(),
                force_n = f.force_n,
                "tool breakage suspected: feed hold requested"
            );
            out.fault = true;
            self.hold_feed(out);
            self.let_go(Release::Breakage, s, out, law);
        }
    }

    /// The period's output after the rules: the state, `CONTROL` bits and alarms they left.
    fn end_period(&self, mut out: PolicyOutput) -> PolicyOutput {
        out.state = self.state;
        out.control = self.control();
        out.alarms = self.alarms;
        out
    }
}
