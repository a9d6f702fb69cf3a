//! The verdict of `acc soak`: memory growth, lost rows, dead threads, the never-raise
//! invariant, and on a hostile line what the proxy did and whether ACC still controls.

use acc_runtime::record::RunRecord;

use crate::invariant::fault_periods_raising;
use crate::proxy::{ProxyLog, ProxyStats};
use crate::read_match::{align_reads, suspicious, trustworthy, Alignment};

/// What the man in the middle did over the soak.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SoakLine {
    /// The proxy's counters.
    pub proxy: ProxyStats,
    /// Replies corrupted with a valid CRC.
    pub corrupted: u64,
    /// Delay episodes planned, and switched on.
    pub episodes_planned: usize,
    /// Delay episodes the proxy ran.
    pub episodes: u64,
    /// Status reads answered with an older reply.
    pub delayed_reads: u64,
    /// Rows of `acc run` flagged as not taking a read at face value (`link:`,
    /// `implausible:`, `unconfirmed:`, `force_invalid`, `echo`, `delay`).
    pub suspicious_rows: usize,
    /// Periods that entered `operator_handback` or `switch_off` (the soak's operator does
    /// switch and turn the knob: reported, not judged).
    pub operator_releases: usize,
    /// Rows whose logged power was checked against the proxy's reads, and agreed
    /// ([`align_reads`]).
    pub aligned: (usize, usize),
}

/// What `analyse` needs to know of the hostile line.
#[derive(Debug, Clone, Default)]
pub struct LineInput {
    /// What the proxy wrote: its counters, its alterations and the reads it handed over.
    pub proxy: ProxyLog,
    /// Delay episodes planned.
    pub episodes_planned: usize,
    /// Machine time of the last re-arm.
    pub rearm_at: f64,
}

/// Periods before a release in which a read the proxy altered explains it.
const FRESH_BAD_FRAME_PERIODS: usize = 5;

/// On a hostile line, `acc run` still controls at the end: ACC is active after the
/// operator's last re-arm, and at the end, unless its last release came within
/// [`FRESH_BAD_FRAME_PERIODS`] periods after a read the proxy altered (a fresh bad frame
/// latched it, as it may at any time on this line). The reads are matched to the rows with
/// [`align_reads`]; without a reliable match ACC must be active at the end. A problem, if
/// any.
pub fn controlling_after_rearm(
    r: &[RunRecord],
    l: &LineInput,
    alignment: &Alignment,
) -> Option<String> {
    let from = r.iter().position(|x| x.t_s > l.rearm_at + 0.5)?;
    let active = |x: &RunRecord| x.state == "active";
    if !r[from..].iter().any(active) {
        return Some("ACC was not controlling after the operator's last re-arm".into());
    }
    if r.last().is_some_and(active) {
        return None;
    }
    let release = (from.max(1)..r.len())
        .rev()
        .find(|&j| active(&r[j - 1]) && !active(&r[j]))?;
    let x = &r[release];
    // The match where it matters: the 30 s of rows before the release.
    let (checked, agreed) =
        alignment.agreement_in(r, &l.proxy.reads, release.saturating_sub(300)..release + 1);
    if !trustworthy(checked, agreed) {
        return Some(format!(
            "ACC released at t = {:.1} s ({}) after the operator's last re-arm, and the proxy's reads could not be matched to the rows ({agreed} of {checked} powers agree)",
            x.t_s, x.state
        ));
    }
    let altered: std::collections::HashSet<usize> = l
        .proxy
        .events
        .iter()
        .filter_map(|e| e.read_index)
        .filter_map(|i| alignment.row_of_read.get(&i).copied())
        .collect();
    let fresh =
        (release.saturating_sub(FRESH_BAD_FRAME_PERIODS)..=release).any(|j| altered.contains(&j));
    (!fresh).then(|| {
        format!(
            "ACC released at t = {:.1} s ({}, flags `{}`) after the operator's last re-arm with no read altered by the proxy in the {FRESH_BAD_FRAME_PERIODS} periods before",
            x.t_s, x.state, x.flags
        )
    })
}

