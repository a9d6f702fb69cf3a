//! The judgement of one row from its logs. A fault from outside the program (acc killed or
//! frozen, the power frozen, the operator's knob, a pause, the estop) is judged here: what
//! acc allowed before the fault against what the motion got after it. A program's own
//! event goes on to [`judge_program_event`].
//!
//! The steps, in order: [`fault_moment`], [`machine_log_figures`], [`RunClock::place`],
//! [`run_log_figures`], then [`failures`] or [`judge_program_event`], then [`finish`].

use acc_linuxcnc::machine_log::MachineRow;
use acc_runtime::record::RunRecord;

use super::outcome::{outcome, program_end};
use super::program_event::judge_program_event;
use super::row::{LcncRow, AFTER_S, BEFORE_S, CONTACT_SHARE, MAX_STOP_S, RAISE_GRACE_S, SILENT_S};
use super::rows::{program_event, LcncFault};

/// What acc allowed in a machine-log row: feed override × adaptive feed, percent.
pub(super) fn applied(r: &MachineRow) -> f64 {
    100.0 * r.feed_override * r.adaptive_feed
}

/// The tool is in the stock: the true force above [`CONTACT_SHARE`] of Fr.
pub(super) fn in_contact(force_n: f64, fr_n: f64) -> bool {
    force_n > CONTACT_SHARE * fr_n
}

/// The machine-log row nearest after `t` (the last one past the end).
pub(super) fn machine_row_at(machine: &[MachineRow], t: f64) -> Option<&MachineRow> {
    let k = machine.partition_point(|r| r.t_s < t);
    machine.get(k.min(machine.len().saturating_sub(1)))
}

/// Raises `m` to `v` (`None` counts as below everything).
fn raise(m: &mut Option<f64>, v: f64) {
    *m = Some(m.map_or(v, |m| m.max(v)));
}

/// Judges one row from its logs: the machine log, acc's run log and `ui.log`; `fr_n` is
/// the force reference.
pub fn judge(
    f: &LcncFault,
    fr_n: f64,
    machine: &[MachineRow],
    run: &[RunRecord],
    ui_log: &str,
) -> LcncRow {
    let mut row = LcncRow {
        fault: f.name.to_string(),
        what: f.what.to_string(),
        at_force_n: f.at_force_n,
        delay_s: f.delay_s,
        log_rows: run.len(),
        log_complete: !run.is_empty() && run.windows(2).all(|w| w[1].period == w[0].period + 1),
        program: program_end(ui_log),
        ..LcncRow::default()
    };
    let Some(i_f) = fault_moment(machine) else {
        let why = format!("the fault never came (true force below {} N)", f.at_force_n);
        row.verdict = format!("FAIL: {why}");
        return row;
    };
    machine_log_figures(&mut row, fr_n, machine, i_f);
    let clock = RunClock::place(machine, run, i_f);
    run_log_figures(&mut row, fr_n, machine, run, &clock);
    row.allowed_pct = allowed_with_last_write(&row, machine, i_f);
    let why = if program_event(f) {
        let (figures, why) = judge_program_event(f, fr_n, machine, i_f, run, clock.offset_s, &row);
        // The generic after-the-fault figures do not apply to the program's own event.
        row.force_after_n = figures.peak_after_n;
        row.stop_s = None;
        row.knob_s = None;
        row.max_cmd_after_pct = None;
        row.cmd_at_grace_pct = None;
        row.event = Some(figures);
        why
    } else {
        failures(f, &row)
    };
    finish(f, row, why)
}

/// What acc last allowed: the applied override in the machine-log row before the fault, or
/// acc's last command before it if that is higher (on the knob of that row: applied =
/// 100 × knob × command / 150 %, the knob a ratio). `ui.py` marks the fault a few ms before it signals acc, and
/// acc's write of the period that was running may land in between: the machine log's
/// last row before the mark then still shows the command before.
fn allowed_with_last_write(row: &LcncRow, machine: &[MachineRow], i_f: usize) -> Option<f64> {
    let knob = machine[..i_f].last()?.feed_override;
    let by_write = row
        .last_cmd_pct
        .map(|c| 100.0 * knob * f64::from(c) / acc_linuxcnc::mapping::LAW_MAX_PCT);
    match (row.allowed_pct, by_write) {
        (Some(a), Some(w)) => Some(a.max(w)),
        (a, _) => a,
    }
}

