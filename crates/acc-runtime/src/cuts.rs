//! Per-cut records: one [`CutRecord`] per cut, computed by one piece of code
//! ([`CutRecorder`]) from a stream of [`RunRecord`]s — live (the logging side of `acc run`)
//! and offline (`acc report` on a run log).
//!
//! A **cut** is a run of contiguous cutting periods with the same tool and program; its
//! block range is the first and last block seen. A period is *cutting* when its force sample
//! is valid and at least [`CutRecorder::cut_force_fraction`] × Fr; a cut ends after
//! [`CutRecorder::gap_periods`] periods that are not cutting (a short dip does not split a
//! cut), or at once when the tool or program changes.
//!
//! Time saved against the programmed feed: the path a period covered at the applied override
//! `ov` would take `T · ov/100` at 100 %, so a period saves `T · (ov/100 − 1)` (negative when
//! ACC ran slower than programmed); a cut's time saved is the sum over its periods.
//!
//! ```
//! use acc_runtime::cuts::CutRecorder;
//! use acc_runtime::RunRecord;
//! let mut rec = CutRecorder::new(0.1);
//! let row = |t: f64, f: f64, ov: u16| RunRecord {
//!     t_s: t, tool: Some(1), program: Some(1000), block: Some(20), x_mm: Some(t),
//!     force_n: Some(f), force_valid: true, force_ref_n: Some(800.0),
//!     override_applied_pct: Some(ov), ..RunRecord::default() };
//! let mut cuts = Vec::new();
//! for i in 0..10 { cuts.extend(rec.push(&row(f64::from(i) * 0.1, 800.0, 150))); }
//! for i in 10..20 { cuts.extend(rec.push(&row(f64::from(i) * 0.1, 0.0, 150))); }
//! cuts.extend(rec.finish());
//! assert_eq!(cuts.len(), 1);
//! assert!((cuts[0].time_in_cut_s - 1.0).abs() < 1e-9);
//! assert!((cuts[0].time_saved_s - 0.5).abs() < 1e-9); // 10 periods at 150 %
//! ```

use crate::record::RunRecord;

/// Alarm names by run-log bit (see [`RunRecord::alarms`]).
pub const ALARM_NAMES: [&str; 6] = [
    "link_lost",
    "power_invalid",
    "watchdog",
    "board_reset",
    "overload",
    "breakage",
];

/// Names of the alarm bits set in `bits`.
pub fn alarm_names(bits: u8) -> Vec<&'static str> {
    ALARM_NAMES
        .iter()
        .enumerate()
        .filter(|(i, _)| bits & (1u8 << i) != 0)
        .map(|(_, n)| *n)
        .collect()
}

/// One cut.
#[derive(Debug, Clone, PartialEq)]
pub struct CutRecord {
    /// Tool number (0: unknown).
    pub tool: u16,
    /// Program number (0: unknown).
    pub program: u16,
    /// First block of the cut (0: unknown).
    pub block_first: u16,
    /// Last block of the cut (0: unknown).
    pub block_last: u16,
    /// Time of the first cutting period, s since the run began.
    pub t_start_s: f64,
    /// Time of the last cutting period, s.
    pub t_end_s: f64,
    /// Path position at the first cutting period, mm.
    pub x_start_mm: f64,
    /// Path position at the last cutting period, mm.
    pub x_end_mm: f64,
    /// Time in cut: cutting periods × T, s.
    pub time_in_cut_s: f64,
    /// Mean force over the cutting periods, N.
    pub force_mean_n: f64,
    /// Largest force, N.
    pub force_max_n: f64,
    /// RMS of F − Fr over the cutting periods, N.
    pub force_rms_error_n: f64,
    /// Force reference Fr (of the last cutting period), N.
    pub force_ref_n: f64,
    /// Bin width of the override histogram, percent (10, or 1 when the log shows a 1 %
    /// board).
    pub hist_bin_pct: u16,
    /// Periods per override bin: bin `i` holds applied overrides in
    /// `[i·bin, (i+1)·bin)`, the last bin 150 %. Sums to the number of cutting periods.
    pub override_hist: Vec<u32>,
    /// Alarm bits seen during the cut and the gap that closed it (OR of the rows'
    /// `alarms`).
    pub alarm_bits: u8,
    /// Alarms of the watch beside the loop raised during the cut (`wear_warn`,
    /// `wear_limit`), in order, each once.
    pub watch_alarms: Vec<String>,
    /// Periods with a feed-hold request during the cut (and its closing gap).
    pub feed_hold_periods: u32,
    /// Time at 100 % for the same path minus the actual time, s (negative: slower than
    /// programmed).
    pub time_saved_s: f64,
}

