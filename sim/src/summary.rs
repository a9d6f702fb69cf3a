//! Run summaries: per depth segment after settling, and one line per law for `acc compare`.

use std::fmt;

use acc_core::stats::rms;

use crate::run::RunResult;
use crate::scenario::Scenario;
use crate::workpiece::Workpiece;
use acc_runtime::record::RunRecord;

/// Statistics of one workpiece segment.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentStats {
    /// Segment index in the workpiece.
    pub index: usize,
    /// Label, e.g. `"cut 3.0 mm"`.
    pub label: String,
    /// Whether the segment has material.
    pub is_cut: bool,
    /// Time of the first period attributed to the segment, s.
    pub t_enter_s: f64,
    /// Time of the last period attributed to the segment, s.
    pub t_leave_s: f64,
    /// Periods attributed to the segment.
    pub periods: usize,
    /// Periods after settling (`t ≥ t_enter + settle_s`).
    pub settled_periods: usize,
    /// Mean measured force after settling, N.
    pub mean_force_n: f64,
    /// Mean force error `F − Fr` after settling, N.
    pub mean_error_n: f64,
    /// RMS force error `F − Fr` after settling, N.
    pub rms_error_n: f64,
    /// Standard deviation of the force after settling, N.
    pub std_force_n: f64,
    /// Oscillation amplitude after settling, N: half of the spread between the 5th and
    /// 95th percentile of the force (a sinusoid of amplitude A gives ≈ 0.99·A; noise of
    /// standard deviation σ gives ≈ 1.6·σ).
    pub osc_amplitude_n: f64,
    /// RMS force error in the first `settle_s` (entry or depth-change transient), N.
    pub transient_rms_n: f64,
    /// Peak force in the first `settle_s`, N (the entry / depth-change peak).
    pub peak_entry_n: f64,
    /// Time with force above `1.1·Fr`, s.
    pub time_above_s: f64,
    /// Mean applied override after settling, percent.
    pub mean_override_pct: f64,
    /// Fraction of settled periods with the override command at its maximum.
    pub frac_at_max: f64,
    /// Whether Fr is reachable here (the override was not pinned at its maximum for more
    /// than half of the settled periods).
    pub reaches_ref: bool,
}

/// Whole-run figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Law name.
    pub law: String,
    /// Force reference, N.
    pub force_ref_n: f64,
    /// Settling time used, s.
    pub settle_s: f64,
    /// Per-segment statistics.
    pub segments: Vec<SegmentStats>,
    /// Cycle time (tool centre from 0 to the end of the path), s; `None` if the run hit
    /// its time limit first or ended in a fault feed hold.
    pub cycle_time_s: Option<f64>,
    /// The production loop's fault policy stopped the machine with a feed hold (overload:
    /// the tool-breakage protection) at this time, s, and the run ended there.
    pub feed_hold_at_s: Option<f64>,
    /// Why the policy held the feed (the state of the first feed-hold period: `overload`,
    /// `breakage`, …); empty without a feed hold.
    pub feed_hold_reason: String,
    /// Cycle time at the programmed feed (100 % throughout), s.
    pub programmed_cycle_time_s: f64,
    /// Metal removed, cm³.
    pub volume_cm3: f64,
    /// RMS of `F − Fr` over all periods in cutting segments (transients included), N.
    pub rms_error_cut_n: f64,
    /// Largest measured force, N.
    pub peak_force_n: f64,
    /// Time with force above `1.1·Fr`, s.
    pub time_above_s: f64,
    /// Number of periods in which the override command changed.
    pub override_switches: usize,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let idx = (p * (sorted.len() - 1) as f64).round() as usize;
    sorted[idx.min(sorted.len() - 1)]
}

/// The force of a record, N: the one the controller saw, else (a machine-side log of
/// `acc board-sim`) the true force, else 0.
fn force(r: &RunRecord) -> f64 {
    r.force_n.or(r.force_true_n).unwrap_or(0.0)
}

