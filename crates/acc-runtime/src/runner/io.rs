//! The I/O thread: it owns the [`Board`] and the [`Ticker`]. At every deadline it reads the
//! status, hands it to the control thread, waits for the period's writes (bounded by one
//! period), performs them and reports their outcome with the next status; before each
//! period it decides whether the run ends (observer, `max_periods`, device lost, stop).

use std::sync::atomic::Ordering;
use std::time::Duration;

use acc_pmc::{Board, BoardError, BoardErrorKind, BoardStatus};
use crossbeam_channel::{Receiver, RecvTimeoutError, Sender};

use crate::clock::Clock;
use crate::control_loop::{BoardWrites, WriteResult};
use crate::stats::LatencyStats;
use crate::ticker::{Tick, Ticker};

use super::{execute_writes, Ended, Flags, OnDeviceLost, Reopen, RunOptions, StopRequest};

/// One period's status, from the I/O thread to the control thread.
pub(super) struct StatusMsg {
    /// The period's index among the cycles that ran.
    pub seq: u64,
    /// The period's deadline, s since the run began (clock time).
    pub t_s: f64,
    /// Deadlines the ticker skipped before this one.
    pub skipped: u64,
    /// The status read, or the link error.
    pub link: Result<BoardStatus, BoardErrorKind>,
    /// What the previous period's writes did.
    pub writes: WriteResult,
    /// How late the ticker woke.
    pub lateness: Duration,
    /// The ticker overran this deadline.
    pub overrun: bool,
    /// The link was reopened before this read.
    pub reopened: bool,
}

/// What the I/O thread counts over a run (for the [`super::RunSummary`]).
#[derive(Debug)]
pub(super) struct IoCounts {
    /// Periods whose cycle ran (read, decide, write).
    pub periods: u64,
    /// Periods of the clock the ticker skipped (they count toward `max_periods`).
    pub skipped_periods: u64,
    /// Round-trip time of a cycle: read, decision, writes.
    pub rtt: LatencyStats,
    /// The last status read.
    pub last_status: Option<BoardStatus>,
    /// Times the link was reopened.
    pub reconnects: u64,
    /// Longest time without the device (clock time).
    pub longest_device_loss: Duration,
}

/// The I/O thread of one run.
pub(super) struct IoLoop<'a, 'r, P, C: Clock> {
    pmc: &'a mut P,
    ticker: &'a mut Ticker<C>,
    clock: C,
    opts: RunOptions,
    reopen: Option<Reopen<'r, P>>,
    /// Clock time the run began.
    origin: Duration,
    /// What the last period's writes did (reported with the next status).
    writes: WriteResult,
    /// Consecutive reads that found the device gone.
    gone: u32,
    /// When the device was first found gone (clock time).
    gone_since: Option<Duration>,
    /// When a stop request's drain began (clock time).
    drain_since: Option<Duration>,
    counts: IoCounts,
}

impl<'a, 'r, P: Board, C: Clock> IoLoop<'a, 'r, P, C> {
    /// The I/O side of a run on `pmc`, paced by `ticker`; the run begins now.
    pub(super) fn new(
        pmc: &'a mut P,
        ticker: &'a mut Ticker<C>,
        clock: C,
        opts: RunOptions,
        reopen: Option<Reopen<'r, P>>,
    ) -> Self {
        let origin = clock.now();
        Self {
            pmc,
            ticker,
            clock,
            opts,
            reopen,
            origin,
            writes: WriteResult::default(),
            gone: 0,
            gone_since: None,
            drain_since: None,
            counts: IoCounts {
                periods: 0,
                skipped_periods: 0,
                rtt: LatencyStats::new(),
                last_status: None,
                reconnects: 0,
                longest_device_loss: Duration::ZERO,
            },
        }
    }

    /// What the thread counted.
    pub(super) fn counts(self) -> IoCounts {
        self.counts
    }

    /// The thread's periods until the run ends; returns how it ended.
    pub(super) fn run<Q: StopRequest + ?Sized>(
        &mut self,
        stop: &Q,
        flags: &Flags,
        statuses: &Sender<StatusMsg>,
        writes: &Receiver<(u64, BoardWrites)>,
    ) -> Ended {
        let control_stopped = Ended::FeedHold {
            reason: "control_stopped",
        };
        loop {
            if let Some(ended) = self.end_of_run(stop, flags) {
                return ended;
            }
            let tick = self.wait_for_deadline();
            let t0 = self.clock.now();
            let reopened = self.reopen_if_gone();
            let link = self.read_status(t0);
            if statuses
                .send(self.status_msg(&tick, link, reopened))
                .is_err()
            {
                return control_stopped;
            }
            let Some(w) = self.await_writes(writes, t0) else {
                return control_stopped;
            };
            self.writes = execute_writes(self.pmc, &w);
            self.counts.rtt.record(self.clock.now().saturating_sub(t0));
            self.counts.periods += 1;
        }
    }

    /// Before a period: does the run end here? In this order: the observer finished it,
    /// `max_periods` is reached, the device is lost, a stop is requested (and its drain is
    /// over).
    fn end_of_run<Q: StopRequest + ?Sized>(&mut self, stop: &Q, flags: &Flags) -> Option<Ended> {
        if flags.finished.load(Ordering::SeqCst) {
            return Some(Ended::Finished);
        }
        let c = &self.counts;
        if self
            .opts
            .max_periods
            .is_some_and(|m| c.periods + c.skipped_periods >= m)
        {
            return Some(Ended::Completed);
        }
        if self.device_lost() {
            return Some(Ended::DeviceLost);
        }
        if stop.stop_requested() {
            return self.end_of_drain(stop, flags);
        }
        None
    }

