//! The wear trend: Kc_hat per tool from run-log records, graded against the tool's fresh
//! reference (one concern of [`crate::watch`]; runs beside the loop, never inside its step).

use super::{median, WatchLimits};
use crate::record::RunRecord;

/// Wear grade of a Kc_hat rise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum WearLevel {
    /// Below the warning level.
    Ok,
    /// At or above `wear_warn_pct`.
    Warn,
    /// At or above `wear_limit_pct`.
    Limit,
}

impl WearLevel {
    /// `ok`, `warn`, `limit`.
    pub fn as_str(self) -> &'static str {
        match self {
            WearLevel::Ok => "ok",
            WearLevel::Warn => "warn",
            WearLevel::Limit => "limit",
        }
    }

    /// Grade `rise_pct` with `limits`.
    pub fn grade(rise_pct: f64, limits: &WatchLimits) -> WearLevel {
        if rise_pct >= limits.wear_limit_pct {
            WearLevel::Limit
        } else if rise_pct >= limits.wear_warn_pct {
            WearLevel::Warn
        } else {
            WearLevel::Ok
        }
    }
}

/// One point of a tool's Kc trend.
#[derive(Debug, Clone, PartialEq)]
pub struct WearSample {
    /// Tool number (0: unknown).
    pub tool: u16,
    /// Program number (0: unknown).
    pub program: u16,
    /// Block number of the window's last period (0: unknown).
    pub block: u16,
    /// Time of the window's last period, s since the run began.
    pub t_s: f64,
    /// Path position of the window's last period, mm.
    pub x_mm: f64,
    /// Median Kc_hat of the window, N/(mm/min).
    pub kc: f64,
    /// The tool's fresh reference, N/(mm/min).
    pub kc_ref: f64,
    /// Rise over the reference, percent.
    pub rise_pct: f64,
    /// Grade.
    pub level: WearLevel,
}

/// Key of a fresh reference: (tool, program, block). Kc_hat depends on the engagement as
/// well as on the edge, so a reference is kept per tool *and* cut (program, block); a
/// machine that does not report the program and block has one reference per tool.
pub type RefKey = (u16, u16, u16);

/// Follows Kc_hat per tool from run-log records: the median of `wear_window_periods` steady
/// cut periods is one [`WearSample`]; the first sample of a (tool, program, block) is its
/// fresh reference unless one is known ([`WearTracker::set_reference`], e.g. from the
/// history database).
#[derive(Debug, Clone, Default)]
pub struct WearTracker {
    limits: WatchLimits,
    per_tool: std::collections::BTreeMap<u16, WatchLimits>,
    refs: std::collections::BTreeMap<RefKey, f64>,
    /// The last trend point of each cut in this run (a step against it is a new cut
    /// condition, not wear).
    last: std::collections::BTreeMap<RefKey, f64>,
    window: Vec<f64>,
    key: Option<RefKey>,
}

/// A change of Kc_hat between two consecutive trend points of one cut larger than this,
/// percent, is a change of the cut condition (depth, width, material: the same NC block can
/// cut a step), not wear, which grows by far less in one window (3 s): the fresh reference is
/// moved with the step, keeping the rise accumulated before it. Across runs (a reference from
/// the history) there is no previous point, so a tool that comes back worn still counts.
pub const CONDITION_STEP_PCT: f64 = 10.0;

impl WearTracker {
    /// A tracker with `limits` for every tool.
    pub fn new(limits: WatchLimits) -> Self {
        WearTracker {
            limits,
            ..Default::default()
        }
    }

    /// Limits of one tool (the tool table's entry).
    pub fn set_tool_limits(&mut self, tool: u16, limits: WatchLimits) {
        self.per_tool.insert(tool, limits);
    }

    fn limits_for(&self, tool: u16) -> WatchLimits {
        self.per_tool.get(&tool).copied().unwrap_or(self.limits)
    }

    /// A known fresh reference (from an earlier run).
    pub fn set_reference(&mut self, key: RefKey, kc: f64) {
        self.refs.insert(key, kc);
    }

    /// The fresh references so far.
    pub fn references(&self) -> &std::collections::BTreeMap<RefKey, f64> {
        &self.refs
    }

    /// Whether `rec` is a steady cut period for the trend.
    pub fn is_steady(rec: &RunRecord, limits: &WatchLimits) -> bool {
        let (Some(f), Some(fr), Some(kc)) = (rec.force_n, rec.force_ref_n, rec.kc_hat) else {
            return false;
        };
        rec.force_valid
            && rec.state == "active"
            && rec.saturation == "none"
            && fr > 0.0
            && kc.is_finite()
            && kc > 0.0
            && (f - fr).abs() <= limits.steady_band_pct / 100.0 * fr
    }