/// The override commanded in a record's period, percent: the one written, else the one in
/// force (a period without a write holds the previous command).
fn cmd(r: &RunRecord) -> u16 {
    r.override_cmd_pct
        .or(r.override_applied_pct)
        .unwrap_or_default()
}

/// Which segment a row belongs to: a segment begins when the front of the cutter's contact
/// arc reaches it (centre + `√(d·(D − d))` with `d` the larger of the two depths at the
/// boundary, capped at the radius), because that is where the force starts to change.
#[derive(Debug, Clone, PartialEq)]
pub struct Attribution {
    /// Segment starts along the path, mm.
    starts_mm: Vec<f64>,
    /// Reach of the contact arc ahead of the centre at each segment's start, mm.
    reach_mm: Vec<f64>,
}

impl Attribution {
    /// The attribution for `workpiece` cut by a tool of `diameter_mm`.
    pub fn new(workpiece: &Workpiece, diameter_mm: f64) -> Self {
        let r = 0.5 * diameter_mm;
        let reach_mm = workpiece
            .segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let prev = if i == 0 {
                    0.0
                } else {
                    workpiece.segments[i - 1].depth_end_mm
                };
                let d = prev.max(s.depth_start_mm).min(r);
                (d * (diameter_mm - d)).max(0.0).sqrt()
            })
            .collect();
        Attribution {
            starts_mm: workpiece.segments.iter().map(|s| s.start_mm).collect(),
            reach_mm,
        }
    }

    /// The segment of a row whose tool centre is at `x_mm`.
    pub fn segment(&self, x_mm: f64) -> usize {
        (0..self.starts_mm.len())
            .rev()
            .find(|&i| x_mm + self.reach_mm[i] >= self.starts_mm[i])
            .unwrap_or(0)
    }
}

/// Attribute each row to a segment ([`Attribution`], at the row's true tool position, else
/// its logged one).
pub fn attribute_rows(rows: &[RunRecord], workpiece: &Workpiece, diameter_mm: f64) -> Vec<usize> {
    let a = Attribution::new(workpiece, diameter_mm);
    rows.iter()
        .map(|row| a.segment(row.x_true_mm.or(row.x_mm).unwrap_or(0.0)))
        .collect()
}

