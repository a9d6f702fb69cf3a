//! Fault policy and operator priority: a pure state machine, one call per period.
//!
//! Inputs of [`FaultPolicy::step`]: the result of this period's status read (or the link
//! error), the error of the previous period's writes, the force sample the force source made
//! of the status, and the time. Outputs ([`CycleOutput`]): the override to write (with the
//! heartbeat), the `CONTROL` bits wanted on the board, the alarms in force and the events of
//! this period. The controller itself is any [`OverrideLaw`], stepped from here so that the
//! policy decides when it runs, when it is frozen and what of its command reaches the board.
//!
//! # Judges
//!
//! Each rule is a small judge in its own file (`policy/<judge>.rs`) that answers one question
//! about the period; [`FaultPolicy::step`] is the one place that asks them, in this order,
//! and acts on the answers (arm, hold, release, latch, re-arm, feed hold):
//!
//! Every period, in every state:
//! 1. `link.rs` — has the link failed for longer than ACC may hold the override?
//! 2. `plausibility.rs` (the line guard's verdict) — is there a status to read at all?
//! 3. `staleness.rs` — is the power sensor stale (`SAMPLE_SEQ` unchanged)?
//! 4. `plausibility.rs` (the power's) — is the force sample valid, and for how long has it
//!    not been?
//! 5. `shutdown.rs` — is this period out of the cut (the drain of a stop)?
//! 6. `operator.rs` — the switch and the knob as seen (a latch needs the switch off, then on);
//! 7. `overload.rs` — has the force been above the overload limit for too long?
//! 8. `breakage.rs` — did the tool break? (Not judged in a period where the plan's
//!    look-ahead explains a force drop: [`FaultPolicy::set_exit_planned`]; a drop while a
//!    block or tool change waits for its confirmation is held until the change is
//!    confirmed or not: [`FaultPolicy::set_context_pending`].)
//!
//! Then by state. **Active**, first answer that acts wins:
//! 9. `operator.rs` — switch off (release) or knob down (hand back, or cap on a v1 board);
//! 10. `watchdog.rs` — tripped (release, or re-arm after an outage mid-cut)?
//! 11. `reset.rs` — did the board restart under us (re-arm mid-cut, else release)?
//! 12. `lock.rs` — is the override locked by the NC (freeze the law, hold)?
//! 13. `reset.rs` — does the board confirm ACC within `ack_periods`?
//! 14. `link.rs`, `plausibility.rs` — over the link budget, over the invalid-power budget
//!     (release); a failing link holds the last command;
//! 15. `log.rs` — can the period be recorded (the run log's writer not stalled past its
//!     buffer)? No record, no cut (feed hold, release).
//! 16. `delay.rs` — is the line's delay beyond the gains' margin (feed hold, release)?
//! 17. `settle.rs` — in the periods after a fault of the line or the board, no higher than
//!     what ACC allowed before it; `tool_limits.rs` — what bounds the law's command (range, invalid sample,
//!     knob, the shop layer's and the plan's limits, the settle cap)? Then the law's step within those bounds
//!     ([`OverrideLaw::step_within`]: its one quantization step applies them).
//!
//! **Active without a status**: over the link budget, over the power budget, else hold.
//! **Idle**: a tripped watchdog latches; the switch on in a clean period arms (clean: link
//! answered, force valid, override not locked, the run log's writer not stalled).
//! **Latched** (after a link loss): the link restored mid-cut, the switch on and the knob
//! kept re-arm at the last command; otherwise the switch off and on again in a clean period
//! arms.
//!
//! What the answers mean for the board:
//! - **ACC only while the operator's switch is on**: arming is bumpless (the law is engaged
//!   at the override in force) and needs a clean period (link answered, force valid, override
//!   not locked).
//! - **Link**: hold the last override (keep writing it and the heartbeat) for at most
//!   `link_hold_periods`, then release and raise [`Alarms::link_lost`]; the board's own
//!   watchdog is the backstop when nothing gets through at all.
//! - **Power invalid or stale**: the command may go down but never up; after
//!   `invalid_power_periods` in a row, release and alarm.
//! - **Watchdog tripped / board reset / no confirmation**: release, alarm, latch. A latched
//!   policy re-arms only after the operator's switch has been seen off and then on again;
//!   re-arming writes `ALARM_RESET` if the watchdog is still tripped or the board reports
//!   `BOARD_RESTARTED`.
//! - **Re-arm mid-cut** (board restart, link restored): [`Event::Rearmed`], not latched:
//!   `OVERRIDE_CMD` = the last command is written first, then `CONTROL` = `ACC_REQUEST |
//!   ALARM_RESET` (which clears `BOARD_RESTARTED` and a v2 board's power-up feed hold), and
//!   control continues from the last command. On a v1 board the re-arm is at `min(last
//!   command, override applied)`: the re-arm never raises the feed further.
//! - **Overload, breakage, delay**: feed-hold request and alarm, release and latch.
//! - **Log stalled**: feed-hold request, release and latch (no alarm bit: the run says so in
//!   its log flags and summary).
//! - **A fault release never raises the feed**: a release mid-cut that is not the
//!   operator's requests feed hold; out of the cut, a release requests feed hold when the
//!   knob is above ACC's last command on a board without the fallback clamp
//!   (`hold_on_raising_release`, default on). Every feed-hold request stays until the
//!   operator re-arms ACC (switch off, then on).
//! - **Never above the maximum**: every command is floored onto the board's grid within
//!   `[min_override_pct, max_override_pct]` by the override spec ([`OverrideSpec::floor`];
//!   the law's command in its quantization step, [`acc_core::CommandBounds::place`]).
//!
//! Invariant (property-tested): a period with a fault input never writes a command higher
//! than the last one written.

