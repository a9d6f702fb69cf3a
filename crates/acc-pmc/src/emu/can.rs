//! An in-memory CAN bus with the board on it: [`CanBoardEmulator`] implements
//! [`embedded_can::blocking::Can`] with [`MemFrame`]s and serves a [`BoardLogic`](super::BoardLogic) per the
//! spec's CAN variant. Used as the mock bus of the CAN link's tests and as a simulated CAN
//! board.
//!
//! Behaviour: a command frame (`0x200+n`) is applied as one write of `OVERRIDE_CMD`,
//! `HEARTBEAT`, `CONTROL` (an invalid override makes the board ignore the whole frame, as
//! it keeps the old value on RTU). The status pair (`0x180+n`, `0x280+n`) is queued
//! whenever `SAMPLE_SEQ` has changed since the last pair (a new power sample), or on
//! [`CanBoardEmulator::emit_status`]. A v2 board (see
//! [`EmulatedProtocol`](super::EmulatedProtocol)) sends the NC-context frame (`0x300+n`) right
//! after every pair and the identity frame (`0x380+n`: protocol version, program number)
//! once a second of board time, the first one at the first poll; a v1 board sends neither.
//! `receive` on an empty queue sleeps `idle` (default 1 ms, like a socket read timeout) and
//! returns [`MemBusError::Timeout`].

use std::collections::VecDeque;
use std::time::Duration;

use embedded_can::{Frame, Id, StandardId};

use super::board::{lock_board, SharedBoard};
use crate::can::codec::{decode_command, encode_context, encode_identity, encode_status, NodeIds};
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
    /// NC-context frames (`0x300+n`, v2) sent.
    pub context_frames: u64,
    /// Identity frames (`0x380+n`, v2) sent.
    pub identity_frames: u64,
}

/// Interval of the v2 identity frame (`0x380+n`), ms of board time.
pub const IDENTITY_INTERVAL_MS: u64 = 1000;

/// The board on an in-memory CAN bus.
pub struct CanBoardEmulator {
    board: SharedBoard,
    ids: NodeIds,
    clock: Box<dyn Clock>,
    rx: VecDeque<MemFrame>,
    last_seq_sent: Option<u16>,
    last_identity_ms: Option<u64>,
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
            last_identity_ms: None,
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

    fn push(&mut self, raw: u16, data: &[u8]) -> bool {
        match StandardId::new(raw).and_then(|id| MemFrame::new(id, data)) {
            Some(frame) => {
                self.rx.push_back(frame);
                true
            }
            None => false,
        }
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
        self.push(self.ids.status_a, &a);
        self.push(self.ids.status_b, &b);
        self.stats.status_pairs += 1;
        if status.is_v2() {
            if let Ok(c) = encode_context(&status) {
                if self.push(self.ids.context, &c) {
                    self.stats.context_frames += 1;
                }
            }
        }
    }

