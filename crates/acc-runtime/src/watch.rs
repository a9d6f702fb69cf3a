//! Wear and breakage watch: the tool's Kc_hat trend while cutting, and the breakage detector
//! the fault policy consults every period.
//!
//! Two parts with different homes:
//! - [`BreakageDetector`] is pure, allocation-free and fixed-size: the [`crate::FaultPolicy`]
//!   owns one and steps it with every valid force sample (the policy is the one place that
//!   judges a sample). A sudden drop (tool gone) or spike against the tool's own recent
//!   history, while the NC says the cut continues (cycle on, same tool and block, no feed
//!   hold), makes the policy request feed hold in the same period.
//! - [`WearTracker`] follows Kc_hat per tool from the run log's records (steady cut periods
//!   only, median of a window), against the tool's fresh reference, and grades the rise with
//!   the [`WatchLimits`] warn / limit levels. It runs beside the loop (on the logging side or
//!   offline), never inside the 0.1 s step.
//!
//! ```
//! use acc_runtime::watch::{BreakageDetector, BreakageSample, WatchLimits, Breakage};
//! let mut d = BreakageDetector::new(WatchLimits::default());
//! let s = |f: f64| BreakageSample { force_n: f, force_ref_n: 800.0, cycle_active: true,
//!     feed_hold_active: false, tool: 1, block: 20, override_pct: 60 };
//! for _ in 0..12 { assert_eq!(d.observe(&s(800.0)), None); }
//! // The tool broke: the force falls to a tenth within one period.
//! assert!(matches!(d.observe(&s(80.0)), Some(Breakage::Drop { .. })));
//! ```

use crate::record::RunRecord;

/// Wear and breakage limits of one tool. The tool table (issue 14 item 1) carries one per
/// tool; [`WatchLimits::default`] is the default entry. Every field documents its unit and
/// default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchLimits {
    /// Breakage detection on (default true).
    pub breakage_enabled: bool,
    /// Kc_hat rise over the tool's fresh reference that raises a wear warning, percent
    /// (default 25).
    pub wear_warn_pct: f64,
    /// Kc_hat rise over the fresh reference at the wear limit (change the tool), percent
    /// (default 50; ≥ `wear_warn_pct`).
    pub wear_limit_pct: f64,
    /// A force sample more than this far below the median of the recent history is a
    /// breakage (tool gone), percent (default 60: below 0.4 × the median).
    pub breakage_drop_pct: f64,
    /// A force sample above this factor × the median of the recent history is a breakage
    /// (chipped insert, crash), 1 (default 3.0: a hard spot of 2.5 × Ks is ridden by the
    /// controller, as in the fault matrix).
    pub breakage_spike_factor: f64,
    /// Periods of steady cut the history must hold before a sample is judged (default 10,
    /// 1 s at T = 0.1 s; at most [`BreakageDetector::CAPACITY`]).
    pub breakage_history_periods: u32,
    /// A period counts as cutting when the force is at least this fraction of Fr (default
    /// 0.25). The history must be all cutting periods.
    pub cut_force_fraction: f64,
    /// A period is a steady cut for the wear trend when |F − Fr| ≤ this share of Fr,
    /// percent (default 15).
    pub steady_band_pct: f64,
    /// Steady periods per wear sample (their Kc_hat median is one point of the trend;
    /// default 30 = 3 s at T = 0.1 s).
    pub wear_window_periods: u32,
}

impl Default for WatchLimits {
    fn default() -> Self {
        WatchLimits {
            breakage_enabled: true,
            wear_warn_pct: 25.0,
            wear_limit_pct: 50.0,
            breakage_drop_pct: 60.0,
            breakage_spike_factor: 3.0,
            breakage_history_periods: 10,
            cut_force_fraction: 0.25,
            steady_band_pct: 15.0,
            wear_window_periods: 30,
        }
    }
}

impl WatchLimits {
    /// These limits with the wear and breakage levels of a tool-table entry (`wear_warn_pct`,
    /// `wear_limit_pct`, `breakage_drop_pct`, `breakage_spike_x`); the rest is kept.
    pub fn with_tool(self, t: &acc_config::ToolLimits) -> Self {
        Self {
            wear_warn_pct: t.wear_warn_pct,
            wear_limit_pct: t.wear_limit_pct,
            breakage_drop_pct: t.breakage_drop_pct,
            breakage_spike_factor: t.breakage_spike_x,
            ..self
        }
    }