use acc_core::{FeedOverride, Measurement, OverrideLaw, OverrideSpec};
use acc_pmc::{BoardProtocol, BoardStatus, ControlBits};

use crate::watch::WatchLimits;

mod breakage;
mod config;
mod delay;
mod io;
mod link;
mod lock;
mod log;
mod operator;
mod overload;
mod plausibility;
mod reset;
mod settle;
mod shutdown;
mod staleness;
mod state;
mod tool_limits;
mod watchdog;

pub use config::{PolicyConfig, PolicyConfigError};
pub use delay::delay_exceeded;
pub use io::{CycleInput, CycleOutput, Event, Events};
pub use settle::{RECENT_PERIODS as SETTLE_RECENT_PERIODS, SETTLE_PERIODS};
pub use state::{AccState, Alarms, Rearm, Release};
pub use tool_limits::CommandLimits;

use breakage::BreakageJudge;
use link::LinkJudge;
use lock::LockJudge;
use operator::{OperatorJudge, OperatorVerdict};
use overload::{OverloadJudge, OverloadVerdict};
use plausibility::PowerJudge;
use reset::{Ack, ResetJudge};
use settle::SettleJudge;
use shutdown::DrainJudge;
use staleness::Staleness;
use watchdog::WatchdogVerdict;

/// The fault-policy state machine: what ACC does with the board (state, alarms, requests,
/// the last command) and the judges it asks every period.
#[derive(Debug, Clone)]
pub struct FaultPolicy {
    cfg: PolicyConfig,
    state: AccState,
    alarms: Alarms,
    feed_hold: bool,
    last_cmd: Option<u16>,
    alarm_reset_pulse: bool,
    acc_request: bool,
    /// The board's `OVERRIDE_STEP` as last reported, percent.
    board_step: u16,
    /// The board's protocol as its status reports it (`None` before the first status).
    protocol: Option<BoardProtocol>,
    /// `CYCLE_ACTIVE` of the last status (true until a status says otherwise).
    cycle_active: bool,
    /// Command limits of the shop layer for the next step ([`FaultPolicy::set_command_limits`]).
    shop_limits: CommandLimits,
    /// The plan says the tool may leave the material this period
    /// ([`FaultPolicy::set_exit_planned`]).
    exit_planned: bool,
    /// The read shows a block, tool or program number the line guard has not yet confirmed
    /// ([`FaultPolicy::set_context_pending`]).
    context_pending: bool,
    link: LinkJudge,
    staleness: Staleness,
    power: PowerJudge,
    drain: DrainJudge,
    operator: OperatorJudge,
    overload: OverloadJudge,
    breakage: BreakageJudge,
    reset: ResetJudge,
    lock: LockJudge,
    settle: SettleJudge,
}

