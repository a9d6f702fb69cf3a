//! One control period against any [`Board`]: read the status, make a force sample of it,
//! run the [`FaultPolicy`] (which steps the law), write the override with the heartbeat and
//! the `CONTROL` bits when they change.
//!
//! The period is split so that the threaded runtime can run the I/O on one thread and the
//! decision on another ([`ControlLoop::decide`] is pure: no I/O, no clock), while a
//! single-threaded caller (tests, the simulator on a manual clock) uses
//! [`ControlLoop::cycle`].
//!
//! | file | what |
//! | --- | --- |
//! | `mod.rs` | [`ControlLoop`]: the loop's state and the period's named steps |
//! | `record.rs` | [`BoardWrites`], [`WriteResult`], [`PeriodRecord`] and its run-log row |
//! | `in_force.rs` | the commands in force over the last periods (echoes, loop delay) |

mod in_force;
mod record;

pub use record::SEQ_SKIP_MAX;
pub use record::{kind_name, mode_name, saturation_name, BoardWrites, PeriodRecord, WriteResult};

use acc_core::{ForceSample, ForceSource, OverrideLaw, PeriodInput};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardStatus, ControlBits};

use crate::echo::{DelayReading, LoopDelay, MAX_ECHO_PERIODS};
use crate::guard::{Expected, Guarded, LineGuard};
use crate::lookahead::{LookAhead, LookAheadInput, LookAheadStep};
use crate::policy::{FaultPolicy, PolicyInput, PolicyOutput};
use crate::record::RunRecord;
use crate::runner::execute_writes;
use crate::shop::{ShopControl, ShopStep, ToolChange};
pub(crate) use in_force::InForce;
use record::context_pending;

/// The loop's state between periods: the policy, the law, the force source, the heartbeat
/// counter and what the board was last given.
#[derive(Debug)]
pub struct ControlLoop<L, F> {
    policy: FaultPolicy,
    law: L,
    source: F,
    period_s: f64,
    index: u64,
    heartbeat: u16,
    control_on_board: Option<ControlBits>,
    write_error: Option<BoardErrorKind>,
    path_mm: f64,
    last_feed_mm_min: f64,
    shop: Option<ShopControl>,
    guard: LineGuard,
    delay: LoopDelay,
    /// The commands in force after the last periods (for the guard and the loop delay).
    in_force: InForce,
    /// The run log's writer is stalled past the logger's buffer ([`Self::set_log_stalled`]).
    log_stalled: bool,
    /// The plan's look-ahead, if any ([`ControlLoop::with_lookahead`]).
    lookahead: Option<LookAhead>,
    /// The ticker woke this period past its deadline ([`ControlLoop::set_period_late`]).
    period_late: bool,
}

impl<L: OverrideLaw, F: ForceSource> ControlLoop<L, F> {
    /// A loop with period `period_s` (s).
    pub fn new(policy: FaultPolicy, law: L, source: F, period_s: f64) -> Self {
        let guard = LineGuard::new(policy.config().guard());
        Self {
            guard,
            delay: LoopDelay::new(),
            in_force: InForce::default(),
            policy,
            law,
            source,
            period_s,
            index: 0,
            heartbeat: 0,
            control_on_board: None,
            write_error: None,
            path_mm: 0.0,
            last_feed_mm_min: 0.0,
            shop: None,
            log_stalled: false,
            lookahead: None,
            period_late: false,
        }
    }

    /// Run with a plan's look-ahead ([`crate::lookahead`]): every period, after the shop
    /// layer, its cap joins the command limits (the lower cap wins), so the plan can only
    /// lower the law's command.
    pub fn with_lookahead(mut self, lookahead: LookAhead) -> Self {
        self.lookahead = Some(lookahead);
        self
    }

    /// The look-ahead, if any.
    pub fn lookahead(&self) -> Option<&LookAhead> {
        self.lookahead.as_ref()
    }

    /// Whether the ticker woke for the period about to be decided past its deadline (an
    /// overrun): the period may have lasted longer than the control period, so the plan's
    /// lead does not act and the look-ahead sets no bound over it.
    pub fn set_period_late(&mut self, late: bool) {
        self.period_late = late;
    }

