//! The board's register map (`../shared/docs/pmc-board.md`, protocol v2, which keeps every v1
//! register where it was): register addresses, bits,
//! limits, and [`BoardStatus`] ⇄ input registers, [`ControlBits`] ⇄ `CONTROL`. Pure data
//! and pure functions, shared by the clients ([`crate::rtu`], [`crate::can`]) and the
//! emulator (`crate::emu`, feature `emulator`).
//!
//! ```
//! use acc_pmc::regs::{input, status_bits};
//! use acc_pmc::BoardStatus;
//! let mut regs = [0u16; input::COUNT as usize];
//! regs[input::STATUS as usize] = status_bits::ACC_SWITCH | status_bits::ACC_ACTIVE;
//! regs[input::POWER_HI as usize] = 0x0001;
//! regs[input::POWER_LO as usize] = 0x86A0;
//! regs[input::PROTOCOL_VERSION as usize] = 2;
//! regs[input::TOOL_NUMBER as usize] = 7;
//! let status = BoardStatus::from_input_registers(&regs);
//! assert!(status.acc_switch && status.acc_active);
//! assert_eq!(status.spindle_power_w, 100_000);
//! assert!(status.is_v2());
//! assert_eq!(status.tool_number, 7);
//! assert_eq!(status.to_input_registers(), regs);
//! // A v1 board has registers 0…8 only: the v2 fields read as "unknown".
//! let v1 = BoardStatus::from_v1_input_registers(&[0x03, 100, 100, 10, 0, 500, 6000, 1, 800]);
//! assert!(!v1.is_v2());
//! assert_eq!(v1.fallback_override_pct, 150);
//! ```

use crate::{BoardStatus, ControlBits};

/// Holding register addresses (0-based protocol addresses; read with FC03, write FC06/FC16).
pub mod holding {
    /// `OVERRIDE_CMD`: requested feed override, percent, 0…150, multiple of `OVERRIDE_STEP`.
    pub const OVERRIDE_CMD: u16 = 0;
    /// `HEARTBEAT`: changed by the controller every cycle.
    pub const HEARTBEAT: u16 = 1;
    /// `CONTROL`: bits `ACC_REQUEST`, `FEED_HOLD_REQUEST`, `ALARM_RESET`.
    pub const CONTROL: u16 = 2;
    /// `WATCHDOG_MS`: watchdog time, ms, 100…5000, default 500.
    pub const WATCHDOG_MS: u16 = 3;
    /// `FALLBACK_MODE` (v2): what a watchdog trip does besides the fallback clamp,
    /// see [`super::FallbackMode`].
    pub const FALLBACK_MODE: u16 = 4;
    /// Number of holding registers of a v2 board (addresses `0..COUNT`).
    pub const COUNT: u16 = 5;
    /// Number of holding registers of a v1 board (no `FALLBACK_MODE`).
    pub const V1_COUNT: u16 = 4;
}

