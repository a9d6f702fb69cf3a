//! Alarms and state changes as OPC UA events (`BaseEventType`): one event when an alarm of
//! [`crate::items::CONDITIONS`] is raised or cleared, and one when ACC's state changes. Pure:
//! [`EventFeed::push`] takes a record and returns what happened; the server notifies.

use acc_runtime::RunRecord;

use crate::items::{Level, CONDITIONS};

/// Severity (1..1000, Part 5) of a fault being raised.
pub const SEVERITY_FAULT: u16 = 800;
/// Severity of a warning being raised.
pub const SEVERITY_WARNING: u16 = 500;
/// Severity of an alarm cleared or a state change.
pub const SEVERITY_INFO: u16 = 100;

/// One event to publish.
#[derive(Debug, Clone, PartialEq)]
pub struct AccEvent {
    /// Period of the record that raised it.
    pub period: u64,
    /// Machine time of that record, s.
    pub t_s: f64,
    /// Severity 1..1000.
    pub severity: u16,
    /// Text: `OVERLOAD raised: …`, `OVERLOAD cleared`, `state idle -> active`.
    pub message: String,
}

/// What the last record said, to see what changed.
#[derive(Debug, Default)]
pub struct EventFeed {
    last: Option<(u8, String)>,
}

impl EventFeed {
    /// The events of record `r` against the previous one (the first record raises its alarms
    /// and reports its state).
    pub fn push(&mut self, r: &RunRecord) -> Vec<AccEvent> {
        let (bits0, state0) = self.last.take().unwrap_or((0, String::new()));
        let mut out = Vec::new();
        let ev = |severity: u16, message: String| AccEvent {
            period: r.period,
            t_s: r.t_s,
            severity,
            message,
        };
        for (_, bit, level, code, text) in CONDITIONS {
            let (was, is) = (bits0 >> bit & 1 == 1, r.alarms >> bit & 1 == 1);
            if is && !was {
                let sev = if level == Level::Fault {
                    SEVERITY_FAULT
                } else {
                    SEVERITY_WARNING
                };
                out.push(ev(sev, format!("{code} raised: {text}")));
            } else if was && !is {
                out.push(ev(SEVERITY_INFO, format!("{code} cleared")));
            }
        }
        if r.state != state0 {
            let from = if state0.is_empty() { "-" } else { &state0 };
            out.push(ev(SEVERITY_INFO, format!("state {from} -> {}", r.state)));
        }
        self.last = Some((r.alarms, r.state.clone()));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raised_cleared_and_state_changes() {
        let mut f = EventFeed::default();
        let rec = |alarms: u8, state: &str| RunRecord {
            alarms,
            state: state.into(),
            ..RunRecord::default()
        };
        assert_eq!(f.push(&rec(0, "idle"))[0].message, "state - -> idle");
        assert!(f.push(&rec(0, "idle")).is_empty());
        let e = f.push(&rec(1 << 4, "overload"));
        assert_eq!(e.len(), 2);
        assert!(e[0].message.starts_with("OVERLOAD raised") && e[0].severity == SEVERITY_FAULT);
        assert_eq!(e[1].message, "state idle -> overload");
        let e = f.push(&rec(0, "overload"));
        assert_eq!(e[0].message, "OVERLOAD cleared");
    }
}
