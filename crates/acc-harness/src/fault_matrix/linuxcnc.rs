//! The LinuxCNC section of `acc fault-matrix` (`--linuxcnc`): each row is one `acc linuxcnc
//! PROGRAM --fault KIND@N` run (headless LinuxCNC 2.9, `acc run --hal`, the simulated process
//! `acc linuxcnc-process`, the realtime watchdog of `configs/linuxcnc/acc.hal`); `ui.py`
//! carries the fault out the first time the true force reaches N and marks the moment in the
//! machine log (`fault` column). One LinuxCNC runs per host: the rows run one after another.
//!
//! A row is judged from the machine log (true force, feed, the adaptive feed acc wrote, the
//! operator's feed override, acc's heartbeat) and acc's run log:
//!
//! - **allowed**: what acc last allowed, `100 × feed override × adaptive feed` in the
//!   machine log's last row before the fault (percent of the programmed feed);
//! - **max applied, ACC not driving**: the largest applied override after the fault while
//!   the tool is in the stock (true force above 2 % of Fr; where the machine log has ended,
//!   the cut's programmed feed) and the feed moves, in the periods acc does not drive (its
//!   run log's state is not `active`) and while acc is silent (no heartbeat for 0.15 s: dead
//!   or frozen, the machine log's adaptive feed); rapids are not counted (acc never slows
//!   them, by design);
//! - **max cmd after** (the rows where acc must not raise: frozen acc, frozen power): the
//!   largest override acc commanded from 0.25 s after the fault (its last real sample is in
//!   by then) against its last command up to then;
//! - **force before / after**: the largest true force in the 1 s before the fault and in the
//!   5 s after it (none when the process is the fault: it is dead);
//! - **log complete**: the run log's periods consecutive.
//!
//! Pass: max applied ≤ allowed (+ 1 %, the pins' rounding), force after ≤ 1.05 × before, log
//! complete, no raise where acc must not raise, and for a dead or frozen acc the motion
//! stopped within 0.3 s of the fault. The run log's and the machine log's clocks start with
//! their processes: the run log is placed on the machine log's time by acc's first heartbeat
//! toggle (its first status read), to within one period.

use std::path::{Path, PathBuf};
use std::time::Duration;

use acc_linuxcnc::machine_log::{self, MachineLogError, MachineRow};
use acc_runtime::record::RunRecord;
use anyhow::{bail, Context};

use super::FaultMatrixArgs;
use crate::child::{describe, read, Proc};

/// One LinuxCNC row: `acc linuxcnc --fault KIND@N`.
#[derive(Debug, Clone, Copy)]
pub struct LcncFault {
    /// Row name, and `--fault`'s KIND.
    pub name: &'static str,
    /// What the fault is.
    pub what: &'static str,
    /// acc must not raise its command after the fault (it is frozen, or its power is).
    pub no_raise: bool,
    /// acc is dead or frozen: the watchdog must stop the motion within 0.3 s.
    pub watchdog_stop: bool,
    /// The fault comes when the true force first reaches this, N, …
    pub at_force_n: f64,
    /// … and this long after, s.
    pub delay_s: f64,
    /// The row's own NC program, a file beside `--linuxcnc-program` (`tests/nc/`), for a
    /// fault the program makes itself (`M52 P0`, `M6`); `None`: `--linuxcnc-program`.
    pub program: Option<&'static str>,
}

/// 1 000 N + 2.5 s: the settled heavy slot of `tests/nc/linuxcnc_short.ngc` (only its entry
/// reaches 1 000 N; the light slot stays below 900 N).
const HEAVY: (f64, f64) = (1000.0, 2.5);
/// 700 N + 0 s: the light slot's entry. A power frozen there reads below Fr while the heavy
/// slot is still to come: the worst moment for a frozen power.
const LIGHT_ENTRY: (f64, f64) = (700.0, 0.0);

/// The rows, in the order they run.
pub static LCNC_FAULTS: [LcncFault; 9] = [
    LcncFault {
        name: "kill-acc",
        what: "acc killed (SIGKILL) in the heavy cut; program aborted 2 s later",
        no_raise: true,
        watchdog_stop: true,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "stop-acc",
        what: "acc frozen (SIGSTOP 2 s, then SIGCONT; the watchdog re-armed 0.5 s later)",
        no_raise: true,
        watchdog_stop: true,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "kill-process",
        what: "the power pin frozen while the spindle turns (acc-process killed)",
        no_raise: true,
        watchdog_stop: false,
        at_force_n: LIGHT_ENTRY.0,
        delay_s: LIGHT_ENTRY.1,
        program: None,
    },
    LcncFault {
        name: "feed-override",
        what: "the operator's feed override to 30 % (feedrate(0.3))",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "pause",
        what: "program paused (AUTO_PAUSE) 2 s, then resumed",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "estop",
        what: "estop mid-cut",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "m52-off",
        what: "the program switches the adaptive feed off mid-cut (`M52 P0`, F60) and on again (`M52 P1`): tests/nc/linuxcnc/m52.ngc",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: LIGHT_ENTRY.0,
        delay_s: LIGHT_ENTRY.1,
        program: Some("linuxcnc/m52.ngc"),
    },
    LcncFault {
        name: "abort-restart",
        what: "program aborted in the heavy cut (the operator's abort, Z retracted), then run again from its start",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: HEAVY.0,
        delay_s: HEAVY.1,
        program: None,
    },
    LcncFault {
        name: "tool-change",
        what: "a tool change between two cuts (`M5`, `T2 M6`, `M3`; tool table T1, T2): tests/nc/linuxcnc_tool_change.ngc",
        no_raise: false,
        watchdog_stop: false,
        at_force_n: LIGHT_ENTRY.0,
        delay_s: LIGHT_ENTRY.1,
        program: Some("linuxcnc_tool_change.ngc"),
    },
];

/// The rows whose fault is the program's own or a restart: judged by their own criteria
/// ([`judge_program_event`]), not by the force in the 5 s after the fault.
fn program_event(f: &LcncFault) -> bool {
    matches!(f.name, "m52-off" | "abort-restart" | "tool-change")
}