    /// Feed one record; returns a trend point when a window completes.
    pub fn observe(&mut self, rec: &RunRecord) -> Option<WearSample> {
        let key = (
            rec.tool.unwrap_or(0),
            rec.program.unwrap_or(0),
            rec.block.unwrap_or(0),
        );
        if self.key != Some(key) {
            self.key = Some(key);
            self.window.clear();
        }
        let limits = self.limits_for(key.0);
        if !Self::is_steady(rec, &limits) {
            return None;
        }
        self.window.extend(rec.kc_hat);
        if self.window.len() < limits.wear_window_periods as usize {
            return None;
        }
        let kc = median(&mut self.window);
        self.window.clear();
        let mut kc_ref = *self.refs.entry(key).or_insert(kc);
        if let Some(prev) = self.last.insert(key, kc) {
            if (kc / prev - 1.0).abs() * 100.0 > CONDITION_STEP_PCT {
                // Keep the wear accumulated so far: rise(after) = rise(before the step).
                kc_ref *= kc / prev;
                self.refs.insert(key, kc_ref);
            }
        }
        let rise_pct = (kc / kc_ref - 1.0) * 100.0;
        Some(WearSample {
            tool: key.0,
            program: key.1,
            block: key.2,
            t_s: rec.t_s,
            x_mm: rec.x_mm.unwrap_or(f64::NAN),
            kc,
            kc_ref,
            rise_pct,
            level: WearLevel::grade(rise_pct, &limits),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steady(t: f64, kc: f64) -> RunRecord {
        RunRecord {
            t_s: t,
            tool: Some(3),
            program: Some(1000),
            block: Some(20),
            x_mm: Some(t),
            force_n: Some(805.0),
            force_valid: true,
            force_ref_n: Some(800.0),
            kc_hat: Some(kc),
            state: "active".into(),
            saturation: "none".into(),
            ..RunRecord::default()
        }
    }

    #[test]
    fn wear_trend_grades_the_rise() {
        let mut w = WearTracker::new(WatchLimits::default());
        let mut out = Vec::new();
        for i in 0..300 {
            let kc = 6.0 * (1.0 + 0.6 * f64::from(i) / 300.0);
            out.extend(w.observe(&steady(f64::from(i) * 0.1, kc)));
        }
        assert_eq!(out.len(), 10);
        assert!(
            out[0].rise_pct.abs() < 1e-9,
            "first window is the reference"
        );
        assert_eq!(out[0].level, WearLevel::Ok);
        assert!(out.iter().any(|s| s.level == WearLevel::Warn));
        assert_eq!(out.last().map(|s| s.level), Some(WearLevel::Limit));
        // A non-steady period adds nothing.
        let mut r = steady(100.0, 9.0);
        r.force_n = Some(400.0);
        assert!(!WearTracker::is_steady(&r, &WatchLimits::default()));
    }

    #[test]
    fn a_step_in_the_cut_condition_is_not_wear_but_a_worn_tool_from_the_history_is() {
        // 2 mm then 4 mm in one block (Kc 4 -> 8) with a slow 1 % per window drift: the step
        // moves the reference, the drift stays the rise.
        let mut w = WearTracker::new(WatchLimits::default());
        let mut out = Vec::new();
        for i in 0..300 {
            let depth = if i < 150 { 4.0 } else { 8.0 };
            let kc = depth * (1.0 + 0.01 * f64::from(i / 30));
            out.extend(w.observe(&steady(f64::from(i) * 0.1, kc)));
        }
        assert_eq!(out.len(), 10);
        let last = out.last().expect("points");
        // 9 % of drift, less the one window's drift hidden in the step.
        assert!((7.0..=9.5).contains(&last.rise_pct), "{last:?}");
        assert!(out.iter().all(|s| s.level == WearLevel::Ok), "{out:?}");
        // The same cut in a later run with a worn tool: no previous point in this run, the
        // stored reference stands.
        let mut w = WearTracker::new(WatchLimits::default());
        w.set_reference((3, 1000, 20), 4.0);
        let mut out = Vec::new();
        for i in 0..30 {
            out.extend(w.observe(&steady(f64::from(i) * 0.1, 5.6)));
        }
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].level, WearLevel::Warn, "{out:?}");
    }
}
