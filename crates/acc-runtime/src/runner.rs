//! The threaded runtime: link I/O, control and logging on three threads joined by
//! `crossbeam-channel`.
//!
//! - **I/O thread** (owns the [`Board`] and the [`Ticker`]): at every deadline it reads the
//!   status, hands it to the control thread, waits for the write plan (bounded by one
//!   period), performs the writes and reports their outcome with the next status. It also
//!   measures the round-trip time of each cycle (read + decide + writes).
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

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use acc_core::{ForceSource, OverrideLaw};
use acc_pmc::{Board, BoardError, BoardErrorKind, BoardProtocol, BoardStatus};
use crossbeam_channel::{bounded, RecvTimeoutError};

use crate::clock::Clock;
use crate::control_loop::{ControlLoop, WritePlan, WriteResult};
use crate::log_backlog::{Backlog, LOG_QUEUE};
use crate::policy::{AccState, Alarms};
use crate::record::RunRecord;
use crate::stats::LatencyStats;
use crate::ticker::{Ticker, TickerError, TickerStats};

/// Where the logger thread puts the records (the CLI writes the run-log CSV).
pub trait LogSink {
    /// Error of the sink.
    type Error: std::fmt::Display;
    /// Write one record (and flush it, for a run log that survives a crash).
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error>;
    /// Flush everything (called once at the end).
    fn flush(&mut self) -> Result<(), Self::Error>;
}

/// A sink that keeps the records in memory (tests).
#[derive(Debug, Default, Clone)]
pub struct VecSink(pub Vec<RunRecord>);

impl LogSink for VecSink {
    type Error = std::convert::Infallible;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.0.push(rec.clone());
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Options of [`run`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOptions {
    /// Control period T.
    pub period: Duration,
    /// Stop after this many periods of the clock (`None`: until the stop flag): the cycles
    /// run plus the periods the ticker skipped, so that a run on a loaded host ends at the
    /// same machine time (the first period at or past it).
    pub max_periods: Option<u64>,
    /// Records the logger may fall behind before the loop holds the feed (the logger's
    /// queue plus the control thread's backlog; default 6000, ten minutes at T = 0.1 s).
    /// Records beyond it are kept too (see the module docs): none is dropped.
    pub log_buffer: usize,
    /// Attempts of the final `CONTROL` write at shutdown (default 5).
    pub shutdown_attempts: u32,
    /// Machine seconds per wall second (default 1): the run log's `t_s` is machine time.
    pub time_scale: f64,
    /// Fr to log in periods where the law was not stepped, N (default `None`).
    pub force_ref_n: Option<f64>,
    /// Drain on a stop request (default `None`: release at once). With a drain, a stop
    /// request while ACC drives the override keeps the loop running until the cut has ended
    /// ([`Drain::air_periods`] in a row out of the cut, see [`ControlLoop::air_periods`]), at
    /// most [`Drain::max`]; still cutting then, or on a second request, it requests feed hold
    /// and then releases ([`Ended::FeedHold`]). `max_periods` ends without a drain.
    pub drain: Option<Drain>,
    /// End the run after this many consecutive periods in which the link reported the
    /// device gone (`BoardErrorKind::Disconnected`: the port or bus vanished), default 20
    /// (`None`: never). The policy has released by then (after `link_hold_periods`); the run
    /// ends with [`Ended::DeviceLost`] instead of logging "disconnected" forever. Used with
    /// [`OnDeviceLost::Exit`].
    pub device_lost_periods: Option<u32>,
    /// What a vanished device does (default [`OnDeviceLost::Exit`]).
    pub on_device_lost: OnDeviceLost,
}

/// What the runner does when the board's device vanishes (`[runtime] on_device_lost`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OnDeviceLost {
    /// End the run after [`RunOptions::device_lost_periods`] ([`Ended::DeviceLost`]).
    #[default]
    Exit,
    /// Keep a row every period (flagged `link:disconnected`) and try to reopen the link
    /// every period (the callback of [`drive`]); after `timeout` (clock time)
    /// without the device, end as [`OnDeviceLost::Exit`] does.
    Reconnect {
        /// Longest time without the device.
        timeout: Duration,
    },
}

/// The shutdown drain (`[shutdown]` of the run config).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drain {
    /// Longest drain, in the clock's (wall) time.
    pub max: Duration,
    /// Consecutive periods out of the cut that end the drain (≥ 1).
    pub air_periods: u32,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// `max_periods` reached; `ACC_REQUEST` cleared.
    Completed,
    /// Stopped on request out of the cut (or with ACC not driving): `ACC_REQUEST` cleared,
    /// the operator has the override.
    Released,
    /// Stopped on request while still cutting (the drain ran out, or a second request):
    /// feed hold requested, then `ACC_REQUEST` cleared with the feed hold kept.
    FeedHold {
        /// `drain_timeout` or `second_signal`.
        reason: &'static str,
    },
    /// The device was gone for [`RunOptions::device_lost_periods`] periods in a row; the
    /// final `CONTROL` write was tried (it normally fails: the board's watchdog and fallback
    /// take over).
    DeviceLost,
    /// The [`PeriodObserver`] ended the run (the simulated machine finished its path, or
    /// stood in a fault's feed hold for the simulator's limit); shut down as
    /// [`Ended::Completed`].
    Finished,
}

