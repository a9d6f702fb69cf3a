//! The telemetry tap: fan-out of the per-period [`RunRecord`] to any number of subscribers
//! (the SHDR adapter, the MQTT publisher, a live view) over bounded `crossbeam-channel`s.
//!
//! [`Tap::publish`] **never blocks**: each subscriber gets the record with `try_send`; a
//! subscriber whose queue is full loses that record and counts it
//! ([`Subscriber::dropped`]). A subscriber that went away is removed at the next publish.
//! The records are shared (`Arc`): one clone per published period, whatever the number of
//! subscribers.
//!
//! Where the records come from: [`TapSink`] wraps the run-log [`LogSink`] of `acc run` (the
//! logger thread publishes each record just before it writes it, so the control thread never
//! touches telemetry); `acc sim` and `acc board-sim` call [`Tap::publish`] after each period's
//! row.
//!
//! ```
//! use acc_runtime::tap::Tap;
//! use acc_runtime::RunRecord;
//! let tap = Tap::new();
//! let sub = tap.subscribe(2);
//! for p in 0..5 {
//!     tap.publish(&RunRecord { period: p, ..RunRecord::default() });
//! }
//! // The queue held 2; the other 3 were dropped and counted, the publisher never waited.
//! assert_eq!(sub.try_iter().map(|r| r.period).collect::<Vec<_>>(), vec![0, 1]);
//! assert_eq!(sub.dropped(), 3);
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender, TrySendError};

use crate::record::RunRecord;
use crate::runner::LogSink;

struct Outlet {
    tx: Sender<Arc<RunRecord>>,
    dropped: Arc<AtomicU64>,
}

#[derive(Default)]
struct Inner {
    outlets: Mutex<Vec<Outlet>>,
    published: AtomicU64,
    missed: AtomicU64,
}

/// The fan-out point. Cheap to clone (all clones publish to the same subscribers).
#[derive(Clone, Default)]
pub struct Tap {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for Tap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tap")
            .field("published", &self.published())
            .field("missed", &self.missed())
            .finish_non_exhaustive()
    }
}

/// One subscriber's end: a bounded queue of records and the count of records it lost
/// because the queue was full.
#[derive(Debug, Clone)]
pub struct Subscriber {
    rx: Receiver<Arc<RunRecord>>,
    dropped: Arc<AtomicU64>,
}

impl Tap {
    /// A tap with no subscribers (publishing is then a no-op).
    pub fn new() -> Self {
        Self::default()
    }

    /// A new subscriber with a queue of `capacity` records (at least 1).
    pub fn subscribe(&self, capacity: usize) -> Subscriber {
        let (tx, rx) = bounded(capacity.max(1));
        let dropped = Arc::new(AtomicU64::new(0));
        let outlet = Outlet {
            tx,
            dropped: dropped.clone(),
        };
        self.inner
            .outlets
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(outlet);
        Subscriber { rx, dropped }
    }

    /// Offer `rec` to every subscriber without waiting: a full queue drops the record for
    /// that subscriber (counted in its [`Subscriber::dropped`]); a subscriber that went
    /// away is removed. If a [`Tap::subscribe`] holds the list at this very instant, the
    /// record is not published at all (counted in [`Tap::missed`]) rather than waited for.
    pub fn publish(&self, rec: &RunRecord) {
        let Ok(mut outlets) = self.inner.outlets.try_lock() else {
            self.inner.missed.fetch_add(1, Ordering::Relaxed);
            return;
        };
        self.inner.published.fetch_add(1, Ordering::Relaxed);
        if outlets.is_empty() {
            return;
        }
        let shared = Arc::new(rec.clone());
        outlets.retain(|o| match o.tx.try_send(shared.clone()) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                o.dropped.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(TrySendError::Disconnected(_)) => false,
        });
    }

    /// Records offered to the subscribers so far.
    pub fn published(&self) -> u64 {
        self.inner.published.load(Ordering::Relaxed)
    }

    /// Records not published because a `subscribe` held the list (never waited on).
    pub fn missed(&self) -> u64 {
        self.inner.missed.load(Ordering::Relaxed)
    }

    /// Subscribers still connected (as of the last publish).
    pub fn subscribers(&self) -> usize {
        self.inner
            .outlets
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .len()
    }
}

impl Subscriber {
    /// Records this subscriber lost because its queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Wait for the next record at most `timeout`; `Err(Disconnected)` once every [`Tap`]
    /// clone is gone and the queue is empty.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Arc<RunRecord>, RecvTimeoutError> {
        self.rx.recv_timeout(timeout)
    }

    /// The records queued now, without waiting.
    pub fn try_iter(&self) -> impl Iterator<Item = Arc<RunRecord>> + '_ {
        self.rx.try_iter()
    }

    /// The underlying receiver (for `select!`).
    pub fn receiver(&self) -> &Receiver<Arc<RunRecord>> {
        &self.rx
    }
}

/// A [`LogSink`] that publishes every record on a [`Tap`] and then hands it to the inner
/// sink (the run log). Used by `acc run`: the runner's logger thread calls it, so the
/// control thread never waits on telemetry (and a slow subscriber only drops).
#[derive(Debug)]
pub struct TapSink<S> {
    /// The run-log sink.
    pub inner: S,
    /// Where the records are published.
    pub tap: Tap,
}

impl<S: LogSink> LogSink for TapSink<S> {
    type Error = S::Error;

    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.tap.publish(rec);
        self.inner.write(rec)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runner::VecSink;

    fn rec(p: u64) -> RunRecord {
        RunRecord {
            period: p,
            ..RunRecord::default()
        }
    }

    #[test]
    fn fans_out_to_every_subscriber_and_counts_drops_per_subscriber() {
        let tap = Tap::new();
        let fast = tap.subscribe(100);
        let slow = tap.subscribe(3);
        for p in 0..10 {
            tap.publish(&rec(p));
        }
        assert_eq!(fast.try_iter().count(), 10);
        assert_eq!(fast.dropped(), 0);
        let got: Vec<u64> = slow.try_iter().map(|r| r.period).collect();
        assert_eq!(got, vec![0, 1, 2]);
        assert_eq!(slow.dropped(), 7);
        assert_eq!(tap.published(), 10);
    }

    #[test]
    fn a_gone_subscriber_is_removed_and_publish_never_blocks() {
        let tap = Tap::new();
        let a = tap.subscribe(1);
        let b = tap.subscribe(1);
        drop(b);
        let t0 = std::time::Instant::now();
        for p in 0..100_000 {
            tap.publish(&rec(p));
        }
        // Nobody reads `a`: 100 000 publishes still return at once.
        assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
        assert_eq!(tap.subscribers(), 1);
        assert_eq!(a.dropped(), 99_999);
    }

    #[test]
    fn tap_sink_publishes_what_it_logs() {
        let tap = Tap::new();
        let sub = tap.subscribe(8);
        let mut sink = TapSink {
            inner: VecSink::default(),
            tap: tap.clone(),
        };
        for p in 0..4 {
            sink.write(&rec(p)).expect("vec sink");
        }
        assert_eq!(sink.inner.0.len(), 4);
        let got: Vec<u64> = sub.try_iter().map(|r| r.period).collect();
        assert_eq!(got, vec![0, 1, 2, 3]);
        drop((sink, tap));
        assert!(matches!(
            sub.recv_timeout(Duration::from_millis(10)),
            Err(RecvTimeoutError::Disconnected)
        ));
    }
}
