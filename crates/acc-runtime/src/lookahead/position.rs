//! Where the tool is on the plan (docs/plan.md, "Where the tool is"): the block reported
//! looked up in the plan, the position set at a block's start within the reach of the
//! periods it may have begun in ([`super::block_start`]), the path of each period from the
//! plan's feed or `ACTUAL_FEED`, and the drift allowance of that integrated path.
use acc_pmc::BoardStatus;

use super::plan::PlanRow;
use super::LookAhead;

/// Where the tool is this period, as the band, the cap and the lead read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Located {
    /// Path position on the plan, mm (clamped to the plan).
    pub(super) x: f64,
    /// Path of the period, mm.
    pub(super) dx: f64,
    /// The position's uncertainty plus the change of the period's path, mm.
    pub(super) unc_mm: f64,
    /// The highest override the tool may move at now (in force or written), %.
    pub(super) in_force_pct: u16,
}

impl LookAhead {
    /// The periods since the old block was last read raw, from this read's raw block
    /// number `raw_block` (`None`: the reported one). The reported number lags the raw one
    /// while the line guard confirms a change. A read the guard held is suspect (a stale
    /// frame may show the old block): it never restarts the count. Returns the raw number
    /// that counts (`None` for a held read).
    pub(super) fn count_since_old_block(
        &mut self,
        s: &BoardStatus,
        raw_block: Option<u16>,
    ) -> Option<u16> {
        let raw = Some(raw_block.unwrap_or(s.block_number)).filter(|_| !self.held);
        self.since_old = if raw.is_some() && raw == self.last_block {
            0
        } else {
            self.since_old.saturating_add(1)
        };
        raw
    }

    /// Remember the period for the block start's reach: the highest override that may have
    /// been in force (the one applied at both reads around it and the commands written that
    /// may have acted; not known after a failed read or a feed hold, nor from a status the
    /// guard held) and the feed read.
    pub(super) fn remember_period(&mut self, s: &BoardStatus) {
        let top_pct = self.applied_prev.filter(|_| !self.held).map(|p| {
            p.max(s.override_applied_pct)
                .max(self.written[0])
                .max(self.written[1])
        });
        let v = f64::from(s.actual_feed_mm_min);
        self.recent.push(top_pct, v, self.line_nominal);
    }

    /// Move the position by the path the NC reports, whatever the block (the block report
    /// lags the feed by the line guard's confirmation); the drift allowance grows by a
    /// whole period's path on a line not as designed, else by the register's rounding
    /// where the path is not exact. Returns the period's path, mm.
    pub(super) fn advance_position(&mut self, s: &BoardStatus, period_s: f64) -> f64 {
        let v = f64::from(s.actual_feed_mm_min);
        let (dx, exact) = self.period_path_mm(s, v, period_s);
        self.x_mm += dx;
        if !self.line_nominal {
            // A late period or a lagging sample: the period's length is not the nominal one.
            self.drift_mm += dx;
        } else if !exact {
            self.drift_mm += self.cfg.feed_rounding_mm_min * period_s / 60.0;
        }
        dx
    }

    /// A block reported for the first time (or while the tool is not located): look it up
    /// in the plan from the visit the tool was in and set the position at its start
    /// ([`LookAhead::place_at_block_start`]). A reported block equal to the raw one `raw`
    /// restarts the count of periods since the old block.
    pub(super) fn locate_block(
        &mut self,
        s: &BoardStatus,
        raw: Option<u16>,
        dx: f64,
        period_s: f64,
    ) {
        let prior = self.last_block;
        if prior != Some(s.block_number) || self.visit.is_none() {
            self.last_block = Some(s.block_number);
            self.visit = self.find_visit(s.block_number, self.visit, self.x_mm);
            if let Some(i) = self.visit {
                let changed = prior.is_some_and(|b| b != s.block_number);
                self.place_at_block_start(i, changed, dx, period_s);
            }
        }
        if raw == Some(s.block_number) {
            // The block reported now is the one read: the next change counts from here.
            self.since_old = 0;
        }
    }

    /// Where the tool is for the rest of the period after moving `dx` (mm). The tool may
    /// move at the override in force or a command written and not yet applied. The
    /// position integrates a feed register that may be an instantaneous value: where the
    /// feed changed, it may be off by up to the change of the period's path, so the walk
    /// starts that much behind the position and reaches that much farther.
    pub(super) fn located(&mut self, s: &BoardStatus, dx: f64) -> Located {
        let x = self.x_mm.clamp(0.0, self.plan.length_mm());
        let in_force_pct = s
            .override_applied_pct
            .max(self.written[0])
            .max(self.written[1]);
        let margin = (dx - self.dx_prev_mm).abs();
        if self.instantaneous_feed {
            // An instantaneous register misses the part of the period at the old feed: the
            // change of the period's path stays in the integrated position.
            self.drift_mm += margin;
        }
        self.dx_prev_mm = dx;
        Located {
            x,
            dx,
            unc_mm: self.unc_mm + margin,
            in_force_pct,
        }
    }

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
    /// mm ([`super::block_start::RecentPeriods::reach_mm`]): over the periods since the
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
        let rounding = self.cfg.feed_rounding_mm_min;
        let close = |f: f64| (f - v).abs() <= rounding + 1e-9;
        if prev != applied {
            // A period mean lies between the old feed and the new one; the new feed itself,
            // with the two far enough apart, is an instantaneous value.
            if (at(applied) - at(prev)).abs() > 4.0 * rounding && close(at(applied)) {
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