/// Summarise a run of `scenario`.
pub fn summarize(result: &RunResult, scenario: &Scenario) -> Summary {
    let rows = &result.rows;
    let workpiece = &scenario.workpiece;
    let period_s = scenario.controller.period_s;
    let settle_s = scenario.settle_s;
    let max_pct = scenario.controller.override_spec.max_pct;
    let programmed_feed_mm_min = scenario.programmed_feed_mm_min;
    let diameter_mm = scenario.tool.diameter_mm;
    let fr = rows
        .iter()
        .find_map(|r| r.force_ref_n)
        .unwrap_or(scenario.controller.force_ref_n);
    let seg_of = attribute_rows(rows, workpiece, diameter_mm);
    let mut segments = Vec::new();
    for (index, seg) in workpiece.segments.iter().enumerate() {
        let mine: Vec<&RunRecord> = rows
            .iter()
            .zip(&seg_of)
            .filter(|(_, s)| **s == index)
            .map(|(r, _)| r)
            .collect();
        let (Some(first), Some(last)) = (mine.first(), mine.last()) else {
            continue;
        };
        let t0 = first.t_s - period_s;
        let (transient, settled): (Vec<&RunRecord>, Vec<&RunRecord>) =
            mine.iter().partition(|r| r.t_s - t0 <= settle_s + 1e-9);
        let n = settled.len().max(1) as f64;
        let mean_force = settled.iter().map(|r| force(r)).sum::<f64>() / n;
        let mut forces: Vec<f64> = settled.iter().map(|r| force(r)).collect();
        forces.sort_by(f64::total_cmp);
        let at_max = settled.iter().filter(|r| cmd(r) >= max_pct).count() as f64 / n;
        segments.push(SegmentStats {
            index,
            label: seg.label(),
            is_cut: seg.is_cut(),
            t_enter_s: t0,
            t_leave_s: last.t_s,
            periods: mine.len(),
            settled_periods: settled.len(),
            mean_force_n: mean_force,
            mean_error_n: mean_force - fr,
            rms_error_n: rms(settled.iter().map(|r| force(r) - fr)),
            std_force_n: rms(settled.iter().map(|r| force(r) - mean_force)),
            osc_amplitude_n: 0.5 * (percentile(&forces, 0.95) - percentile(&forces, 0.05)),
            transient_rms_n: rms(transient.iter().map(|r| force(r) - fr)),
            peak_entry_n: transient.iter().map(|r| force(r)).fold(0.0, f64::max),
            time_above_s: mine.iter().filter(|r| force(r) > 1.1 * fr).count() as f64 * period_s,
            mean_override_pct: settled
                .iter()
                .map(|r| f64::from(r.override_applied_pct.unwrap_or(0)))
                .sum::<f64>()
                / n,
            frac_at_max: at_max,
            reaches_ref: seg.is_cut() && !settled.is_empty() && at_max <= 0.5,
        });
    }
    let cut_rows = rows
        .iter()
        .zip(&seg_of)
        .filter(|(_, s)| workpiece.segments[**s].is_cut())
        .map(|(r, _)| r);
    Summary {
        law: result.law.clone(),
        force_ref_n: fr,
        settle_s,
        segments,
        cycle_time_s: result.finished.then(|| rows.last().map_or(0.0, |r| r.t_s)),
        feed_hold_at_s: result
            .ended_in_feed_hold
            .then(|| rows.iter().find(|r| r.feed_hold).map_or(0.0, |r| r.t_s)),
        feed_hold_reason: if result.ended_in_feed_hold {
            rows.iter()
                .find(|r| r.feed_hold)
                .map_or_else(String::new, |r| r.state.clone())
        } else {
            String::new()
        },
        programmed_cycle_time_s: workpiece.length_mm() / programmed_feed_mm_min * 60.0,
        volume_cm3: result.volume_mm3 * 1e-3,
        rms_error_cut_n: rms(cut_rows.map(|r| force(r) - fr)),
        peak_force_n: rows.iter().map(force).fold(0.0, f64::max),
        time_above_s: rows.iter().filter(|r| force(r) > 1.1 * fr).count() as f64 * period_s,
        override_switches: rows.windows(2).filter(|w| cmd(&w[0]) != cmd(&w[1])).count(),
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "law: {}   Fr = {:.0} N   settled = after {:.1} s in a segment",
            self.law, self.force_ref_n, self.settle_s
        )?;
        writeln!(
            f,
            "{:<3} {:<22} {:>7} {:>7} {:>9} {:>9} {:>8} {:>9} {:>9} {:>8} {:>7}",
            "#",
            "segment",
            "enter_s",
            "leave_s",
            "mean_F_N",
            "mean_e_N",
            "rms_e_N",
            "osc_amp_N",
            "peak_in_N",
            "t>1.1Fr",
            "ovr_%"
        )?;
        for s in &self.segments {
            let note = if s.is_cut && !s.reaches_ref {
                "  (Fr not reachable: override at max)"
            } else if !s.is_cut && s.index > 0 {
                "  (peak_in: the exit from the previous cut)"
            } else {
                ""
            };
            // Errors against Fr mean nothing in air: dashes.
            let err = |v: f64| {
                if s.is_cut {
                    format!("{v:.1}")
                } else {
                    "-".to_string()
                }
            };
            writeln!(
                f,
                "{:<3} {:<22} {:>7.1} {:>7.1} {:>9.1} {:>9} {:>8} {:>9.1} {:>9.1} {:>8.1} {:>7.1}{}",
                s.index,
                s.label,
                s.t_enter_s,
                s.t_leave_s,
                s.mean_force_n,
                err(s.mean_error_n),
                err(s.rms_error_n),
                s.osc_amplitude_n,
                s.peak_entry_n,
                s.time_above_s,
                s.mean_override_pct,
                note
            )?;
        }
        let cycle = self.cycle_time_s.map_or_else(
            || match self.feed_hold_at_s {
                Some(t) => format!(
                    "not finished: {} feed hold at {t:.1} s",
                    if self.feed_hold_reason.is_empty() {
                        "fault"
                    } else {
                        &self.feed_hold_reason
                    }
                ),
                None => "not finished".to_string(),
            },
            |c| format!("{c:.1} s"),
        );
        writeln!(
            f,
            "cycle time {cycle} (at the programmed feed: {:.1} s); metal removed {:.2} cm³",
            self.programmed_cycle_time_s, self.volume_cm3
        )?;
        if let Some(c) = self.cycle_time_s {
            writeln!(
                f,
                "mean MRR {:.2} cm³/min (at the programmed feed: {:.2} cm³/min)",
                self.volume_cm3 / c * 60.0,
                self.volume_cm3 / self.programmed_cycle_time_s * 60.0
            )?;
        }
        writeln!(
            f,
            "force RMS error while cutting {:.1} N; peak {:.1} N; time above 1.1·Fr {:.1} s; override switches {}",
            self.rms_error_cut_n, self.peak_force_n, self.time_above_s, self.override_switches
        )
    }
}

