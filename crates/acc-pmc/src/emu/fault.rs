//! Fault injection on a link's byte stream, for tests of the link and of the runtime's
//! fault policy.
//!
//! [`FaultyStream`] wraps the *client's* end of a stream. Every request the client writes
//! starts a new exchange; if a [`Fault`] is queued in the shared [`FaultInjector`], it is
//! applied to that exchange's reply:
//!
//! * [`Fault::CorruptCrc`] flips one bit of the reply's 4th byte (every RTU reply is at
//!   least 5 bytes long, so the byte exists and the reply then fails its CRC check; the
//!   byte is a data or address byte except in a 5-byte exception reply);
//! * [`Fault::DropReply`] swallows the reply (the client times out);
//! * [`Fault::DelayReply`] holds the reply back for a while (longer than the client's
//!   timeout ⇒ a timeout now and a late reply on the line later, which the client must
//!   discard);
//! * [`Fault::Garbage`] puts noise bytes in front of the reply.
//!
//! The same faults can be applied on the board's side instead, to every reply an
//! [`super::RtuServer`] sends ([`super::RtuServer::set_faults`],
//! [`super::PtyBoard::faults`]): that reaches a client in another process
//! (`acc run --port <pty>` against `acc board-sim`).
//!
//! The injector is `Clone + Send`: keep one handle in the test while the stream is owned
//! by an [`crate::rtu::RtuBoard`] running in another thread.
//!
//! ```
//! use acc_pmc::emu::fault::{Fault, FaultInjector};
//! let faults = FaultInjector::default();
//! faults.push_n(Fault::DropReply, 2);
//! assert_eq!(faults.pending(), 2);
//! ```

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use crate::clock::{Clock, SystemClock};

/// One fault applied to one reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fault {
    /// Flip bit 0 of the reply's byte at index 3, so that the reply fails its CRC check.
    /// That byte is the CRC's low byte only in a 5-byte exception reply; in a read reply it
    /// is the first data byte, in a write echo the register address's low byte. The CRC
    /// bytes themselves are left as sent.
    CorruptCrc,
    /// Swallow the whole reply.
    DropReply,
    /// Deliver the reply only this long after the request was written.
    DelayReply(Duration),
    /// Deliver these bytes before the reply.
    Garbage(Vec<u8>),
}

#[derive(Debug, Default)]
struct Shared {
    queue: VecDeque<Fault>,
    applied: u64,
}

/// Shared queue of faults, one popped per request. Cheap to clone.
#[derive(Debug, Clone, Default)]
pub struct FaultInjector {
    inner: Arc<Mutex<Shared>>,
}

impl FaultInjector {
    fn with<R>(&self, f: impl FnOnce(&mut Shared) -> R) -> R {
        f(&mut self.inner.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// Apply `fault` to the next request's reply (after those already queued).
    pub fn push(&self, fault: Fault) {
        self.with(|s| s.queue.push_back(fault));
    }

    /// Apply `fault` to each of the next `n` replies.
    pub fn push_n(&self, fault: Fault, n: usize) {
        self.with(|s| s.queue.extend(std::iter::repeat_n(fault, n)));
    }

    /// Faults still queued.
    pub fn pending(&self) -> usize {
        self.with(|s| s.queue.len())
    }

    /// Faults taken from the queue so far: one counts when its request is written (client
    /// side) or its reply is sent (board side), whether or not the reply then arrives.
    pub fn applied(&self) -> u64 {
        self.with(|s| s.applied)
    }

    /// Drop all queued faults.
    pub fn clear(&self) {
        self.with(|s| s.queue.clear());
    }

    pub(crate) fn next(&self) -> Option<Fault> {
        self.with(|s| {
            let f = s.queue.pop_front();
            if f.is_some() {
                s.applied += 1;
            }
            f
        })
    }
}

#[derive(Debug)]
enum Active {
    None,
    Corrupt { seen: usize },
    Drop,
    Garbage { bytes: Vec<u8>, sent: usize },
}

/// A client-side byte stream that applies queued [`Fault`]s to replies.
#[derive(Debug)]
pub struct FaultyStream<T> {
    inner: T,
    faults: FaultInjector,
    active: Active,
    /// Bytes on the line are held back until then (a late reply is late for everyone).
    hold_until: Option<Duration>,
    writing: bool,
    idle_slice: Duration,
    /// The hold and the idle waits pass on this clock (default: the system clock).
    clock: Arc<dyn Clock>,
}

impl<T: Read + Write> FaultyStream<T> {
    /// Wrap `inner`; faults come from `faults`. While a reply is held back the stream
    /// answers reads with `TimedOut` after `idle_slice`, or sooner when the hold ends first
    /// (use the port's read timeout, e.g. [`crate::serial::POLL_SLICE`]).
    pub fn new(inner: T, faults: FaultInjector, idle_slice: Duration) -> Self {
        Self {
            inner,
            faults,
            active: Active::None,
            hold_until: None,
            writing: false,
            idle_slice,
            clock: Arc::new(SystemClock::new()),
        }
    }

    /// Hold replies and idle on `clock` (default: the system clock).
    pub fn with_clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.clock = clock;
        self
    }

    /// The injector feeding this stream.
    pub fn injector(&self) -> &FaultInjector {
        &self.faults
    }

    /// The wrapped stream.
    pub fn get_mut(&mut self) -> &mut T {
        &mut self.inner
    }

    fn idle(&self, wait: Duration) -> std::io::Error {
        self.clock
            .sleep_until(self.clock.now() + wait.min(self.idle_slice));
        std::io::Error::new(
            std::io::ErrorKind::TimedOut,
            "fault injection: reply held back",
        )
    }
}

impl<T: Read + Write> Write for FaultyStream<T> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if !self.writing && !buf.is_empty() {
            // First write after reading: a new request, a new exchange.
            self.writing = true;
            self.active = match self.faults.next() {
                None => Active::None,
                Some(Fault::CorruptCrc) => Active::Corrupt { seen: 0 },
                Some(Fault::DropReply) => Active::Drop,
                Some(Fault::DelayReply(d)) => {
                    self.hold_until = Some(self.clock.now() + d);
                    Active::None
                }
                Some(Fault::Garbage(bytes)) => Active::Garbage { bytes, sent: 0 },
            };
        }
        self.inner.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<T: Read + Write> Read for FaultyStream<T> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.writing = false;
        if let Some(until) = self.hold_until {
            let now = self.clock.now();
            if now < until {
                return Err(self.idle(until - now));
            }
            self.hold_until = None;
        }
        match &mut self.active {
            Active::None => self.inner.read(buf),
            Active::Corrupt { seen } => {
                let n = self.inner.read(buf)?;
                let start = *seen;
                *seen += n;
                if (start..start + n).contains(&3) {
                    buf[3 - start] ^= 0x01;
                }
                Ok(n)
            }
            Active::Drop => {
                // Consume and discard whatever arrives; report silence.
                let mut sink = [0u8; 64];
                match self.inner.read(&mut sink) {
                    Ok(_) => Err(std::io::Error::new(
                        std::io::ErrorKind::TimedOut,
                        "fault injection: reply dropped",
                    )),
                    Err(e) => Err(e),
                }
            }
            Active::Garbage { bytes, sent } => {
                if *sent < bytes.len() && !buf.is_empty() {
                    let n = (bytes.len() - *sent).min(buf.len());
                    buf[..n].copy_from_slice(&bytes[*sent..*sent + n]);
                    *sent += n;
                    Ok(n)
                } else {
                    self.inner.read(buf)
                }
            }
        }
    }
}
