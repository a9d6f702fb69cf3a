//! When a row of `acc fault-matrix` is run a second time: its first attempt failed (or never
//! reached the fault moment) on a host too loaded to keep `acc run`'s period, told by the
//! controller's own timing counters in its run log (periods flagged `late`: the previous
//! period's work overran T; `skipped`: no cycle ran). The row is re-run once; the table and
//! the JSON keep the first attempt beside the final verdict, so a failure is never turned
//! into a pass unseen.

use acc_runtime::record::RunRecord;

use super::faults::{Action, Fault};

/// Late or skipped periods, as a share of the periods judged, from which the host counts as
/// overloaded: an idle host keeps T = 20 ms of wall time (5× time) with at most a stray
/// late period.
pub const OVERLOAD_SHARE: f64 = 0.02;
/// Late or skipped periods below which the host never counts as overloaded.
pub const OVERLOAD_MIN_PERIODS: usize = 3;

/// The controller's timing in one attempt: periods judged, and how many were late or
/// skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HostLoad {
    /// Periods of `acc run`'s log looked at.
    pub periods: usize,
    /// Of those, flagged `late` or `skipped`.
    pub late_or_skipped: usize,
    /// `acc run` ended before its first period because the board did not answer its
    /// start-up transactions (exit 5): the emulated board on a pty always answers on a host
    /// that runs it in time.
    pub start_failed: bool,
}

impl HostLoad {
    /// The timing of `acc run`'s log `run`. For a fault that stops or signals the
    /// controller (its own lateness is the fault), only the periods up to the fault moment
    /// `t_fault_s` (machine time, s) count.
    pub fn of(run: &[RunRecord], f: &Fault, t_fault_s: Option<f64>) -> Self {
        let process_fault = matches!(
            f.action,
            Action::Signal(_) | Action::DoubleSigint | Action::Hang(_)
        );
        let judged: Vec<&RunRecord> = run
            .iter()
            .filter(|r| !process_fault || t_fault_s.is_none_or(|t| r.t_s <= t))
            .collect();
        let late_or_skipped = judged
            .iter()
            .filter(|r| r.flags.split(';').any(|fl| fl == "late" || fl == "skipped"))
            .count();
        Self {
            periods: judged.len(),
            late_or_skipped,
            start_failed: false,
        }
    }

    /// The attempt's `acc run` ended at start, the board not answering (exit 5, `stderr`
    /// its error lines), before writing a period.
    pub fn with_start(mut self, stderr: &str) -> Self {
        self.start_failed = self.periods == 0 && stderr.contains("(exit code 5)");
        self
    }

    /// The host was too loaded for the controller to start or to keep its period: a start
    /// that failed ([`Self::with_start`]), or at least
    /// [`OVERLOAD_MIN_PERIODS`] and [`OVERLOAD_SHARE`] of the periods late or skipped.
    pub fn overloaded(&self) -> bool {
        self.start_failed
            || self.late_or_skipped >= OVERLOAD_MIN_PERIODS
                && self.late_or_skipped as f64 >= OVERLOAD_SHARE * self.periods as f64
    }

    /// `12 of 450 acc run periods late or skipped`.
    pub fn describe(&self) -> String {
        if self.start_failed {
            return "acc run's start-up transactions got no reply in time (exit 5)".into();
        }
        format!(
            "{} of {} acc run periods late or skipped",
            self.late_or_skipped, self.periods
        )
    }
}

/// What the table and the JSON say of a first attempt: `FAIL: … (host overloaded: 12 of
/// 450 acc run periods late or skipped)`, or, for a row re-run because its fault met no cut
/// under ACC on a host that kept the period, `FAIL: … (host load: 0 of 400 …)`.
pub fn first_attempt(outcome: &str, load: &HostLoad) -> String {
    let what = if load.overloaded() {
        "host overloaded"
    } else {
        "host load"
    };
    format!("{outcome} ({what}: {})", load.describe())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fault_matrix::faults::FAULTS;

    fn rows(n: usize, flagged: &[usize]) -> Vec<RunRecord> {
        (0..n)
            .map(|i| RunRecord {
                period: i as u64,
                t_s: 0.1 * (i + 1) as f64,
                flags: if flagged.contains(&i) {
                    "link:timeout;late".into()
                } else {
                    String::new()
                },
                ..RunRecord::default()
            })
            .collect()
    }

    fn fault(name: &str) -> &'static Fault {
        FAULTS.iter().find(|f| f.name == name).expect("fault")
    }

    #[test]
    fn a_few_late_periods_are_an_idle_host_many_are_an_overloaded_one() {
        let f = fault("crc");
        let idle = HostLoad::of(&rows(450, &[10, 300]), f, Some(40.0));
        assert_eq!(idle.late_or_skipped, 2);
        assert!(!idle.overloaded());
        let late: Vec<usize> = (0..450).step_by(20).collect();
        let loaded = HostLoad::of(&rows(450, &late), f, Some(40.0));
        assert_eq!(loaded.late_or_skipped, 23);
        assert!(loaded.overloaded(), "{}", loaded.describe());
        // 2 % of 450 is 9: 8 late periods are not enough.
        assert!(!HostLoad::of(&rows(450, &late[..8]), f, Some(40.0)).overloaded());
    }

    #[test]
    fn a_stopped_controller_is_judged_on_the_periods_before_the_fault() {
        // SIGSTOP at 40 s: the periods after it are late because of the fault.
        let after: Vec<usize> = (400..450).collect();
        let hang = HostLoad::of(&rows(450, &after), fault("watchdog"), Some(40.0));
        assert_eq!(hang.periods, 400);
        assert!(!hang.overloaded());
        // The same log on a board fault counts every period.
        assert!(HostLoad::of(&rows(450, &after), fault("crc"), Some(40.0)).overloaded());
    }

    #[test]
    fn a_run_that_never_started_for_a_silent_board_is_an_overloaded_host() {
        let f = fault("crc");
        let exit5 = "acc run: ended: the board did not answer at start or cannot be driven: ACC never drove the override (exit code 5)";
        let never = HostLoad::of(&[], f, None).with_start(exit5);
        assert!(never.overloaded());
        assert!(never.describe().contains("exit 5"), "{}", never.describe());
        // Another exit at start is not the host's load; nor is exit 5 after periods ran.
        assert!(!HostLoad::of(&[], f, None)
            .with_start("acc run: ended: … (exit code 2)")
            .overloaded());
        assert!(!HostLoad::of(&rows(10, &[]), f, None)
            .with_start(exit5)
            .overloaded());
    }

    #[test]
    fn the_first_attempt_is_reported_with_the_load() {
        let load = HostLoad {
            periods: 450,
            late_or_skipped: 12,
            start_failed: false,
        };
        assert_eq!(
            first_attempt("FAIL: force 883 → 978 N", &load),
            "FAIL: force 883 → 978 N (host overloaded: 12 of 450 acc run periods late or skipped)"
        );
    }
}
