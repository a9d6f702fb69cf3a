//! Fault policy and operator priority: a pure state machine, one call per period.
//!
//! Inputs of [`FaultPolicy::step`]: the result of this period's status read (or the link
//! error), the error of the previous period's writes, the force sample the force source made
//! of the status, and the time. Outputs ([`CycleOutput`]): the override to write (with the
//! heartbeat), the `CONTROL` bits wanted on the board, the alarms in force and the events of
//! this period. The controller itself is any [`OverrideLaw`], stepped from here so that the
//! policy decides when it runs, when it is frozen and what of its command reaches the board.
//!
//! Rules:
//! - **ACC only while the operator's switch is on**: the policy arms (bumpless: the law is
//!   engaged at the override in force) when `ACC_SWITCH` is on, and releases at once when it
//!   goes off.
//! - **Link timeout / CRC / exception / protocol error** (read or write): hold the last
//!   override (keep writing it and the heartbeat) for at most `link_hold_periods`, then
//!   release to the operator and raise [`Alarms::link_lost`]. The board's own watchdog is the
//!   backstop when nothing gets through at all.
//! - **Power invalid or stale** (force source says invalid; NaN, negative or above
//!   `max_power_w`; `SAMPLE_SEQ` unchanged for `stale_seq_periods`): the command may go down
//!   but never up; after `invalid_power_periods` in a row, release and alarm.
//! - **Watchdog tripped / board reset** (the board dropped `ACC_ACTIVE` while the switch is
//!   on and nothing else explains it, or never confirmed it within `ack_periods`): release,
//!   alarm, latch. A latched policy re-arms only after the operator's switch has been seen
//!   off and then on again; re-arming writes `ALARM_RESET` if the watchdog is still tripped
//!   or the board reports `BOARD_RESTARTED`.
//! - **Board restart mid-cut** (v2: `BOARD_RESTARTED`; v1: `ACC_ACTIVE` dropped with no
//!   watchdog, lock or switch to explain it) while `CYCLE_ACTIVE`: re-armed at once, not
//!   latched ([`Event::Rearmed`]): `OVERRIDE_CMD` = the last command is written first, then
//!   `CONTROL` = `ACC_REQUEST | ALARM_RESET` (which clears `BOARD_RESTARTED` and a v2 board's
//!   power-up feed hold), and control continues from the last command. On a v1 board the
//!   re-arm is at `min(last command, override applied)`: the one period at the operator's knob
//!   is already past and the re-arm never raises the feed further. A board that keeps
//!   restarting (more than `ack_periods` re-arms without a clean confirmation) is released.
//! - **Link restored while the cut is on**: after a `LinkLost` release (or a watchdog trip
//!   that followed an outage), the first good status with the switch on, `CYCLE_ACTIVE` and
//!   the override not locked re-arms the same way, with `ALARM_RESET`, instead of latching.
//! - **Overload**: force above `overload_force_n` for at least `overload_time_s` → feed-hold
//!   request and alarm, release and latch (tool-breakage protection).
//! - **A fault release never raises the feed**: handing the override back to the operator
//!   moves the board to `OPERATOR_OVERRIDE`; if that knob is above ACC's last command, the
//!   release also requests feed hold (`hold_on_raising_release`, default on). Every feed-hold
//!   request stays until the operator re-arms ACC (switch off, then on). On a v2 board (the
//!   status reports `PROTOCOL_VERSION` ≥ 2) a release engages the board's fallback clamp: the
//!   applied override becomes `min(knob, last command)`, so no feed hold is needed and none is
//!   requested; on a v1 board (or before the protocol is known) the rule above applies.
//! - **`OVERRIDE_LOCKED`** (tapping, threading, override cancel): the law is frozen
//!   ([`OverrideLaw::set_frozen`]) and not stepped; the last command is held, never fought.
//! - **Operator knob down** by more than `operator_handback_pct` from its highest position
//!   since arming → hand back to the operator, latch. On a board without the fallback clamp
//!   (v1) a knob still above ACC's last command is not handed back (the board would move to
//!   the knob and raise the feed): ACC keeps control with the knob as the ceiling of its
//!   command, and hands back once the knob is below that command.
//! - **Breakage** (the wear and breakage watch, [`crate::watch`]): a valid force sample far
//!   below (tool gone) or far above (spike) the median of the tool's own recent steady-cut
//!   history, while the NC says the cut continues (cycle on, same tool and block, no feed
//!   hold) → feed-hold request in the same period, [`Alarms::breakage`],
//!   [`Event::Breakage`], release and latch. Limits: [`WatchLimits`], per tool through
//!   [`FaultPolicy::set_watch_limits`].
//! - **Never above the maximum**: every command is clamped to `[min_override_pct,
//!   max_override_pct]` and floored to the board's `OVERRIDE_STEP`.
//!
//! Invariant (property-tested): a period with a fault input never writes a command higher
//! than the last one written.

use acc_core::{FeedOverride, ForceSample, Measurement, OverrideLaw, StepOutput};
use acc_pmc::{BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};

use crate::watch::{Breakage, BreakageDetector, BreakageSample, WatchLimits};