    /// Check every field; the error names the key (as in a `[watch]` table) and the range.
    pub fn validate(&self) -> Result<(), acc_config::RangeError> {
        use acc_config::RangeError;
        let fin = |x: f64| x.is_finite();
        if !(fin(self.wear_warn_pct) && self.wear_warn_pct > 0.0 && self.wear_warn_pct <= 1000.0) {
            return Err(RangeError::new(
                "wear_warn_pct",
                self.wear_warn_pct.to_string(),
                "0 < x <= 1000",
            ));
        }
        if !(fin(self.wear_limit_pct)
            && self.wear_limit_pct >= self.wear_warn_pct
            && self.wear_limit_pct <= 1000.0)
        {
            return Err(RangeError::new(
                "wear_limit_pct",
                self.wear_limit_pct.to_string(),
                "wear_warn_pct <= x <= 1000",
            ));
        }
        if !(fin(self.breakage_drop_pct)
            && self.breakage_drop_pct > 0.0
            && self.breakage_drop_pct < 100.0)
        {
            return Err(RangeError::new(
                "breakage_drop_pct",
                self.breakage_drop_pct.to_string(),
                "0 < x < 100",
            ));
        }
        if !(fin(self.breakage_spike_factor)
            && self.breakage_spike_factor > 1.0
            && self.breakage_spike_factor <= 100.0)
        {
            return Err(RangeError::new(
                "breakage_spike_factor",
                self.breakage_spike_factor.to_string(),
                "1 < x <= 100",
            ));
        }
        if self.breakage_history_periods < 3
            || self.breakage_history_periods as usize > BreakageDetector::CAPACITY
        {
            return Err(RangeError::new(
                "breakage_history_periods",
                self.breakage_history_periods.to_string(),
                "3 ..= 32",
            ));
        }
        if !(fin(self.cut_force_fraction)
            && self.cut_force_fraction > 0.0
            && self.cut_force_fraction < 1.0)
        {
            return Err(RangeError::new(
                "cut_force_fraction",
                self.cut_force_fraction.to_string(),
                "0 < x < 1",
            ));
        }
        if !(fin(self.steady_band_pct)
            && self.steady_band_pct > 0.0
            && self.steady_band_pct <= 100.0)
        {
            return Err(RangeError::new(
                "steady_band_pct",
                self.steady_band_pct.to_string(),
                "0 < x <= 100",
            ));
        }
        if self.wear_window_periods == 0 || self.wear_window_periods > 10_000 {
            return Err(RangeError::new(
                "wear_window_periods",
                self.wear_window_periods.to_string(),
                "1 ..= 10000",
            ));
        }
        Ok(())
    }
}

/// `[watch]` table of a run config or scenario: every key optional, defaults of
/// [`WatchLimits`]; `history` is the tool-history file (relative to the config file;
/// default `acc-history.sqlite` beside the run log).
#[derive(Debug, Clone, serde::Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct WatchSection {
    /// Tool-history SQLite file, relative to the config file.
    pub history: Option<std::path::PathBuf>,
    /// [`WatchLimits::breakage_enabled`].
    pub breakage: Option<bool>,
    /// [`WatchLimits::wear_warn_pct`], percent.
    pub wear_warn_pct: Option<f64>,
    /// [`WatchLimits::wear_limit_pct`], percent.
    pub wear_limit_pct: Option<f64>,
    /// [`WatchLimits::breakage_drop_pct`], percent.
    pub breakage_drop_pct: Option<f64>,
    /// [`WatchLimits::breakage_spike_factor`], 1.
    pub breakage_spike_factor: Option<f64>,
    /// [`WatchLimits::breakage_history_periods`], periods.
    pub breakage_history_periods: Option<u32>,
    /// [`WatchLimits::cut_force_fraction`], 1.
    pub cut_force_fraction: Option<f64>,
    /// [`WatchLimits::steady_band_pct`], percent.
    pub steady_band_pct: Option<f64>,
    /// [`WatchLimits::wear_window_periods`], periods.
    pub wear_window_periods: Option<u32>,
}

