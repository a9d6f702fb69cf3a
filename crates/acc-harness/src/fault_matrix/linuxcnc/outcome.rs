//! A row's outcome in words, and how its program ended.

use super::program_event::EventFigures;
use super::row::LcncRow;
use super::rows::{program_event, LcncFault};

/// How the program ended, from `ui.log`.
pub(super) fn program_end(ui_log: &str) -> String {
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
pub(super) fn outcome(f: &LcncFault, r: &LcncRow) -> String {
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
            "run again {dur} after the abort at acc's {} (last before the abort {}); peak after the restart {} (first run {:.0} N), above 1.05 × {:.0} N for {} (the restart's air moves and its re-entry into the wall the abort left capped at acc's command of the stopped cut, `restart:<pct>`); acc drove every cut period",
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
