//! The plan's lead: while the tool cuts and the plan and the measurement agree, the
//! look-ahead ([`crate::lookahead`]) sets the period's command from the plan's force at the
//! tool's next position, scaled by the measurement, instead of capping a feedback law that
//! answers a change of engagement one period late.
//!
//! The feedback law sees a corner's exit one period after it and climbs back over several
//! periods; on a 10 % grid at a low override its position is one step below Fr for as long
//! as the engagement holds (a step is 25–33 % of the force at 30–40 %). The oracle that
//! knows the engagement (`acc_sim::oracle`) chooses each period's command from the force
//! of the next period. The lead does the same with the plan:
//!
//! - **Scale.** `k` is the median of the last [`SCALE_SAMPLES`] ratios of the measured force
//!   to the plan's force at the period's actual feed, taken where the plan knows the force
//!   well (the rows the tool crossed in the period predict within ±[`NARROW`] of their
//!   middle, and the plan and the measurement are both above [`CUTTING`] × Fr). It corrects
//!   the plan for the tool, the material and the model's error, as the law's Kc estimate
//!   does (seed 002: the force is the process gain times the feed).
//! - **Ceiling.** The highest grid position `o` at which every period the command can
//!   govern has a predicted mean force `k · F(o)` at most [`CEILING`] × Fr: the periods that
//!   start anywhere from the position's error behind the tool (its uncertainty after a
//!   block change, the change of the period's path where the feed changed, and the drift
//!   of the path integrated from `ACTUAL_FEED`: the half units of its whole mm/min over
//!   the periods whose path is taken from it, at most one period's path) to where the
//!   override in force carries it within the command delay and the error ahead
//!   ([`crate::LookAheadConfig::command_delay_s`]; [`WINDOW_SAMPLES`] + 1 starts and every
//!   row boundary in between), each
//!   path-weighted over the rows it crosses at `force_100 · (o/100)^β` (seed 002 eq. 1).
//!   The ceiling is the peak target at entries and corners (1.05 Fr) less a margin for
//!   the plan's error between the scale's samples.
//! - **Between two positions.** The command is that position or the one below, whichever
//!   brings the running sum of predicted errors `Σ (k · F_here − Fr)` nearer zero (a σ-Δ
//!   modulator in force, Candy & Temes 1992): on a coarse grid the period forces average to
//!   Fr instead of sitting a step below it; the step below is taken only where it too is
//!   within the ceiling.
//! - **Entries.** Before a cut's scale is confirmed the look-ahead's cap acts; once the
//!   tool has a scale confirmed in an earlier cut (a new tool or program, or a board that
//!   names no tool, forgets it), the cap may be lifted to the same ceiling at the highest
//!   of that scale, 1 and this cut's ratios: [`highest_within`] over the same window,
//!   while the tool enters or its cut's scale has not disagreed (docs/plan.md, "Entries").
//!   It is a cap, bounded by the law's own command, until this cut has shown a ratio,
//!   judged within the last [`CONFIRM_PERIODS`], within ±[`AGREE`] of the tool's scale
//!   ([`PlanScale::recent_ratio_agrees_with`]); from then it is the command, as the lead.
//! - **When.** Only while the scale is confirmed in the cut the tool is in: a force below
//!   [`CUTTING`] × Fr where the plan has air (entries keep the look-ahead's cap; below it
//!   inside the plan's band in the material the period is not judged), a failed or skipped read, a
//!   new tool, or any pending or declared disagreement starts the scale again; it needs
//!   [`SCALE_MIN_SAMPLES`] samples, this period agreeing with `k` (its ratio within
//!   ±[`AGREE`] where the plan knows the force well, elsewhere its force within the band ×
//!   `k`, ±[`AGREE`]), and a period judged and agreeing within the last
//!   [`CONFIRM_PERIODS`]. Also: the measured force at most [`HIGH`] × Fr, the tool located
//!   on the plan, no feed hold, and the line as designed (no longer echo delay, late
//!   periods or lagging samples: the window assumes the command acts within the command
//!   delay). Otherwise there is no lead: the law under the cap sets the command, and the
//!   running sum restarts.
//!
//! The lead replaces the law's command for the period (the policy's floor and cap in
//! [`acc_core::CommandLimits`]; the law re-engages on it, bumpless): the shop layer's and
//! the tool's limits still bound it (the lower cap wins), and every guard of the policy
//! (staleness, link, overload, operator) acts as without a plan.