    /// Run with the shop layer (tool table by `TOOL_NUMBER`, entry control): see
    /// [`crate::shop`].
    pub fn with_shop(mut self, shop: ShopControl) -> Self {
        self.shop = Some(shop);
        self
    }

    /// The shop layer, if any.
    pub fn shop(&self) -> Option<&ShopControl> {
        self.shop.as_ref()
    }

    /// Count a period as out of the cut when the force sample is valid and below
    /// `air_force_n`, N (default 0: only a fallen `CYCLE_ACTIVE` counts); see
    /// [`ControlLoop::air_periods`] (the policy's drain, [`FaultPolicy::with_air_force_n`]).
    pub fn with_air_force_n(mut self, air_force_n: f64) -> Self {
        self.policy = self.policy.with_air_force_n(air_force_n);
        self
    }

    /// Consecutive periods up to now that were out of the cut: the status read and either
    /// `CYCLE_ACTIVE` off or a valid force sample below the air threshold. A shutdown drains
    /// until this reaches its configured count ([`FaultPolicy::air_periods`]).
    pub fn air_periods(&self) -> u32 {
        self.policy.air_periods()
    }

    /// The period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Index of the next period.
    pub fn next_index(&self) -> u64 {
        self.index
    }

    /// Path position so far, mm (integral of the actual feed).
    pub fn path_mm(&self) -> f64 {
        self.path_mm
    }

    /// Account for a period in which no cycle ran (the ticker skipped its deadline): the
    /// index advances, the path integrates the last known feed, and the row is flagged
    /// `skipped`. The policy is not stepped (nothing was read or written).
    pub fn skip(&mut self, t_s: f64) -> RunRecord {
        self.path_mm += self.last_feed_mm_min * self.period_s / 60.0;
        if let Some(la) = self.lookahead.as_mut() {
            la.missed();
        }
        self.guard.skipped();
        self.in_force
            .book(self.policy.state() == crate::policy::AccState::Active, None);
        let mut r = RunRecord::skipped(self.index, t_s, self.policy.state().name());
        r.x_mm = Some(self.path_mm);
        r.alarms = self.policy.alarms().bits();
        self.index += 1;
        r
    }

    /// What the line guard has caught so far ([`crate::guard::GuardCounts`]).
    pub fn guard_counts(&self) -> crate::guard::GuardCounts {
        self.guard.counts()
    }

    /// The last loop-delay measurement ([`crate::echo`]).
    pub fn delay_reading(&self) -> DelayReading {
        self.delay.last()
    }

    /// The policy (state, alarms).
    pub fn policy(&self) -> &FaultPolicy {
        &self.policy
    }

    /// Switch the policy's wear and breakage limits (the tool table, on a tool change:
    /// [`FaultPolicy::set_watch_limits`]).
    pub fn set_watch_limits(&mut self, limits: crate::watch::WatchLimits) {
        self.policy.set_watch_limits(limits);
    }

    /// The law.
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Decide this period from the status read (or link error) at time `t_s`. Pure.
    ///
    /// The actual feed is computed here, once: programmed feed (`PROGRAMMED_FEED`, or the
    /// policy's `nominal_feed_mm_min` when the board reports 0) × `OVERRIDE_APPLIED`, and 0
    /// while `FEED_HOLD_ACTIVE`. The force source, the law and the path integral all use that
    /// one value.
    ///
    /// With the shop layer, its [`ToolChange`] event is applied to the law here, before the
    /// policy steps it (the one place the law's Fr and Kc_hat change from outside the law).
    pub fn decide(&mut self, t_s: f64, read: Result<BoardStatus, BoardErrorKind>) -> PeriodRecord {
        let guard = self.guard_read(read);
        let link = match read {
            Err(k) => Err(k),
            Ok(_) => guard.status.ok_or(BoardErrorKind::Protocol),
        };
        let held = read.is_ok() && guard.hold;
        let delay = self.measure_delay(read, link, held, &guard);
        let feeds = self.feeds(link);
        self.advance_path(feeds);
        let force = self.estimate_force(link, feeds, held);
        let write_error = self.write_error.take();
        let input = PolicyInput {
            t_s,
            link,
            write_error,
            force,
            programmed_feed_mm_min: feeds.map_or(0.0, |f| f.0),
            feed_mm_min: feeds.map_or(0.0, |f| f.1),
            held,
            delay,
            log_stalled: self.log_stalled,
        };
        let shop = self.shop_limits(link, &force);
        let lookahead = self.lookahead_limits(read, link, held, &force, &delay);
        self.policy
            .set_context_pending(context_pending(read, guard.status.as_ref()));
        let out = self.policy.step(&input, &mut self.law);
        let writes = self.board_writes(&out);
        self.book_command(&out);
        let rec = PeriodRecord {
            index: self.index,
            t_s,
            link,
            write_error,
            programmed_feed_mm_min: feeds.map(|f| f.0),
            feed_mm_min: feeds.map(|f| f.1),
            path_mm: self.path_mm,
            force,
            out,
            writes,
            shop,
            tool_force_ref_n: self.shop.as_ref().and_then(ShopControl::force_ref_n),
            guard,
            delay,
            delay_margin_periods: self.law.delay_margin_periods(),
            log_stalled: self.log_stalled,
            lookahead,
        };
        self.index += 1;
        rec
    }