/// The measured outcome.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SoakReport {
    /// Machine time covered by `acc run`'s log, s.
    pub machine_s: f64,
    /// Wall time of the run, s.
    pub wall_s: f64,
    /// Faults the board fired.
    pub faults_fired: usize,
    /// Faults by kind.
    pub faults_by_kind: Vec<(String, usize)>,
    /// `acc run` rows, and the periods missing between its first and last row.
    pub run_rows: usize,
    /// Periods without a row in `acc run`'s log.
    pub run_missing: u64,
    /// Rows flagged skipped / late / link error in `acc run`'s log.
    pub run_flagged: usize,
    /// Machine-side rows and missing periods.
    pub machine_rows: usize,
    /// Periods without a row in the machine-side log.
    pub machine_missing: u64,
    /// Deadlines board-sim's ticker skipped (it fell more than a period behind the wall
    /// clock: machine time lagged, no machine period was lost; flagged `ticks_skipped:<n>`).
    pub machine_ticks_skipped: u64,
    /// The run was long enough (≥ 150 s of wall time) to measure memory growth.
    pub memory_measured: bool,
    /// RSS growth of `acc run`, KiB (last minute vs first minute after warm-up).
    pub run_rss_growth_kib: i64,
    /// RSS of `acc run` at the end, KiB.
    pub run_rss_end_kib: u64,
    /// RSS growth of `acc board-sim`, KiB.
    pub board_rss_growth_kib: i64,
    /// RSS of `acc board-sim` at the end, KiB.
    pub board_rss_end_kib: u64,
    /// Thread counts (min, max) of `acc run` and `acc board-sim` after start-up.
    pub run_threads: (u64, u64),
    /// Thread counts of `acc board-sim`.
    pub board_threads: (u64, u64),
    /// Fault periods that raised the command (must be 0).
    pub raised_in_fault: usize,
    /// Largest true force while ACC was active and not in feed hold, N; and Fr.
    pub max_force_n: f64,
    /// Share of the run ACC was active, percent.
    pub active_pct: f64,
    /// `acc run`'s exit.
    pub exit: String,
    /// ACC was active in the last second of the run.
    pub active_at_end: bool,
    /// The hostile line (`None`: `--no-hostile-line`).
    pub line: Option<SoakLine>,
    /// Verdict lines (empty = pass).
    pub problems: Vec<String>,
}

fn median(mut v: Vec<u64>) -> Option<u64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    Some(v[v.len() / 2])
}

/// Periods missing between the first and last row (`period` must count up by one).
fn missing(rows: &[RunRecord]) -> u64 {
    rows.windows(2)
        .map(|w| w[1].period.saturating_sub(w[0].period + 1))
        .sum()
}

/// Deadlines board-sim's ticker skipped, from its rows' `ticks_skipped:<n>` flags.
fn ticks_skipped(rows: &[RunRecord]) -> u64 {
    rows.iter()
        .flat_map(|x| x.flags.split(';'))
        .filter_map(|f| f.strip_prefix("ticks_skipped:"))
        .filter_map(|n| n.parse::<u64>().ok())
        .sum()
}

/// One sample: wall time s, (RSS KiB, threads) of acc run and of acc board-sim.
pub type Sample = (f64, Option<(u64, u64)>, Option<(u64, u64)>);

