//! The line guard: every register of a status read is checked against its range and its
//! physics, and every change is confirmed, before any rule of the loop acts on it.
//!
//! Modbus RTU has no transaction id, and a reply with a valid CRC can still carry a wrong
//! value (a flipped bit in a gateway's buffer, a converter that answers for the wrong slave
//! with a well-formed frame). A value the rules would act on — the operator's knob, the ACC
//! switch, the NC's lock, the power the force is estimated from — must therefore be
//! believable before it means anything. Three classes of register:
//!
//! - **Implausible** (the sample is invalid, never used, flagged `implausible:<register>`):
//!   an override or knob above 150 % or off the board's `OVERRIDE_STEP` grid, an
//!   `OVERRIDE_STEP` other than 1 or 10 or other than the board's first, a power above the
//!   spindle's rating (`max_power_w`), a `PROTOCOL_VERSION` that changed, a
//!   `FALLBACK_OVERRIDE` above 150 %.
//! - **Held for confirmation** (the sample is not used this period: the command may go down
//!   but not up; flagged `unconfirmed:<register>`): any change of a `STATUS` bit (ACC switch,
//!   ACC active, cycle, feed hold, watchdog, NC lock, CNC alarm, clamp, restart), a power
//!   change larger than `max_power_step_w` in one period, a spindle speed change larger than
//!   `max_rpm_step`, a `SAMPLE_SEQ` that does not advance by 0 ..= (periods since the last
//!   accepted read + 1), an `OVERRIDE_APPLIED` that is none of the recent commands, the knob
//!   or the clamp. The change counts once `debounce_reads` consecutive reads agree (default
//!   2: the next read confirms it); a change the next read does not repeat was a bad frame.
//! - **Debounced** (the old value stays in force until confirmed, the sample is still used;
//!   flagged `unconfirmed:<register>`): the operator's knob, `PROGRAMMED_FEED`, tool,
//!   program and block numbers, `FALLBACK_OVERRIDE`.
//!
//! `ACTUAL_FEED` is only read by the loop-delay measurement ([`crate::echo`]) and passes
//! through. A real operator act therefore costs `debounce_reads − 1` periods of reaction
//! time (0.1 s with the defaults), measured in `docs/runtime.md`.
//!
//! ```
//! use acc_pmc::BoardStatus;
//! use acc_runtime::guard::{Expected, GuardConfig, LineGuard, Register};
//! let mut g = LineGuard::new(GuardConfig::default());
//! let s = BoardStatus { acc_switch: true, cycle_active: true, override_applied_pct: 100,
//!     operator_override_pct: 100, override_step_pct: 10, spindle_power_w: 900,
//!     sample_seq: 1, fallback_override_pct: 150, ..BoardStatus::default() };
//! assert!(!g.check(Ok(s), &Expected::default()).hold);
//! // 16 484 %: a flipped bit in the knob register is never the operator.
//! let bad = BoardStatus { operator_override_pct: 16_484, sample_seq: 2, ..s };
//! let v = g.check(Ok(bad), &Expected::default());
//! assert!(v.hold);
//! assert_eq!(v.implausible, Some(Register::OperatorOverride));
//! assert_eq!(v.status.map(|s| s.operator_override_pct), Some(100));
//! ```

use acc_pmc::{BoardErrorKind, BoardStatus};

/// Longest replay of the board's past the guard recognises, periods: a buffering gateway
/// holds a few replies; a `SAMPLE_SEQ` further back is a sensor that restarted.
pub const MAX_REPLAY_PERIODS: u16 = 16;

/// Limits of the line guard (the run config's `[policy]` keys of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardConfig {
    /// Consecutive reads a changed value must hold before it counts, 1 ..= 10 (default 2;
    /// 1 = no debounce).
    pub debounce_reads: u32,
    /// The spindle's largest plausible input power, W (default 30 000).
    pub max_power_w: f64,
    /// Largest plausible change of the spindle power between two consecutive samples, W
    /// (default 2 000).
    pub max_power_step_w: f64,
    /// Largest plausible change of the spindle speed between two consecutive samples, rpm
    /// (default 1 000).
    pub max_rpm_step: f64,
}

