//! Test doubles for the runtime: a scripted [`Board`] built on the board's own
//! [`BoardLogic`] (so every register rule of the spec holds), a scripted [`OverrideLaw`],
//! and a linear power-to-force source. Used by the unit tests here and by `tests/runtime_*`.

use std::collections::VecDeque;

use acc_core::{
    FeedOverride, ForceSample, ForceSource, Measurement, Mode, OverrideLaw, PeriodInput,
    Saturation, StepOutput, Trace,
};
use acc_pmc::emu::{BoardLogic, EmulatedProtocol, Request};
use acc_pmc::regs::{holding, OverrideResolution};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};

/// Error of [`ScriptedBoard`]: just the kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("scripted board error: {0:?}")]
pub struct ScriptedError(pub BoardErrorKind);

impl BoardError for ScriptedError {
    fn kind(&self) -> BoardErrorKind {
        self.0
    }
}

/// What the scripted link does with one transaction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkFault {
    /// The request reaches the board, the reply is lost or corrupt (the write took effect).
    ReplyLost(BoardErrorKind),
    /// The request never reaches the board.
    RequestLost(BoardErrorKind),
}

/// A [`Board`] over an in-memory [`BoardLogic`] with a script of link faults and a manual
/// board time (ms), advanced by the test.
#[derive(Debug, Clone)]
pub struct ScriptedBoard {
    /// The board (the test sets switches, power, … on it).
    pub board: BoardLogic,
    /// Board time, ms.
    pub now_ms: u64,
    /// Faults applied to the next transactions, one per transaction (`None` = clean).
    pub faults: VecDeque<Option<LinkFault>>,
    /// Every override/heartbeat write that reached the board: `(override, heartbeat)`.
    pub override_writes: Vec<(u16, u16)>,
    /// Every control write that reached the board.
    pub control_writes: Vec<ControlBits>,
}

impl ScriptedBoard {
    /// A 10 %-step v2 board with the operator's switch on at 100 %, cycle active.
    pub fn new() -> Self {
        Self::with_protocol(EmulatedProtocol::V2)
    }

    /// As [`ScriptedBoard::new`], a v1 board (exception 02 for registers 9…14: no fallback
    /// clamp, no `BOARD_RESTARTED`).
    pub fn v1() -> Self {
        Self::with_protocol(EmulatedProtocol::V1Exception)
    }

    /// As [`ScriptedBoard::new`], speaking `protocol`.
    pub fn with_protocol(protocol: EmulatedProtocol) -> Self {
        let mut board = BoardLogic::with_protocol(OverrideResolution::Percent10, protocol);
        board.set_acc_switch(true);
        board.set_operator_override_pct(100);
        board.set_cycle_active(true);
        board.set_programmed_feed_mm_min(200);
        board.set_spindle_rpm(600);
        Self {
            board,
            now_ms: 0,
            faults: VecDeque::new(),
            override_writes: Vec::new(),
            control_writes: Vec::new(),
        }
    }

    /// Queue `n` transactions with `fault`.
    pub fn inject(&mut self, fault: LinkFault, n: usize) {
        self.faults.extend(std::iter::repeat_n(Some(fault), n));
    }

    fn transact<T>(
        &mut self,
        apply: impl FnOnce(&mut Self) -> Result<T, ScriptedError>,
    ) -> Result<T, ScriptedError> {
        match self.faults.pop_front().flatten() {
            None => apply(self),
            Some(LinkFault::RequestLost(k)) => Err(ScriptedError(k)),
            Some(LinkFault::ReplyLost(k)) => {
                let _ = apply(self);
                Err(ScriptedError(k))
            }
        }
    }
}

impl Default for ScriptedBoard {
    fn default() -> Self {
        Self::new()
    }
}

