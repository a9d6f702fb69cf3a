//! The board side of the RTU link: [`RtuServer`] serves a [`BoardLogic`](super::BoardLogic) over any byte
//! stream. Used by `acc board-sim`, the tests and the `mbpoll` interop test.
//!
//! Framing is robust to what a real line delivers: a frame arriving in pieces is
//! reassembled; garbage before a frame is skipped one byte at a time until a frame with a
//! correct CRC lines up; a partial frame followed by silence (one read timeout of the
//! stream, standing in for the Modbus 3.5-character gap) is dropped; frames for other slave
//! addresses are ignored; broadcast writes (address 0) are applied without a reply.
//!
//! Every request for this slave gets an answer (`pmc-board.md`): a malformed write — function
//! 16 with a zero quantity, a quantity above 123, or a byte count that does not match the
//! quantity or the frame — answers exception 03, an unknown function exception 01. A frame is
//! complete when its length (from the function code and byte count) is in, or, for a frame
//! whose length cannot be trusted, when the line goes silent with a correct CRC over
//! everything received. Only bad-CRC frames and frames for another slave are ignored.
//!
//! The server never ends on a transient error: a reply that cannot be written (the peer does
//! not read and the pty's buffer is full: the write times out, `EAGAIN`, `EIO`) is dropped
//! and counted in [`ServerStats::replies_dropped`]; while the output is congested the server
//! tries to write at most one reply every [`CONGESTED_RETRY_MS`] and drops the others without
//! waiting, so a flood of unread requests never slows the reading side down. A read error
//! other than the idle timeout (no peer on the pty: `EIO`, end of stream) is counted in
//! [`ServerStats::io_errors`] and retried after a pause. Both are logged (`tracing`) when they
//! start and when they end.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use rmodbus::consts::ModbusFunction;
use rmodbus::server::{ModbusFrame, Read as ExtRead};
use rmodbus::{ErrorKind, ModbusProto};

use super::board::{lock_board, Exception, Reply, Request, SharedBoard};
use super::fault::{Fault, FaultInjector};
use crate::clock::{Clock, SystemClock};
use crate::regs::MAX_WRITE_COUNT;
use crate::rtu::codec::{append_crc, crc_ok};
use crate::rtu::is_idle;

/// While replies cannot be delivered, at most one write is attempted per this many ms (the
/// others are dropped at once).
pub const CONGESTED_RETRY_MS: u64 = 20;
/// Pause after a read error (no peer on the pty, device gone) before reading again, ms.
pub const READ_ERROR_PAUSE_MS: u64 = 20;
/// Bytes kept waiting for the line to go silent before the head byte is given up as garbage.
const MAX_PENDING: usize = 512;
/// Function code of "write multiple registers".
const FC_WRITE_MULTIPLE: u8 = 16;

/// Counters of the server since it was created.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServerStats {
    /// Requests answered (positively or with an exception).
    pub requests: u64,
    /// Of which answered with an exception.
    pub exceptions: u64,
    /// Well-formed frames for other slave addresses, ignored.
    pub other_slave: u64,
    /// Broadcast frames applied without a reply.
    pub broadcasts: u64,
    /// Bytes dropped while resynchronising (garbage, bad CRC, partial frames).
    pub bytes_discarded: u64,
    /// Replies that could not be delivered (the peer does not read, the stream failed) and
    /// were dropped; they are counted in `requests` too.
    pub replies_dropped: u64,
    /// Read errors other than the idle timeout (no peer, device gone), each retried.
    pub io_errors: u64,
}

/// A Modbus RTU slave serving a [`BoardLogic`](super::BoardLogic) on the byte stream `P`.
pub struct RtuServer<P: Read + Write> {
    port: P,
    slave: u8,
    board: SharedBoard,
    clock: Box<dyn Clock>,
    buf: Vec<u8>,
    stats: ServerStats,
    faults: Option<FaultInjector>,
    /// Time of the last failed reply write, ms; `None` while replies get through.
    congested_since_ms: Option<u64>,
    /// Replies dropped since the output became congested (for the log).
    dropped_in_congestion: u64,
    /// A read error is ongoing (logged once).
    read_failing: bool,
}

