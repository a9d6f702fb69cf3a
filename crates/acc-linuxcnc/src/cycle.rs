//! `CYCLE_ACTIVE` on LinuxCNC: the program's run, seen through acc's reads 0.1 s apart.
//!
//! `halui.program.is-running` is set by the program's run in AUTO and by every MDI command.
//! An operator who aborts and retracts the tool by MDI leaves the interpreter idle for a few
//! ms only: acc's reads can miss that idle, or find it at one read, which the line guard
//! holds as unconfirmed when the next read shows a run again. Measured on LinuxCNC under
//! CPU load (`acc fault-matrix --linuxcnc --only abort-restart`): the cycle then fell only
//! when the retract ended, 7–8 periods after the cut, where the restart judge
//! (`acc_runtime::policy`, `restart.rs`) no longer counts the stop as one in the cut.
//!
//! So the MDI command that follows the end of the program's run in AUTO, if it starts
//! within [`FOLLOW_READS`] reads of that end, belongs to the stop: the cycle stays ended
//! through it. The next MDI command (after that one went idle), or one started later, is a
//! cycle (acc drives an MDI cut). Without `acc.mode-auto` netted (read false) the program
//! running alone is the cycle.

/// Reads after the end of the program's run in AUTO within which an MDI command that starts
/// belongs to the stop (1 s at acc's 0.1 s period: a retract sent at once by the operator's
/// panel or a script, not a cut typed afterwards).
pub const FOLLOW_READS: u32 = 10;

/// The judge of `CYCLE_ACTIVE` from the two pins, one call per read.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ProgramCycle {
    /// The program ran in AUTO at the last read.
    ran_in_auto: bool,
    /// Reads since the program's run in AUTO ended (`None`: it runs, or never ran).
    since_end: Option<u32>,
    /// The MDI command that followed the end runs (the cycle stays ended).
    following_mdi: bool,
    /// That MDI command has gone idle: later ones are cycles.
    follow_done: bool,
    /// `CYCLE_ACTIVE` of the last read.
    active: bool,
}

impl ProgramCycle {
    /// One read of `halui.program.is-running` and `halui.mode.is-auto`; `CYCLE_ACTIVE`.
    pub(crate) fn read(&mut self, running: bool, auto: bool) -> bool {
        if running && auto {
            *self = Self {
                ran_in_auto: true,
                active: true,
                ..Self::default()
            };
            return true;
        }
        if self.ran_in_auto {
            self.ran_in_auto = false;
            self.since_end = Some(0);
        } else if let Some(n) = &mut self.since_end {
            *n = n.saturating_add(1);
        }
        if let Some(n) = self.since_end {
            if running && !self.following_mdi && !self.follow_done && n <= FOLLOW_READS {
                self.following_mdi = true;
            }
            if !running && self.following_mdi {
                self.following_mdi = false;
                self.follow_done = true;
            }
        }
        self.active = running && !self.following_mdi;
        self.active
    }

    /// `CYCLE_ACTIVE` of the last read.
    pub(crate) fn active(&self) -> bool {
        self.active
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_retract_after_an_abort_belongs_to_the_stop_whether_or_not_a_read_saw_the_idle() {
        for idle_reads in [0, 1, 3] {
            let mut c = ProgramCycle::default();
            assert!(c.read(true, true), "the program runs");
            for _ in 0..idle_reads {
                assert!(!c.read(false, true), "aborted, idle");
            }
            for _ in 0..4 {
                assert!(
                    !c.read(true, false),
                    "the MDI retract: {idle_reads} idle reads"
                );
            }
            assert!(!c.read(false, false), "the retract done");
            assert!(c.read(true, false), "the next MDI command is a cycle");
            assert!(!c.read(false, false));
            assert!(c.read(true, true), "the program again");
        }
    }

    #[test]
    fn an_mdi_command_started_later_is_a_cycle() {
        let mut c = ProgramCycle::default();
        c.read(true, true);
        for _ in 0..=FOLLOW_READS {
            assert!(!c.read(false, true));
        }
        assert!(
            c.read(true, false),
            "typed after the program's end: a cut acc drives"
        );
    }

    #[test]
    fn without_the_mode_pin_the_program_running_is_the_cycle() {
        let mut c = ProgramCycle::default();
        for running in [true, true, false, true, false] {
            assert_eq!(c.read(running, false), running);
        }
    }
}
