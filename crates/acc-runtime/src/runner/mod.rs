//! The threaded runtime: link I/O, control and logging on three threads joined by
//! `crossbeam-channel`.
//!
//! - **I/O thread** (owns the [`Board`] and the [`Ticker`]): at every deadline it reads the
//!   status, hands it to the control thread, waits for the period's writes
//!   ([`BoardWrites`], bounded by one period), performs them and reports their outcome with
//!   the next status. It also measures the round-trip time of each cycle (read + decide +
//!   writes).
//! - **Control thread** (owns the [`ControlLoop`]: policy, law, force source): pure
//!   decisions, no I/O; every period it hands a [`RunRecord`] to the logger with
//!   `try_send`, **never waiting on it**. A record the logger's queue cannot take yet waits
//!   in the control thread's backlog, in order, and goes first next period.
//! - **Logger thread** (owns the [`LogSink`]): writes and flushes each record; drains the
//!   queue and flushes at the end.
//!
//! **No row is lost.** The queue and the backlog together hold
//! [`RunOptions::log_buffer`] records (default 6000: ten minutes at T = 0.1 s). When the
//! writer has stalled past that (a full disk, a hung network share), every further record
//! is still kept in the backlog, flagged `log_stalled`, and the loop is told
//! ([`ControlLoop::set_log_stalled`]): an active ACC releases with a feed hold
//! ([`crate::policy::Release::LogStalled`]) and does not arm again while the writer is
//! stalled — the machine never cuts on without a record. When the writer catches up, the
//! backlog drains and the run goes on (re-arming needs the operator's switch, as after any
//! latched release). At the end, after the shutdown `CONTROL` write, the backlog is handed
//! to the logger and written in full ([`RunSummary::log_backlog_max`] says how far it got).
//! Only a logger that has died (its thread gone) loses records; they are counted in
//! [`RunSummary::log_dropped`].
//!
//! Shutdown: when `max_periods` is reached, or a stop is requested ([`StopRequest`]: Ctrl-C,
//! see [`crate::shutdown`]) and — with a [`Drain`] — the cut has ended, the I/O thread writes
//! `CONTROL` with `ACC_REQUEST` and `FEED_HOLD_REQUEST` cleared (the board then follows the
//! operator's override). A stop while still cutting when the drain runs out, or a second
//! request, writes feed hold first and then releases with the hold kept ([`Ended`]). The
//! channels close, the logger drains and flushes, and [`run`] returns a [`RunSummary`].
//!
//! On a board without the fallback clamp (a v1 board, or a protocol not yet known) a run that
//! ends while ACC still drives the override in the cut (`max_periods`, a vanished device)
//! also requests feed hold before it releases: a release there would hand the feed to the
//! operator's knob ([`RunSummary::shutdown_feed_hold`]).
//!
//! A vanished device ([`BoardErrorKind::Disconnected`]) ends the run after
//! [`RunOptions::device_lost_periods`] ([`OnDeviceLost::Exit`]), or, with
//! [`OnDeviceLost::Reconnect`] and a reopen callback ([`drive`]), the runner keeps
//! a row every period and tries to reopen the link every period until the timeout; the
//! policy re-arms at the last command once the board answers again while the cut is on.
//!
//! Files, in the order a run uses them: `options.rs` (what a run is asked to do),
//! `logger.rs` (the logger thread and its sinks), `control.rs` (the control thread's
//! period), `io.rs` (the I/O thread's period and the run's end conditions), `shutdown.rs`
//! (the final `CONTROL` write), `outcome.rs` (how a run ended, what it did).

use std::sync::atomic::AtomicBool;

use acc_core::{ForceSource, OverrideLaw};
use acc_pmc::{Board, BoardError};
use crossbeam_channel::bounded;

use crate::clock::Clock;
use crate::control_loop::{BoardWrites, ControlLoop, WriteResult};
use crate::log_backlog::{Backlog, LOG_QUEUE};
use crate::record::RunRecord;
use crate::ticker::Ticker;

mod control;
mod io;
mod logger;
mod options;
mod outcome;
mod shutdown;

pub use control::{PeriodObserver, Verdict};
pub use logger::{LogSink, VecSink};
pub use options::{Drain, OnDeviceLost, RunOptions, StopRequest};
pub use outcome::{Ended, RunError, RunSummary};

use control::ControlThread;
use io::{IoLoop, StatusMsg};

/// Optional hooks of [`drive`].
pub struct Hooks<'a, P> {
    /// Reopens a vanished link ([`OnDeviceLost::Reconnect`]).
    pub reopen: Option<Reopen<'a, P>>,
    /// Sees every period's record ([`PeriodObserver`]).
    pub observer: Option<&'a mut dyn PeriodObserver>,
}

impl<P> Default for Hooks<'_, P> {
    fn default() -> Self {
        Self {
            reopen: None,
            observer: None,
        }
    }
}