impl<P: Read + Write> std::fmt::Debug for RtuServer<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RtuServer")
            .field("slave", &self.slave)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<P: Read + Write> RtuServer<P> {
    /// Serve `board` as slave `slave` (1…247) on `port`; the board's `now_ms` is taken from
    /// the system monotonic clock.
    pub fn new(port: P, slave: u8, board: SharedBoard) -> Self {
        Self::with_clock(port, slave, board, Box::new(SystemClock::default()))
    }

    /// As [`RtuServer::new`] with an injected clock (the board's watchdog runs on it).
    pub fn with_clock(port: P, slave: u8, board: SharedBoard, clock: Box<dyn Clock>) -> Self {
        Self {
            port,
            slave,
            board,
            clock,
            buf: Vec::with_capacity(512),
            stats: ServerStats::default(),
            faults: None,
            congested_since_ms: None,
            dropped_in_congestion: 0,
            read_failing: false,
        }
    }

    /// Apply queued [`Fault`]s to the replies this server sends (one fault per reply:
    /// corrupt a CRC byte, drop the reply, send it late, or send garbage before it).
    pub fn set_faults(&mut self, faults: FaultInjector) {
        self.faults = Some(faults);
    }

    /// The served board (lock it with [`lock_board`]).
    pub fn board(&self) -> &SharedBoard {
        &self.board
    }

    /// Counters since creation.
    pub fn stats(&self) -> ServerStats {
        self.stats
    }

    /// The byte stream.
    pub fn get_mut(&mut self) -> &mut P {
        &mut self.port
    }

    /// Wait `d` on the server's clock.
    fn pause(&self, d: std::time::Duration) {
        self.clock.sleep_until(self.clock.now() + d);
    }

    fn now_ms(&self) -> u64 {
        u64::try_from(self.clock.now().as_millis()).unwrap_or(u64::MAX)
    }

    /// Serve until `stop` is set. Errors of the stream never end it (see the module docs);
    /// the `Result` is kept for callers that match on it and is always `Ok(())`.
    pub fn run(&mut self, stop: &AtomicBool) -> std::io::Result<()> {
        while !stop.load(Ordering::Relaxed) {
            self.poll()?;
        }
        Ok(())
    }

    /// One read from the stream (blocking at most the stream's read timeout), then answer
    /// every complete frame in the buffer. Also advances the board's watchdog. Returns the
    /// number of replies delivered. A read error is counted, logged, and followed by a pause
    /// of [`READ_ERROR_PAUSE_MS`]; it is not returned.
    pub fn poll(&mut self) -> std::io::Result<usize> {
        let now = self.now_ms();
        lock_board(&self.board).tick(now);
        let mut chunk = [0u8; 256];
        let silent = match self.port.read(&mut chunk) {
            Ok(0) => {
                self.read_failed(&std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    "serial stream closed",
                ));
                return Ok(0);
            }
            Ok(n) => {
                if self.read_failing {
                    self.read_failing = false;
                    tracing::info!("board server: the stream reads again");
                }
                self.buf.extend_from_slice(&chunk[..n]);
                false
            }
            Err(e) if is_idle(&e) => true,
            Err(e) => {
                self.read_failed(&e);
                return Ok(0);
            }
        };
        let mut served = self.process();
        if silent && !self.buf.is_empty() {
            served += self.flush_on_silence();
        }
        Ok(served)
    }

    fn read_failed(&mut self, e: &std::io::Error) {
        self.stats.io_errors += 1;
        if !self.read_failing {
            self.read_failing = true;
            tracing::warn!(
                "board server: read failed ({e}); retrying every {READ_ERROR_PAUSE_MS} ms"
            );
        }
        self.pause(std::time::Duration::from_millis(READ_ERROR_PAUSE_MS));
    }

    /// Answer all complete frames at the head of the buffer.
    fn process(&mut self) -> usize {
        let mut served = 0;
        loop {
            if self.buf.len() < 2 {
                return served;
            }
            let len = match rmodbus::guess_request_frame_len(&self.buf, ModbusProto::Rtu) {
                Ok(n) => usize::from(n),
                Err(ErrorKind::OOB) => return served,
                // FC15/16 with a byte count too large for an RTU frame: the length cannot be
                // trusted, wait for the line to go silent (then exception 03 if the CRC is
                // right), unless so much is pending that the head byte must be garbage.
                Err(_) if is_write_multiple(self.buf[1]) && self.buf.len() <= MAX_PENDING => {
                    return served
                }
                Err(_) => {
                    self.discard(1);
                    continue;
                }
            };
            if self.buf.len() < len {
                return served;
            }
            if !crc_ok(&self.buf[..len]) {
                if is_known_function(self.buf[1]) {
                    if is_write_multiple(self.buf[1]) && self.buf.len() <= MAX_PENDING {
                        // The byte count may disagree with the frame: silence decides.
                        return served;
                    }
                    self.discard(1);
                    continue;
                }
                // An unknown function has an unknown length: wait for the line to go silent.
                if self.buf.len() > MAX_PENDING {
                    self.discard(1);
                    continue;
                }
                return served;
            }
            let frame: Vec<u8> = self.buf.drain(..len).collect();
            served += self.answer(&frame);
        }
    }

    /// The line went silent with bytes left. Everything received with a correct CRC is one
    /// frame by RTU timing: answer it (an unknown function with exception 01, a malformed
    /// one with exception 03); otherwise drop bytes from the front until a frame lines up or
    /// nothing is left.
    fn flush_on_silence(&mut self) -> usize {
        if self.buf.len() >= 4 && crc_ok(&self.buf) {
            let frame = std::mem::take(&mut self.buf);
            return self.answer(&frame);
        }
        let mut served = 0;
        while !self.buf.is_empty() {
            self.discard(1);
            served += self.process();
            if self.buf.len() >= 4 && crc_ok(&self.buf) {
                let frame = std::mem::take(&mut self.buf);
                return served + self.answer(&frame);
            }
        }
        served
    }

    fn discard(&mut self, n: usize) {
        let n = n.min(self.buf.len());
        self.buf.drain(..n);
        self.stats.bytes_discarded += n as u64;
    }

    /// Answer one frame whose CRC is correct. Returns 1 if a reply was delivered.
    fn answer(&mut self, frame: &[u8]) -> usize {
        let unit = frame[0];
        let broadcast = unit == 0;
        if !broadcast && unit != self.slave {
            self.stats.other_slave += 1;
            return 0;
        }
        if let Some(function) = malformed(frame) {
            if broadcast {
                self.stats.broadcasts += 1;
                return 0;
            }
            let mut response = vec![
                self.slave,
                function | 0x80,
                Exception::IllegalDataValue.code(),
            ];
            append_crc(&mut response);
            return self.send(response, true);
        }
        let now = self.now_ms();
        let mut response: Vec<u8> = Vec::with_capacity(64);
        let mut mf = ModbusFrame::new(self.slave, frame, ModbusProto::Rtu, &mut response);
        if mf.parse().is_err() {
            self.stats.bytes_discarded += frame.len() as u64;
            return 0;
        }
        if mf.error.is_none() && mf.processing_required {
            let request = to_request(&mf, frame);
            let result = lock_board(&self.board).handle(request, now);
            let outcome = match result {
                Ok(Reply::Registers(values)) => match mf.get_external_read() {
                    Ok(ExtRead::Words(w)) if w.buf.len() == values.len() * 2 => {
                        for (dst, v) in w.buf.chunks_exact_mut(2).zip(&values) {
                            dst.copy_from_slice(&v.to_be_bytes());
                        }
                        mf.process_external_read(Ok(()))
                    }
                    _ => mf.set_modbus_error_if_unset(&ErrorKind::SlaveDeviceFailure),
                },
                Ok(Reply::WroteSingle { .. } | Reply::WroteMultiple { .. }) => {
                    mf.process_external_write(Ok(()))
                }
                Err(e) => mf.set_modbus_error_if_unset(&exception_kind(e)),
            };
            if outcome.is_err() {
                mf.set_modbus_error_if_unset(&ErrorKind::SlaveDeviceFailure)
                    .ok();
            }
        }
        if broadcast {
            self.stats.broadcasts += 1;
            return 0;
        }
        if !mf.response_required {
            return 0;
        }
        let is_exception = mf.error.is_some();
        if mf.finalize_response().is_err() {
            return 0;
        }
        self.send(response, is_exception)
    }

    /// Deliver one reply (with any injected fault). A reply that cannot be written is
    /// dropped and counted; while the output is congested, one write is attempted per
    /// [`CONGESTED_RETRY_MS`]. Returns 1 if delivered.
    fn send(&mut self, mut response: Vec<u8>, is_exception: bool) -> usize {
        self.stats.requests += 1;
        if is_exception {
            self.stats.exceptions += 1;
        }
        let mut garbage = None;
        match self.faults.as_ref().and_then(FaultInjector::next) {
            Some(Fault::DropReply) => return 0,
            Some(Fault::CorruptCrc) => {
                if let Some(b) = response.get_mut(3) {
                    *b ^= 0x01;
                }
            }
            Some(Fault::DelayReply(d)) => self.pause(d),
            Some(Fault::Garbage(g)) => garbage = Some(g),
            None => {}
        }
        let now = self.now_ms();
        if self
            .congested_since_ms
            .is_some_and(|t| now.saturating_sub(t) < CONGESTED_RETRY_MS)
        {
            self.drop_reply();
            return 0;
        }
        let written = match garbage {
            Some(g) => self.port.write_all(&g),
            None => Ok(()),
        }
        .and_then(|()| self.port.write_all(&response))
        .and_then(|()| self.port.flush());
        match written {
            Ok(()) => {
                if self.congested_since_ms.take().is_some() {
                    tracing::info!(
                        "board server: replies delivered again after {} dropped",
                        self.dropped_in_congestion
                    );
                    self.dropped_in_congestion = 0;
                }
                1
            }
            Err(e) => {
                if self.congested_since_ms.is_none() {
                    tracing::warn!(
                        "board server: a reply could not be written ({e}); dropping replies until the peer reads"
                    );
                }
                self.congested_since_ms = Some(now);
                self.drop_reply();
                0
            }
        }
    }

    fn drop_reply(&mut self) {
        self.stats.replies_dropped += 1;
        self.dropped_in_congestion += 1;
    }
}

