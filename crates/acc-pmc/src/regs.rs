//! The board's register map (`../shared/docs/pmc-board.md`, v1): register addresses, bits,
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
//! let status = BoardStatus::from_input_registers(&regs);
//! assert!(status.acc_switch && status.acc_active);
//! assert_eq!(status.spindle_power_w, 100_000);
//! assert_eq!(status.to_input_registers(), regs);
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
    /// Number of holding registers (addresses `0..COUNT`).
    pub const COUNT: u16 = 4;
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
    /// Number of input registers (addresses `0..COUNT`).
    pub const COUNT: u16 = 9;
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
    /// Encode as input registers 0…8 (spec table "Input registers").
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
        ]
    }

    /// Decode input registers 0…8. Undefined `STATUS` bits are ignored.
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
            override_applied_pct: regs[input::OVERRIDE_APPLIED as usize],
            operator_override_pct: regs[input::OPERATOR_OVERRIDE as usize],
            override_step_pct: regs[input::OVERRIDE_STEP as usize],
            spindle_power_w: (u32::from(regs[input::POWER_HI as usize]) << 16)
                | u32::from(regs[input::POWER_LO as usize]),
            spindle_rpm: regs[input::SPINDLE_RPM as usize],
            sample_seq: regs[input::SAMPLE_SEQ as usize],
            programmed_feed_mm_min: regs[input::PROGRAMMED_FEED as usize],
        }
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
        };
        let r = s.to_input_registers();
        assert_eq!(
            r,
            [0b101_0101, 90, 110, 10, 0xDEAD, 0xBEEF, 12_000, 65_000, 800]
        );
        assert_eq!(BoardStatus::from_input_registers(&r), s);
        // every single status bit maps to its own field.
        for bit in 0..7 {
            let mut regs = [0u16; 9];
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
            ];
            assert_eq!(flags.iter().filter(|f| **f).count(), 1);
            assert!(flags[bit]);
            assert_eq!(d.to_input_registers(), regs);
        }
        // undefined bits are ignored.
        assert_eq!(
            BoardStatus::from_input_registers(&[0xFF80, 0, 0, 0, 0, 0, 0, 0, 0]),
            BoardStatus::default()
        );
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
