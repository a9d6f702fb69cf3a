//! The override commands in force on the board over the last periods, as the loop books
//! them: what the line guard expects as echoes and the loop delay measures against.

use crate::echo::{Booked, MAX_ECHO_PERIODS};

/// The override commands in force on the board after each of the last periods, newest
/// first (`None`: ACC not driving, or unknown): booked by the loop once the policy has
/// decided a period (or skipped it); read by the line guard (the echoes to expect) and the
/// loop delay ([`LoopDelay::period`]) in the next period.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct InForce {
    /// Newest first.
    pub(crate) cmds: [Option<u16>; MAX_ECHO_PERIODS],
    /// A period was booked with ACC not driving since the loop delay last looked.
    pub(crate) released: bool,
}

impl InForce {
    /// Book the command in force after this period: `written` while `driving` (`None`: the
    /// last one is kept), nothing known while ACC is not driving.
    pub(crate) fn book(&mut self, driving: bool, written: Option<u16>) {
        let now = if driving {
            written.or(self.cmds[0])
        } else {
            self.released = true;
            None
        };
        self.cmds.rotate_right(1);
        self.cmds[0] = now;
    }

    /// What the loop delay reads this period (`line_broke`: the line lost its cadence);
    /// the release is reported once.
    pub(crate) fn take(&mut self, line_broke: bool) -> Booked<'_> {
        let released = std::mem::take(&mut self.released);
        Booked {
            in_force: &self.cmds,
            released,
            line_broke,
        }
    }
}
