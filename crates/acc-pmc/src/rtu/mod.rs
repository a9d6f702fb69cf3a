//! Modbus RTU: the board's link over a serial line.
//!
//! * [`codec`]: pure frames (built and checked with `rmodbus`), layered reply errors.
//! * [`RtuBoard`]: the client link, generic over any `Read + Write` byte stream; implements
//!   [`crate::Board`].
//!
//! The board side (`RtuServer`, serving the emulated board) lives in `crate::emu` (feature
//! `emulator`).
//!
//! Streams must return from `read` within a short time when no byte arrives
//! (`ErrorKind::TimedOut` or `WouldBlock`): a [`serialport::TTYPort`] opened by
//! [`crate::serial::open_port`] or configured with [`crate::serial::POLL_SLICE`] does.

pub mod client;
pub mod codec;

pub use client::{LinkStats, RtuBoard, RtuError, RtuLinkConfig};

/// Whether an I/O error only means "no byte yet" (the stream's read timeout).
pub(crate) fn is_idle(err: &std::io::Error) -> bool {
    matches!(
        err.kind(),
        std::io::ErrorKind::TimedOut
            | std::io::ErrorKind::WouldBlock
            | std::io::ErrorKind::Interrupted
    )
}
