//! `acc-pmc`: the PMC interface board as the controller sees it — the [`Board`] trait, the
//! board register map (`../shared/docs/pmc-board.md`), the Modbus RTU and CAN links — and,
//! behind the cargo feature `emulator`, the board's own side (emulator, servers, faults).
//!
//! | module | built | what |
//! | --- | --- | --- |
//! | crate root | always | [`Board`] (read status, write override + heartbeat, write `CONTROL`), [`BoardError`] / [`BoardErrorKind`], [`BoardStatus`], [`ControlBits`] |
//! | [`regs`] | always | pure register map: addresses, bits, limits, [`OverrideResolution`](regs::OverrideResolution); [`BoardStatus`] ⇄ input registers, [`ControlBits`] ⇄ `CONTROL` |
//! | [`rtu`] | always | Modbus RTU: pure codec on `rmodbus` ([`rtu::codec`]); client [`rtu::RtuBoard`] (implements [`Board`]) over any `Read + Write` |
//! | [`can`] | always | CAN: pure frame codec ([`can::codec`]); client [`can::CanBoard`] (implements [`Board`]) over any `embedded_can::blocking::Can` |
//! | [`serial`] | always | typed, validated serial config ([`serial::RtuConfig`]) and opening a port with read-back of the framing |
//! | [`clock`] | always | re-export of `acc_core::clock`, the injected [`clock::Clock`] ([`clock::SystemClock`], per-instance [`clock::ManualClock`]) |
//! | `emu` | feature `emulator` | the board emulator: `BoardLogic` (register behaviour), `RtuServer`, `CanBoardEmulator`, `PtyBoard`, fault injectors |
//!
//! One controller cycle, here on the in-memory CAN bus of the emulator (the RTU link reads
//! the same):
//!
//! ```
//! # #[cfg(feature = "emulator")] {
//! use acc_pmc::emu::{lock_board, BoardLogic, CanBoardEmulator};
//! use acc_pmc::can::{CanBoard, CanLinkConfig};
//! use acc_pmc::{Board, BoardError, BoardErrorKind, ControlBits};
//! let mut logic = BoardLogic::default();
//! logic.set_acc_switch(true);
//! logic.push_power_sample(3_000);
//! let board = logic.shared();
//! let bus = CanBoardEmulator::new(board.clone(), 1).unwrap();
//! let mut link = CanBoard::new(bus, CanLinkConfig::default()).unwrap();
//! let status = link.read_status().unwrap();
//! assert_eq!(status.spindle_power_w, 3_000);
//! link.write_control(ControlBits { acc_request: true, ..Default::default() }).unwrap();
//! link.write_override(120, 1).unwrap();
//! assert_eq!(lock_board(&board).override_applied_pct(), 120);
//! // The board's step is 10 %: 125 % is refused like exception 03.
//! let err = link.write_override(125, 2).unwrap_err();
//! assert_eq!(err.kind(), BoardErrorKind::Exception(3));
//! # }
//! ```
//!
//! CONTRACT NOTE: the names in this file are shared with the simulator and runtime crates.
//! Add, but do not rename.
#![deny(missing_docs)]

/// The `serialport` crate this crate links against (for `TTYPort`, `SerialPort`).
pub use serialport;

pub mod can;
pub use acc_core::clock;
#[cfg(feature = "emulator")]
pub mod emu;
pub mod regs;
pub mod rtu;
pub mod serial;