/// Samples of the plan's scale kept (the median is taken).
pub const SCALE_SAMPLES: usize = 5;
/// Samples needed before the lead acts.
pub const SCALE_MIN_SAMPLES: usize = 3;
/// A period predicts the force well when its band is within ± this of its middle, −.
pub const NARROW: f64 = 0.1;
/// The tool cuts: the plan and the measurement above this × Fr, −.
pub const CUTTING: f64 = 0.2;
/// No lead while the measured force is above this × Fr, −.
pub const HIGH: f64 = 1.1;
/// The lead needs a period judged (and agreeing) within this many periods, − (a corner's
/// wide band and the slow periods of its exit are not judged: four on the pocket's).
pub const CONFIRM_PERIODS: u32 = 5;
/// No lead while the period's ratio is off the scale by more than this (relative), −.
pub const AGREE: f64 = 0.15;
/// No period the lead governs is predicted above this × Fr, − (the peak target at entries
/// and corners, 1.05, less a margin for the plan's error).
pub const CEILING: f64 = 1.03;
/// The window of period starts is sampled at this many intervals.
pub const WINDOW_SAMPLES: u16 = 4;

/// The plan's scale: the median ratio of measured to planned force over the last periods
/// that predict the force well.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlanScale {
    /// The last ratios, a ring of [`SCALE_SAMPLES`] (no allocation on the control path).
    ratios: [f64; SCALE_SAMPLES],
    /// How many of `ratios` hold a sample.
    len: usize,
    /// Where the next sample goes.
    next: usize,
    /// Whether this period's ratio agreed with the scale (or could not be judged).
    agrees: bool,
    /// Periods since the last one whose ratio was judged (and agreed).
    since_judged: u32,
}

impl PlanScale {
    /// Forget the samples (the tool is lost on the plan, or the plan disagreed).
    pub fn clear(&mut self) {
        self.len = 0;
        self.next = 0;
        self.agrees = false;
        self.since_judged = u32::MAX;
    }

    /// One period: the valid measured force `measured_n` (N; `None`: not valid), the plan's
    /// band `(lo, hi)` at the period's feed (N) and the force reference `force_ref_n` (N).
    pub fn update(&mut self, measured_n: Option<f64>, band_n: (f64, f64), force_ref_n: f64) {
        self.since_judged = self.since_judged.saturating_add(1);
        let Some(f) = measured_n.filter(|f| f.is_finite()) else {
            self.agrees = false;
            return;
        };
        let (lo, hi) = band_n;
        let mid = 0.5 * (lo + hi);
        let known = lo.is_finite()
            && mid > CUTTING * force_ref_n
            && hi - lo <= 2.0 * NARROW * mid
            && f > CUTTING * force_ref_n;
        if !known {
            // Nothing to judge the ratio by: the period adds no sample, and agrees unless
            // the force is outside the band at the scale, ± `AGREE`.
            self.agrees = self.scale().is_none_or(|k| {
                lo.is_finite() && f >= k * lo * (1.0 - AGREE) && f <= k * hi * (1.0 + AGREE)
            });
            return;
        }
        let r = f / mid;
        self.agrees = self.scale().is_none_or(|k| (r - k).abs() <= AGREE * k);
        if self.agrees {
            self.since_judged = 0;
        }
        self.ratios[self.next] = r;
        self.next = (self.next + 1) % SCALE_SAMPLES;
        self.len = (self.len + 1).min(SCALE_SAMPLES);
    }

    /// The scale `k`, − (`None`: fewer than [`SCALE_MIN_SAMPLES`] samples).
    pub fn scale(&self) -> Option<f64> {
        if self.len < SCALE_MIN_SAMPLES {
            return None;
        }
        let mut v = self.ratios;
        let v = &mut v[..self.len];
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    }

    /// The largest ratio sampled in this cut, − (`None`: no sample yet).
    pub fn max_ratio(&self) -> Option<f64> {
        self.ratios[..self.len].iter().copied().reduce(f64::max)
    }

    /// Whether this cut has a ratio judged within the last [`CONFIRM_PERIODS`] periods and
    /// the newest one is within ±[`AGREE`] of `k` (the tool's scale from an earlier cut).
    pub fn recent_ratio_agrees_with(&self, k: f64) -> bool {
        self.len > 0
            && self.since_judged <= CONFIRM_PERIODS
            && (self.ratios[(self.next + SCALE_SAMPLES - 1) % SCALE_SAMPLES] - k).abs() <= AGREE * k
    }

    /// Whether the last period's ratio agreed with the scale.
    pub fn agrees(&self) -> bool {
        self.agrees
    }

    /// Whether the scale is confirmed now: at least [`SCALE_MIN_SAMPLES`] samples, this
    /// period agreed (or could not be judged), and a period within the last
    /// [`CONFIRM_PERIODS`] was judged and agreed (a corner's wide band cannot be judged:
    /// the lead crosses it on the confirmation just before).
    pub fn confirmed(&self) -> bool {
        self.scale().is_some() && self.agrees && self.since_judged <= CONFIRM_PERIODS
    }
}

