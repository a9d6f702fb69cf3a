//! The judgement of a row whose fault is the program's own event or a restart (`M52 P0`,
//! an abort and a second run, a tool change).

use acc_linuxcnc::machine_log::MachineRow;
use acc_runtime::record::RunRecord;

use super::judge::{applied, in_contact, machine_row_at};
use super::row::{LcncRow, AFTER_S, BEFORE_S};
use super::rows::LcncFault;

/// m52-off: after `M52 P1` is back, the applied override is judged this long, s (acc's
/// next read and write: 0.1 s, with margin).
pub(super) const RETURN_S: f64 = 0.5;
/// abort-restart: the longest a true force above 1.05 × the force before may last after
/// the restart, s (one period to see it, one to act, the deceleration).
pub(super) const MAX_EXCURSION_S: f64 = 0.3;
/// tool-change: the second cut's settled mean within this share of Fr.
pub(super) const SETTLED_SHARE: f64 = 0.2;

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
    /// m52-off, abort-restart: the largest applied override in the cut in the [`BEFORE_S`]
    /// before the event: what acc allowed there (its law steps between neighbouring
    /// values), percent.
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
///   restarted run is not above what it allowed in the cut before the abort (its last
///   command, or the largest override applied in the cut in the [`BEFORE_S`] before it:
///   no wind-up over the abort);
///   acc drives in every cut period of the restarted run; the peak after the restart is at
///   most 1.05 × the force before the abort (the restart judge caps the restarted program
///   at the command of the stopped cut until its first cut is measured:
///   `acc_runtime::policy`, `restart.rs`).
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
    let mut e = EventFigures::default();
    let Some(i_end) = event_end(f, machine, i_f) else {
        let why = match f.name {
            "m52-off" => "M52 P1 never came back (the marker stayed set)",
            _ => "the program never ran again",
        };
        return (e, vec![why.to_string()]);
    };
    let t_end = machine[i_end].t_s;
    e.t_end_s = Some(t_end);
    e.peak_before_n = peak(&machine[..i_f]);
    commands_around(&mut e, run, offset, machine[i_f].t_s, t_end);
    driving_after(&mut e, fr_n, machine, run, offset, t_end);
    let mut why = match f.name {
        "m52-off" => m52_off(&mut e, fr_n, machine, i_f, i_end, row),
        "abort-restart" => abort_restart(&mut e, fr_n, machine, i_f, i_end, row),
        _ => tool_change(&mut e, fr_n, machine, i_end),
    };
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
    if !row.program.starts_with("completed") {
        why.push(format!("the program {}", row.program));
    }
    (e, why)
}

/// The machine-log row where the event ends: the marker's fall (`M52 P1` back, the
/// restart), or for a tool change the change itself (`None`: it never ended).
fn event_end(f: &LcncFault, machine: &[MachineRow], i_f: usize) -> Option<usize> {
    if f.name == "tool-change" {
        return Some(i_f);
    }
    machine[i_f..]
        .iter()
        .position(|r| !r.fault)
        .map(|k| i_f + k)
}

/// The largest true force in `rows`, N (0 for none).
fn peak(rows: &[MachineRow]) -> f64 {
    rows.iter().map(|r| r.force_n).fold(0.0, f64::max)
}

/// acc's last command up to the event (at `t_f`) and its first from the event's end
/// (`t_end`) on, both on the machine log's clock (`offset`: run log to machine log, s).
fn commands_around(e: &mut EventFigures, run: &[RunRecord], offset: f64, t_f: f64, t_end: f64) {
    e.cmd_before_pct = run
        .iter()
        .rev()
        .filter(|r| r.t_s + offset <= t_f)
        .find_map(|r| r.override_cmd_pct);
    e.cmd_after_end_pct = run
        .iter()
        .filter(|r| r.t_s + offset >= t_end)
        .find_map(|r| r.override_cmd_pct);
}

/// Counts acc's run-log periods in the cut (tool in the stock, feed moving) from the
/// event's end to the last cut: those it did not drive, and those its law stepped.
fn driving_after(
    e: &mut EventFigures,
    fr_n: f64,
    machine: &[MachineRow],
    run: &[RunRecord],
    offset: f64,
    t_end: f64,
) {
    let last_cut_t = machine
        .iter()
        .rev()
        .find(|r| in_contact(r.force_n, fr_n))
        .map_or(t_end, |r| r.t_s);
    for r in run.iter() {
        let t = r.t_s + offset;
        if t < t_end || t > last_cut_t {
            continue;
        }
        let cutting = machine_row_at(machine, t)
            .is_some_and(|m| in_contact(m.force_n, fr_n) && m.feed_mm_min > 0.0);
        if !cutting {
            continue;
        }
        if r.state != "active" {
            e.periods_not_driving += 1;
        } else if !r.mode.is_empty() {
            e.periods_stepped += 1;
        }
    }
}

