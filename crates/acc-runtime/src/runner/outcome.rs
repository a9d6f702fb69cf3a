//! How a run ended ([`Ended`]) and what it did ([`RunSummary`]), or why it could not run
//! ([`RunError`]).

use std::time::Duration;

use acc_pmc::{BoardErrorKind, BoardProtocol, BoardStatus};

use crate::log_backlog::LogTally;
use crate::policy::{AccState, Alarms};
use crate::stats::LatencyStats;
use crate::ticker::{TickerError, TickerStats};

use super::control::ControlTotals;
use super::io::IoCounts;
use super::logger::Written;
use super::shutdown::ShutdownOutcome;
#[cfg(doc)]
use super::{run, PeriodObserver, RunOptions};

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

impl RunSummary {
    /// The summary of a run that ended `ended`, from what each thread counted and the
    /// shutdown did.
    pub(super) fn of(
        ended: Ended,
        io: IoCounts,
        ctl: &ControlTotals,
        ticker: &TickerStats,
        log: LogTally,
        written: Written,
        shutdown: ShutdownOutcome,
    ) -> Self {
        Self {
            periods: io.periods,
            ended,
            skipped: ctl.skipped,
            ticker: ticker.clone(),
            cycle_rtt: io.rtt,
            logged: log.handed,
            log_dropped: log.dropped,
            log_backlog_max: log.most_behind,
            log_stalled_periods: log.stalled_periods,
            log_errors: written.errors,
            log_error: written.first_error,
            final_state: ctl.final_state,
            alarms: ctl.alarms,
            shutdown_ok: shutdown.ok,
            last_status: io.last_status,
            protocol: shutdown.protocol,
            shutdown_feed_hold: shutdown.feed_hold,
            reconnects: io.reconnects,
            longest_device_loss: io.longest_device_loss,
        }
    }
}