impl CutRecord {
    /// Names of the alarms seen: the run log's alarm bits, then the watch's.
    pub fn alarms(&self) -> Vec<&str> {
        let mut v = alarm_names(self.alarm_bits);
        v.extend(self.watch_alarms.iter().map(String::as_str));
        v
    }

    /// Block range as text (`N20`, `N20–N40`, `?`).
    pub fn block_range(&self) -> String {
        match (self.block_first, self.block_last) {
            (0, 0) => "?".into(),
            (a, b) if a == b => format!("N{a}"),
            (a, b) => format!("N{a}–N{b}"),
        }
    }
}

#[derive(Debug, Clone)]
struct Open {
    rec: CutRecord,
    n: u32,
    sum_f: f64,
    sum_e2: f64,
    gap: u32,
}

/// Builds [`CutRecord`]s from a stream of [`RunRecord`]s.
#[derive(Debug, Clone)]
pub struct CutRecorder {
    period_s: f64,
    /// A period is cutting when its valid force is at least this fraction of Fr (default
    /// 0.25, as [`crate::watch::WatchLimits::cut_force_fraction`]).
    pub cut_force_fraction: f64,
    /// Non-cutting periods that end a cut (default 3).
    pub gap_periods: u32,
    /// Bin width of the override histogram, percent (default 10; set 1 for a 1 % board).
    pub hist_bin_pct: u16,
    open: Option<Open>,
}

impl CutRecorder {
    /// A recorder for a loop of period `period_s` (s).
    pub fn new(period_s: f64) -> Self {
        CutRecorder {
            period_s,
            cut_force_fraction: 0.25,
            gap_periods: 3,
            hist_bin_pct: 10,
            open: None,
        }
    }

    /// As [`CutRecorder::new`] with the histogram bin of `bin_pct` (1 or 10).
    pub fn with_bin_pct(mut self, bin_pct: u16) -> Self {
        self.hist_bin_pct = bin_pct.clamp(1, 150);
        self
    }

    /// Whether `r` is a cutting period.
    pub fn is_cutting(&self, r: &RunRecord) -> bool {
        match (r.force_n, r.force_ref_n) {
            (Some(f), Some(fr)) => {
                r.force_valid && f.is_finite() && fr > 0.0 && f >= self.cut_force_fraction * fr
            }
            _ => false,
        }
    }

    fn bins(&self) -> usize {
        150 / usize::from(self.hist_bin_pct) + 1
    }

