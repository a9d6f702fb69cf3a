//! The plan's scale (docs/plan.md, "The plan's lead"): the median ratio of measured to
//! planned force over the periods the plan predicts well. It belongs to the cut it was
//! measured in; the tool keeps its last confirmed scale for its next entries.

use acc_pmc::BoardStatus;

use super::band::Judged;
use super::position::Located;
use super::{LookAhead, LookAheadConfig};

/// Samples of the plan's scale kept (the median is taken): the ring's capacity.
pub const SCALE_SAMPLES: usize = 5;

/// The plan's scale: the median ratio of measured to planned force over the last periods
/// that predict the force well.
#[derive(Debug, Clone, PartialEq)]
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
    /// [`LookAheadConfig::scale_min_samples`].
    min_samples: usize,
    /// [`LookAheadConfig::scale_band_half_width`], −.
    band_half_width: f64,
    /// [`LookAheadConfig::cutting_share_of_fr`], −.
    cutting_share_of_fr: f64,
    /// [`LookAheadConfig::scale_agreement`], −.
    agreement: f64,
    /// [`LookAheadConfig::scale_confirm_periods`].
    confirm_periods: u32,
}

impl PlanScale {
    /// An empty scale with the tuning of `cfg`.
    pub fn new(cfg: &LookAheadConfig) -> Self {
        PlanScale {
            ratios: [0.0; SCALE_SAMPLES],
            len: 0,
            next: 0,
            agrees: false,
            since_judged: 0,
            min_samples: cfg.scale_min_samples,
            band_half_width: cfg.scale_band_half_width,
            cutting_share_of_fr: cfg.cutting_share_of_fr,
            agreement: cfg.scale_agreement,
            confirm_periods: cfg.scale_confirm_periods,
        }
    }

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
        let cutting_n = self.cutting_share_of_fr * force_ref_n;
        let known = lo.is_finite()
            && mid > cutting_n
            && hi - lo <= 2.0 * self.band_half_width * mid
            && f > cutting_n;
        let agree = self.agreement;
        if !known {
            // Nothing to judge the ratio by: the period adds no sample, and agrees unless
            // the force is outside the band at the scale, ± the agreement.
            self.agrees = self.scale().is_none_or(|k| {
                lo.is_finite() && f >= k * lo * (1.0 - agree) && f <= k * hi * (1.0 + agree)
            });
            return;
        }
        let r = f / mid;
        self.agrees = self.scale().is_none_or(|k| (r - k).abs() <= agree * k);
        if self.agrees {
            self.since_judged = 0;
        }
        self.ratios[self.next] = r;
        self.next = (self.next + 1) % SCALE_SAMPLES;
        self.len = (self.len + 1).min(SCALE_SAMPLES);
    }

    /// The scale `k`, − (`None`: fewer than [`LookAheadConfig::scale_min_samples`]).
    pub fn scale(&self) -> Option<f64> {
        if self.len < self.min_samples {
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

    /// Whether this cut has a ratio judged within the last
    /// [`LookAheadConfig::scale_confirm_periods`] and the newest one agrees with `k` (the
    /// tool's scale from an earlier cut) within [`LookAheadConfig::scale_agreement`].
    pub fn recent_ratio_agrees_with(&self, k: f64) -> bool {
        self.len > 0
            && self.since_judged <= self.confirm_periods
            && (self.ratios[(self.next + SCALE_SAMPLES - 1) % SCALE_SAMPLES] - k).abs()
                <= self.agreement * k
    }

    /// Whether the last period's ratio agreed with the scale.
    pub fn agrees(&self) -> bool {
        self.agrees
    }

    /// Whether the scale is confirmed now: enough samples, this period agreed (or could
    /// not be judged), and a period within the last
    /// [`LookAheadConfig::scale_confirm_periods`] was judged and agreed (a corner's wide
    /// band cannot be judged: the lead crosses it on the confirmation just before).
    pub fn confirmed(&self) -> bool {
        self.scale().is_some() && self.agrees && self.since_judged <= self.confirm_periods
    }
}

impl LookAhead {
    /// A new tool or program (`TOOL_NUMBER`, `PROGRAM_NUMBER` of `s`) starts the scale
    /// again: it belongs to the tool measured in the program that ran.
    pub(super) fn forget_scale_of_another_tool(&mut self, s: &BoardStatus) {
        if self.last_tool_program != Some((s.tool_number, s.program_number)) {
            self.last_tool_program = Some((s.tool_number, s.program_number));
            self.scale.clear();
            self.tool_scale = None;
        }
    }

    /// The cut's scale from this period's measurement (`judged`) at `at`. Out of the cut
    /// (a force below the cutting share, unless the plan has the tool in the material
    /// wherever it can be and the force is at least the band's lowest (> 0) less its
    /// relative tolerance; or no valid force), and whenever plan and measurement disagree,
    /// it starts again. Such a force (a slow override through light engagement) is the
    /// same cut: the period is not judged, so the scale stays confirmed for at most
    /// [`LookAheadConfig::scale_confirm_periods`].
    pub(super) fn update_scale(&mut self, at: &Located, judged: &Judged) {
        let fr = self.cfg.force_ref_n;
        let band = judged.band;
        let same_cut = |f: f64| {
            f >= self.cfg.cutting_n()
                || (band.0 > 0.0
                    && f >= band.0 * (1.0 - self.cfg.tolerance)
                    && self.in_material(at.x, at.dx))
        };
        if judged.agree && judged.measured.is_some_and(same_cut) {
            self.scale.update(judged.measured, band, fr);
        } else {
            self.scale.clear();
        }
    }

    /// The tool's scale for its next entries: the cut's, confirmed in a period the lead
    /// could lead, of a tool the board names (`TOOL_NUMBER` 0 is unknown: a tool change
    /// would not show).
    pub(super) fn remember_tool_scale(&mut self, judged: &Judged, s: &BoardStatus) {
        if self.scale.confirmed()
            && judged.measured.is_some_and(|f| self.cfg.lead_may_act_at(f))
            && s.tool_number != 0
        {
            self.tool_scale = self.scale.scale();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_is_the_median_of_known_periods() {
        let mut s = PlanScale::new(&LookAheadConfig::new(0.1, 800.0, 150));
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
}
