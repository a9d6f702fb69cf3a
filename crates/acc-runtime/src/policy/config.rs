//! The fault policy's parameters (`[policy]` of the run config): one concern, their values,
//! defaults and allowed ranges.

/// Parameters of the fault policy. Defaults in each field's doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolicyConfig {
    /// Control period T, s (default 0.1); converts `overload_time_s` into periods.
    pub period_s: f64,
    /// Lowest override ever commanded, percent (default 0).
    pub min_override_pct: u16,
    /// Highest override ever commanded, percent (default 150, never above 150).
    pub max_override_pct: u16,
    /// Consecutive link failures during which the last override is held (default 5).
    pub link_hold_periods: u32,
    /// Consecutive invalid or stale power samples tolerated before release (default 5).
    pub invalid_power_periods: u32,
    /// `SAMPLE_SEQ` unchanged for this many periods ⇒ the power sensor is stale (default 3).
    pub stale_seq_periods: u32,
    /// Periods after arming within which the board must report `ACC_ACTIVE` (default 3).
    pub ack_periods: u32,
    /// Overload force limit, N (default 1600, twice the paper's Fr).
    pub overload_force_n: f64,
    /// Time above the overload limit before feed hold, s (default 0.3), counted in periods
    /// T from the first period above: see [`PolicyConfig::overload_periods`].
    pub overload_time_s: f64,
    /// Operator knob turned down by more than this from its highest position since arming
    /// hands control back, percent (default 10).
    pub operator_handback_pct: u16,
    /// Largest plausible spindle power, W (default 30 000); above it the sample is invalid.
    pub max_power_w: f64,
    /// Feed assumed when the board reports `PROGRAMMED_FEED` = 0 (unknown), mm/min
    /// (default 200, the paper's nominal feed).
    pub nominal_feed_mm_min: f64,
    /// On a release while the NC is not cutting (`CYCLE_ACTIVE` off), request feed hold if
    /// the operator's knob is above the last command (default true). A release mid-cut
    /// that is not the operator's always requests feed hold.
    pub hold_on_raising_release: bool,
    /// Consecutive reads a changed register must hold before it counts, 1 ..= 10 (default
    /// 2; 1 = no debounce): see [`crate::guard`].
    pub debounce_reads: u32,
    /// Largest plausible change of the spindle power between two samples, W (default
    /// 2 000); a larger one is held a period for confirmation.
    pub max_power_step_w: f64,
    /// Largest plausible change of the spindle speed between two samples, rpm (default
    /// 1 000).
    pub max_rpm_step: f64,
}

impl Default for PolicyConfig {
    fn default() -> Self {
        Self {
            period_s: 0.1,
            min_override_pct: 0,
            max_override_pct: 150,
            link_hold_periods: 5,
            invalid_power_periods: 5,
            stale_seq_periods: 3,
            ack_periods: 3,
            overload_force_n: 1600.0,
            overload_time_s: 0.3,
            operator_handback_pct: 10,
            max_power_w: 30_000.0,
            nominal_feed_mm_min: 200.0,
            hold_on_raising_release: true,
            debounce_reads: 2,
            max_power_step_w: 2_000.0,
            max_rpm_step: 1_000.0,
        }
    }
}

/// A policy parameter outside its allowed range: the workspace's one
/// [`acc_config::RangeError`], keyed as in the `[policy]` table of the run config (the run
/// config loader prefixes `policy.` and names the file).
pub type PolicyConfigError = acc_config::RangeError;

impl PolicyConfig {
    /// Check every field; the error names the key and the allowed range.
    pub fn validate(&self) -> Result<(), PolicyConfigError> {
        fn err(
            key: &'static str,
            value: impl ToString,
            allowed: &'static str,
        ) -> PolicyConfigError {
            PolicyConfigError::new(key, value.to_string(), allowed)
        }
        let finite_pos = |x: f64| x.is_finite() && x > 0.0;
        if !(finite_pos(self.period_s) && self.period_s <= 10.0) {
            return Err(err("period_s", self.period_s, "0 < x <= 10"));
        }
        if self.max_override_pct > 150 || self.max_override_pct == 0 {
            return Err(err("max_override_pct", self.max_override_pct, "1 ..= 150"));
        }
        if self.min_override_pct > self.max_override_pct {
            return Err(err(
                "min_override_pct",
                self.min_override_pct,
                "0 ..= max_override_pct",
            ));
        }
        // Counts of tolerated faults are at least 1: 0 would release on a single CRC error or
        // a single bad sample, and a release mid-cut on a board without the fallback clamp
        // hands the feed back to the operator's (higher) knob.
        for (key, count) in [
            ("link_hold_periods", self.link_hold_periods),
            ("invalid_power_periods", self.invalid_power_periods),
            ("stale_seq_periods", self.stale_seq_periods),
            ("ack_periods", self.ack_periods),
        ] {
            if !(1..=1000).contains(&count) {
                return Err(err(key, count, "1 ..= 1000"));
            }
        }
        if !finite_pos(self.overload_force_n) {
            return Err(err("overload_force_n", self.overload_force_n, "> 0"));
        }
        if !(self.overload_time_s.is_finite() && self.overload_time_s >= 0.0) {
            return Err(err("overload_time_s", self.overload_time_s, ">= 0"));
        }
        if self.operator_handback_pct > 150 {
            return Err(err(
                "operator_handback_pct",
                self.operator_handback_pct,
                "0 ..= 150",
            ));
        }
        if !finite_pos(self.max_power_w) {
            return Err(err("max_power_w", self.max_power_w, "> 0"));
        }
        if !finite_pos(self.nominal_feed_mm_min) {
            return Err(err("nominal_feed_mm_min", self.nominal_feed_mm_min, "> 0"));
        }
        if !(1..=10).contains(&self.debounce_reads) {
            return Err(err("debounce_reads", self.debounce_reads, "1 ..= 10"));
        }
        if !(finite_pos(self.max_power_step_w) && self.max_power_step_w <= self.max_power_w) {
            return Err(err(
                "max_power_step_w",
                self.max_power_step_w,
                "0 < x <= max_power_w",
            ));
        }
        if !finite_pos(self.max_rpm_step) {
            return Err(err("max_rpm_step", self.max_rpm_step, "> 0"));
        }
        Ok(())
    }

    /// The line guard's limits ([`crate::guard`]) from this policy's keys.
    pub fn guard(&self) -> crate::guard::GuardConfig {
        crate::guard::GuardConfig {
            debounce_reads: self.debounce_reads,
            max_power_w: self.max_power_w,
            max_power_step_w: self.max_power_step_w,
            max_rpm_step: self.max_rpm_step,
        }
    }

    /// Consecutive periods above `overload_force_n` that trip the feed hold:
    /// `ceil(overload_time_s / period_s) + 1`. The first period above only shows that the
    /// force crossed the limit somewhere in it; `overload_time_s` is counted from that
    /// period's end, in whole periods T. With the defaults (0.3 s, T = 0.1 s): 4 periods;
    /// with `overload_time_s` = 0: the first period above.
    pub fn overload_periods(&self) -> u32 {
        // The tolerance keeps 0.9 s / 0.3 s at 3 periods of time, not 4, despite rounding.
        let after_first = (self.overload_time_s / self.period_s - 1e-9).ceil();
        if after_first.is_finite() && after_first >= 1.0 {
            (after_first.min(f64::from(u32::MAX - 1)) as u32) + 1
        } else {
            1
        }
    }
}