    /// Feed one record; returns a cut that ended before it, if any.
    pub fn push(&mut self, r: &RunRecord) -> Option<CutRecord> {
        let tool = r.tool.unwrap_or(0);
        let program = r.program.unwrap_or(0);
        let mut ended = None;
        if let Some(o) = &self.open {
            if o.rec.tool != tool || o.rec.program != program {
                ended = self.close();
            }
        }
        if !self.is_cutting(r) {
            if let Some(o) = self.open.as_mut() {
                // An alarm or a feed hold in the gap belongs to the cut (a breakage drops
                // the force out of the cut in the very period it is raised).
                o.rec.alarm_bits |= r.alarms;
                if r.feed_hold {
                    o.rec.feed_hold_periods += 1;
                }
                o.gap += 1;
                if o.gap >= self.gap_periods {
                    ended = self.close().or(ended);
                }
            }
            return ended;
        }
        let bins = self.bins();
        let o = self.open.get_or_insert_with(|| Open {
            rec: CutRecord {
                tool,
                program,
                block_first: r.block.unwrap_or(0),
                block_last: r.block.unwrap_or(0),
                t_start_s: r.t_s,
                t_end_s: r.t_s,
                x_start_mm: r.x_mm.unwrap_or(f64::NAN),
                x_end_mm: r.x_mm.unwrap_or(f64::NAN),
                time_in_cut_s: 0.0,
                force_mean_n: 0.0,
                force_max_n: f64::NEG_INFINITY,
                force_rms_error_n: 0.0,
                force_ref_n: 0.0,
                hist_bin_pct: self.hist_bin_pct,
                override_hist: vec![0; bins],
                alarm_bits: 0,
                watch_alarms: Vec::new(),
                feed_hold_periods: 0,
                time_saved_s: 0.0,
            },
            n: 0,
            sum_f: 0.0,
            sum_e2: 0.0,
            gap: 0,
        });
        o.gap = 0;
        let f = r.force_n.unwrap_or(0.0);
        let fr = r.force_ref_n.unwrap_or(0.0);
        o.n += 1;
        o.sum_f += f;
        o.sum_e2 += (f - fr) * (f - fr);
        o.rec.force_max_n = o.rec.force_max_n.max(f);
        o.rec.force_ref_n = fr;
        if let Some(b) = r.block.filter(|b| *b != 0) {
            if o.rec.block_first == 0 {
                o.rec.block_first = b;
            }
            o.rec.block_last = b;
        }
        o.rec.t_end_s = r.t_s;
        if let Some(x) = r.x_mm {
            o.rec.x_end_mm = x;
        }
        o.rec.alarm_bits |= r.alarms;
        if r.feed_hold {
            o.rec.feed_hold_periods += 1;
        }
        let ov = r.override_applied_pct.unwrap_or(100).min(150);
        let bin = (usize::from(ov) / usize::from(o.rec.hist_bin_pct)).min(bins - 1);
        o.rec.override_hist[bin] += 1;
        o.rec.time_saved_s += self.period_s * (f64::from(ov) / 100.0 - 1.0);
        ended
    }

    fn close(&mut self) -> Option<CutRecord> {
        let o = self.open.take()?;
        let mut rec = o.rec;
        let n = f64::from(o.n.max(1));
        rec.time_in_cut_s = f64::from(o.n) * self.period_s;
        rec.force_mean_n = o.sum_f / n;
        rec.force_rms_error_n = (o.sum_e2 / n).sqrt();
        Some(rec)
    }

    /// Note an alarm of the watch (`wear_warn`, …) on the open cut, if any.
    pub fn note_alarm(&mut self, name: &str) {
        if let Some(o) = self.open.as_mut() {
            if !o.rec.watch_alarms.iter().any(|a| a == name) {
                o.rec.watch_alarms.push(name.to_string());
            }
        }
    }

    /// End of the stream: the cut still open, if any.
    pub fn finish(&mut self) -> Option<CutRecord> {
        self.close()
    }

    /// All cuts of a whole log.
    pub fn cuts_of(period_s: f64, bin_pct: u16, rows: &[RunRecord]) -> Vec<CutRecord> {
        let mut c = CutRecorder::new(period_s).with_bin_pct(bin_pct);
        let mut out: Vec<CutRecord> = rows.iter().filter_map(|r| c.push(r)).collect();
        out.extend(c.finish());
        out
    }
}

/// Period of a log, s: the median spacing of `t_s` (0.1 when it cannot be told).
pub fn log_period_s(rows: &[RunRecord]) -> f64 {
    let mut d: Vec<f64> = rows
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    let m = crate::watch::median(&mut d);
    if m.is_finite() {
        m
    } else {
        0.1
    }
}