/// The figures of the `acc compare` oracle row (see [`crate::oracle`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OracleFigures {
    /// Lowest force RMS error while cutting, N.
    pub rms_error_cut_n: f64,
    /// Lowest peak force of a law no slower than the constant safe feed, N (`None`: the
    /// constant safe feed does not finish within the time limit).
    pub peak_force_n: Option<f64>,
    /// Shortest cycle time with no row above Fr, s (`None`: the fastest safe feed does not
    /// finish within the scenario's time limit).
    pub cycle_time_s: Option<f64>,
}

impl From<&crate::oracle::Oracle> for OracleFigures {
    fn from(o: &crate::oracle::Oracle) -> Self {
        OracleFigures {
            rms_error_cut_n: o.rms.rms_error_cut_n,
            peak_force_n: o.peak_n,
            cycle_time_s: o.safe.cycle_time_s,
        }
    }
}

/// `value / oracle` with two decimals, `-` where it means nothing (no oracle, a zero
/// oracle figure, or no value).
fn ratio(value: Option<f64>, oracle: Option<f64>) -> String {
    match (value, oracle) {
        (Some(v), Some(o)) if o > 0.0 && v.is_finite() => format!("{:.2}", v / o),
        _ => "-".to_string(),
    }
}

/// Print the `acc compare` table: one row per law, and with `oracle` its row last and
/// every law's ratio to it (`rms/oracle`, `peak/oracle`, `cycle/oracle`).
pub fn comparison_table(summaries: &[Summary], oracle: Option<&OracleFigures>) -> String {
    let mut out = format!(
        "{:<16} {:>12} {:>12} {:>14} {:>13} {:>10}",
        "law", "rms_err_N", "peak_F_N", "t>1.1Fr_s", "cycle_s", "switches"
    );
    if oracle.is_some() {
        out.push_str(&format!(
            " {:>11} {:>12} {:>13}",
            "rms/oracle", "peak/oracle", "cycle/oracle"
        ));
    }
    out.push('\n');
    for s in summaries {
        let cycle = s.cycle_time_s.map_or_else(
            || match s.feed_hold_at_s {
                Some(t) => format!("hold@{t:.1}"),
                None => "unfinished".to_string(),
            },
            |c| format!("{c:.1}"),
        );
        out.push_str(&format!(
            "{:<16} {:>12.1} {:>12.1} {:>14.1} {:>13} {:>10}",
            s.law, s.rms_error_cut_n, s.peak_force_n, s.time_above_s, cycle, s.override_switches
        ));
        if let Some(o) = oracle {
            out.push_str(&format!(
                " {:>11} {:>12} {:>13}",
                ratio(Some(s.rms_error_cut_n), Some(o.rms_error_cut_n)),
                ratio(Some(s.peak_force_n), o.peak_force_n),
                ratio(s.cycle_time_s, o.cycle_time_s)
            ));
        }
        out.push('\n');
    }
    if let Some(o) = oracle {
        let cycle = o
            .cycle_time_s
            .map_or_else(|| "unfinished".to_string(), |c| format!("{c:.1}"));
        let peak = o
            .peak_force_n
            .map_or_else(|| "-".to_string(), |p| format!("{p:.1}"));
        out.push_str(&format!(
            "{:<16} {:>12.1} {:>12} {:>14} {:>13} {:>10} {:>11} {:>12} {:>13}\n",
            "oracle", o.rms_error_cut_n, peak, "-", cycle, "-", "1.00", "1.00", "1.00"
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::configs_dir;

    /// Synthetic rows at 200 mm/min through the 2-3-4 mm part: the force is Fr plus a
    /// ±100 N square wave while the cutter is fully engaged at 3 mm, and exactly Fr
    /// elsewhere in the cut.
    #[test]
    fn segment_statistics_from_synthetic_rows() {
        let sc =
            Scenario::load(configs_dir().join("scenarios/paper_case1.toml")).expect("scenario");
        let wp = &sc.workpiece;
        let mut rows = Vec::new();
        for k in 1..=450 {
            let t = 0.1 * k as f64;
            let x = 200.0 / 60.0 * t;
            let depth = wp.engagement(x, 8.0).radial_mm;
            let in_cut = wp.depth_at(x) > 0.0;
            let force = if !in_cut {
                0.0
            } else if (depth - 3.0).abs() < 1e-9 {
                800.0 + if k % 2 == 0 { 100.0 } else { -100.0 }
            } else {
                800.0
            };
            rows.push(RunRecord {
                t_s: t,
                x_mm: Some(x),
                force_n: Some(force),
                force_ref_n: Some(800.0),
                override_cmd_pct: Some(if in_cut { 100 } else { 150 }),
                override_applied_pct: Some(100),
                ..RunRecord::default()
            });
        }
        let result = RunResult {
            law: "synthetic".into(),
            rows,
            finished: true,
            volume_mm3: 5760.0,
            ended_in_feed_hold: false,
        };
        let s = summarize(&result, &sc);
        let three = s
            .segments
            .iter()
            .find(|x| x.label == "cut 3.0 mm")
            .expect("3 mm");
        // A ±100 N square wave: mean error 0, RMS 100, 5–95 % half-spread 100.
        assert!(three.mean_error_n.abs() < 5.0, "{}", three.mean_error_n);
        assert!((three.rms_error_n - 100.0).abs() < 1e-9);
        assert!((three.osc_amplitude_n - 100.0).abs() < 1e-9);
        // Every other period is at 900 N > 1.1·Fr = 880 N (outside the 0.94 mm ramp-in).
        let half = 0.5 * (three.t_leave_s - three.t_enter_s);
        assert!(
            (three.time_above_s - half).abs() < 0.25,
            "{} vs {half}",
            three.time_above_s
        );
        let two = s
            .segments
            .iter()
            .find(|x| x.label == "cut 2.0 mm")
            .expect("2 mm");
        assert_eq!(two.rms_error_n, 0.0);
        assert!(two.reaches_ref && !s.segments[0].reaches_ref);
        // The 3 mm segment starts when the contact arc's front (√(3·13) = 6.2 mm ahead of
        // the centre) reaches x = 55 mm: at t = (55 − 6.2)/(200/60) = 14.6 s.
        assert!((three.t_enter_s - 14.6).abs() < 0.15, "{}", three.t_enter_s);
        assert_eq!(s.cycle_time_s, Some(45.0));
        assert!((s.programmed_cycle_time_s - 45.0).abs() < 1e-9);
        assert_eq!(s.override_switches, 2);
    }
}