impl FaultPolicy {
    /// A policy in the idle state. Validate `cfg` first ([`PolicyConfig::validate`]).
    pub fn new(cfg: PolicyConfig) -> Self {
        let mut breakage = BreakageJudge::new(WatchLimits::default());
        breakage
            .detector
            .set_pending_limit(cfg.debounce_reads as usize);
        Self {
            cfg,
            state: AccState::Idle,
            alarms: Alarms::default(),
            feed_hold: false,
            last_cmd: None,
            alarm_reset_pulse: false,
            acc_request: false,
            board_step: 10,
            protocol: None,
            cycle_active: true,
            shop_limits: CommandLimits::default(),
            exit_planned: false,
            context_pending: false,
            link: LinkJudge::default(),
            staleness: Staleness::default(),
            power: PowerJudge::default(),
            drain: DrainJudge::default(),
            operator: OperatorJudge::default(),
            overload: OverloadJudge::default(),
            breakage,
            reset: ResetJudge::default(),
            lock: LockJudge::default(),
            settle: SettleJudge::default(),
        }
    }

    /// Limits on the law's command for the next [`FaultPolicy::step`] (replaces the
    /// previous ones; see [`CommandLimits`]).
    pub fn set_command_limits(&mut self, limits: CommandLimits) {
        self.shop_limits = limits;
    }

    /// The plan's look-ahead says the tool may leave the material in the next
    /// [`FaultPolicy::step`]'s period (its predicted force band reaches air): a force drop
    /// there is the planned exit, not a broken tool, and the breakage watch does not judge
    /// the period. A plan the measured force is above is not believed (the caller passes
    /// `false`).
    pub fn set_exit_planned(&mut self, planned: bool) {
        self.exit_planned = planned;
    }

    /// The next [`FaultPolicy::step`]'s read shows a block, tool or program number other
    /// than the one in force, which the line guard holds until the next read confirms it
    /// ([`crate::guard`], debounced registers): the NC may already run the next block, so a
    /// force drop in that period is held (the cut may have ended with its block) and judged
    /// once the change is confirmed or not ([`crate::watch::BreakageDetector::observe`]).
    pub fn set_context_pending(&mut self, pending: bool) {
        self.context_pending = pending;
    }

    /// The command limits in force for the next [`FaultPolicy::step`].
    pub fn command_limits(&self) -> CommandLimits {
        self.shop_limits
    }

    /// This policy with wear and breakage limits `limits` (default [`WatchLimits::default`]).
    pub fn with_watch_limits(mut self, limits: WatchLimits) -> Self {
        self.breakage.detector.set_limits(limits);
        self
    }

    /// The overload limit of the tool in use (the tool table on a tool change): force above
    /// `force_n`, N, for `time_s`, s → `reaction`. `Warning` raises the overload alarm while
    /// the force is above and keeps regulating; `FeedHold` requests feed hold, releases and
    /// latches; `SpindleStop` does the same and logs `overload:spindle_stop` (board protocol
    /// v2 has no spindle-stop output: the request is for the PMC ladder, docs/shop.md).
    /// Non-finite or negative values are ignored (the tool table is validated on load).
    pub fn set_overload(
        &mut self,
        force_n: f64,
        time_s: f64,
        reaction: acc_config::OverloadReaction,
    ) {
        if force_n.is_finite() && force_n > 0.0 && time_s.is_finite() && time_s >= 0.0 {
            self.cfg.overload_force_n = force_n;
            self.cfg.overload_time_s = time_s;
            self.overload.reaction = reaction;
        }
    }