    fn poll_board(&mut self) {
        let now = self.now_ms();
        let status = {
            let mut b = lock_board(&self.board);
            b.tick(now);
            b.status()
        };
        if status.is_v2()
            && self
                .last_identity_ms
                .is_none_or(|t| now.saturating_sub(t) >= IDENTITY_INTERVAL_MS)
        {
            self.last_identity_ms = Some(now);
            if self.push(self.ids.identity, &encode_identity(&status)) {
                self.stats.identity_frames += 1;
            }
        }
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
                self.clock.sleep_until(self.clock.now() + self.idle);
                Err(MemBusError::Timeout)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{decode_context, decode_identity, decode_status};
    use crate::clock::ManualClock;
    use crate::emu::{BoardLogic, EmulatedProtocol};
    use crate::regs::OverrideResolution;
    use embedded_can::blocking::Can;

    fn bus(protocol: EmulatedProtocol) -> (CanBoardEmulator, SharedBoard, ManualClock) {
        let mut logic = BoardLogic::with_protocol(OverrideResolution::Percent10, protocol);
        logic.set_acc_switch(true);
        logic.set_cycle_active(true);
        logic.set_tool_number(7);
        logic.set_program_number(4711);
        logic.set_block_number(230);
        logic.set_actual_feed_mm_min(640);
        let board = logic.shared();
        let clock = ManualClock::new();
        let mut emu = CanBoardEmulator::with_clock(board.clone(), 3, Box::new(clock.clone()))
            .expect("node 3");
        emu.set_idle(Duration::ZERO);
        (emu, board, clock)
    }

    /// Every frame queued now: `(id, data)`.
    fn drain(emu: &mut CanBoardEmulator) -> Vec<(u16, Vec<u8>)> {
        let mut out = Vec::new();
        while let Ok(f) = emu.receive() {
            let Id::Standard(id) = f.id() else {
                panic!("extended frame")
            };
            out.push((id.as_raw(), f.data().to_vec()));
        }
        out
    }

    #[test]
    fn v2_board_sends_context_with_every_pair_and_identity_once_a_second() {
        let (mut emu, board, clock) = bus(EmulatedProtocol::V2);
        let ids = NodeIds::new(3).expect("ids");
        lock_board(&board).push_power_sample(4_000);
        let frames = drain(&mut emu);
        let order: Vec<u16> = frames.iter().map(|f| f.0).collect();
        assert_eq!(order, [0x383, 0x183, 0x283, 0x303]);
        assert_eq!(decode_identity(ids, &frames[0].1), Ok((2, 4711)));
        let mut s = decode_status(ids, &frames[1].1, &frames[2].1).expect("pair");
        decode_context(ids, &frames[3].1, &mut s).expect("context");
        assert_eq!(
            (s.tool_number, s.block_number, s.actual_feed_mm_min),
            (7, 230, 640)
        );
        assert_eq!(s.fallback_override_pct, 150);
        assert!(!s.board_restarted);
        // The clamp and BOARD_RESTARTED travel in the context frame.
        {
            let mut b = lock_board(&board);
            b.write_holding(0, &[40, 1, 1], 0).expect("arm");
            b.write_holding(2, &[0], 0).expect("release");
            b.power_cycle();
            b.push_power_sample(4_100);
        }
        let frames = drain(&mut emu);
        assert_eq!(frames.len(), 3, "no identity before a second: {frames:?}");
        let mut s = decode_status(ids, &frames[0].1, &frames[1].1).expect("pair");
        decode_context(ids, &frames[2].1, &mut s).expect("context");
        assert!(s.board_restarted && s.feed_hold_active);
        // Identity: again at 1 s of board time, not at 999 ms; pairs only with new samples.
        clock.advance(Duration::from_millis(999));
        assert!(drain(&mut emu).is_empty());
        clock.advance(Duration::from_millis(1));
        let frames = drain(&mut emu);
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].0, 0x383);
        for _ in 0..5 {
            clock.advance(Duration::from_millis(500));
            lock_board(&board).push_power_sample(4_200);
            drain(&mut emu);
        }
        let st = emu.stats();
        assert_eq!(
            (st.status_pairs, st.context_frames, st.identity_frames),
            (7, 7, 4)
        );
    }

    #[test]
    fn clamp_reaches_the_context_frame() {
        let (mut emu, board, _clock) = bus(EmulatedProtocol::V2);
        let ids = NodeIds::new(3).expect("ids");
        {
            let mut b = lock_board(&board);
            b.write_holding(0, &[40, 1, 1], 0).expect("arm");
            b.write_holding(2, &[0], 0).expect("release");
            b.push_power_sample(4_000);
        }
        let frames = drain(&mut emu);
        let ctx = frames.iter().find(|f| f.0 == 0x303).expect("context");
        let a = frames.iter().find(|f| f.0 == 0x183).expect("a");
        let b = frames.iter().find(|f| f.0 == 0x283).expect("b");
        let mut s = decode_status(ids, &a.1, &b.1).expect("pair");
        decode_context(ids, &ctx.1, &mut s).expect("context");
        assert!(s.fallback_active);
        assert_eq!((s.fallback_override_pct, s.override_applied_pct), (40, 40));
    }

    #[test]
    fn v1_boards_send_neither_context_nor_identity() {
        for protocol in [EmulatedProtocol::V1Exception, EmulatedProtocol::V1Zeros] {
            let (mut emu, board, clock) = bus(protocol);
            for k in 0..30u32 {
                lock_board(&board).push_power_sample(4_000 + k);
                clock.advance(Duration::from_millis(100));
                let frames = drain(&mut emu);
                let order: Vec<u16> = frames.iter().map(|f| f.0).collect();
                assert_eq!(order, [0x183, 0x283], "{protocol:?}");
            }
            let st = emu.stats();
            assert_eq!(
                (st.status_pairs, st.context_frames, st.identity_frames),
                (30, 0, 0)
            );
        }
    }
}