/// Parameters of the fault policy. Defaults in each field's doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolicyConfig {
    /// Control period T, s (default 0.1); converts `overload_time_s` into periods.
    pub period_s: f64,
    /// Lowest override ever commanded, percent (default 0).
    pub min_override_pct: u16,
    /// Highest override ever commanded, percent (default 150, never above 150).
    pub max_override_pct: u16,
    /// Consecutive link failures during which the last override is held (default 5).
    pub link_hold_periods: u32,
    /// Consecutive invalid or stale power samples tolerated before release (default 5).
    pub invalid_power_periods: u32,
    /// `SAMPLE_SEQ` unchanged for this many periods ⇒ the power sensor is stale (default 3).
    pub stale_seq_periods: u32,
    /// Periods after arming within which the board must report `ACC_ACTIVE` (default 3).
    pub ack_periods: u32,
    /// Overload force limit, N (default 1600, twice the paper's Fr).
    pub overload_force_n: f64,
    /// Time above the overload limit before feed hold, s (default 0.3), counted in periods
    /// T from the first period above: see [`PolicyConfig::overload_periods`].
    pub overload_time_s: f64,
    /// Operator knob turned down by more than this from its highest position since arming
    /// hands control back, percent (default 10).
    pub operator_handback_pct: u16,
    /// Largest plausible spindle power, W (default 30 000); above it the sample is invalid.
    pub max_power_w: f64,
    /// Feed assumed when the board reports `PROGRAMMED_FEED` = 0 (unknown), mm/min
    /// (default 200, the paper's nominal feed).
    pub nominal_feed_mm_min: f64,
    /// On a release while the NC is not cutting (`CYCLE_ACTIVE` off), request feed hold if
    /// the operator's knob is above the last command (default true). A release mid-cut
    /// that is not the operator's always requests feed hold.
    pub hold_on_raising_release: bool,
    /// Consecutive reads a changed register must hold before it counts, 1 ..= 10 (default
    /// 2; 1 = no debounce): see [`crate::guard`].
    pub debounce_reads: u32,
    /// Largest plausible change of the spindle power between two samples, W (default
    /// 2 000); a larger one is held a period for confirmation.
    pub max_power_step_w: f64,
    /// Largest plausible change of the spindle speed between two samples, rpm (default
    /// 1 000).
    pub max_rpm_step: f64,
}

impl Default for PolicyConfig {
    fn default() -> Self {
        Self {
            period_s: 0.1,
            min_override_pct: 0,
            max_override_pct: 150,
            link_hold_periods: 5,
            invalid_power_periods: 5,
            stale_seq_periods: 3,
            ack_periods: 3,
            overload_force_n: 1600.0,
            overload_time_s: 0.3,
            operator_handback_pct: 10,
            max_power_w: 30_000.0,
            nominal_feed_mm_min: 200.0,
            hold_on_raising_release: true,
            debounce_reads: 2,
            max_power_step_w: 2_000.0,
            max_rpm_step: 1_000.0,
        }
    }
}

/// A policy parameter outside its allowed range: the workspace's one
/// [`acc_config::RangeError`], keyed as in the `[policy]` table of the run config (the run
/// config loader prefixes `policy.` and names the file).
pub type PolicyConfigError = acc_config::RangeError;

impl PolicyConfig {
    /// Check every field; the error names the key and the allowed range.
    pub fn validate(&self) -> Result<(), PolicyConfigError> {
        fn err(
            key: &'static str,
            value: impl ToString,
            allowed: &'static str,
        ) -> PolicyConfigError {
            PolicyConfigError::new(key, value.to_string(), allowed)
        }
        let finite_pos = |x: f64| x.is_finite() && x > 0.0;
        if !(finite_pos(self.period_s) && self.period_s <= 10.0) {
            return Err(err("period_s", self.period_s, "0 < x <= 10"));
        }
        if self.max_override_pct > 150 || self.max_override_pct == 0 {
            return Err(err("max_override_pct", self.max_override_pct, "1 ..= 150"));
        }
        if self.min_override_pct > self.max_override_pct {
            return Err(err(
                "min_override_pct",
                self.min_override_pct,
                "0 ..= max_override_pct",
            ));
        }
        // Counts of tolerated faults are at least 1: 0 would release on a single CRC error or
        // a single bad sample, and a release mid-cut on a board without the fallback clamp
        // hands the feed back to the operator's (higher) knob.
        if self.link_hold_periods == 0 || self.link_hold_periods > 1000 {
            return Err(err(
                "link_hold_periods",
                self.link_hold_periods,
                "1 ..= 1000",
            ));
        }
        if self.invalid_power_periods == 0 || self.invalid_power_periods > 1000 {
            return Err(err(
                "invalid_power_periods",
                self.invalid_power_periods,
                "1 ..= 1000",
            ));
        }
        if self.stale_seq_periods == 0 || self.stale_seq_periods > 1000 {
            return Err(err(
                "stale_seq_periods",
                self.stale_seq_periods,
                "1 ..= 1000",
            ));
        }
        if self.ack_periods == 0 || self.ack_periods > 1000 {
            return Err(err("ack_periods", self.ack_periods, "1 ..= 1000"));
        }
        if !finite_pos(self.overload_force_n) {
            return Err(err("overload_force_n", self.overload_force_n, "> 0"));
        }
        if !(self.overload_time_s.is_finite() && self.overload_time_s >= 0.0) {
            return Err(err("overload_time_s", self.overload_time_s, ">= 0"));
        }
        if self.operator_handback_pct > 150 {
            return Err(err(
                "operator_handback_pct",
                self.operator_handback_pct,
                "0 ..= 150",
            ));
        }
        if !finite_pos(self.max_power_w) {
            return Err(err("max_power_w", self.max_power_w, "> 0"));
        }
        if !finite_pos(self.nominal_feed_mm_min) {
            return Err(err("nominal_feed_mm_min", self.nominal_feed_mm_min, "> 0"));
        }
        if !(1..=10).contains(&self.debounce_reads) {
            return Err(err("debounce_reads", self.debounce_reads, "1 ..= 10"));
        }
        if !(finite_pos(self.max_power_step_w) && self.max_power_step_w <= self.max_power_w) {
            return Err(err(
                "max_power_step_w",
                self.max_power_step_w,
                "0 < x <= max_power_w",
            ));
        }
        if !finite_pos(self.max_rpm_step) {
            return Err(err("max_rpm_step", self.max_rpm_step, "> 0"));
        }
        Ok(())
    }

