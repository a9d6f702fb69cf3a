//! A cut's entry (docs/plan.md, "Entries"): before the cut's scale is confirmed, the
//! plan's period forces at the tool's scale from its earlier cuts may lift the cap, and
//! once this cut shows a ratio that agrees with that scale the entry's position is the
//! command.

use acc_pmc::BoardStatus;

use super::band::Judged;
use super::lead::highest_within;
use super::position::Located;
use super::LookAhead;

/// A cut's entry this period: the scale its cap is judged at, the window of period starts
/// and the entry's cap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Entry {
    /// The highest of the tool's scale, 1 and every ratio this cut has shown, −.
    k: f64,
    /// The window of period starts `(y0, y1)`, mm ([`LookAhead::window`]).
    window: (f64, f64),
    /// The entry's cap, % (`None`: not even the lowest grid step is within the ceiling).
    cap_pct: Option<u16>,
}

impl Entry {
    /// The period's cap `cap_pct` (%) lifted to the entry's, where there is one.
    pub(super) fn lift(cap_pct: Option<u16>, entry: Option<Entry>) -> Option<u16> {
        match (cap_pct, entry) {
            (Some(c), Some(e)) => Some(e.cap_pct.map_or(c, |e| e.max(c))),
            (c, _) => c,
        }
    }
}

impl LookAhead {
    /// The entry of this period, if the cap `cap_pct` may be lifted: the tool has a scale
    /// from an earlier cut, the lead may act ([`LookAhead::lead_may_act`]), this cut's scale
    /// is not confirmed, and the tool enters (the measured force below the cutting share)
    /// or its cut's scale has not yet disagreed. The force at most the lead's ceiling, at
    /// the highest of the tool's scale, 1 and every ratio this cut has shown.
    pub(super) fn entry(
        &self,
        cap_pct: Option<u16>,
        at: &Located,
        judged: &Judged,
        s: &BoardStatus,
        period_s: f64,
    ) -> Option<Entry> {
        let tool_k = self.tool_scale?;
        cap_pct?;
        let entering =
            judged.measured.is_some_and(|f| f < self.cfg.cutting_n()) || self.scale.agrees();
        if !(self.lead_may_act(judged, s) && entering && !self.scale.confirmed()) {
            return None;
        }
        let k = tool_k.max(1.0).max(self.scale.max_ratio().unwrap_or(0.0));
        let (y0, y1, _) = self.window(at.x, at.dx, at.unc_mm, at.in_force_pct);
        let cap_pct = self.entry_cap(k, (y0, y1), s.override_step_pct, period_s);
        Some(Entry {
            k,
            window: (y0, y1),
            cap_pct,
        })
    }

    /// The entry's position as the command, % (the law's may be low from the stretch
    /// before: a corner, an engagement that fell below the cutting share): only once this
    /// cut has shown a ratio, judged within the last periods, that agrees with the tool's
    /// scale; in air and until then the law's command stands under the cap. The position is
    /// taken again at the highest of the entry's scale and this cut's ratios, which may be
    /// up to [`super::LookAheadConfig::scale_agreement`] above the tool's.
    pub(super) fn entry_lead(
        &self,
        entry: Option<Entry>,
        s: &BoardStatus,
        period_s: f64,
    ) -> Option<u16> {
        entry
            .filter(|_| {
                self.tool_scale
                    .is_some_and(|k| self.scale.recent_ratio_agrees_with(k))
            })
            .and_then(|e| match self.scale.max_ratio() {
                Some(r) if r > e.k => self.entry_cap(r, e.window, s.override_step_pct, period_s),
                _ => e.cap_pct,
            })
    }

    /// The entry's cap (docs/plan.md, "Entries"): the highest position of the
    /// board's grid of `step_pct` at which every period starting in `y0 ..= y1` (mm, the
    /// [`LookAhead::window`]) is predicted at most the ceiling with scale `k`.
    pub(super) fn entry_cap(
        &self,
        k: f64,
        (y0, y1): (f64, f64),
        step_pct: u16,
        period_s: f64,
    ) -> Option<u16> {
        highest_within(self.cfg.max_pct, step_pct, self.cfg.lead_ceiling_n(), |o| {
            k * self.worst_period_n(y0, y1, o, period_s)
        })
    }
}