impl Board for ScriptedBoard {
    type Error = ScriptedError;

    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        self.transact(|s| {
            s.board.tick(s.now_ms);
            Ok(s.board.status())
        })
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error> {
        self.transact(|s| {
            let req = Request::WriteMultiple {
                addr: holding::OVERRIDE_CMD,
                values: vec![override_pct, heartbeat],
            };
            s.board
                .handle(req, s.now_ms)
                .map_err(|e| ScriptedError(BoardErrorKind::Exception(e.code())))?;
            s.override_writes.push((override_pct, heartbeat));
            Ok(())
        })
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error> {
        self.transact(|s| {
            let req = Request::WriteSingle {
                addr: holding::CONTROL,
                value: control.to_register(),
            };
            s.board
                .handle(req, s.now_ms)
                .map_err(|e| ScriptedError(BoardErrorKind::Exception(e.code())))?;
            s.control_writes.push(control);
            Ok(())
        })
    }

    /// The emulated board's protocol (as a link would find it).
    fn protocol(&self) -> Option<BoardProtocol> {
        Some(if self.board.protocol().is_v2() {
            BoardProtocol::V2
        } else {
            BoardProtocol::V1
        })
    }
}

/// Force = `n_per_w` × power (a stand-in for the spindle-power force source); invalid when
/// the power is absent.
#[derive(Debug, Clone, Copy)]
pub struct LinearPowerForce {
    /// N per W.
    pub n_per_w: f64,
}

impl ForceSource for LinearPowerForce {
    fn name(&self) -> &str {
        "linear-power"
    }

    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample {
        match input.power_w {
            Some(p) => ForceSample {
                force_n: p * self.n_per_w,
                power_w: Some(p),
                valid: true,
            },
            None => ForceSample::INVALID,
        }
    }
}

/// A law that commands a scripted sequence (the last value repeats) and records how it is
/// driven.
#[derive(Debug, Clone, Default)]
pub struct ScriptedLaw {
    /// Commands returned by successive `step` calls, percent.
    pub script: VecDeque<u16>,
    /// Value returned once the script is empty (default: the engage value).
    pub hold: u16,
    /// `engage` calls.
    pub engaged: Vec<u16>,
    /// `set_frozen` calls.
    pub frozen_calls: Vec<bool>,
    /// Measurements seen by `step`.
    pub seen: Vec<Measurement>,
    /// Fr the law reports in its trace, N (`None`: NaN, as a law without one).
    pub force_ref_n: Option<f64>,
}

impl ScriptedLaw {
    /// A law that returns `script` then repeats its last value.
    pub fn new(script: impl IntoIterator<Item = u16>) -> Self {
        Self {
            script: script.into_iter().collect(),
            ..Self::default()
        }
    }
}

/// A trace with every number NaN (for laws that have none).
pub fn empty_trace(mode: Mode) -> Trace {
    Trace {
        force_ref_n: f64::NAN,
        error_n: f64::NAN,
        kc_hat: f64::NAN,
        kp: f64::NAN,
        ki: f64::NAN,
        integral_mm_min: f64::NAN,
        feed_cmd_mm_min: f64::NAN,
        unquantized_pct: f64::NAN,
        saturation: Saturation::None,
        mode,
        estimator_active: false,
        excitation: 0.0,
    }
}

impl OverrideLaw for ScriptedLaw {
    fn name(&self) -> &str {
        "scripted"
    }

    fn engage(&mut self, current: FeedOverride) {
        self.engaged.push(current.0);
        self.hold = current.0;
    }

    fn step(&mut self, m: &Measurement) -> StepOutput {
        self.seen.push(*m);
        if let Some(v) = self.script.pop_front() {
            self.hold = v;
        }
        let mut trace = empty_trace(Mode::Baseline);
        if let Some(fr) = self.force_ref_n {
            trace.force_ref_n = fr;
        }
        StepOutput {
            command: FeedOverride(self.hold),
            trace,
        }
    }

    fn set_frozen(&mut self, frozen: bool) {
        self.frozen_calls.push(frozen);
    }
}
