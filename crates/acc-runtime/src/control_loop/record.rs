//! What one period leaves behind: the writes it asks of the link ([`BoardWrites`]), their
//! outcome ([`WriteResult`]) and everything known about it ([`PeriodRecord`]), turned into
//! the run log's row ([`PeriodRecord::record`]) with its flags.

use acc_core::{ForceSample, Mode, Saturation};
use acc_pmc::{BoardErrorKind, BoardStatus, ControlBits};

use crate::echo::DelayReading;
use crate::guard::Guarded;
use crate::lookahead::LookAheadStep;
use crate::policy::PolicyOutput;
use crate::record::RunRecord;
use crate::shop::{ShopState, ShopStep};

/// The largest `SAMPLE_SEQ` advance logged as `seq_skip:<n>` (ten seconds of samples at
/// T = 0.1 s; a larger jump is a board restart, not missed samples).
pub const SEQ_SKIP_MAX: u16 = 100;

/// The writes one period asks of the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BoardWrites {
    /// `OVERRIDE_CMD` and `HEARTBEAT` to write (function 16), if any.
    pub override_and_heartbeat: Option<(u16, u16)>,
    /// `CONTROL` bits to write, if they differ from what the board was last given.
    pub control: Option<ControlBits>,
}

/// Outcome of a [`BoardWrites`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteResult {
    /// Error of the override/heartbeat write.
    pub override_error: Option<BoardErrorKind>,
    /// Error of the control write.
    pub control_error: Option<BoardErrorKind>,
    /// The control bits that reached the board (the plan's, if written without error).
    pub control_written: Option<ControlBits>,
}

impl WriteResult {
    /// The first error, if any.
    pub fn error(&self) -> Option<BoardErrorKind> {
        self.override_error.or(self.control_error)
    }
}

/// Everything known about one period, for the run log and tracing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodRecord {
    /// Period index.
    pub index: u64,
    /// Time of the period, s since start.
    pub t_s: f64,
    /// Status read, or the link error.
    pub link: Result<BoardStatus, BoardErrorKind>,
    /// Error of the previous period's writes, if any (reported to the policy this period).
    pub write_error: Option<BoardErrorKind>,
    /// Programmed feed the loop used, mm/min (`PROGRAMMED_FEED`, or the policy's nominal
    /// feed when the board reports 0); `None` without a status.
    pub programmed_feed_mm_min: Option<f64>,
    /// Actual feed of the period, mm/min (programmed × applied override); `None` without a
    /// status. Computed once here and used by the force source, the law and the path.
    pub feed_mm_min: Option<f64>,
    /// Path position after this period, mm: the integral of the actual feed (the last known
    /// feed carries over periods without a status).
    pub path_mm: f64,
    /// The force source's sample.
    pub force: ForceSample,
    /// The policy's decision.
    pub out: PolicyOutput,
    /// The writes asked for.
    pub writes: BoardWrites,
    /// What the shop layer (tool table, entry control) did, if the loop has one.
    pub shop: Option<ShopStep>,
    /// Force reference Fr of the tool in use, N (the shop layer's tool table; `None`
    /// without one or before the first status): the Fr the law holds after this period's
    /// tool change, logged also in periods where the law was not stepped.
    pub tool_force_ref_n: Option<f64>,
    /// What the line guard made of the read ([`crate::guard`]).
    pub guard: Guarded,
    /// The loop delay measured on the line ([`crate::echo`]).
    pub delay: DelayReading,
    /// Extra periods of dead time the law's gains tolerate (after this period's step).
    pub delay_margin_periods: Option<u32>,
    /// The run log's writer was stalled past the logger's buffer this period.
    pub log_stalled: bool,
    /// What the look-ahead decided, if the loop runs with a plan ([`crate::lookahead`]).
    pub lookahead: Option<LookAheadStep>,
}

/// Short name of an error kind for the run log's `flags` (`timeout`, `crc`, `exception_03`,
/// `disconnected`, `protocol`).
pub fn kind_name(k: BoardErrorKind) -> String {
    match k {
        BoardErrorKind::Timeout => "timeout".into(),
        BoardErrorKind::Crc => "crc".into(),
        BoardErrorKind::Exception(c) => format!("exception_{c:02}"),
        BoardErrorKind::Disconnected => "disconnected".into(),
        BoardErrorKind::Protocol => "protocol".into(),
    }
}

