//! The board side of the RTU link: [`RtuServer`] serves a [`BoardLogic`](super::BoardLogic) over any byte
//! stream. Used by `acc board-sim`, the tests and the `mbpoll` interop test.
//!
//! Framing is robust to what a real line delivers: a frame arriving in pieces is
//! reassembled; garbage before a frame is skipped one byte at a time until a frame with a
//! correct CRC lines up; a partial frame followed by silence (one read timeout of the
//! stream, standing in for the Modbus 3.5-character gap) is dropped; frames for other slave
//! addresses are ignored; broadcast writes (address 0) are applied without a reply.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use rmodbus::consts::ModbusFunction;
use rmodbus::server::{ModbusFrame, Read as ExtRead};
use rmodbus::{ErrorKind, ModbusProto};

use super::board::{lock_board, Exception, Reply, Request, SharedBoard};
use super::fault::{Fault, FaultInjector};
use crate::clock::{Clock, SystemClock};
use crate::rtu::codec::crc_ok;
use crate::rtu::is_idle;

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

    fn now_ms(&self) -> u64 {
        u64::try_from(self.clock.now().as_millis()).unwrap_or(u64::MAX)
    }

    /// Serve until `stop` is set or the stream fails. Returns `Ok(())` on stop; an I/O error
    /// (e.g. the peer closed the pty) otherwise.
    pub fn run(&mut self, stop: &AtomicBool) -> std::io::Result<()> {
        while !stop.load(Ordering::Relaxed) {
            self.poll()?;
        }
        Ok(())
    }

    /// One read from the stream (blocking at most the stream's read timeout), then answer
    /// every complete frame in the buffer. Also advances the board's watchdog. Returns the
    /// number of requests answered.
    pub fn poll(&mut self) -> std::io::Result<usize> {
        let now = self.now_ms();
        lock_board(&self.board).tick(now);
        let mut chunk = [0u8; 256];
        let silent = match self.port.read(&mut chunk) {
            Ok(0) => {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    "serial stream closed",
                ))
            }
            Ok(n) => {
                self.buf.extend_from_slice(&chunk[..n]);
                false
            }
            Err(e) if is_idle(&e) => true,
            Err(e) => return Err(e),
        };
        let mut served = self.process()?;
        if silent && !self.buf.is_empty() {
            served += self.flush_on_silence()?;
        }
        Ok(served)
    }

    /// Answer all complete frames at the head of the buffer.
    fn process(&mut self) -> std::io::Result<usize> {
        let mut served = 0;
        loop {
            if self.buf.len() < 2 {
                return Ok(served);
            }
            let len = match rmodbus::guess_request_frame_len(&self.buf, ModbusProto::Rtu) {
                Ok(n) => usize::from(n),
                Err(ErrorKind::OOB) => return Ok(served),
                Err(_) => {
                    self.discard(1);
                    continue;
                }
            };
            if self.buf.len() < len {
                return Ok(served);
            }
            if !crc_ok(&self.buf[..len]) {
                if is_known_function(self.buf[1]) {
                    self.discard(1);
                    continue;
                }
                // An unknown function has an unknown length: wait for the line to go silent.
                return Ok(served);
            }
            let frame: Vec<u8> = self.buf.drain(..len).collect();
            served += self.answer(&frame)?;
        }
    }

    /// The line went silent with bytes left: they are a partial or garbled frame. An
    /// unknown function whose whole buffer has a correct CRC is answered with exception 01;
    /// otherwise drop bytes from the front until a frame lines up or nothing is left.
    fn flush_on_silence(&mut self) -> std::io::Result<usize> {
        if self.buf.len() >= 4 && !is_known_function(self.buf[1]) && crc_ok(&self.buf) {
            let frame = std::mem::take(&mut self.buf);
            return self.answer(&frame);
        }
        let mut served = 0;
        while !self.buf.is_empty() {
            self.discard(1);
            served += self.process()?;
        }
        Ok(served)
    }

    fn discard(&mut self, n: usize) {
        let n = n.min(self.buf.len());
        self.buf.drain(..n);
        self.stats.bytes_discarded += n as u64;
    }

    /// Answer one frame whose CRC is correct. Returns 1 if a reply was sent.
    fn answer(&mut self, frame: &[u8]) -> std::io::Result<usize> {
        let unit = frame[0];
        let broadcast = unit == 0;
        if !broadcast && unit != self.slave {
            self.stats.other_slave += 1;
            return Ok(0);
        }
        let now = self.now_ms();
        let mut response: Vec<u8> = Vec::with_capacity(64);
        let mut mf = ModbusFrame::new(self.slave, frame, ModbusProto::Rtu, &mut response);
        if mf.parse().is_err() {
            self.stats.bytes_discarded += frame.len() as u64;
            return Ok(0);
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
            return Ok(0);
        }
        if !mf.response_required {
            return Ok(0);
        }
        let is_exception = mf.error.is_some();
        if mf.finalize_response().is_err() {
            return Ok(0);
        }
        self.stats.requests += 1;
        match self.faults.as_ref().and_then(FaultInjector::next) {
            Some(Fault::DropReply) => return Ok(0),
            Some(Fault::CorruptCrc) => {
                if let Some(b) = response.get_mut(3) {
                    *b ^= 0x01;
                }
            }
            Some(Fault::DelayReply(d)) => std::thread::sleep(d),
            Some(Fault::Garbage(g)) => self.port.write_all(&g)?,
            None => {}
        }
        self.port.write_all(&response)?;
        self.port.flush()?;
        if is_exception {
            self.stats.exceptions += 1;
        }
        Ok(1)
    }
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

/// Serve `board` on `port` in a new thread until `stop` is set; the thread returns the
/// server (for its statistics) or the I/O error that ended it.
pub fn spawn_server<P>(
    port: P,
    slave: u8,
    board: SharedBoard,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<std::io::Result<ServerStats>>
where
    P: Read + Write + Send + 'static,
{
    std::thread::spawn(move || {
        let mut server = RtuServer::new(port, slave, board);
        server.run(&stop)?;
        Ok(server.stats())
    })
}
