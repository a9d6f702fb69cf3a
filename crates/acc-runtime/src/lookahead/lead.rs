//! The plan's lead (docs/plan.md, "The plan's lead"): the plan's scale `k` (the median
//! ratio of measured to planned force over the periods the plan predicts well), the
//! highest grid position whose predicted period forces `k · F(o)` stay under the ceiling,
//! and the choice between it and the position below by a running sum of predicted errors
//! (a σ-Δ modulator in force, Candy & Temes 1992). The force law is seed 002 eq. 1,
//! `force_100 · (o/100)^β`. Its tuning is in [`super::LookAheadConfig`].

use acc_pmc::BoardStatus;

use super::band::Judged;
use super::position::Located;
use super::LookAhead;

/// The highest position of the grid of `step_pct` up to `max_pct` (%) at which `worst`
/// (the largest predicted period force, N) is at most the ceiling `ceiling_n` (N,
/// [`LookAheadConfig::lead_ceiling_n`]; `None`: not even the lowest step).
pub fn highest_within(
    max_pct: u16,
    step_pct: u16,
    ceiling_n: f64,
    worst: impl Fn(u16) -> f64,
) -> Option<u16> {
    let step = step_pct.max(1);
    let mut top = max_pct - max_pct % step;
    while top >= step && worst(top) > ceiling_n {
        top -= step;
    }
    (top >= step).then_some(top)
}

/// The lead's choice between two grid positions: the running sum of predicted errors.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanLead {
    /// `Σ (k · F_here − Fr)` over the periods led so far, N (clamped to ± Fr).
    error_sum_n: f64,
}

impl PlanLead {
    /// No lead this period: the running sum restarts.
    pub fn reset(&mut self) {
        self.error_sum_n = 0.0;
    }

    /// The period's command, percent, on the grid of `step_pct` up to `max_pct`:
    /// `worst(o)` is the largest predicted mean force (N, scaled) of any period the command
    /// can govern at position `o`, `here(o)` the predicted mean force of the next period
    /// from the tool's position (N). `None` (and the sum restarts) when even the lowest
    /// position is predicted above the ceiling `ceiling_n` (N).
    pub fn choose(
        &mut self,
        max_pct: u16,
        step_pct: u16,
        force_ref_n: f64,
        ceiling_n: f64,
        worst: impl Fn(u16) -> f64,
        here: impl Fn(u16) -> f64,
    ) -> Option<u16> {
        let step = step_pct.max(1);
        let Some(top) = highest_within(max_pct, step, ceiling_n, &worst) else {
            self.reset();
            return None;
        };
        let below = (top - step).max(step);
        let e_top = self.error_sum_n + here(top) - force_ref_n;
        let e_below = self.error_sum_n + here(below) - force_ref_n;
        // The step below is taken only where it too is within the ceiling (with β < 1 a
        // shorter period may sit wholly in a narrow peak).
        let below_ok = worst(below) <= ceiling_n;
        let (pick, e) = if !below_ok || e_top.abs() <= e_below.abs() {
            (top, e_top)
        } else {
            (below, e_below)
        };
        self.error_sum_n = e.clamp(-force_ref_n, force_ref_n);
        Some(pick)
    }
}

impl LookAhead {
    /// Whether the lead may act this period: asked for, a nominal line, no feed hold (from
    /// `s`), the plan and the measurement agreeing, and the measured force at most
    /// [`super::LookAheadConfig::lead_max_force_share_of_fr`] × Fr.
    pub(super) fn lead_may_act(&self, judged: &Judged, s: &BoardStatus) -> bool {
        self.cfg.lead
            && self.line_nominal
            && !s.feed_hold_active
            && judged.agree
            && judged.measured.is_some_and(|f| self.cfg.lead_may_act_at(f))
    }

    /// The period's lead, %: while the cut's scale is confirmed and the lead may act, the
    /// command from the plan's force ahead scaled by the measurement; otherwise the running
    /// sum restarts and the entry's lead `entry_lead` (if any) stands.
    pub(super) fn lead_or_entry(
        &mut self,
        at: &Located,
        judged: &Judged,
        s: &BoardStatus,
        entry_lead: Option<u16>,
        period_s: f64,
    ) -> Option<u16> {
        match (self.scale.scale(), judged.measured) {
            (Some(k), Some(_)) if self.lead_may_act(judged, s) && self.scale.confirmed() => {
                self.lead_command(k, at, s, period_s)
            }
            _ => {
                self.lead.reset();
                entry_lead
            }
        }
    }