    /// The device has been gone too long: [`RunOptions::device_lost_periods`] reads in a
    /// row ([`OnDeviceLost::Exit`]) or the reconnect timeout (clock time). Also keeps the
    /// longest loss.
    fn device_lost(&mut self) -> bool {
        let lost_for = self.gone_since.map(|t| self.clock.now().saturating_sub(t));
        if let Some(d) = lost_for {
            self.counts.longest_device_loss = self.counts.longest_device_loss.max(d);
        }
        let gone = self.gone;
        let lost = match self.opts.on_device_lost {
            OnDeviceLost::Exit => self
                .opts
                .device_lost_periods
                .is_some_and(|n| gone >= n.max(1)),
            OnDeviceLost::Reconnect { timeout } => lost_for.is_some_and(|d| d >= timeout),
        };
        if lost {
            tracing::error!(
                periods = gone,
                secs = lost_for.unwrap_or_default().as_secs_f64(),
                "the board's device is gone: ending the run"
            );
        }
        lost
    }

    /// A stop is requested: without a drain it ends now; with one, once the cut has ended
    /// (the control thread's flag), on a second request, or when the drain times out.
    fn end_of_drain<Q: StopRequest + ?Sized>(&mut self, stop: &Q, flags: &Flags) -> Option<Ended> {
        let Some(drain) = self.opts.drain else {
            return Some(Ended::Released);
        };
        let now = self.clock.now();
        let since = *self.drain_since.get_or_insert_with(|| {
            tracing::warn!(
                max_s = drain.max.as_secs_f64(),
                "stop requested: ACC keeps control until the cut ends"
            );
            now
        });
        if flags.out_of_cut.load(Ordering::SeqCst) {
            return Some(Ended::Released);
        }
        if stop.stop_now() {
            return Some(Ended::FeedHold {
                reason: "second_signal",
            });
        }
        if now.saturating_sub(since) >= drain.max {
            return Some(Ended::FeedHold {
                reason: "drain_timeout",
            });
        }
        None
    }

    /// Sleep to the next deadline (absolute); an overrun is traced.
    fn wait_for_deadline(&mut self) -> Tick {
        let tick = self.ticker.wait();
        if tick.overrun {
            tracing::warn!(
                period = tick.index,
                late_us = tick.lateness.as_micros() as u64,
                skipped = tick.skipped,
                "period overrun"
            );
        }
        tick
    }

    /// The device is gone and the run reconnects: try to reopen it (once per period,
    /// before the read). Whether a fresh link replaced the board.
    fn reopen_if_gone(&mut self) -> bool {
        if self.gone == 0 || !matches!(self.opts.on_device_lost, OnDeviceLost::Reconnect { .. }) {
            return false;
        }
        let Some(f) = self.reopen.as_mut() else {
            return false;
        };
        match f() {
            Ok(fresh) => {
                *self.pmc = fresh;
                self.counts.reconnects += 1;
                tracing::warn!(after_periods = self.gone, "board link reopened");
                true
            }
            Err(e) => {
                tracing::debug!(error = %e, "reopening the board link failed");
                false
            }
        }
    }

    /// Read the board's status at `t0`; count the reads that find the device gone.
    fn read_status(&mut self, t0: Duration) -> Result<BoardStatus, BoardErrorKind> {
        let link = self.pmc.read_status().map_err(|e| e.kind());
        if let Ok(s) = link {
            self.counts.last_status = Some(s);
        }
        self.gone = match link {
            Err(BoardErrorKind::Disconnected) => self.gone.saturating_add(1),
            _ => 0,
        };
        if self.gone == 1 {
            self.gone_since = Some(t0);
        } else if self.gone == 0 {
            self.gone_since = None;
        }
        link
    }

    /// The status message of this period (the first period reports no skipped deadlines).
    fn status_msg(
        &mut self,
        tick: &Tick,
        link: Result<BoardStatus, BoardErrorKind>,
        reopened: bool,
    ) -> StatusMsg {
        let skipped = if self.counts.periods == 0 {
            0
        } else {
            tick.skipped
        };
        self.counts.skipped_periods += skipped;
        StatusMsg {
            seq: self.counts.periods,
            t_s: (tick.deadline.saturating_sub(self.origin)).as_secs_f64(),
            skipped,
            link,
            writes: self.writes,
            lateness: tick.lateness,
            overrun: tick.overrun,
            reopened,
        }
    }

    /// This period's writes from the control thread, awaited until one period after `t0`
    /// (none then: write nothing); a late answer of an earlier period is discarded.
    /// `None`: the control thread has stopped.
    fn await_writes(
        &self,
        writes: &Receiver<(u64, BoardWrites)>,
        t0: Duration,
    ) -> Option<BoardWrites> {
        let deadline = t0 + self.opts.period;
        loop {
            let left = deadline.saturating_sub(self.clock.now());
            // On a stepped clock a wait costs no clock time: the writes are awaited as long
            // as the period has clock time left (a read that used the whole period still
            // misses them, as on the wall clock).
            let got = if self.clock.is_stepped() && !left.is_zero() {
                writes.recv().map_err(|_| RecvTimeoutError::Disconnected)
            } else {
                writes.recv_timeout(left)
            };
            match got {
                Ok((i, w)) if i == self.counts.periods => return Some(w),
                Ok(_) => continue,
                Err(RecvTimeoutError::Timeout) => {
                    tracing::error!(
                        period = self.counts.periods,
                        "control thread missed its period"
                    );
                    return Some(BoardWrites::default());
                }
                Err(RecvTimeoutError::Disconnected) => return None,
            }
        }
    }
}
