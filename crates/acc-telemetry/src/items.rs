//! The data items the shop sees, taken from one [`RunRecord`]: the same names and values
//! for the SHDR adapter and the MQTT JSON (docs/telemetry.md lists them with units).

use acc_runtime::RunRecord;

/// Value of an item whose source is unknown (SHDR's `UNAVAILABLE`).
pub const UNAVAILABLE: &str = "UNAVAILABLE";

/// Condition level of an alarm (MTConnect CONDITION).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// No alarm.
    Normal,
    /// A warning (the loop goes on).
    Warning,
    /// A fault (ACC released or feed hold).
    Fault,
}

impl Level {
    /// SHDR spelling.
    pub fn name(self) -> &'static str {
        match self {
            Level::Normal => "NORMAL",
            Level::Warning => "WARNING",
            Level::Fault => "FAULT",
        }
    }
}

/// One alarm condition: (item name, bit of `RunRecord::alarms`, level when on, native code,
/// text).
pub const CONDITIONS: [(&str, u8, Level, &str, &str); 5] = [
    (
        "link_cond",
        0,
        Level::Fault,
        "LINK_LOST",
        "board link lost: ACC released",
    ),
    (
        "power_cond",
        1,
        Level::Warning,
        "POWER_INVALID",
        "spindle power sample invalid",
    ),
    (
        "watchdog_cond",
        2,
        Level::Fault,
        "WATCHDOG",
        "board watchdog tripped",
    ),
    (
        "board_reset_cond",
        3,
        Level::Warning,
        "BOARD_RESET",
        "interface board restarted",
    ),
    (
        "overload_cond",
        4,
        Level::Fault,
        "OVERLOAD",
        "cutting force above the overload limit: feed hold",
    ),
];

/// Names of the SAMPLE / EVENT data items, in the order they are sent.
pub const ITEMS: [&str; 17] = [
    "avail",
    "execution",
    "acc_state",
    "Fovr",
    "Fovr_cmd",
    "Fovr_op",
    "path_feedrate",
    "Srpm",
    "Spower",
    "Fc",
    "Fr",
    "Kc",
    "Tool",
    "program",
    "line",
    "feed_hold",
    "acc_period",
];

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map_or_else(|| UNAVAILABLE.to_string(), |x| x.to_string())
}

fn num(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.digits$}"),
        _ => UNAVAILABLE.to_string(),
    }
}

/// Availability of the machine's data: `AVAILABLE` unless the period's status read failed
/// (flag `link:…`) or the period was skipped.
pub fn available(r: &RunRecord) -> bool {
    !(r.has_flag("link") || r.has_flag("skipped"))
}

/// MTConnect `Execution`: `FEED_HOLD` when ACC requested feed hold, `ACTIVE` while ACC
/// drives the override, `READY` otherwise.
pub fn execution(r: &RunRecord) -> &'static str {
    if r.feed_hold {
        "FEED_HOLD"
    } else if r.state == "active" {
        "ACTIVE"
    } else {
        "READY"
    }
}

/// The values of [`ITEMS`] for record `r` (same order).
pub fn values(r: &RunRecord) -> [String; ITEMS.len()] {
    [
        if available(r) {
            "AVAILABLE"
        } else {
            "UNAVAILABLE"
        }
        .to_string(),
        execution(r).to_string(),
        if r.state.is_empty() {
            UNAVAILABLE.to_string()
        } else {
            r.state.clone()
        },
        opt(r.override_applied_pct),
        opt(r.override_cmd_pct),
        opt(r.override_operator_pct),
        num(r.feed_mm_min, 1),
        num(r.spindle_rpm, 0),
        num(r.power_w, 1),
        num(r.force_n, 1),
        num(r.force_ref_n, 1),
        num(r.kc_hat, 4),
        opt(r.tool),
        opt(r.program),
        opt(r.block),
        if r.feed_hold { "ON" } else { "OFF" }.to_string(),
        r.period.to_string(),
    ]
}

/// The level of every condition of [`CONDITIONS`] for record `r`.
pub fn levels(r: &RunRecord) -> [Level; CONDITIONS.len()] {
    CONDITIONS.map(|(_, bit, on, _, _)| {
        if r.alarms >> bit & 1 == 1 {
            on
        } else {
            Level::Normal
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_values_are_unavailable_and_alarms_map_to_levels() {
        let r = RunRecord {
            force_n: Some(812.25),
            override_cmd_pct: Some(90),
            state: "overload".into(),
            feed_hold: true,
            alarms: 0b10010,
            ..RunRecord::default()
        };
        let v = values(&r);
        let get = |n: &str| v[ITEMS.iter().position(|i| *i == n).expect("item")].clone();
        assert_eq!(get("Fc"), "812.2");
        assert_eq!(get("Fovr_cmd"), "90");
        assert_eq!(get("Fovr"), UNAVAILABLE);
        assert_eq!(get("execution"), "FEED_HOLD");
        let l = levels(&r);
        assert_eq!(l[1], Level::Warning);
        assert_eq!(l[4], Level::Fault);
        assert_eq!(l[0], Level::Normal);
    }
}