/// Input register addresses (0-based protocol addresses; read with FC04).
pub mod input {
    /// `STATUS` bits, see [`super::status_bits`].
    pub const STATUS: u16 = 0;
    /// `OVERRIDE_APPLIED`: override now on the PMC inputs, percent.
    pub const OVERRIDE_APPLIED: u16 = 1;
    /// `OPERATOR_OVERRIDE`: the operator's override switch, percent.
    pub const OPERATOR_OVERRIDE: u16 = 2;
    /// `OVERRIDE_STEP`: the board's resolution, percent (10 or 1).
    pub const OVERRIDE_STEP: u16 = 3;
    /// `POWER_HI`: spindle input power, W, high word of a u32.
    pub const POWER_HI: u16 = 4;
    /// `POWER_LO`: spindle input power, W, low word of a u32.
    pub const POWER_LO: u16 = 5;
    /// `SPINDLE_RPM`: actual spindle speed, rpm.
    pub const SPINDLE_RPM: u16 = 6;
    /// `SAMPLE_SEQ`: wraps, increments with every new power sample.
    pub const SAMPLE_SEQ: u16 = 7;
    /// `PROGRAMMED_FEED`: programmed feed of the active block, mm/min (0 = unknown).
    pub const PROGRAMMED_FEED: u16 = 8;
    /// `PROTOCOL_VERSION` (v2): 2. A v1 board answers exception 02 or 0 here.
    pub const PROTOCOL_VERSION: u16 = 9;
    /// `TOOL_NUMBER` (v2): active tool (T word), 0 = none/unknown.
    pub const TOOL_NUMBER: u16 = 10;
    /// `PROGRAM_NUMBER` (v2): running program (O number), 0 = unknown.
    pub const PROGRAM_NUMBER: u16 = 11;
    /// `BLOCK_NUMBER` (v2): sequence number of the active block (N word, low 16 bits),
    /// 0 = unknown.
    pub const BLOCK_NUMBER: u16 = 12;
    /// `ACTUAL_FEED` (v2): actual path feed from the NC, mm/min (after override, 0 in feed
    /// hold).
    pub const ACTUAL_FEED: u16 = 13;
    /// `FALLBACK_OVERRIDE` (v2): the fallback clamp now applied, percent; 150 when no clamp
    /// is engaged.
    pub const FALLBACK_OVERRIDE: u16 = 14;
    /// Number of input registers of a v2 board (addresses `0..COUNT`).
    pub const COUNT: u16 = 15;
    /// Number of input registers of a v1 board (addresses `0..V1_COUNT`).
    pub const V1_COUNT: u16 = 9;
}

/// Bits of the `STATUS` input register.
pub mod status_bits {
    /// bit 0 `ACC_SWITCH`: the operator's ACC ON switch.
    pub const ACC_SWITCH: u16 = 1 << 0;
    /// bit 1 `ACC_ACTIVE`: the board is driving the override.
    pub const ACC_ACTIVE: u16 = 1 << 1;
    /// bit 2 `CYCLE_ACTIVE`: NC cycle running.
    pub const CYCLE_ACTIVE: u16 = 1 << 2;
    /// bit 3 `FEED_HOLD_ACTIVE`: the NC's feed hold is asserted.
    pub const FEED_HOLD_ACTIVE: u16 = 1 << 3;
    /// bit 4 `WATCHDOG_TRIPPED`.
    pub const WATCHDOG_TRIPPED: u16 = 1 << 4;
    /// bit 5 `OVERRIDE_LOCKED`: the NC forces 100 % (tapping, threading, override cancel).
    pub const OVERRIDE_LOCKED: u16 = 1 << 5;
    /// bit 6 `CNC_ALARM`.
    pub const CNC_ALARM: u16 = 1 << 6;
    /// bit 7 `FALLBACK_ACTIVE` (v2): the fallback clamp is engaged.
    pub const FALLBACK_ACTIVE: u16 = 1 << 7;
    /// bit 8 `BOARD_RESTARTED` (v2): set at power-up, cleared by `ALARM_RESET`.
    pub const BOARD_RESTARTED: u16 = 1 << 8;
}

/// Bits of the `CONTROL` holding register.
pub mod control_bits {
    /// bit 0 `ACC_REQUEST`: the controller wants to drive the override.
    pub const ACC_REQUEST: u16 = 1 << 0;
    /// bit 1 `FEED_HOLD_REQUEST`: assert the NC's feed hold.
    pub const FEED_HOLD_REQUEST: u16 = 1 << 1;
    /// bit 2 `ALARM_RESET`: write 1 to clear a tripped watchdog; reads back 0.
    pub const ALARM_RESET: u16 = 1 << 2;
    /// All bits the board defines; writing any other bit is exception 03.
    pub const DEFINED: u16 = ACC_REQUEST | FEED_HOLD_REQUEST | ALARM_RESET;
}

/// `PROTOCOL_VERSION` of a v2 board.
pub const PROTOCOL_V2: u16 = 2;
/// `FALLBACK_OVERRIDE` when no clamp is engaged, percent.
pub const FALLBACK_NONE_PCT: u16 = 150;