impl Default for GuardConfig {
    fn default() -> Self {
        Self {
            debounce_reads: 2,
            max_power_w: 30_000.0,
            max_power_step_w: 2_000.0,
            max_rpm_step: 1_000.0,
        }
    }
}

/// A register of the board's status (names as in `pmc-board.md`, lower case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Register {
    /// `STATUS` bits.
    Status,
    /// `OVERRIDE_APPLIED`.
    OverrideApplied,
    /// `OPERATOR_OVERRIDE`.
    OperatorOverride,
    /// `OVERRIDE_STEP`.
    OverrideStep,
    /// `POWER_HI:POWER_LO`.
    Power,
    /// `SPINDLE_RPM`.
    SpindleRpm,
    /// `SAMPLE_SEQ`.
    SampleSeq,
    /// `PROGRAMMED_FEED`.
    ProgrammedFeed,
    /// `PROTOCOL_VERSION`.
    ProtocolVersion,
    /// `TOOL_NUMBER`.
    ToolNumber,
    /// `PROGRAM_NUMBER`.
    ProgramNumber,
    /// `BLOCK_NUMBER`.
    BlockNumber,
    /// `FALLBACK_OVERRIDE`.
    FallbackOverride,
}

impl Register {
    /// Name for the run log's flags (`status`, `override_applied`, `operator_override`, …).
    pub fn name(self) -> &'static str {
        match self {
            Register::Status => "status",
            Register::OverrideApplied => "override_applied",
            Register::OperatorOverride => "operator_override",
            Register::OverrideStep => "override_step",
            Register::Power => "power",
            Register::SpindleRpm => "spindle_rpm",
            Register::SampleSeq => "sample_seq",
            Register::ProgrammedFeed => "programmed_feed",
            Register::ProtocolVersion => "protocol_version",
            Register::ToolNumber => "tool_number",
            Register::ProgramNumber => "program_number",
            Register::BlockNumber => "block_number",
            Register::FallbackOverride => "fallback_override",
        }
    }
}

/// What the loop expects of the next read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Expected {
    /// Overrides ACC wrote in the last periods (up to 8), newest first.
    pub commands: [u16; 8],
    /// How many of `commands` are set.
    pub count: usize,
    /// `ACC_REQUEST` is set on the board.
    pub acc_requested: bool,
}

impl Expected {
    /// The recent commands.
    pub fn recent_commands(&self) -> &[u16] {
        &self.commands[..self.count.min(self.commands.len())]
    }
}

/// What the guard made of one read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guarded {
    /// The status the rules see: the read with every unconfirmed debounced value replaced
    /// by the one in force; when `hold`, the last accepted status. `None` before any read
    /// was accepted.
    pub status: Option<BoardStatus>,
    /// Do not use this period's sample: the force is invalid, the command may not rise.
    pub hold: bool,
    /// The first value found out of range or physically impossible.
    pub implausible: Option<Register>,
    /// The first changed value not yet confirmed (held or debounced).
    pub unconfirmed: Option<Register>,
    /// This read confirmed that `SAMPLE_SEQ` went back, with no restart to explain it: the
    /// line delivers the board's past, this many periods late (a buffering gateway).
    pub replay_lag_periods: Option<u32>,
}

impl Guarded {
    fn accepted(status: BoardStatus, unconfirmed: Option<Register>) -> Self {
        Self {
            status: Some(status),
            hold: false,
            implausible: None,
            unconfirmed,
            replay_lag_periods: None,
        }
    }

    fn held(status: Option<BoardStatus>, why: Result<Register, Register>) -> Self {
        Self {
            status,
            hold: true,
            implausible: why.err(),
            unconfirmed: why.ok(),
            replay_lag_periods: None,
        }
    }
}

/// What the guard has caught since the run began.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GuardCounts {
    /// Reads with a value out of range or physically impossible (never used).
    pub implausible: u64,
    /// Reads held a period for confirmation (a changed STATUS bit, a jump).
    pub held: u64,
    /// Held changes the next read did not repeat (bad frames).
    pub discarded: u64,
    /// Reads with a debounced value not yet confirmed (the old value stayed in force).
    pub debounced: u64,
    /// Confirmed replays of the board's past (`SAMPLE_SEQ` went back with no restart).
    pub replays: u64,
}