/// The caller's view of every period, on the control thread, after the decision and before
/// the period's writes go to the board: its verdict takes effect before the next period,
/// whatever the threads' timing (the simulator's end conditions are deterministic).
pub trait PeriodObserver: Send {
    /// Annotate the period's record before it is logged (the simulator adds its plant's
    /// truth) and say whether the run ends after this period.
    fn period(&mut self, rec: &mut RunRecord) -> Verdict;
}

/// A [`PeriodObserver`]'s answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Go on.
    Continue,
    /// End the run after this period ([`Ended::Finished`]).
    Finish,
}

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

/// How the caller asks a run to stop: a plain flag (`AtomicBool`, a stop request) or the
/// process's signals ([`crate::shutdown::StopSignals`]: the first signal drains, a second
/// stops now).
pub trait StopRequest: Sync {
    /// A stop was requested (drain first, when the run has a [`Drain`]).
    fn stop_requested(&self) -> bool;
    /// Stop now, without waiting for the cut to end.
    fn stop_now(&self) -> bool {
        false
    }
}

impl StopRequest for AtomicBool {
    fn stop_requested(&self) -> bool {
        self.load(Ordering::SeqCst)
    }
}

impl StopRequest for crate::shutdown::StopSignals {
    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
    fn stop_now(&self) -> bool {
        self.again.load(Ordering::SeqCst)
    }
}

impl RunOptions {
    /// Options with period `period` and defaults otherwise.
    pub fn new(period: Duration) -> Self {
        Self {
            period,
            max_periods: None,
            log_buffer: 6000,
            shutdown_attempts: 5,
            time_scale: 1.0,
            force_ref_n: None,
            drain: None,
            device_lost_periods: Some(20),
            on_device_lost: OnDeviceLost::Exit,
        }
    }
}

/// What a run did.
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// Periods whose cycle ran (read, decide, write).
    pub periods: u64,
    /// How the run ended.
    pub ended: Ended,
    /// Periods the ticker skipped (no cycle ran; each still has a run-log row, flagged
    /// `skipped`).
    pub skipped: u64,
    /// Ticker counters and period jitter.
    pub ticker: TickerStats,
    /// Round-trip time of a controller cycle: read, decision, writes.
    pub cycle_rtt: LatencyStats,
    /// Records handed to the logger.
    pub logged: u64,
    /// Records lost because the logger thread had died (none otherwise: see the module
    /// docs).
    pub log_dropped: u64,
    /// Most records the logger was behind at once (queue and backlog).
    pub log_backlog_max: u64,
    /// Periods in which the writer was stalled past [`RunOptions::log_buffer`] (the loop
    /// held the feed).
    pub log_stalled_periods: u64,
    /// Errors the sink reported (records lost).
    pub log_errors: u64,
    /// First sink error, if any.
    pub log_error: Option<String>,
    /// Policy state at the end (before the shutdown write).
    pub final_state: AccState,
    /// Alarms at the end.
    pub alarms: Alarms,
    /// The shutdown `CONTROL` write reached the board.
    pub shutdown_ok: Result<(), BoardErrorKind>,
    /// The last status read.
    pub last_status: Option<BoardStatus>,
    /// The board's protocol as the link found it at the end (`None`: never known).
    pub protocol: Option<BoardProtocol>,
    /// The shutdown requested feed hold before releasing (a stop or end in the cut: see
    /// [`Ended::FeedHold`] and the module docs).
    pub shutdown_feed_hold: bool,
    /// Times the link was reopened after the device vanished.
    pub reconnects: u64,
    /// Longest time without the device during the run (clock time).
    pub longest_device_loss: Duration,
}