/// `FALLBACK_MODE` (holding register 4, v2): what a watchdog trip does besides engaging the
/// fallback clamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FallbackMode {
    /// 0: clamp only.
    ClampOnly,
    /// 1: clamp and feed hold until `ALARM_RESET` (power-up default).
    #[default]
    ClampAndFeedHold,
}

impl FallbackMode {
    /// The register value (0 or 1).
    pub fn to_register(self) -> u16 {
        match self {
            FallbackMode::ClampOnly => 0,
            FallbackMode::ClampAndFeedHold => 1,
        }
    }

    /// The mode for a register value; `None` outside 0…1.
    pub fn from_register(v: u16) -> Option<Self> {
        match v {
            0 => Some(FallbackMode::ClampOnly),
            1 => Some(FallbackMode::ClampAndFeedHold),
            _ => None,
        }
    }
}

/// Highest `OVERRIDE_CMD` the board accepts, percent.
pub const OVERRIDE_MAX_PCT: u16 = 150;
/// Power-cycle default of `OVERRIDE_CMD`, percent.
pub const OVERRIDE_DEFAULT_PCT: u16 = 100;
/// Power-cycle default of `WATCHDOG_MS`, ms.
pub const WATCHDOG_DEFAULT_MS: u16 = 500;
/// Allowed range of `WATCHDOG_MS`, ms.
pub const WATCHDOG_RANGE_MS: core::ops::RangeInclusive<u16> = 100..=5000;
/// Largest register count a Modbus read may ask for (Modbus application protocol v1.1b3,
/// §6.3/6.4); a larger or zero count is exception 03.
pub const MAX_READ_COUNT: u16 = 125;
/// Largest register count of a Modbus FC16 write (§6.12).
pub const MAX_WRITE_COUNT: u16 = 123;

/// The board's override resolution (`OVERRIDE_STEP`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OverrideResolution {
    /// 4-bit board (`*OV1 *OV2 *OV4 *OV8`): 10 % steps, 16 positions 0…150 %.
    #[default]
    Percent10,
    /// Byte board (`G012`): 1 % steps.
    Percent1,
}

impl OverrideResolution {
    /// The step in percent (10 or 1).
    pub fn step_pct(self) -> u16 {
        match self {
            OverrideResolution::Percent10 => 10,
            OverrideResolution::Percent1 => 1,
        }
    }

    /// The resolution for a step in percent; `None` unless the step is 10 or 1.
    pub fn from_step_pct(step_pct: u16) -> Option<Self> {
        match step_pct {
            10 => Some(OverrideResolution::Percent10),
            1 => Some(OverrideResolution::Percent1),
            _ => None,
        }
    }
}

impl BoardStatus {
    /// Encode as input registers 0…14 (spec table "Input registers", v2).
    pub fn to_input_registers(&self) -> [u16; input::COUNT as usize] {
        use status_bits as b;
        let flags = [
            (self.acc_switch, b::ACC_SWITCH),
            (self.acc_active, b::ACC_ACTIVE),
            (self.cycle_active, b::CYCLE_ACTIVE),
            (self.feed_hold_active, b::FEED_HOLD_ACTIVE),
            (self.watchdog_tripped, b::WATCHDOG_TRIPPED),
            (self.override_locked, b::OVERRIDE_LOCKED),
            (self.cnc_alarm, b::CNC_ALARM),
            (self.fallback_active, b::FALLBACK_ACTIVE),
            (self.board_restarted, b::BOARD_RESTARTED),
        ];
        let status = flags
            .iter()
            .filter(|(on, _)| *on)
            .fold(0, |acc, (_, bit)| acc | bit);
        [
            status,
            self.override_applied_pct,
            self.operator_override_pct,
            self.override_step_pct,
            (self.spindle_power_w >> 16) as u16,
            (self.spindle_power_w & 0xFFFF) as u16,
            self.spindle_rpm,
            self.sample_seq,
            self.programmed_feed_mm_min,
            self.protocol_version,
            self.tool_number,
            self.program_number,
            self.block_number,
            self.actual_feed_mm_min,
            self.fallback_override_pct,
        ]
    }