/// The verdict on the soak: memory, threads, lost rows, the never-raise invariant, and on a
/// hostile line what the proxy did and whether ACC still controls.
pub fn analyse(
    r: &[RunRecord],
    m: &[RunRecord],
    samples: &[Sample],
    fired: &[String],
    exit: String,
    wall_s: f64,
    line: Option<&LineInput>,
) -> SoakReport {
    let mut problems = Vec::new();
    // Memory: first minute after a 30 s warm-up against the last minute.
    let series = |pick: fn(&Sample) -> Option<(u64, u64)>| -> Vec<(f64, u64, u64)> {
        samples
            .iter()
            .filter_map(|s| pick(s).map(|(rss, th)| (s.0, rss, th)))
            .collect()
    };
    let growth = |v: &[(f64, u64, u64)]| -> (i64, u64, (u64, u64)) {
        let end_t = v.last().map_or(0.0, |x| x.0);
        let first = median(
            v.iter()
                .filter(|x| x.0 >= 30.0 && x.0 < 90.0)
                .map(|x| x.1)
                .collect(),
        );
        let last = median(
            v.iter()
                .filter(|x| x.0 > end_t - 60.0)
                .map(|x| x.1)
                .collect(),
        );
        let threads = v
            .iter()
            .filter(|x| x.0 >= 5.0)
            .fold((u64::MAX, 0), |(lo, hi), x| (lo.min(x.2), hi.max(x.2)));
        let g = match (first, last) {
            (Some(a), Some(b)) => b as i64 - a as i64,
            _ => 0,
        };
        (g, v.last().map_or(0, |x| x.1), threads)
    };
    let (run_g, run_end, run_th) = growth(&series(|s| s.1));
    let (board_g, board_end, board_th) = growth(&series(|s| s.2));
    // Memory growth needs a first and a last minute after the warm-up: shorter runs
    // (the CI test) report it as not measured.
    let memory_measured = samples.len() >= 150;
    if memory_measured {
        for (who, g) in [("acc run", run_g), ("acc board-sim", board_g)] {
            if g >= 1024 {
                problems.push(format!("{who} RSS grew by {g} KiB (limit 1024)"));
            }
        }
    }
    if board_th.0 < board_th.1 {
        problems.push(format!(
            "acc board-sim's threads went from {} to {}",
            board_th.1, board_th.0
        ));
    }
    let run_missing = missing(r);
    let machine_missing = missing(m);
    if run_missing > 0 || r.first().is_some_and(|x| x.period != 0) {
        problems.push(format!("acc run's log misses {run_missing} periods"));
    }
    if machine_missing > 0 {
        problems.push(format!("the machine log misses {machine_missing} periods"));
    }
    let run_flagged = r.iter().filter(|x| !x.flags.is_empty()).count();
    let machine_ticks_skipped = ticks_skipped(m);
    // The invariant: a period with an unusable force sample never raises the command.
    let raised = fault_periods_raising(r);
    if raised > 0 {
        problems.push(format!("{raised} fault periods raised the command"));
    }
    let t_end = r.last().map_or(0.0, |x| x.t_s);
    let (active_at_end, aligned) = match line {
        None => {
            let ok = r
                .iter()
                .filter(|x| x.t_s > t_end - 1.0)
                .any(|x| x.state == "active");
            if !ok {
                problems.push("ACC was not controlling at the end of the run".into());
            }
            (ok, None)
        }
        Some(l) => {
            let alignment = align_reads(r, &l.proxy.reads);
            let problem = controlling_after_rearm(r, l, &alignment);
            let ok = problem.is_none();
            problems.extend(problem);
            (ok, Some((alignment.checked, alignment.agreed)))
        }
    };
    let line = line.map(|l| {
        let mut out = SoakLine {
            episodes_planned: l.episodes_planned,
            aligned: aligned.unwrap_or_default(),
            suspicious_rows: r.iter().filter(|x| suspicious(&x.flags)).count(),
            ..SoakLine::default()
        };
        let operator =
            |x: &RunRecord| matches!(x.state.as_str(), "operator_handback" | "switch_off");
        out.operator_releases = r
            .windows(2)
            .filter(|w| operator(&w[1]) && !operator(&w[0]))
            .count();
        match &l.proxy.stats {
            Some(st) => {
                out.corrupted = st.corrupted();
                out.episodes = st.episodes;
                out.delayed_reads = st.altered.get("delay").copied().unwrap_or(0);
                out.proxy = st.clone();
                if out.corrupted == 0 {
                    problems.push("the hostile line corrupted no reply".into());
                }
                if out.episodes != l.episodes_planned as u64 {
                    problems.push(format!(
                        "the hostile line ran {} delay episodes of {} planned",
                        out.episodes, l.episodes_planned
                    ));
                }
            }
            None => problems.push("the man-in-the-middle proxy wrote no counters".into()),
        }
        out
    });
    if !(exit == "0" || exit == "3") {
        problems.push(format!("acc run exit {exit}"));
    }
    let active = r.iter().filter(|x| x.state == "active").count();
    let max_force_n = m
        .iter()
        .filter(|x| x.state == "acc_active" && !x.feed_hold)
        .filter_map(|x| x.force_true_n)
        .fold(0.0, f64::max);
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for l in fired {
        let k = l
            .split(": fault ")
            .nth(1)
            .and_then(|s| s.split(['(', ' ']).next())
            .unwrap_or("?")
            .to_string();
        match kinds.iter_mut().find(|(n, _)| *n == k) {
            Some((_, c)) => *c += 1,
            None => kinds.push((k, 1)),
        }
    }
    kinds.sort();
    SoakReport {
        machine_s: t_end,
        wall_s,
        faults_fired: fired.len(),
        faults_by_kind: kinds,
        run_rows: r.len(),
        run_missing,
        run_flagged,
        machine_rows: m.len(),
        machine_missing,
        machine_ticks_skipped,
        memory_measured,
        run_rss_growth_kib: run_g,
        run_rss_end_kib: run_end,
        board_rss_growth_kib: board_g,
        board_rss_end_kib: board_end,
        run_threads: run_th,
        board_threads: board_th,
        raised_in_fault: raised,
        max_force_n,
        active_pct: 100.0 * active as f64 / r.len().max(1) as f64,
        exit,
        active_at_end,
        line,
        problems,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proxy::{ProxyEvent, ProxyRead};

    #[test]
    fn a_release_after_the_last_re_arm_needs_a_fresh_bad_frame() {
        // Rows 0..40 (0.1 s apart), one read each after one start-up read; unique powers.
        let rows = |released_from: usize, state: &str| -> Vec<RunRecord> {
            (0..40)
                .map(|i| RunRecord {
                    t_s: 0.1 * i as f64,
                    period: i as u64,
                    power_w: Some(1000.0 + i as f64),
                    state: if i >= released_from { state } else { "active" }.into(),
                    ..RunRecord::default()
                })
                .collect()
        };
        let reads: Vec<ProxyRead> = (0..41)
            .map(|i| ProxyRead {
                i: Some(i),
                power: Some(1000.0 + i as f64 - 1.0),
                applied: None,
                altered: false,
            })
            .collect();
        let bad_frame = |read: u64| ProxyEvent {
            t: 0.0,
            read_index: Some(read),
            fc: 4,
            kind: "random".into(),
            register: None,
            bit: None,
            before: None,
            after: None,
        };
        let line = |events: Vec<ProxyEvent>| LineInput {
            proxy: ProxyLog {
                stats: None,
                events,
                reads: reads.clone(),
            },
            episodes_planned: 0,
            rearm_at: 1.0,
        };
        let check = |r: &[RunRecord], l: &LineInput| {
            let a = align_reads(r, &l.proxy.reads);
            assert_eq!(a.offset, 1);
            controlling_after_rearm(r, l, &a)
        };
        // Active to the end.
        assert_eq!(check(&rows(99, ""), &line(vec![])), None);
        // Released at row 30: explained by the altered read 29 (row 28), not otherwise.
        let r = rows(30, "power_invalid");
        assert_eq!(check(&r, &line(vec![bad_frame(29)])), None);
        let p = check(&r, &line(vec![bad_frame(5)])).expect("a problem");
        assert!(
            p.contains("t = 3.0 s") && p.contains("no read altered"),
            "{p}"
        );
        // Never active again after the re-arm (rows after 1.5 s).
        let p = check(&rows(12, "delay"), &line(vec![bad_frame(13)])).expect("a problem");
        assert!(p.contains("not controlling after"), "{p}");
    }

    #[test]
    fn missing_periods_are_counted() {
        let row = |p| RunRecord {
            period: p,
            ..RunRecord::default()
        };
        assert_eq!(missing(&[row(0), row(1), row(2)]), 0);
        assert_eq!(missing(&[row(0), row(3), row(4), row(6)]), 3);
    }

    #[test]
    fn skipped_board_ticks_are_summed_from_the_flags() {
        let row = |p, flags: &str| RunRecord {
            period: p,
            flags: flags.into(),
            ..RunRecord::default()
        };
        let m = [
            row(0, ""),
            row(1, "late;ticks_skipped:2"),
            row(2, "late"),
            row(3, "fallback:50;late;ticks_skipped:1"),
        ];
        assert_eq!(ticks_skipped(&m), 3);
        // Consecutive machine periods: a skipped tick is not a missing row.
        assert_eq!(missing(&m), 0);
    }
}