/// Status read from the board once per cycle (input registers 0…14 on a v2 board, 0…8 on a
/// v1 board, where the v2 fields read as unknown: see
/// [`BoardStatus::from_v1_input_registers`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BoardStatus {
    /// `STATUS` bit 0: operator's ACC ON switch.
    pub acc_switch: bool,
    /// `STATUS` bit 1: the board is driving the override.
    pub acc_active: bool,
    /// `STATUS` bit 2: NC cycle running.
    pub cycle_active: bool,
    /// `STATUS` bit 3: feed hold asserted.
    pub feed_hold_active: bool,
    /// `STATUS` bit 4: watchdog tripped (cleared only by `ALARM_RESET`).
    pub watchdog_tripped: bool,
    /// `STATUS` bit 5: NC forces 100 % (tapping, threading, override cancel).
    pub override_locked: bool,
    /// `STATUS` bit 6: CNC alarm.
    pub cnc_alarm: bool,
    /// `OVERRIDE_APPLIED`, percent.
    pub override_applied_pct: u16,
    /// `OPERATOR_OVERRIDE`, percent.
    pub operator_override_pct: u16,
    /// `OVERRIDE_STEP`, percent (10 or 1).
    pub override_step_pct: u16,
    /// `POWER_HI:POWER_LO`, spindle input power, W.
    pub spindle_power_w: u32,
    /// `SPINDLE_RPM`, rpm.
    pub spindle_rpm: u16,
    /// `SAMPLE_SEQ`, wraps; unchanged ⇒ stale power sensor.
    pub sample_seq: u16,
    /// `PROGRAMMED_FEED`, mm/min (0 = unknown).
    pub programmed_feed_mm_min: u16,
    /// `STATUS` bit 7 (v2): the board's fallback clamp is engaged.
    pub fallback_active: bool,
    /// `STATUS` bit 8 (v2): the board has powered up since the last `ALARM_RESET`.
    pub board_restarted: bool,
    /// `PROTOCOL_VERSION` (v2: 2; 0 on a v1 board).
    pub protocol_version: u16,
    /// `TOOL_NUMBER` (v2): active tool (T word), 0 = none/unknown.
    pub tool_number: u16,
    /// `PROGRAM_NUMBER` (v2): running program (O number), 0 = unknown.
    pub program_number: u16,
    /// `BLOCK_NUMBER` (v2): active block (N word, low 16 bits), 0 = unknown.
    pub block_number: u16,
    /// `ACTUAL_FEED` (v2): actual path feed from the NC, mm/min (after override, 0 in feed
    /// hold); 0 on a v1 board.
    pub actual_feed_mm_min: u16,
    /// `FALLBACK_OVERRIDE` (v2): the clamp now applied, percent; 150 when no clamp is
    /// engaged (and always 150 on a v1 board, which has no clamp).
    pub fallback_override_pct: u16,
}

/// The board's protocol generation, as a link found it (`../shared/docs/pmc-board.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoardProtocol {
    /// v1: registers 0…8 only. No fallback clamp (a watchdog trip, release or lost link
    /// falls back to the operator's knob, which can raise the feed), no `FALLBACK_MODE`, no
    /// tool / program / block / actual-feed registers, no `BOARD_RESTARTED`.
    V1,
    /// v2: the fallback clamp, `FALLBACK_MODE`, the NC context registers 9…14.
    V2,
}

impl BoardProtocol {
    /// What a controller cannot do on a board of this protocol, for the one-time
    /// announcement ("" for v2).
    pub fn limitations(self) -> &'static str {
        match self {
            BoardProtocol::V2 => "",
            BoardProtocol::V1 => {
                "v1 board: no fallback clamp (a watchdog trip, a killed controller or a pulled cable hands the feed back to the operator's knob, which can raise it), \
                 so ACC never releases mid-cut without a feed hold; no FALLBACK_MODE; no tool, program, block or actual-feed registers; no BOARD_RESTARTED bit"
            }
        }
    }
}

/// `CONTROL` register bits (holding register 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ControlBits {
    /// bit 0 `ACC_REQUEST`: the controller wants to drive the override.
    pub acc_request: bool,
    /// bit 1 `FEED_HOLD_REQUEST`.
    pub feed_hold_request: bool,
    /// bit 2 `ALARM_RESET`: write 1 to clear a tripped watchdog (reads back 0).
    pub alarm_reset: bool,
}

/// Error kinds the runtime acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoardErrorKind {
    /// No (complete) reply within the timeout.
    Timeout,
    /// Reply with a bad checksum.
    Crc,
    /// The board answered with a Modbus exception code (01 function, 02 address, 03 value…).
    Exception(u8),
    /// The port or bus is gone.
    Disconnected,
    /// A reply that parses but violates the protocol (wrong slave, wrong function, length).
    Protocol,
}

/// An error of a [`Board`] link: it knows which [`BoardErrorKind`] the runtime acts on
/// (embedded-hal habit: each driver's error maps onto one shared kind).
pub trait BoardError: std::error::Error + Send + Sync + 'static {
    /// Classify this error.
    fn kind(&self) -> BoardErrorKind;
}

/// The PMC interface board, as the controller sees it: narrow and fallible. Implemented by
/// the Modbus RTU board, the CAN board and the simulated board.
pub trait Board {
    /// Error type; carries its [`BoardErrorKind`] ([`BoardError::kind`]).
    type Error: BoardError;
    /// Read the status block (input registers 0…8).
    fn read_status(&mut self) -> Result<BoardStatus, Self::Error>;
    /// Write `OVERRIDE_CMD` (percent, a multiple of the board's step) and `HEARTBEAT` in
    /// one transaction.
    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error>;
    /// Write the `CONTROL` bits (ACC request, feed-hold request, alarm reset).
    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error>;
    /// The protocol the link found the board to speak; `None` until it knows (before the
    /// first successful status read). Links that only ever speak one protocol may keep the
    /// default, which derives nothing and says `None`.
    fn protocol(&self) -> Option<BoardProtocol> {
        None
    }
}
