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

    /// A new block was reported, its visit starting at row `i`; `changed`: the block
    /// reported before had another number (not the run's first, nor after a v1 board's or a
    /// zero block number). The tool is then at most [`LookAhead::block_reach_mm`] past the
    /// block's start: a position within that reach is kept and bounds the drift allowance;
    /// any other becomes the middle of the reach, ± half of it (the uncertainty, kept until
    /// the next block change). Without that bound (the run's first block, a period the line
    /// ran late, more periods than remembered) a position inside the visit is kept; one
    /// outside becomes the start plus half the path the register read since the old block
    /// was last read (at least this period's), ± that much.
    pub(super) fn place_at_block_start(&mut self, i: usize, changed: bool, dx: f64, period_s: f64) {
        let start = self.plan.rows[i].start_mm;
        let end = self.plan.rows[self.visit_end[i]].end_mm;
        let reach = if changed {
            self.block_reach_mm(i, period_s)
        } else {
            None
        };
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
                let d = self
                    .recent
                    .read_path_mm(self.since_old as usize, period_s)
                    .max(dx);
                self.x_mm = start + 0.5 * d;
                self.unc_mm = 0.5 * d;
                // A period longer than designed may have carried the tool farther.
                self.drift_mm = if self.line_nominal { 0.0 } else { dx };
            }
            None => {}
        }
    }

    /// How far the tool can be past the start of the block whose visit starts at row `i`,
    /// mm ([`crate::block_start::RecentPeriods::reach_mm`]): over the periods since the
    /// old block was last read raw (`since_old`), each at the highest speed of the rows
    /// from the block's start to the reach ([`PlanRow::speed_mm_min`] at the period's
    /// highest override, the grid's maximum where that is not known), the rows widened
    /// until the reach no longer leaves them. `None` without a bound.
    fn block_reach_mm(&self, i: usize, period_s: f64) -> Option<f64> {
        let rows = &self.plan.rows;
        let start = rows[i].start_mm;
        let max_pct = self.cfg.max_pct;
        let mut last = self.visit_end[i];
        for _ in 0..8 {
            let span = &rows[i..=last];
            let speed = |pct: Option<u16>| {
                let pct = pct.unwrap_or(max_pct);
                span.iter().map(|r| r.speed_mm_min(pct)).fold(0.0, f64::max)
            };
            let h = self
                .recent
                .reach_mm(self.since_old as usize, speed, period_s)?;
            let to = self.plan.row_at(start + h).max(last);
            if to == last {
                return Some(h);
            }
            last = to;
        }
        None
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
        // A status the line guard held is the last accepted one: the override applied now
        // is not known.
        self.applied_prev = (!s.feed_hold_active && !self.held).then_some(applied);
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