    /// The line guard's limits ([`crate::guard`]) from this policy's keys.
    pub fn guard(&self) -> crate::guard::GuardConfig {
        crate::guard::GuardConfig {
            debounce_reads: self.debounce_reads,
            max_power_w: self.max_power_w,
            max_power_step_w: self.max_power_step_w,
            max_rpm_step: self.max_rpm_step,
        }
    }

    /// Consecutive periods above `overload_force_n` that trip the feed hold:
    /// `ceil(overload_time_s / period_s) + 1`. The first period above only shows that the
    /// force crossed the limit somewhere in it; `overload_time_s` is counted from that
    /// period's end, in whole periods T. With the defaults (0.3 s, T = 0.1 s): 4 periods;
    /// with `overload_time_s` = 0: the first period above.
    pub fn overload_periods(&self) -> u32 {
        // The tolerance keeps 0.9 s / 0.3 s at 3 periods of time, not 4, despite rounding.
        let after_first = (self.overload_time_s / self.period_s - 1e-9).ceil();
        if after_first.is_finite() && after_first >= 1.0 {
            (after_first.min(f64::from(u32::MAX - 1)) as u32) + 1
        } else {
            1
        }
    }
}

/// Why ACC let go of the override.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Release {
    /// The operator switched ACC off (not latched: switching on re-arms).
    SwitchOff,
    /// The operator turned the override knob down by more than the hand-back amount.
    OperatorHandback,
    /// Link failures for more than `link_hold_periods`.
    LinkLost,
    /// Invalid or stale power for more than `invalid_power_periods`.
    PowerInvalid,
    /// The board's watchdog tripped.
    Watchdog,
    /// The board dropped `ACC_ACTIVE` unexplained (power cycle / reset).
    BoardReset,
    /// The board never confirmed `ACC_ACTIVE` after arming.
    NoBoardAck,
    /// Force above the overload limit for too long (feed hold requested).
    Overload,
    /// Tool breakage suspected: a sudden force drop or spike (feed hold requested).
    Breakage,
    /// The measured loop delay exceeds what the gains in use tolerate (feed hold
    /// requested): see [`crate::echo`].
    Delay,
    /// The run log's writer has stalled past the logger's buffer (feed hold requested):
    /// the cut never goes on without a record. See [`crate::runner`].
    LogStalled,
}

impl Release {
    /// Short lower-case name for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Release::SwitchOff => "switch_off",
            Release::OperatorHandback => "operator_handback",
            Release::LinkLost => "link_lost",
            Release::PowerInvalid => "power_invalid",
            Release::Watchdog => "watchdog",
            Release::BoardReset => "board_reset",
            Release::NoBoardAck => "no_board_ack",
            Release::Overload => "overload",
            Release::Breakage => "breakage",
            Release::Delay => "delay",
            Release::LogStalled => "log_stalled",
        }
    }

    /// Whether re-arming needs the operator's switch to be cycled off and on.
    pub fn latches(self) -> bool {
        !matches!(self, Release::SwitchOff)
    }
}

/// Why the policy re-armed by itself ([`Event::Rearmed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rearm {
    /// The board restarted (v2 `BOARD_RESTARTED`, v1 an unexplained `ACC_ACTIVE` drop).
    BoardRestart,
    /// The link came back after an outage, the cut still on.
    LinkRestored,
}

impl Rearm {
    /// Short lower-case name for logs (`board_restart`, `link_restored`).
    pub fn as_str(self) -> &'static str {
        match self {
            Rearm::BoardRestart => "board_restart",
            Rearm::LinkRestored => "link_restored",
        }
    }
}

/// ACC state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccState {
    /// Not driving the override; arms when the operator's switch is on.
    Idle,
    /// Driving the override (`ACC_REQUEST` set).
    Active,
    /// Released after a fault or a hand-back; re-arms only after the switch cycles off → on.
    Latched(Release),
}

impl AccState {
    /// Short name for logs (`idle`, `active`, `latched:<reason>`).
    pub fn name(self) -> &'static str {
        match self {
            AccState::Idle => "idle",
            AccState::Active => "active",
            AccState::Latched(r) => r.as_str(),
        }
    }
}

/// Alarms in force (cleared when the operator re-arms by cycling the switch).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Alarms {
    /// Link lost for more than the hold time.
    pub link_lost: bool,
    /// Power invalid or stale for too long.
    pub power_invalid: bool,
    /// Board watchdog tripped.
    pub watchdog: bool,
    /// Board reset / did not confirm ACC.
    pub board_reset: bool,
    /// Overload: feed hold requested.
    pub overload: bool,
    /// Tool breakage suspected (sudden force drop or spike): feed hold requested.
    pub breakage: bool,
    /// The loop delay exceeded the gains' delay margin: feed hold requested.
    pub delay: bool,
}

impl Alarms {
    /// Any alarm set.
    pub fn any(&self) -> bool {
        self.link_lost
            || self.power_invalid
            || self.watchdog
            || self.board_reset
            || self.overload
            || self.breakage
            || self.delay
    }

    /// The alarms in force by name, comma-separated (`none` when there are none): `link_lost`,
    /// `power_invalid`, `watchdog`, `board_reset`, `overload`.
    ///
    /// ```
    /// use acc_runtime::Alarms;
    /// let a = Alarms { watchdog: true, overload: true, ..Alarms::default() };
    /// assert_eq!(a.names(), "watchdog, overload");
    /// assert_eq!(Alarms::default().names(), "none");
    /// ```
    pub fn names(&self) -> String {
        let all = [
            (self.link_lost, "link_lost"),
            (self.power_invalid, "power_invalid"),
            (self.watchdog, "watchdog"),
            (self.board_reset, "board_reset"),
            (self.overload, "overload"),
            (self.breakage, "breakage"),
            (self.delay, "delay"),
        ];
        let on: Vec<&str> = all.iter().filter(|(b, _)| *b).map(|(_, n)| *n).collect();
        if on.is_empty() {
            "none".into()
        } else {
            on.join(", ")
        }
    }

