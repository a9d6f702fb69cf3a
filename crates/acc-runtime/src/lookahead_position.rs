//! Where the tool is on the plan ([`crate::lookahead`], "Where the tool is"): the block
//! reported looked up in the plan, the position set at a block's start within the reach of
//! the periods it may have begun in ([`crate::block_start`]), the path of each period from
//! the plan's feed or `ACTUAL_FEED`, and the drift allowance of that integrated path.
use acc_pmc::BoardStatus;

use super::{LookAhead, FEED_RESOLUTION_MM_MIN};
use crate::plan::PlanRow;

impl LookAhead {
    /// The first row of the visit of `block` (low 16 bits) the tool at `x` (mm) can be in:
    /// the first visit from the one before `from` (or the start) that ends at or after
    /// `x`, wrapping once.
    pub(super) fn find_visit(&self, block: u16, from: Option<usize>, x: f64) -> Option<usize> {
        let n = self.plan.rows.len();
        let start = from.unwrap_or(0);
        let is_start = |i: usize| i == 0 || self.plan.rows[i - 1].block != self.plan.rows[i].block;
        let ok = |i: usize| is_start(i) && (self.plan.rows[i].block & 0xFFFF) as u16 == block;
        (start..n)
            .find(|&i| ok(i) && self.plan.rows[self.visit_end[i]].end_mm >= x - 1e-9)
            .or_else(|| (start..n).chain(0..start.min(n)).find(|&i| ok(i)))
    }

    /// A new block was reported, its visit starting at row `i`: the tool is at most
    /// [`RecentPeriods::reach_mm`] past the block's start. A position within that keeps,
    /// and bounds the drift allowance to it; any other is set to the middle of it, ± half
    /// of it (the uncertainty, kept until the next block change). Where the block may have
    /// begun before the periods remembered, a position outside the visit is set to the
    /// start plus half this period's path at most at the block's top speed (its feed × the
    /// grid's maximum, a rapid's rapid rate), ± that much.
    pub(super) fn place_at_block_start(&mut self, i: usize, dx: f64, period_s: f64) {
        let r = &self.plan.rows[i];
        let (start, end) = (r.start_mm, self.plan.rows[self.visit_end[i]].end_mm);
        let reach = self.recent.reach_mm(
            r.feed_mm_min,
            r.rapid,
            self.debounce_reads,
            self.cfg.max_pct,
            period_s,
        );
        match reach {
            Some(h) if (start..=start + h).contains(&self.x_mm) => {
                let bound = (self.x_mm - start).max(start + h - self.x_mm);
                self.drift_mm = self.drift_mm.min(bound);
            }
            Some(h) => {
                self.x_mm = start + 0.5 * h;
                self.unc_mm = 0.5 * h;
                self.drift_mm = 0.0;
            }
            None if !(start..=end).contains(&self.x_mm) => {
                let top = if r.rapid {
                    r.feed_mm_min
                } else {
                    r.feed_mm_min * f64::from(self.cfg.max_pct) / 100.0
                };
                let d = dx.min(top * period_s / 60.0);
                self.x_mm = start + 0.5 * d;
                self.unc_mm = 0.5 * d;
                // A period longer than designed may have carried the tool farther.
                self.drift_mm = if self.line_nominal { 0.0 } else { dx };
            }
            None => {}
        }
    }

    /// Whether the plan has the tool in the material wherever it can be in the period that
    /// ended at `x` (mm) after moving `dx` (mm): every row from the period's start to its
    /// end, widened by the position's uncertainty and drift allowance, cuts.
    pub(super) fn in_material(&self, x: f64, dx: f64) -> bool {
        let err = self.unc_mm + self.drift_allowance(dx);
        let (a, b) = (self.plan.row_at(x - dx - err), self.plan.row_at(x + err));
        self.plan.rows[a..=b].iter().all(PlanRow::cuts)
    }

    /// The drift allowance of the integrated position, mm (`drift_mm`; at least the
    /// period's path `dx`, mm, once the register has shown itself an instantaneous value).
    pub(super) fn drift_allowance(&self, dx: f64) -> f64 {
        if self.instantaneous_feed {
            self.drift_mm.max(dx)
        } else {
            self.drift_mm
        }
    }

    /// The path of the period that ended, mm, and whether it is exact: where the override
    /// applied is the one of the read before, no feed hold, and the tool stayed in the feed
    /// of one plan row of the block, the path is that row's programmed feed × the override,
    /// as long as the register agrees with it to its rounding (`v`, mm/min); otherwise the
    /// register's `v` (a whole number of mm/min: off by up to half a unit). A period in
    /// which an override change took effect and the register already shows the new feed
    /// marks the register as instantaneous (`instantaneous_feed`).
    pub(super) fn period_path_mm(&mut self, s: &BoardStatus, v: f64, period_s: f64) -> (f64, bool) {
        let applied = s.override_applied_pct;
        let prev = self.applied_prev;
        self.applied_prev = (!s.feed_hold_active).then_some(applied);
        let reported = v * period_s / 60.0;
        let Some(prev) = prev.filter(|_| !s.feed_hold_active) else {
            return (reported, false);
        };
        let (a, b) = (
            &self.plan.rows[self.plan.row_at(self.x_mm)],
            &self.plan.rows[self.plan.row_at(self.x_mm + reported)],
        );
        if a.rapid || b.rapid || a.block != b.block || a.feed_mm_min != b.feed_mm_min {
            return (reported, false);
        }
        let at = |pct: u16| a.feed_mm_min * f64::from(pct) / 100.0;
        let close = |f: f64| (f - v).abs() <= FEED_RESOLUTION_MM_MIN + 1e-9;
        if prev != applied {
            // A period mean lies between the old feed and the new one; the new feed itself,
            // with the two far enough apart, is an instantaneous value.
            if (at(applied) - at(prev)).abs() > 4.0 * FEED_RESOLUTION_MM_MIN && close(at(applied)) {
                self.instantaneous_feed = true;
            }
            return (reported, false);
        }
        if close(at(applied)) {
            (at(applied) * period_s / 60.0, true)
        } else {
            (reported, false)
        }
    }
}
