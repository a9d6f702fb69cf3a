//! The Modbus RTU client link to the board: [`RtuBoard`].

use std::io::{Read, Write};
use std::time::Duration;

use super::codec::{BuildError, Decoded, FrameError, ProtocolError, Transaction};
use super::is_idle;
use crate::clock::{Clock, SystemClock};
use crate::regs::{holding, input, FallbackMode};
use crate::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus, ControlBits};

/// Link parameters of [`RtuBoard`] (validated from the `[board]` config by
/// [`crate::serial::RtuConfig::validate`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtuLinkConfig {
    /// Modbus slave address, 1…247. Default 1.
    pub slave: u8,
    /// Time allowed for one complete reply after the request is sent. Default 40 ms.
    pub timeout: Duration,
    /// Extra attempts after a timeout, CRC or protocol error (never after an exception or
    /// an I/O error). Default 1.
    pub retries: u8,
    /// Total time one call (all attempts) may take; a retry is started only if a full
    /// `timeout` still fits. Keep it below the control period T. Default 90 ms.
    pub budget: Duration,
}

impl Default for RtuLinkConfig {
    fn default() -> Self {
        Self {
            slave: 1,
            timeout: Duration::from_millis(40),
            retries: 1,
            budget: Duration::from_millis(90),
        }
    }
}

