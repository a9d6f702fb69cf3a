//! The board emulator (feature `emulator`): everything that plays the *board's* side of the
//! link, for `acc board-sim`, the simulator and the tests. Production (`acc run`) needs none
//! of it.
//!
//! | module | what |
//! | --- | --- |
//! | [`board`] | the board as a pure state machine ([`BoardLogic`]): register behaviour of `pmc-board.md` v2 (or v1, [`EmulatedProtocol`]), `ACC_ACTIVE`, watchdog (time passed in), fallback clamp, feed holds, exceptions ([`Exception`]) |
//! | [`rtu_server`] | Modbus RTU slave ([`RtuServer`]) serving a [`SharedBoard`] over any `Read + Write` |
//! | [`can`] | in-memory CAN bus with the board on it ([`CanBoardEmulator`], [`MemFrame`]) |
//! | [`loopback`] | the emulated board on a pty pair ([`PtyBoard`]); UART pacing ([`Paced`]) |
//! | [`fault`] | fault injection on a client's byte stream or a server's replies ([`FaultInjector`]) |
//!
//! ```
//! use acc_pmc::emu::{lock_board, BoardLogic, CanBoardEmulator};
//! use acc_pmc::can::{CanBoard, CanLinkConfig};
//! use acc_pmc::{Board, ControlBits};
//! let board = BoardLogic::default().shared();
//! lock_board(&board).set_acc_switch(true);
//! lock_board(&board).push_power_sample(2_500);
//! let bus = CanBoardEmulator::new(board.clone(), 1).unwrap();
//! let mut link = CanBoard::new(bus, CanLinkConfig::default()).unwrap();
//! assert_eq!(link.read_status().unwrap().spindle_power_w, 2_500);
//! link.write_control(ControlBits { acc_request: true, ..Default::default() }).unwrap();
//! assert!(lock_board(&board).acc_active());
//! ```

pub mod board;
pub mod can;
pub mod fault;
pub mod loopback;
pub mod rtu_server;

pub use board::{lock_board, BoardLogic, EmulatedProtocol, Exception, Reply, Request, SharedBoard};
pub use can::{CanBoardEmulator, EmulatorStats, MemBusError, MemFrame};
pub use fault::{Fault, FaultInjector, FaultyStream};
pub use loopback::{Paced, PtyBoard};
pub use rtu_server::{spawn_server, RtuServer, ServerStats};