/// The callback that reopens a vanished link ([`drive`]): a fresh link, or why
/// not.
pub type Reopen<'a, P> = &'a mut dyn FnMut() -> Result<P, String>;

/// What the control thread tells the I/O thread between periods.
#[derive(Debug)]
struct Flags {
    /// Set after each decision: the cut has ended (or ACC is not driving), so a release
    /// cannot raise the feed.
    out_of_cut: AtomicBool,
    /// Set before the period's writes are handed over: the observer ended the run.
    finished: AtomicBool,
}

/// Perform a period's writes on a board: the I/O thread does it after the control thread's
/// decision, [`ControlLoop::cycle`] in a single-threaded period.
pub fn execute_writes<P: Board>(pmc: &mut P, writes: &BoardWrites) -> WriteResult {
    let mut r = WriteResult::default();
    if let Some((cmd, hb)) = writes.override_and_heartbeat {
        if let Err(e) = pmc.write_override(cmd, hb) {
            r.override_error = Some(e.kind());
        }
    }
    if let Some(c) = writes.control {
        match pmc.write_control(c) {
            Ok(()) => r.control_written = Some(c),
            Err(e) => r.control_error = Some(e.kind()),
        }
    }
    r
}

/// Run the loop until `stop` is set or `opts.max_periods` is reached. See the module docs.
/// A vanished device is never reopened (see [`drive`]).
pub fn run<P, L, F, C, S, Q>(
    pmc: &mut P,
    control: &mut ControlLoop<L, F>,
    clock: C,
    sink: &mut S,
    stop: &Q,
    opts: RunOptions,
) -> Result<RunSummary, RunError>
where
    P: Board + Send,
    L: OverrideLaw + Send,
    F: ForceSource + Send,
    C: Clock + Clone,
    S: LogSink + Send,
    Q: StopRequest + ?Sized,
{
    drive(pmc, control, clock, sink, stop, opts, Hooks::default())
}

/// The period driver: `acc run` (wall clock, a serial or CAN board), `acc sim`, `acc compare`,
/// the what-if and the paper tests (the stepped clock, the simulated board) all run the loop
/// through it. See the module docs; [`run`] is its short form without hooks. With
/// [`OnDeviceLost::Reconnect`], `hooks.reopen` is called once per period while the device is
/// gone and its link replaces `pmc` on success.
pub fn drive<P, L, F, C, S, Q>(
    pmc: &mut P,
    control: &mut ControlLoop<L, F>,
    clock: C,
    sink: &mut S,
    stop: &Q,
    opts: RunOptions,
    hooks: Hooks<'_, P>,
) -> Result<RunSummary, RunError>
where
    P: Board + Send,
    L: OverrideLaw + Send,
    F: ForceSource + Send,
    C: Clock + Clone,
    S: LogSink + Send,
    Q: StopRequest + ?Sized,
{
    let mut ticker = Ticker::new(clock.clone(), opts.period)?;
    let (status_tx, status_rx) = bounded::<StatusMsg>(1);
    let (writes_tx, writes_rx) = bounded::<(u64, BoardWrites)>(2);
    let queue = LOG_QUEUE.min(opts.log_buffer.max(1));
    let (log_tx, log_rx) = bounded::<RunRecord>(queue);
    let backlog = Backlog::new(log_tx, opts.log_buffer.max(1).saturating_sub(queue));
    let flags = Flags {
        out_of_cut: AtomicBool::new(true),
        finished: AtomicBool::new(false),
    };
    let flags = &flags;
    let Hooks { reopen, observer } = hooks;
    let ctl = ControlThread::new(control, observer, backlog, &opts, flags);

    std::thread::scope(|scope| {
        let logger = spawn(scope, "acc-log", move || logger::write_all(sink, log_rx))?;
        let ctl = spawn(scope, "acc-control", move || ctl.run(status_rx, writes_tx))?;
        let io_span = tracing::info_span!("io").entered();
        let mut io = IoLoop::new(&mut *pmc, &mut ticker, clock, opts, reopen);
        let ended = io.run(stop, flags, &status_tx, &writes_rx);
        let io = io.counts();
        drop(status_tx);
        let ctl = ctl.join().map_err(|_| RunError::Panicked("acc-control"))?;
        let shutdown = shutdown::release_board(pmc, ctl.control, ended, flags, &opts);
        drop(io_span);
        // The board has been told; now every record still waiting goes to the logger,
        // waiting on it as long as it takes.
        let log = ctl.log.finish();
        let written = logger.join().map_err(|_| RunError::Panicked("acc-log"))?;
        Ok(RunSummary::of(
            ended,
            io,
            &ctl.totals,
            ticker.stats(),
            log,
            written,
            shutdown,
        ))
    })
}

/// Start a named thread of the run in `scope`.
fn spawn<'scope, 'env, T: Send + 'scope>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    name: &str,
    f: impl FnOnce() -> T + Send + 'scope,
) -> std::io::Result<std::thread::ScopedJoinHandle<'scope, T>> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn_scoped(scope, f)
}