/// Errors that stop [`run`] before or while it runs.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Bad period.
    #[error(transparent)]
    Ticker(#[from] TickerError),
    /// A thread panicked.
    #[error("runtime thread `{0}` panicked")]
    Panicked(&'static str),
    /// A thread could not be started.
    #[error("cannot start runtime thread: {0}")]
    Spawn(#[from] std::io::Error),
}

struct StatusMsg {
    seq: u64,
    t_s: f64,
    skipped: u64,
    link: Result<BoardStatus, BoardErrorKind>,
    writes: WriteResult,
    lateness: Duration,
    overrun: bool,
    reopened: bool,
}

/// The callback that reopens a vanished link ([`drive`]): a fresh link, or why
/// not.
pub type Reopen<'a, P> = &'a mut dyn FnMut() -> Result<P, String>;

/// Perform a write plan on a board: the I/O thread does it after the control thread's
/// decision, [`ControlLoop::cycle`] in a single-threaded period.
pub fn execute_writes<P: Board>(pmc: &mut P, plan: &WritePlan) -> WriteResult {
    let mut r = WriteResult::default();
    if let Some((cmd, hb)) = plan.override_and_heartbeat {
        if let Err(e) = pmc.write_override(cmd, hb) {
            r.override_error = Some(e.kind());
        }
    }
    if let Some(c) = plan.control {
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
    let (plan_tx, plan_rx) = bounded::<(u64, WritePlan)>(2);
    let queue = LOG_QUEUE.min(opts.log_buffer.max(1));
    let (log_tx, log_rx) = bounded::<RunRecord>(queue);
    let backlog_limit = opts.log_buffer.max(1).saturating_sub(queue);
    let (time_scale, force_ref_n) = (opts.time_scale, opts.force_ref_n);
    let tick_s = opts.period.as_secs_f64();
    // Set by the control thread after each decision: the cut has ended (or ACC is not
    // driving), so a release cannot raise the feed.
    let out_of_cut = &AtomicBool::new(true);
    let air_needed = opts.drain.map_or(1, |d| d.air_periods.max(1));
    let Hooks {
        mut reopen,
        mut observer,
    } = hooks;
    // Set by the control thread before it hands over the plan: the observer ended the run.
    let finished = &AtomicBool::new(false);

    std::thread::scope(|scope| {
        // ---------------------------------------------------------------- logger
        let logger = std::thread::Builder::new()
            .name("acc-log".into())
            .spawn_scoped(scope, move || {
                let _span = tracing::info_span!("logger").entered();
                let (mut errors, mut first) = (0u64, None::<String>);
                for rec in log_rx.iter() {
                    if let Err(e) = sink.write(&rec) {
                        errors += 1;
                        if first.is_none() {
                            tracing::error!(error = %e, "run log write failed");
                            first = Some(e.to_string());
                        }
                    }
                }
                if let Err(e) = sink.flush() {
                    errors += 1;
                    first.get_or_insert(e.to_string());
                }
                (errors, first)
            })?;

        // ---------------------------------------------------------------- control
        let ctl = std::thread::Builder::new()
            .name("acc-control".into())
            .spawn_scoped(scope, move || {
                let _span = tracing::info_span!("control").entered();
                let mut skipped = 0u64;
                let mut log = Backlog::new(log_tx, backlog_limit);
                for msg in status_rx.iter() {
                    // The writer's state decides this period: stalled → no cut.
                    log.pump();
                    control.set_log_stalled(log.stalled());
                    // Deadlines the ticker skipped still get their (flagged) rows.
                    skipped += msg.skipped;
                    for k in 0..msg.skipped {
                        let t = msg.t_s - (msg.skipped - k) as f64 * tick_s;
                        log.offer(control.skip(t * time_scale));
                    }
                    if msg.reopened {
                        control.link_reopened();
                    }
                    control.writes_done(&msg.writes);
                    control.set_period_late(msg.overrun);
                    let rec = control.decide(msg.t_s * time_scale, msg.link);
                    out_of_cut.store(
                        control.policy().state() != AccState::Active
                            || control.air_periods() >= air_needed,
                        Ordering::SeqCst,
                    );
                    for e in rec.out.events.iter() {
                        tracing::info!(period = rec.index, event = ?e, "policy event");
                    }
                    let mut r = rec.record(force_ref_n);
                    r.late_ms = msg.lateness.as_secs_f64() * 1e3;
                    if msg.overrun {
                        r.flag("late");
                    }
                    if let Some(o) = observer.as_deref_mut() {
                        if o.period(&mut r) == Verdict::Finish {
                            finished.store(true, Ordering::SeqCst);
                        }
                    }
                    if plan_tx.send((msg.seq, rec.plan)).is_err() {
                        break;
                    }
                    log.offer(r);
                }
                (
                    log,
                    skipped,
                    control.policy().state(),
                    control.policy().alarms(),
                    control,
                )
            })?;

        // ---------------------------------------------------------------- link I/O (here)
        let io_span = tracing::info_span!("io").entered();
        let mut rtt = LatencyStats::new();
        let mut writes = WriteResult::default();
        let mut periods = 0u64;
        // Periods of the clock the ticker skipped (they count toward `max_periods`).
        let mut skipped_periods = 0u64;
        let mut last_status = None;
        let origin = clock.now();
        let mut drain_since: Option<std::time::Duration> = None;
        let mut gone = 0u32;
        let mut gone_since: Option<Duration> = None;
        let mut longest_device_loss = Duration::ZERO;
        let mut reconnects = 0u64;
        let ended = loop {
            if finished.load(Ordering::SeqCst) {
                break Ended::Finished;
            }
            if opts
                .max_periods
                .is_some_and(|m| periods + skipped_periods >= m)
            {
                break Ended::Completed;
            }
            let lost_for = gone_since.map(|t| clock.now().saturating_sub(t));
            if let Some(d) = lost_for {
                longest_device_loss = longest_device_loss.max(d);
            }
            let lost = match opts.on_device_lost {
                OnDeviceLost::Exit => opts.device_lost_periods.is_some_and(|n| gone >= n.max(1)),
                OnDeviceLost::Reconnect { timeout } => lost_for.is_some_and(|d| d >= timeout),
            };
            if lost {
                tracing::error!(
                    periods = gone,
                    secs = lost_for.unwrap_or_default().as_secs_f64(),
                    "the board's device is gone: ending the run"
                );
                break Ended::DeviceLost;
            }
            if stop.stop_requested() {
                let Some(drain) = opts.drain else {
                    break Ended::Released;
                };
                let now = clock.now();
                let since = *drain_since.get_or_insert_with(|| {
                    tracing::warn!(
                        max_s = drain.max.as_secs_f64(),
                        "stop requested: ACC keeps control until the cut ends"
                    );
                    now
                });
                if out_of_cut.load(Ordering::SeqCst) {
                    break Ended::Released;
                }
                if stop.stop_now() {
                    break Ended::FeedHold {
                        reason: "second_signal",
                    };
                }
                if now.saturating_sub(since) >= drain.max {
                    break Ended::FeedHold {
                        reason: "drain_timeout",
                    };
                }
            }
            let tick = ticker.wait();
            if tick.overrun {
                tracing::warn!(
                    period = tick.index,
                    late_us = tick.lateness.as_micros() as u64,
                    skipped = tick.skipped,
                    "period overrun"
                );
            }
            let t0 = clock.now();
            // The device is gone: try to reopen it (once per period) before this read.
            let mut reopened = false;
            if gone > 0 && matches!(opts.on_device_lost, OnDeviceLost::Reconnect { .. }) {
                if let Some(f) = reopen.as_mut() {
                    match f() {
                        Ok(fresh) => {
                            *pmc = fresh;
                            reopened = true;
                            reconnects += 1;
                            tracing::warn!(after_periods = gone, "board link reopened");
                        }
                        Err(e) => tracing::debug!(error = %e, "reopening the board link failed"),
                    }
                }
            }
            let link = pmc.read_status().map_err(|e| e.kind());
            if let Ok(s) = link {
                last_status = Some(s);
            }
            gone = match link {
                Err(BoardErrorKind::Disconnected) => gone.saturating_add(1),
                _ => 0,
            };
            if gone == 1 {
                gone_since = Some(t0);
            } else if gone == 0 {
                gone_since = None;
            }
            let skipped = if periods == 0 { 0 } else { tick.skipped };
            skipped_periods += skipped;
            let msg = StatusMsg {
                seq: periods,
                t_s: (tick.deadline.saturating_sub(origin)).as_secs_f64(),
                skipped,
                link,
                writes,
                lateness: tick.lateness,
                overrun: tick.overrun,
                reopened,
            };
            if status_tx.send(msg).is_err() {
                break Ended::FeedHold {
                    reason: "control_stopped",
                };
            }
            // The plan of this period; a late plan of an earlier period is discarded.
            let deadline = t0 + opts.period;
            let plan = loop {
                let left = deadline.saturating_sub(clock.now());
                // On a stepped clock a wait costs no clock time: the plan is awaited as long
                // as the period has clock time left (a read that used the whole period still
                // misses it, as on the wall clock).
                let got = if clock.is_stepped() && !left.is_zero() {
                    plan_rx.recv().map_err(|_| RecvTimeoutError::Disconnected)
                } else {
                    plan_rx.recv_timeout(left)
                };
                match got {
                    Ok((i, p)) if i == periods => break Some(p),
                    Ok(_) => continue,
                    Err(RecvTimeoutError::Timeout) => {
                        tracing::error!(period = periods, "control thread missed its period");
                        break Some(WritePlan::default());
                    }
                    Err(RecvTimeoutError::Disconnected) => break None,
                }
            };
            let Some(plan) = plan else {
                break Ended::FeedHold {
                    reason: "control_stopped",
                };
            };
            writes = execute_writes(pmc, &plan);
            rtt.record(clock.now().saturating_sub(t0));
            periods += 1;
        };
        // Stop: out of the cut, ACC request and feed hold cleared (the operator has the
        // override); still cutting, feed hold first, then the release with the hold kept.
        drop(status_tx);
        let (log, skipped, final_state, alarms, control) =
            ctl.join().map_err(|_| RunError::Panicked("acc-control"))?;
        // Without the board's fallback clamp (v1, or not known), a release while ACC drives
        // the override in the cut would hand the feed to the operator's knob: hold first.
        let protocol = pmc.protocol().or(control.policy().protocol());
        let in_cut = !out_of_cut.load(Ordering::SeqCst);
        let shutdown_feed_hold = match ended {
            Ended::FeedHold { .. } => true,
            Ended::Completed | Ended::Finished | Ended::DeviceLost => {
                in_cut && protocol != Some(BoardProtocol::V2)
            }
            Ended::Released => false,
        };
        let shutdown_ok = if shutdown_feed_hold {
            control.hold_and_release(pmc, opts.shutdown_attempts)
        } else {
            control.shutdown(pmc, opts.shutdown_attempts)
        };
        match (shutdown_ok, ended) {
            (Ok(()), Ended::FeedHold { reason }) => tracing::warn!(
                reason,
                "still cutting: feed hold requested, then ACC_REQUEST cleared with the hold kept"
            ),
            (Ok(()), _) if shutdown_feed_hold => tracing::warn!(
                "still cutting on a board without the fallback clamp: feed hold requested, then ACC_REQUEST cleared with the hold kept"
            ),
            (Ok(()), _) => tracing::info!("ACC_REQUEST cleared; the operator has the override"),
            (Err(k), _) => {
                tracing::error!(kind = ?k, "could not write CONTROL; the board watchdog will release")
            }
        }
        drop(io_span);
        // The board has been told; now every record still waiting goes to the logger,
        // waiting on it as long as it takes.
        let log = log.finish();
        let (log_errors, log_error) = logger.join().map_err(|_| RunError::Panicked("acc-log"))?;
        Ok(RunSummary {
            periods,
            ended,
            skipped,
            ticker: ticker.stats().clone(),
            cycle_rtt: rtt,
            logged: log.handed,
            log_dropped: log.dropped,
            log_backlog_max: log.most_behind,
            log_stalled_periods: log.stalled_periods,
            log_errors,
            log_error,
            final_state,
            alarms,
            shutdown_ok,
            last_status,
            protocol,
            shutdown_feed_hold,
            reconnects,
            longest_device_loss,
        })
    })
}