/// The window before the fault for the reference force, s.
const BEFORE_S: f64 = 1.0;
/// The window after the fault for the largest force, s (a 2 s pause and 3 s of cut after).
const AFTER_S: f64 = 5.0;
/// Silence of acc's heartbeat that counts as a dead or frozen acc, s (its period is 0.1 s).
const SILENT_S: f64 = 0.15;
/// After the fault, the run log's rows from this on are judged for a raise, s.
const RAISE_GRACE_S: f64 = 0.25;
/// The longest stop after a dead or frozen acc, s (docs/linuxcnc.md: 0.216 s measured).
const MAX_STOP_S: f64 = 0.3;

/// The measured outcome of one LinuxCNC row.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LcncRow {
    /// Row name (`--fault`'s KIND).
    pub fault: String,
    /// What the fault is.
    pub what: String,
    /// The true force that triggered it, N.
    pub at_force_n: f64,
    /// The fault came this long after that force, s.
    pub delay_s: f64,
    /// The fault's moment on the machine log's clock, s.
    pub t_fault_s: Option<f64>,
    /// What acc last allowed before the fault: feed override × adaptive feed, percent.
    pub allowed_pct: Option<f64>,
    /// acc's last command before the fault (run log), percent.
    pub last_cmd_pct: Option<u16>,
    /// Largest applied override after the fault, in the stock, feed moving, acc not
    /// driving or silent, percent (`None`: no such period).
    pub max_applied_not_driving_pct: Option<f64>,
    /// Largest applied override after the fault in the stock, feed moving, whoever drove.
    pub max_applied_in_cut_pct: Option<f64>,
    /// acc's largest command from [`RAISE_GRACE_S`] after the fault, and its last command
    /// up to then (rows where acc must not raise).
    pub max_cmd_after_pct: Option<u16>,
    /// acc's last command up to [`RAISE_GRACE_S`] after the fault.
    pub cmd_at_grace_pct: Option<u16>,
    /// Largest true force in the [`BEFORE_S`] before the fault, N.
    pub force_before_n: f64,
    /// Largest true force in the [`AFTER_S`] after it, N (`None`: the machine log ends with
    /// the fault).
    pub force_after_n: Option<f64>,
    /// From the fault to the feed at 0, s.
    pub stop_s: Option<f64>,
    /// From the fault to the feed at most the knob's share of the programmed feed (+ 10 %),
    /// s (the operator's row).
    pub knob_s: Option<f64>,
    /// The run log's states after the fault, in order, repeats dropped.
    pub states_after: Vec<String>,
    /// Run-log rows.
    pub log_rows: usize,
    /// Run-log periods consecutive.
    pub log_complete: bool,
    /// How the program ended (`ui.log`).
    pub program: String,
    /// `acc linuxcnc`'s exit.
    pub exit: String,
    /// The outcome in words.
    pub outcome: String,
    /// Every criterion met.
    pub ok: bool,
    /// `pass`, or `FAIL: why`.
    pub verdict: String,
    /// The figures of a program's own event (m52-off, abort-restart, tool-change).
    pub event: Option<EventFigures>,
}

/// What the rows of a program's own event measured ([`judge_program_event`]). Their
/// moments: `ui.py`'s marker is set while `M52 P0` is in force (m52-off), from the abort to
/// the restart (abort-restart), from the tool change on (tool-change); the event's end is
/// the marker's fall (`M52 P1` back, the restart) or, for a tool change, the change itself.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct EventFigures {
    /// The event's end on the machine log's clock, s (`None`: it never ended).
    pub t_end_s: Option<f64>,
    /// m52-off: the largest knob × adaptive feed on the pin while `M52 P0` was in force,
    /// i.e. what the motion gets the moment `M52 P1` is back, percent.
    pub pin_during_pct: Option<f64>,
    /// m52-off: the operator's override while `M52 P0` was in force (LinuxCNC then applies it
    /// alone: the program's feed, not acc's), percent.
    pub knob_during_pct: Option<f64>,
    /// m52-off: the largest applied override in the cut in the [`RETURN_S`] after the end,
    /// percent.
    pub applied_after_end_pct: Option<f64>,
    /// m52-off: the largest applied override in the cut in the [`BEFORE_S`] before the
    /// event: what acc allowed there (its law steps between neighbouring values), percent.
    pub allowed_recent_pct: Option<f64>,
    /// acc's last command up to the event, percent.
    pub cmd_before_pct: Option<u16>,
    /// acc's first command from the event's end on (abort-restart: the restarted run's
    /// first), percent.
    pub cmd_after_end_pct: Option<u16>,
    /// The largest true force before the event (tool-change, abort-restart: the whole run up
    /// to it), N.
    pub peak_before_n: f64,
    /// The largest true force after the event's end (in the [`AFTER_S`] after it for
    /// m52-off), N.
    pub peak_after_n: Option<f64>,
    /// abort-restart: the longest time the true force stayed above 1.05 × the force in the
    /// [`BEFORE_S`] before the abort, after the restart, s.
    pub longest_excursion_s: Option<f64>,
    /// tool-change: the mean true force over the second half of the cut after the change, N.
    pub settled_mean_n: Option<f64>,
    /// Run-log periods from the event's end to the last cut, in the cut, in which acc did
    /// not drive (state not `active`).
    pub periods_not_driving: usize,
    /// Run-log periods in the cut after the event's end in which acc's law was stepped.
    pub periods_stepped: usize,
}

