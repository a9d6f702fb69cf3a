//! The emulated PMC interface board, as a pure state machine (`../shared/docs/pmc-board.md`, v1).
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
//! ```
//! use acc_pmc::emu::board::{BoardLogic, Exception, Request, Reply};
//! use acc_pmc::regs::{holding, OverrideResolution};
//! let mut board = BoardLogic::new(OverrideResolution::Percent10);
//! board.set_acc_switch(true);
//! board.set_operator_override_pct(80);
//! // The controller asks for the override (CONTROL bit 0) and commands 120 %.
//! board.handle(Request::WriteSingle { addr: holding::CONTROL, value: 1 }, 0).unwrap();
//! board.handle(Request::WriteMultiple { addr: holding::OVERRIDE_CMD, values: vec![120, 1] }, 0).unwrap();
//! assert_eq!(board.status().override_applied_pct, 120);
//! // 125 is not a multiple of the 10 % step: exception 03, the old value stays.
//! let err = board.handle(Request::WriteSingle { addr: holding::OVERRIDE_CMD, value: 125 }, 0);
//! assert_eq!(err, Err(Exception::IllegalDataValue));
//! // No heartbeat change for WATCHDOG_MS = 500 ms: the board falls back to the operator.
//! board.tick(500);
//! assert!(board.status().watchdog_tripped);
//! assert_eq!(board.status().override_applied_pct, 80);
//! ```

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use crate::regs::{
    control_bits, holding, input, OverrideResolution, MAX_READ_COUNT, MAX_WRITE_COUNT,
    OVERRIDE_DEFAULT_PCT, OVERRIDE_MAX_PCT, WATCHDOG_DEFAULT_MS, WATCHDOG_RANGE_MS,
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

/// The board: holding registers, machine-side inputs, and the behaviour rules of the spec.
///
/// Time: every call that can change the watchdog takes `now_ms`, a monotonic time in
/// milliseconds from any origin. The board never reads a clock.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoardLogic {
    resolution: OverrideResolution,
    // --- holding registers ---
    override_cmd_pct: u16,
    heartbeat: u16,
    acc_request: bool,
    feed_hold_request: bool,
    watchdog_ms: u16,
    // --- internal state ---
    watchdog_tripped: bool,
    /// Start of the current watchdog interval: the last heartbeat change, ACC request
    /// edge, alarm reset or power cycle, ms.
    watchdog_since_ms: Option<u64>,
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
}

impl Default for BoardLogic {
    fn default() -> Self {
        Self::new(OverrideResolution::default())
    }
}

impl BoardLogic {
    /// A board just powered up: `OVERRIDE_CMD` = 100, `CONTROL` = 0, `WATCHDOG_MS` = 500,
    /// `ACC_ACTIVE` off; operator switch off, operator override 100 %, no power, no cycle.
    pub fn new(resolution: OverrideResolution) -> Self {
        Self {
            resolution,
            override_cmd_pct: OVERRIDE_DEFAULT_PCT,
            heartbeat: 0,
            acc_request: false,
            feed_hold_request: false,
            watchdog_ms: WATCHDOG_DEFAULT_MS,
            watchdog_tripped: false,
            watchdog_since_ms: None,
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
        }
    }

    /// Power cycle: holding registers back to their defaults (`OVERRIDE_CMD` = 100,
    /// `HEARTBEAT` = 0, `CONTROL` = 0, `WATCHDOG_MS` = 500), watchdog cleared. The machine
    /// side (switches, power, rpm, …) is the CNC's and stays as it is.
    pub fn power_cycle(&mut self) {
        self.override_cmd_pct = OVERRIDE_DEFAULT_PCT;
        self.heartbeat = 0;
        self.acc_request = false;
        self.feed_hold_request = false;
        self.watchdog_ms = WATCHDOG_DEFAULT_MS;
        self.watchdog_tripped = false;
        self.watchdog_since_ms = None;
    }

    // ------------------------------------------------------------------ controller side

    /// Advance the watchdog to `now_ms`: trips when `ACC_REQUEST` is set and `HEARTBEAT` has
    /// not changed for `WATCHDOG_MS` (spec, "Board behaviour"). Call it at least once per
    /// millisecond of interest; [`BoardLogic::handle`] calls it before every request.
    pub fn tick(&mut self, now_ms: u64) {
        if !self.acc_request || self.watchdog_tripped {
            return;
        }
        let since = *self.watchdog_since_ms.get_or_insert(now_ms);
        if now_ms.saturating_sub(since) >= u64::from(self.watchdog_ms) {
            self.watchdog_tripped = true;
        }
    }