    /// Encode as a v1 board's input registers 0…8 (the v2 `STATUS` bits 7 and 8 are not
    /// part of v1 and are left out).
    pub fn to_v1_input_registers(&self) -> [u16; input::V1_COUNT as usize] {
        let all = self.to_input_registers();
        let mut v1 = [0u16; input::V1_COUNT as usize];
        v1.copy_from_slice(&all[..input::V1_COUNT as usize]);
        v1[input::STATUS as usize] &=
            !(status_bits::FALLBACK_ACTIVE | status_bits::BOARD_RESTARTED);
        v1
    }

    /// Decode input registers 0…14. Undefined `STATUS` bits are ignored.
    pub fn from_input_registers(regs: &[u16; input::COUNT as usize]) -> Self {
        use status_bits as b;
        let s = regs[input::STATUS as usize];
        BoardStatus {
            acc_switch: s & b::ACC_SWITCH != 0,
            acc_active: s & b::ACC_ACTIVE != 0,
            cycle_active: s & b::CYCLE_ACTIVE != 0,
            feed_hold_active: s & b::FEED_HOLD_ACTIVE != 0,
            watchdog_tripped: s & b::WATCHDOG_TRIPPED != 0,
            override_locked: s & b::OVERRIDE_LOCKED != 0,
            cnc_alarm: s & b::CNC_ALARM != 0,
            fallback_active: s & b::FALLBACK_ACTIVE != 0,
            board_restarted: s & b::BOARD_RESTARTED != 0,
            override_applied_pct: regs[input::OVERRIDE_APPLIED as usize],
            operator_override_pct: regs[input::OPERATOR_OVERRIDE as usize],
            override_step_pct: regs[input::OVERRIDE_STEP as usize],
            spindle_power_w: (u32::from(regs[input::POWER_HI as usize]) << 16)
                | u32::from(regs[input::POWER_LO as usize]),
            spindle_rpm: regs[input::SPINDLE_RPM as usize],
            sample_seq: regs[input::SAMPLE_SEQ as usize],
            programmed_feed_mm_min: regs[input::PROGRAMMED_FEED as usize],
            protocol_version: regs[input::PROTOCOL_VERSION as usize],
            tool_number: regs[input::TOOL_NUMBER as usize],
            program_number: regs[input::PROGRAM_NUMBER as usize],
            block_number: regs[input::BLOCK_NUMBER as usize],
            actual_feed_mm_min: regs[input::ACTUAL_FEED as usize],
            fallback_override_pct: regs[input::FALLBACK_OVERRIDE as usize],
        }
    }

    /// Decode a v1 board's input registers 0…8: the v2 fields read as unknown
    /// (`protocol_version` 0, no tool/program/block, no clamp: `fallback_override_pct`
    /// 150), and `STATUS` bits 7 and 8 (not defined in v1) are ignored.
    pub fn from_v1_input_registers(regs: &[u16; input::V1_COUNT as usize]) -> Self {
        let mut all = [0u16; input::COUNT as usize];
        all[..input::V1_COUNT as usize].copy_from_slice(regs);
        all[input::STATUS as usize] &=
            !(status_bits::FALLBACK_ACTIVE | status_bits::BOARD_RESTARTED);
        all[input::FALLBACK_OVERRIDE as usize] = FALLBACK_NONE_PCT;
        Self::from_input_registers(&all)
    }

    /// The board speaks protocol v2 (`PROTOCOL_VERSION` ≥ 2): fallback clamp, NC context.
    pub fn is_v2(&self) -> bool {
        self.protocol_version >= PROTOCOL_V2
    }
}

