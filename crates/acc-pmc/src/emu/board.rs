//! The emulated PMC interface board, as a pure state machine (`../shared/docs/pmc-board.md`,
//! protocol v2, or v1 on request).
//!
//! [`BoardLogic`] holds the board's holding and input registers and implements every rule of
//! the spec's "Board behaviour" section. It never touches a port or a clock: time is passed in
//! as milliseconds (`now_ms`, any monotonic origin) so that the simulator can run it on a
//! manual clock and the Modbus server (`RtuServer`) on the wall clock.
//!
//! The controller side talks to it in Modbus terms ([`BoardLogic::handle`] with a
//! [`Request`]); the machine side (the simulator, or a test) sets what the CNC and the
//! operator do with the `set_*` methods.
//!
//! The protocol is chosen at construction ([`BoardLogic::with_protocol`] with an
//! [`EmulatedProtocol`]; [`BoardLogic::new`] and `default` give v2):
//!
//! | | v2 | v1 (`V1Exception` / `V1Zeros`) |
//! | --- | --- | --- |
//! | input registers 9…14, holding register 4 | `PROTOCOL_VERSION` = 2, NC context, `FALLBACK_OVERRIDE`; `FALLBACK_MODE` | exception 02 / read 0 |
//! | `ACC_ACTIVE` falls (watchdog, `ACC_REQUEST` cleared, lost link) in a cycle | fallback clamp: applied = min(operator, override at the fall) until the knob turns, the cycle ends or ACC is active again | applied = operator's knob |
//! | watchdog trip | clamp, and feed hold until `ALARM_RESET` when `FALLBACK_MODE` = 1 | — |
//! | power cycle | `BOARD_RESTARTED` and (in a cycle) feed hold until `ALARM_RESET` | — |
//!
//! ```
//! use acc_pmc::emu::board::{BoardLogic, EmulatedProtocol, Exception, Request, Reply};
//! use acc_pmc::regs::{holding, OverrideResolution};
//! let mut board = BoardLogic::new(OverrideResolution::Percent10);
//! board.set_acc_switch(true);
//! board.set_cycle_active(true);
//! board.set_operator_override_pct(100);
//! // The controller asks for the override (CONTROL bit 0) and commands 60 %.
//! board.handle(Request::WriteSingle { addr: holding::CONTROL, value: 1 }, 0).unwrap();
//! board.handle(Request::WriteMultiple { addr: holding::OVERRIDE_CMD, values: vec![60, 1] }, 0).unwrap();
//! assert_eq!(board.status().override_applied_pct, 60);
//! // 65 is not a multiple of the 10 % step: exception 03, the old value stays.
//! let err = board.handle(Request::WriteSingle { addr: holding::OVERRIDE_CMD, value: 65 }, 0);
//! assert_eq!(err, Err(Exception::IllegalDataValue));
//! // No heartbeat change for WATCHDOG_MS = 500 ms: the watchdog trips. The operator's knob
//! // is at 100 %, but the fallback clamp keeps the 60 % of the moment of the trip, and
//! // FALLBACK_MODE 1 (the default) holds the feed until ALARM_RESET.
//! board.tick(500);
//! let s = board.status();
//! assert!(s.watchdog_tripped && s.fallback_active && s.feed_hold_active);
//! assert_eq!((s.override_applied_pct, s.fallback_override_pct), (60, 60));
//! // A v1 board hands the feed back to the knob: 100 %.
//! let mut v1 = BoardLogic::with_protocol(OverrideResolution::Percent10, EmulatedProtocol::V1Exception);
//! v1.set_acc_switch(true);
//! v1.set_cycle_active(true);
//! v1.handle(Request::WriteMultiple { addr: 0, values: vec![60, 1, 1] }, 0).unwrap();
//! v1.tick(500);
//! assert_eq!(v1.status().override_applied_pct, 100);
//! assert_eq!(v1.handle(Request::ReadInput { addr: 9, count: 1 }, 500), Err(Exception::IllegalDataAddress));
//! ```

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use crate::regs::{
    control_bits, holding, input, FallbackMode, OverrideResolution, FALLBACK_NONE_PCT,
    MAX_READ_COUNT, MAX_WRITE_COUNT, OVERRIDE_DEFAULT_PCT, OVERRIDE_MAX_PCT, PROTOCOL_V2,
    WATCHDOG_DEFAULT_MS, WATCHDOG_RANGE_MS,
};
use crate::BoardStatus;

/// A board shared between a server thread (RTU or CAN emulator) and the machine side (the
/// simulator sets the switch, power, rpm… through the same mutex).
pub type SharedBoard = Arc<Mutex<BoardLogic>>;

/// Lock a [`SharedBoard`]; a poisoned lock (a panicking holder) still yields the board.
pub fn lock_board(board: &SharedBoard) -> MutexGuard<'_, BoardLogic> {
    board.lock().unwrap_or_else(PoisonError::into_inner)
}

impl BoardLogic {
    /// Wrap in a [`SharedBoard`].
    pub fn shared(self) -> SharedBoard {
        Arc::new(Mutex::new(self))
    }
}

/// Modbus exception codes the board answers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Exception {
    /// 01: the function code is not supported.
    IllegalFunction,
    /// 02: an address outside the register map.
    IllegalDataAddress,
    /// 03: a value the board refuses (override not a multiple of the step or > 150,
    /// watchdog outside 100…5000 ms, undefined `CONTROL` bit, zero or too large count).
    IllegalDataValue,
}

impl Exception {
    /// The exception code byte on the wire.
    pub fn code(self) -> u8 {
        match self {
            Exception::IllegalFunction => 0x01,
            Exception::IllegalDataAddress => 0x02,
            Exception::IllegalDataValue => 0x03,
        }
    }
}

impl core::fmt::Display for Exception {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Exception::IllegalFunction => write!(f, "exception 01 (illegal function)"),
            Exception::IllegalDataAddress => write!(f, "exception 02 (illegal data address)"),
            Exception::IllegalDataValue => write!(f, "exception 03 (illegal data value)"),
        }
    }
}

impl std::error::Error for Exception {}

impl crate::BoardError for Exception {
    /// `Exception(code)`: the board refused the request.
    fn kind(&self) -> crate::BoardErrorKind {
        crate::BoardErrorKind::Exception(self.code())
    }
}

/// A Modbus request as the board sees it (the PDU, after framing and CRC are checked).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// FC03: read `count` holding registers from `addr`.
    ReadHolding {
        /// First register address.
        addr: u16,
        /// Number of registers.
        count: u16,
    },
    /// FC04: read `count` input registers from `addr`.
    ReadInput {
        /// First register address.
        addr: u16,
        /// Number of registers.
        count: u16,
    },
    /// FC06: write one holding register.
    WriteSingle {
        /// Register address.
        addr: u16,
        /// Value.
        value: u16,
    },
    /// FC16: write consecutive holding registers from `addr` (all or nothing).
    WriteMultiple {
        /// First register address.
        addr: u16,
        /// Values, one per register.
        values: Vec<u16>,
    },
    /// Any other function code: the board answers exception 01.
    Other {
        /// The function code.
        function: u8,
    },
}

/// The board's positive answer to a [`Request`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// Register values of a read, in address order.
    Registers(Vec<u16>),
    /// FC06 echo.
    WroteSingle {
        /// Register address.
        addr: u16,
        /// Value written.
        value: u16,
    },
    /// FC16 acknowledgement.
    WroteMultiple {
        /// First register address.
        addr: u16,
        /// Number of registers written.
        count: u16,
    },
}

