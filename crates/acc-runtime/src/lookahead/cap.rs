//! The cap (docs/plan.md, "The cap"): the lowest planned override of the plan's feed rows
//! from the position's uncertainty behind the tool to where it can be
//! [`super::LookAheadConfig::horizon_s`] ahead, walked at the override the tool may move
//! at; inside a profiled row, the override that gives Fr at the part the tool can reach.

use super::band::Judged;
use super::plan::PlanRow;
use super::position::Located;
use super::{Disagreement, LookAhead};

impl LookAhead {
    /// The period's cap from where the tool is (`at`) and what the measurement says
    /// (`judged`): none while the plan over-predicts (it would slow the tool for metal that
    /// is not there); each row at its largest force while it under-predicts.
    pub(super) fn plan_cap(&self, at: &Located, judged: &Judged) -> Option<u16> {
        if judged.disagreement == Some(Disagreement::Below) {
            None
        } else {
            self.cap(at.x, at.unc_mm, at.in_force_pct, judged.shape)
        }
    }

    /// The lowest planned override of the feed rows from `x − unc_mm` to where the tool can
    /// be `horizon_s` later, with `in_force_pct` the highest override the tool may move at
    /// now (in force or written), reading a profiled row's shape when `shape` (`None`:
    /// nothing below the grid's maximum).
    fn cap(&self, x: f64, unc_mm: f64, in_force_pct: u16, shape: bool) -> Option<u16> {
        let rows = &self.plan.rows;
        let mut i = self.plan.row_at(x - unc_mm);
        let mut at = (x - unc_mm).max(rows[i].start_mm);
        let mut left_s = self.cfg.horizon_s;
        let mut cap = u16::MAX;
        // The uncertainty ahead costs no time: the tool may already be there.
        let mut free_mm = 2.0 * unc_mm;
        loop {
            let r: &PlanRow = &rows[i];
            let len = (r.end_mm - at).max(0.0);
            let free = free_mm.min(len);
            // The tool crosses this row at most at the override in force or the cap so far
            // with this row's: `reach(c)` is how far into the row it gets at cap `c`, and
            // the time it spends in the row.
            let reach = |c: u16| {
                let pct = in_force_pct.max(cap.min(c).min(self.cfg.max_pct)).max(1);
                let speed = r.speed_mm_min(pct) / 60.0;
                let t = if speed > 0.0 {
                    (len - free) / speed
                } else {
                    f64::INFINITY
                };
                let to = if t >= left_s {
                    at + free + speed * left_s
                } else {
                    r.end_mm
                };
                (to, t)
            };
            // The row's cap over the part the tool can reach; the reach of the lowest
            // (whole-row) cap gives a first cap, and the reach at that cap the final one:
            // a command at most the final cap moves the tool no farther than was judged.
            let planned = r.cap_for_fr(self.cfg.force_ref_n);
            let (t, row_cap) = if r.rapid {
                (reach(u16::MAX).1, u16::MAX)
            } else if !shape {
                (reach(planned).1, planned)
            } else {
                let c1 = self.row_cap(r, planned, at, reach(planned).0);
                let (to, t1) = reach(c1);
                (t1, self.row_cap(r, planned, at, to))
            };
            cap = cap.min(row_cap);
            free_mm -= free;
            if t >= left_s || i + 1 >= rows.len() {
                break;
            }
            left_s -= t;
            i += 1;
            at = rows[i].start_mm;
        }
        (cap < self.cfg.max_pct).then_some(cap)
    }

    /// The cap of feed row `r` over its part `from_mm ..= to_mm`, percent: `planned`, the
    /// row's planned override for the loop's Fr ([`PlanRow::cap_for_fr`]), where the row's force is not
    /// known inside it (`flat`) or the part holds its largest force; else the override at
    /// which the part's largest force ([`PlanRow::force_100_over_n`]) is Fr,
    /// `100 · (Fr / F)^(1/β)` (seed 002 eq. 1 solved for the feed), at least the planned
    /// override and at most the grid's maximum. The tool's own override limits are the
    /// shop layer's (they join the cap, the lower wins).
    fn row_cap(&self, r: &PlanRow, planned: u16, from_mm: f64, to_mm: f64) -> u16 {
        let f = r.force_100_over_n(from_mm, to_mm);
        if !r.cuts() || f >= r.force_100_n {
            return planned;
        }
        let top = f64::from(self.cfg.max_pct);
        let o = match r.override_for_fr(f, self.cfg.force_ref_n) {
            Some(o) => o.min(top),
            None if f <= 0.0 && self.cfg.force_ref_n > 0.0 => top,
            None => return planned,
        };
        (o.floor() as u16).max(planned)
    }
}