/// The force that marks the tool in the stock: this share of Fr.
const CONTACT_SHARE: f64 = 0.02;
/// m52-off: after `M52 P1` is back, the applied override is judged this long, s (acc's
/// next read and write: 0.1 s, with margin).
const RETURN_S: f64 = 0.5;
/// abort-restart: the longest a true force above 1.05 × the force before may last after
/// the restart, s (one period to see it, one to act, the deceleration).
const MAX_EXCURSION_S: f64 = 0.3;
/// tool-change: the second cut's settled mean within this share of Fr.
const SETTLED_SHARE: f64 = 0.2;

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
    let Some(i_f) = machine.iter().position(|r| r.fault) else {
        row.verdict = format!(
            "FAIL: the fault never came (true force below {} N)",
            f.at_force_n
        );
        return row;
    };
    let t_f = machine[i_f].t_s;
    row.t_fault_s = Some(t_f);
    let applied = |r: &MachineRow| 100.0 * r.feed_override * r.adaptive_feed;
    let contact = |force_n: f64| force_n > CONTACT_SHARE * fr_n;
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

    // The machine log after the fault: in the cut, moving; acc silent or not.
    let mut last_change = machine[..=i_f]
        .windows(2)
        .rposition(|w| w[0].heartbeat != w[1].heartbeat)
        .map_or(machine[0].t_s, |k| machine[k + 1].t_s);
    let mut not_driving: Option<f64> = None;
    let mut in_cut: Option<f64> = None;
    let max = |m: &mut Option<f64>, v: f64| *m = Some(m.map_or(v, |m: f64| m.max(v)));
    for w in machine[i_f.saturating_sub(1)..].windows(2) {
        let r = &w[1];
        if w[0].heartbeat != r.heartbeat {
            last_change = r.t_s;
        }
        if r.feed_mm_min > 0.0 && contact(r.force_n) {
            max(&mut in_cut, applied(r));
            if r.t_s - last_change > SILENT_S {
                max(&mut not_driving, applied(r));
            }
        }
    }

    // The run log on the machine log's clock.
    let first_beat = machine
        .windows(2)
        .position(|w| w[0].heartbeat != w[1].heartbeat)
        .map(|k| machine[k + 1].t_s);
    let offset = match (first_beat, run.first()) {
        (Some(t), Some(r0)) => t - r0.t_s,
        _ => 0.0,
    };
    let t_f_run = t_f - offset;
    let near = |t: f64| {
        let k = machine.partition_point(|r| r.t_s < t);
        machine.get(k.min(machine.len().saturating_sub(1)))
    };
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
        let t = r.t_s + offset;
        let in_stock = if t <= log_end {
            near(t).is_some_and(|m| contact(m.force_n))
        } else {
            match (r.programmed_feed_mm_min, cut_feed) {
                (Some(p), Some(c)) => (p - c).abs() <= 0.01 * c.max(1.0),
                _ => true,
            }
        };
        let moving = r.feed_mm_min.is_some_and(|v| v > 0.0);
        if r.state != "active" && in_stock && moving {
            if let Some(a) = r.override_applied_pct {
                max(&mut not_driving, f64::from(a));
            }
        }
    }
    row.states_after = states;
    row.max_applied_not_driving_pct = not_driving;
    row.max_applied_in_cut_pct = in_cut;
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

    // The verdict.
    let mut why: Vec<String> = Vec::new();
    if program_event(f) {
        let (figures, event_why) = judge_program_event(f, fr_n, machine, i_f, run, offset, &row);
        why = event_why;
        // The generic after-the-fault figures do not apply to the program's own event.
        row.force_after_n = figures.peak_after_n;
        row.stop_s = None;
        row.knob_s = None;
        row.max_cmd_after_pct = None;
        row.cmd_at_grace_pct = None;
        row.event = Some(figures);
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
        return row;
    }
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
    if !row.log_complete {
        why.push("run-log periods not consecutive".into());
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
    row.outcome = outcome(f, &row);
    row.ok = why.is_empty();
    row.verdict = if row.ok {
        "pass".into()
    } else {
        format!("FAIL: {}", why.join("; "))
    };
    row
}