impl PeriodRecord {
    /// The period's run-log record (`force_ref_n`: Fr to log when the law was not stepped
    /// and no tool table gives the Fr of the tool in use).
    /// The plant-truth columns stay empty; the simulator fills them in.
    pub fn record(&self, force_ref_n: Option<f64>) -> RunRecord {
        let status = self.link.ok();
        let step = self.out.step;
        let trace = step.map(|o| o.trace);
        let mut r = RunRecord {
            t_s: self.t_s,
            period: self.index,
            x_mm: Some(self.path_mm),
            spindle_rpm: status.map(|s| f64::from(s.spindle_rpm)),
            programmed_feed_mm_min: self.programmed_feed_mm_min,
            feed_mm_min: self.feed_mm_min,
            power_w: status.map(|s| f64::from(s.spindle_power_w)),
            force_n: (status.is_some() && self.force.valid && self.force.force_n.is_finite())
                .then_some(self.force.force_n),
            force_valid: self.out.force_valid,
            force_ref_n: trace
                .map(|t| t.force_ref_n)
                .or(self.tool_force_ref_n)
                .or(force_ref_n),
            kc_hat: trace.map(|t| t.kc_hat),
            kp: trace.map(|t| t.kp),
            ki: trace.map(|t| t.ki),
            error_n: trace.map(|t| t.error_n),
            mode: trace.map_or_else(String::new, |t| mode_name(t.mode).to_string()),
            saturation: trace
                .map_or_else(String::new, |t| saturation_name(t.saturation).to_string()),
            override_cmd_pct: self.out.write_override.map(|o| o.0),
            heartbeat: self.writes.override_and_heartbeat.map(|(_, hb)| hb),
            override_applied_pct: status.map(|s| s.override_applied_pct),
            override_operator_pct: status.map(|s| s.operator_override_pct),
            state: self.out.state.name().to_string(),
            alarms: self.out.alarms.bits(),
            feed_hold: self.out.control.feed_hold_request,
            echo_delay_periods: self.delay.echo_periods,
            feed_echo_periods: self.delay.feed_echo_periods,
            seq_lag_periods: self.delay.seq_lag_periods,
            delay_margin_periods: self.delay_margin_periods,
            ..RunRecord::default()
        };
        // The NC context of a v2 board (0 = unknown there, an empty cell here).
        if let Some(s) = status.filter(|s| s.is_v2()) {
            let known = |v: u16| (v != 0).then_some(v);
            r.tool = known(s.tool_number);
            r.program = known(s.program_number);
            r.block = known(s.block_number);
            r.board_feed_mm_min = Some(f64::from(s.actual_feed_mm_min));
        }
        if let Err(k) = self.link {
            r.flag(&format!("link:{}", kind_name(k)));
        }
        if let Some(reg) = self.guard.implausible {
            r.flag(&format!("implausible:{}", reg.name()));
        }
        if let Some(reg) = self.guard.unconfirmed {
            r.flag(&format!("unconfirmed:{}", reg.name()));
        }
        if let Some(k) = self.write_error {
            r.flag(&format!("write:{}", kind_name(k)));
        }
        // Where the power sample sits in the board's sequence (a board restart starts it
        // again: a jump of more than `SEQ_SKIP_MAX` is not logged as a skip).
        match self.out.sample_advance {
            Some(0) => r.flag("seq_repeat"),
            Some(n) if (2..=SEQ_SKIP_MAX).contains(&n) => r.flag(&format!("seq_skip:{n}")),
            _ => {}
        }
        if status.is_some() && !self.out.force_valid {
            r.flag("force_invalid");
        }
        if self.out.fault {
            r.flag("fault");
        }
        if let Some(c) = self.out.settle_cap {
            r.flag(&format!("settle:{c}"));
        }
        if let Some(c) = self.out.restart_cap {
            r.flag(&format!("restart:{c}"));
        }
        if self.log_stalled {
            r.flag("log_stalled");
        }
        if let Some(la) = self.lookahead {
            la.flag_onto(&mut r);
        }
        if let Some(sh) = self.shop {
            if sh.state == ShopState::Entry {
                r.flag("entry");
            }
            if sh.tool_changed {
                r.flag("tool_change");
            }
            if sh.limited {
                r.flag("limit");
            }
        }
        for e in self.out.events.iter() {
            match e {
                crate::policy::Event::Rearmed { reason, .. } => {
                    r.flag(&format!("rearm:{}", reason.as_str()));
                }
                crate::policy::Event::Breakage(b) => r.flag(&format!("breakage:{}", b.kind())),
                crate::policy::Event::SpindleStopRequest => r.flag("overload:spindle_stop"),
                crate::policy::Event::DelayExceeded {
                    extra_periods,
                    margin_periods,
                } => r.flag(&format!("delay:{extra_periods}/{margin_periods}")),
                _ => {}
            }
        }
        r
    }
}

/// Whether the guard holds a block, tool or program number of the raw `read` until the
/// next read confirms it (the guarded status `accepted` differs).
pub(crate) fn context_pending(
    read: Result<BoardStatus, BoardErrorKind>,
    accepted: Option<&BoardStatus>,
) -> bool {
    match (read, accepted) {
        (Ok(raw), Some(st)) => {
            (raw.block_number, raw.tool_number, raw.program_number)
                != (st.block_number, st.tool_number, st.program_number)
        }
        _ => false,
    }
}

/// Run-log name of a law mode.
pub fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::AdaptivePi => "adaptive_pi",
        Mode::FixedPi => "fixed_pi",
        Mode::AdaptiveIntegral => "adaptive_integral",
        Mode::Baseline => "baseline",
    }
}

/// Run-log name of a saturation state.
pub fn saturation_name(s: Saturation) -> &'static str {
    match s {
        Saturation::None => "none",
        Saturation::Low => "low",
        Saturation::High => "high",
    }
}