    /// Compact bit code for the run log: bit 0 link, 1 power, 2 watchdog, 3 board reset,
    /// 4 overload, 5 breakage, 6 delay.
    pub fn bits(&self) -> u8 {
        u8::from(self.link_lost)
            | u8::from(self.power_invalid) << 1
            | u8::from(self.watchdog) << 2
            | u8::from(self.board_reset) << 3
            | u8::from(self.overload) << 4
            | u8::from(self.breakage) << 5
            | u8::from(self.delay) << 6
    }
}

/// Something that happened in a period (for tracing and the event log).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// ACC armed at this override (percent); `alarm_reset` written with the request.
    Armed {
        /// Override in force when armed, percent.
        at_pct: u16,
        /// `ALARM_RESET` written with the request.
        alarm_reset: bool,
    },
    /// ACC released.
    Released(Release),
    /// The tool's overload reaction is `spindle_stop`: feed hold is requested and the
    /// spindle should stop (logged `overload:spindle_stop`; the board has no such output).
    SpindleStopRequest,
    /// ACC re-armed by itself, mid-cut, at the last command (v1: at most the override
    /// applied), with `ALARM_RESET`: see the module docs.
    Rearmed {
        /// Why.
        reason: Rearm,
        /// Override written before `ACC_REQUEST`, percent.
        at_pct: u16,
    },
    /// A link error this period (the count of consecutive failures).
    LinkError {
        /// Error kind.
        kind: BoardErrorKind,
        /// Consecutive failures including this one.
        consecutive: u32,
    },
    /// The force sample was not usable (count of consecutive invalid samples).
    PowerInvalid {
        /// `SAMPLE_SEQ` unchanged for too long.
        stale: bool,
        /// Consecutive invalid samples including this one.
        consecutive: u32,
    },
    /// `OVERRIDE_LOCKED` seen: the law was frozen (`true`) or thawed (`false`).
    Frozen(bool),
    /// Feed-hold request set (`true`) or cleared (`false`).
    FeedHold(bool),
    /// The board's watchdog was seen tripped.
    WatchdogTripped,
    /// Tool breakage suspected (the feed hold follows in the same period).
    Breakage(Breakage),
    /// The measured loop delay exceeds the delay margin of the gains in use (the release
    /// and feed hold follow in the same period).
    DelayExceeded {
        /// Measured extra delay beyond the designed one period, periods.
        extra_periods: u32,
        /// What the gains tolerate, periods.
        margin_periods: u32,
    },
    /// The run log's writer stalled past the logger's buffer (the release and feed hold
    /// follow in the same period while ACC is active).
    LogStalled,
}

/// Up to [`Events::CAPACITY`] events of one period, without allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Events {
    items: [Option<Event>; Events::CAPACITY],
    len: usize,
}

impl Default for Events {
    fn default() -> Self {
        Self {
            items: [None; Events::CAPACITY],
            len: 0,
        }
    }
}

impl Events {
    /// Most events one period can produce.
    pub const CAPACITY: usize = 8;

    fn push(&mut self, e: Event) {
        if let Some(slot) = self.items.get_mut(self.len) {
            *slot = Some(e);
            self.len += 1;
        }
    }

    /// The events in order.
    pub fn iter(&self) -> impl Iterator<Item = &Event> {
        self.items.iter().take(self.len).flatten()
    }

    /// Number of events.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No events.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether an event equal to `e` happened.
    pub fn contains(&self, e: &Event) -> bool {
        self.iter().any(|x| x == e)
    }
}

/// What the runtime hands the policy once per period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleInput {
    /// Time of the period (start of the read), s since the run began.
    pub t_s: f64,
    /// Status read this period, or the link error kind.
    pub link: Result<BoardStatus, BoardErrorKind>,
    /// Error of the previous period's writes, if any.
    pub write_error: Option<BoardErrorKind>,
    /// Force sample computed from this period's status ([`ForceSample::INVALID`] when the
    /// read failed).
    pub force: ForceSample,
    /// Programmed feed of the active block, mm/min (the loop substitutes the nominal feed
    /// when the board reports 0; 0 when the read failed).
    pub programmed_feed_mm_min: f64,
    /// Actual feed of the period (programmed × applied override), mm/min, as the loop
    /// computed it once (0 when the read failed).
    pub feed_mm_min: f64,
    /// The line guard held this read for confirmation or found it implausible
    /// ([`crate::guard`]): `link` is the last accepted status, the sample is not used.
    pub held: bool,
    /// The loop delay measured on the line this period ([`crate::echo`]).
    pub delay: crate::echo::DelayReading,
    /// The run log's writer is stalled past the logger's buffer ([`crate::runner`]): ACC
    /// releases with a feed hold and does not arm.
    pub log_stalled: bool,
}

/// What the runtime does with the board this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleOutput {
    /// State after this period.
    pub state: AccState,
    /// Override to write with the heartbeat (`None`: leave `OVERRIDE_CMD` alone).
    pub write_override: Option<FeedOverride>,
    /// `CONTROL` bits wanted on the board (write when they differ from the last written).
    pub control: ControlBits,
    /// Alarms in force.
    pub alarms: Alarms,
    /// Events of this period.
    pub events: Events,
    /// The law's output, if it was stepped.
    pub step: Option<StepOutput>,
    /// What the law saw, if it was stepped.
    pub measurement: Option<Measurement>,
    /// Whether the force sample was used as valid this period.
    pub force_valid: bool,
    /// This period had a fault input (link, power, watchdog, reset, lock): the written
    /// override, if any, is not above the previous one.
    pub fault: bool,
    /// How far the board's `SAMPLE_SEQ` moved since the last successful read (wrapping):
    /// 1 normally, 0 when the power read is the previous sample again, more when samples
    /// were missed (a late read, failed reads). `None` without a status now or before.
    /// Logged as the flags `seq_repeat` / `seq_skip:<n>`; the discrepancy workflow's replay
    /// maps each row to the board's sample with it.
    pub sample_advance: Option<u16>,
}