    /// The line guard's reading of `read` (plausibility and confirmation before meaning:
    /// the rules see the guarded status), against the echoes to expect: the commands in
    /// force after the last periods and whether ACC was requested.
    fn guard_read(&mut self, read: Result<BoardStatus, BoardErrorKind>) -> Guarded {
        let mut expect = Expected {
            acc_requested: self.control_on_board.is_some_and(|c| c.acc_request),
            ..Expected::default()
        };
        for (slot, c) in expect
            .commands
            .iter_mut()
            .zip(self.in_force.cmds.iter().flatten().copied())
        {
            *slot = c;
            expect.count += 1;
        }
        self.guard.check(read, &expect)
    }

    /// The loop delay measured this period from the commands booked so far and the status
    /// accepted (`link` unless the guard `held` it). Where the line or the board lost its
    /// cadence (a failed read or write), whether the board took the commands booked so far
    /// is unknown: they are forgotten.
    fn measure_delay(
        &mut self,
        read: Result<BoardStatus, BoardErrorKind>,
        link: Result<BoardStatus, BoardErrorKind>,
        held: bool,
        guard: &Guarded,
    ) -> DelayReading {
        let line_broke = read.is_err() || self.write_error.is_some();
        if line_broke {
            self.in_force.cmds = [None; MAX_ECHO_PERIODS];
        }
        let accepted = link.ok().filter(|_| !held);
        let booked = self.in_force.take(line_broke);
        let mut delay = self.delay.period(self.index, &booked, accepted.as_ref());
        delay.replay_lag_periods = guard.replay_lag_periods;
        delay
    }

    /// The period's `(programmed, actual)` feed from the status, mm/min (`None` without
    /// one): `PROGRAMMED_FEED`, or the policy's nominal feed when the board reports 0;
    /// × `OVERRIDE_APPLIED`, 0 in a feed hold (it stops the axes whatever the override).
    fn feeds(&self, link: Result<BoardStatus, BoardErrorKind>) -> Option<(f64, f64)> {
        link.ok().map(|s| {
            let programmed = if s.programmed_feed_mm_min > 0 {
                f64::from(s.programmed_feed_mm_min)
            } else {
                self.policy.config().nominal_feed_mm_min
            };
            let feed = if s.feed_hold_active {
                0.0
            } else {
                programmed * f64::from(s.override_applied_pct) / 100.0
            };
            (programmed, feed)
        })
    }

    /// The path integral over the period: the actual feed of `feeds`, or the last known one
    /// without a status.
    fn advance_path(&mut self, feeds: Option<(f64, f64)>) {
        if let Some((_, feed)) = feeds {
            self.last_feed_mm_min = feed;
        }
        self.path_mm += self.last_feed_mm_min * self.period_s / 60.0;
    }

    /// The force source's sample of the status at the period's actual feed; invalid
    /// without a status or for a read the guard `held`.
    fn estimate_force(
        &mut self,
        link: Result<BoardStatus, BoardErrorKind>,
        feeds: Option<(f64, f64)>,
        held: bool,
    ) -> ForceSample {
        match (link, feeds) {
            (Ok(s), Some((_, feed))) if !held => {
                let input = PeriodInput {
                    period_s: self.period_s,
                    spindle_rpm: f64::from(s.spindle_rpm),
                    feed_mm_min: feed,
                    true_force_n: None,
                    power_w: Some(f64::from(s.spindle_power_w)),
                    phases: None,
                };
                self.source.estimate(&input)
            }
            _ => ForceSample::INVALID,
        }
    }