/// A debounced register value: the one in force, and a candidate with its count.
#[derive(Debug, Clone, Copy, Default)]
struct Debounced {
    pending: Option<(u16, u32)>,
}

impl Debounced {
    /// The value in force after seeing `raw` (`current` until `raw` held `n` reads).
    fn step(&mut self, current: u16, raw: u16, n: u32) -> (u16, bool) {
        if raw == current {
            self.pending = None;
            return (current, false);
        }
        let count = match self.pending {
            Some((v, c)) if v == raw => c + 1,
            _ => 1,
        };
        if count >= n {
            self.pending = None;
            (raw, false)
        } else {
            self.pending = Some((raw, count));
            (current, true)
        }
    }
}

/// The guard's state between reads.
#[derive(Debug, Clone)]
pub struct LineGuard {
    cfg: GuardConfig,
    accepted: Option<BoardStatus>,
    /// A held read awaiting confirmation, and how many reads agreed so far.
    candidate: Option<(BoardStatus, u32)>,
    /// Periods since the accepted read (1 on the next read when every read answers).
    periods_since_accept: u32,
    first_step: Option<u16>,
    first_protocol: Option<u16>,
    knob: Debounced,
    programmed_feed: Debounced,
    tool: Debounced,
    program: Debounced,
    block: Debounced,
    fallback: Debounced,
    counts: GuardCounts,
}

fn status_bits(s: &BoardStatus) -> [bool; 9] {
    [
        s.acc_switch,
        s.acc_active,
        s.cycle_active,
        s.feed_hold_active,
        s.watchdog_tripped,
        s.override_locked,
        s.cnc_alarm,
        s.fallback_active,
        s.board_restarted,
    ]
}

fn on_grid(pct: u16, step: u16) -> bool {
    pct <= 150 && (step == 0 || pct.is_multiple_of(step))
}

impl LineGuard {
    /// A guard that has seen nothing yet.
    pub fn new(cfg: GuardConfig) -> Self {
        Self {
            cfg,
            accepted: None,
            candidate: None,
            periods_since_accept: 0,
            first_step: None,
            first_protocol: None,
            knob: Debounced::default(),
            programmed_feed: Debounced::default(),
            tool: Debounced::default(),
            program: Debounced::default(),
            block: Debounced::default(),
            fallback: Debounced::default(),
            counts: GuardCounts::default(),
        }
    }

    /// What the guard has caught so far.
    pub fn counts(&self) -> GuardCounts {
        self.counts
    }

    /// The limits.
    pub fn config(&self) -> &GuardConfig {
        &self.cfg
    }

    /// The last accepted status.
    pub fn accepted(&self) -> Option<&BoardStatus> {
        self.accepted.as_ref()
    }

    /// A period in which nothing was read (the ticker skipped it).
    pub fn skipped(&mut self) {
        self.periods_since_accept = self.periods_since_accept.saturating_add(1);
    }

    /// Check one period's read against what the loop expects (`expect`: the overrides ACC
    /// wrote in the last periods — an `OVERRIDE_APPLIED` equal to one of them is an echo,
    /// not a surprise — and whether `ACC_REQUEST` is on the board, so that `ACC_ACTIVE`
    /// rising is the board's answer).
    pub fn check(
        &mut self,
        link: Result<BoardStatus, BoardErrorKind>,
        expect: &Expected,
    ) -> Guarded {
        self.periods_since_accept = self.periods_since_accept.saturating_add(1);
        let raw = match link {
            Ok(s) => s,
            Err(_) => {
                return Guarded {
                    status: self.accepted,
                    hold: true,
                    implausible: None,
                    unconfirmed: None,
                    replay_lag_periods: None,
                }
            }
        };
        if let Some(reg) = self.implausible(&raw) {
            self.counts.implausible += 1;
            self.candidate = None;
            return Guarded::held(self.accepted, Err(reg));
        }
        let Some(acc) = self.accepted else {
            return self.accept(raw);
        };
        let g = self.judge_change(acc, raw, expect);
        if g.hold {
            self.counts.held += 1;
        }
        if !g.hold && g.unconfirmed.is_some() {
            self.counts.debounced += 1;
        }
        if g.replay_lag_periods.is_some() {
            self.counts.replays += 1;
        }
        g
    }

