//! The board's register map as the controller sees it: the Modbus requests it serves
//! ([`Request`], [`Reply`], [`Exception`]), the validation and all-or-nothing application
//! of holding-register writes, and the holding and input registers as they read back.

use super::{BoardLogic, EmulatedProtocol};
use crate::regs::OverrideResolution;
use crate::regs::{
    control_bits, holding, input, FallbackMode, MAX_READ_COUNT, MAX_WRITE_COUNT, OVERRIDE_MAX_PCT,
    PROTOCOL_V2, WATCHDOG_RANGE_MS,
};
use crate::BoardStatus;

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

impl BoardLogic {
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