impl WatchSection {
    /// The limits (defaults for the keys not given), validated; errors name `file` and
    /// `watch.<key>`.
    pub fn resolve(&self, file: &std::path::Path) -> Result<WatchLimits, acc_config::ConfigError> {
        let d = WatchLimits::default();
        let l = WatchLimits {
            breakage_enabled: self.breakage.unwrap_or(d.breakage_enabled),
            wear_warn_pct: self.wear_warn_pct.unwrap_or(d.wear_warn_pct),
            wear_limit_pct: self.wear_limit_pct.unwrap_or(d.wear_limit_pct),
            breakage_drop_pct: self.breakage_drop_pct.unwrap_or(d.breakage_drop_pct),
            breakage_spike_factor: self
                .breakage_spike_factor
                .unwrap_or(d.breakage_spike_factor),
            breakage_history_periods: self
                .breakage_history_periods
                .unwrap_or(d.breakage_history_periods),
            cut_force_fraction: self.cut_force_fraction.unwrap_or(d.cut_force_fraction),
            steady_band_pct: self.steady_band_pct.unwrap_or(d.steady_band_pct),
            wear_window_periods: self.wear_window_periods.unwrap_or(d.wear_window_periods),
        };
        l.validate()
            .map_err(|e| acc_config::ConfigError::OutOfRange(e.prefixed("watch").in_file(file)))?;
        Ok(l)
    }

    /// The history file: `history` relative to `file`, else `default`.
    pub fn history_path(
        &self,
        file: &std::path::Path,
        default: std::path::PathBuf,
    ) -> std::path::PathBuf {
        self.history
            .as_ref()
            .map_or(default, |h| acc_config::resolve_relative(file, h))
    }
}

/// What the breakage detector saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Breakage {
    /// The force fell below `(1 − breakage_drop_pct/100)` × the recent median (tool gone).
    Drop {
        /// The sample, N.
        force_n: f64,
        /// Median of the recent history, N.
        reference_n: f64,
    },
    /// The force rose above `breakage_spike_factor` × the recent median.
    Spike {
        /// The sample, N.
        force_n: f64,
        /// Median of the recent history, N.
        reference_n: f64,
    },
}

impl Breakage {
    /// `drop` or `spike`.
    pub fn kind(&self) -> &'static str {
        match self {
            Breakage::Drop { .. } => "drop",
            Breakage::Spike { .. } => "spike",
        }
    }
}

/// One period as the breakage detector sees it (the policy builds it from the status and
/// the force sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BreakageSample {
    /// Valid force sample of the period, N.
    pub force_n: f64,
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// The NC runs the program (`CYCLE_ACTIVE`).
    pub cycle_active: bool,
    /// The axes are held (`FEED_HOLD_ACTIVE`): a falling force is expected then.
    pub feed_hold_active: bool,
    /// `TOOL_NUMBER` (0: unknown).
    pub tool: u16,
    /// `BLOCK_NUMBER` (0: unknown). A drop is judged only while the board reports the block
    /// (the NC says the cut continues in the same block); a spike always.
    pub block: u16,
    /// Override in force (`OVERRIDE_APPLIED`), percent. A drop is judged only when it is at
    /// least 0.8 × its value two periods back (the feed was not cut: an operator turning the
    /// knob down is no breakage), a spike only when it is at most 1.25 × that + 10 %.
    pub override_pct: u16,
}

/// Breakage detector: a ring of the last [`WatchLimits::breakage_history_periods`] force
/// samples of the current (tool, block), judged against their median. Fixed size, no
/// allocation (it runs inside the policy's step).
#[derive(Debug, Clone)]
pub struct BreakageDetector {
    limits: WatchLimits,
    ring: [f64; BreakageDetector::CAPACITY],
    len: usize,
    head: usize,
    context: Option<(u16, u16)>,
    /// Applied override of the last [`BreakageDetector::LAG_PERIODS`] periods (newest last),
    /// percent.
    overrides: [u16; BreakageDetector::LAG_PERIODS],
}