/// Which protocol generation the emulated board speaks (`../shared/docs/pmc-board.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EmulatedProtocol {
    /// v2 (the default): `PROTOCOL_VERSION` = 2, `FALLBACK_MODE`, the fallback clamp, the
    /// watchdog and power-up feed holds, `STATUS` bits 7/8, the NC context registers 9…14.
    #[default]
    V2,
    /// A v1 board that answers exception 02 for input registers 9…14 and holding register
    /// 4: no clamp (a fall of `ACC_ACTIVE` hands the override to the operator's knob), no
    /// feed hold of its own, `STATUS` bits 7/8 never set.
    V1Exception,
    /// A v1 board that reads 0 for input registers 9…14 and holding register 4 (writes to
    /// register 4 are accepted and ignored); otherwise as [`EmulatedProtocol::V1Exception`].
    V1Zeros,
}

impl EmulatedProtocol {
    /// The board speaks v2.
    pub fn is_v2(self) -> bool {
        self == EmulatedProtocol::V2
    }
}

/// The board: holding registers, machine-side inputs, and the behaviour rules of the spec.
///
/// Time: every call that can change the watchdog takes `now_ms`, a monotonic time in
/// milliseconds from any origin. The board never reads a clock.
///
/// Every method that changes state re-evaluates `ACC_ACTIVE`: a fall for any reason other
/// than the operator's [ACC ON] switch or `OVERRIDE_LOCKED` engages the fallback clamp (v2,
/// while `CYCLE_ACTIVE`), a rise ends it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoardLogic {
    resolution: OverrideResolution,
    protocol: EmulatedProtocol,
    // --- holding registers ---
    override_cmd_pct: u16,
    heartbeat: u16,
    acc_request: bool,
    feed_hold_request: bool,
    watchdog_ms: u16,
    fallback_mode: FallbackMode,
    // --- internal state ---
    watchdog_tripped: bool,
    /// Start of the current watchdog interval: the last heartbeat change, ACC request
    /// edge, alarm reset or power cycle, ms.
    watchdog_since_ms: Option<u64>,
    /// `ACC_ACTIVE` as last evaluated (edge detection for the clamp).
    was_active: bool,
    /// The fallback clamp (v2), percent; `None` when not engaged.
    clamp_pct: Option<u16>,
    /// Feed hold asserted by a watchdog trip with `FALLBACK_MODE` = 1, until `ALARM_RESET`.
    watchdog_feed_hold: bool,
    /// Feed hold asserted at power-up in a cycle, until `ALARM_RESET`.
    restart_feed_hold: bool,
    /// `BOARD_RESTARTED` (v2): set by a power cycle, cleared by `ALARM_RESET`.
    board_restarted: bool,
    // --- machine side ---
    acc_switch: bool,
    operator_override_pct: u16,
    cycle_active: bool,
    override_locked: bool,
    cnc_alarm: bool,
    operator_feed_hold: bool,
    spindle_power_w: u32,
    spindle_rpm: u16,
    sample_seq: u16,
    programmed_feed_mm_min: u16,
    tool_number: u16,
    program_number: u16,
    block_number: u16,
    actual_feed_mm_min: u16,
}

impl Default for BoardLogic {
    fn default() -> Self {
        Self::new(OverrideResolution::default())
    }
}

impl BoardLogic {
    /// A v2 board (see [`BoardLogic::with_protocol`]).
    pub fn new(resolution: OverrideResolution) -> Self {
        Self::with_protocol(resolution, EmulatedProtocol::V2)
    }

    /// A board speaking `protocol`, as the controller finds it when it connects:
    /// `OVERRIDE_CMD` = 100, `CONTROL` = 0, `WATCHDOG_MS` = 500, `FALLBACK_MODE` = 1,
    /// `ACC_ACTIVE` off, no clamp; operator switch off, operator override 100 %, no power,
    /// no cycle, no NC context. `BOARD_RESTARTED` is clear (the board has been up for a while;
    /// [`BoardLogic::power_cycle`] models a restart).
    pub fn with_protocol(resolution: OverrideResolution, protocol: EmulatedProtocol) -> Self {
        Self {
            resolution,
            protocol,
            override_cmd_pct: OVERRIDE_DEFAULT_PCT,
            heartbeat: 0,
            acc_request: false,
            feed_hold_request: false,
            watchdog_ms: WATCHDOG_DEFAULT_MS,
            fallback_mode: FallbackMode::default(),
            watchdog_tripped: false,
            watchdog_since_ms: None,
            was_active: false,
            clamp_pct: None,
            watchdog_feed_hold: false,
            restart_feed_hold: false,
            board_restarted: false,
            acc_switch: false,
            operator_override_pct: OVERRIDE_DEFAULT_PCT,
            cycle_active: false,
            override_locked: false,
            cnc_alarm: false,
            operator_feed_hold: false,
            spindle_power_w: 0,
            spindle_rpm: 0,
            sample_seq: 0,
            programmed_feed_mm_min: 0,
            tool_number: 0,
            program_number: 0,
            block_number: 0,
            actual_feed_mm_min: 0,
        }
    }

    /// The protocol this board speaks.
    pub fn protocol(&self) -> EmulatedProtocol {
        self.protocol
    }

    /// Power cycle: holding registers back to their defaults (`OVERRIDE_CMD` = 100,
    /// `HEARTBEAT` = 0, `CONTROL` = 0, `WATCHDOG_MS` = 500, `FALLBACK_MODE` = 1), watchdog
    /// cleared, clamp forgotten. v2: `BOARD_RESTARTED` set until `ALARM_RESET`, and if
    /// `CYCLE_ACTIVE` is set the board asserts feed hold until `ALARM_RESET` (it has lost the
    /// last override). The machine side (switches, power, rpm, NC context) is the CNC's and
    /// stays as it is.
    pub fn power_cycle(&mut self) {
        self.override_cmd_pct = OVERRIDE_DEFAULT_PCT;
        self.heartbeat = 0;
        self.acc_request = false;
        self.feed_hold_request = false;
        self.watchdog_ms = WATCHDOG_DEFAULT_MS;
        self.fallback_mode = FallbackMode::default();
        self.watchdog_tripped = false;
        self.watchdog_since_ms = None;
        self.was_active = false;
        self.clamp_pct = None;
        self.watchdog_feed_hold = false;
        let v2 = self.protocol.is_v2();
        self.board_restarted = v2;
        self.restart_feed_hold = v2 && self.cycle_active;
    }

    /// Re-evaluate `ACC_ACTIVE` after a state change: a fall engages the clamp (v2, in a
    /// cycle) unless the operator's switch is off or the override is locked; a rise ends it.
    fn update_active(&mut self) {
        let active = self.acc_active();
        if active {
            self.clamp_pct = None;
        } else if self.was_active
            && self.protocol.is_v2()
            && self.cycle_active
            && self.acc_switch
            && !self.override_locked
        {
            // ACC was active until this change, so the applied override was the command.
            self.clamp_pct = Some(self.override_cmd_pct);
        }
        self.was_active = active;
    }

    // ------------------------------------------------------------------ controller side

    /// Advance the watchdog to `now_ms`: trips when `ACC_REQUEST` is set and `HEARTBEAT` has
    /// not changed for `WATCHDOG_MS` (spec, "Board behaviour"). A trip engages the clamp and,
    /// with `FALLBACK_MODE` = 1, the feed hold (v2). Call it at least once per millisecond of
    /// interest; [`BoardLogic::handle`] calls it before every request.
    pub fn tick(&mut self, now_ms: u64) {
        if !self.acc_request || self.watchdog_tripped {
            return;
        }
        let since = *self.watchdog_since_ms.get_or_insert(now_ms);
        if now_ms.saturating_sub(since) >= u64::from(self.watchdog_ms) {
            self.watchdog_tripped = true;
            if self.protocol.is_v2() && self.fallback_mode == FallbackMode::ClampAndFeedHold {
                self.watchdog_feed_hold = true;
            }
            self.update_active();
        }
    }

