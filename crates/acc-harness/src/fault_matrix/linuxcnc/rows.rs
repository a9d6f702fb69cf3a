//! The rows of the LinuxCNC section: what each fault is, when it comes, what it must not do.

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

/// A row whose fault comes from outside the program, at `at` (force, N; delay, s), judged
/// by the common criteria only (acc may raise; no watchdog stop): the fields a row
/// changes are set over it.
const fn row(name: &'static str, what: &'static str, at: (f64, f64)) -> LcncFault {
    LcncFault {
        name,
        what,
        no_raise: false,
        watchdog_stop: false,
        at_force_n: at.0,
        delay_s: at.1,
        program: None,
    }
}

/// The rows, in the order they run.
pub static LCNC_FAULTS: [LcncFault; 9] = [
    LcncFault {
        no_raise: true,
        watchdog_stop: true,
        ..row("kill-acc", "acc killed (SIGKILL) in the heavy cut; program aborted 2 s later", HEAVY)
    },
    LcncFault {
        no_raise: true,
        watchdog_stop: true,
        ..row("stop-acc", "acc frozen (SIGSTOP 2 s, then SIGCONT; the watchdog re-armed 0.5 s later)", HEAVY)
    },
    LcncFault {
        no_raise: true,
        ..row("kill-process", "the power pin frozen while the spindle turns (acc-process killed)", LIGHT_ENTRY)
    },
    row("feed-override", "the operator's feed override to 30 % (feedrate(0.3))", HEAVY),
    row("pause", "program paused (AUTO_PAUSE) 2 s, then resumed", HEAVY),
    row("estop", "estop mid-cut", HEAVY),
    LcncFault {
        program: Some("linuxcnc/m52.ngc"),
        ..row("m52-off", "the program switches the adaptive feed off mid-cut (`M52 P0`, F60) and on again (`M52 P1`): tests/nc/linuxcnc/m52.ngc", LIGHT_ENTRY)
    },
    row("abort-restart", "program aborted in the heavy cut (the operator's abort, Z retracted), then run again from its start", HEAVY),
    LcncFault {
        program: Some("linuxcnc_tool_change.ngc"),
        ..row("tool-change", "a tool change between two cuts (`M5`, `T2 M6`, `M3`; tool table T1, T2): tests/nc/linuxcnc_tool_change.ngc", LIGHT_ENTRY)
    },
];

/// The rows whose fault is the program's own or a restart: judged by their own criteria
/// ([`super::judge_program_event`]), not by the force in the 5 s after the fault.
pub(super) fn program_event(f: &LcncFault) -> bool {
    matches!(f.name, "m52-off" | "abort-restart" | "tool-change")
}