    /// The shop layer's command limits for the period, and its tool change applied to the
    /// law, from the status, the force, the last command and the law's Kc estimate.
    fn shop_limits(
        &mut self,
        link: Result<BoardStatus, BoardErrorKind>,
        force: &ForceSample,
    ) -> Option<ShopStep> {
        let sh = self.shop.as_mut()?;
        let decision = sh.before(
            link.as_ref().ok(),
            force,
            self.policy.last_command(),
            self.law.kc_estimate(),
        );
        self.policy.set_command_limits(decision.limits);
        if let Some(change) = decision.tool_change {
            self.apply_tool_change(change);
        }
        decision.step
    }

    /// The plan's look-ahead for the period, from its one input: the status accepted, the
    /// raw block read, whether the guard held the read, whether the line runs as designed
    /// (the designed loop delay, no late period: the lead's window assumes it), the force
    /// and the tool's Fr. Its cap (or lead) joins the command limits
    /// ([`ControlLoop::join_plan_limits`]).
    fn lookahead_limits(
        &mut self,
        read: Result<BoardStatus, BoardErrorKind>,
        link: Result<BoardStatus, BoardErrorKind>,
        held: bool,
        force: &ForceSample,
        delay: &DelayReading,
    ) -> Option<LookAheadStep> {
        let input = LookAheadInput {
            status: link.ok(),
            raw_block: read.ok().map(|raw| raw.block_number),
            read_held: held,
            line_nominal: delay.as_designed() && !self.period_late,
            force: *force,
            force_ref_n: self.shop.as_ref().and_then(ShopControl::force_ref_n),
            period_s: self.period_s,
        };
        let st = self.lookahead.as_mut()?.step(&input);
        self.join_plan_limits(&st);
        Some(st)
    }

    /// The look-ahead's decision `st` joins the command limits (the shop layer's, if any):
    /// its cap, the lower cap wins; the plan's lead, where there is one, is the period's
    /// command, the plan's cap and floor at once (the shop layer's cap, applied last, still
    /// wins). Also whether the plan explains a force drop (the breakage watch's exit).
    fn join_plan_limits(&mut self, st: &LookAheadStep) {
        let mut limits = if self.shop.is_some() {
            self.policy.command_limits()
        } else {
            crate::policy::CommandLimits::default()
        };
        let plan_cap = match st.lead_pct {
            Some(l) => {
                limits.floor_pct = Some(limits.floor_pct.map_or(l, |f| f.max(l)));
                Some(l)
            }
            None => st.cap_pct,
        };
        if let Some(c) = plan_cap {
            limits.cap_pct = Some(limits.cap_pct.map_or(c, |s| s.min(c)));
        }
        self.policy.set_command_limits(limits);
        self.policy.set_exit_planned(st.exit_planned);
    }

    /// The writes the policy's decision `out` asks of the link: the override with the next
    /// heartbeat, and the `CONTROL` bits where they differ from what the board was given.
    fn board_writes(&mut self, out: &PolicyOutput) -> BoardWrites {
        let mut writes = BoardWrites::default();
        if let Some(cmd) = out.write_override {
            self.heartbeat = self.heartbeat.wrapping_add(1);
            writes.override_and_heartbeat = Some((cmd.0, self.heartbeat));
        }
        if self.control_on_board != Some(out.control) {
            writes.control = Some(out.control);
        }
        writes
    }

    /// Book the command `out` writes: the look-ahead walks at it until the board applies it,
    /// and the guard and the loop delay expect its echo.
    fn book_command(&mut self, out: &PolicyOutput) {
        if let (Some(la), Some(cmd)) = (self.lookahead.as_mut(), out.write_override) {
            la.note_written(cmd.0);
        }
        self.in_force.book(
            out.state == crate::policy::AccState::Active,
            out.write_override.map(|o| o.0),
        );
    }