/// Errors of the RTU link, layered: the board refused (exception) ≠ line noise (CRC) ≠ no
/// answer (timeout) ≠ a wrong answer (protocol) ≠ the port is gone (I/O). A frozen power
/// sensor (`SAMPLE_SEQ` unchanged) is not a link error: the status is returned as read and
/// the runtime's fault policy judges staleness.
#[derive(Debug, thiserror::Error)]
pub enum RtuError {
    /// The board answered with a Modbus exception.
    #[error("slave {slave}: {source}")]
    Exception {
        /// Slave address.
        slave: u8,
        /// The exception ([`FrameError::Exception`]).
        source: FrameError,
    },
    /// The reply's CRC was wrong (on the last attempt).
    #[error("slave {slave}: {source}")]
    Crc {
        /// Slave address.
        slave: u8,
        /// The CRC error ([`FrameError::Crc`]).
        source: FrameError,
    },
    /// No complete reply within the timeout (on the last attempt).
    #[error("slave {slave}: no complete reply within {timeout_ms} ms ({received} bytes received) after {attempts} attempt(s)")]
    Timeout {
        /// Slave address.
        slave: u8,
        /// The per-attempt timeout, ms.
        timeout_ms: u64,
        /// Bytes of the reply received before the deadline.
        received: usize,
        /// Attempts made.
        attempts: u8,
    },
    /// A reply that breaks the protocol (on the last attempt).
    #[error("slave {slave}: protocol violation: {source}")]
    Protocol {
        /// Slave address.
        slave: u8,
        /// What was wrong.
        source: ProtocolError,
    },
    /// The byte stream failed (port unplugged, pty closed).
    #[error("serial I/O failed: {0}")]
    Io(#[source] std::io::Error),
    /// A caller error: a request that cannot be encoded, or a register read asked of a
    /// write transaction.
    #[error(transparent)]
    Build(#[from] super::codec::BuildError),
}

impl BoardError for RtuError {
    /// The [`BoardErrorKind`] the runtime acts on.
    fn kind(&self) -> BoardErrorKind {
        match self {
            RtuError::Exception {
                source: FrameError::Exception { code, .. },
                ..
            } => BoardErrorKind::Exception(*code),
            RtuError::Exception { .. } | RtuError::Protocol { .. } | RtuError::Build(_) => {
                BoardErrorKind::Protocol
            }
            RtuError::Crc { .. } => BoardErrorKind::Crc,
            RtuError::Timeout { .. } => BoardErrorKind::Timeout,
            RtuError::Io(_) => BoardErrorKind::Disconnected,
        }
    }
}

impl RtuError {
    fn retryable(&self) -> bool {
        matches!(
            self,
            RtuError::Crc { .. } | RtuError::Timeout { .. } | RtuError::Protocol { .. }
        )
    }
}

/// Counters of the link since it was created (for logs and the run summary).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Transactions started (calls, not attempts).
    pub transactions: u64,
    /// Attempts beyond the first.
    pub retries: u64,
    /// Attempts that timed out.
    pub timeouts: u64,
    /// Replies with a bad CRC.
    pub crc_errors: u64,
    /// Replies that broke the protocol.
    pub protocol_errors: u64,
    /// Exception replies.
    pub exceptions: u64,
    /// Bytes thrown away while resynchronising after an error (late or garbled replies).
    pub bytes_discarded: u64,
}

/// The board over Modbus RTU on any byte stream `T` (a serial port, a pty, a test double).
///
/// One controller cycle is [`Board::read_status`] (FC04, registers 0…8) then
/// [`Board::write_override`] (FC16, registers 0…1). After any failed attempt the link drains
/// the input until the line is silent, so a late reply is never taken for the next one.
pub struct RtuBoard<T: Read + Write> {
    port: T,
    cfg: RtuLinkConfig,
    clock: Box<dyn Clock>,
    stats: LinkStats,
    resync: bool,
    protocol: Option<BoardProtocol>,
}

impl<T: Read + Write> std::fmt::Debug for RtuBoard<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RtuBoard")
            .field("cfg", &self.cfg)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<T: Read + Write> RtuBoard<T> {
    /// A link on `port` with the system monotonic clock.
    pub fn new(port: T, cfg: RtuLinkConfig) -> Self {
        Self::with_clock(port, cfg, Box::new(SystemClock::default()))
    }

    /// A link with an injected clock (deadlines are measured on it).
    pub fn with_clock(port: T, cfg: RtuLinkConfig, clock: Box<dyn Clock>) -> Self {
        Self {
            port,
            cfg,
            clock,
            stats: LinkStats::default(),
            resync: false,
            protocol: None,
        }
    }

    /// The link parameters.
    pub fn config(&self) -> &RtuLinkConfig {
        &self.cfg
    }

    /// Counters since creation.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// The byte stream (e.g. to change a test double's behaviour).
    pub fn get_mut(&mut self) -> &mut T {
        &mut self.port
    }

    /// Give the byte stream back.
    pub fn into_inner(self) -> T {
        self.port
    }

    /// FC03: read the holding registers — 0…4 on a v2 board (`OVERRIDE_CMD`, `HEARTBEAT`,
    /// `CONTROL`, `WATCHDOG_MS`, `FALLBACK_MODE`), 0…3 on a v1 board (detected as in
    /// [`Board::read_status`]: exception 02 for the v2 register).
    pub fn read_holding(&mut self) -> Result<Vec<u16>, RtuError> {
        if self.protocol != Some(BoardProtocol::V1) {
            let tx = Transaction::read_holding_registers(self.cfg.slave, 0, holding::COUNT)?;
            match self.registers(&tx) {
                Err(e)
                    if e.kind() == BoardErrorKind::Exception(2)
                        && self.protocol != Some(BoardProtocol::V2) =>
                {
                    self.protocol = Some(BoardProtocol::V1);
                }
                other => return other,
            }
        }
        let tx = Transaction::read_holding_registers(self.cfg.slave, 0, holding::V1_COUNT)?;
        self.registers(&tx)
    }

    /// FC06: set `FALLBACK_MODE` (v2 only; a v1 board answers exception 02).
    pub fn write_fallback_mode(&mut self, mode: FallbackMode) -> Result<(), RtuError> {
        let tx = Transaction::write_single_register(
            self.cfg.slave,
            holding::FALLBACK_MODE,
            mode.to_register(),
        )?;
        self.transact(&tx).map(|_| ())
    }

    /// FC06: set `WATCHDOG_MS` (100…5000 ms; the board answers exception 03 otherwise).
    pub fn write_watchdog_ms(&mut self, watchdog_ms: u16) -> Result<(), RtuError> {
        let tx =
            Transaction::write_single_register(self.cfg.slave, holding::WATCHDOG_MS, watchdog_ms)?;
        self.transact(&tx).map(|_| ())
    }

    fn registers(&mut self, tx: &Transaction) -> Result<Vec<u16>, RtuError> {
        match self.transact(tx)? {
            Decoded::Registers(r) => Ok(r),
            // Only a write transaction (FC06/FC16) decodes to an acknowledgement: the caller
            // passed a write where a register read was needed. Nothing is wrong with the reply.
            Decoded::WriteAck => Err(RtuError::Build(BuildError(
                "a register read was given a write transaction (FC06/FC16), which returns no registers",
            ))),
        }
    }

    /// Run one transaction with retries inside the budget.
    fn transact(&mut self, tx: &Transaction) -> Result<Decoded, RtuError> {
        self.stats.transactions += 1;
        let start = self.clock.now();
        let mut attempts: u8 = 0;
        loop {
            attempts = attempts.saturating_add(1);
            if self.resync {
                self.drain(start + self.cfg.budget)?;
            }
            let result = self.attempt(tx, attempts);
            let err = match result {
                Ok(d) => return Ok(d),
                Err(e) => e,
            };
            match &err {
                RtuError::Timeout { .. } => self.stats.timeouts += 1,
                RtuError::Crc { .. } => self.stats.crc_errors += 1,
                RtuError::Protocol { .. } => self.stats.protocol_errors += 1,
                RtuError::Exception { .. } => self.stats.exceptions += 1,
                _ => {}
            }
            if err.retryable() {
                self.resync = true;
            }
            let elapsed = self.clock.now().saturating_sub(start);
            let fits = elapsed + self.cfg.timeout <= self.cfg.budget;
            if err.retryable() && attempts <= self.cfg.retries && fits {
                self.stats.retries += 1;
                continue;
            }
            return Err(err);
        }
    }

    /// Send the request and read exactly one reply frame.
    fn attempt(&mut self, tx: &Transaction, attempts: u8) -> Result<Decoded, RtuError> {
        let slave = self.cfg.slave;
        self.port
            .write_all(tx.request_bytes())
            .map_err(RtuError::Io)?;
        self.port.flush().map_err(RtuError::Io)?;
        let deadline = self.clock.now() + self.cfg.timeout;
        let mut buf = [0u8; 256];
        let mut have = 0usize;
        // 3 bytes tell the length of any reply (rmodbus guess_response_frame_len).
        let mut need = 3usize;
        loop {
            if have == need {
                let n = match tx.reply_len(&buf[..have]) {
                    Ok(Some(n)) => n,
                    Ok(None) => have + 1,
                    Err(source) => return Err(RtuError::Protocol { slave, source }),
                };
                if n <= have {
                    break;
                }
                need = n.min(buf.len());
            }
            if self.clock.now() >= deadline {
                return Err(RtuError::Timeout {
                    slave,
                    timeout_ms: self.cfg.timeout.as_millis() as u64,
                    received: have,
                    attempts,
                });
            }
            match self.port.read(&mut buf[have..need]) {
                Ok(0) => {
                    return Err(RtuError::Io(std::io::Error::new(
                        std::io::ErrorKind::UnexpectedEof,
                        "serial stream closed",
                    )))
                }
                Ok(n) => have += n,
                Err(e) if is_idle(&e) => {}
                Err(e) => return Err(RtuError::Io(e)),
            }
        }
        tx.decode(&buf[..have]).map_err(|e| match e {
            FrameError::Crc { .. } => RtuError::Crc { slave, source: e },
            FrameError::Exception { .. } => RtuError::Exception { slave, source: e },
            FrameError::Protocol(source) => RtuError::Protocol { slave, source },
        })
    }

    /// Throw away input until one read finds the line silent (or `until` passes).
    fn drain(&mut self, until: Duration) -> Result<(), RtuError> {
        let mut scratch = [0u8; 64];
        loop {
            match self.port.read(&mut scratch) {
                Ok(0) => break,
                Ok(n) => self.stats.bytes_discarded += n as u64,
                Err(e) if is_idle(&e) => break,
                Err(e) => return Err(RtuError::Io(e)),
            }
            if self.clock.now() >= until {
                break;
            }
        }
        self.resync = false;
        Ok(())
    }
}

impl<T: Read + Write> Board for RtuBoard<T> {
    type Error = RtuError;

