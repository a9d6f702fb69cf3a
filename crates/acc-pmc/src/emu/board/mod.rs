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

//!
//! The board's rules, one concern a file: the register map and the Modbus requests
//! ([`registers`]: [`Request`], [`Reply`], [`Exception`], validation, read-back), `ACC_ACTIVE`
//! with the watchdog, the fallback clamp and the feed holds ([`fallback`]), and the machine
//! side, what the CNC and the operator set ([`machine`]).

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use crate::regs::{FallbackMode, OverrideResolution, OVERRIDE_DEFAULT_PCT, WATCHDOG_DEFAULT_MS};

pub mod fallback;
pub mod machine;
pub mod registers;

pub use registers::{Exception, Reply, Request};

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
}

#[cfg(test)]
mod tests;
