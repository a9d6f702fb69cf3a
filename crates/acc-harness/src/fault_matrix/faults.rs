//! The faults of `acc fault-matrix`: what each is and how the harness brings it about.

use super::FaultMatrixArgs;

/// How a fault is brought about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// A signal to `acc run` at the moment (`SIGINT`, `SIGTERM`, `SIGKILL`).
    Signal(&'static str),
    /// Two `SIGINT`s, 0.5 s of machine time apart.
    DoubleSigint,
    /// `SIGSTOP` for this many s of machine time, then `SIGCONT` (the controller hangs: the
    /// board's watchdog trips).
    Hang(f64),
    /// An `acc board-sim --fault` at the moment; `{t}` in the text is replaced by the time.
    Board(&'static str),
    /// The man in the middle on the serial line switches its faults on at the moment and off
    /// at the end of the window: `corrupt` of the replies corrupted with a valid CRC (every
    /// kind), and/or every status read answered with the reply of `delay_reads` reads
    /// earlier.
    Line {
        /// Share of the replies corrupted, 0 ..= 1.
        corrupt: f64,
        /// Reads of delay (0: none).
        delay_reads: u32,
    },
    /// `acc run --plan` with a wrong plan, against `acc board-sim --program` (the plan rows,
    /// [`super::wrong_plan`]).
    Plan(PlanFault),
}

/// What is wrong with the plan of a plan row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanFault {
    /// Made for a stock 1 mm lower than the one on the table: the machine cuts more.
    LowerStock,
    /// The same plan followed with the plan's lead (`acc run --plan … --plan-lead`).
    LowerStockLead,
    /// The right plan followed with the plan's lead, the line turning slow mid-cut (every
    /// status read answered with the reply of 2 reads earlier).
    LeadSlowLine,
    /// The plan file does not exist.
    Missing,
}

/// One fault of the matrix.
#[derive(Debug, Clone, Copy)]
pub struct Fault {
    pub name: &'static str,
    pub what: &'static str,
    pub action: Action,
    /// Why a v1 board cannot be made safe against it (`None`: it must pass on v1 too).
    pub v1_unsafe: Option<&'static str>,
    /// Not judged: the NC itself ignores the override inputs.
    pub not_judged: Option<&'static str>,
}

const NO_CLAMP: &str = "v1 board: no fallback clamp; with the controller gone the board falls back to the operator's knob (100 %)";

pub const FAULTS: &[Fault] = &[
    Fault {
        name: "sigint",
        what: "Ctrl-C to acc run",
        action: Action::Signal("INT"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigterm",
        what: "SIGTERM to acc run",
        action: Action::Signal("TERM"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigint-twice",
        what: "a second Ctrl-C 0.5 s later",
        action: Action::DoubleSigint,
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "sigkill",
        what: "kill -9 acc run",
        action: Action::Signal("KILL"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "watchdog",
        what: "acc run hangs 2 s (SIGSTOP/SIGCONT): the board's watchdog trips",
        action: Action::Hang(2.0),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "cable-pulled",
        what: "the line goes dead for 3 s (no replies), then comes back",
        action: Action::Board("unplug@{t}:3"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "device-vanished",
        what: "the serial device disappears for good",
        action: Action::Board("vanish@{t}"),
        v1_unsafe: Some(NO_CLAMP),
        not_judged: None,
    },
    Fault {
        name: "board-restart",
        what: "the board power-cycles",
        action: Action::Board("restart@{t}"),
        v1_unsafe: Some("v1 board: it comes up at the operator's knob, with no feed hold at power-up, for the period before the controller sees it"),
        not_judged: None,
    },
    Fault {
        name: "crc",
        what: "20 replies with a bad CRC",
        action: Action::Board("crc@{t}:20"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "late",
        what: "4 replies late (after the timeout: the link resynchronises)",
        action: Action::Board("late@{t}:4"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "frozen-seq",
        what: "SAMPLE_SEQ frozen for 3 s (stale power sensor)",
        action: Action::Board("freeze-seq@{t}:3"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "bad-power",
        what: "power register 0xFFFFFFFF (implausible) for 3 s",
        action: Action::Board("bad-power@{t}:3"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "knob-down",
        what: "the operator turns the knob from 100 % to 60 %",
        action: Action::Board("operator@{t}:60"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "override-locked",
        what: "the NC locks the override for 3 s (tapping, override cancel)",
        action: Action::Board("lock@{t}:3"),
        v1_unsafe: None,
        not_judged: Some("the NC forces 100 % itself (OVERRIDE_LOCKED): the board reports it, no controller can change it"),
    },
    Fault {
        name: "hard-spot",
        what: "a hard spot: the material's Ks × 2.5 for 2 s (ACC rides it)",
        action: Action::Board("hard@{t}:2:2.5"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "overload",
        what: "Ks × 12 for 2 s: above the overload limit even at the 10 % minimum (overload protection)",
        action: Action::Board("hard@{t}:2:12"),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "garbage-1pct",
        what: "a man in the middle corrupts 1 % of the replies with a valid CRC (flipped bit, slave, exception, byte count, truncated, random)",
        action: Action::Line {
            corrupt: 0.01,
            delay_reads: 0,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "garbage-10pct",
        what: "a man in the middle corrupts 10 % of the replies with a valid CRC (all six kinds)",
        action: Action::Line {
            corrupt: 0.10,
            delay_reads: 0,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-2",
        what: "every status read answered with the board's reply of 2 reads earlier (a buffering gateway), sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 2,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-3",
        what: "every status read answered with the board's reply of 3 reads earlier, sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 3,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "delay-5",
        what: "every status read answered with the board's reply of 5 reads earlier, sustained",
        action: Action::Line {
            corrupt: 0.0,
            delay_reads: 5,
        },
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "plan-low-stock",
        what: "acc run --plan with a plan made for a stock 1 mm lower than the one on the table (the machine cuts more than planned), the pocket program",
        action: Action::Plan(PlanFault::LowerStock),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "plan-lead-low-stock",
        what: "acc run --plan --plan-lead with a plan made for a stock 1 mm lower than the one on the table (the machine cuts more than planned), the pocket program",
        action: Action::Plan(PlanFault::LowerStockLead),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "plan-lead-slow-line",
        what: "acc run --plan --plan-lead with the right plan, the pocket program; mid-cut every status read is answered with the board's reply of 2 reads earlier (a buffering gateway), to the end",
        action: Action::Plan(PlanFault::LeadSlowLine),
        v1_unsafe: None,
        not_judged: None,
    },
    Fault {
        name: "plan-missing",
        what: "acc run --plan names a plan file that does not exist",
        action: Action::Plan(PlanFault::Missing),
        v1_unsafe: None,
        not_judged: None,
    },
];

/// The window after the fault of a row, s of machine time.
pub fn window_s(f: &Fault, args: &FaultMatrixArgs) -> f64 {
    match f.action {
        Action::Line { .. } => args.line_after_s,
        _ => args.after_s,
    }
}
