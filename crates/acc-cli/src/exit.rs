//! The exit codes of `acc run`: one per way a run can end, defined once here and listed in
//! `acc run --help` and docs/runtime.md. The last line a run prints says which way it ended
//! (`acc run: ended: <meaning> (exit code N)`).

/// How `acc run` ended; the discriminant is the process exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i32)]
pub enum RunExit {
    /// Stopped out of the cut (signal, drain ended) or `--duration-s` reached; `ACC_REQUEST`
    /// cleared, the operator has the override.
    Completed = 0,
    /// An error the program does not expect (a bug, a panic, a runtime thread that died).
    Internal = 1,
    /// Bad command line, config file, referenced file, run-log path or serial device:
    /// nothing was sent to the board.
    Usage = 2,
    /// A stop signal found the machine still cutting (drain ran out, or a second signal):
    /// feed hold requested, then `ACC_REQUEST` cleared with the feed hold kept.
    FeedHold = 3,
    /// The board's serial device or CAN interface vanished mid-run; the board's watchdog
    /// and fallback take the override.
    DeviceLost = 4,
    /// The board did not answer at start, or is not one ACC can drive (`OVERRIDE_STEP`
    /// not 1 or 10, a step the preset cannot use): ACC never drove the override.
    BoardNotAnswering = 5,
    /// A fault (overload, or a release that would have raised the feed) requested feed hold
    /// during the run and it was still in force at the end.
    FaultFeedHold = 6,
    /// The final `CONTROL` write did not get through (link failed at the end): the board's
    /// watchdog releases the override.
    FinalWriteFailed = 7,
}

impl RunExit {
    /// Every exit, in code order.
    pub const ALL: [RunExit; 8] = [
        RunExit::Completed,
        RunExit::Internal,
        RunExit::Usage,
        RunExit::FeedHold,
        RunExit::DeviceLost,
        RunExit::BoardNotAnswering,
        RunExit::FaultFeedHold,
        RunExit::FinalWriteFailed,
    ];

    /// The process exit code.
    pub const fn code(self) -> i32 {
        self as i32
    }

    /// The exit with this code, if it is one of ours.
    pub fn from_code(code: i32) -> Option<RunExit> {
        Self::ALL.into_iter().find(|e| e.code() == code)
    }

    /// One line on what the code means (help, docs, the last line of a run).
    pub const fn meaning(self) -> &'static str {
        match self {
            RunExit::Completed => "completed: stopped out of the cut or --duration-s reached; the operator has the override",
            RunExit::Internal => "internal error (a bug: please report it with the run log)",
            RunExit::Usage => "usage or config error: nothing was sent to the board",
            RunExit::FeedHold => "stopped by a signal while cutting: feed hold requested and kept, the NC needs cycle start",
            RunExit::DeviceLost => "the board's device vanished (port, cable, CAN interface); the board's watchdog has the override",
            RunExit::BoardNotAnswering => "the board did not answer at start or cannot be driven: ACC never drove the override",
            RunExit::FaultFeedHold => "ended with a fault feed hold in force (overload …): the NC needs cycle start",
            RunExit::FinalWriteFailed => "the final CONTROL write did not get through: the board's watchdog releases the override",
        }
    }

    /// The last line of a run that ended this way.
    pub fn last_line(self) -> String {
        format!(
            "acc run: ended: {} (exit code {})",
            self.meaning(),
            self.code()
        )
    }

    /// The exit-code table of `acc run --help`.
    pub fn help() -> String {
        let mut s = String::from("Exit codes:\n");
        for e in Self::ALL {
            s.push_str(&format!("  {}  {}\n", e.code(), e.meaning()));
        }
        s
    }
}

/// An error of `acc run` with the exit it ends with: `main` prints `error: {error:#}`, then
/// the run's last line, and exits with the code.
#[derive(Debug)]
pub struct Failed {
    /// How the run ended.
    pub exit: RunExit,
    /// What went wrong (the file, key, value and range for a config error).
    pub error: anyhow::Error,
}

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:#}", self.error)
    }
}

impl std::error::Error for Failed {}

/// Tag a result's error with the exit it ends `acc run` with.
pub trait ExitAs<T> {
    /// The error, if any, ends the run with `exit`.
    fn exit_as(self, exit: RunExit) -> anyhow::Result<T>;
}

impl<T, E: Into<anyhow::Error>> ExitAs<T> for Result<T, E> {
    fn exit_as(self, exit: RunExit) -> anyhow::Result<T> {
        self.map_err(|e| {
            let error: anyhow::Error = e.into();
            // An error already tagged keeps its first (innermost) exit.
            if error.downcast_ref::<Failed>().is_some() {
                return error;
            }
            Failed { exit, error }.into()
        })
    }
}

/// The exit of an `acc run` error: its tag ([`Failed`], or [`crate::cmd_run::ExitWith`]'s
/// code), otherwise [`RunExit::Internal`] (an error nobody classified).
pub fn exit_of(e: &anyhow::Error) -> RunExit {
    if let Some(f) = e.downcast_ref::<Failed>() {
        return f.exit;
    }
    if let Some(x) = e.downcast_ref::<crate::cmd_run::ExitWith>() {
        return RunExit::from_code(x.code).unwrap_or(RunExit::Internal);
    }
    RunExit::Internal
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_distinct_and_in_order() {
        for (i, e) in RunExit::ALL.into_iter().enumerate() {
            assert_eq!(e.code(), i as i32);
            assert_eq!(RunExit::from_code(e.code()), Some(e));
        }
        assert_eq!(RunExit::from_code(8), None);
        // The two codes other tools already rely on.
        assert_eq!(RunExit::FeedHold.code(), 3);
        assert_eq!(RunExit::DeviceLost.code(), 4);
        let help = RunExit::help();
        assert!(help.contains("  2  usage or config error"), "{help}");
    }

    #[test]
    fn a_tagged_error_keeps_its_exit() {
        let r: Result<(), anyhow::Error> = Err(anyhow::anyhow!("bad key"));
        let e = r
            .exit_as(RunExit::Usage)
            .exit_as(RunExit::Internal)
            .expect_err("error");
        assert_eq!(exit_of(&e), RunExit::Usage);
        assert_eq!(format!("{e:#}"), "bad key");
        assert_eq!(exit_of(&anyhow::anyhow!("x")), RunExit::Internal);
    }
}