/// The fault-policy state machine.
#[derive(Debug, Clone)]
pub struct FaultPolicy {
    cfg: PolicyConfig,
    state: AccState,
    alarms: Alarms,
    feed_hold: bool,
    last_operator_pct: Option<u16>,
    last_cmd: Option<u16>,
    link_failures: u32,
    invalid_count: u32,
    last_seq: Option<u16>,
    seq_unchanged: u32,
    /// Consecutive periods so far with the force above `overload_force_n`.
    overload_count: u32,
    switch_seen_off: bool,
    operator_ref: u16,
    acc_confirmed: bool,
    arm_age: u32,
    frozen: bool,
    alarm_reset_pulse: bool,
    acc_request: bool,
    board_step: u16,
    /// The board's protocol as its status reports it (`None` before the first status).
    protocol: Option<BoardProtocol>,
    /// Link failures since ACC was last seen confirmed on a clean period.
    outage: bool,
    /// Consecutive re-arms without a clean confirmation.
    rearms: u32,
    /// The operator's knob as a ceiling on ACC's command: set when the knob is turned down
    /// but handing back would raise the feed (a board without the fallback clamp, knob above
    /// ACC's last command). Cleared on arming.
    knob_ceiling: Option<u16>,
    /// Reaction to an overload (the tool table's `overload_reaction`; default feed hold).
    overload_reaction: acc_config::OverloadReaction,
    /// The breakage watch (fixed size, no allocation).
    breakage: BreakageDetector,
    /// Fr of the law's last step, N (the breakage watch's cut threshold).
    force_ref_n: Option<f64>,
    /// Command limits of the shop layer for the next step ([`FaultPolicy::set_command_limits`]).
    shop_limits: CommandLimits,
    /// `CYCLE_ACTIVE` of the last status (true until a status says otherwise).
    cycle_active: bool,
}

/// Limits on the law's command set from outside the law for one period (the tool table and
/// entry control of [`crate::shop`]): applied after the board-step quantization, the cap
/// last. A command the limits change re-engages the law at the written value (bumpless,
/// no windup against the limit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommandLimits {
    /// Highest command this period, percent (floored to the board step).
    pub cap_pct: Option<u16>,
    /// Lowest command this period while the force sample is valid, percent (rounded up to
    /// the board step; never above the cap).
    pub floor_pct: Option<u16>,
}

impl FaultPolicy {
    /// A policy in the idle state. Validate `cfg` first ([`PolicyConfig::validate`]).
    pub fn new(cfg: PolicyConfig) -> Self {
        Self {
            cfg,
            state: AccState::Idle,
            alarms: Alarms::default(),
            feed_hold: false,
            last_operator_pct: None,
            last_cmd: None,
            link_failures: 0,
            invalid_count: 0,
            last_seq: None,
            seq_unchanged: 0,
            overload_count: 0,
            switch_seen_off: false,
            operator_ref: 0,
            acc_confirmed: false,
            arm_age: 0,
            frozen: false,
            alarm_reset_pulse: false,
            acc_request: false,
            board_step: 10,
            protocol: None,
            outage: false,
            rearms: 0,
            knob_ceiling: None,
            overload_reaction: acc_config::OverloadReaction::FeedHold,
            shop_limits: CommandLimits::default(),
            breakage: BreakageDetector::new(WatchLimits::default()),
            force_ref_n: None,
            cycle_active: true,
        }
    }

    /// Limits on the law's command for the next [`FaultPolicy::step`] (replaces the
    /// previous ones; see [`CommandLimits`]).
    pub fn set_command_limits(&mut self, limits: CommandLimits) {
        self.shop_limits = limits;
    }

