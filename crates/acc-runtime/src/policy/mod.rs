//! Fault policy and operator priority: a pure state machine, one call per period.
//!
//! Inputs of [`FaultPolicy::step`]: the result of this period's status read (or the link
//! error), the error of the previous period's writes, the force sample the force source made
//! of the status, and the time. Outputs ([`PolicyOutput`]): the override to write (with the
//! heartbeat), the `CONTROL` bits wanted on the board, the alarms in force and the events of
//! this period. The controller itself is any [`OverrideLaw`], stepped from here so that the
//! policy decides when it runs, when it is frozen and what of its command reaches the board.
//!
//! # Judges
//!
//! Each rule is a small judge in its own file (`policy/<judge>.rs`) that answers one question
//! about the period; [`FaultPolicy::step`] is the one place that asks them, in this order,
//! and acts on the answers (arm, hold, release, latch, re-arm, feed hold). `period.rs` holds
//! `step` and the rules of every period, `by_state.rs` the rules by state, `actions.rs` what
//! an answer does to the board (arm, re-arm, release, latch, feed hold):
//!
//! Every period, in every state:
//! 1. `link.rs` — has the link failed for longer than ACC may hold the override?
//! 2. `plausibility.rs` (the line guard's verdict) — is there a status to read at all?
//! 3. `staleness.rs` — is the power sensor stale (`SAMPLE_SEQ` unchanged)?
//! 4. `plausibility.rs` (the power's) — is the force sample valid, and for how long has it
//!    not been (not counted while the spindle is off: no speed, no power)?
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
//!     Do the axes stand still (`FEED_HOLD_ACTIVE`: the NC's feed hold, a paused program)?
//!     Then the last command is written again and the law is not stepped (no wind-up on
//!     the missing chip for the moment the cut resumes).
//! 17. `settle.rs` — in the periods after a fault of the line or the board, no higher than
//!     what ACC allowed before it; `restart.rs` — after a program stopped in a cut, no
//!     higher than the command that was cutting until the new cycle's cut is measured; `tool_limits.rs` — what bounds the law's command (range, invalid sample,
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

#[cfg(doc)]
use acc_core::{OverrideLaw, OverrideSpec};
use acc_pmc::BoardProtocol;

use crate::watch::WatchLimits;

mod actions;
mod breakage;
mod by_state;
mod config;
mod delay;
mod io;
mod link;
mod lock;
mod log;
mod operator;
mod overload;
mod period;
mod plausibility;
mod reset;
mod restart;
mod settle;
mod shutdown;
mod staleness;
mod state;
mod tool_limits;
mod watchdog;

pub use config::{PolicyConfig, PolicyConfigError};
pub use delay::delay_exceeded;
pub use io::{Event, Events, PolicyInput, PolicyOutput};
pub use settle::{RECENT_PERIODS as SETTLE_RECENT_PERIODS, SETTLE_PERIODS};
pub use state::{AccState, Alarms, Rearm, Release};
pub use tool_limits::CommandLimits;

use breakage::BreakageJudge;
use link::LinkJudge;
use lock::LockJudge;
use operator::OperatorJudge;
use overload::OverloadJudge;
use plausibility::PowerJudge;
use reset::ResetJudge;
use restart::RestartJudge;
use settle::SettleJudge;
use shutdown::DrainJudge;
use staleness::Staleness;

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
    restart: RestartJudge,
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
            restart: RestartJudge::default(),
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
}