/// The first machine-log row `ui.py` marked as the fault's (`None`: it never came).
fn fault_moment(machine: &[MachineRow]) -> Option<usize> {
    machine.iter().position(|r| r.fault)
}

/// From the machine log around the fault at row `i_f`: what acc allowed just before, the
/// forces before and after, the stop, the knob's effect, and the largest applied override
/// in the cut after the fault (all of it, and while acc's heartbeat was silent).
fn machine_log_figures(row: &mut LcncRow, fr_n: f64, machine: &[MachineRow], i_f: usize) {
    let t_f = machine[i_f].t_s;
    row.t_fault_s = Some(t_f);
    let before = machine[..i_f].last();
    row.allowed_pct = before.map(applied);
    row.force_before_n = machine[..i_f]
        .iter()
        .filter(|r| r.t_s >= t_f - BEFORE_S)
        .map(|r| r.force_n)
        .fold(0.0, f64::max);
    let after = &machine[i_f..];
    let log_end = machine.last().map_or(t_f, |r| r.t_s);
    row.force_after_n = (log_end - t_f > 0.5).then(|| {
        after
            .iter()
            .filter(|r| r.t_s <= t_f + AFTER_S)
            .map(|r| r.force_n)
            .fold(0.0, f64::max)
    });
    row.stop_s = after
        .iter()
        .find(|r| r.feed_mm_min <= 0.0)
        .map(|r| r.t_s - t_f);
    // The programmed feed F from the last row before: feed = F × override × adaptive.
    if let Some(b) = before.filter(|b| b.feed_override * b.adaptive_feed > 0.01) {
        let programmed = b.feed_mm_min / (b.feed_override * b.adaptive_feed);
        row.knob_s = after
            .iter()
            .find(|r| {
                r.feed_override < b.feed_override
                    && r.feed_mm_min <= 1.1 * programmed * r.feed_override
            })
            .map(|r| r.t_s - t_f);
    }
    // In the cut and moving after the fault; acc silent (no heartbeat toggle) or not.
    let mut last_change = machine[..=i_f]
        .windows(2)
        .rposition(|w| w[0].heartbeat != w[1].heartbeat)
        .map_or(machine[0].t_s, |k| machine[k + 1].t_s);
    for w in machine[i_f.saturating_sub(1)..].windows(2) {
        let r = &w[1];
        if w[0].heartbeat != r.heartbeat {
            last_change = r.t_s;
        }
        if r.feed_mm_min > 0.0 && in_contact(r.force_n, fr_n) {
            raise(&mut row.max_applied_in_cut_pct, applied(r));
            if r.t_s - last_change > SILENT_S {
                raise(&mut row.max_applied_not_driving_pct, applied(r));
            }
        }
    }
}

/// The run log on the machine log's clock: both start with their processes; acc's first
/// heartbeat toggle (its first status read) ties them, to within one period.
struct RunClock {
    /// Machine-log time minus run-log time, s.
    offset_s: f64,
    /// The fault on the run log's clock, s.
    t_fault_run_s: f64,
    /// The machine log's last row, s.
    log_end_s: f64,
}

impl RunClock {
    /// Ties the two clocks (offset 0 when either log has no toggle or no row); the fault
    /// is machine-log row `i_f`.
    fn place(machine: &[MachineRow], run: &[RunRecord], i_f: usize) -> Self {
        let first_beat = machine
            .windows(2)
            .position(|w| w[0].heartbeat != w[1].heartbeat)
            .map(|k| machine[k + 1].t_s);
        let offset_s = match (first_beat, run.first()) {
            (Some(t), Some(r0)) => t - r0.t_s,
            _ => 0.0,
        };
        let t_f = machine[i_f].t_s;
        let log_end_s = machine.last().map_or(t_f, |r| r.t_s);
        Self {
            offset_s,
            t_fault_run_s: t_f - offset_s,
            log_end_s,
        }
    }
}