    /// Switch the breakage limits (the tool table on a tool change); the history is kept and
    /// restarts by itself on the new tool number.
    pub fn set_watch_limits(&mut self, limits: WatchLimits) {
        self.breakage.detector.set_limits(limits);
    }

    /// The wear and breakage limits in use.
    pub fn watch_limits(&self) -> &WatchLimits {
        self.breakage.detector.limits()
    }

    /// The board's protocol as the last status reported it (`PROTOCOL_VERSION` ≥ 2: v2),
    /// `None` before the first status.
    pub fn protocol(&self) -> Option<BoardProtocol> {
        self.protocol
    }

    /// Whether a release engages the board's fallback clamp (a v2 board), so that handing
    /// the override back can never raise the feed.
    pub fn board_clamps(&self) -> bool {
        self.protocol == Some(BoardProtocol::V2)
    }

    /// Current state.
    pub fn state(&self) -> AccState {
        self.state
    }

    /// Alarms in force.
    pub fn alarms(&self) -> Alarms {
        self.alarms
    }

    /// The configuration.
    pub fn config(&self) -> &PolicyConfig {
        &self.cfg
    }

    /// Last override written while active, percent.
    pub fn last_command(&self) -> Option<u16> {
        self.last_cmd
    }

    fn control(&self) -> ControlBits {
        ControlBits {
            acc_request: self.acc_request,
            feed_hold_request: self.feed_hold,
            alarm_reset: self.alarm_reset_pulse,
        }
    }

    /// The configured command range on a board grid of `step` percent (0 = unknown: 10 %):
    /// every command of the policy is floored onto it by the override spec.
    fn grid(&self, step: u16) -> OverrideSpec {
        let step = if step == 0 { 10 } else { step };
        OverrideSpec::range(self.cfg.min_override_pct, self.cfg.max_override_pct).on_grid(step)
    }

    /// The last command, floored to the board's step as last reported (never above it).
    fn held(&mut self) -> Option<FeedOverride> {
        let grid = self.grid(self.board_step);
        self.last_cmd = self.last_cmd.map(|c| grid.floor(c).0.min(c));
        self.last_cmd.map(FeedOverride)
    }

    /// Request feed hold (once).
    fn hold_feed(&mut self, out: &mut CycleOutput) -> bool {
        if self.feed_hold {
            return false;
        }
        self.feed_hold = true;
        out.events.push(Event::FeedHold(true));
        true
    }