/// The highest position of the grid of `step_pct` up to `max_pct` (%) at which `worst`
/// (the largest predicted period force, N) is at most [`CEILING`] × `force_ref_n`
/// (`None`: not even the lowest step).
pub fn highest_within(
    max_pct: u16,
    step_pct: u16,
    force_ref_n: f64,
    worst: impl Fn(u16) -> f64,
) -> Option<u16> {
    let step = step_pct.max(1);
    let mut top = max_pct - max_pct % step;
    while top >= step && worst(top) > CEILING * force_ref_n {
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
    /// position is predicted above [`CEILING`] × `force_ref_n`.
    pub fn choose(
        &mut self,
        max_pct: u16,
        step_pct: u16,
        force_ref_n: f64,
        worst: impl Fn(u16) -> f64,
        here: impl Fn(u16) -> f64,
    ) -> Option<u16> {
        let step = step_pct.max(1);
        let Some(top) = highest_within(max_pct, step, force_ref_n, &worst) else {
            self.reset();
            return None;
        };
        let below = (top - step).max(step);
        let e_top = self.error_sum_n + here(top) - force_ref_n;
        let e_below = self.error_sum_n + here(below) - force_ref_n;
        // The step below is taken only where it too is within the ceiling (with β < 1 a
        // shorter period may sit wholly in a narrow peak).
        let below_ok = worst(below) <= CEILING * force_ref_n;
        let (pick, e) = if !below_ok || e_top.abs() <= e_below.abs() {
            (top, e_top)
        } else {
            (below, e_below)
        };
        self.error_sum_n = e.clamp(-force_ref_n, force_ref_n);
        Some(pick)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_is_the_median_of_known_periods() {
        let mut s = PlanScale::default();
        // A wide band (a corner's transition) says nothing.
        s.update(Some(500.0), (200.0, 800.0), 800.0);
        assert!(s.agrees() && s.scale().is_none());
        for f in [550.0, 600.0, 575.0, 5000.0] {
            s.update(Some(f), (480.0, 520.0), 800.0);
        }
        // 1.1, 1.2, 1.15, 10: the median ignores the one wild sample.
        assert!((s.scale().expect("k") - 1.2).abs() < 1e-12);
        // 10 was off the scale of the three before it (1.15) by far more than 15 %.
        assert!(!s.agrees());
        s.update(Some(600.0), (480.0, 520.0), 800.0);
        assert!(s.agrees());
        s.update(None, (480.0, 520.0), 800.0);
        assert!(!s.agrees());
        // With a scale (1.2), a period that cannot be judged still agrees only inside the
        // band at the scale, ± 15 %: 200…800 N → 204…1 104 N.
        s.update(Some(600.0), (480.0, 520.0), 800.0);
        s.update(Some(1000.0), (200.0, 800.0), 800.0);
        assert!(s.agrees());
        s.update(Some(1150.0), (200.0, 800.0), 800.0);
        assert!(!s.agrees());
        // A force below the cutting share, where the band is narrow: 100 N planned.
        s.update(Some(115.0), (95.0, 105.0), 800.0);
        assert!(s.agrees());
        s.update(Some(60.0), (95.0, 105.0), 800.0);
        assert!(!s.agrees());
        s.clear();
        assert!(s.scale().is_none());
    }

    #[test]
    fn the_lead_averages_to_fr_between_two_positions_under_the_ceiling() {
        // F = 24 N per percent: 30 % gives 720 N, 40 % 960 N (above 1.05 × 800), so the
        // ceiling allows 30 % only and the lead holds it.
        let f = |o: u16| 24.0 * f64::from(o);
        let mut lead = PlanLead::default();
        for _ in 0..10 {
            assert_eq!(lead.choose(150, 10, 800.0, f, f), Some(30));
        }
        // 20.5 N per percent: 30 % gives 615 N, 40 % 820 N (within 1.05 Fr). Alternating,
        // the mean of the predicted forces goes to Fr and no period is above the ceiling.
        let f = |o: u16| 20.5 * f64::from(o);
        let mut lead = PlanLead::default();
        let picks: Vec<u16> = (0..100)
            .map(|_| lead.choose(150, 10, 800.0, f, f).expect("led"))
            .collect();
        let mean = picks.iter().map(|&o| f(o)).sum::<f64>() / picks.len() as f64;
        assert!((mean - 800.0).abs() < 5.0, "mean {mean}");
        assert!(picks.iter().all(|&o| o == 30 || o == 40));
        // Even the lowest position predicted above the ceiling: no lead.
        assert_eq!(lead.choose(150, 10, 800.0, |_| 1e6, f), None);
        // The step below nearer Fr but with a period above the ceiling (a narrow peak a
        // shorter period sits in): the step above.
        let here = |o: u16| if o == 40 { 850.0 } else { 780.0 };
        let worst = |o: u16| if o == 40 { 820.0 } else { 2000.0 };
        let mut lead = PlanLead::default();
        assert_eq!(lead.choose(40, 10, 800.0, worst, here), Some(40));
        let worst = |o: u16| if o == 40 { 820.0 } else { 780.0 };
        let mut lead = PlanLead::default();
        assert_eq!(lead.choose(40, 10, 800.0, worst, here), Some(30));
    }
}