/// The criteria of a program's own event (m52-off, abort-restart, tool-change) on the
/// machine log (its first marked row `i_f`) and the run log (`offset` puts it on the
/// machine log's clock); `row` holds the generic figures. The figures and the failures.
///
/// - **m52-off**: while `M52 P0` is in force the pin keeps what acc allowed before it (the
///   law is frozen, not wound up: the moment `M52 P1` is back the motion gets that); in the
///   [`RETURN_S`] after the return the applied override is at most the largest acc
///   allowed in the [`BEFORE_S`] before `M52 P0` (its law steps on from there); in the
///   [`AFTER_S`] after the return no true force above 1.05 × the largest in the
///   [`BEFORE_S`] before `M52 P0` lasts longer than [`MAX_EXCURSION_S`] (the held command
///   is the one acc wrote as `M52 P0` came, which may be a step above the cut before it:
///   the law steps on the block end's deceleration, `M52` ends the blend); acc drives (and
///   its law steps) in the cut after the return.
/// - **abort-restart**: the program ran again and completed; acc's first command of the
///   restarted run is not above its last before the abort (no wind-up over the abort);
///   acc drives in every cut period of the restarted run; no true force above 1.05 × the
///   force before the abort lasts longer than [`MAX_EXCURSION_S`] (acc brings every entry
///   back; the entry itself is a feedback limit, stated as the peak).
/// - **tool-change**: acc drives in every cut period after the change (it neither latches
///   nor holds the feed on the `M5` / `M6` / `M3`); the second tool's peak is at most 1.05 ×
///   the first tool's (both entries from the air cut); its cut settles within
///   [`SETTLED_SHARE`] of Fr (second half's mean); the program completed.
pub fn judge_program_event(
    f: &LcncFault,
    fr_n: f64,
    machine: &[MachineRow],
    i_f: usize,
    run: &[RunRecord],
    offset: f64,
    row: &LcncRow,
) -> (EventFigures, Vec<String>) {
    let mut why: Vec<String> = Vec::new();
    let mut e = EventFigures::default();
    let contact = |force_n: f64| force_n > CONTACT_SHARE * fr_n;
    let applied = |r: &MachineRow| 100.0 * r.feed_override * r.adaptive_feed;
    let t_f = machine[i_f].t_s;
    let i_end = if f.name == "tool-change" {
        Some(i_f)
    } else {
        machine[i_f..]
            .iter()
            .position(|r| !r.fault)
            .map(|k| i_f + k)
    };
    let Some(i_end) = i_end else {
        why.push(match f.name {
            "m52-off" => "M52 P1 never came back (the marker stayed set)".to_string(),
            _ => "the program never ran again".to_string(),
        });
        return (e, why);
    };
    let t_end = machine[i_end].t_s;
    e.t_end_s = Some(t_end);
    let peak = |rows: &[MachineRow]| rows.iter().map(|r| r.force_n).fold(0.0, f64::max);
    e.peak_before_n = peak(&machine[..i_f]);
    let last_cut_t = machine
        .iter()
        .rev()
        .find(|r| contact(r.force_n))
        .map_or(t_end, |r| r.t_s);
    let on_machine = |r: &RunRecord| r.t_s + offset;
    e.cmd_before_pct = run
        .iter()
        .rev()
        .filter(|r| on_machine(r) <= t_f)
        .find_map(|r| r.override_cmd_pct);
    e.cmd_after_end_pct = run
        .iter()
        .filter(|r| on_machine(r) >= t_end)
        .find_map(|r| r.override_cmd_pct);
    let near = |t: f64| {
        let k = machine.partition_point(|r| r.t_s < t);
        machine.get(k.min(machine.len().saturating_sub(1)))
    };
    for r in run.iter().filter(|r| {
        let t = on_machine(r);
        t >= t_end && t <= last_cut_t
    }) {
        if near(on_machine(r)).is_some_and(|m| contact(m.force_n) && m.feed_mm_min > 0.0) {
            if r.state != "active" {
                e.periods_not_driving += 1;
            } else if !r.mode.is_empty() {
                e.periods_stepped += 1;
            }
        }
    }
    let completed = row.program.starts_with("completed");
    let allowed = row.allowed_pct.unwrap_or(0.0);
    match f.name {
        "m52-off" => {
            let section = &machine[i_f..i_end];
            e.pin_during_pct = section.iter().map(applied).reduce(f64::max);
            e.knob_during_pct = section
                .iter()
                .map(|r| 100.0 * r.feed_override)
                .reduce(f64::max);
            e.allowed_recent_pct = machine[..i_f]
                .iter()
                .filter(|r| r.t_s >= t_f - BEFORE_S && contact(r.force_n) && r.feed_mm_min > 0.0)
                .map(applied)
                .reduce(f64::max);
            e.applied_after_end_pct = machine[i_end..]
                .iter()
                .take_while(|r| r.t_s <= t_end + RETURN_S)
                .filter(|r| contact(r.force_n) && r.feed_mm_min > 0.0)
                .map(applied)
                .reduce(f64::max);
            e.peak_after_n = Some(peak(
                &machine[i_end..]
                    .iter()
                    .take_while(|r| r.t_s <= t_end + AFTER_S)
                    .copied()
                    .collect::<Vec<_>>(),
            ));
            if let Some(p) = e.pin_during_pct.filter(|p| *p > allowed + 1.0) {
                why.push(format!(
                    "the pin said {p:.0} % under M52 P0, above the {allowed:.0} % acc allowed: M52 P1 gets it"
                ));
            }
            let recent = e.allowed_recent_pct.unwrap_or(allowed).max(allowed);
            if let Some(a) = e.applied_after_end_pct.filter(|a| *a > recent + 1.0) {
                why.push(format!(
                    "applied {a:.0} % after M52 P1, above the {recent:.0} % acc allowed in the {BEFORE_S} s before M52 P0"
                ));
            }
            let longest = longest_excursion_s(
                &machine[i_end..]
                    .iter()
                    .take_while(|r| r.t_s <= t_end + AFTER_S)
                    .copied()
                    .collect::<Vec<_>>(),
                1.05 * row.force_before_n,
            );
            e.longest_excursion_s = Some(longest);
            if longest > MAX_EXCURSION_S {
                why.push(format!(
                    "the true force stayed above 1.05 × {:.0} N for {longest:.2} s after M52 P1",
                    row.force_before_n
                ));
            }
        }
        "abort-restart" => {
            e.peak_after_n = Some(peak(&machine[i_end..]));
            let longest = longest_excursion_s(&machine[i_end..], 1.05 * row.force_before_n);
            e.longest_excursion_s = Some(longest);
            if let (Some(a), Some(b)) = (e.cmd_after_end_pct, e.cmd_before_pct) {
                if a > b {
                    why.push(format!(
                        "acc restarted at {a} %, above its {b} % before the abort (wound up)"
                    ));
                }
            }
            if longest > MAX_EXCURSION_S {
                why.push(format!(
                    "the true force stayed above 1.05 × {:.0} N for {longest:.2} s after the restart",
                    row.force_before_n
                ));
            }
        }
        _ => {
            let after: Vec<&MachineRow> = machine[i_end..]
                .iter()
                .filter(|r| contact(r.force_n))
                .collect();
            e.peak_after_n = after.iter().map(|r| r.force_n).reduce(f64::max);
            let tail = &after[after.len() / 2..];
            e.settled_mean_n = (!tail.is_empty())
                .then(|| tail.iter().map(|r| r.force_n).sum::<f64>() / tail.len() as f64);
            match e.peak_after_n {
                None => why.push("no cut after the tool change".into()),
                Some(p) if p > 1.05 * e.peak_before_n => why.push(format!(
                    "the second tool's peak {p:.0} N > 1.05 × the first's {:.0} N",
                    e.peak_before_n
                )),
                _ => {}
            }
            if let Some(m) = e
                .settled_mean_n
                .filter(|m| (m - fr_n).abs() > SETTLED_SHARE * fr_n)
            {
                why.push(format!(
                    "the second tool's cut settled at {m:.0} N, not within {:.0} % of Fr {fr_n:.0} N",
                    100.0 * SETTLED_SHARE
                ));
            }
        }
    }
    if e.periods_not_driving > 0 {
        why.push(format!(
            "acc did not drive in {} cut periods after the event (states {})",
            e.periods_not_driving,
            row.states_after.join(" → ")
        ));
    }
    if e.periods_stepped == 0 {
        why.push("acc's law never stepped in the cut after the event".into());
    }
    if !completed {
        why.push(format!("the program {}", row.program));
    }
    (e, why)
}

/// The longest stretch of `rows` with the true force above `limit_n`, s (one still open at
/// the end counts to the last row).
fn longest_excursion_s(rows: &[MachineRow], limit_n: f64) -> f64 {
    let mut longest: f64 = 0.0;
    let mut since: Option<f64> = None;
    for r in rows {
        match (r.force_n > limit_n, since) {
            (true, None) => since = Some(r.t_s),
            (false, Some(t0)) => {
                longest = longest.max(r.t_s - t0);
                since = None;
            }
            _ => {}
        }
    }
    if let (Some(t0), Some(last)) = (since, rows.last()) {
        longest = longest.max(last.t_s - t0);
    }
    longest
}

