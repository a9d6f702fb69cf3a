//! Latency statistics without allocation on the record path: a fixed 1 µs-bucket
//! histogram (0 … 50 ms) with an exact maximum, for tick lateness (jitter) and link
//! round-trip times.

use std::time::Duration;

/// Histogram range covered by 1 µs buckets, µs. Samples above land in an overflow count
/// (their exact maximum is still kept).
pub const HISTOGRAM_RANGE_US: usize = 50_000;

/// A latency histogram with 1 µs resolution.
///
/// ```
/// use acc_runtime::stats::LatencyStats;
/// use std::time::Duration;
/// let mut s = LatencyStats::new();
/// for us in 1..=100 {
///     s.record(Duration::from_micros(us));
/// }
/// assert_eq!(s.count(), 100);
/// assert_eq!(s.quantile(0.5), Duration::from_micros(50));
/// assert_eq!(s.quantile(0.99), Duration::from_micros(99));
/// assert_eq!(s.max(), Duration::from_micros(100));
/// ```
#[derive(Debug, Clone)]
pub struct LatencyStats {
    buckets: Vec<u32>,
    overflow: u64,
    count: u64,
    sum_ns: u128,
    max: Duration,
}

impl Default for LatencyStats {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyStats {
    /// An empty histogram (allocates its buckets once, here).
    pub fn new() -> Self {
        Self {
            buckets: vec![0; HISTOGRAM_RANGE_US + 1],
            overflow: 0,
            count: 0,
            sum_ns: 0,
            max: Duration::ZERO,
        }
    }

    /// Record one sample.
    pub fn record(&mut self, d: Duration) {
        let us = d.as_micros();
        match usize::try_from(us) {
            Ok(i) if i <= HISTOGRAM_RANGE_US => {
                if let Some(b) = self.buckets.get_mut(i) {
                    *b = b.saturating_add(1);
                }
            }
            _ => self.overflow += 1,
        }
        self.count += 1;
        self.sum_ns += d.as_nanos();
        if d > self.max {
            self.max = d;
        }
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Largest sample (exact).
    pub fn max(&self) -> Duration {
        self.max
    }

    /// Mean of the samples (zero when empty).
    pub fn mean(&self) -> Duration {
        if self.count == 0 {
            return Duration::ZERO;
        }
        let ns = self.sum_ns / u128::from(self.count);
        Duration::from_nanos(u64::try_from(ns).unwrap_or(u64::MAX))
    }

    /// The `q`-quantile (0 ≤ q ≤ 1), nearest-rank, to 1 µs (samples are truncated to whole
    /// µs); a quantile that falls in the overflow range reports the exact maximum.
    pub fn quantile(&self, q: f64) -> Duration {
        if self.count == 0 {
            return Duration::ZERO;
        }
        let q = if q.is_finite() {
            q.clamp(0.0, 1.0)
        } else {
            1.0
        };
        // nearest rank: the smallest value with at least ceil(q·n) samples at or below it
        let rank = ((q * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (us, &n) in self.buckets.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return Duration::from_micros(us as u64);
            }
        }
        self.max
    }

    /// One-line summary `n=… p50=… p99=… max=… mean=…` in µs.
    pub fn summary(&self) -> String {
        format!(
            "n={} p50={}us p99={}us max={}us mean={}us",
            self.count,
            self.quantile(0.5).as_micros(),
            self.quantile(0.99).as_micros(),
            self.max.as_micros(),
            self.mean().as_micros()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_is_zero() {
        let s = LatencyStats::new();
        assert_eq!(s.quantile(0.99), Duration::ZERO);
        assert_eq!(s.mean(), Duration::ZERO);
    }

    #[test]
    fn overflow_quantile_reports_max() {
        let mut s = LatencyStats::new();
        s.record(Duration::from_micros(10));
        s.record(Duration::from_secs(1));
        assert_eq!(s.quantile(0.5), Duration::from_micros(10));
        assert_eq!(s.quantile(1.0), Duration::from_secs(1));
        assert_eq!(s.max(), Duration::from_secs(1));
    }

    #[test]
    fn p99_of_skewed_distribution() {
        let mut s = LatencyStats::new();
        for _ in 0..990 {
            s.record(Duration::from_micros(20));
        }
        for _ in 0..10 {
            s.record(Duration::from_micros(900));
        }
        assert_eq!(s.quantile(0.5), Duration::from_micros(20));
        assert_eq!(s.quantile(0.99), Duration::from_micros(20));
        assert_eq!(s.quantile(0.995), Duration::from_micros(900));
    }
}