    /// FC04 registers 0…14 (v2) or 0…8 (v1), decoded as read (`SAMPLE_SEQ` staleness is the
    /// fault policy's to judge).
    ///
    /// Protocol detection: until the board is known to be v1, the link reads 0…14. A v2
    /// board answers `PROTOCOL_VERSION` ≥ 2. Exception 02 (a v1 board without registers
    /// 9…14) or a version of 0/1 (a v1 board answering zeros) makes the link a v1 link from
    /// then on: it reads 0…8 and the v2 fields read as unknown
    /// ([`BoardStatus::from_v1_input_registers`]).
    ///
    /// The protocol is decided by the first decisive answer and never changes after: on a
    /// link known to be v2, an exception 02 is an error of that read and a version below 2 is
    /// returned as read (the line guard flags it `implausible:protocol_version`). One forged
    /// frame on a hostile line must not turn a v2 board into a v1 board for the rest of the
    /// run.
    fn read_status(&mut self) -> Result<BoardStatus, RtuError> {
        if self.protocol == Some(BoardProtocol::V2) {
            let tx = Transaction::read_input_registers(self.cfg.slave, 0, input::COUNT)?;
            let regs = self.registers(&tx)?;
            let mut block = [0u16; input::COUNT as usize];
            block.copy_from_slice(&regs);
            return Ok(BoardStatus::from_input_registers(&block));
        }
        if self.protocol != Some(BoardProtocol::V1) {
            let tx = Transaction::read_input_registers(self.cfg.slave, 0, input::COUNT)?;
            match self.registers(&tx) {
                Ok(regs) => {
                    let mut block = [0u16; input::COUNT as usize];
                    block.copy_from_slice(&regs);
                    let status = BoardStatus::from_input_registers(&block);
                    if status.is_v2() {
                        self.protocol = Some(BoardProtocol::V2);
                        return Ok(status);
                    }
                    self.protocol = Some(BoardProtocol::V1);
                    let mut v1 = [0u16; input::V1_COUNT as usize];
                    v1.copy_from_slice(&block[..input::V1_COUNT as usize]);
                    return Ok(BoardStatus::from_v1_input_registers(&v1));
                }
                Err(e) if e.kind() == BoardErrorKind::Exception(2) => {
                    self.protocol = Some(BoardProtocol::V1);
                }
                Err(e) => return Err(e),
            }
        }
        let tx = Transaction::read_input_registers(self.cfg.slave, 0, input::V1_COUNT)?;
        let regs = self.registers(&tx)?;
        let mut block = [0u16; input::V1_COUNT as usize];
        block.copy_from_slice(&regs);
        Ok(BoardStatus::from_v1_input_registers(&block))
    }