    /// Let go of the override for `why`: release an active policy, or latch an idle or
    /// latched one with the alarm (its switch must go off, then on again).
    fn let_go<L: OverrideLaw + ?Sized>(
        &mut self,
        why: Release,
        s: &BoardStatus,
        out: &mut CycleOutput,
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

    fn release(
        &mut self,
        why: Release,
        out: &mut CycleOutput,
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

    /// Advance one period: ask the judges in the order of the module docs and act on their
    /// answers. `law` is the controller (stepped only while active and unlocked).
    pub fn step<L: OverrideLaw + ?Sized>(
        &mut self,
        input: &CycleInput,
        law: &mut L,
    ) -> CycleOutput {
        self.alarm_reset_pulse = false;
        let mut out = CycleOutput {
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
        };

        // 1. Link: read errors and last period's write errors.
        let link_fault = input.link.err().or(input.write_error);
        if let Some(e) = self.link.observe(link_fault, self.state != AccState::Idle) {
            out.events.push(e);
            out.fault = true;
        }
        // 2. The line guard's verdict: a held read is no status this period.
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
        }
        // 3. Staleness of the power sensor.
        let stale = status.is_some_and(|s| {
            let (advance, stale) = self
                .staleness
                .observe(s.sample_seq, self.cfg.stale_seq_periods);
            out.sample_advance = advance;
            stale
        });
        // 4. The force sample's validity (a held read counts as invalid).
        let f = input.force;
        let force_valid =
            plausibility::force_valid(status.as_ref(), stale, &f, self.cfg.max_power_w);
        out.force_valid = force_valid;
        if status.is_some() || input.held {
            if let Some(e) = self.power.count(force_valid, stale) {
                out.events.push(e);
                out.fault = true;
            }
        }
        // 5. The drain of a stop: out of the cut?
        self.drain.observe(input);

        if let Some(s) = status {
            // 6. The operator's switch and knob as seen; the board's own faults.
            self.operator.observe(&s);
            if s.watchdog_tripped || s.override_locked {
                out.fault = true;
            }
            // 7. Overload (tool-breakage protection), in any state.
            match self
                .overload
                .judge(force_valid, f.force_n, input.held, &self.cfg)
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
                    self.hold_feed(&mut out);
                    tracing::warn!(force_n = f.force_n, "overload: feed hold requested");
                    out.fault = true;
                    self.let_go(Release::Overload, &s, &mut out, law);
                }
                OverloadVerdict::Hold { .. } => {}
            }
            // 8. Breakage watch (tool gone / spike), judged on valid samples only, and not
            //    where the plan says the tool may be leaving the material this period.
            let broken = (force_valid && !self.exit_planned)
                .then(|| {
                    self.breakage
                        .judge(f.force_n, &s, self.feed_hold, !self.context_pending)
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
                self.hold_feed(&mut out);
                self.let_go(Release::Breakage, &s, &mut out, law);
            }
        }

        // The periods after a fault of the line or the board settle under what ACC allowed
        // before it.
        self.settle.observe(
            link_fault.is_some()
                || input.held
                || status.is_some_and(|s| s.watchdog_tripped || s.override_locked),
        );

        // 9.–17. By state. Arming needs a clean period: link answered, force valid,
        //    override not locked, the run log's writer not stalled.
        let clean = link_fault.is_none()
            && force_valid
            && log::recordable(input)
            && status.is_some_and(|s| !s.override_locked);
        match (self.state, status) {
            (AccState::Active, None) => {
                // No status this period: hold, or release after the budget.
                if self.link.over_budget(self.cfg.link_hold_periods) {
                    self.release(Release::LinkLost, &mut out, law);
                } else if self.power.over_budget(self.cfg.invalid_power_periods) {
                    self.release(Release::PowerInvalid, &mut out, law);
                } else {
                    out.write_override = self.held();
                }
            }
            (AccState::Active, Some(s)) => self.active_step(s, force_valid, input, &mut out, law),
            (AccState::Idle, Some(s)) => {
                if s.watchdog_tripped {
                    out.events.push(Event::WatchdogTripped);
                    self.let_go(Release::Watchdog, &s, &mut out, law);
                } else if s.acc_switch && clean {
                    self.arm(s, &mut out, law);
                }
            }
            (AccState::Latched(why), Some(s)) => {
                if why == Release::LinkLost
                    && !self.operator.switch_seen_off
                    && s.acc_switch
                    && s.cycle_active
                    && !s.override_locked
                    && link_fault.is_none()
                    && self.operator.knob_kept(&s, self.cfg.operator_handback_pct)
                    && self.last_cmd.is_some()
                {
                    self.rearm(Rearm::LinkRestored, s, &mut out, law);
                } else if self.operator.switch_cycled(&s) && clean {
                    self.arm(s, &mut out, law);
                }
            }
            (AccState::Idle | AccState::Latched(_), None) => {}
        }

        out.state = self.state;
        out.control = self.control();
        out.alarms = self.alarms;
        out
    }