impl BreakageDetector {
    /// Largest history, periods.
    pub const CAPACITY: usize = 32;

    /// How far back an override change can still explain a change of force, periods
    /// (0.6 s at T = 0.1 s: the feed drive's lag and the NC's override delay). A drop is a
    /// breakage only if the applied override was not lowered by more than 20 % anywhere in
    /// this window, a spike only if it was not raised by more than 25 %: a loop that
    /// oscillates through a slow feed path (override cut, force falls three periods later)
    /// is not a broken tool.
    pub const LAG_PERIODS: usize = 6;

    /// A detector with an empty history.
    pub fn new(limits: WatchLimits) -> Self {
        BreakageDetector {
            limits,
            ring: [0.0; Self::CAPACITY],
            len: 0,
            head: 0,
            context: None,
            overrides: [0; Self::LAG_PERIODS],
        }
    }

    /// The limits in use.
    pub fn limits(&self) -> &WatchLimits {
        &self.limits
    }

    /// New limits (a tool change through the tool table); the history is kept.
    pub fn set_limits(&mut self, limits: WatchLimits) {
        self.limits = limits;
    }

    /// Forget the history (air, a new block or tool, a feed hold).
    pub fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
    }

    fn history_len(&self) -> usize {
        (self.limits.breakage_history_periods as usize).clamp(3, Self::CAPACITY)
    }

    /// Ring size: the reference plus the last two samples.
    fn ring_len(&self) -> usize {
        self.history_len() + 2
    }

    fn push(&mut self, f: f64) {
        let n = self.ring_len();
        self.ring[self.head % n] = f;
        self.head = (self.head + 1) % n;
        self.len = (self.len + 1).min(n);
    }

    /// The sample `back` periods before the newest (0: newest).
    fn back(&self, back: usize) -> f64 {
        let n = self.ring_len();
        self.ring[(self.head + n - 1 - back) % n]
    }

    /// Median and minimum of the reference (the ring without its two newest samples; full
    /// ring only), and the sample two periods back from the one being judged.
    fn median_min(&self) -> Option<(f64, f64, f64)> {
        let n = self.history_len();
        if self.len < self.ring_len() {
            return None;
        }
        let mut buf = [0.0f64; Self::CAPACITY];
        for (i, slot) in buf.iter_mut().enumerate().take(n) {
            *slot = self.back(2 + i);
        }
        let s = &mut buf[..n];
        s.sort_by(f64::total_cmp);
        let med = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Some((med, s[0], self.back(1)))
    }

    /// Judge one valid sample against the history, then add it. `None`: nothing unusual.
    pub fn observe(&mut self, s: &BreakageSample) -> Option<Breakage> {
        if !self.limits.breakage_enabled {
            return None;
        }
        let ctx = (s.tool, s.block);
        if self.context != Some(ctx) {
            self.context = Some(ctx);
            self.reset();
        }
        let cut_n = self.limits.cut_force_fraction * s.force_ref_n;
        self.overrides.rotate_left(1);
        self.overrides[Self::LAG_PERIODS - 1] = s.override_pct;
        let ov_now = u32::from(s.override_pct);
        let ov_max = self.overrides.iter().copied().max().map_or(0, u32::from);
        let ov_min = self.overrides.iter().copied().min().map_or(0, u32::from);
        let feed_kept = ov_now * 5 >= ov_max * 4;
        let feed_not_raised = ov_now * 4 <= ov_min * 5 + 40;
        if !s.cycle_active || s.feed_hold_active || !s.force_n.is_finite() {
            self.reset();
            return None;
        }
        let mut verdict = None;
        if let Some((med, min, two_back)) = self.median_min() {
            // Judge only against a history of steady cutting.
            if min >= cut_n && med > 0.0 {
                if s.block != 0
                    && feed_kept
                    && s.force_n < med * (1.0 - self.limits.breakage_drop_pct / 100.0)
                    && two_back >= 0.8 * med
                {
                    verdict = Some(Breakage::Drop {
                        force_n: s.force_n,
                        reference_n: med,
                    });
                } else if feed_not_raised && s.force_n > med * self.limits.breakage_spike_factor {
                    verdict = Some(Breakage::Spike {
                        force_n: s.force_n,
                        reference_n: med,
                    });
                }
            }
        }
        if verdict.is_some() {
            self.reset();
        } else if s.force_n >= cut_n {
            self.push(s.force_n);
        } else {
            self.reset();
        }
        verdict
    }
}

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

