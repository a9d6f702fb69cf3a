//! The verdict on a row of `acc fault-matrix`, from the machine-side log, `acc run`'s log
//! and, on a hostile line, what the proxy wrote (the criteria: the module docs of
//! `acc fault-matrix`).

use acc_runtime::record::RunRecord;

use super::faults::{window_s, Action, Fault};
use super::FaultMatrixArgs;
use crate::invariant::fault_periods_raising;
use crate::proxy::{ProxyEvent, ProxyLog, ProxyStats};
use crate::read_match::{align_reads, must_be_flagged, suspicious};

/// Largest plausible spindle power, W: `policy.max_power_w` of
/// `configs/runtime/fault_matrix.toml` (a flipped power bit above it must be flagged).
const MAX_POWER_W: f64 = 30_000.0;

/// What the man in the middle did in a hostile-line row, and what `acc run` made of it.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LineReport {
    /// The proxy's counters.
    pub proxy: ProxyStats,
    /// Replies the proxy altered after the fault (corrupted or delayed).
    pub altered_replies: u64,
    /// Status reads (FC04) it corrupted (delays not counted).
    pub corrupted_reads: usize,
    /// Status reads it delayed.
    pub delayed_reads: usize,
    /// Corrupted status reads that must be flagged ([`must_be_flagged`]).
    pub must_flag: usize,
    /// Of which flagged in `acc run`'s log (read by read), or, when `matching` is
    /// `counts`, the rows after the fault flagged as suspicious.
    pub flagged: usize,
    /// `read by read` (matched, [`align_reads`]) or `counts` (the match was not reliable).
    pub matching: String,
    /// Rows whose logged power was checked against the proxy's reads, and agreed.
    pub aligned: (usize, usize),
    /// Rows after the fault that `acc run` flagged as suspicious ([`suspicious`]).
    pub suspicious_rows: usize,
    /// Corrupted reads that must be flagged and were not: `read #i (kind, register): t = …`.
    pub unflagged: Vec<String>,
    /// Periods after the fault that entered `operator_handback` or `switch_off`.
    pub operator_releases: usize,
}

/// The measured outcome of one row.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    /// Fault name.
    pub fault: String,
    /// What the fault is.
    pub what: String,
    /// Board protocol, 1 or 2.
    pub protocol: u8,
    /// Machine time the fault hit, s.
    pub t_fault_s: Option<f64>,
    /// Last override ACC commanded before the fault, percent.
    pub last_cmd_pct: Option<u16>,
    /// Largest applied override after the fault in periods where ACC was not driving the
    /// override and the feed was not held, percent (`None`: ACC drove, or the feed was held,
    /// in every period of the window).
    pub max_applied_after_pct: Option<u16>,
    /// Largest true force in the window before the fault, N.
    pub force_before_n: f64,
    /// Largest true force in the window after the fault, N (all periods, including those
    /// in which ACC drove the override again).
    pub force_after_n: f64,
    /// Largest true force after the fault in periods where ACC was not driving, N.
    pub force_after_released_n: f64,
    /// Periods of `acc run` with an unusable force sample or a link fault in which the
    /// command rose above the one before.
    pub raised_in_fault: usize,
    /// The feed was held (feed hold active) at some point after the fault.
    pub feed_hold_after: bool,
    /// `acc run`'s log rows, and whether every period from first to last has one.
    pub log_rows: usize,
    /// Every period has a row.
    pub log_complete: bool,
    /// `acc run`'s exit: code, or `signal N`, or `stopped by the harness (code)`.
    pub exit: String,
    /// `pass`, `FAIL: …`, `unsafe on v1: …` or `not judged: …`.
    pub verdict: String,
    /// The row passed (or is marked with a reason).
    pub ok: bool,
    /// Hostile-line rows: the proxy's alterations and the controller's flags.
    pub line: Option<LineReport>,
    /// The row was run twice: the first attempt's verdict (or error) on an overloaded host,
    /// with the controller's late and skipped periods, or on a run in which the fault met
    /// no cut under ACC ([`super::rerun`]); `verdict` and `ok` are the second attempt's.
    pub first_attempt: Option<String>,
    /// The fault met no cut under ACC, so the row did not test it: what the machine and
    /// `acc run` were doing at the fault moment (`None`: ACC drove the cut).
    pub untested: Option<String>,
}