    fn arm<L: OverrideLaw + ?Sized>(&mut self, s: BoardStatus, out: &mut CycleOutput, law: &mut L) {
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
    fn rearm<L: OverrideLaw + ?Sized>(
        &mut self,
        why: Rearm,
        s: BoardStatus,
        out: &mut CycleOutput,
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

    /// Steps 9–16 of the module docs: an active policy with a status.
    fn active_step<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        force_valid: bool,
        input: &CycleInput,
        out: &mut CycleOutput,
        law: &mut L,
    ) {
        // 9. Operator priority first.
        let board_clamps = self.board_clamps();
        match self.operator.judge(
            &s,
            self.cfg.operator_handback_pct,
            board_clamps,
            self.last_cmd,
        ) {
            OperatorVerdict::SwitchOff => return self.release(Release::SwitchOff, out, law),
            OperatorVerdict::Handback => return self.release(Release::OperatorHandback, out, law),
            OperatorVerdict::Keep => {}
        }
        // 10. The board's watchdog.
        if let Some(v) = watchdog::judge(&s, self.link.outage(), self.last_cmd.is_some()) {
            out.events.push(Event::WatchdogTripped);
            return match v {
                WatchdogVerdict::Rearm => self.rearm(Rearm::LinkRestored, s, out, law),
                WatchdogVerdict::Release => self.release(Release::Watchdog, out, law),
            };
        }
        // 11. The board restarted under us.
        if self.reset.restarted(&s) {
            if s.cycle_active {
                return self.rearm(Rearm::BoardRestart, s, out, law);
            }
            out.fault = true;
            return self.release(Release::BoardReset, out, law);
        }
        // 12. The NC locked the override: freeze the law and hold.
        if let Some(frozen) = self.lock.judge(s.override_locked) {
            law.set_frozen(frozen);
            out.events.push(Event::Frozen(frozen));
        }
        if s.override_locked {
            out.write_override = self.held();
            return;
        }
        // 13. The board's confirmation of ACC.
        let write_ok = input.write_error.is_none();
        match self.reset.ack(&s, write_ok, self.cfg.ack_periods) {
            Ack::Confirmed { clean: true } => self.link.close_outage(),
            Ack::Confirmed { clean: false } | Ack::Waiting => {}
            Ack::Missing => {
                out.fault = true;
                return self.release(Release::NoBoardAck, out, law);
            }
        }
        // 14. Link failures (e.g. a write error with a good read) and the power budget.
        if self.link.over_budget(self.cfg.link_hold_periods) {
            return self.release(Release::LinkLost, out, law);
        }
        if self.power.over_budget(self.cfg.invalid_power_periods) {
            return self.release(Release::PowerInvalid, out, law);
        }
        let grid = self.grid(s.override_step_pct);
        let last = self
            .held()
            .map_or_else(|| grid.floor(s.override_applied_pct).0, |c| c.0);
        if self.link.failing() {
            out.write_override = Some(FeedOverride(last));
            return;
        }
        // 15. No record, no cut.
        if !log::recordable(input) {
            out.events.push(Event::LogStalled);
            tracing::error!("the run log's writer has stalled past its buffer: feed hold");
            out.fault = true;
            return self.release(Release::LogStalled, out, law);
        }
        // 16. The line's delay against what the gains in use tolerate: never drive on into
        //     an oscillation.
        if let Some((extra, margin)) = delay_exceeded(&input.delay, || law.delay_margin_periods()) {
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
            return self.release(Release::Delay, out, law);
        }
        // 17. The control step, on the feed the loop computed once for this period, its
        //     command placed on the grid within the bounds judged here (one quantization).
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
        out.settle_cap = self.settle.cap(SettleJudge::cutting(
            force_valid,
            input.force.force_n,
            self.breakage.force_ref_n,
        ));
        if let Some(c) = out.settle_cap {
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
        out.write_override = Some(step.command);
        out.step = Some(step);
        out.measurement = Some(m);
    }
}
