//! How far the tool can have gone since a block began: the bound the look-ahead
//! ([`crate::lookahead`]) sets its position by when the board reports a new block.
//!
//! The board reports `BLOCK_NUMBER` as the NC has it at the read, but the line guard holds
//! a changed block number until `debounce_reads` consecutive reads agree
//! ([`crate::guard`]), and a read it holds whole (a suspect value), a failed read or a
//! period the line ran late delays that further. So when the loop sees a new block, the
//! block began within the last `debounce_reads` periods, one more for each of the recent
//! periods that was not a fresh read on a line as designed. Over each such period the tool
//! moved at most at the block's programmed feed × the highest override in force in it (the
//! override applied at both reads that bound it and the commands written before it that may
//! have acted), or at the register's own reading where that is higher; a rapid at its
//! rapid rate. The sum is the farthest the tool can be past the block's start.
//!
//! Kept for the last [`RECENT_PERIODS`] periods, without allocation on the control path.

/// Periods remembered (the guard's largest `debounce_reads`, 10, with room for the
/// periods that delay a confirmation).
pub const RECENT_PERIODS: usize = 16;

/// One period as the bound needs it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Period {
    /// The highest override that may have been in force, percent (`None`: not known, the
    /// read failed: the grid's maximum).
    top_pct: Option<u16>,
    /// The feed the register read at the period's end, mm/min.
    feed_read_mm_min: f64,
    /// A fresh read on a line as designed (not failed, not held by the guard, not late).
    fresh: bool,
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
    /// it (`None`: unknown), the feed the register read at its end (mm/min), and whether
    /// it was a fresh read on a line as designed.
    pub fn push(&mut self, top_pct: Option<u16>, feed_read_mm_min: f64, fresh: bool) {
        self.ring[self.next] = Period {
            top_pct,
            feed_read_mm_min: if feed_read_mm_min.is_finite() {
                feed_read_mm_min.max(0.0)
            } else {
                0.0
            },
            fresh,
        };
        self.next = (self.next + 1) % RECENT_PERIODS;
        self.len = (self.len + 1).min(RECENT_PERIODS);
    }

    /// The farthest the tool can be past the start of a block just reported, mm: the
    /// block's programmed feed `feed_mm_min` (mm/min; `rapid`: the rapid rate, which the
    /// override does not scale), the guard's `debounce_reads`, the grid's maximum `max_pct`
    /// (%) and the control period `period_s` (s). `None` when the block may have begun
    /// before the periods remembered (or before the first).
    pub fn reach_mm(
        &self,
        feed_mm_min: f64,
        rapid: bool,
        debounce_reads: u32,
        max_pct: u16,
        period_s: f64,
    ) -> Option<f64> {
        let newest = |j: usize| self.ring[(self.next + RECENT_PERIODS - 1 - j) % RECENT_PERIODS];
        // The periods the block may have begun in: `debounce_reads`, one more for each of
        // them that was not fresh (a confirmation it delayed), up to what is remembered.
        let mut n = debounce_reads.max(1) as usize;
        let mut j = 0;
        while j < n {
            if j >= self.len {
                return None;
            }
            if !newest(j).fresh {
                n += 1;
            }
            j += 1;
        }
        let path = |p: Period| {
            let pct = p.top_pct.unwrap_or(max_pct);
            let top = if rapid {
                feed_mm_min
            } else {
                feed_mm_min * f64::from(pct) / 100.0
            };
            top.max(p.feed_read_mm_min) * period_s / 60.0
        };
        Some((0..n).map(|j| path(newest(j))).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(periods: &[(Option<u16>, f64, bool)]) -> RecentPeriods {
        let mut r = RecentPeriods::default();
        for &(top, feed, fresh) in periods {
            r.push(top, feed, fresh);
        }
        r
    }

    #[test]
    fn the_reach_counts_the_debounce_and_each_period_that_delayed_it() {
        // 600 mm/min at up to 40 %: 0.4 mm per period of 0.1 s.
        let r = filled(&[(Some(40), 240.0, true); 4]);
        let reach = |r: &RecentPeriods, d| r.reach_mm(600.0, false, d, 150, 0.1);
        assert!((reach(&r, 2).expect("reach") - 0.8).abs() < 1e-12);
        assert!((reach(&r, 3).expect("reach") - 1.2).abs() < 1e-12);
        // A held or late period among them delays the confirmation by one more.
        let r = filled(&[
            (Some(40), 240.0, true),
            (Some(40), 240.0, true),
            (Some(40), 240.0, false),
            (Some(40), 240.0, true),
        ]);
        assert!((reach(&r, 2).expect("reach") - 1.2).abs() < 1e-12);
        // A failed read: the grid's maximum over that period (600 mm/min × 150 %: 1.5 mm).
        let r = filled(&[
            (Some(40), 240.0, true),
            (None, 0.0, false),
            (Some(40), 240.0, true),
        ]);
        assert!((reach(&r, 2).expect("reach") - (0.4 + 1.5 + 0.4)).abs() < 1e-12);
        // Not remembered far enough back: no bound.
        assert_eq!(reach(&filled(&[(Some(40), 240.0, true)]), 2), None);
        // A register reading above the override's feed counts; a rapid runs at its rate.
        let r = filled(&[(Some(10), 600.0, true); 2]);
        assert!((reach(&r, 2).expect("reach") - 2.0).abs() < 1e-12);
        assert!((r.reach_mm(3000.0, true, 2, 150, 0.1).expect("reach") - 10.0).abs() < 1e-12);
    }
}
