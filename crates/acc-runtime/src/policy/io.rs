//! What the runtime hands the policy once per period and what the policy hands back: the
//! input, the output and the period's events.

use acc_core::{FeedOverride, ForceSample, Measurement, StepOutput};
use acc_pmc::{BoardErrorKind, BoardStatus, ControlBits};

use super::{AccState, Alarms, Rearm, Release};
use crate::watch::Breakage;

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

    pub(crate) fn push(&mut self, e: Event) {
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
pub struct PolicyInput {
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
    /// releases with a feed hold and does not arm (`log.rs`).
    pub log_stalled: bool,
}

/// What the runtime does with the board this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolicyOutput {
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
    /// The settle judge's cap on the law's command this period, percent (`policy/settle.rs`:
    /// after a fault input, no higher than what ACC allowed before it); logged
    /// `settle:<pct>`.
    pub settle_cap: Option<u16>,
    /// The restart judge's cap on the law's command this period, percent
    /// (`policy/restart.rs`: a program stopped in a cut, the new cycle's cut not yet
    /// measured); logged as `restart:<pct>`.
    pub restart_cap: Option<u16>,
}
