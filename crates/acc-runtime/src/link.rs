//! Adapters between the links of `acc-pmc` and the runtime.

use std::io::{Read, Write};

use acc_pmc::can::{CanBoard, CanError};
use acc_pmc::rtu::{RtuBoard, RtuError};
use acc_pmc::{Board, BoardStatus, ControlBits};

/// The Modbus RTU board for the runtime: a `SAMPLE_SEQ`-stale read is passed on as the
/// status it carries (the policy judges staleness itself on the full status, so it still
/// sees the operator's switch, the watchdog and the lock while the power sensor is frozen).
#[derive(Debug)]
pub struct RtuPmc<T: Read + Write>(pub RtuBoard<T>);

impl<T: Read + Write> Board for RtuPmc<T> {
    type Error = RtuError;

    fn read_status(&mut self) -> Result<BoardStatus, RtuError> {
        match self.0.read_status() {
            Err(RtuError::Stale { status, .. }) => Ok(status),
            other => other,
        }
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), RtuError> {
        self.0.write_override(override_pct, heartbeat)
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), RtuError> {
        self.0.write_control(control)
    }
}

/// The CAN board for the runtime, with the same stale-status pass-through as [`RtuPmc`].
#[derive(Debug)]
pub struct CanPmc<B: embedded_can::blocking::Can>(pub CanBoard<B>);

impl<B> Board for CanPmc<B>
where
    B: embedded_can::blocking::Can,
    CanBoard<B>: Board<Error = CanError<B::Error>>,
    B::Error: std::error::Error + Send + Sync + 'static,
{
    type Error = CanError<B::Error>;

    fn read_status(&mut self) -> Result<BoardStatus, Self::Error> {
        match self.0.read_status() {
            Err(CanError::Stale { status, .. }) => Ok(status),
            other => other,
        }
    }

    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), Self::Error> {
        self.0.write_override(override_pct, heartbeat)
    }

    fn write_control(&mut self, control: ControlBits) -> Result<(), Self::Error> {
        self.0.write_control(control)
    }
}