    fn protocol(&self) -> Option<BoardProtocol> {
        self.protocol
    }

    /// FC16 registers 0…1 (`OVERRIDE_CMD`, `HEARTBEAT`).
    fn write_override(&mut self, override_pct: u16, heartbeat: u16) -> Result<(), RtuError> {
        let tx = Transaction::write_multiple_registers(
            self.cfg.slave,
            holding::OVERRIDE_CMD,
            &[override_pct, heartbeat],
        )?;
        self.transact(&tx).map(|_| ())
    }

    /// FC06 register 2 (`CONTROL`).
    fn write_control(&mut self, control: ControlBits) -> Result<(), RtuError> {
        let tx = Transaction::write_single_register(
            self.cfg.slave,
            holding::CONTROL,
            control.to_register(),
        )?;
        self.transact(&tx).map(|_| ())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A byte stream that answers every request with the bytes of `reply` (then EOF).
    struct Canned {
        reply: Cursor<Vec<u8>>,
        written: Vec<u8>,
    }

    impl Read for Canned {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            self.reply.read(buf)
        }
    }

    impl Write for Canned {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.written.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// An FC04 reply of 15 input registers with `PROTOCOL_VERSION` = `version`.
    fn status_reply(version: u16) -> Vec<u8> {
        let mut regs = [0u16; input::COUNT as usize];
        regs[input::OVERRIDE_STEP as usize] = 10;
        regs[input::PROTOCOL_VERSION as usize] = version;
        let mut f = vec![1, 4, 2 * input::COUNT as u8];
        for r in regs {
            f.extend_from_slice(&r.to_be_bytes());
        }
        crate::rtu::codec::append_crc(&mut f);
        f
    }

    #[test]
    fn a_v2_link_stays_v2_whatever_one_frame_says() {
        let mut replies = status_reply(2);
        let mut exception = vec![1, 0x84, 2];
        crate::rtu::codec::append_crc(&mut exception);
        replies.extend_from_slice(&exception);
        replies.extend(status_reply(0));
        replies.extend(status_reply(2));
        let port = Canned {
            reply: Cursor::new(replies),
            written: Vec::new(),
        };
        let mut link = RtuBoard::new(port, RtuLinkConfig::default());
        assert!(link.read_status().expect("v2 status").is_v2());
        assert_eq!(link.protocol(), Some(BoardProtocol::V2));
        // A forged exception 02: an error of this read, not a v1 board.
        let e = link.read_status().expect_err("exception");
        assert_eq!(e.kind(), BoardErrorKind::Exception(2));
        assert_eq!(link.protocol(), Some(BoardProtocol::V2));
        // A version of 0 in one frame is returned as read (the line guard judges it).
        let s = link.read_status().expect("status as read");
        assert_eq!(s.protocol_version, 0);
        assert_eq!(link.protocol(), Some(BoardProtocol::V2));
        assert!(link.read_status().expect("v2 again").is_v2());
    }

    #[test]
    fn registers_of_a_write_transaction_is_a_caller_error_not_a_bad_reply() {
        let tx = Transaction::write_single_register(1, holding::WATCHDOG_MS, 500).expect("build");
        // FC06's reply echoes the request byte for byte: a correct acknowledgement.
        let ack = tx.request_bytes().to_vec();
        let port = Canned {
            reply: Cursor::new(ack.clone()),
            written: Vec::new(),
        };
        let mut link = RtuBoard::new(port, RtuLinkConfig::default());
        let e = link
            .registers(&tx)
            .expect_err("a write returns no registers");
        assert!(
            matches!(e, RtuError::Build(BuildError(msg)) if msg.contains("write transaction")),
            "{e:?}"
        );
        assert_eq!(link.get_mut().written, ack, "the request went out once");
    }
}
