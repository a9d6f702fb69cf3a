//! Wear and breakage watch: the tool's Kc_hat trend while cutting, and the breakage detector
//! the fault policy consults every period.
//!
//! Two parts with different homes (one file each; this one holds the limits they share):
//! - [`BreakageDetector`] (`watch/breakage.rs`) is pure, allocation-free and fixed-size: the [`crate::FaultPolicy`]
//!   owns one and steps it with every valid force sample (the policy is the one place that
//!   judges a sample). A sudden drop (tool gone) or spike against the tool's own recent
//!   history, while the NC says the cut continues (cycle on, same tool and block, no feed
//!   hold), makes the policy request feed hold in the same period.
//! - [`WearTracker`] (`watch/wear.rs`) follows Kc_hat per tool from the run log's records (steady cut periods
//!   only, median of a window), against the tool's fresh reference, and grades the rise with
//!   the [`WatchLimits`] warn / limit levels. It runs beside the loop (on the logging side or
//!   offline), never inside the 0.1 s step.
//!
//! ```
//! use acc_runtime::watch::{BreakageDetector, BreakageSample, WatchLimits, Breakage};
//! let mut d = BreakageDetector::new(WatchLimits::default());
//! let s = |f: f64| BreakageSample { force_n: f, force_ref_n: 800.0, cycle_active: true,
//!     feed_hold_active: false, tool: 1, block: 20, block_settled: true, override_pct: 60 };
//! for _ in 0..12 { assert_eq!(d.observe(&s(800.0)), None); }
//! // The tool broke: the force falls to a tenth within one period.
//! assert!(matches!(d.observe(&s(80.0)), Some(Breakage::Drop { .. })));
//! ```

mod breakage;
mod wear;

pub use breakage::{Breakage, BreakageDetector, BreakageSample};
pub use wear::{RefKey, WearLevel, WearSample, WearTracker, CONDITION_STEP_PCT};

/// Wear and breakage limits of one tool. The tool table carries one per tool;
/// [`WatchLimits::default`] is the default entry. Every field documents its unit and default.
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
        let within = |x: f64, lo: f64, hi: f64| x.is_finite() && x > lo && x < hi;
        let checks = [
            (
                within(self.wear_warn_pct, 0.0, f64::INFINITY) && self.wear_warn_pct <= 1000.0,
                "wear_warn_pct",
                self.wear_warn_pct,
                "0 < x <= 1000",
            ),
            (
                self.wear_limit_pct.is_finite()
                    && self.wear_limit_pct >= self.wear_warn_pct
                    && self.wear_limit_pct <= 1000.0,
                "wear_limit_pct",
                self.wear_limit_pct,
                "wear_warn_pct <= x <= 1000",
            ),
            (
                within(self.breakage_drop_pct, 0.0, 100.0),
                "breakage_drop_pct",
                self.breakage_drop_pct,
                "0 < x < 100",
            ),
            (
                within(self.breakage_spike_factor, 1.0, f64::INFINITY)
                    && self.breakage_spike_factor <= 100.0,
                "breakage_spike_factor",
                self.breakage_spike_factor,
                "1 < x <= 100",
            ),
            (
                self.breakage_history_periods >= 3
                    && self.breakage_history_periods as usize <= BreakageDetector::CAPACITY,
                "breakage_history_periods",
                f64::from(self.breakage_history_periods),
                "3 ..= 32",
            ),
            (
                within(self.cut_force_fraction, 0.0, 1.0),
                "cut_force_fraction",
                self.cut_force_fraction,
                "0 < x < 1",
            ),
            (
                within(self.steady_band_pct, 0.0, f64::INFINITY) && self.steady_band_pct <= 100.0,
                "steady_band_pct",
                self.steady_band_pct,
                "0 < x <= 100",
            ),
            (
                (1..=10_000).contains(&self.wear_window_periods),
                "wear_window_periods",
                f64::from(self.wear_window_periods),
                "1 ..= 10000",
            ),
        ];
        match checks.into_iter().find(|c| !c.0) {
            Some((_, key, value, allowed)) => Err(RangeError::new(key, value, allowed)),
            None => Ok(()),
        }
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
}