impl ControlBits {
    /// Encode as the `CONTROL` register value.
    pub fn to_register(self) -> u16 {
        let mut v = 0;
        if self.acc_request {
            v |= control_bits::ACC_REQUEST;
        }
        if self.feed_hold_request {
            v |= control_bits::FEED_HOLD_REQUEST;
        }
        if self.alarm_reset {
            v |= control_bits::ALARM_RESET;
        }
        v
    }

    /// Decode a `CONTROL` register value (undefined bits ignored).
    pub fn from_register(v: u16) -> Self {
        ControlBits {
            acc_request: v & control_bits::ACC_REQUEST != 0,
            feed_hold_request: v & control_bits::FEED_HOLD_REQUEST != 0,
            alarm_reset: v & control_bits::ALARM_RESET != 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_round_trips_through_registers() {
        let s = BoardStatus {
            acc_switch: true,
            acc_active: false,
            cycle_active: true,
            feed_hold_active: false,
            watchdog_tripped: true,
            override_locked: false,
            cnc_alarm: true,
            override_applied_pct: 90,
            operator_override_pct: 110,
            override_step_pct: 10,
            spindle_power_w: 0xDEAD_BEEF,
            spindle_rpm: 12_000,
            sample_seq: 65_000,
            programmed_feed_mm_min: 800,
            fallback_active: true,
            board_restarted: false,
            protocol_version: 2,
            tool_number: 12,
            program_number: 4711,
            block_number: 230,
            actual_feed_mm_min: 720,
            fallback_override_pct: 90,
        };
        let r = s.to_input_registers();
        assert_eq!(
            r,
            [
                0b1101_0101,
                90,
                110,
                10,
                0xDEAD,
                0xBEEF,
                12_000,
                65_000,
                800,
                2,
                12,
                4711,
                230,
                720,
                90
            ]
        );
        assert_eq!(BoardStatus::from_input_registers(&r), s);
        // every single status bit maps to its own field.
        for bit in 0..9 {
            let mut regs = [0u16; 15];
            regs[0] = 1 << bit;
            let d = BoardStatus::from_input_registers(&regs);
            let flags = [
                d.acc_switch,
                d.acc_active,
                d.cycle_active,
                d.feed_hold_active,
                d.watchdog_tripped,
                d.override_locked,
                d.cnc_alarm,
                d.fallback_active,
                d.board_restarted,
            ];
            assert_eq!(flags.iter().filter(|f| **f).count(), 1);
            assert!(flags[bit]);
            assert_eq!(d.to_input_registers(), regs);
        }
        // undefined bits are ignored.
        assert_eq!(
            BoardStatus::from_input_registers(&[0xFE00, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]),
            BoardStatus::default()
        );
        // v1: registers 0…8 only; bits 7 and 8 are not v1's and are ignored.
        let v1 = BoardStatus::from_v1_input_registers(&[0x0185, 90, 110, 10, 0, 1, 2, 3, 4]);
        assert!(v1.acc_switch && v1.cycle_active && !v1.fallback_active && !v1.board_restarted);
        assert!(!v1.is_v2());
        assert_eq!(v1.fallback_override_pct, FALLBACK_NONE_PCT);
        assert_eq!(
            v1.to_v1_input_registers(),
            [0x0005, 90, 110, 10, 0, 1, 2, 3, 4]
        );
    }

    #[test]
    fn fallback_mode_register() {
        for m in [FallbackMode::ClampOnly, FallbackMode::ClampAndFeedHold] {
            assert_eq!(FallbackMode::from_register(m.to_register()), Some(m));
        }
        assert_eq!(FallbackMode::from_register(2), None);
        assert_eq!(FallbackMode::default(), FallbackMode::ClampAndFeedHold);
    }

    #[test]
    fn control_bits_round_trip() {
        for v in 0..8u16 {
            assert_eq!(ControlBits::from_register(v).to_register(), v);
        }
        let c = ControlBits {
            acc_request: true,
            feed_hold_request: false,
            alarm_reset: true,
        };
        assert_eq!(c.to_register(), 0b101);
    }
}
