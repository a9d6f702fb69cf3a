//! How far the tool can have gone since a block began: the bound the look-ahead
//! ([`crate::lookahead`]) sets its position by when the loop reports a new block.
//!
//! The board reports `BLOCK_NUMBER` as the NC has it at the read, but the line guard
//! ([`crate::guard`]) reports a changed number only once `debounce_reads` consecutive reads
//! agree; a read it holds whole, a failed read and a read that shows yet another number (a
//! bad frame) delay that further. The block began after the last read whose raw number
//! was still the old block's, so the look-ahead counts the periods since then. Over each
//! of them the tool moved at most at the top speed of the rows it can have crossed × the
//! highest override that may have been in force in the period (the override applied at the
//! reads on both sides of it and the commands written that may have acted; the grid's
//! maximum where that is not known), or at the register's own reading where that is
//! higher. The sum is the farthest the tool can be past the block's start. A period the
//! line ran late may have lasted longer than the control period: there is no bound over
//! it.
//!
//! Kept for the last [`RECENT_PERIODS`] periods, without allocation on the control path.

/// Periods remembered (1.6 s at T = 0.1 s: the guard's largest `debounce_reads`, 10, with
/// room for the reads that delay a confirmation).
pub const RECENT_PERIODS: usize = 16;

/// One period as the bound needs it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Period {
    /// The highest override that may have been in force, percent (`None`: not known).
    top_pct: Option<u16>,
    /// The feed the register read at the period's end, mm/min (0 when not read).
    feed_read_mm_min: f64,
    /// The period ran on a line as designed (not late: its length was the control period).
    nominal: bool,
}

/// The last [`RECENT_PERIODS`] periods.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecentPeriods {
    ring: [Period; RECENT_PERIODS],
    /// Periods recorded, at most [`RECENT_PERIODS`].
    len: usize,
    /// Where the next period goes.
    next: usize,
}

impl RecentPeriods {
    /// Record the period that ended: the highest override that may have been in force in
    /// it (%, `None`: not known), the feed the register read at its end (mm/min; 0 when
    /// not read) and whether the line ran as designed.
    pub fn push(&mut self, top_pct: Option<u16>, feed_read_mm_min: f64, nominal: bool) {
        self.ring[self.next] = Period {
            top_pct,
            feed_read_mm_min: if feed_read_mm_min.is_finite() {
                feed_read_mm_min.max(0.0)
            } else {
                0.0
            },
            nominal,
        };
        self.next = (self.next + 1) % RECENT_PERIODS;
        self.len = (self.len + 1).min(RECENT_PERIODS);
    }

    /// The `j`-th newest period (0: the one that just ended).
    fn newest(&self, j: usize) -> Period {
        self.ring[(self.next + RECENT_PERIODS - 1 - j) % RECENT_PERIODS]
    }

    /// The farthest the tool can have moved over the last `n` periods, mm: each at most at
    /// `speed_mm_min(top_pct)` (mm/min, the rows' top speed at the period's highest
    /// override, `None`: not known) or the register's reading, whichever is higher, for
    /// the control period `period_s` (s). `None` when fewer than `n` periods are
    /// remembered or one of them ran late.
    pub fn reach_mm(
        &self,
        n: usize,
        speed_mm_min: impl Fn(Option<u16>) -> f64,
        period_s: f64,
    ) -> Option<f64> {
        if n > self.len {
            return None;
        }
        (0..n)
            .map(|j| self.newest(j))
            .map(|p| {
                p.nominal
                    .then(|| speed_mm_min(p.top_pct).max(p.feed_read_mm_min) * period_s / 60.0)
            })
            .sum()
    }

    /// The path the register read over the last `n` periods (as many as are remembered),
    /// mm, for the control period `period_s` (s).
    pub fn read_path_mm(&self, n: usize, period_s: f64) -> f64 {
        (0..n.min(self.len))
            .map(|j| self.newest(j).feed_read_mm_min * period_s / 60.0)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(periods: &[(Option<u16>, f64, bool)]) -> RecentPeriods {
        let mut r = RecentPeriods::default();
        for &(top, feed, nominal) in periods {
            r.push(top, feed, nominal);
        }
        r
    }

    /// 600 mm/min × the override, the grid's maximum 150 % where it is not known.
    fn speed(pct: Option<u16>) -> f64 {
        600.0 * f64::from(pct.unwrap_or(150)) / 100.0
    }

    #[test]
    fn the_reach_sums_each_periods_top_speed() {
        // At up to 40 %: 0.4 mm per period of 0.1 s.
        let r = filled(&[(Some(40), 240.0, true); 4]);
        let reach = |r: &RecentPeriods, n| r.reach_mm(n, speed, 0.1);
        assert!((reach(&r, 2).expect("reach") - 0.8).abs() < 1e-12);
        assert!((reach(&r, 4).expect("reach") - 1.6).abs() < 1e-12);
        // An override not known: the grid's maximum over that period (1.5 mm).
        let r = filled(&[
            (Some(40), 240.0, true),
            (None, 0.0, true),
            (Some(40), 240.0, true),
        ]);
        assert!((reach(&r, 3).expect("reach") - (0.4 + 1.5 + 0.4)).abs() < 1e-12);
        // Not remembered far enough back, or a late period among them: no bound.
        assert_eq!(reach(&r, 4), None);
        let r = filled(&[(Some(40), 240.0, false), (Some(40), 240.0, true)]);
        assert!(reach(&r, 1).is_some());
        assert_eq!(reach(&r, 2), None);
        // A register reading above the override's feed counts.
        let r = filled(&[(Some(10), 600.0, true); 2]);
        assert!((reach(&r, 2).expect("reach") - 2.0).abs() < 1e-12);
        assert!((r.read_path_mm(5, 0.1) - 2.0).abs() < 1e-12);
    }
}