    /// The run log's writer is stalled past the logger's buffer (`true`) or has caught up
    /// (`false`). While stalled, the policy does not arm, and an active ACC releases with a
    /// feed hold ([`crate::policy::Release::LogStalled`]); every record is flagged
    /// `log_stalled`.
    pub fn set_log_stalled(&mut self, stalled: bool) {
        self.log_stalled = stalled;
    }

    /// Apply a tool change of the shop layer (also the first tool of the run), before the
    /// policy steps the law: the one place where the law's Fr and Kc_hat change from
    /// outside the law (through [`OverrideLaw::set_force_ref_n`] and
    /// [`OverrideLaw::reset_kc_estimate`], [`ToolChange::apply_to`]), and where the policy
    /// takes the tool's wear, breakage and overload limits from the tool table. The command
    /// never rises at once on a change: the shop layer's cap starts at the last command.
    fn apply_tool_change(&mut self, change: ToolChange) {
        change.apply_to(&mut self.law);
        if let Some(sh) = self.shop.as_ref() {
            let t = sh.table().get(change.tool);
            let limits = self.policy.watch_limits().with_tool(t);
            self.policy.set_watch_limits(limits);
            self.policy
                .set_overload(t.overload_n, t.overload_time_s, t.overload_reaction);
        }
    }

    /// The link was reopened (a new port or bus after the device vanished): what the board
    /// was last given is unknown, so the next period writes `CONTROL` again.
    pub fn link_reopened(&mut self) {
        self.control_on_board = None;
    }

    /// Report how the plan's writes went (feeds the next period's policy input).
    pub fn writes_done(&mut self, r: &WriteResult) {
        if let Some(c) = r.control_written {
            self.control_on_board = Some(c);
        }
        if r.override_error.is_some() {
            // Whether the board took this period's command is unknown: no echo is judged
            // until it has left the history.
            self.in_force.cmds[0] = None;
        }
        self.write_error = r.error();
    }

    /// One full period on `pmc` at time `t_s`: read, decide, write.
    pub fn cycle<P: Board>(&mut self, pmc: &mut P, t_s: f64) -> PeriodRecord {
        let link = pmc.read_status().map_err(|e| e.kind());
        let rec = self.decide(t_s, link);
        let r = execute_writes(pmc, &rec.writes);
        self.writes_done(&r);
        rec
    }

    /// Orderly stop: clear `ACC_REQUEST` and `FEED_HOLD_REQUEST` (the board then follows the
    /// operator's override), trying up to `attempts` times. Returns the last error if none
    /// of the attempts got through.
    pub fn shutdown<P: Board>(&mut self, pmc: &mut P, attempts: u32) -> Result<(), BoardErrorKind> {
        let bits = self.shutdown_bits();
        let mut last = BoardErrorKind::Disconnected;
        for _ in 0..attempts.max(1) {
            match pmc.write_control(bits) {
                Ok(()) => {
                    self.control_on_board = Some(bits);
                    return Ok(());
                }
                Err(e) => last = e.kind(),
            }
        }
        Err(last)
    }

    /// Stop in the middle of a cut: request feed hold while ACC still drives the override,
    /// then release ACC with the feed hold kept, so that handing the override back to the
    /// operator cannot raise the feed (the NC needs cycle start). Up to `attempts` tries per
    /// write; returns the last error if a write never got through.
    pub fn hold_and_release<P: Board>(
        &mut self,
        pmc: &mut P,
        attempts: u32,
    ) -> Result<(), BoardErrorKind> {
        let hold = ControlBits {
            acc_request: self.control_on_board.is_some_and(|c| c.acc_request),
            feed_hold_request: true,
            alarm_reset: false,
        };
        let released = self.policy.shutdown_with_hold();
        for bits in [hold, released] {
            let mut result = Err(BoardErrorKind::Disconnected);
            for _ in 0..attempts.max(1) {
                match pmc.write_control(bits) {
                    Ok(()) => {
                        self.control_on_board = Some(bits);
                        result = Ok(());
                        break;
                    }
                    Err(e) => result = Err(e.kind()),
                }
            }
            result?;
        }
        Ok(())
    }

    /// The `CONTROL` bits of an orderly stop (moves the policy to idle).
    pub fn shutdown_bits(&mut self) -> ControlBits {
        self.policy.shutdown()
    }
}