    /// A plausible read against the accepted status: accept it, hold it for confirmation,
    /// or accept it as the confirmation of the held one.
    fn judge_change(&mut self, acc: BoardStatus, raw: BoardStatus, expect: &Expected) -> Guarded {
        match self.surprise(&acc, &raw, expect) {
            None => {
                // No surprise against the accepted read. If the held read had gone back and
                // this one goes on from it, the line replays the board's past (a buffer
                // of two reads shows exactly this: s, s − 1, s).
                let replay = self.candidate.take().and_then(|(cand, _)| {
                    let lag = self.replay_lag(&acc, &cand, &raw);
                    if lag.is_none() {
                        self.counts.discarded += 1;
                    }
                    lag
                });
                let mut g = self.accept_debounced(acc, raw);
                g.replay_lag_periods = replay;
                g
            }
            Some(reg) => {
                let agreed = match self.candidate {
                    // The next read confirms the change when, taken against the held
                    // read, it holds no surprise of its own.
                    Some((cand, n)) if self.surprise(&cand, &raw, expect).is_none() => n + 1,
                    _ => 1,
                };
                if agreed >= self.cfg.debounce_reads {
                    let replay = self
                        .candidate
                        .and_then(|(cand, _)| self.replay_lag(&acc, &cand, &raw));
                    // The confirmed change replaces the state; debounced values are
                    // carried as confirmed with it.
                    self.candidate = None;
                    let mut g = self.accept_debounced(acc, raw);
                    g.replay_lag_periods = replay;
                    g
                } else {
                    self.candidate = Some((raw, agreed));
                    Guarded::held(self.accepted, Ok(reg))
                }
            }
        }
    }

    fn implausible(&mut self, s: &BoardStatus) -> Option<Register> {
        if !matches!(s.override_step_pct, 1 | 10)
            || self.first_step.is_some_and(|f| f != s.override_step_pct)
        {
            return Some(Register::OverrideStep);
        }
        let step = s.override_step_pct;
        if !on_grid(s.override_applied_pct, step) {
            return Some(Register::OverrideApplied);
        }
        if !on_grid(s.operator_override_pct, step) {
            return Some(Register::OperatorOverride);
        }
        if f64::from(s.spindle_power_w) > self.cfg.max_power_w {
            return Some(Register::Power);
        }
        if !matches!(s.protocol_version, 0 | 2)
            || self.first_protocol.is_some_and(|f| f != s.protocol_version)
        {
            return Some(Register::ProtocolVersion);
        }
        if s.fallback_override_pct > 150 {
            return Some(Register::FallbackOverride);
        }
        None
    }

    /// The first value that changed more than it physically can (held for confirmation).
    fn surprise(
        &self,
        acc: &BoardStatus,
        raw: &BoardStatus,
        expect: &Expected,
    ) -> Option<Register> {
        let mut was = status_bits(acc);
        if expect.acc_requested && raw.acc_active {
            // ACC_ACTIVE rising is the board's answer to ACC_REQUEST.
            was[1] = true;
        }
        if was != status_bits(raw) {
            return Some(Register::Status);
        }
        let recent = expect.recent_commands();
        let advance = raw.sample_seq.wrapping_sub(acc.sample_seq);
        if u32::from(advance) > self.periods_since_accept + 1 {
            return Some(Register::SampleSeq);
        }
        if (f64::from(raw.spindle_power_w) - f64::from(acc.spindle_power_w)).abs()
            > self.cfg.max_power_step_w
        {
            return Some(Register::Power);
        }
        if (f64::from(raw.spindle_rpm) - f64::from(acc.spindle_rpm)).abs() > self.cfg.max_rpm_step {
            return Some(Register::SpindleRpm);
        }
        let a = raw.override_applied_pct;
        let explained = a == acc.override_applied_pct
            || recent.contains(&a)
            || a == raw.operator_override_pct
            || a == acc.operator_override_pct
            || a == raw.fallback_override_pct
            || a == acc.fallback_override_pct;
        if !explained {
            return Some(Register::OverrideApplied);
        }
        None
    }