    /// Number of holding registers this board has (exception 02 beyond).
    fn holding_len(&self) -> u16 {
        match self.protocol {
            EmulatedProtocol::V1Exception => holding::V1_COUNT,
            EmulatedProtocol::V2 | EmulatedProtocol::V1Zeros => holding::COUNT,
        }
    }

    /// Number of input registers this board has (exception 02 beyond).
    fn input_len(&self) -> u16 {
        match self.protocol {
            EmulatedProtocol::V1Exception => input::V1_COUNT,
            EmulatedProtocol::V2 | EmulatedProtocol::V1Zeros => input::COUNT,
        }
    }

    /// Serve one Modbus request at time `now_ms` (ms). Writes are all-or-nothing: an
    /// exception leaves every register unchanged.
    pub fn handle(&mut self, request: Request, now_ms: u64) -> Result<Reply, Exception> {
        self.tick(now_ms);
        match request {
            Request::ReadHolding { addr, count } => {
                let range = check_range(addr, count, self.holding_len(), MAX_READ_COUNT)?;
                let regs = self.holding_registers();
                Ok(Reply::Registers(regs[range].to_vec()))
            }
            Request::ReadInput { addr, count } => {
                let range = check_range(addr, count, self.input_len(), MAX_READ_COUNT)?;
                let regs = self.input_registers();
                Ok(Reply::Registers(regs[range].to_vec()))
            }
            Request::WriteSingle { addr, value } => {
                self.write_holding(addr, &[value], now_ms)?;
                Ok(Reply::WroteSingle { addr, value })
            }
            Request::WriteMultiple { addr, values } => {
                let count = u16::try_from(values.len()).map_err(|_| Exception::IllegalDataValue)?;
                self.write_holding(addr, &values, now_ms)?;
                Ok(Reply::WroteMultiple { addr, count })
            }
            Request::Other { .. } => Err(Exception::IllegalFunction),
        }
    }

    /// Write consecutive holding registers from `addr` at time `now_ms` (ms): validate all,
    /// then apply all in address order (FC06 is a write of one).
    ///
    /// Errors: exception 02 for addresses outside the map (`0..5`; `0..4` on a
    /// [`EmulatedProtocol::V1Exception`] board); exception 03 for an empty or too long
    /// write, an override above 150 or not a multiple of the step, a watchdog outside
    /// 100…5000 ms, an undefined `CONTROL` bit, or a `FALLBACK_MODE` other than 0 or 1.
    pub fn write_holding(
        &mut self,
        addr: u16,
        values: &[u16],
        now_ms: u64,
    ) -> Result<(), Exception> {
        self.tick(now_ms);
        let count = u16::try_from(values.len()).map_err(|_| Exception::IllegalDataValue)?;
        let range = check_range(addr, count, self.holding_len(), MAX_WRITE_COUNT)?;
        for (reg, &value) in range.clone().zip(values) {
            self.validate_holding(reg as u16, value)?;
        }
        for (reg, &value) in range.zip(values) {
            self.apply_holding(reg as u16, value, now_ms);
            self.update_active();
        }
        Ok(())
    }

    fn validate_holding(&self, addr: u16, value: u16) -> Result<(), Exception> {
        let ok = match addr {
            holding::OVERRIDE_CMD => {
                value <= OVERRIDE_MAX_PCT && value % self.resolution.step_pct() == 0
            }
            holding::HEARTBEAT => true,
            holding::CONTROL => value & !control_bits::DEFINED == 0,
            holding::WATCHDOG_MS => WATCHDOG_RANGE_MS.contains(&value),
            holding::FALLBACK_MODE => match self.protocol {
                EmulatedProtocol::V2 => FallbackMode::from_register(value).is_some(),
                // An unused register of a v1 board: anything goes, nothing happens.
                EmulatedProtocol::V1Zeros => true,
                EmulatedProtocol::V1Exception => return Err(Exception::IllegalDataAddress),
            },
            _ => return Err(Exception::IllegalDataAddress),
        };
        if ok {
            Ok(())
        } else {
            Err(Exception::IllegalDataValue)
        }
    }

    fn apply_holding(&mut self, addr: u16, value: u16, now_ms: u64) {
        match addr {
            holding::OVERRIDE_CMD => self.override_cmd_pct = value,
            holding::HEARTBEAT if value != self.heartbeat => {
                self.heartbeat = value;
                self.watchdog_since_ms = Some(now_ms);
            }
            holding::CONTROL => {
                let request = value & control_bits::ACC_REQUEST != 0;
                if request && !self.acc_request {
                    // The watchdog interval starts when the controller takes over.
                    self.watchdog_since_ms = Some(now_ms);
                }
                self.acc_request = request;
                self.feed_hold_request = value & control_bits::FEED_HOLD_REQUEST != 0;
                if value & control_bits::ALARM_RESET != 0 {
                    self.watchdog_tripped = false;
                    self.watchdog_since_ms = Some(now_ms);
                    self.watchdog_feed_hold = false;
                    self.restart_feed_hold = false;
                    self.board_restarted = false;
                }
            }
            holding::WATCHDOG_MS => self.watchdog_ms = value,
            holding::FALLBACK_MODE if self.protocol.is_v2() => {
                self.fallback_mode = FallbackMode::from_register(value).unwrap_or_default();
            }
            _ => {}
        }
    }

    /// Holding registers 0…4 as they read back (`ALARM_RESET` reads 0; `FALLBACK_MODE` reads
    /// 0 on a [`EmulatedProtocol::V1Zeros`] board and is outside the map of a
    /// [`EmulatedProtocol::V1Exception`] board).
    pub fn holding_registers(&self) -> [u16; holding::COUNT as usize] {
        let mut control = 0;
        if self.acc_request {
            control |= control_bits::ACC_REQUEST;
        }
        if self.feed_hold_request {
            control |= control_bits::FEED_HOLD_REQUEST;
        }
        let fallback_mode = if self.protocol.is_v2() {
            self.fallback_mode.to_register()
        } else {
            0
        };
        [
            self.override_cmd_pct,
            self.heartbeat,
            control,
            self.watchdog_ms,
            fallback_mode,
        ]
    }

    /// Input registers 0…14 as the controller reads them (on a v1 board registers 9…14 read
    /// 0, or are outside the map of a [`EmulatedProtocol::V1Exception`] board).
    pub fn input_registers(&self) -> [u16; input::COUNT as usize] {
        let status = self.status();
        if self.protocol.is_v2() {
            status.to_input_registers()
        } else {
            let mut regs = [0u16; input::COUNT as usize];
            regs[..input::V1_COUNT as usize].copy_from_slice(&status.to_v1_input_registers());
            regs
        }
    }