fn is_write_multiple(f: u8) -> bool {
    f == 15 || f == FC_WRITE_MULTIPLE
}

/// A frame (correct CRC) whose fields disagree with its function: `Some(function)` for
/// exception 03. Function 16: quantity 0 or above 123, byte count ≠ 2 × quantity, or a frame
/// length ≠ 9 + byte count; functions 3, 4 and 6: a length other than 8.
fn malformed(frame: &[u8]) -> Option<u8> {
    let function = frame[1];
    let bad = match function {
        FC_WRITE_MULTIPLE => {
            if frame.len() < 9 {
                true
            } else {
                let quantity = u16::from_be_bytes([frame[4], frame[5]]);
                let bytes = usize::from(frame[6]);
                quantity == 0
                    || quantity > MAX_WRITE_COUNT
                    || bytes != 2 * usize::from(quantity)
                    || frame.len() != 9 + bytes
            }
        }
        3 | 4 | 6 => frame.len() != 8,
        _ => false,
    };
    bad.then_some(function)
}

fn is_known_function(f: u8) -> bool {
    ModbusFunction::try_from(f).is_ok()
}

fn exception_kind(e: Exception) -> ErrorKind {
    match e {
        Exception::IllegalFunction => ErrorKind::IllegalFunction,
        Exception::IllegalDataAddress => ErrorKind::IllegalDataAddress,
        Exception::IllegalDataValue => ErrorKind::IllegalDataValue,
    }
}

