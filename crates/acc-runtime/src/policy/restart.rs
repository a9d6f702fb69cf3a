//! Restart judge: *how high may the command go when a program runs again after it stopped
//! in a cut?*
//!
//! A program stopped in the material (an abort or a reset: `CYCLE_ACTIVE` falls while the
//! tool was cutting, or within [`STOP_PERIODS`] of it) leaves the stock with a wall no plan
//! and no model knows. The program run again reaches that wall after its air moves, and the
//! law, which sees no force in air, runs those at the top of its range: measured on
//! LinuxCNC (`acc fault-matrix --linuxcnc`, row `abort-restart`), the re-entry into the
//! wall at the air cut's 150 % reached 2 668 N against the 898 N of the cut the abort
//! stopped, 3.3 Fr, until the law's next period. So from the stop until the new cycle's
//! first cut has been measured ([`ENTRY_PERIODS`] periods with a valid force of at least
//! [`super::settle::CUTTING_SHARE`] × Fr), the command is capped at the command that was
//! cutting when the program stopped: what ACC last allowed in the material and saw the
//! force of, the lower of the last cutting period's command and the override its force was
//! measured at. (A command the law raised in the period the program stopped was never
//! measured in the material: on LinuxCNC under load, the abort came as the law wrote 60 %
//! over a cut measured at 50 %, and the re-entry at 60 % reached 1 060 N against the 898 N
//! before.) The cap joins
//! the shop layer's and the plan's limits (the lower wins; it re-seats the law's
//! integrator) and is logged as `restart:<pct>`. It never raises a command; it survives a
//! release and a re-arm (the wall is still there), and a board without NC context (v1:
//! `CYCLE_ACTIVE` always set) never starts one.

/// Periods after the last cutting period within which a falling `CYCLE_ACTIVE` counts as a
/// stop in the cut (the force falls with the feed and the spindle as the NC stops).
pub const STOP_PERIODS: u32 = 5;
/// Cutting periods of the new cycle after which the cap lifts: the law has measured the
/// cut it is in.
pub const ENTRY_PERIODS: u32 = 3;

/// The judge's state.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct RestartJudge {
    /// The last command written in a cutting period, percent, and the periods since.
    last_cut: Option<(u16, u32)>,
    /// `CYCLE_ACTIVE` of the last status.
    cycle_active: bool,
    /// The cap in force, percent.
    cap: Option<u16>,
    /// Cutting periods of the new cycle under the cap.
    measured: u32,
}

impl RestartJudge {
    /// The status's `CYCLE_ACTIVE`, every period a status was accepted: its fall soon after
    /// a cut starts the cap.
    pub(super) fn cycle(&mut self, active: bool) {
        if self.cycle_active && !active {
            if let Some((cmd, _)) = self.last_cut.filter(|(_, s)| *s <= STOP_PERIODS) {
                self.cap = Some(self.cap.map_or(cmd, |c| c.min(cmd)));
                self.measured = 0;
            }
        }
        self.cycle_active = active;
        if let Some((_, since)) = &mut self.last_cut {
            *since = since.saturating_add(1);
        }
    }

    /// A period in which the law stepped: `cutting` is whether its valid force shows the
    /// tool in the material ([`super::settle::SettleJudge::cutting`]), `cmd` the command
    /// written, `measured_at` the override the period's force was measured at
    /// (`OVERRIDE_APPLIED`; `None`: not known). Under the cap, the new cycle's cutting
    /// periods are counted until the cap lifts.
    pub(super) fn stepped(&mut self, cutting: bool, cmd: u16, measured_at: Option<u16>) {
        if !cutting {
            return;
        }
        self.last_cut = Some((measured_at.map_or(cmd, |a| a.min(cmd)), 0));
        if self.cap.is_some() && self.cycle_active {
            self.measured += 1;
            if self.measured >= ENTRY_PERIODS {
                self.cap = None;
            }
        }
    }

    /// The cap in force this period, percent (`None`: no program stopped in a cut, or the
    /// new cycle's cut has been measured).
    pub(super) fn cap(&self) -> Option<u16> {
        self.cap
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cycle that cuts at `cmd` for a few periods.
    fn cut(j: &mut RestartJudge, cmd: u16) {
        for _ in 0..4 {
            j.cycle(true);
            j.stepped(true, cmd, None);
        }
    }

    #[test]
    fn a_program_stopped_in_the_cut_caps_the_next_cycle_until_its_cut_is_measured() {
        let mut j = RestartJudge::default();
        cut(&mut j, 40);
        // The abort: the force goes first, then the cycle.
        j.cycle(true);
        j.stepped(false, 40, None);
        j.cycle(false);
        assert_eq!(j.cap(), Some(40));
        // The retract, the restart and its air moves: capped, however long.
        for _ in 0..50 {
            j.cycle(true);
            j.stepped(false, 40, None);
            assert_eq!(j.cap(), Some(40));
        }
        // The re-entry: ENTRY_PERIODS cutting periods under the cap, then free.
        for k in 1..ENTRY_PERIODS {
            j.cycle(true);
            j.stepped(true, 40, None);
            assert_eq!(j.cap(), Some(40), "{k}");
        }
        j.cycle(true);
        j.stepped(true, 40, None);
        assert_eq!(j.cap(), None);
    }

    #[test]
    fn a_command_raised_as_the_program_stopped_is_not_the_cap() {
        let mut j = RestartJudge::default();
        for _ in 0..4 {
            j.cycle(true);
            j.stepped(true, 50, Some(50));
        }
        // The law raises to 60 % in the last cutting period, measured at 50 %; the abort.
        j.cycle(true);
        j.stepped(true, 60, Some(50));
        j.cycle(false);
        assert_eq!(j.cap(), Some(50));
        // A command lowered in the last period is the cap.
        let mut j = RestartJudge::default();
        j.cycle(true);
        j.stepped(true, 40, Some(50));
        j.cycle(false);
        assert_eq!(j.cap(), Some(40));
    }

    #[test]
    fn a_program_that_ends_in_air_caps_nothing() {
        let mut j = RestartJudge::default();
        cut(&mut j, 60);
        for _ in 0..=STOP_PERIODS {
            j.cycle(true);
            j.stepped(false, 150, None);
        }
        j.cycle(false);
        assert_eq!(
            j.cap(),
            None,
            "the cut ended {} periods before",
            STOP_PERIODS + 1
        );
    }

    #[test]
    fn a_board_without_nc_context_never_starts_a_cap() {
        let mut j = RestartJudge::default();
        cut(&mut j, 60);
        for _ in 0..20 {
            j.cycle(true);
            j.stepped(false, 150, None);
        }
        assert_eq!(j.cap(), None);
    }

    #[test]
    fn a_second_stop_before_the_cut_is_measured_keeps_the_lower_cap() {
        let mut j = RestartJudge::default();
        cut(&mut j, 50);
        j.cycle(false);
        assert_eq!(j.cap(), Some(50));
        // The new cycle enters at the cap, the law comes down to 30 %, and the program is
        // stopped again before its cut was measured for ENTRY_PERIODS.
        j.cycle(true);
        j.stepped(true, 30, None);
        j.cycle(false);
        assert_eq!(j.cap(), Some(30));
    }
}