    /// The status block decoded: input registers 0…14 of a v2 board; on a v1 board what
    /// [`BoardStatus::from_v1_input_registers`] gives (no clamp, no context, version 0).
    pub fn status(&self) -> BoardStatus {
        let acc_active = self.acc_active();
        let full = BoardStatus {
            acc_switch: self.acc_switch,
            acc_active,
            cycle_active: self.cycle_active,
            feed_hold_active: self.feed_hold_active(),
            watchdog_tripped: self.watchdog_tripped,
            override_locked: self.override_locked,
            cnc_alarm: self.cnc_alarm,
            override_applied_pct: self.override_applied_pct(),
            operator_override_pct: self.operator_override_pct,
            override_step_pct: self.resolution.step_pct(),
            spindle_power_w: self.spindle_power_w,
            spindle_rpm: self.spindle_rpm,
            sample_seq: self.sample_seq,
            programmed_feed_mm_min: self.programmed_feed_mm_min,
            fallback_active: self.clamp_pct.is_some(),
            board_restarted: self.board_restarted,
            protocol_version: PROTOCOL_V2,
            tool_number: self.tool_number,
            program_number: self.program_number,
            block_number: self.block_number,
            actual_feed_mm_min: self.actual_feed_mm_min,
            fallback_override_pct: self.fallback_override_pct(),
        };
        if self.protocol.is_v2() {
            full
        } else {
            BoardStatus::from_v1_input_registers(&full.to_v1_input_registers())
        }
    }

    /// `ACC_ACTIVE` = `ACC_SWITCH` ∧ `ACC_REQUEST` ∧ ¬`WATCHDOG_TRIPPED` ∧ ¬`OVERRIDE_LOCKED`.
    pub fn acc_active(&self) -> bool {
        self.acc_switch && self.acc_request && !self.watchdog_tripped && !self.override_locked
    }

    /// `OVERRIDE_APPLIED`, percent: `OVERRIDE_CMD` while `ACC_ACTIVE`; otherwise the
    /// operator's switch, limited by the fallback clamp when it is engaged (v2:
    /// `min(OPERATOR_OVERRIDE, FALLBACK_OVERRIDE)`). This is what the machine's feed drive
    /// should obey (the NC itself forces 100 % while `OVERRIDE_LOCKED`; that is the
    /// machine's business, not the board's).
    pub fn override_applied_pct(&self) -> u16 {
        if self.acc_active() {
            self.override_cmd_pct
        } else {
            match self.clamp_pct {
                Some(clamp) => self.operator_override_pct.min(clamp),
                None => self.operator_override_pct,
            }
        }
    }

    /// `FALLBACK_OVERRIDE` (v2), percent: the clamp when engaged, else 150.
    pub fn fallback_override_pct(&self) -> u16 {
        self.clamp_pct.unwrap_or(FALLBACK_NONE_PCT)
    }

    /// `FALLBACK_ACTIVE` (v2): the clamp is engaged.
    pub fn fallback_active(&self) -> bool {
        self.clamp_pct.is_some()
    }

    /// `FALLBACK_MODE` (v2) as last written.
    pub fn fallback_mode(&self) -> FallbackMode {
        self.fallback_mode
    }

    /// `BOARD_RESTARTED` (v2): set by [`BoardLogic::power_cycle`], cleared by `ALARM_RESET`.
    pub fn board_restarted(&self) -> bool {
        self.board_restarted
    }

    /// `FEED_HOLD_ACTIVE`: the controller's `FEED_HOLD_REQUEST`, the operator's feed hold,
    /// or (v2) the board's own feed hold after a watchdog trip with `FALLBACK_MODE` = 1 or a
    /// power-up in a cycle (both until `ALARM_RESET`).
    pub fn feed_hold_active(&self) -> bool {
        self.feed_hold_request
            || self.operator_feed_hold
            || self.watchdog_feed_hold
            || self.restart_feed_hold
    }

    /// `OVERRIDE_CMD`, percent, as last accepted.
    pub fn override_cmd_pct(&self) -> u16 {
        self.override_cmd_pct
    }

    /// `HEARTBEAT` as last written.
    pub fn heartbeat(&self) -> u16 {
        self.heartbeat
    }

    /// `CONTROL` bits as they read back (`alarm_reset` is always false).
    pub fn control(&self) -> crate::ControlBits {
        crate::ControlBits {
            acc_request: self.acc_request,
            feed_hold_request: self.feed_hold_request,
            alarm_reset: false,
        }
    }

    /// `WATCHDOG_MS`, ms.
    pub fn watchdog_ms(&self) -> u16 {
        self.watchdog_ms
    }

    /// The board's resolution.
    pub fn resolution(&self) -> OverrideResolution {
        self.resolution
    }

    // ------------------------------------------------------------------ machine side

    /// The operator's [ACC ON] switch.
    pub fn set_acc_switch(&mut self, on: bool) {
        self.acc_switch = on;
        self.update_active();
    }

    /// The operator's override switch, percent; clamped to 0…150. Turning the knob (a
    /// value different from the current one) is a deliberate act: it ends the fallback clamp.
    pub fn set_operator_override_pct(&mut self, pct: u16) {
        let pct = pct.min(OVERRIDE_MAX_PCT);
        if pct != self.operator_override_pct {
            self.clamp_pct = None;
        }
        self.operator_override_pct = pct;
    }

    /// NC cycle running (`CYCLE_ACTIVE`); its fall ends the fallback clamp.
    pub fn set_cycle_active(&mut self, on: bool) {
        if !on {
            self.clamp_pct = None;
        }
        self.cycle_active = on;
        self.update_active();
    }

    /// The NC forces 100 % (tapping, threading, override cancel): `OVERRIDE_LOCKED`. A fall
    /// of `ACC_ACTIVE` because of the lock does not engage the clamp.
    pub fn set_override_locked(&mut self, on: bool) {
        self.override_locked = on;
        self.update_active();
    }

    /// CNC alarm (`CNC_ALARM`).
    pub fn set_cnc_alarm(&mut self, on: bool) {
        self.cnc_alarm = on;
    }

    /// The operator pressed feed hold on the machine panel (also reported as
    /// `FEED_HOLD_ACTIVE`).
    pub fn set_operator_feed_hold(&mut self, on: bool) {
        self.operator_feed_hold = on;
    }

    /// Spindle input power, W (`POWER_HI:POWER_LO`), without a new sample sequence number.
    pub fn set_spindle_power_w(&mut self, power_w: u32) {
        self.spindle_power_w = power_w;
    }

    /// A new power sample: sets the power (W) and increments `SAMPLE_SEQ` (wrapping).
    pub fn push_power_sample(&mut self, power_w: u32) {
        self.spindle_power_w = power_w;
        self.sample_seq = self.sample_seq.wrapping_add(1);
    }

    /// `SAMPLE_SEQ` directly (to freeze or jump it in fault tests).
    pub fn set_sample_seq(&mut self, seq: u16) {
        self.sample_seq = seq;
    }

    /// Actual spindle speed, rpm.
    pub fn set_spindle_rpm(&mut self, rpm: u16) {
        self.spindle_rpm = rpm;
    }

    /// Programmed feed of the active block, mm/min (0 = unknown).
    pub fn set_programmed_feed_mm_min(&mut self, feed_mm_min: u16) {
        self.programmed_feed_mm_min = feed_mm_min;
    }

    /// Active tool (T word), 0 = none/unknown: `TOOL_NUMBER` (v2).
    pub fn set_tool_number(&mut self, tool: u16) {
        self.tool_number = tool;
    }

    /// Running program (O number), 0 = unknown: `PROGRAM_NUMBER` (v2).
    pub fn set_program_number(&mut self, program: u16) {
        self.program_number = program;
    }

    /// Sequence number of the active block (N word, low 16 bits), 0 = unknown:
    /// `BLOCK_NUMBER` (v2).
    pub fn set_block_number(&mut self, block: u16) {
        self.block_number = block;
    }

    /// Actual path feed from the NC, mm/min (after override, 0 in feed hold):
    /// `ACTUAL_FEED` (v2).
    pub fn set_actual_feed_mm_min(&mut self, feed_mm_min: u16) {
        self.actual_feed_mm_min = feed_mm_min;
    }
}