/// Histogram bin of a log: 1 % when any applied override is not a multiple of 10, else 10 %.
pub fn log_bin_pct(rows: &[RunRecord]) -> u16 {
    if rows
        .iter()
        .filter_map(|r| r.override_applied_pct)
        .any(|o| o % 10 != 0)
    {
        1
    } else {
        10
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn row(t: f64, f: f64, ov: u16, block: u16) -> RunRecord {
        RunRecord {
            t_s: t,
            tool: Some(1),
            program: Some(1000),
            block: Some(block),
            x_mm: Some(t * 10.0),
            force_n: Some(f),
            force_valid: true,
            force_ref_n: Some(800.0),
            override_applied_pct: Some(ov),
            ..RunRecord::default()
        }
    }

    #[test]
    fn time_saved_sign_and_cut_split() {
        let mut rows = Vec::new();
        // Cut 1 at 50 %: slower than programmed.
        for i in 0..20 {
            rows.push(row(f64::from(i) * 0.1, 800.0, 50, 20));
        }
        for i in 20..30 {
            rows.push(row(f64::from(i) * 0.1, 0.0, 150, 30));
        }
        // Cut 2 at 120 %, blocks 40 and 50, with a 2-period dip that does not split it.
        for i in 30..60 {
            let f = if (40..42).contains(&i) { 10.0 } else { 900.0 };
            rows.push(row(
                f64::from(i) * 0.1,
                f,
                120,
                if i < 45 { 40 } else { 50 },
            ));
        }
        let cuts = CutRecorder::cuts_of(0.1, 10, &rows);
        assert_eq!(cuts.len(), 2, "{cuts:#?}");
        assert!((cuts[0].time_saved_s - (-1.0)).abs() < 1e-9);
        assert!(cuts[0].time_saved_s < 0.0);
        assert!((cuts[1].time_saved_s - 28.0 * 0.1 * 0.2).abs() < 1e-9);
        assert_eq!(cuts[1].block_range(), "N40–N50");
        assert_eq!(cuts[0].block_range(), "N20");
        assert!((cuts[1].force_rms_error_n - 100.0).abs() < 1e-9);
        assert_eq!(cuts[0].override_hist[5], 20);
        assert_eq!(cuts[1].override_hist[12], 28);
    }

    #[test]
    fn tool_change_ends_a_cut() {
        let mut rows: Vec<RunRecord> = (0..10).map(|i| row(f64::from(i), 800.0, 100, 10)).collect();
        for r in rows.iter_mut().skip(5) {
            r.tool = Some(2);
        }
        let cuts = CutRecorder::cuts_of(0.1, 10, &rows);
        assert_eq!(cuts.len(), 2);
        assert_eq!((cuts[0].tool, cuts[1].tool), (1, 2));
        assert!(cuts.iter().all(|c| c.time_saved_s.abs() < 1e-12));
    }

    proptest! {
        #[test]
        fn histogram_sums_to_cut_periods(
            ovs in proptest::collection::vec(0u16..=150, 1..200),
            bin in prop_oneof![Just(1u16), Just(10u16)],
        ) {
            let rows: Vec<RunRecord> = ovs.iter().enumerate()
                .map(|(i, ov)| row(i as f64 * 0.1, 800.0, *ov, 10)).collect();
            let cuts = CutRecorder::cuts_of(0.1, bin, &rows);
            prop_assert_eq!(cuts.len(), 1);
            let c = &cuts[0];
            let total: u32 = c.override_hist.iter().sum();
            prop_assert_eq!(total as usize, ovs.len());
            prop_assert!((c.time_in_cut_s - ovs.len() as f64 * 0.1).abs() < 1e-9);
            let expect: f64 = ovs.iter().map(|o| 0.1 * (f64::from(*o) / 100.0 - 1.0)).sum();
            prop_assert!((c.time_saved_s - expect).abs() < 1e-9);
            prop_assert_eq!(c.time_saved_s < 0.0, expect < 0.0);
        }
    }
}
