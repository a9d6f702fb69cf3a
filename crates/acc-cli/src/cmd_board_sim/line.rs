//! The board's side of the line: faults on its replies (`--fault crc|drop|late|stall`, a
//! pulled cable) and the lockstep of the machine with the controller's command writes
//! (`--pace controller`).

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use acc_pmc::emu::Paced;
use acc_runtime::{Clock, SystemClock};

use super::faults::ReplyFault;

/// Modbus function code of Write Multiple Registers (FC 16): the controller's per-period
/// command (`OVERRIDE_CMD` + `HEARTBEAT`, ../shared/docs/pmc-board.md). Its normal reply
/// echoes the code in byte 1; an exception reply carries 0x90.
const WRITE_MULTIPLE: u8 = 0x10;

/// How long a command reply waits for the machine to take its period before it leaves
/// anyway (a machine loop that has stopped must not hang the line), wall time.
const TAKE_LIMIT: Duration = Duration::from_secs(2);

/// The machine in lockstep with the controller's command writes (`--pace controller`).
///
/// Every answered FC 16 write lets the machine advance one period, and the reply leaves
/// the board only after the machine has advanced. The controller's next read therefore
/// sees the period its command drove, however late either process runs on a loaded host:
/// machine time is counted in the controller's commands, not on a wall clock.
#[derive(Debug, Default)]
pub(super) struct CommandPace {
    state: Mutex<PaceState>,
    changed: Condvar,
}

#[derive(Debug, Default)]
struct PaceState {
    /// Command writes answered so far.
    written: u64,
    /// Command writes the machine has taken (advanced for, or seen to repeat a heartbeat).
    taken: u64,
    /// The machine loop has ended.
    closed: bool,
}

impl CommandPace {
    fn lock(&self) -> MutexGuard<'_, PaceState> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Server side: a command write was answered. Returns once the machine has taken it,
    /// or after [`TAKE_LIMIT`].
    fn command_answered(&self) {
        let mut s = self.lock();
        s.written += 1;
        let want = s.written;
        self.changed.notify_all();
        let _ = self
            .changed
            .wait_timeout_while(s, TAKE_LIMIT, |s| s.taken < want && !s.closed)
            .unwrap_or_else(PoisonError::into_inner);
    }

    /// Machine side: waits at most `poll` for a command write the machine has not taken;
    /// `true` if there is one.
    pub(super) fn next_command(&self, poll: Duration) -> bool {
        let s = self.lock();
        let (s, _) = self
            .changed
            .wait_timeout_while(s, poll, |s| s.written == s.taken && !s.closed)
            .unwrap_or_else(PoisonError::into_inner);
        s.written > s.taken
    }

    /// Machine side: every command write answered so far is taken.
    pub(super) fn take_all(&self) {
        let mut s = self.lock();
        s.taken = s.written;
        self.changed.notify_all();
    }

    /// The machine loop has ended: no writer waits any more.
    pub(super) fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }
}

pub(super) type FaultQueue = Arc<Mutex<VecDeque<ReplyFault>>>;

/// The board's side of the line with reply faults: each `write` of the server is one reply.
/// While `unplugged` is set the cable is out: whatever arrives is read and lost (the server
/// sees a silent line) and replies go nowhere.
struct FaultyReplies<P> {
    inner: P,
    queue: FaultQueue,
    unplugged: Arc<AtomicBool>,
    /// Late and stalled replies wait on the wall clock.
    wall: SystemClock,
    /// `--pace controller`: a command reply waits for the machine's period.
    pace: Option<Arc<CommandPace>>,
}

impl<P: Read> Read for FaultyReplies<P> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if self.unplugged.load(Ordering::Relaxed) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                "cable unplugged",
            ));
        }
        Ok(n)
    }
}

impl<P: Write> Write for FaultyReplies<P> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.unplugged.load(Ordering::Relaxed) {
            return Ok(buf.len());
        }
        if let (Some(pace), Some(&WRITE_MULTIPLE)) = (&self.pace, buf.get(1)) {
            pace.command_answered();
        }
        let fault = self
            .queue
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop_front();
        match fault {
            None => self.inner.write_all(buf)?,
            Some(ReplyFault::Drop) => {}
            Some(ReplyFault::Crc) => {
                let mut b = buf.to_vec();
                if let Some(x) = b.get_mut(3) {
                    *x ^= 0x01;
                }
                self.inner.write_all(&b)?;
            }
            Some(ReplyFault::Late(d)) | Some(ReplyFault::Stall(d)) => {
                self.wall.sleep_until(self.wall.now() + d);
                self.inner.write_all(buf)?;
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

pub(super) fn wrap<P: Read + Write + Send + 'static>(
    inner: P,
    queue: FaultQueue,
    unplugged: Arc<AtomicBool>,
    paced: Option<u32>,
    pace: Option<Arc<CommandPace>>,
) -> Box<dyn ReadWrite> {
    match paced {
        Some(baud) => Box::new(FaultyReplies {
            inner: Paced::new(inner, baud, 10),
            queue,
            unplugged,
            wall: SystemClock::new(),
            pace,
        }),
        None => Box::new(FaultyReplies {
            inner,
            queue,
            unplugged,
            wall: SystemClock::new(),
            pace,
        }),
    }
}

pub(super) trait ReadWrite: Read + Write + Send {}
impl<T: Read + Write + Send> ReadWrite for T {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_reply_waits_until_the_machine_has_taken_its_period() {
        let pace = Arc::new(CommandPace::default());
        assert!(
            !pace.next_command(Duration::from_millis(5)),
            "no write, no period"
        );
        let writer = {
            let pace = Arc::clone(&pace);
            std::thread::spawn(move || {
                let wall = SystemClock::new();
                let start = wall.now();
                pace.command_answered();
                wall.now() - start
            })
        };
        assert!(
            pace.next_command(Duration::from_secs(1)),
            "the write arrived"
        );
        let wall = SystemClock::new();
        wall.sleep_until(wall.now() + Duration::from_millis(100));
        pace.take_all();
        let waited = writer.join().expect("writer");
        assert!(
            waited >= Duration::from_millis(100) && waited < TAKE_LIMIT,
            "the reply left when the period was taken: {waited:?}"
        );
        assert!(!pace.next_command(Duration::from_millis(5)), "taken");
    }

    #[test]
    fn a_closed_pace_releases_the_writer() {
        let pace = CommandPace::default();
        pace.close();
        let wall = SystemClock::new();
        let start = wall.now();
        pace.command_answered();
        assert!(wall.now() - start < Duration::from_millis(500));
    }
}
