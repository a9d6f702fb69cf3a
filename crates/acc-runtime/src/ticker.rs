//! A fixed-period ticker on absolute deadlines.
//!
//! Deadline `k` is `start + k·T` (`next += period`, never "work, then sleep T", which drifts
//! by the work time every period). A call to [`Ticker::wait`] that arrives after its deadline
//! is an **overrun** (the previous period's work did not fit in T); it runs at once without
//! sleeping. If it arrives more than a whole period late, the missed deadlines are
//! **skipped** (counted, not burst-replayed), so the grid stays aligned to `start + k·T`.
//! The lateness of every wake-up against its deadline is the period **jitter**, kept in a
//! [`LatencyStats`] histogram.

use std::time::Duration;

use crate::clock::Clock;
use crate::stats::LatencyStats;

/// Errors building a ticker.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TickerError {
    /// The period must be positive.
    #[error("ticker period must be > 0 (got {0:?})")]
    ZeroPeriod(Duration),
}

/// One tick of the ticker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tick {
    /// Period index, 0 for the first deadline; skipped deadlines advance it too.
    pub index: u64,
    /// Absolute deadline of this tick (since the clock's origin).
    pub deadline: Duration,
    /// When the ticker returned (since the clock's origin).
    pub woke: Duration,
    /// `woke − deadline`: the jitter of this tick.
    pub lateness: Duration,
    /// The call arrived after the deadline (previous period's work overran).
    pub overrun: bool,
    /// Whole deadlines skipped before this one because the call was > T late.
    pub skipped: u64,
}

/// Counters and jitter statistics of a ticker.
#[derive(Debug, Clone, Default)]
pub struct TickerStats {
    /// Ticks returned.
    pub ticks: u64,
    /// Calls that arrived after their deadline.
    pub overruns: u64,
    /// Deadlines skipped in total.
    pub skipped: u64,
    /// Lateness of each tick against its deadline.
    pub jitter: LatencyStats,
}

/// The fixed-period ticker.
///
/// ```
/// use acc_runtime::clock::{Clock, ManualClock};
/// use acc_runtime::ticker::Ticker;
/// use std::time::Duration;
/// let clock = ManualClock::new();
/// let mut t = Ticker::new(clock.clone(), Duration::from_millis(100)).unwrap();
/// let a = t.wait();
/// clock.advance(Duration::from_millis(30)); // work inside the period
/// let b = t.wait();
/// assert_eq!(a.deadline, Duration::from_millis(100));
/// assert_eq!(b.deadline, Duration::from_millis(200)); // absolute, no drift by the 30 ms
/// assert_eq!(t.stats().overruns, 0);
/// ```
#[derive(Debug)]
pub struct Ticker<C: Clock> {
    clock: C,
    period: Duration,
    next: Duration,
    index: u64,
    stats: TickerStats,
}

impl<C: Clock> Ticker<C> {
    /// A ticker whose first deadline is one period from now.
    pub fn new(clock: C, period: Duration) -> Result<Self, TickerError> {
        if period.is_zero() {
            return Err(TickerError::ZeroPeriod(period));
        }
        let next = clock.now() + period;
        Ok(Self {
            clock,
            period,
            next,
            index: 0,
            stats: TickerStats::default(),
        })
    }

    /// The period T.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// The clock the ticker runs on.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// The next deadline (absolute).
    pub fn next_deadline(&self) -> Duration {
        self.next
    }

    /// Counters and jitter so far.
    pub fn stats(&self) -> &TickerStats {
        &self.stats
    }