/// Why the fault at `tf` met no cut under ACC, from the machine log's last period before
/// it (`m`: ACC not driving the override, or the feed held) and `acc run`'s state then
/// (`r`); `None` when ACC was driving the cut.
fn untested(m: &[&RunRecord], r: &[RunRecord], tf: f64) -> Option<String> {
    let at = m.last()?;
    if at.state == "acc_active" && !at.feed_hold {
        return None;
    }
    let run = r.iter().rev().find(|x| x.t_s <= tf).map_or_else(
        || "no period".to_string(),
        |x| format!("`{}` since t = {:.1} s", x.state, since(r, x)),
    );
    Some(format!(
        "the fault met no cut under ACC (machine at t = {:.1} s: {}{}; acc run: {run})",
        at.t_s,
        at.state,
        if at.feed_hold { ", feed held" } else { "" },
    ))
}

/// When `acc run`'s log entered the state of its row `x`, s.
fn since(r: &[RunRecord], x: &RunRecord) -> f64 {
    r.iter()
        .rev()
        .skip_while(|y| y.period > x.period)
        .take_while(|y| y.state == x.state)
        .last()
        .map_or(x.t_s, |y| y.t_s)
}

/// What a row is judged from: the machine-side log, `acc run`'s log, and on a hostile line
/// what the proxy wrote.
#[derive(Debug, Clone, Copy)]
pub struct Logs<'a> {
    pub machine: &'a [RunRecord],
    pub run: &'a [RunRecord],
    pub line: Option<&'a ProxyLog>,
}

/// The verdict on one row (the criteria are in the module docs of `acc fault-matrix`).
pub fn judge(
    f: &Fault,
    protocol: u8,
    t_fault: Option<f64>,
    logs: Logs<'_>,
    exit: String,
    args: &FaultMatrixArgs,
) -> Row {
    let (m, r) = (logs.machine, logs.run);
    let tf = t_fault.unwrap_or(args.at_s);
    // A machine row covers the period ending at t_s: the fault's period is the first with
    // t_s > tf. A signalled acc run drains for up to 10 s and then releases: its window runs
    // to the end of the machine log.
    let until = match f.action {
        Action::Signal(_) | Action::DoubleSigint => f64::INFINITY,
        _ => tf + window_s(f, args),
    };
    let before: Vec<&RunRecord> = m.iter().filter(|x| x.t_s <= tf).collect();
    let after: Vec<&RunRecord> = m.iter().filter(|x| x.t_s > tf && x.t_s <= until).collect();
    let driving = |x: &RunRecord| x.state == "acc_active";
    let last_cmd = before
        .iter()
        .rev()
        .find(|x| driving(x))
        .and_then(|x| x.override_applied_pct);
    // Board side: in every period after the fault in which ACC was not driving the override
    // and the feed was not held, the applied override is at most what ACC last commanded
    // (tracked through the window: ACC may re-arm and command again).
    let mut last = last_cmd;
    let mut max_released: Option<u16> = None;
    let mut over = Vec::new();
    for x in &after {
        if driving(x) {
            last = x.override_applied_pct.or(last);
            continue;
        }
        if x.feed_hold {
            continue;
        }
        if let Some(a) = x.override_applied_pct {
            max_released = Some(max_released.map_or(a, |m: u16| m.max(a)));
            if let Some(c) = last.filter(|c| a > *c) {
                over.push(format!("t = {:.1} s: {c} → {a} %", x.t_s));
            }
        }
    }
    let force = |x: &&RunRecord| x.force_true_n.unwrap_or(0.0);
    let force_before = before
        .iter()
        .filter(|x| x.t_s > tf - args.before_s)
        .map(force)
        .fold(0.0, f64::max);
    let force_after = after.iter().map(force).fold(0.0, f64::max);
    let force_after_released = after
        .iter()
        .filter(|x| !driving(x))
        .map(force)
        .fold(0.0, f64::max);
    let feed_hold_after = after.iter().any(|x| x.feed_hold);
    // Controller side: no period with an unusable force sample or a link fault raised the
    // command above the one before it.
    let raised = fault_periods_raising(r);
    let log_complete =
        !r.is_empty() && r.windows(2).all(|w| w[1].period == w[0].period + 1) && r[0].period == 0;

    let mut problems = Vec::new();
    if m.is_empty() || after.is_empty() {
        problems.push("no machine rows after the fault".to_string());
    }
    if last_cmd.is_none() {
        problems.push("ACC was not active before the fault".into());
    }
    let untested = untested(&before, r, tf);
    problems.extend(untested.clone());
    if let Some(first) = over.first() {
        problems.push(format!(
            "override above ACC's last command in {} periods (first {first})",
            over.len()
        ));
    }
    let on_line = matches!(f.action, Action::Line { .. });
    if on_line {
        // ACC drives through a bad line: every period counts in which the feed moved.
        let moving = after
            .iter()
            .filter(|x| !x.feed_hold)
            .max_by(|a, b| force(a).total_cmp(&force(b)));
        if let Some(x) = moving.filter(|x| force(x) > 1.05 * force_before) {
            problems.push(format!(
                "force {force_before:.0} → {:.0} N at t = {:.1} s with the feed not held (> 1.05×)",
                force(x),
                x.t_s
            ));
        }
    } else if force_after_released > 1.05 * force_before {
        problems.push(format!(
            "force {force_before:.0} → {force_after_released:.0} N with ACC not driving (> 1.05×)"
        ));
    }
    if raised > 0 {
        problems.push(format!("{raised} fault periods raised the command"));
    }
    if !log_complete {
        problems.push("acc run's log misses periods".into());
    }
    let line = logs
        .line
        .filter(|_| on_line)
        .map(|l| judge_line(l, r, tf, &mut problems));
    let (verdict, ok) = if let Some(why) = f.not_judged {
        (format!("not judged: {why}"), true)
    } else if problems.is_empty() {
        ("pass".to_string(), true)
    } else if protocol == 1 && f.v1_unsafe.is_some() {
        (
            format!(
                "unsafe on v1 ({}): {}",
                problems.join("; "),
                f.v1_unsafe.unwrap_or_default()
            ),
            true,
        )
    } else {
        (format!("FAIL: {}", problems.join("; ")), false)
    };
    Row {
        fault: f.name.into(),
        what: f.what.into(),
        protocol,
        t_fault_s: t_fault,
        last_cmd_pct: last_cmd,
        max_applied_after_pct: max_released,
        force_before_n: force_before,
        force_after_n: force_after,
        force_after_released_n: force_after_released,
        raised_in_fault: raised,
        feed_hold_after,
        log_rows: r.len(),
        log_complete,
        exit,
        verdict,
        ok,
        line,
        first_attempt: None,
        untested,
    }
}