/// The board's view of a parsed frame. Coil functions (01, 02, 05, 15) are not in the
/// board's map: they become [`Request::Other`] (exception 01).
fn to_request<V: rmodbus::VectorTrait<u8>>(mf: &ModbusFrame<'_, V>, frame: &[u8]) -> Request {
    let addr = mf.reg;
    match mf.func {
        ModbusFunction::GetHoldings => Request::ReadHolding {
            addr,
            count: mf.count,
        },
        ModbusFunction::GetInputs => Request::ReadInput {
            addr,
            count: mf.count,
        },
        ModbusFunction::SetHolding => {
            let value = u16::from_be_bytes([frame[4], frame[5]]);
            Request::WriteSingle { addr, value }
        }
        ModbusFunction::SetHoldingsBulk => {
            let bytes = usize::from(frame[6]);
            if bytes != usize::from(mf.count) * 2 || frame.len() < 7 + bytes {
                // Byte count disagrees with the register count: an empty write is exception 03.
                return Request::WriteMultiple {
                    addr,
                    values: Vec::new(),
                };
            }
            let values = frame[7..7 + bytes]
                .chunks_exact(2)
                .map(|p| u16::from_be_bytes([p[0], p[1]]))
                .collect();
            Request::WriteMultiple { addr, values }
        }
        ModbusFunction::GetCoils
        | ModbusFunction::GetDiscretes
        | ModbusFunction::SetCoil
        | ModbusFunction::SetCoilsBulk => Request::Other {
            function: mf.func.byte(),
        },
    }
}

/// Serve `board` on `port` in a new thread until `stop` is set, the board's time on `clock`
/// (its watchdog); the thread returns the server's statistics (stream errors never end it:
/// see the module docs).
pub fn spawn_server<P>(
    port: P,
    slave: u8,
    board: SharedBoard,
    stop: Arc<AtomicBool>,
    clock: Box<dyn Clock>,
) -> std::thread::JoinHandle<std::io::Result<ServerStats>>
where
    P: Read + Write + Send + 'static,
{
    std::thread::spawn(move || {
        let mut server = RtuServer::with_clock(port, slave, board, clock);
        server.run(&stop)?;
        Ok(server.stats())
    })
}