    /// Serve one Modbus request at time `now_ms` (ms). Writes are all-or-nothing: an
    /// exception leaves every register unchanged.
    pub fn handle(&mut self, request: Request, now_ms: u64) -> Result<Reply, Exception> {
        self.tick(now_ms);
        match request {
            Request::ReadHolding { addr, count } => {
                let range = check_range(addr, count, holding::COUNT, MAX_READ_COUNT)?;
                let regs = self.holding_registers();
                Ok(Reply::Registers(regs[range].to_vec()))
            }
            Request::ReadInput { addr, count } => {
                let range = check_range(addr, count, input::COUNT, MAX_READ_COUNT)?;
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
    /// then apply all (FC06 is a write of one).
    ///
    /// Errors: exception 02 for addresses outside `0..4`; exception 03 for an empty or
    /// too long write, an override above 150 or not a multiple of the step, a watchdog
    /// outside 100…5000 ms, or an undefined `CONTROL` bit.
    pub fn write_holding(
        &mut self,
        addr: u16,
        values: &[u16],
        now_ms: u64,
    ) -> Result<(), Exception> {
        self.tick(now_ms);
        let count = u16::try_from(values.len()).map_err(|_| Exception::IllegalDataValue)?;
        let range = check_range(addr, count, holding::COUNT, MAX_WRITE_COUNT)?;
        for (reg, &value) in range.clone().zip(values) {
            self.validate_holding(reg as u16, value)?;
        }
        for (reg, &value) in range.zip(values) {
            self.apply_holding(reg as u16, value, now_ms);
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
                }
            }
            holding::WATCHDOG_MS => self.watchdog_ms = value,
            _ => {}
        }
    }

    /// Holding registers 0…3 as they read back (`ALARM_RESET` reads 0).
    pub fn holding_registers(&self) -> [u16; holding::COUNT as usize] {
        let mut control = 0;
        if self.acc_request {
            control |= control_bits::ACC_REQUEST;
        }
        if self.feed_hold_request {
            control |= control_bits::FEED_HOLD_REQUEST;
        }
        [
            self.override_cmd_pct,
            self.heartbeat,
            control,
            self.watchdog_ms,
            crate::regs::FallbackMode::default().to_register(),
        ]
    }

    /// Input registers 0…8 as the controller reads them.
    pub fn input_registers(&self) -> [u16; input::COUNT as usize] {
        self.status().to_input_registers()
    }

    /// The status block (input registers 0…8) decoded.
    pub fn status(&self) -> BoardStatus {
        let acc_active = self.acc_active();
        BoardStatus {
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
            // TODO(v2): the emulator's v2 behaviour (clamp, context registers).
            fallback_active: false,
            board_restarted: false,
            protocol_version: 0,
            tool_number: 0,
            program_number: 0,
            block_number: 0,
            actual_feed_mm_min: 0,
            fallback_override_pct: crate::regs::FALLBACK_NONE_PCT,
        }
    }

    /// `ACC_ACTIVE` = `ACC_SWITCH` ∧ `ACC_REQUEST` ∧ ¬`WATCHDOG_TRIPPED` ∧ ¬`OVERRIDE_LOCKED`.
    pub fn acc_active(&self) -> bool {
        self.acc_switch && self.acc_request && !self.watchdog_tripped && !self.override_locked
    }

    /// `OVERRIDE_APPLIED`, percent: `OVERRIDE_CMD` while `ACC_ACTIVE`, otherwise the
    /// operator's switch. This is what the machine's feed drive should obey (the NC itself
    /// forces 100 % while `OVERRIDE_LOCKED`; that is the machine's business, not the board's).
    pub fn override_applied_pct(&self) -> u16 {
        if self.acc_active() {
            self.override_cmd_pct
        } else {
            self.operator_override_pct
        }
    }

    /// `FEED_HOLD_ACTIVE`: the controller's `FEED_HOLD_REQUEST` or the operator's feed hold.
    pub fn feed_hold_active(&self) -> bool {
        self.feed_hold_request || self.operator_feed_hold
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
    }

    /// The operator's override switch, percent; clamped to 0…150.
    pub fn set_operator_override_pct(&mut self, pct: u16) {
        self.operator_override_pct = pct.min(OVERRIDE_MAX_PCT);
    }

    /// NC cycle running (`CYCLE_ACTIVE`).
    pub fn set_cycle_active(&mut self, on: bool) {
        self.cycle_active = on;
    }

    /// The NC forces 100 % (tapping, threading, override cancel): `OVERRIDE_LOCKED`.
    pub fn set_override_locked(&mut self, on: bool) {
        self.override_locked = on;
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
}
