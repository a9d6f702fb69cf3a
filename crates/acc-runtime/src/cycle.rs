//! One controller cycle against any [`Board`]: read the status, make a force sample of it,
//! run the [`FaultPolicy`] (which steps the law), write the override with the heartbeat and
//! the `CONTROL` bits when they change.
//!
//! The cycle is split so that the threaded runtime can run the I/O on one thread and the
//! decision on another ([`ControlLoop::decide`] is pure: no I/O, no clock), while a
//! single-threaded caller (tests, the simulator on a manual clock) uses
//! [`ControlLoop::cycle`].

use acc_core::{ForceSample, ForceSource, OverrideLaw, PeriodInput};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardStatus, ControlBits};

use crate::policy::{CycleInput, CycleOutput, FaultPolicy};

/// The writes one period asks of the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WritePlan {
    /// `OVERRIDE_CMD` and `HEARTBEAT` to write (function 16), if any.
    pub override_and_heartbeat: Option<(u16, u16)>,
    /// `CONTROL` bits to write, if they differ from what the board was last given.
    pub control: Option<ControlBits>,
}

/// Outcome of a [`WritePlan`].
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
pub struct CycleRecord {
    /// Period index.
    pub index: u64,
    /// Time of the period, s since start.
    pub t_s: f64,
    /// Status read, or the link error.
    pub link: Result<BoardStatus, BoardErrorKind>,
    /// The force source's sample.
    pub force: ForceSample,
    /// The policy's decision.
    pub out: CycleOutput,
    /// The writes asked for.
    pub plan: WritePlan,
}

/// Perform a write plan on a board.
pub fn execute_writes<P: Board>(pmc: &mut P, plan: &WritePlan) -> WriteResult {
    let mut r = WriteResult::default();
    if let Some((cmd, hb)) = plan.override_and_heartbeat {
        if let Err(e) = pmc.write_override(cmd, hb) {
            r.override_error = Some(e.kind());
        }
    }
    if let Some(c) = plan.control {
        match pmc.write_control(c) {
            Ok(()) => r.control_written = Some(c),
            Err(e) => r.control_error = Some(e.kind()),
        }
    }
    r
}

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
}

impl<L: OverrideLaw, F: ForceSource> ControlLoop<L, F> {
    /// A loop with period `period_s` (s).
    pub fn new(policy: FaultPolicy, law: L, source: F, period_s: f64) -> Self {
        Self {
            policy,
            law,
            source,
            period_s,
            index: 0,
            heartbeat: 0,
            control_on_board: None,
            write_error: None,
        }
    }

    /// The policy (state, alarms).
    pub fn policy(&self) -> &FaultPolicy {
        &self.policy
    }

    /// The law.
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Decide this period from the status read (or link error) at time `t_s`. Pure.
    pub fn decide(&mut self, t_s: f64, link: Result<BoardStatus, BoardErrorKind>) -> CycleRecord {
        let force = match link {
            Ok(s) => {
                let programmed = f64::from(s.programmed_feed_mm_min);
                let input = PeriodInput {
                    period_s: self.period_s,
                    spindle_rpm: f64::from(s.spindle_rpm),
                    feed_mm_min: programmed * f64::from(s.override_applied_pct) / 100.0,
                    true_force_n: None,
                    power_w: Some(f64::from(s.spindle_power_w)),
                    phases: None,
                };
                self.source.estimate(&input)
            }
            Err(_) => ForceSample::INVALID,
        };
        let input = CycleInput {
            t_s,
            link,
            write_error: self.write_error.take(),
            force,
        };
        let out = self.policy.step(&input, &mut self.law);
        let mut plan = WritePlan::default();
        if let Some(cmd) = out.write_override {
            self.heartbeat = self.heartbeat.wrapping_add(1);
            plan.override_and_heartbeat = Some((cmd.0, self.heartbeat));
        }
        if self.control_on_board != Some(out.control) {
            plan.control = Some(out.control);
        }
        let rec = CycleRecord {
            index: self.index,
            t_s,
            link,
            force,
            out,
            plan,
        };
        self.index += 1;
        rec
    }

    /// Report how the plan's writes went (feeds the next period's policy input).
    pub fn writes_done(&mut self, r: &WriteResult) {
        if let Some(c) = r.control_written {
            self.control_on_board = Some(c);
        }
        self.write_error = r.error();
    }

    /// One full period on `pmc` at time `t_s`: read, decide, write.
    pub fn cycle<P: Board>(&mut self, pmc: &mut P, t_s: f64) -> CycleRecord {
        let link = pmc.read_status().map_err(|e| e.kind());
        let rec = self.decide(t_s, link);
        let r = execute_writes(pmc, &rec.plan);
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

    /// The `CONTROL` bits of an orderly stop (moves the policy to idle).
    pub fn shutdown_bits(&mut self) -> ControlBits {
        self.policy.shutdown()
    }
}