/// How the program ended, from `ui.log`.
fn program_end(ui_log: &str) -> String {
    let cycle = ui_log.lines().find_map(|l| {
        l.split_once(" cycle_s ")
            .and_then(|(_, v)| v.trim().parse::<f64>().ok())
    });
    if ui_log.contains(" estop") {
        "ended by the estop".into()
    } else if ui_log.contains(" aborted") {
        "aborted".into()
    } else if let Some(c) = cycle {
        format!("completed ({c:.1} s)")
    } else {
        "did not complete".into()
    }
}

/// The row's outcome in words.
fn outcome(f: &LcncFault, r: &LcncRow) -> String {
    let mut parts: Vec<String> = Vec::new();
    let pct = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.0} %"));
    if let Some(e) = r.event.as_ref().filter(|_| program_event(f)) {
        parts.push(event_outcome(f, r, e));
        if !r.states_after.is_empty() {
            parts.push(format!("acc: {}", r.states_after.join(" → ")));
        }
        parts.push(format!("program {}", r.program));
        return parts.join("; ");
    }
    match f.name {
        "feed-override" => parts.push(match r.knob_s {
            Some(s) => format!("feed at the knob's 30 % {s:.2} s after the turn"),
            None => "the feed did not follow the knob".into(),
        }),
        "kill-process" => {
            parts.push("no true force after (the process is dead)".into());
        }
        _ => {
            if let Some(s) = r.stop_s {
                parts.push(format!("motion stopped {s:.3} s after the fault"));
            }
        }
    }
    parts.push(format!(
        "in the cut after it: applied ≤ {} (allowed {})",
        pct(r.max_applied_in_cut_pct),
        pct(r.allowed_pct)
    ));
    if !r.states_after.is_empty() {
        parts.push(format!("acc: {}", r.states_after.join(" → ")));
    }
    parts.push(format!("program {}", r.program));
    parts.join("; ")
}

/// The figures of a program's own event in words.
fn event_outcome(f: &LcncFault, r: &LcncRow, e: &EventFigures) -> String {
    let pct = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.0} %"));
    let u = |v: Option<u16>| v.map_or("–".to_string(), |v| format!("{v} %"));
    let n = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.0} N"));
    let dur = e
        .t_end_s
        .zip(r.t_fault_s)
        .map_or("–".to_string(), |(b, a)| format!("{:.1} s", b - a));
    match f.name {
        "m52-off" => format!(
            "M52 P0 for {dur}: LinuxCNC applied the knob's {} (the program's F), acc's law frozen, the pin held at {} (allowed {}); after M52 P1: applied ≤ {}, max force {} (before {:.0} N; above 1.05 × that for {}); law stepped in {} cut periods",
            pct(e.knob_during_pct),
            pct(e.pin_during_pct),
            pct(r.allowed_pct),
            pct(e.applied_after_end_pct),
            n(e.peak_after_n),
            r.force_before_n,
            e.longest_excursion_s.map_or("–".to_string(), |s| format!("{s:.2} s")),
            e.periods_stepped
        ),
        "abort-restart" => format!(
            "run again {dur} after the abort at acc's {} (last before the abort {}); peak after the restart {} (first run {:.0} N), above 1.05 × {:.0} N for at most {} (the re-entry into the wall the abort left, at the air cut's command); acc drove every cut period",
            u(e.cmd_after_end_pct),
            u(e.cmd_before_pct),
            n(e.peak_after_n),
            e.peak_before_n,
            r.force_before_n,
            e.longest_excursion_s.map_or("–".to_string(), |s| format!("{s:.2} s"))
        ),
        _ => format!(
            "second tool: peak {} (first tool {:.0} N), settled at {}; acc drove every cut period ({} not)",
            n(e.peak_after_n),
            e.peak_before_n,
            n(e.settled_mean_n),
            e.periods_not_driving
        ),
    }
}

