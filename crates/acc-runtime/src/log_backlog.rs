//! The control thread's side of the run log: hand every record to the logger thread without
//! ever waiting on it, and without losing one.
//!
//! The logger's queue is short ([`LOG_QUEUE`]); a record it cannot take yet waits here, in
//! order, and goes first at the next [`Backlog::pump`]. When the logger is more than the
//! run's `log_buffer` records behind, the writer counts as stalled ([`Backlog::stalled`]):
//! the runner tells the loop, which holds the feed (see [`crate::runner`]). Records keep
//! being kept while stalled, up to [`MAX_BACKLOG`] (more than a day at T = 0.1 s; only
//! beyond it is the oldest one dropped and counted). [`Backlog::finish`] hands the rest to
//! the logger, waiting on it.

use std::collections::VecDeque;

use crossbeam_channel::{Sender, TrySendError};

use crate::record::RunRecord;

/// Capacity of the channel to the logger thread, records.
pub(crate) const LOG_QUEUE: usize = 256;

/// Most records the backlog keeps (about 29 h at T = 0.1 s); beyond, the oldest is dropped
/// and counted.
pub(crate) const MAX_BACKLOG: usize = 1 << 20;

/// Records on their way to the logger thread.
pub(crate) struct Backlog {
    tx: Sender<RunRecord>,
    waiting: VecDeque<RunRecord>,
    /// Records the backlog may hold before the writer counts as stalled.
    limit: usize,
    tally: LogTally,
}

/// What happened to the records of a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct LogTally {
    /// Records handed to the logger thread.
    pub handed: u64,
    /// Records lost: the logger thread had died, or the backlog was beyond [`MAX_BACKLOG`].
    pub dropped: u64,
    /// Most records the logger was behind at once (queue and backlog).
    pub most_behind: u64,
    /// Periods in which the writer counted as stalled.
    pub stalled_periods: u64,
}

impl Backlog {
    /// A backlog feeding `tx` that counts the writer as stalled when more than `limit`
    /// records wait here (the queue being full).
    pub(crate) fn new(tx: Sender<RunRecord>, limit: usize) -> Self {
        Self {
            tx,
            waiting: VecDeque::new(),
            limit,
            tally: LogTally::default(),
        }
    }

    /// Move waiting records into the logger's queue as far as it takes them; once per
    /// period (it counts the stalled periods).
    pub(crate) fn pump(&mut self) {
        self.drain();
        if self.stalled() {
            self.tally.stalled_periods += 1;
        }
    }

    /// The logger is more than the run's buffer behind.
    pub(crate) fn stalled(&self) -> bool {
        self.waiting.len() > self.limit
    }

    /// Queue `rec` behind the waiting ones and hand on what the logger takes.
    pub(crate) fn offer(&mut self, rec: RunRecord) {
        if self.waiting.len() >= MAX_BACKLOG {
            self.waiting.pop_front();
            self.tally.dropped += 1;
        }
        self.waiting.push_back(rec);
        self.drain();
        let behind = (self.waiting.len() + self.tx.len()) as u64;
        self.tally.most_behind = self.tally.most_behind.max(behind);
    }

    fn drain(&mut self) {
        while let Some(rec) = self.waiting.pop_front() {
            match self.tx.try_send(rec) {
                Ok(()) => self.tally.handed += 1,
                Err(TrySendError::Full(rec)) => {
                    self.waiting.push_front(rec);
                    return;
                }
                Err(TrySendError::Disconnected(_)) => self.tally.dropped += 1,
            }
        }
    }

    /// Hand every waiting record to the logger, waiting on it as long as it takes, and
    /// close the queue (the logger then flushes and ends).
    pub(crate) fn finish(mut self) -> LogTally {
        for rec in std::mem::take(&mut self.waiting) {
            match self.tx.send(rec) {
                Ok(()) => self.tally.handed += 1,
                Err(_) => self.tally.dropped += 1,
            }
        }
        self.tally
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crossbeam_channel::bounded;

    fn rec(i: u64) -> RunRecord {
        RunRecord {
            period: i,
            ..RunRecord::default()
        }
    }

    #[test]
    fn a_full_queue_keeps_records_in_order_and_reports_the_stall() {
        let (tx, rx) = bounded(2);
        let mut b = Backlog::new(tx, 3);
        for i in 0..5 {
            b.offer(rec(i));
            b.pump();
        }
        assert!(!b.stalled(), "2 in the queue, 3 waiting: at the limit");
        b.offer(rec(5));
        b.pump();
        assert!(b.stalled());
        // The writer catches up: the order is kept and the stall ends.
        let first: Vec<u64> = rx.try_iter().map(|r| r.period).collect();
        assert_eq!(first, vec![0, 1]);
        b.pump();
        assert!(!b.stalled());
        let rx2 = rx.clone();
        let reader = std::thread::spawn(move || rx2.iter().map(|r| r.period).collect::<Vec<_>>());
        let tally = b.finish();
        let rest = reader.join().expect("reader");
        assert_eq!(rest, vec![2, 3, 4, 5]);
        assert_eq!(tally.handed, 6);
        assert_eq!(tally.dropped, 0);
        assert_eq!(tally.stalled_periods, 1);
        assert_eq!(tally.most_behind, 6);
    }

    #[test]
    fn a_dead_logger_is_counted_as_lost_records() {
        let (tx, rx) = bounded(1);
        drop(rx);
        let mut b = Backlog::new(tx, 10);
        b.offer(rec(0));
        b.offer(rec(1));
        assert_eq!(b.finish().dropped, 2);
    }
}