    /// The window of period starts the command written now can govern, and where the
    /// next period starts, `(y0, y1, here)` in mm: the tool at `x` (mm) having moved `dx`
    /// (mm) this period, the position's uncertainty and feed-change margin `unc_mm` (mm),
    /// the highest override it may move at `in_force_pct` (%). The command acts within
    /// `command_delay_s`, at the override in force until then, and governs one period from
    /// there, so every such period's mean force counts. The position may be off by
    /// `unc_mm` and by the drift allowance of the path integrated from `ACTUAL_FEED`
    /// (`drift_mm`, [`LookAhead::period_path_mm`]; at least one period's path once the
    /// register has shown itself an instantaneous value) either way.
    pub(super) fn window(
        &self,
        x: f64,
        dx: f64,
        unc_mm: f64,
        in_force_pct: u16,
    ) -> (f64, f64, f64) {
        let drift = self.drift_allowance(dx);
        let here = x - drift;
        let ahead = self.plan.advance(x, in_force_pct, self.cfg.command_delay_s);
        (here - unc_mm, ahead + unc_mm + drift, here)
    }

    /// The largest of the plan's period-mean forces at override `o` (%) of the periods
    /// starting in `y0 ..= y1` (mm), N: starts evenly over the window and at every row
    /// boundary in it (where a heavy stretch begins).
    pub(super) fn worst_period_n(&self, y0: f64, y1: f64, o: u16, period_s: f64) -> f64 {
        let plan = &self.plan;
        let rows = &plan.rows[plan.row_at(y0)..=plan.row_at(y1)];
        let n = self.cfg.window_intervals;
        (0..=n)
            .map(|j| y0 + (y1 - y0) * f64::from(j) / f64::from(n))
            .chain(rows.iter().map(|r| r.start_mm))
            .filter(|y| (y0..=y1).contains(y))
            .map(|y| plan.period_force_n(y, o, period_s))
            .fold(0.0f64, f64::max)
    }

    /// The plan's lead with scale `k` over the [`LookAhead::window`] of the tool at `at`, on
    /// the board's grid from `s`.
    fn lead_command(
        &mut self,
        k: f64,
        at: &Located,
        s: &BoardStatus,
        period_s: f64,
    ) -> Option<u16> {
        let (y0, y1, here) = self.window(at.x, at.dx, at.unc_mm, at.in_force_pct);
        let worst = |o: u16| k * self.worst_period_n(y0, y1, o, period_s);
        let here = |o: u16| k * self.plan.period_force_n(here, o, period_s);
        let fr = self.cfg.force_ref_n;
        let ceiling_n = self.cfg.lead_ceiling_n();
        let mut lead = self.lead;
        let pick = lead.choose(
            self.cfg.max_pct,
            s.override_step_pct,
            fr,
            ceiling_n,
            worst,
            here,
        );
        self.lead = lead;
        pick
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lookahead::LookAheadConfig;

    /// The default ceiling at Fr = 800 N, N.
    const CEILING_N: f64 = LookAheadConfig::DEFAULT_LEAD_CEILING_SHARE_OF_FR * 800.0;

    #[test]
    fn the_lead_averages_to_fr_between_two_positions_under_the_ceiling() {
        // F = 24 N per percent: 30 % gives 720 N, 40 % 960 N (above 1.05 × 800), so the
        // ceiling allows 30 % only and the lead holds it.
        let f = |o: u16| 24.0 * f64::from(o);
        let mut lead = PlanLead::default();
        for _ in 0..10 {
            assert_eq!(lead.choose(150, 10, 800.0, CEILING_N, f, f), Some(30));
        }
        // 20.5 N per percent: 30 % gives 615 N, 40 % 820 N (within 1.05 Fr). Alternating,
        // the mean of the predicted forces goes to Fr and no period is above the ceiling.
        let f = |o: u16| 20.5 * f64::from(o);
        let mut lead = PlanLead::default();
        let picks: Vec<u16> = (0..100)
            .map(|_| lead.choose(150, 10, 800.0, CEILING_N, f, f).expect("led"))
            .collect();
        let mean = picks.iter().map(|&o| f(o)).sum::<f64>() / picks.len() as f64;
        assert!((mean - 800.0).abs() < 5.0, "mean {mean}");
        assert!(picks.iter().all(|&o| o == 30 || o == 40));
        // Even the lowest position predicted above the ceiling: no lead.
        assert_eq!(lead.choose(150, 10, 800.0, CEILING_N, |_| 1e6, f), None);
        // The step below nearer Fr but with a period above the ceiling (a narrow peak a
        // shorter period sits in): the step above.
        let here = |o: u16| if o == 40 { 850.0 } else { 780.0 };
        let worst = |o: u16| if o == 40 { 820.0 } else { 2000.0 };
        let mut lead = PlanLead::default();
        assert_eq!(lead.choose(40, 10, 800.0, CEILING_N, worst, here), Some(40));
        let worst = |o: u16| if o == 40 { 820.0 } else { 780.0 };
        let mut lead = PlanLead::default();
        assert_eq!(lead.choose(40, 10, 800.0, CEILING_N, worst, here), Some(30));
    }
}
