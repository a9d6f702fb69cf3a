//! An emulated board on a pseudo-terminal pair, for tests, benches, `acc board-sim` and
//! the runtime's end-to-end tests.
//!
//! [`PtyBoard::spawn`] creates a [`TTYPort::pair`], serves a [`BoardLogic`] with an
//! [`RtuServer`] on the master end in a background thread, and hands out the other end:
//! either as a [`TTYPort`] for our own client ([`PtyBoard::take_client_port`]) or as a device
//! path for an external program (`mbpoll`, a `serialport::new(path)` open).
//!
//! ```
//! use acc_pmc::emu::{BoardLogic, PtyBoard};
//! use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
//! use acc_pmc::Board;
//! let mut pty = PtyBoard::spawn(BoardLogic::default(), 1, 115_200).unwrap();
//! pty.with_board(|b| { b.set_acc_switch(true); b.push_power_sample(4200); });
//! let mut link = RtuBoard::new(pty.take_client_port().unwrap(), RtuLinkConfig::default());
//! let status = link.read_status().unwrap();
//! assert!(status.acc_switch);
//! assert_eq!(status.spindle_power_w, 4200);
//! ```

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use serialport::{SerialPort, TTYPort};

use super::board::{lock_board, BoardLogic, SharedBoard};
use super::fault::FaultInjector;
use super::rtu_server::{RtuServer, ServerStats};
use crate::clock::{Clock, SystemClock};
use crate::serial::configure_pty;

/// A [`BoardLogic`] served over Modbus RTU on the master end of a pty pair.
#[derive(Debug)]
pub struct PtyBoard {
    board: SharedBoard,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<std::io::Result<ServerStats>>>,
    client: Option<TTYPort>,
    path: String,
    faults: FaultInjector,
}

impl PtyBoard {
    /// Serve `board` as slave `slave` at `baud` (8N1; a pty does not pace bytes, see
    /// [`Paced`]). The client end stays open inside until taken, so the pty never hangs up.
    pub fn spawn(board: BoardLogic, slave: u8, baud: u32) -> std::io::Result<Self> {
        Self::spawn_with(Arc::new(Mutex::new(board)), slave, baud, |p| p)
    }

    /// As [`PtyBoard::spawn`] with a shared board and a wrapper around the server's stream
    /// (e.g. [`Paced`] to emulate wire time).
    pub fn spawn_with<S, F>(
        board: SharedBoard,
        slave: u8,
        baud: u32,
        wrap: F,
    ) -> std::io::Result<Self>
    where
        S: Read + Write + Send + 'static,
        F: FnOnce(TTYPort) -> S,
    {
        Self::spawn_with_clock(board, slave, baud, wrap, Box::new(SystemClock::default()))
    }

    /// As [`PtyBoard::spawn_with`] with the board's time (its watchdog) on `clock`, e.g. a
    /// [`crate::clock::ScaledClock`] so that `WATCHDOG_MS` counts machine time when the
    /// simulated machine runs faster than real time.
    pub fn spawn_with_clock<S, F>(
        board: SharedBoard,
        slave: u8,
        baud: u32,
        wrap: F,
        clock: Box<dyn Clock>,
    ) -> std::io::Result<Self>
    where
        S: Read + Write + Send + 'static,
        F: FnOnce(TTYPort) -> S,
    {
        let (mut master, mut client) = TTYPort::pair().map_err(std::io::Error::other)?;
        configure_pty(&mut master, baud).map_err(std::io::Error::other)?;
        configure_pty(&mut client, baud).map_err(std::io::Error::other)?;
        let path = client
            .name()
            .ok_or_else(|| std::io::Error::other("pty slave has no device path"))?;
        let stop = Arc::new(AtomicBool::new(false));
        let faults = FaultInjector::default();
        let stream = wrap(master);
        let thread = {
            let board = Arc::clone(&board);
            let stop = Arc::clone(&stop);
            let faults = faults.clone();
            std::thread::Builder::new()
                .name("pty-board".into())
                .spawn(move || {
                    let mut server = RtuServer::with_clock(stream, slave, board, clock);
                    server.set_faults(faults);
                    server.run(&stop)?;
                    Ok(server.stats())
                })?
        };
        Ok(Self {
            board,
            stop,
            thread: Some(thread),
            client: Some(client),
            path,
            faults,
        })
    }

    /// Device path of the client end, for an external program (`mbpoll`, pymodbus) or
    /// [`crate::serial::open_port`]. Keep `self` alive while it is in use.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The client end as a port (8N1, read timeout [`crate::serial::POLL_SLICE`]).
    /// `None` after the first call.
    pub fn take_client_port(&mut self) -> Option<TTYPort> {
        self.client.take()
    }

    /// Faults applied to the board's replies (see [`super::fault`]); empty by default.
    pub fn faults(&self) -> &FaultInjector {
        &self.faults
    }

    /// The served board (shared with the server thread).
    pub fn board(&self) -> &SharedBoard {
        &self.board
    }

    /// Run `f` on the board under its lock (the machine side: switch, power, rpm…).
    pub fn with_board<R>(&self, f: impl FnOnce(&mut BoardLogic) -> R) -> R {
        f(&mut lock_board(&self.board))
    }

    /// Stop the server and return its statistics.
    pub fn stop(mut self) -> std::io::Result<ServerStats> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> std::io::Result<ServerStats> {
        self.stop.store(true, Ordering::Relaxed);
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| std::io::Error::other("pty board thread panicked"))?,
            None => Ok(ServerStats::default()),
        }
    }
}

impl Drop for PtyBoard {
    fn drop(&mut self) {
        // The result is only interesting to callers of `stop`.
        let _ = self.shutdown();
    }
}

/// Paces writes like a UART at `baud`: `n` bytes are delivered `n` × bits per character /
/// baud after the write starts. A pty moves bytes instantly; wrapping the board's stream in `Paced`
/// makes a round trip cost its wire time, as on a real line.
#[derive(Debug)]
pub struct Paced<T> {
    inner: T,
    byte_time: Duration,
    /// The line is busy until then (time on `clock`).
    busy_until: Duration,
    clock: Arc<dyn Clock>,
}

impl<T> Paced<T> {
    /// `bits_per_char`: 1 start + 8 data + parity (0/1) + stop bits (1/2), i.e. 10 for
    /// 8N1, 11 for 8E1.
    pub fn new(inner: T, baud: u32, bits_per_char: u32) -> Self {
        let byte_time = Duration::from_secs_f64(f64::from(bits_per_char) / f64::from(baud.max(1)));
        Self {
            inner,
            byte_time,
            busy_until: Duration::ZERO,
            clock: Arc::new(SystemClock::new()),
        }
    }

    /// The wire time passes on `clock` (default: the system clock).
    pub fn with_clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.clock = clock;
        self
    }

    /// Time one character takes on the wire.
    pub fn byte_time(&self) -> Duration {
        self.byte_time
    }
}

impl<T: Write> Write for Paced<T> {
    /// Wait the wire time of `buf`, then deliver it whole (the receiver sees the last
    /// byte when a UART would have shifted it out).
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let start = self.busy_until.max(self.clock.now());
        self.busy_until = start + self.byte_time * u32::try_from(buf.len()).unwrap_or(u32::MAX);
        self.clock.sleep_until(self.busy_until);
        self.inner.write_all(buf)?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<T: Read> Read for Paced<T> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf)
    }
}
