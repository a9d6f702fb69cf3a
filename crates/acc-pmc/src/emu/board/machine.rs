//! The machine side of the board: what the CNC and the operator set (the [ACC ON] switch,
//! the override knob, the cycle, the lock, feed hold, spindle power and speed, the NC
//! context). The simulator or a test calls these; the controller never does.

use super::BoardLogic;
use crate::regs::OVERRIDE_MAX_PCT;

impl BoardLogic {
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