/// The largest override applied in the cut (in contact, feeding) in the [`BEFORE_S`] before
/// the machine-log row `i_f`, percent: what acc allowed just before an event.
fn allowed_before(machine: &[MachineRow], i_f: usize, fr_n: f64) -> Option<f64> {
    let t_f = machine[i_f].t_s;
    machine[..i_f]
        .iter()
        .filter(|r| r.t_s >= t_f - BEFORE_S)
        .filter(|r| in_contact(r.force_n, fr_n) && r.feed_mm_min > 0.0)
        .map(applied)
        .reduce(f64::max)
}

/// m52-off: the pin under `M52 P0` holds what acc allowed; after `M52 P1` the applied
/// override stays at what acc allowed just before, and no force excursion lasts.
fn m52_off(
    e: &mut EventFigures,
    fr_n: f64,
    machine: &[MachineRow],
    i_f: usize,
    i_end: usize,
    row: &LcncRow,
) -> Vec<String> {
    let mut why = Vec::new();
    let t_end = machine[i_end].t_s;
    let cutting = |r: &&MachineRow| in_contact(r.force_n, fr_n) && r.feed_mm_min > 0.0;
    let section = &machine[i_f..i_end];
    e.pin_during_pct = section.iter().map(applied).reduce(f64::max);
    e.knob_during_pct = section
        .iter()
        .map(|r| 100.0 * r.feed_override)
        .reduce(f64::max);
    e.allowed_recent_pct = allowed_before(machine, i_f, fr_n);
    e.applied_after_end_pct = machine[i_end..]
        .iter()
        .take_while(|r| r.t_s <= t_end + RETURN_S)
        .filter(cutting)
        .map(applied)
        .reduce(f64::max);
    let after_end = {
        let n = machine[i_end..]
            .iter()
            .take_while(|r| r.t_s <= t_end + AFTER_S)
            .count();
        &machine[i_end..i_end + n]
    };
    e.peak_after_n = Some(peak(after_end));
    let allowed = row.allowed_pct.unwrap_or(0.0);
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
    let longest = longest_excursion_s(after_end, 1.05 * row.force_before_n);
    e.longest_excursion_s = Some(longest);
    if longest > MAX_EXCURSION_S {
        why.push(format!(
            "the true force stayed above 1.05 × {:.0} N for {longest:.2} s after M52 P1",
            row.force_before_n
        ));
    }
    why
}

/// abort-restart: acc restarts at no more than it allowed in the cut before the abort (no
/// wind-up: the larger of its last command before the abort and the largest override
/// applied in the cut in the [`BEFORE_S`] before it, since the two logs' clocks place the
/// abort within a period: a command written in the abort's period may be the cut's last),
/// and no force excursion after the restart lasts.
fn abort_restart(
    e: &mut EventFigures,
    fr_n: f64,
    machine: &[MachineRow],
    i_f: usize,
    i_end: usize,
    row: &LcncRow,
) -> Vec<String> {
    let mut why = Vec::new();
    e.allowed_recent_pct = allowed_before(machine, i_f, fr_n);
    e.peak_after_n = Some(peak(&machine[i_end..]));
    let longest = longest_excursion_s(&machine[i_end..], 1.05 * row.force_before_n);
    e.longest_excursion_s = Some(longest);
    if let (Some(a), Some(b)) = (e.cmd_after_end_pct, e.cmd_before_pct) {
        let recent = e.allowed_recent_pct.unwrap_or(0.0);
        if f64::from(a) > f64::from(b).max(recent) + 1.0 {
            why.push(format!(
                "acc restarted at {a} %, above its {b} % before the abort and the {recent:.0} % applied in the cut in the {BEFORE_S} s before it (wound up)"
            ));
        }
    }
    let peak = e.peak_after_n.unwrap_or(0.0);
    if peak > 1.05 * row.force_before_n {
        why.push(format!(
            "peak {peak:.0} N after the restart > 1.05 × {:.0} N before the abort (above for {longest:.2} s)",
            row.force_before_n
        ));
    }
    why
}

/// tool-change: the second tool's peak is at most 1.05 × the first's, and its cut settles
/// within [`SETTLED_SHARE`] of Fr.
fn tool_change(
    e: &mut EventFigures,
    fr_n: f64,
    machine: &[MachineRow],
    i_end: usize,
) -> Vec<String> {
    let mut why = Vec::new();
    let after: Vec<&MachineRow> = machine[i_end..]
        .iter()
        .filter(|r| in_contact(r.force_n, fr_n))
        .collect();
    e.peak_after_n = after.iter().map(|r| r.force_n).reduce(f64::max);
    let tail = &after[after.len() / 2..];
    e.settled_mean_n =
        (!tail.is_empty()).then(|| tail.iter().map(|r| r.force_n).sum::<f64>() / tail.len() as f64);
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
    why
}

/// The longest stretch of `rows` with the true force above `limit_n`, s (one still open at
/// the end counts to the last row).
pub(super) fn longest_excursion_s(rows: &[MachineRow], limit_n: f64) -> f64 {
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
