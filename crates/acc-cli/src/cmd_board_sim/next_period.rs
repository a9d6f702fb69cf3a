//! What moves the machine to its next period (`--pace`): its own ticker every
//! `T / time_scale` of wall time, or the controller's next command write.

use std::sync::Arc;
use std::time::Duration;

use acc_pmc::emu::{lock_board, SharedBoard};
use acc_runtime::{Clock, SystemClock, Tick, Ticker, TickerStats};

use super::line::CommandPace;

/// The answer of [`NextPeriod::wait`].
pub(super) enum Next {
    /// Advance the machine one period.
    Period(Tick),
    /// No period yet (no command, or a repeated write); ask again.
    NotYet,
    /// A finished workpiece and a controller gone quiet for the linger time: end.
    Done,
}

/// The source of machine periods.
pub(super) struct NextPeriod {
    wall: SystemClock,
    period: Duration,
    ticker: Ticker<SystemClock>,
    pace: Option<Arc<CommandPace>>,
    /// `--pace controller`: the heartbeat of the command the last period was taken for.
    last_heartbeat: Option<u16>,
    last_command: Duration,
    /// `--pace controller`: the machine runs on its own ticker again once the controller
    /// has released (ACC_REQUEST cleared after a run), as a real machine runs on when ACC
    /// lets go.
    on_own_ticker: bool,
}

impl NextPeriod {
    /// Periods of `period` (wall time), paced by `pace`'s command writes when given.
    pub(super) fn new(period: Duration, pace: Option<Arc<CommandPace>>) -> anyhow::Result<Self> {
        let wall = SystemClock::new();
        Ok(NextPeriod {
            wall,
            period,
            ticker: Ticker::new(wall, period)?,
            last_heartbeat: None,
            last_command: wall.now(),
            on_own_ticker: pace.is_none(),
            pace,
        })
    }

    /// Wait for the next period: machine period `index` on the controller's pace. With
    /// `quiet_end` (a finished workpiece under `--exit-when-done`), a controller silent for
    /// that long ends the run.
    pub(super) fn wait(
        &mut self,
        board: &SharedBoard,
        index: u64,
        quiet_end: Option<Duration>,
    ) -> anyhow::Result<Next> {
        let Some(pace) = self.pace.clone() else {
            return Ok(Next::Period(self.ticker.wait()));
        };
        if !lock_board(board).control().acc_request {
            if !self.on_own_ticker {
                self.ticker = Ticker::new(self.wall, self.period)?;
                self.on_own_ticker = true;
            }
            // Writes while released move nothing (as before the request).
            pace.take_all();
            return Ok(Next::Period(self.ticker.wait()));
        }
        self.on_own_ticker = false;
        if !pace.next_command(Duration::from_millis(50)) {
            let quiet = self.wall.now().saturating_sub(self.last_command);
            return Ok(match quiet_end {
                Some(end) if quiet >= end => Next::Done,
                _ => Next::NotYet,
            });
        }
        self.last_command = self.wall.now();
        let heartbeat = lock_board(board).heartbeat();
        if self.last_heartbeat == Some(heartbeat) {
            // A repeated write (a retry after a lost reply): no new period.
            pace.take_all();
            return Ok(Next::NotYet);
        }
        self.last_heartbeat = Some(heartbeat);
        let now = self.wall.now();
        Ok(Next::Period(Tick {
            index,
            deadline: now,
            woke: now,
            lateness: Duration::ZERO,
            overrun: false,
            skipped: 0,
        }))
    }

    /// The period is taken: the writes that drove it are answered.
    pub(super) fn period_taken(&self) {
        if let Some(pace) = &self.pace {
            pace.take_all();
        }
    }

    /// No more periods: a writer still waiting is released.
    pub(super) fn close(&self) {
        if let Some(pace) = &self.pace {
            pace.close();
        }
    }

    /// The ticker's counters (of the current ticker: a controller-paced run restarts it).
    pub(super) fn stats(&self) -> &TickerStats {
        self.ticker.stats()
    }
}