    /// This policy with wear and breakage limits `limits` (default [`WatchLimits::default`]).
    pub fn with_watch_limits(mut self, limits: WatchLimits) -> Self {
        self.breakage.set_limits(limits);
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
            self.overload_reaction = reaction;
        }
    }

    /// Switch the breakage limits (the tool table on a tool change); the history is kept and
    /// restarts by itself on the new tool number.
    pub fn set_watch_limits(&mut self, limits: WatchLimits) {
        self.breakage.set_limits(limits);
    }

    /// The wear and breakage limits in use.
    pub fn watch_limits(&self) -> &WatchLimits {
        self.breakage.limits()
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

    /// The `CONTROL` bits for an orderly shutdown: ACC request cleared, the override left to
    /// the operator. A feed hold the policy requested (an overload, a release that would have
    /// raised the feed) is kept: stopping the program must not restart the axes. Moves the
    /// policy to idle.
    pub fn shutdown(&mut self) -> ControlBits {
        self.state = AccState::Idle;
        self.acc_request = false;
        ControlBits {
            acc_request: false,
            feed_hold_request: self.feed_hold,
            alarm_reset: false,
        }
    }

    /// The `CONTROL` bits of a stop in the middle of a cut: ACC request cleared, feed hold
    /// requested (and kept). Moves the policy to idle.
    pub fn shutdown_with_hold(&mut self) -> ControlBits {
        self.state = AccState::Idle;
        self.acc_request = false;
        self.feed_hold = true;
        ControlBits {
            acc_request: false,
            feed_hold_request: true,
            alarm_reset: false,
        }
    }

    fn control(&self) -> ControlBits {
        ControlBits {
            acc_request: self.acc_request,
            feed_hold_request: self.feed_hold,
            alarm_reset: self.alarm_reset_pulse,
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
        self.acc_confirmed = false;
        if self.frozen {
            law.set_frozen(false);
            self.frozen = false;
        }
        self.state = if why.latches() {
            self.switch_seen_off = false;
            AccState::Latched(why)
        } else {
            AccState::Idle
        };
        let operator = matches!(why, Release::SwitchOff | Release::OperatorHandback);
        // A v2 board clamps the applied override to min(knob, last applied) on a release.
        let raising = !self.board_clamps()
            && match (self.last_operator_pct, self.last_cmd) {
                (Some(op), Some(cmd)) => op > cmd,
                _ => true,
            };
        // A release that is not the operator's while the NC cuts is a feed hold, on every
        // board: nobody else is there to take the cut (the clamp holds the override, not
        // the force). Out of the cut, only a release that would raise the feed holds.
        let hold =
            !operator && (self.cycle_active || (raising && self.cfg.hold_on_raising_release));
        if hold && !self.feed_hold {
            self.feed_hold = true;
            out.events.push(Event::FeedHold(true));
            tracing::warn!(
                reason = why.as_str(),
                "feed hold: ACC let go of the cut for a reason that is not the operator's"
            );
        }
        match why {
            Release::LinkLost => self.alarms.link_lost = true,
            Release::PowerInvalid => self.alarms.power_invalid = true,
            Release::Watchdog => self.alarms.watchdog = true,
            Release::BoardReset | Release::NoBoardAck => self.alarms.board_reset = true,
            Release::Overload => self.alarms.overload = true,
            Release::Breakage => self.alarms.breakage = true,
            Release::Delay => self.alarms.delay = true,
            Release::LogStalled | Release::SwitchOff | Release::OperatorHandback => {}
        }
    }

    /// The last command, floored to the board's step as last reported (never above it).
    fn held(&mut self) -> Option<FeedOverride> {
        let step = self.board_step;
        self.last_cmd = self.last_cmd.map(|c| self.quantize(c, step).min(c));
        self.last_cmd.map(FeedOverride)
    }

    /// Floor to the board step and clamp to the configured range.
    fn quantize(&self, pct: u16, step: u16) -> u16 {
        let step = if step == 0 { 10 } else { step };
        let hi = self.cfg.max_override_pct.min(150);
        let hi = hi - hi % step;
        let lo = self.cfg.min_override_pct.div_ceil(step) * step;
        let v = pct.min(hi);
        (v - v % step).max(lo).min(hi)
    }

    /// Advance one period. `law` is the controller (stepped only while active and unlocked).
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
        };

        // 1. Link health: read errors and last period's write errors.
        let read_fault = input.link.err();
        let link_fault = read_fault.or(input.write_error);
        if let Some(kind) = link_fault {
            self.link_failures = self.link_failures.saturating_add(1);
            out.events.push(Event::LinkError {
                kind,
                consecutive: self.link_failures,
            });
            out.fault = true;
        } else {
            self.link_failures = 0;
        }
        // A read the line guard held is no status at all this period: nothing is concluded
        // from the last accepted one (it is stale), the sample counts as invalid.
        let status = input.link.ok().filter(|_| !input.held);
        if let Some(s) = status.filter(|s| s.override_step_pct > 0) {
            self.board_step = s.override_step_pct;
        }
        if let Some(s) = status {
            self.protocol = Some(if s.is_v2() {
                BoardProtocol::V2
            } else {
                BoardProtocol::V1
            });
        }
        if link_fault.is_some() && self.state != AccState::Idle {
            self.outage = true;
        }

        // 2. Power validity (force source flag, plausibility, SAMPLE_SEQ).
        let mut stale = false;
        if let Some(s) = status {
            self.cycle_active = s.cycle_active;
            out.sample_advance = self.last_seq.map(|l| s.sample_seq.wrapping_sub(l));
            if out.sample_advance == Some(0) {
                self.seq_unchanged = self.seq_unchanged.saturating_add(1);
            } else {
                self.seq_unchanged = 0;
            }
            self.last_seq = Some(s.sample_seq);
            stale |= self.seq_unchanged >= self.cfg.stale_seq_periods;
        }
        let f = input.force;
        let power_ok = f
            .power_w
            .is_none_or(|p| p.is_finite() && p >= 0.0 && p <= self.cfg.max_power_w);
        let board_power_ok =
            status.is_none_or(|s| f64::from(s.spindle_power_w) <= self.cfg.max_power_w);
        let force_valid = status.is_some()
            && board_power_ok
            && !stale
            && f.valid
            && f.force_n.is_finite()
            && f.force_n >= 0.0
            && power_ok;
        out.force_valid = force_valid;
        if status.is_some() || stale || input.held {
            if force_valid {
                self.invalid_count = 0;
            } else {
                self.invalid_count = self.invalid_count.saturating_add(1);
                out.events.push(Event::PowerInvalid {
                    stale,
                    consecutive: self.invalid_count,
                });
                out.fault = true;
            }
        }

        // 3. Board-level observations that apply in every state.
        if let Some(s) = status {
            if !s.acc_switch {
                self.switch_seen_off = true;
            }
            self.last_operator_pct = Some(s.operator_override_pct);
            if s.watchdog_tripped || s.override_locked {
                out.fault = true;
            }
            // Overload (tool-breakage protection), in any state.
            if force_valid && f.force_n > self.cfg.overload_force_n {
                self.overload_count = self.overload_count.saturating_add(1);
                let tripped = self.overload_count >= self.cfg.overload_periods();
                if tripped && self.overload_reaction == acc_config::OverloadReaction::Warning {
                    if !self.alarms.overload {
                        tracing::warn!(force_n = f.force_n, "overload: warning (tool table)");
                    }
                    self.alarms.overload = true;
                } else if tripped && !self.feed_hold {
                    if self.overload_reaction == acc_config::OverloadReaction::SpindleStop {
                        out.events.push(Event::SpindleStopRequest);
                    }
                    self.feed_hold = true;
                    out.events.push(Event::FeedHold(true));
                    tracing::warn!(force_n = f.force_n, "overload: feed hold requested");
                    out.fault = true;
                    if self.state == AccState::Active {
                        self.release(Release::Overload, &mut out, law);
                    } else {
                        self.alarms.overload = true;
                        self.state = AccState::Latched(Release::Overload);
                        self.switch_seen_off = !s.acc_switch;
                    }
                }
            } else if !input.held {
                // A held read says nothing about the force: the count neither grows nor
                // restarts.
                self.overload_count = 0;
                if self.overload_reaction == acc_config::OverloadReaction::Warning
                    && self.state != AccState::Latched(Release::Overload)
                {
                    self.alarms.overload = false;
                }
            }
            // Breakage watch (tool gone / spike), judged on valid samples only.
            if let (true, Some(fr)) = (force_valid, self.force_ref_n) {
                let sample = BreakageSample {
                    force_n: f.force_n,
                    force_ref_n: fr,
                    cycle_active: s.cycle_active,
                    feed_hold_active: s.feed_hold_active || self.feed_hold,
                    tool: if s.is_v2() { s.tool_number } else { 0 },
                    block: if s.is_v2() { s.block_number } else { 0 },
                    override_pct: s.override_applied_pct,
                };
                if let Some(b) = self.breakage.observe(&sample) {
                    out.events.push(Event::Breakage(b));
                    tracing::warn!(
                        kind = b.kind(),
                        force_n = f.force_n,
                        "tool breakage suspected: feed hold requested"
                    );
                    out.fault = true;
                    if !self.feed_hold {
                        self.feed_hold = true;
                        out.events.push(Event::FeedHold(true));
                    }
                    if self.state == AccState::Active {
                        self.release(Release::Breakage, &mut out, law);
                    } else {
                        self.alarms.breakage = true;
                        self.state = AccState::Latched(Release::Breakage);
                        self.switch_seen_off = !s.acc_switch;
                    }
                }
            }
        }

        // 4. State transitions. Arming needs a clean period: link answered, force valid,
        //    override not locked.
        let clean = link_fault.is_none()
            && force_valid
            && !input.log_stalled
            && status.is_some_and(|s| !s.override_locked);
        match (self.state, status) {
            (AccState::Active, None) => {
                // No status this period: hold, or release after the budget.
                let over_link = self.link_failures > self.cfg.link_hold_periods;
                let over_power = self.invalid_count > self.cfg.invalid_power_periods;
                if over_link {
                    self.release(Release::LinkLost, &mut out, law);
                } else if over_power {
                    self.release(Release::PowerInvalid, &mut out, law);
                } else {
                    out.write_override = self.held();
                }
            }
            (AccState::Active, Some(s)) => self.active_step(s, force_valid, input, &mut out, law),
            (AccState::Idle, Some(s)) => {
                if s.watchdog_tripped {
                    out.events.push(Event::WatchdogTripped);
                    self.alarms.watchdog = true;
                    self.state = AccState::Latched(Release::Watchdog);
                    self.switch_seen_off = !s.acc_switch;
                } else if s.acc_switch && clean {
                    self.arm(s, &mut out, law);
                }
            }
            (AccState::Latched(why), Some(s)) => {
                let knob_kept = u32::from(s.operator_override_pct)
                    + u32::from(self.cfg.operator_handback_pct)
                    >= u32::from(self.operator_ref);
                if why == Release::LinkLost
                    && !self.switch_seen_off
                    && s.acc_switch
                    && s.cycle_active
                    && !s.override_locked
                    && link_fault.is_none()
                    && knob_kept
                    && self.last_cmd.is_some()
                {
                    self.rearm(Rearm::LinkRestored, s, &mut out, law);
                } else if self.switch_seen_off && s.acc_switch && clean {
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
        let at = self.quantize(s.override_applied_pct, s.override_step_pct);
        if self.feed_hold {
            self.feed_hold = false;
            out.events.push(Event::FeedHold(false));
        }
        law.engage(FeedOverride(at));
        let alarm_reset = s.watchdog_tripped || s.board_restarted;
        self.alarm_reset_pulse = alarm_reset;
        self.alarms = Alarms::default();
        self.outage = false;
        self.rearms = 0;
        self.knob_ceiling = None;
        self.acc_request = true;
        self.acc_confirmed = false;
        self.arm_age = 0;
        self.operator_ref = s.operator_override_pct;
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
        self.rearms = self.rearms.saturating_add(1);
        if self.rearms > self.cfg.ack_periods {
            return self.release(Release::BoardReset, out, law);
        }
        let applied = self.quantize(s.override_applied_pct, s.override_step_pct);
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
        if self.frozen {
            law.set_frozen(false);
            self.frozen = false;
        }
        if self.feed_hold && !self.alarms.overload {
            self.feed_hold = false;
            out.events.push(Event::FeedHold(false));
        }
        self.alarm_reset_pulse = true;
        self.alarms = Alarms::default();
        self.acc_request = true;
        self.acc_confirmed = false;
        self.arm_age = 0;
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

    fn active_step<L: OverrideLaw + ?Sized>(
        &mut self,
        s: BoardStatus,
        force_valid: bool,
        input: &CycleInput,
        out: &mut CycleOutput,
        law: &mut L,
    ) {
        // Operator priority first.
        if !s.acc_switch {
            return self.release(Release::SwitchOff, out, law);
        }
        self.operator_ref = self.operator_ref.max(s.operator_override_pct);
        if u32::from(s.operator_override_pct) + u32::from(self.cfg.operator_handback_pct)
            < u32::from(self.operator_ref)
        {
            // Handing back moves the board to the knob. Without the fallback clamp (v1) a
            // knob still above ACC's last command would raise the feed: keep control with the
            // knob as the ceiling instead, and hand back once the knob is below ACC's command
            // (at the knob's own value the command may be a dither step above ACC's
            // regulated level, which a hand-back would hold for good).
            let raising =
                !self.board_clamps() && self.last_cmd.is_some_and(|c| s.operator_override_pct >= c);
            if !raising {
                return self.release(Release::OperatorHandback, out, law);
            }
            if self.knob_ceiling != Some(s.operator_override_pct) {
                tracing::info!(
                    knob_pct = s.operator_override_pct,
                    "operator's knob down: it caps ACC's command (handing back would raise the feed on this board)"
                );
            }
            self.knob_ceiling = Some(s.operator_override_pct);
        } else {
            self.knob_ceiling = None;
        }
        // Board-side faults.
        if s.watchdog_tripped {
            out.events.push(Event::WatchdogTripped);
            // A trip that followed a link outage (the heartbeat could not get through), the
            // cut still on: re-arm at the last command rather than latch.
            if self.outage && s.cycle_active && !s.override_locked && self.last_cmd.is_some() {
                return self.rearm(Rearm::LinkRestored, s, out, law);
            }
            return self.release(Release::Watchdog, out, law);
        }
        // The board restarted under us (v2: BOARD_RESTARTED; v1: ACC_ACTIVE dropped with no
        // watchdog, lock or switch to explain it).
        let restarted =
            self.acc_confirmed && (s.board_restarted || (!s.acc_active && !s.override_locked));
        if restarted {
            if s.cycle_active {
                return self.rearm(Rearm::BoardRestart, s, out, law);
            }
            out.fault = true;
            return self.release(Release::BoardReset, out, law);
        }
        if s.override_locked {
            if !self.frozen {
                law.set_frozen(true);
                self.frozen = true;
                out.events.push(Event::Frozen(true));
            }
            out.write_override = self.held();
            return;
        }
        if self.frozen {
            law.set_frozen(false);
            self.frozen = false;
            out.events.push(Event::Frozen(false));
        }
        if s.acc_active {
            self.acc_confirmed = true;
            if !s.board_restarted && input.write_error.is_none() {
                self.rearms = 0;
                self.outage = false;
            }
        } else {
            self.arm_age = self.arm_age.saturating_add(1);
            if self.arm_age > self.cfg.ack_periods {
                out.fault = true;
                return self.release(Release::NoBoardAck, out, law);
            }
        }
        // Link failures (e.g. a write error with a good read) and power budget.
        if self.link_failures > self.cfg.link_hold_periods {
            return self.release(Release::LinkLost, out, law);
        }
        if self.invalid_count > self.cfg.invalid_power_periods {
            return self.release(Release::PowerInvalid, out, law);
        }
        let last = self.held().map_or_else(
            || self.quantize(s.override_applied_pct, s.override_step_pct),
            |c| c.0,
        );
        if self.link_failures > 0 {
            out.write_override = Some(FeedOverride(last));
            return;
        }
        // No record, no cut: a run log that cannot be written stops the feed.
        if input.log_stalled {
            out.events.push(Event::LogStalled);
            tracing::error!("the run log's writer has stalled past its buffer: feed hold");
            out.fault = true;
            return self.release(Release::LogStalled, out, law);
        }
        // The line's delay against what the gains in use tolerate: never drive on into an
        // oscillation.
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
        // The control step, on the feed the loop computed once for this period.
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
        let step = law.step(&m);
        self.force_ref_n = Some(step.trace.force_ref_n);
        let mut cmd = self.quantize(step.command.0, s.override_step_pct);
        if !force_valid {
            cmd = cmd.min(last);
        }
        if let Some(knob) = self.knob_ceiling {
            cmd = cmd.min(self.quantize(knob, s.override_step_pct));
        }
        let law_cmd = cmd;
        let lim = self.shop_limits;
        if let Some(f) = lim.floor_pct.filter(|_| force_valid) {
            let step_pct = if s.override_step_pct == 0 {
                10
            } else {
                s.override_step_pct
            };
            cmd = cmd.max(self.quantize(f.div_ceil(step_pct) * step_pct, step_pct));
        }
        if let Some(c) = lim.cap_pct {
            cmd = cmd.min(self.quantize(c, s.override_step_pct));
        }
        if cmd != law_cmd {
            law.engage(FeedOverride(cmd));
        }
        self.last_cmd = Some(cmd);
        out.write_override = Some(FeedOverride(cmd));
        out.step = Some(step);
        out.measurement = Some(m);
    }
}

/// The measured extra delay and the margin when the delay exceeds the margin: the
/// estimate has been later than the designed 1 period on at least two informative
/// periods in a row (`late_streak`) and
/// is more periods late than the law's gains tolerate. `None` when the law cannot judge
/// its margin (no model: the comparison baselines).
///
/// A confirmed replay of the board's past (`replay_lag_periods`: `SAMPLE_SEQ` went back and
/// the next read went on from there) is judged at once: its very first sample is already
/// that many periods old.
///
/// `margin` is asked only when a delay was measured (the margin's Schur–Cohn scan stays off
/// the control period otherwise).
pub fn delay_exceeded(
    d: &crate::echo::DelayReading,
    margin: impl FnOnce() -> Option<u32>,
) -> Option<(u32, u32)> {
    let echo = d
        .echo_periods
        .filter(|_| d.late_streak >= 2)
        .map(|e| e.saturating_sub(1));
    let extra = echo.max(d.replay_lag_periods).filter(|e| *e > 0)?;
    let margin = margin()?;
    (extra > margin).then_some((extra, margin))
}
