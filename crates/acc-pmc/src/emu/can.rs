//! An in-memory CAN bus with the board on it: [`CanBoardEmulator`] implements
//! [`embedded_can::blocking::Can`] with [`MemFrame`]s and serves a [`BoardLogic`](super::BoardLogic) per the
//! spec's CAN variant. Used as the mock bus of the CAN link's tests and as a simulated CAN
//! board.
//!
//! Behaviour: a command frame (`0x200+n`) is applied as one write of `OVERRIDE_CMD`,
//! `HEARTBEAT`, `CONTROL` (an invalid override makes the board ignore the whole frame, as
//! it keeps the old value on RTU). The status pair (`0x180+n`, `0x280+n`) is queued
//! whenever `SAMPLE_SEQ` has changed since the last pair (a new power sample), or on
//! [`CanBoardEmulator::emit_status`]. `receive` on an empty queue sleeps `idle` (default
//! 1 ms, like a socket read timeout) and returns [`MemBusError::Timeout`].

use std::collections::VecDeque;
use std::time::Duration;

use embedded_can::{Frame, Id, StandardId};

use super::board::{lock_board, SharedBoard};
use crate::can::codec::{decode_command, encode_status, NodeIds};
use crate::can::ReceiveTimeout;
use crate::clock::{Clock, SystemClock};
use crate::regs::holding;

/// A classic CAN data frame held in memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemFrame {
    id: Id,
    len: usize,
    data: [u8; 8],
    remote: bool,
}

impl Frame for MemFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let mut d = [0u8; 8];
        d[..data.len()].copy_from_slice(data);
        Some(Self {
            id: id.into(),
            len: data.len(),
            data: d,
            remote: false,
        })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| Self {
            id: id.into(),
            len: dlc,
            data: [0; 8],
            remote: true,
        })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        self.len
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            &self.data[..self.len]
        }
    }
}

/// Errors of the in-memory bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MemBusError {
    /// No frame queued (the equivalent of a socket read timeout).
    #[error("no frame within the bus read timeout")]
    Timeout,
    /// An injected bus error.
    #[error("injected CAN bus error {0:?}")]
    Bus(embedded_can::ErrorKind),
}

impl embedded_can::Error for MemBusError {
    fn kind(&self) -> embedded_can::ErrorKind {
        match self {
            MemBusError::Timeout => embedded_can::ErrorKind::Other,
            MemBusError::Bus(k) => *k,
        }
    }
}

impl ReceiveTimeout for MemBusError {
    fn is_receive_timeout(&self) -> bool {
        matches!(self, MemBusError::Timeout)
    }
}

/// Counters of the emulator.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Command frames applied.
    pub commands: u64,
    /// Command frames ignored (invalid override, wrong length).
    pub rejected: u64,
    /// Status pairs sent.
    pub status_pairs: u64,
}

/// The board on an in-memory CAN bus.
pub struct CanBoardEmulator {
    board: SharedBoard,
    ids: NodeIds,
    clock: Box<dyn Clock>,
    rx: VecDeque<MemFrame>,
    last_seq_sent: Option<u16>,
    fail_next: VecDeque<embedded_can::ErrorKind>,
    drop_pairs: usize,
    idle: Duration,
    stats: EmulatorStats,
}

impl std::fmt::Debug for CanBoardEmulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanBoardEmulator")
            .field("ids", &self.ids)
            .field("stats", &self.stats)
            .finish()
    }
}

impl CanBoardEmulator {
    /// Serve `board` as node `node` (1…127; `None` outside), on the system clock.
    pub fn new(board: SharedBoard, node: u8) -> Option<Self> {
        Self::with_clock(board, node, Box::new(SystemClock::default()))
    }

    /// As [`CanBoardEmulator::new`] with an injected clock (the board's watchdog runs on it).
    pub fn with_clock(board: SharedBoard, node: u8, clock: Box<dyn Clock>) -> Option<Self> {
        Some(Self {
            board,
            ids: NodeIds::new(node)?,
            clock,
            rx: VecDeque::new(),
            last_seq_sent: None,
            fail_next: VecDeque::new(),
            drop_pairs: 0,
            idle: Duration::from_millis(1),
            stats: EmulatorStats::default(),
        })
    }

    /// Time an empty `receive` waits before reporting a timeout (default 1 ms).
    pub fn set_idle(&mut self, idle: Duration) {
        self.idle = idle;
    }

    /// The served board.
    pub fn board(&self) -> &SharedBoard {
        &self.board
    }

    /// Counters.
    pub fn stats(&self) -> EmulatorStats {
        self.stats
    }

    /// Queue a status pair now, whether or not there is a new sample (a board that repeats
    /// its last sample).
    pub fn emit_status(&mut self) {
        let status = lock_board(&self.board).status();
        self.queue_pair(status);
    }

    /// The next `receive` calls fail with these bus errors, in order.
    pub fn fail_next_receive(&mut self, kind: embedded_can::ErrorKind) {
        self.fail_next.push_back(kind);
    }

    /// Lose the next `n` status pairs (as if the frames never made it).
    pub fn drop_next_pairs(&mut self, n: usize) {
        self.drop_pairs += n;
    }

    fn now_ms(&self) -> u64 {
        u64::try_from(self.clock.now().as_millis()).unwrap_or(u64::MAX)
    }

    fn queue_pair(&mut self, status: crate::BoardStatus) {
        self.last_seq_sent = Some(status.sample_seq);
        if self.drop_pairs > 0 {
            self.drop_pairs -= 1;
            return;
        }
        let (a, b) = match encode_status(&status) {
            Ok(p) => p,
            Err(_) => return, // a status that does not fit u8 fields is not sent
        };
        let ids = [(self.ids.status_a, a), (self.ids.status_b, b)];
        for (raw, data) in ids {
            if let Some(frame) = StandardId::new(raw).and_then(|id| MemFrame::new(id, &data)) {
                self.rx.push_back(frame);
            }
        }
        self.stats.status_pairs += 1;
    }

    fn poll_board(&mut self) {
        let now = self.now_ms();
        let status = {
            let mut b = lock_board(&self.board);
            b.tick(now);
            b.status()
        };
        if self.last_seq_sent != Some(status.sample_seq) {
            self.queue_pair(status);
        }
    }
}

impl embedded_can::blocking::Can for CanBoardEmulator {
    type Frame = MemFrame;
    type Error = MemBusError;

    fn transmit(&mut self, frame: &MemFrame) -> Result<(), MemBusError> {
        let is_command = matches!(frame.id(), Id::Standard(id) if id.as_raw() == self.ids.command);
        if !is_command || frame.is_remote_frame() {
            return Ok(());
        }
        let now = self.now_ms();
        let applied = decode_command(self.ids, frame.data())
            .ok()
            .is_some_and(|c| {
                let values = [
                    u16::from(c.override_pct),
                    c.heartbeat,
                    c.control.to_register(),
                ];
                lock_board(&self.board)
                    .write_holding(holding::OVERRIDE_CMD, &values, now)
                    .is_ok()
            });
        if applied {
            self.stats.commands += 1;
        } else {
            self.stats.rejected += 1;
        }
        Ok(())
    }

    fn receive(&mut self) -> Result<MemFrame, MemBusError> {
        if let Some(kind) = self.fail_next.pop_front() {
            return Err(MemBusError::Bus(kind));
        }
        self.poll_board();
        match self.rx.pop_front() {
            Some(f) => Ok(f),
            None => {
                std::thread::sleep(self.idle);
                Err(MemBusError::Timeout)
            }
        }
    }
}