/// The hostile-line criteria (see the module docs); problems are added to `problems`.
fn judge_line(l: &ProxyLog, r: &[RunRecord], tf: f64, problems: &mut Vec<String>) -> LineReport {
    let mut rep = LineReport::default();
    match &l.stats {
        Some(st) => {
            rep.proxy = st.clone();
            if st.episodes != 1 {
                problems.push(format!(
                    "the proxy's faults were switched on {} times (1 expected)",
                    st.episodes
                ));
            }
        }
        None => problems.push("the proxy wrote no counters".into()),
    }
    rep.altered_replies = rep.proxy.altered_replies;
    if l.events.is_empty() {
        problems.push("the proxy altered no reply: the fault did not happen".into());
    }
    let mut corrupted = std::collections::BTreeSet::new();
    let mut must: std::collections::BTreeMap<u64, &ProxyEvent> = Default::default();
    for e in &l.events {
        let Some(i) = e.read_index.filter(|_| e.fc == 4) else {
            continue;
        };
        if e.kind == "delay" {
            rep.delayed_reads += 1;
            continue;
        }
        corrupted.insert(i);
        if must_be_flagged(e, MAX_POWER_W) {
            must.entry(i).or_insert(e);
        }
    }
    rep.corrupted_reads = corrupted.len();
    rep.must_flag = must.len();
    let after = || r.iter().filter(|x| x.t_s > tf);
    rep.suspicious_rows = after().filter(|x| suspicious(&x.flags)).count();
    let alignment = align_reads(r, &l.reads);
    rep.aligned = (alignment.checked, alignment.agreed);
    if alignment.reliable() {
        rep.matching = "read by read".into();
        for (i, e) in &must {
            let row = alignment.row_of_read.get(i).map(|&j| &r[j]);
            if row.is_some_and(|x| suspicious(&x.flags)) {
                rep.flagged += 1;
            } else {
                let reg = e
                    .register
                    .map_or(String::new(), |g| format!(" register {g}"));
                let at = row.map_or("no row".to_string(), |x| {
                    format!("t = {:.1} s, flags `{}`", x.t_s, x.flags)
                });
                rep.unflagged
                    .push(format!("read #{i} ({}{reg}): {at}", e.kind));
            }
        }
        if let Some(first) = rep.unflagged.first() {
            problems.push(format!(
                "{} of {} corrupted status reads not flagged (first {first})",
                rep.unflagged.len(),
                rep.must_flag
            ));
        }
    } else {
        rep.matching = "counts".into();
        rep.flagged = rep.suspicious_rows;
        if rep.flagged < rep.must_flag {
            problems.push(format!(
                "{} flagged rows after the fault for {} corrupted status reads (reads not matched to rows: {} of {} powers agreed)",
                rep.flagged, rep.must_flag, alignment.agreed, alignment.checked
            ));
        }
    }
    // A release labelled as the operator's: the proxy never touches the knob or the switch.
    let operator = |x: &RunRecord| matches!(x.state.as_str(), "operator_handback" | "switch_off");
    let mut prev_operator = r
        .iter()
        .take_while(|x| x.t_s <= tf)
        .last()
        .is_some_and(operator);
    let mut first = None;
    for x in after() {
        let now = operator(x);
        if now && !prev_operator {
            rep.operator_releases += 1;
            first.get_or_insert(format!("t = {:.1} s: {}", x.t_s, x.state));
        }
        prev_operator = now;
    }
    if let Some(first) = first {
        problems.push(format!(
            "{} releases labelled as the operator's (first {first}): a bad frame taken for the operator",
            rep.operator_releases
        ));
    }
    rep
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::super::faults::FAULTS;
    use super::*;
    use crate::proxy::ProxyRead;

    fn row(t: f64, state: &str, applied: u16, force: f64, hold: bool, period: u64) -> RunRecord {
        RunRecord {
            t_s: t,
            period,
            state: state.into(),
            override_applied_pct: Some(applied),
            force_true_n: Some(force),
            feed_hold: hold,
            ..RunRecord::default()
        }
    }

    fn args() -> FaultMatrixArgs {
        FaultMatrixArgs {
            out: PathBuf::from("x"),
            protocol: "both".into(),
            only: vec![],
            scenario: PathBuf::from("s"),
            config: PathBuf::from("c"),
            plan_config: PathBuf::from("pc"),
            time_scale: 10.0,
            at_s: 1.0,
            before_s: 1.0,
            after_s: 1.0,
            line_after_s: 1.0,
            proxy: PathBuf::from("p"),
            line_seed: 1,
            jobs: 1,
            linuxcnc: false,
            linuxcnc_program: PathBuf::from("p.ngc"),
            linuxcnc_stock_box: "0,0,0,1,1,1".into(),
        }
    }

    /// `kill -9` at t = 1 s on a board of `protocol`, judged from machine rows `m` and
    /// `acc run` rows `r` (no hostile line).
    fn judge_sigkill(protocol: u8, m: &[RunRecord], r: &[RunRecord]) -> Row {
        let sigkill = FAULTS.iter().find(|f| f.name == "sigkill").expect("row");
        let logs = Logs {
            machine: m,
            run: r,
            line: None,
        };
        judge(sigkill, protocol, Some(1.0), logs, "killed".into(), &args())
    }

    #[test]
    fn a_raised_override_or_force_fails_and_a_held_feed_does_not_count() {
        let run: Vec<RunRecord> = (0..5)
            .map(|i| row(0.1 * i as f64, "active", 80, 0.0, false, i))
            .collect();
        // The knob's 100 % while the feed is held: fine.
        let m = vec![
            row(0.9, "acc_active", 80, 800.0, false, 9),
            row(1.0, "acc_active", 80, 800.0, false, 10),
            row(1.1, "operator", 100, 700.0, true, 11),
            row(1.2, "operator", 100, 0.0, true, 12),
        ];
        let r = judge_sigkill(2, &m, &run);
        assert!(r.ok && r.verdict == "pass", "{r:?}");
        assert_eq!((r.last_cmd_pct, r.max_applied_after_pct), (Some(80), None));
        // The knob's 100 % with the feed moving: a failure on v2, marked on v1.
        let m2 = vec![
            row(1.0, "acc_active", 80, 800.0, false, 10),
            row(1.1, "operator", 100, 900.0, false, 11),
        ];
        let r = judge_sigkill(2, &m2, &run);
        assert!(!r.ok && r.verdict.starts_with("FAIL"), "{r:?}");
        assert!(r.verdict.contains("80 → 100") && r.verdict.contains("800 → 900"));
        let r = judge_sigkill(1, &m2, &run);
        assert!(r.ok && r.verdict.starts_with("unsafe on v1"), "{r:?}");
        // A gap in acc run's periods fails the log check.
        let mut gappy = run.clone();
        gappy.remove(2);
        let r = judge_sigkill(2, &m, &gappy);
        assert!(!r.ok && r.verdict.contains("misses periods"), "{r:?}");
    }

    #[test]
    fn a_fault_that_met_no_cut_under_acc_tested_nothing() {
        // ACC had released with a feed hold at 0.8 s: the signal at 1 s found the machine
        // standing, and no rule was broken, but the row tested nothing.
        let run: Vec<RunRecord> = (0..11)
            .map(|i| {
                let state = if i < 8 { "active" } else { "power_invalid" };
                row(0.1 * i as f64, state, 70, 0.0, false, i)
            })
            .collect();
        let m = vec![
            row(0.9, "operator", 70, 0.0, true, 9),
            row(1.0, "operator", 70, 0.0, true, 10),
            row(1.1, "operator", 70, 0.0, true, 11),
        ];
        let r = judge_sigkill(2, &m, &run);
        assert!(!r.ok, "{r:?}");
        let why = r.untested.as_deref().unwrap_or_default();
        assert!(why.contains("met no cut under ACC"), "{why}");
        assert!(why.contains("`power_invalid` since t = 0.8 s"), "{why}");
        assert!(r.verdict.contains(why), "{}", r.verdict);
        // Driving the cut at the fault moment: tested.
        let m = vec![
            row(1.0, "acc_active", 80, 800.0, false, 10),
            row(1.1, "operator", 80, 0.0, true, 11),
        ];
        assert_eq!(judge_sigkill(2, &m, &run).untested, None);
    }

    #[test]
    fn on_a_hostile_line_every_corrupted_read_is_flagged_and_no_release_is_the_operators() {
        // acc run's rows 0..40 (0.1 s apart), one read each after one start-up read.
        let run = |flags_at_20: &str, state_at_25: &str| -> Vec<RunRecord> {
            (0..40)
                .map(|i| RunRecord {
                    t_s: 0.1 * i as f64,
                    period: i as u64,
                    power_w: Some(1000.0 + i as f64),
                    flags: if i == 20 { flags_at_20 } else { "" }.into(),
                    state: if i >= 25 { state_at_25 } else { "active" }.into(),
                    ..RunRecord::default()
                })
                .collect()
        };
        let ev = |read: u64, kind: &str, register: Option<u16>| ProxyEvent {
            t: 0.0,
            read_index: Some(read),
            fc: 4,
            kind: kind.into(),
            register,
            bit: Some(1),
            before: Some(100),
            after: Some(102),
        };
        let input = ProxyLog {
            stats: Some(ProxyStats {
                episodes: 1,
                altered_replies: 3,
                ..ProxyStats::default()
            }),
            // Read 21 (row 20): a flipped OPERATOR_OVERRIDE bit; read 31: a flipped
            // SPINDLE_RPM bit (not required); a write's echo (not a read).
            events: vec![
                ev(21, "flip", Some(2)),
                ev(31, "flip", Some(6)),
                ProxyEvent {
                    read_index: None,
                    fc: 16,
                    ..ev(0, "slave", None)
                },
            ],
            reads: (0..41)
                .map(|i| ProxyRead {
                    i: Some(i),
                    power: Some(999.0 + i as f64),
                    applied: None,
                    altered: false,
                })
                .collect(),
        };
        let mut problems = Vec::new();
        let rep = judge_line(
            &input,
            &run("unconfirmed:operator_override", "active"),
            1.0,
            &mut problems,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!((rep.corrupted_reads, rep.must_flag, rep.flagged), (2, 1, 1));
        assert_eq!(rep.matching, "read by read");
        let rep = judge_line(
            &input,
            &run("seq_skip:2", "operator_handback"),
            1.0,
            &mut problems,
        );
        assert_eq!((rep.flagged, rep.operator_releases), (0, 1));
        assert!(problems[0].contains("1 of 1 corrupted status reads not flagged (first read #21 (flip register 2): t = 2.0 s"), "{problems:?}");
        assert!(
            problems[1].contains("t = 2.5 s: operator_handback"),
            "{problems:?}"
        );
    }
}