    /// How many periods older than expected the confirming read `raw`'s sample is, when
    /// the held read `cand` had `SAMPLE_SEQ` go back from `acc` by at most
    /// [`MAX_REPLAY_PERIODS`], `raw` goes on from `cand` at the board's cadence (one sample
    /// per period, or two: a sample tick that fell just before the read, as
    /// [`crate::echo`] allows a lone skip) and the board's state bits are unchanged (no
    /// restart to explain it). A sequence that jumps further back or stands still is a
    /// sensor that restarted or froze, judged by the power rules, not a replay.
    fn replay_lag(&self, acc: &BoardStatus, cand: &BoardStatus, raw: &BoardStatus) -> Option<u32> {
        let expected = acc
            .sample_seq
            .wrapping_add(self.periods_since_accept as u16);
        let behind = expected.wrapping_sub(raw.sample_seq);
        let went_back = cand.sample_seq.wrapping_sub(acc.sample_seq) >= 0x8000;
        let continues = matches!(raw.sample_seq.wrapping_sub(cand.sample_seq), 1 | 2);
        let same_board = !raw.board_restarted
            && raw.watchdog_tripped == acc.watchdog_tripped
            && (raw.acc_active || !acc.acc_active);
        (went_back && continues && same_board && (1..=MAX_REPLAY_PERIODS).contains(&behind))
            .then_some(u32::from(behind))
    }

    fn accept(&mut self, s: BoardStatus) -> Guarded {
        self.first_step.get_or_insert(s.override_step_pct);
        self.first_protocol.get_or_insert(s.protocol_version);
        self.accepted = Some(s);
        self.periods_since_accept = 0;
        Guarded::accepted(s, None)
    }