/// Median of `v` (sorted in place); NaN when empty.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(f: f64, block: u16) -> BreakageSample {
        BreakageSample {
            force_n: f,
            force_ref_n: 800.0,
            cycle_active: true,
            feed_hold_active: false,
            tool: 1,
            block,
            override_pct: 60,
        }
    }

    #[test]
    fn drop_and_spike_against_history() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for i in 0..12 {
            assert_eq!(d.observe(&s(800.0 + f64::from(i), 10)), None);
        }
        assert_eq!(d.observe(&s(700.0, 10)), None, "a 12 % dip is no breakage");
        assert!(matches!(
            d.observe(&s(2500.0, 10)),
            Some(Breakage::Spike { .. })
        ));
        // After a verdict the history starts again.
        assert_eq!(d.observe(&s(50.0, 10)), None);
    }

    #[test]
    fn a_gradual_exit_is_no_breakage_but_a_two_period_fall_is() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        // The tool leaves the workpiece over 8 periods.
        for f in [760.0, 700.0, 620.0, 530.0, 430.0, 330.0, 240.0, 150.0] {
            assert_eq!(d.observe(&s(f, 40)), None, "{f}");
        }
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        assert_eq!(
            d.observe(&s(450.0, 40)),
            None,
            "the break inside the period"
        );
        assert!(matches!(
            d.observe(&s(40.0, 40)),
            Some(Breakage::Drop { .. })
        ));
    }

    #[test]
    fn the_operator_cutting_the_feed_is_no_breakage() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 40));
        }
        // Knob from 60 % to 20 %: the force follows within a period.
        let knob = |f: f64| BreakageSample {
            override_pct: 20,
            ..s(f, 40)
        };
        for f in [260.0, 250.0, 255.0, 262.0] {
            assert_eq!(d.observe(&knob(f)), None, "{f}");
        }
    }

    #[test]
    fn no_verdict_without_steady_history_or_block() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        // Entry: air then cut in a new block; the history is not steady yet.
        for f in [0.0, 5.0, 300.0, 900.0, 1000.0] {
            assert_eq!(d.observe(&s(f, 20)), None);
        }
        // Unknown block: a drop is not judged (the cut may have ended).
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 0));
        }
        assert_eq!(d.observe(&s(10.0, 0)), None);
        // A block change resets the history.
        let mut d = BreakageDetector::new(WatchLimits::default());
        for _ in 0..12 {
            d.observe(&s(800.0, 10));
        }
        assert_eq!(d.observe(&s(10.0, 20)), None);
    }

    #[test]
    fn limits_validate_name_the_key() {
        let bad = WatchLimits {
            wear_limit_pct: 10.0,
            ..WatchLimits::default()
        };
        let e = bad.validate().expect_err("limit below warn");
        assert!(e.to_string().contains("wear_limit_pct"), "{e}");
        assert!(WatchLimits::default().validate().is_ok());
    }

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

    #[test]
    fn a_force_fall_explained_by_an_override_cut_a_few_periods_back_is_no_breakage() {
        let mut d = BreakageDetector::new(WatchLimits::default());
        let at = |f: f64, ov: u16| BreakageSample {
            override_pct: ov,
            ..s(f, 10)
        };
        for i in 0..12 {
            assert_eq!(d.observe(&at(800.0 + f64::from(i), 90)), None);
        }
        // The loop cuts the override hard; the force follows three periods later (a slow
        // feed path), and falls by 80 % while the override is already low and kept.
        for (f, ov) in [
            (1200.0, 50),
            (1200.0, 20),
            (1200.0, 10),
            (731.0, 10),
            (407.0, 20),
        ] {
            assert_eq!(d.observe(&at(f, ov)), None);
        }
        assert_eq!(d.observe(&at(165.0, 20)), None);
    }
}