/// From acc's run log after the fault: its last command before, its states after, the
/// applied override in the cut while it did not drive (where the machine log has ended,
/// "in the cut" is the cut's programmed feed), and its commands after the grace.
fn run_log_figures(
    row: &mut LcncRow,
    fr_n: f64,
    machine: &[MachineRow],
    run: &[RunRecord],
    clock: &RunClock,
) {
    let t_f_run = clock.t_fault_run_s;
    let cut_feed = run
        .iter()
        .rev()
        .find(|r| r.t_s <= t_f_run)
        .and_then(|r| r.programmed_feed_mm_min);
    row.last_cmd_pct = run
        .iter()
        .rev()
        .filter(|r| r.t_s <= t_f_run)
        .find_map(|r| r.override_cmd_pct);
    let mut states: Vec<String> = Vec::new();
    for r in run.iter().filter(|r| r.t_s > t_f_run) {
        if states.last() != Some(&r.state) && !r.state.is_empty() {
            states.push(r.state.clone());
        }
        let t = r.t_s + clock.offset_s;
        let in_stock = if t <= clock.log_end_s {
            machine_row_at(machine, t).is_some_and(|m| in_contact(m.force_n, fr_n))
        } else {
            match (r.programmed_feed_mm_min, cut_feed) {
                (Some(p), Some(c)) => (p - c).abs() <= 0.01 * c.max(1.0),
                _ => true,
            }
        };
        let moving = r.feed_mm_min.is_some_and(|v| v > 0.0);
        if r.state != "active" && in_stock && moving {
            if let Some(a) = r.override_applied_pct {
                raise(&mut row.max_applied_not_driving_pct, f64::from(a));
            }
        }
    }
    row.states_after = states;
    let grace = t_f_run + RAISE_GRACE_S;
    row.cmd_at_grace_pct = run
        .iter()
        .rev()
        .filter(|r| r.t_s <= grace)
        .find_map(|r| r.override_cmd_pct);
    row.max_cmd_after_pct = run
        .iter()
        .filter(|r| r.t_s > grace)
        .filter_map(|r| r.override_cmd_pct)
        .max();
}

/// The criteria of a fault from outside the program, on the row's figures: applied ≤
/// allowed (+ 1 %, the pins' rounding) while acc does not drive, force after ≤ 1.05 ×
/// before, no raise where acc must not raise, the watchdog's stop within
/// [`MAX_STOP_S`]. The failures, in words.
fn failures(f: &LcncFault, row: &LcncRow) -> Vec<String> {
    let mut why: Vec<String> = Vec::new();
    match (row.allowed_pct, row.max_applied_not_driving_pct) {
        (None, _) => why.push("no machine-log row before the fault".into()),
        (Some(allowed), Some(m)) if m > allowed + 1.0 => why.push(format!(
            "applied {m:.0} % with acc not driving, above the {allowed:.0} % it allowed"
        )),
        _ => {}
    }
    if let Some(a) = row.force_after_n {
        if a > 1.05 * row.force_before_n {
            why.push(format!(
                "force after {a:.0} N > 1.05 × {:.0} N before",
                row.force_before_n
            ));
        }
    }
    if f.no_raise {
        if let (Some(m), Some(c)) = (row.max_cmd_after_pct, row.cmd_at_grace_pct) {
            if m > c {
                why.push(format!(
                    "acc raised its command to {m} % after the fault (it was {c} %)"
                ));
            }
        }
    }
    if f.watchdog_stop {
        match row.stop_s {
            Some(s) if s <= MAX_STOP_S => {}
            Some(s) => why.push(format!("the motion stopped {s:.3} s after the fault")),
            None => why.push("the motion did not stop".into()),
        }
    }
    why
}

/// The row's outcome in words and its verdict: `pass`, or `FAIL:` with every failure
/// (a run log with a missing period always fails).
fn finish(f: &LcncFault, mut row: LcncRow, mut why: Vec<String>) -> LcncRow {
    if !row.log_complete {
        why.push("run-log periods not consecutive".into());
    }
    row.outcome = outcome(f, &row);
    row.ok = why.is_empty();
    row.verdict = if row.ok {
        "pass".into()
    } else {
        format!("FAIL: {}", why.join("; "))
    };
    row
}