    /// Block until the next deadline and return the tick.
    pub fn wait(&mut self) -> Tick {
        let now = self.clock.now();
        let mut overrun = false;
        let mut skipped = 0;
        if now > self.next {
            overrun = true;
            let late = now - self.next;
            let whole = late.as_nanos() / self.period.as_nanos();
            if whole > 0 {
                skipped = u64::try_from(whole).unwrap_or(u64::MAX);
                let jump = self
                    .period
                    .checked_mul(u32::try_from(whole).unwrap_or(u32::MAX))
                    .unwrap_or(Duration::MAX);
                self.next = self.next.saturating_add(jump);
                self.index = self.index.saturating_add(skipped);
            }
        } else {
            self.clock.sleep_until(self.next);
        }
        let woke = self.clock.now();
        let deadline = self.next;
        let lateness = woke.saturating_sub(deadline);
        let tick = Tick {
            index: self.index,
            deadline,
            woke,
            lateness,
            overrun,
            skipped,
        };
        self.stats.ticks += 1;
        self.stats.overruns += u64::from(overrun);
        self.stats.skipped += skipped;
        self.stats.jitter.record(lateness);
        self.next = self.next.saturating_add(self.period);
        self.index += 1;
        tick
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::ManualClock;

    const T: Duration = Duration::from_millis(100);

    #[test]
    fn zero_period_is_refused() {
        assert!(Ticker::new(ManualClock::new(), Duration::ZERO).is_err());
    }

    #[test]
    fn deadlines_are_absolute_and_do_not_drift() {
        let clock = ManualClock::new();
        let mut t = Ticker::new(clock.clone(), T).expect("period > 0");
        for k in 1..=1000u32 {
            // variable work inside the period, always shorter than T
            clock.advance(Duration::from_micros(u64::from(k % 7) * 9_000));
            let tick = t.wait();
            assert_eq!(tick.deadline, T * k);
            assert_eq!(tick.woke, T * k);
            assert!(!tick.overrun);
        }
        assert_eq!(clock.now(), T * 1000);
        assert_eq!(t.stats().overruns, 0);
        assert_eq!(t.stats().jitter.max(), Duration::ZERO);
    }

    #[test]
    fn overrun_runs_at_once_and_keeps_the_grid() {
        let clock = ManualClock::new();
        let mut t = Ticker::new(clock.clone(), T).expect("period > 0");
        t.wait(); // t = 100 ms
        clock.advance(Duration::from_millis(130)); // work overruns to 230 ms
        let late = t.wait();
        assert!(late.overrun);
        assert_eq!(late.deadline, Duration::from_millis(200));
        assert_eq!(late.lateness, Duration::from_millis(30));
        assert_eq!(late.skipped, 0);
        let next = t.wait();
        assert!(!next.overrun);
        assert_eq!(next.woke, Duration::from_millis(300));
        assert_eq!(t.stats().overruns, 1);
        assert_eq!(t.stats().jitter.max(), Duration::from_millis(30));
    }

    #[test]
    fn long_overrun_skips_missed_deadlines() {
        let clock = ManualClock::new();
        let mut t = Ticker::new(clock.clone(), T).expect("period > 0");
        t.wait(); // index 0 at 100 ms
        clock.advance(Duration::from_millis(350)); // now 450 ms: deadlines 200, 300, 400 passed
        let tick = t.wait();
        assert!(tick.overrun);
        assert_eq!(tick.skipped, 2);
        assert_eq!(tick.index, 3);
        assert_eq!(tick.deadline, Duration::from_millis(400));
        assert_eq!(tick.lateness, Duration::from_millis(50));
        let next = t.wait();
        assert_eq!(next.index, 4);
        assert_eq!(next.deadline, Duration::from_millis(500));
        assert_eq!(t.stats().skipped, 2);
        assert_eq!(t.stats().overruns, 1);
    }

    proptest::proptest! {
        /// For any sequence of work durations: every deadline lies on the grid start + k·T,
        /// the index counts skipped deadlines, an overrun is counted exactly when the work
        /// ran past the deadline, and the clock never waits past the deadline it asked for.
        #[test]
        fn grid_and_overruns_for_any_work(work_us in proptest::collection::vec(0u64..350_000, 1..200)) {
            let clock = ManualClock::new();
            let mut t = Ticker::new(clock.clone(), T).expect("period > 0");
            let mut overruns = 0;
            let mut last_index = None;
            for w in work_us {
                let next = t.next_deadline();
                clock.advance(Duration::from_micros(w));
                let late = clock.now() > next;
                let tick = t.wait();
                overruns += u64::from(late);
                proptest::prop_assert_eq!(tick.overrun, late);
                proptest::prop_assert_eq!(tick.deadline, T * u32::try_from(tick.index + 1).expect("small"));
                proptest::prop_assert!(tick.woke >= tick.deadline);
                proptest::prop_assert!(tick.lateness < T, "a tick is never a whole period late");
                if let Some(i) = last_index {
                    proptest::prop_assert_eq!(tick.index, i + 1 + tick.skipped);
                }
                last_index = Some(tick.index);
            }
            proptest::prop_assert_eq!(t.stats().overruns, overruns);
        }
    }

    #[test]
    fn jitter_statistics_from_late_wakeups() {
        // A clock that wakes a scripted amount after each deadline.
        #[derive(Clone, Debug)]
        struct Late {
            inner: ManualClock,
            lateness_us: std::sync::Arc<std::sync::Mutex<Vec<u64>>>,
        }
        impl Clock for Late {
            fn now(&self) -> Duration {
                self.inner.now()
            }
            fn sleep_until(&self, deadline: Duration) {
                let extra = self
                    .lateness_us
                    .lock()
                    .map(|mut v| v.pop().unwrap_or(0))
                    .unwrap_or(0);
                self.inner.set(deadline + Duration::from_micros(extra));
            }
        }
        // 100 ticks: 98 wake 10 µs late, one 500 µs, one 2000 µs
        let mut script: Vec<u64> = vec![10; 98];
        script.push(500);
        script.push(2000);
        let clock = Late {
            inner: ManualClock::new(),
            lateness_us: std::sync::Arc::new(std::sync::Mutex::new(script)),
        };
        let mut t = Ticker::new(clock, T).expect("period > 0");
        for _ in 0..100 {
            t.wait();
        }
        let j = &t.stats().jitter;
        assert_eq!(j.count(), 100);
        assert_eq!(j.quantile(0.5), Duration::from_micros(10));
        assert_eq!(j.quantile(0.99), Duration::from_micros(500));
        assert_eq!(j.max(), Duration::from_micros(2000));
        assert_eq!(t.stats().overruns, 0);
    }
}