    /// Accept `raw` with its debounced registers kept at `acc`'s values until confirmed.
    fn accept_debounced(&mut self, acc: BoardStatus, raw: BoardStatus) -> Guarded {
        let n = self.cfg.debounce_reads;
        let mut s = raw;
        let mut unconfirmed = None;
        let mut note = |pending: bool, reg: Register| {
            if pending && unconfirmed.is_none() {
                unconfirmed = Some(reg);
            }
        };
        let (v, p) = self
            .knob
            .step(acc.operator_override_pct, raw.operator_override_pct, n);
        s.operator_override_pct = v;
        note(p, Register::OperatorOverride);
        let (v, p) =
            self.programmed_feed
                .step(acc.programmed_feed_mm_min, raw.programmed_feed_mm_min, n);
        s.programmed_feed_mm_min = v;
        note(p, Register::ProgrammedFeed);
        let (v, p) = self.tool.step(acc.tool_number, raw.tool_number, n);
        s.tool_number = v;
        note(p, Register::ToolNumber);
        let (v, p) = self.program.step(acc.program_number, raw.program_number, n);
        s.program_number = v;
        note(p, Register::ProgramNumber);
        let (v, p) = self.block.step(acc.block_number, raw.block_number, n);
        s.block_number = v;
        note(p, Register::BlockNumber);
        let (v, p) = self
            .fallback
            .step(acc.fallback_override_pct, raw.fallback_override_pct, n);
        s.fallback_override_pct = v;
        note(p, Register::FallbackOverride);
        self.accepted = Some(s);
        self.periods_since_accept = 0;
        Guarded::accepted(s, unconfirmed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> BoardStatus {
        BoardStatus {
            acc_switch: true,
            acc_active: true,
            cycle_active: true,
            override_applied_pct: 70,
            operator_override_pct: 100,
            override_step_pct: 10,
            spindle_power_w: 900,
            spindle_rpm: 600,
            sample_seq: 10,
            programmed_feed_mm_min: 200,
            protocol_version: 2,
            tool_number: 1,
            block_number: 20,
            fallback_override_pct: 150,
            ..BoardStatus::default()
        }
    }

    fn ex(cmds: &[u16]) -> Expected {
        let mut e = Expected {
            count: cmds.len(),
            acc_requested: true,
            ..Expected::default()
        };
        e.commands[..cmds.len()].copy_from_slice(cmds);
        e
    }

    fn next(s: BoardStatus) -> BoardStatus {
        BoardStatus {
            sample_seq: s.sample_seq.wrapping_add(1),
            ..s
        }
    }

    #[test]
    fn a_clean_stream_passes_untouched() {
        let mut g = LineGuard::new(GuardConfig::default());
        let mut s = base();
        for _ in 0..20 {
            let v = g.check(Ok(s), &ex(&[70]));
            assert!(!v.hold && v.implausible.is_none() && v.unconfirmed.is_none());
            assert_eq!(v.status, Some(s));
            s = next(s);
        }
    }

    #[test]
    fn out_of_range_values_are_implausible_and_never_seen() {
        type Corrupt = fn(&mut BoardStatus);
        let cases: [(Corrupt, Register); 6] = [
            (
                |s| s.operator_override_pct = 16_484,
                Register::OperatorOverride,
            ),
            (|s| s.operator_override_pct = 65, Register::OperatorOverride),
            (|s| s.override_applied_pct = 71, Register::OverrideApplied),
            (|s| s.override_step_pct = 3, Register::OverrideStep),
            (|s| s.spindle_power_w = u32::MAX, Register::Power),
            (|s| s.protocol_version = 0, Register::ProtocolVersion),
        ];
        for (bad, reg) in cases {
            let mut g = LineGuard::new(GuardConfig::default());
            let s = base();
            g.check(Ok(s), &ex(&[70]));
            let mut b = next(s);
            bad(&mut b);
            let v = g.check(Ok(b), &ex(&[70]));
            assert!(v.hold, "{reg:?}");
            assert_eq!(v.implausible, Some(reg));
            assert_eq!(v.status, Some(s), "the last accepted status stands");
        }
    }

    #[test]
    fn a_status_bit_counts_only_when_the_next_read_repeats_it() {
        let mut g = LineGuard::new(GuardConfig::default());
        let s = base();
        g.check(Ok(s), &ex(&[70]));
        // A flipped switch bit in one frame: held, then discarded.
        let flipped = BoardStatus {
            acc_switch: false,
            ..next(s)
        };
        let v = g.check(Ok(flipped), &ex(&[70]));
        assert!(v.hold);
        assert_eq!(v.unconfirmed, Some(Register::Status));
        assert!(v.status.expect("a status").acc_switch);
        let back = next(next(s));
        let v = g.check(Ok(back), &ex(&[70]));
        assert!(!v.hold);
        assert!(v.status.expect("a status").acc_switch);
        // A real switch-off: seen twice, then it counts (one period later).
        let off = BoardStatus {
            acc_switch: false,
            ..next(back)
        };
        assert!(g.check(Ok(off), &ex(&[70])).hold);
        let v = g.check(Ok(next(off)), &ex(&[70]));
        assert!(!v.hold);
        assert!(!v.status.expect("a status").acc_switch);
    }

    #[test]
    fn the_knob_is_debounced_without_holding_the_sample() {
        let mut g = LineGuard::new(GuardConfig::default());
        let s = base();
        g.check(Ok(s), &ex(&[70]));
        let down = BoardStatus {
            operator_override_pct: 60,
            ..next(s)
        };
        let v = g.check(Ok(down), &ex(&[70]));
        assert!(!v.hold);
        assert_eq!(v.unconfirmed, Some(Register::OperatorOverride));
        assert_eq!(v.status.expect("a status").operator_override_pct, 100);
        let v = g.check(Ok(next(down)), &ex(&[70]));
        assert_eq!(v.status.expect("a status").operator_override_pct, 60);
        // Without debounce the first read counts.
        let mut g = LineGuard::new(GuardConfig {
            debounce_reads: 1,
            ..GuardConfig::default()
        });
        g.check(Ok(s), &ex(&[70]));
        assert_eq!(
            g.check(Ok(down), &ex(&[70]))
                .status
                .expect("a status")
                .operator_override_pct,
            60
        );
    }

    #[test]
    fn power_jumps_and_sequence_jumps_need_confirmation() {
        let mut g = LineGuard::new(GuardConfig::default());
        let s = base();
        g.check(Ok(s), &ex(&[70]));
        // A high power bit: held, the next normal read discards it.
        let spike = BoardStatus {
            spindle_power_w: 900 + 16_384,
            ..next(s)
        };
        let v = g.check(Ok(spike), &ex(&[70]));
        assert_eq!((v.hold, v.unconfirmed), (true, Some(Register::Power)));
        let v = g.check(Ok(next(next(s))), &ex(&[70]));
        assert!(!v.hold);
        // A sequence that jumps back (a buffering gateway's first stale reply) is held and,
        // when the stream goes on from there, accepted.
        let back = BoardStatus { sample_seq: 9, ..s };
        let v = g.check(Ok(back), &ex(&[70]));
        assert_eq!((v.hold, v.unconfirmed), (true, Some(Register::SampleSeq)));
        let v = g.check(Ok(next(back)), &ex(&[70]));
        assert!(!v.hold);
        assert_eq!(v.status.expect("a status").sample_seq, 10);
        // The last accepted read was 12, two periods ago: 14 was due, 10 came: the line
        // replays the board's past 4 periods late.
        assert_eq!(v.replay_lag_periods, Some(4));
        // A 2-read buffer: 20 accepted, then 19 (held), then 20 again: 22 was due.
        let mut g = LineGuard::new(GuardConfig::default());
        let at = |seq: u16| BoardStatus {
            sample_seq: seq,
            ..s
        };
        g.check(Ok(at(20)), &ex(&[70]));
        assert!(g.check(Ok(at(19)), &ex(&[70])).hold);
        let v = g.check(Ok(at(20)), &ex(&[70]));
        assert!(!v.hold);
        assert_eq!(v.replay_lag_periods, Some(2));
        // A 6-read buffer whose confirming read finds one sample more (the board's tick
        // just before the read): 40 accepted, 35 (held), 37: 42 was due, 5 late.
        let mut g = LineGuard::new(GuardConfig::default());
        g.check(Ok(at(40)), &ex(&[70]));
        assert!(g.check(Ok(at(35)), &ex(&[70])).hold);
        let v = g.check(Ok(at(37)), &ex(&[70]));
        assert_eq!(v.replay_lag_periods, Some(5));
        // A sequence that goes back and then stands still is no replay (a sensor that
        // restarted and froze: the power rules judge it).
        let mut g = LineGuard::new(GuardConfig::default());
        g.check(Ok(at(40)), &ex(&[70]));
        assert!(g.check(Ok(at(35)), &ex(&[70])).hold);
        assert_eq!(g.check(Ok(at(35)), &ex(&[70])).replay_lag_periods, None);
    }

    #[test]
    fn an_applied_override_nobody_asked_for_is_held() {
        let mut g = LineGuard::new(GuardConfig::default());
        let s = base();
        g.check(Ok(s), &ex(&[70]));
        let odd = BoardStatus {
            override_applied_pct: 130,
            ..next(s)
        };
        let v = g.check(Ok(odd), &ex(&[70, 80]));
        assert_eq!(
            (v.hold, v.unconfirmed),
            (true, Some(Register::OverrideApplied))
        );
        let echo = BoardStatus {
            override_applied_pct: 80,
            ..next(s)
        };
        assert!(!g.check(Ok(echo), &ex(&[70, 80])).hold);
    }

    #[test]
    fn a_link_error_holds_with_the_last_accepted_status() {
        let mut g = LineGuard::new(GuardConfig::default());
        let s = base();
        g.check(Ok(s), &ex(&[]));
        let v = g.check(Err(BoardErrorKind::Timeout), &ex(&[]));
        assert!(v.hold);
        // Two periods later the sequence may have advanced by two.
        let v = g.check(Ok(next(next(s))), &ex(&[]));
        assert!(!v.hold, "{v:?}");
    }
}