/// Check `addr..addr+count` against a map of `len` registers and a per-request maximum.
/// Modbus order: a bad count is 03, then a bad address is 02.
fn check_range(
    addr: u16,
    count: u16,
    len: u16,
    max_count: u16,
) -> Result<core::ops::Range<usize>, Exception> {
    if count == 0 || count > max_count {
        return Err(Exception::IllegalDataValue);
    }
    let end = u32::from(addr) + u32::from(count);
    if end > u32::from(len) {
        return Err(Exception::IllegalDataAddress);
    }
    Ok(usize::from(addr)..end as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::regs::status_bits;

    fn write1(b: &mut BoardLogic, addr: u16, value: u16, now: u64) -> Result<Reply, Exception> {
        b.handle(Request::WriteSingle { addr, value }, now)
    }

    fn read_inputs(b: &mut BoardLogic, now: u64) -> Vec<u16> {
        match b.handle(Request::ReadInput { addr: 0, count: 9 }, now) {
            Ok(Reply::Registers(r)) => r,
            other => panic!("read failed: {other:?}"),
        }
    }

    /// A board with the operator's switch on at 70 % and the controller holding ACC_REQUEST.
    fn armed(res: OverrideResolution) -> BoardLogic {
        let mut b = BoardLogic::new(res);
        b.set_acc_switch(true);
        b.set_operator_override_pct(70);
        write1(&mut b, holding::CONTROL, control_bits::ACC_REQUEST, 0).expect("control");
        b
    }

    #[test]
    fn power_up_defaults() {
        let mut b = BoardLogic::new(OverrideResolution::Percent10);
        let r = b.handle(Request::ReadHolding { addr: 0, count: 4 }, 0);
        assert_eq!(r, Ok(Reply::Registers(vec![100, 0, 0, 500])));
        assert!(!b.acc_active());
        assert_eq!(b.status().override_step_pct, 10);
        assert_eq!(
            BoardLogic::new(OverrideResolution::Percent1)
                .status()
                .override_step_pct,
            1
        );
    }

    #[test]
    fn acc_active_needs_switch_request_no_trip_no_lock() {
        let mut b = BoardLogic::new(OverrideResolution::Percent10);
        b.set_operator_override_pct(60);
        b.write_holding(holding::OVERRIDE_CMD, &[130], 0)
            .expect("write");
        // request without switch: not active, applied follows the operator.
        write1(&mut b, holding::CONTROL, 1, 0).expect("control");
        assert!(!b.acc_active());
        assert_eq!(b.override_applied_pct(), 60);
        b.set_acc_switch(true);
        assert!(b.acc_active());
        assert_eq!(b.override_applied_pct(), 130);
        b.set_override_locked(true);
        assert!(!b.acc_active());
        assert_eq!(b.override_applied_pct(), 60);
        b.set_override_locked(false);
        write1(&mut b, holding::CONTROL, 0, 1).expect("control");
        assert!(!b.acc_active());
        assert_eq!(b.override_applied_pct(), 60);
        let regs = read_inputs(&mut b, 1);
        assert_eq!(regs[0] & status_bits::ACC_ACTIVE, 0);
        assert_eq!(regs[0] & status_bits::ACC_SWITCH, status_bits::ACC_SWITCH);
    }

    #[test]
    fn override_validation_step_10() {
        let mut b = armed(OverrideResolution::Percent10);
        for ok in [0u16, 10, 90, 150] {
            assert!(write1(&mut b, holding::OVERRIDE_CMD, ok, 1).is_ok(), "{ok}");
            assert_eq!(b.override_cmd_pct(), ok);
        }
        for bad in [155u16, 35, 160, 1, 65535] {
            let before = b.override_cmd_pct();
            assert_eq!(
                write1(&mut b, holding::OVERRIDE_CMD, bad, 2),
                Err(Exception::IllegalDataValue),
                "{bad}"
            );
            assert_eq!(b.override_cmd_pct(), before, "old value kept after {bad}");
        }
    }

    #[test]
    fn override_validation_step_1() {
        let mut b = armed(OverrideResolution::Percent1);
        assert!(write1(&mut b, holding::OVERRIDE_CMD, 35, 1).is_ok());
        assert_eq!(b.override_applied_pct(), 35);
        assert_eq!(
            write1(&mut b, holding::OVERRIDE_CMD, 151, 1),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(b.override_cmd_pct(), 35);
    }

    #[test]
    fn write_multiple_is_all_or_nothing() {
        let mut b = armed(OverrideResolution::Percent10);
        let req = Request::WriteMultiple {
            addr: 0,
            values: vec![120, 7],
        };
        assert_eq!(
            b.handle(req, 1),
            Ok(Reply::WroteMultiple { addr: 0, count: 2 })
        );
        assert_eq!((b.override_cmd_pct(), b.heartbeat()), (120, 7));
        // bad override with a new heartbeat: neither is applied.
        let req = Request::WriteMultiple {
            addr: 0,
            values: vec![125, 8],
        };
        assert_eq!(b.handle(req, 2), Err(Exception::IllegalDataValue));
        assert_eq!((b.override_cmd_pct(), b.heartbeat()), (120, 7));
        // bad watchdog in the last register of a 4-register write.
        let req = Request::WriteMultiple {
            addr: 0,
            values: vec![50, 9, 1, 50],
        };
        assert_eq!(b.handle(req, 3), Err(Exception::IllegalDataValue));
        assert_eq!(b.holding_registers(), [120, 7, 1, 500, 1]);
    }

    #[test]
    fn addresses_outside_the_map_are_exception_02() {
        let mut b = BoardLogic::default();
        let cases = [
            Request::ReadInput { addr: 15, count: 1 },
            Request::ReadInput { addr: 0, count: 16 },
            Request::ReadInput { addr: 14, count: 2 },
            Request::ReadHolding { addr: 5, count: 1 },
            Request::ReadHolding {
                addr: 65535,
                count: 2,
            },
            Request::WriteSingle { addr: 5, value: 0 },
            Request::WriteMultiple {
                addr: 4,
                values: vec![1, 0],
            },
        ];
        for req in cases {
            assert_eq!(
                b.handle(req.clone(), 0),
                Err(Exception::IllegalDataAddress),
                "{req:?}"
            );
        }
        assert_eq!(b.holding_registers(), [100, 0, 0, 500, 1]);
    }

    #[test]
    fn bad_counts_and_unknown_functions() {
        let mut b = BoardLogic::default();
        assert_eq!(
            b.handle(Request::ReadInput { addr: 0, count: 0 }, 0),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(
            b.handle(
                Request::ReadInput {
                    addr: 0,
                    count: 126
                },
                0
            ),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(
            b.handle(
                Request::WriteMultiple {
                    addr: 0,
                    values: vec![]
                },
                0
            ),
            Err(Exception::IllegalDataValue)
        );
        for f in [0x01u8, 0x02, 0x05, 0x0F, 0x17, 0x2B, 0x7F] {
            assert_eq!(
                b.handle(Request::Other { function: f }, 0),
                Err(Exception::IllegalFunction)
            );
        }
        assert_eq!(Exception::IllegalFunction.code(), 1);
        assert_eq!(Exception::IllegalDataAddress.code(), 2);
        assert_eq!(Exception::IllegalDataValue.code(), 3);
    }

    #[test]
    fn control_and_watchdog_register_validation() {
        let mut b = BoardLogic::default();
        assert_eq!(
            write1(&mut b, holding::CONTROL, 0x08, 0),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(
            write1(&mut b, holding::WATCHDOG_MS, 99, 0),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(
            write1(&mut b, holding::WATCHDOG_MS, 5001, 0),
            Err(Exception::IllegalDataValue)
        );
        assert!(write1(&mut b, holding::WATCHDOG_MS, 100, 0).is_ok());
        assert!(write1(&mut b, holding::WATCHDOG_MS, 5000, 0).is_ok());
        assert_eq!(b.watchdog_ms(), 5000);
        // ALARM_RESET reads back 0, the other bits read back as written.
        assert!(write1(&mut b, holding::CONTROL, 0b111, 0).is_ok());
        assert_eq!(b.holding_registers()[2], 0b011);
    }

    #[test]
    fn watchdog_trips_without_heartbeat_change_and_falls_back() {
        let mut b = armed(OverrideResolution::Percent10);
        b.write_holding(0, &[140, 1], 0).expect("write");
        assert_eq!(b.override_applied_pct(), 140);
        // heartbeat changing every 100 ms keeps it alive far beyond 500 ms.
        for k in 1..20u16 {
            b.write_holding(holding::HEARTBEAT, &[k + 1], u64::from(k) * 100)
                .expect("hb");
        }
        assert!(!b.status().watchdog_tripped);
        // the same heartbeat value written again does not count as a change.
        let last = 1900;
        b.write_holding(0, &[140, 20], last + 300).expect("same hb");
        b.tick(last + 499);
        assert!(!b.status().watchdog_tripped, "499 ms after the last change");
        b.tick(last + 500);
        let s = b.status();
        assert!(s.watchdog_tripped && !s.acc_active);
        assert_eq!(
            s.override_applied_pct, 70,
            "falls back to the operator's switch"
        );
        // heartbeat resumes: still tripped until ALARM_RESET.
        b.write_holding(holding::HEARTBEAT, &[99], last + 600)
            .expect("hb");
        assert!(b.status().watchdog_tripped);
        write1(
            &mut b,
            holding::CONTROL,
            control_bits::ACC_REQUEST | control_bits::ALARM_RESET,
            last + 700,
        )
        .expect("reset");
        let s = b.status();
        assert!(!s.watchdog_tripped && s.acc_active);
        assert_eq!(s.override_applied_pct, 140);
        assert_eq!(b.holding_registers()[2], control_bits::ACC_REQUEST);
        // the interval restarted at the reset.
        b.tick(last + 700 + 499);
        assert!(!b.status().watchdog_tripped);
        b.tick(last + 700 + 500);
        assert!(b.status().watchdog_tripped);
    }

    #[test]
    fn watchdog_only_runs_while_acc_requested_and_uses_configured_time() {
        let mut b = BoardLogic::default();
        b.tick(0);
        b.tick(100_000);
        assert!(!b.status().watchdog_tripped, "no ACC_REQUEST, no watchdog");
        write1(&mut b, holding::WATCHDOG_MS, 200, 100_000).expect("wd");
        write1(&mut b, holding::CONTROL, 1, 100_050).expect("request");
        b.tick(100_249);
        assert!(
            !b.status().watchdog_tripped,
            "interval starts at the request edge"
        );
        b.tick(100_250);
        assert!(b.status().watchdog_tripped);
    }

    #[test]
    fn feed_hold_request_and_operator_feed_hold() {
        let mut b = BoardLogic::default();
        write1(&mut b, holding::CONTROL, control_bits::FEED_HOLD_REQUEST, 0).expect("fh");
        assert!(b.status().feed_hold_active);
        assert_eq!(
            read_inputs(&mut b, 0)[0] & status_bits::FEED_HOLD_ACTIVE,
            status_bits::FEED_HOLD_ACTIVE
        );
        write1(&mut b, holding::CONTROL, 0, 0).expect("release");
        assert!(!b.status().feed_hold_active);
        b.set_operator_feed_hold(true);
        assert!(b.status().feed_hold_active);
    }

    #[test]
    fn power_cycle_restores_defaults_and_keeps_machine_side() {
        let mut b = armed(OverrideResolution::Percent10);
        b.write_holding(0, &[50, 3, 3, 1000], 0).expect("write");
        b.push_power_sample(12_345);
        b.tick(2000);
        assert!(b.status().watchdog_tripped);
        b.power_cycle();
        assert_eq!(b.holding_registers(), [100, 0, 0, 500, 1]);
        let s = b.status();
        assert!(!s.watchdog_tripped && !s.acc_active && !s.feed_hold_active);
        assert!(s.acc_switch);
        assert_eq!(
            (s.spindle_power_w, s.sample_seq, s.override_applied_pct),
            (12_345, 1, 70)
        );
    }

    #[test]
    fn machine_side_registers() {
        let mut b = BoardLogic::default();
        b.set_spindle_power_w(0x0001_86A0); // 100 000 W
        b.set_spindle_rpm(6000);
        b.set_programmed_feed_mm_min(1200);
        b.set_cycle_active(true);
        b.set_cnc_alarm(true);
        b.set_override_locked(true);
        b.set_operator_override_pct(400);
        b.set_sample_seq(u16::MAX);
        b.push_power_sample(2500);
        let r = read_inputs(&mut b, 0);
        let st = status_bits::CYCLE_ACTIVE | status_bits::CNC_ALARM | status_bits::OVERRIDE_LOCKED;
        assert_eq!(r, vec![st, 150, 150, 10, 0, 2500, 6000, 0, 1200]);
        b.set_spindle_power_w(0x0001_86A0);
        assert_eq!(read_inputs(&mut b, 0)[4..6], [0x0001, 0x86A0]);
        match b.handle(Request::ReadInput { addr: 6, count: 3 }, 0) {
            Ok(Reply::Registers(r)) => assert_eq!(r, vec![6000, 0, 1200]),
            other => panic!("{other:?}"),
        }
    }

    // ------------------------------------------------------------------ protocol v2

    const ACC: u16 = control_bits::ACC_REQUEST;
    const RESET: u16 = control_bits::ALARM_RESET;

    /// A board in a cycle, operator switch on, knob at `knob` %, the controller active at
    /// `cmd` % (heartbeat 1) at time 0.
    fn cutting(protocol: EmulatedProtocol, knob: u16, cmd: u16) -> BoardLogic {
        let mut b = BoardLogic::with_protocol(OverrideResolution::Percent10, protocol);
        b.set_acc_switch(true);
        b.set_cycle_active(true);
        b.set_operator_override_pct(knob);
        b.write_holding(0, &[cmd, 1, ACC], 0).expect("arm");
        assert!(b.acc_active());
        assert_eq!(b.override_applied_pct(), cmd);
        b
    }

    fn read_all_inputs(b: &mut BoardLogic) -> Result<Reply, Exception> {
        b.handle(Request::ReadInput { addr: 0, count: 15 }, 0)
    }

    #[test]
    fn v2_reports_version_context_and_fallback_registers() {
        let mut b = BoardLogic::default();
        assert_eq!(b.protocol(), EmulatedProtocol::V2);
        b.set_tool_number(12);
        b.set_program_number(4711);
        b.set_block_number(230);
        b.set_actual_feed_mm_min(720);
        match read_all_inputs(&mut b) {
            Ok(Reply::Registers(r)) => assert_eq!(r[9..], [2, 12, 4711, 230, 720, 150]),
            other => panic!("{other:?}"),
        }
        let s = b.status();
        assert!(s.is_v2() && !s.fallback_active && !s.board_restarted);
        assert_eq!(
            (s.tool_number, s.program_number, s.block_number),
            (12, 4711, 230)
        );
        assert_eq!(s.actual_feed_mm_min, 720);
        assert_eq!(
            b.handle(Request::ReadHolding { addr: 0, count: 5 }, 0),
            Ok(Reply::Registers(vec![100, 0, 0, 500, 1]))
        );
    }

    #[test]
    fn fallback_mode_register_accepts_0_and_1_and_resets_on_power_cycle() {
        let mut b = BoardLogic::default();
        assert_eq!(b.fallback_mode(), FallbackMode::ClampAndFeedHold);
        assert!(write1(&mut b, holding::FALLBACK_MODE, 0, 0).is_ok());
        assert_eq!(b.holding_registers()[4], 0);
        for bad in [2u16, 3, 255, 65535] {
            assert_eq!(
                write1(&mut b, holding::FALLBACK_MODE, bad, 0),
                Err(Exception::IllegalDataValue),
                "{bad}"
            );
        }
        assert_eq!(b.fallback_mode(), FallbackMode::ClampOnly, "old value kept");
        // A bad FALLBACK_MODE in an FC16 write refuses the whole write.
        assert_eq!(
            b.write_holding(3, &[1000, 7], 0),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(b.watchdog_ms(), 500);
        b.power_cycle();
        assert_eq!(b.fallback_mode(), FallbackMode::ClampAndFeedHold);
    }

    #[test]
    fn v1_exception_board_has_no_registers_9_to_14_and_no_fallback_mode() {
        let mut b =
            BoardLogic::with_protocol(OverrideResolution::Percent10, EmulatedProtocol::V1Exception);
        b.set_tool_number(5);
        for req in [
            Request::ReadInput { addr: 0, count: 15 },
            Request::ReadInput { addr: 9, count: 1 },
            Request::ReadInput { addr: 14, count: 1 },
            Request::ReadHolding { addr: 0, count: 5 },
            Request::ReadHolding { addr: 4, count: 1 },
            Request::WriteSingle { addr: 4, value: 1 },
            Request::WriteMultiple {
                addr: 3,
                values: vec![500, 1],
            },
        ] {
            assert_eq!(
                b.handle(req.clone(), 0),
                Err(Exception::IllegalDataAddress),
                "{req:?}"
            );
        }
        assert_eq!(
            b.handle(Request::ReadInput { addr: 0, count: 9 }, 0)
                .map(|r| match r {
                    Reply::Registers(r) => r.len(),
                    _ => 0,
                }),
            Ok(9)
        );
        let s = b.status();
        assert_eq!(
            s,
            BoardStatus::from_v1_input_registers(&s.to_v1_input_registers())
        );
        assert_eq!((s.protocol_version, s.tool_number), (0, 0));
    }

    #[test]
    fn v1_zeros_board_reads_zeros_for_registers_9_to_14() {
        let mut b =
            BoardLogic::with_protocol(OverrideResolution::Percent10, EmulatedProtocol::V1Zeros);
        b.set_tool_number(5);
        b.set_actual_feed_mm_min(300);
        match read_all_inputs(&mut b) {
            Ok(Reply::Registers(r)) => assert_eq!(r[9..], [0; 6]),
            other => panic!("{other:?}"),
        }
        // FALLBACK_MODE reads 0; a write is accepted and changes nothing.
        assert!(write1(&mut b, holding::FALLBACK_MODE, 7, 0).is_ok());
        assert_eq!(
            b.handle(Request::ReadHolding { addr: 0, count: 5 }, 0),
            Ok(Reply::Registers(vec![100, 0, 0, 500, 0]))
        );
        assert!(!b.status().is_v2());
    }

    #[test]
    fn watchdog_trip_clamps_to_the_override_of_the_moment_and_holds_the_feed() {
        let mut b = cutting(EmulatedProtocol::V2, 100, 60);
        b.tick(500);
        let s = b.status();
        assert!(s.watchdog_tripped && !s.acc_active);
        assert!(s.fallback_active && s.feed_hold_active);
        assert_eq!((s.override_applied_pct, s.fallback_override_pct), (60, 60));
        let r = b.input_registers();
        assert_eq!(
            r[0] & (status_bits::FALLBACK_ACTIVE | status_bits::FEED_HOLD_ACTIVE),
            status_bits::FALLBACK_ACTIVE | status_bits::FEED_HOLD_ACTIVE
        );
        assert_eq!(r[14], 60);
        // ALARM_RESET without ACC_REQUEST clears the trip and the feed hold, not the clamp.
        write1(&mut b, holding::CONTROL, RESET, 600).expect("reset");
        let s = b.status();
        assert!(!s.watchdog_tripped && !s.feed_hold_active && s.fallback_active);
        assert_eq!(s.override_applied_pct, 60);
        // The same knob position written again is no turn of the knob.
        b.set_operator_override_pct(100);
        assert_eq!(b.override_applied_pct(), 60);
        // A knob below the clamp wins (min), but turning it is a deliberate act: clamp ends.
        b.set_operator_override_pct(40);
        assert_eq!(b.override_applied_pct(), 40);
        assert!(!b.fallback_active());
        assert_eq!(b.fallback_override_pct(), 150);
        b.set_operator_override_pct(120);
        assert_eq!(b.override_applied_pct(), 120);
    }

    #[test]
    fn clamp_applies_the_lower_of_knob_and_clamp() {
        let mut b = cutting(EmulatedProtocol::V2, 50, 80);
        write1(&mut b, holding::CONTROL, 0, 10).expect("release");
        let s = b.status();
        assert!(
            s.fallback_active && !s.feed_hold_active,
            "a release holds nothing"
        );
        assert_eq!((s.override_applied_pct, s.fallback_override_pct), (50, 80));
    }

    #[test]
    fn watchdog_trip_with_fallback_mode_0_clamps_without_feed_hold() {
        let mut b = cutting(EmulatedProtocol::V2, 150, 90);
        write1(&mut b, holding::FALLBACK_MODE, 0, 0).expect("mode");
        b.tick(499);
        assert!(b.acc_active());
        b.tick(500);
        let s = b.status();
        assert!(s.watchdog_tripped && s.fallback_active && !s.feed_hold_active);
        assert_eq!(s.override_applied_pct, 90);
    }

    #[test]
    fn controller_release_clamps_and_the_clamp_is_taken_in_register_order() {
        // CONTROL = 0 in the same FC16 write as a new command: the command is applied first
        // (register order), so the clamp is the new command.
        let mut b = cutting(EmulatedProtocol::V2, 100, 90);
        b.write_holding(0, &[30, 2, 0], 10).expect("write");
        let s = b.status();
        assert!(!s.acc_active && s.fallback_active);
        assert_eq!((s.override_applied_pct, s.fallback_override_pct), (30, 30));
        // The controller re-arms: ACC active again ends the clamp.
        b.write_holding(0, &[110, 3, ACC], 20).expect("re-arm");
        let s = b.status();
        assert!(s.acc_active && !s.fallback_active);
        assert_eq!(
            (s.override_applied_pct, s.fallback_override_pct),
            (110, 150)
        );
    }

    #[test]
    fn operator_switch_off_and_override_lock_do_not_clamp() {
        let mut b = cutting(EmulatedProtocol::V2, 100, 50);
        b.set_acc_switch(false);
        assert!(!b.fallback_active());
        assert_eq!(b.override_applied_pct(), 100, "the operator took over");
        b.set_acc_switch(true);
        assert!(b.acc_active());
        b.set_override_locked(true);
        assert!(!b.acc_active() && !b.fallback_active());
        assert_eq!(b.override_applied_pct(), 100);
    }

    #[test]
    fn clamp_ends_when_the_cycle_ends_and_is_not_engaged_outside_a_cycle() {
        let mut b = cutting(EmulatedProtocol::V2, 100, 40);
        write1(&mut b, holding::CONTROL, 0, 10).expect("release");
        assert_eq!(b.override_applied_pct(), 40);
        b.set_cycle_active(false);
        assert!(!b.fallback_active());
        assert_eq!(b.override_applied_pct(), 100);
        // Out of a cycle a release has nothing to protect: no clamp.
        write1(&mut b, holding::CONTROL, ACC, 20).expect("arm");
        write1(&mut b, holding::OVERRIDE_CMD, 40, 20).expect("cmd");
        write1(&mut b, holding::CONTROL, 0, 30).expect("release");
        assert!(!b.fallback_active());
        assert_eq!(b.override_applied_pct(), 100);
    }

    #[test]
    fn clamp_survives_the_operator_switch_off_and_alarm_reset() {
        let mut b = cutting(EmulatedProtocol::V2, 100, 70);
        b.tick(500);
        b.set_acc_switch(false);
        write1(&mut b, holding::CONTROL, RESET, 600).expect("reset");
        assert!(b.fallback_active());
        assert_eq!(b.override_applied_pct(), 70);
    }

    #[test]
    fn power_cycle_in_a_cycle_sets_restarted_and_holds_the_feed_until_alarm_reset() {
        let mut b = cutting(EmulatedProtocol::V2, 100, 60);
        b.power_cycle();
        let s = b.status();
        assert!(s.board_restarted && s.feed_hold_active && !s.acc_active);
        assert!(!s.fallback_active, "the board lost the last override");
        assert_eq!(
            b.input_registers()[0] & status_bits::BOARD_RESTARTED,
            status_bits::BOARD_RESTARTED
        );
        // The controller re-arms: override first, then ALARM_RESET with ACC_REQUEST.
        b.write_holding(0, &[60, 1], 100).expect("cmd");
        assert!(b.status().feed_hold_active, "feed hold until ALARM_RESET");
        write1(&mut b, holding::CONTROL, ACC | RESET, 100).expect("reset");
        let s = b.status();
        assert!(!s.board_restarted && !s.feed_hold_active && s.acc_active);
        assert_eq!(s.override_applied_pct, 60);
        // Out of a cycle: restarted, but no feed hold.
        b.set_cycle_active(false);
        b.power_cycle();
        let s = b.status();
        assert!(s.board_restarted && !s.feed_hold_active);
    }

    #[test]
    fn v1_board_hands_the_feed_to_the_knob_after_a_watchdog_trip() {
        // Why a controller on a v1 board must never release mid-cut: last command 40 %, the
        // knob at 100 %, the link dies: the board drives 100 %, no feed hold.
        for protocol in [EmulatedProtocol::V1Exception, EmulatedProtocol::V1Zeros] {
            let mut b = cutting(protocol, 100, 40);
            b.tick(500);
            let s = b.status();
            assert!(s.watchdog_tripped && !s.fallback_active && !s.feed_hold_active);
            assert_eq!(s.override_applied_pct, 100, "{protocol:?}");
            assert_eq!(s.fallback_override_pct, 150);
            // A release raises the feed the same way.
            let mut b = cutting(protocol, 100, 40);
            write1(&mut b, holding::CONTROL, 0, 10).expect("release");
            assert_eq!(b.override_applied_pct(), 100);
            // A power cycle in a cycle: no restarted bit, no feed hold.
            b.power_cycle();
            let s = b.status();
            assert!(!s.board_restarted && !s.feed_hold_active);
            assert_eq!(b.input_registers()[0] & 0x180, 0);
        }
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        /// What the controller, the clock and the power supply do to the board.
        #[derive(Debug, Clone)]
        enum Op {
            /// FC16 `OVERRIDE_CMD`, `HEARTBEAT` (a new heartbeat).
            Override(u16),
            /// FC06 `HEARTBEAT` (a new value).
            Heartbeat,
            /// FC06 `CONTROL` with any defined bits (clearing `ACC_REQUEST`, `ALARM_RESET`…).
            Control(u16),
            /// FC06 `FALLBACK_MODE`.
            FallbackMode(u16),
            /// Time passes with no request: link silence (watchdog trips).
            Silence(u64),
            /// A power cycle of the board.
            PowerCycle,
        }

        fn op() -> impl Strategy<Value = Op> {
            prop_oneof![
                3 => (0u16..=15).prop_map(|k| Op::Override(k * 10)),
                2 => Just(Op::Heartbeat),
                3 => (0u16..8).prop_map(Op::Control),
                1 => (0u16..2).prop_map(Op::FallbackMode),
                3 => (0u64..1500).prop_map(Op::Silence),
                1 => Just(Op::PowerCycle),
            ]
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(512))]

            /// The knob stays where it is and the cycle runs: whatever the controller
            /// writes, however long the link is silent, however often the board restarts,
            /// the override a v2 board applies while ACC is not active never exceeds the
            /// last override it applied while ACC was active, and after a power cycle the
            /// feed is held until the controller writes ALARM_RESET.
            #[test]
            fn v2_never_raises_the_feed_above_the_last_acc_override(
                knob in (0u16..=15).prop_map(|k| k * 10),
                first in (0u16..=15).prop_map(|k| k * 10),
                ops in proptest::collection::vec(op(), 1..60),
            ) {
                let mut b = cutting(EmulatedProtocol::V2, knob, first);
                let mut now = 0u64;
                let mut hb = 1u16;
                let mut last_acc = first;
                // Power cycled, and the controller has not written ALARM_RESET since.
                let mut restarted_unreset = false;
                // Power cycled, and ACC has not been active since: the board lost the last
                // command, the controller must re-arm (its job; see the spec).
                let mut restarted = false;
                // A watchdog trip in FALLBACK_MODE 1 not yet reset.
                let mut wd_hold = false;
                for op in ops {
                    now += 1;
                    let tripped_before = b.status().watchdog_tripped;
                    let mode_before = b.fallback_mode();
                    match op {
                        Op::Override(v) => {
                            hb = hb.wrapping_add(1);
                            b.handle(Request::WriteMultiple { addr: 0, values: vec![v, hb] }, now)
                                .expect("valid write");
                        }
                        Op::Heartbeat => {
                            hb = hb.wrapping_add(1);
                            write1(&mut b, holding::HEARTBEAT, hb, now).expect("hb");
                        }
                        Op::Control(v) => {
                            write1(&mut b, holding::CONTROL, v, now).expect("control");
                            if v & RESET != 0 {
                                restarted_unreset = false;
                                wd_hold = false;
                            }
                        }
                        Op::FallbackMode(v) => {
                            write1(&mut b, holding::FALLBACK_MODE, v, now).expect("mode");
                        }
                        Op::Silence(ms) => {
                            now += ms;
                            b.tick(now);
                        }
                        Op::PowerCycle => {
                            b.power_cycle();
                            restarted_unreset = true;
                            restarted = true;
                            wd_hold = false;
                        }
                    }
                    let s = b.status();
                    prop_assert_eq!(s.operator_override_pct, knob);
                    if s.acc_active {
                        last_acc = s.override_applied_pct;
                        restarted = false;
                    } else if !restarted {
                        prop_assert!(
                            s.override_applied_pct <= last_acc,
                            "applied {} > last ACC override {} ({:?})",
                            s.override_applied_pct, last_acc, s
                        );
                        if s.fallback_active {
                            prop_assert_eq!(
                                s.override_applied_pct,
                                knob.min(s.fallback_override_pct)
                            );
                        }
                    }
                    if restarted_unreset {
                        prop_assert!(s.feed_hold_active && s.board_restarted, "{:?}", s);
                    }
                    if !tripped_before && s.watchdog_tripped && mode_before == FallbackMode::ClampAndFeedHold {
                        wd_hold = true;
                    }
                    if wd_hold {
                        prop_assert!(s.feed_hold_active, "watchdog feed hold: {:?}", s);
                    }
                }
            }
        }
    }
}