/// The LinuxCNC section: every row (or `--only`'s), one after another; the table in
/// `--out` (`fault-matrix-linuxcnc.md`, `.json`) and printed; an error naming failed rows.
pub fn run(args: &FaultMatrixArgs) -> anyhow::Result<()> {
    for o in &args.only {
        if !LCNC_FAULTS.iter().any(|f| f.name == o) {
            let names: Vec<_> = LCNC_FAULTS.iter().map(|f| f.name).collect();
            bail!(
                "--only {o}: not a LinuxCNC row; allowed: {}",
                names.join(", ")
            );
        }
    }
    if !args.linuxcnc_program.is_file() {
        bail!(
            "--linuxcnc-program {}: no such file",
            args.linuxcnc_program.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let faults: Vec<&LcncFault> = LCNC_FAULTS
        .iter()
        .filter(|f| args.only.is_empty() || args.only.iter().any(|o| o == f.name))
        .collect();
    let mut rows = Vec::new();
    for (k, f) in faults.iter().enumerate() {
        let dir = args.out.join(format!("linuxcnc-{}", f.name));
        let row = run_row(args, f, &dir).with_context(|| format!("LinuxCNC row {}", f.name))?;
        eprintln!(
            "[{}/{}] linuxcnc {:<14} {}",
            k + 1,
            faults.len(),
            f.name,
            row.verdict
        );
        rows.push(row);
    }
    let table = markdown(&rows, args);
    std::fs::write(args.out.join("fault-matrix-linuxcnc.md"), &table)?;
    std::fs::write(
        args.out.join("fault-matrix-linuxcnc.json"),
        serde_json::to_string_pretty(&rows)?,
    )?;
    println!("{table}");
    let failed: Vec<_> = rows
        .iter()
        .filter(|r| !r.ok)
        .map(|r| r.fault.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} of {} LinuxCNC rows failed: {}",
            failed.len(),
            rows.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// The NC program of row `f`: its own beside `--linuxcnc-program`, or that one.
fn row_program(args: &FaultMatrixArgs, f: &LcncFault) -> PathBuf {
    match f.program {
        Some(name) => args.linuxcnc_program.with_file_name(name),
        None => args.linuxcnc_program.clone(),
    }
}

/// One row: `acc linuxcnc … --fault KIND@N --out dir`, then its logs judged.
fn run_row(args: &FaultMatrixArgs, f: &LcncFault, dir: &Path) -> anyhow::Result<LcncRow> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let out: PathBuf = dir.join("lcnc");
    let program = row_program(args, f);
    if !program.is_file() {
        bail!(
            "{}: no such file (row {}'s program, beside --linuxcnc-program)",
            program.display(),
            f.name
        );
    }
    let largs = vec![
        "linuxcnc".to_string(),
        program.to_string_lossy().into_owned(),
        format!("--stock-box={}", args.linuxcnc_stock_box),
        "--out".into(),
        out.to_string_lossy().into_owned(),
        "--fault".into(),
        format!("{}@{}+{}", f.name, f.at_force_n, f.delay_s),
        "--timeout-s".into(),
        "120".into(),
    ];
    let (mut p, _) = Proc::spawn(&largs, dir, "linuxcnc")?;
    let exit = match p.wait(Duration::from_secs(200)) {
        Some(st) => describe(st),
        None => "did not end in 200 s (killed)".into(),
    };
    p.drain(Duration::from_millis(200));
    let machine = match machine_log::read(&out.join("machine.csv")) {
        Ok(rows) => rows,
        Err(e @ MachineLogError::Io { .. }) => bail!(
            "{e} ({exit}; see {})",
            dir.join("linuxcnc.stderr").display()
        ),
        Err(e) => return Err(e.into()),
    };
    let run = read(&out.join("run.csv")).unwrap_or_default();
    let ui_log = std::fs::read_to_string(out.join("ui.log")).unwrap_or_default();
    let fr = run.iter().find_map(|r| r.force_ref_n).unwrap_or(800.0);
    let mut row = judge(f, fr, &machine, &run, &ui_log);
    row.exit = exit;
    Ok(row)
}

/// The markdown table of the rows, with the command that produced it.
pub fn markdown(rows: &[LcncRow], args: &FaultMatrixArgs) -> String {
    let mut t = format!(
        "Generated by `acc fault-matrix --linuxcnc` (LinuxCNC 2.9 headless, `{}` unless the row names its own program beside it, stock box {}; each fault S s after the true force first reaches N, column `at`; `configs/linuxcnc/`).\n\n",
        args.linuxcnc_program.display(),
        args.linuxcnc_stock_box,
    );
    t.push_str("| fault | what | at | allowed % | last cmd % | max applied, ACC not driving % | cmd after (at +0.25 s) % | force before N | max force after N | stop s | log rows (complete) | outcome | verdict |\n");
    t.push_str(
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- | --- |\n",
    );
    let f0 = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.0}"));
    let u = |v: Option<u16>| v.map_or("–".to_string(), |v| v.to_string());
    for r in rows {
        t.push_str(&format!(
            "| {} | {} | {:.0} N + {} s | {} | {} | {} | {} ({}) | {:.0} | {} | {} | {} ({}) | {} | {} |\n",
            r.fault,
            r.what,
            r.at_force_n,
            r.delay_s,
            f0(r.allowed_pct),
            u(r.last_cmd_pct),
            f0(r.max_applied_not_driving_pct),
            u(r.max_cmd_after_pct),
            u(r.cmd_at_grace_pct),
            r.force_before_n,
            f0(r.force_after_n),
            r.stop_s.map_or("–".to_string(), |s| format!("{s:.3}")),
            r.log_rows,
            if r.log_complete { "yes" } else { "NO" },
            r.outcome,
            r.verdict
        ));
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    const FR: f64 = 800.0;

    /// A machine log every 10 ms to `end_s`: heartbeat toggling every 0.1 s until
    /// `silent_from` (then still), the fault at `t_fault`, feed/force/adaptive by time.
    fn machine(
        end_s: f64,
        t_fault: f64,
        silent_from: f64,
        at: impl Fn(f64) -> (f64, f64, f64, f64),
    ) -> Vec<MachineRow> {
        (0..=(end_s * 100.0) as u32)
            .map(|k| {
                let t = f64::from(k) * 0.01;
                let (feed, force, af, fo) = at(t);
                let beat_t = t.min(silent_from);
                MachineRow {
                    t_s: t,
                    feed_mm_min: feed,
                    force_n: force,
                    adaptive_feed: af,
                    heartbeat: ((beat_t * 10.0).floor() as u64) % 2 == 1,
                    feed_override: fo,
                    fault: t >= t_fault,
                    ..MachineRow::default()
                }
            })
            .collect()
    }

    /// A run log every 0.1 s to `end_s` (its clock 0.1 s behind the machine log's first
    /// toggle), with state and command by time.
    fn run_log(end_s: f64, at: impl Fn(f64) -> (&'static str, u16, u16)) -> Vec<RunRecord> {
        (0..=(end_s * 10.0) as u64)
            .map(|k| {
                let t = k as f64 * 0.1;
                let (state, cmd, applied) = at(t + 0.1);
                RunRecord {
                    t_s: t,
                    period: k,
                    state: state.into(),
                    override_cmd_pct: Some(cmd),
                    override_applied_pct: Some(applied),
                    programmed_feed_mm_min: Some(300.0),
                    feed_mm_min: Some(300.0),
                    force_ref_n: Some(FR),
                    ..RunRecord::default()
                }
            })
            .collect()
    }

    fn fault(name: &str) -> &'static LcncFault {
        LCNC_FAULTS.iter().find(|f| f.name == name).expect("row")
    }

    #[test]
    fn a_frozen_acc_whose_watchdog_stops_the_motion_and_whose_clamp_holds_passes() {
        // Cutting at 0.6 × 150 % = 90 %; acc frozen at 5 s: the feed 0 from 5.22 s to 7.5 s,
        // then the clamp at 90 % again.
        let mut m = machine(12.0, 5.0, 5.0, |t| {
            let feed = if (5.22..7.5).contains(&t) { 0.0 } else { 270.0 };
            (feed, 700.0, 0.6, 1.5)
        });
        // The heartbeat comes back after SIGCONT at 7 s.
        for r in m.iter_mut().filter(|r| r.t_s >= 7.0) {
            r.heartbeat = ((r.t_s * 10.0).floor() as u64) % 2 == 1;
        }
        let run = run_log(11.0, |t| {
            if t < 5.0 {
                ("active", 90, 90)
            } else {
                ("watchdog", 90, 90)
            }
        });
        let r = judge(fault("stop-acc"), FR, &m, &run, "1.0 cycle_s 11.5\n");
        assert!(r.ok, "{r:#?}");
        assert_eq!(r.allowed_pct.map(f64::round), Some(90.0));
        assert!(
            (r.stop_s.expect("stop") - 0.22).abs() < 0.011,
            "{:?}",
            r.stop_s
        );
        assert_eq!(r.states_after, vec!["watchdog".to_string()]);
        assert_eq!(r.program, "completed (11.5 s)");
    }

    #[test]
    fn a_feed_above_what_acc_allowed_while_it_is_silent_fails() {
        // acc frozen; the adaptive feed jumps to 1.0 (150 %) while it is silent.
        let m = machine(8.0, 5.0, 5.0, |t| {
            let af = if t > 5.5 { 1.0 } else { 0.6 };
            let feed = if (5.2..5.5).contains(&t) { 0.0 } else { 300.0 };
            (feed, 700.0, af, 1.5)
        });
        let run = run_log(5.0, |_| ("active", 90, 90));
        let r = judge(fault("stop-acc"), FR, &m, &run, "");
        assert!(!r.ok);
        assert!(r.verdict.contains("applied 150 %"), "{}", r.verdict);
        assert_eq!(r.program, "did not complete");
    }

    #[test]
    fn acc_raising_its_command_on_a_frozen_power_fails() {
        // The process killed at 5 s: its log ends; acc keeps driving and raises 90 → 120.
        let m = machine(5.05, 5.0, 99.0, |_| (270.0, 700.0, 0.6, 1.5));
        let run = run_log(10.0, |t| {
            let cmd = if t < 5.5 { 90 } else { 120 };
            ("active", cmd, cmd)
        });
        let r = judge(fault("kill-process"), FR, &m, &run, "1 cycle_s 12\n");
        assert!(!r.ok);
        assert!(
            r.verdict.contains("raised its command to 120 %"),
            "{}",
            r.verdict
        );
        assert_eq!(r.force_after_n, None);
        // Released on the stale sample and clamped instead: a pass.
        let run = run_log(10.0, |t| {
            if t < 5.3 {
                ("active", 90, 90)
            } else {
                ("power_invalid", 90, 90)
            }
        });
        let r = judge(fault("kill-process"), FR, &m, &run, "1 cycle_s 12\n");
        assert!(r.ok, "{r:#?}");
        assert_eq!(r.max_applied_not_driving_pct, Some(90.0));
    }

    #[test]
    fn the_operators_knob_lowers_the_feed_and_a_missing_period_fails() {
        let m = machine(10.0, 5.0, 99.0, |t| {
            if t < 5.0 {
                (270.0, 700.0, 0.6, 1.5)
            } else {
                (90.0, 300.0, 1.0, 0.3)
            }
        });
        let mut run = run_log(9.0, |t| {
            if t < 5.1 {
                ("active", 90, 90)
            } else {
                ("operator_handback", 150, 30)
            }
        });
        let r = judge(fault("feed-override"), FR, &m, &run, "1 cycle_s 12\n");
        assert!(r.ok, "{r:#?}");
        assert_eq!(r.max_applied_not_driving_pct, Some(30.0));
        assert!(r.knob_s.expect("knob") < 0.02);
        run.remove(40);
        let r = judge(fault("feed-override"), FR, &m, &run, "1 cycle_s 12\n");
        assert!(r.verdict.contains("not consecutive"), "{}", r.verdict);
    }

    /// A run log every 0.1 s to `end_s` on the machine log's clock (see [`run_log`]), the
    /// law stepped (mode set) where `at` says a state of `active` and `stepped`.
    fn run_log_stepped(
        end_s: f64,
        at: impl Fn(f64) -> (&'static str, u16, bool),
    ) -> Vec<RunRecord> {
        run_log(end_s, |t| {
            let (state, cmd, _) = at(t);
            (state, cmd, cmd)
        })
        .into_iter()
        .map(|mut r| {
            let (_, _, stepped) = at(r.t_s + 0.1);
            if stepped {
                r.mode = "adaptive_pi".into();
            }
            r
        })
        .collect()
    }

    /// The marker where `marked` says, instead of from the fault on.
    fn marked(mut m: Vec<MachineRow>, marked: impl Fn(f64) -> bool) -> Vec<MachineRow> {
        for r in &mut m {
            r.fault = marked(r.t_s);
        }
        m
    }

    const COMPLETED: &str = "1 run x\n2 cycle_s 12.0\n";

    #[test]
    fn m52_off_passes_when_the_pin_holds_and_fails_when_it_says_150_percent() {
        // Cutting at 50 % (0.333 × 150 %), 900 N; M52 P0 from 5 to 9 s at F60 × 150 %.
        let cut = |pin_in_section: f64| {
            marked(
                machine(14.0, 5.0, 99.0, move |t| {
                    if (5.0..9.0).contains(&t) {
                        (90.0, 540.0, pin_in_section, 1.5)
                    } else if (9.0..9.05).contains(&t) && pin_in_section > 0.5 {
                        (450.0, 2250.0, pin_in_section, 1.5)
                    } else {
                        (150.0, 900.0, 0.333, 1.5)
                    }
                }),
                |t| (5.0..9.0).contains(&t),
            )
        };
        let run = run_log_stepped(13.0, |t| ("active", 50, !(5.0..9.1).contains(&t)));
        let r = judge(fault("m52-off"), FR, &cut(0.333), &run, COMPLETED);
        assert!(r.ok, "{r:#?}");
        let e = r.event.as_ref().expect("figures");
        assert_eq!(e.t_end_s, Some(9.0));
        assert_eq!(e.knob_during_pct, Some(150.0));
        assert!(e.pin_during_pct.is_some_and(|p| (p - 50.0).abs() < 0.1));
        assert!(r.outcome.contains("M52 P0 for 4.0 s"), "{}", r.outcome);
        // 1.0 on the pin under M52 P0: M52 P1 runs at 150 % until acc's next write.
        let r = judge(fault("m52-off"), FR, &cut(1.0), &run, COMPLETED);
        assert!(!r.ok);
        assert!(
            r.verdict.contains("the pin said 150 % under M52 P0"),
            "{}",
            r.verdict
        );
        assert!(
            r.verdict.contains("applied 150 % after M52 P1"),
            "{}",
            r.verdict
        );
        // A force above the one before that acc does not bring back.
        let high = marked(
            machine(14.0, 5.0, 99.0, |t| {
                if (5.0..9.0).contains(&t) {
                    (90.0, 540.0, 0.333, 1.5)
                } else if (9.0..10.0).contains(&t) {
                    (150.0, 1200.0, 0.333, 1.5)
                } else {
                    (150.0, 900.0, 0.333, 1.5)
                }
            }),
            |t| (5.0..9.0).contains(&t),
        );
        let r = judge(fault("m52-off"), FR, &high, &run, COMPLETED);
        assert!(
            r.verdict
                .contains("stayed above 1.05 × 900 N for 1.00 s after M52 P1"),
            "{}",
            r.verdict
        );
        // M52 P1 never came back.
        let m = marked(cut(0.333), |t| t >= 5.0);
        let r = judge(fault("m52-off"), FR, &m, &run, COMPLETED);
        assert!(
            r.verdict.contains("M52 P1 never came back"),
            "{}",
            r.verdict
        );
    }

    #[test]
    fn abort_restart_passes_when_acc_drives_on_and_fails_latched_or_wound_up() {
        // The first run cuts at 900 N to 5 s; aborted 5–6.3 s; the restart re-enters the
        // wall at 8 s (2 600 N for 0.1 s), then 900 N.
        let m = marked(
            machine(14.0, 5.0, 99.0, |t| {
                if (5.0..6.3).contains(&t) {
                    (0.0, 0.0, 0.333, 1.5)
                } else if (6.3..8.0).contains(&t) {
                    (450.0, 0.0, 1.0, 1.5)
                } else if (8.0..8.1).contains(&t) {
                    (450.0, 2600.0, 1.0, 1.5)
                } else {
                    (150.0, 900.0, 0.333, 1.5)
                }
            }),
            |t| (5.0..6.3).contains(&t),
        );
        let ok = run_log_stepped(13.0, |_| ("active", 50, true));
        let r = judge(fault("abort-restart"), FR, &m, &ok, COMPLETED);
        assert!(r.ok, "{r:#?}");
        let e = r.event.as_ref().expect("figures");
        assert_eq!(
            (e.cmd_before_pct, e.cmd_after_end_pct),
            (Some(50), Some(50))
        );
        assert!(e
            .longest_excursion_s
            .is_some_and(|s| (s - 0.1).abs() < 0.011));
        assert_eq!(e.peak_after_n, Some(2600.0));
        // Latched on the abort's stopped spindle: the restart runs uncontrolled.
        let latched = run_log_stepped(13.0, |t| {
            if t < 5.2 {
                ("active", 50, true)
            } else {
                ("power_invalid", 50, false)
            }
        });
        let r = judge(fault("abort-restart"), FR, &m, &latched, COMPLETED);
        assert!(r.verdict.contains("acc did not drive in"), "{}", r.verdict);
        // Wound up over the abort.
        let wound = run_log_stepped(13.0, |t| ("active", if t < 6.0 { 50 } else { 150 }, true));
        let r = judge(fault("abort-restart"), FR, &m, &wound, COMPLETED);
        assert!(r.verdict.contains("restarted at 150 %"), "{}", r.verdict);
        // The force not brought back.
        let slow = marked(
            machine(14.0, 5.0, 99.0, |t| {
                if (5.0..6.3).contains(&t) {
                    (0.0, 0.0, 0.333, 1.5)
                } else if t >= 8.0 {
                    (450.0, 2600.0, 1.0, 1.5)
                } else {
                    (150.0, 900.0, 0.333, 1.5)
                }
            }),
            |t| (5.0..6.3).contains(&t),
        );
        let r = judge(fault("abort-restart"), FR, &slow, &ok, COMPLETED);
        assert!(
            r.verdict.contains("stayed above 1.05 × 900 N"),
            "{}",
            r.verdict
        );
        // It never ran again.
        let r = judge(
            fault("abort-restart"),
            FR,
            &marked(m, |t| t >= 5.0),
            &ok,
            "",
        );
        assert!(r.verdict.contains("never ran again"), "{}", r.verdict);
    }

    #[test]
    fn a_tool_change_passes_when_acc_drives_the_second_cut_and_fails_when_it_lets_go() {
        // The first tool: entry peak 1 390 N, 900 N; the change at 5 s; the second tool's
        // entry 1 180 N at 6 s, then 800 N.
        let m = marked(
            machine(12.0, 5.0, 99.0, |t| match t {
                t if t < 0.5 => (450.0, 1390.0, 1.0, 1.5),
                t if t < 4.0 => (150.0, 900.0, 0.333, 1.5),
                t if t < 6.0 => (0.0, 0.0, 1.0, 1.5),
                t if t < 6.3 => (450.0, 1180.0, 1.0, 1.5),
                _ => (210.0, 800.0, 0.467, 1.5),
            }),
            |t| t >= 5.0,
        );
        let ok = run_log_stepped(11.0, |_| ("active", 50, true));
        let r = judge(fault("tool-change"), FR, &m, &ok, COMPLETED);
        assert!(r.ok, "{r:#?}");
        let e = r.event.as_ref().expect("figures");
        assert_eq!((e.peak_before_n, e.peak_after_n), (1390.0, Some(1180.0)));
        assert_eq!(e.settled_mean_n, Some(800.0));
        // Released on the M5 with a feed hold: the second cut never under acc.
        let held = run_log_stepped(11.0, |t| {
            if t < 5.0 {
                ("active", 50, true)
            } else {
                ("power_invalid", 50, false)
            }
        });
        let r = judge(
            fault("tool-change"),
            FR,
            &m,
            &held,
            "1 feed inhibited for 5 s\n2 aborted\n",
        );
        assert!(r.verdict.contains("acc did not drive in"), "{}", r.verdict);
        assert!(r.verdict.contains("the program aborted"), "{}", r.verdict);
    }

    #[test]
    fn a_fault_that_never_came_fails() {
        let m = machine(3.0, 99.0, 99.0, |_| (270.0, 300.0, 0.6, 1.5));
        let r = judge(fault("pause"), FR, &m, &[], "");
        assert!(
            r.verdict.starts_with("FAIL: the fault never came"),
            "{}",
            r.verdict
        );
    }
}
