//! Settle judge: *how high may the command go in the periods after a fault?*
//!
//! A period with a fault of the line or the board (a failed read or write, a status the
//! line guard held, the board's watchdog or override lock) holds the command; the law then
//! meets a force the hold shaped (a dither held at its lower position shows the steady low force)
//! and its integrator answers it. Measured on the fault matrix's hostile line
//! (`garbage-1pct`, v1 board, 10 % grid): one truncated write reply and one random status
//! held the dither at 40 % for two periods, and two periods later the law commanded 60 %,
//! 941 N against the 816 N before (1.15×). So for [`SETTLE_PERIODS`] periods after the last
//! such fault the command is capped at the highest command ACC wrote in the
//! [`RECENT_PERIODS`] clean periods before the fault (what ACC last allowed: both positions
//! of a dither). The cap joins the shop layer's and the plan's limits (the lower wins; a
//! cap re-seats the law's integrator, so no windup builds against it) and is logged as
//! `settle:<pct>`. It never raises a command. It acts only while the sample shows the tool
//! cutting (a valid force of at least [`CUTTING_SHARE`] × Fr): in air there is no force to
//! overshoot. A sample that is only unusable (a dynamometer's negative noise in air, a
//! stale power register) is not a fault of the line: the command holds in that period as
//! always, and no settling follows. (With those counted, `acc compare tool_wear_dynamometer`
//! moved: the rate-limited law, capped at its air command after the noise of the air cut,
//! ended 0.2 s later and ran out the invalid-sample budget in the last air move.)

/// Periods after the last fault input during which the command stays at or below what ACC
/// allowed before it (1 s at T = 0.1 s: longer than the law's answer to a held period).
pub const SETTLE_PERIODS: u32 = 10;
/// Clean periods before a fault whose highest command is the cap.
pub const RECENT_PERIODS: usize = 5;
/// The cap acts while the valid force is at least this share of Fr, −.
pub const CUTTING_SHARE: f64 = 0.2;

/// The judge's state: the commands of the last clean periods and the cap in force.
#[derive(Debug, Clone, Default)]
pub(super) struct SettleJudge {
    recent: [Option<u16>; RECENT_PERIODS],
    next: usize,
    /// Periods still capped, this one included (0: not settling).
    left: u32,
    cap: Option<u16>,
}

impl SettleJudge {
    /// One period: `fault` is whether it had a fault input. A fault starts (or prolongs)
    /// the settling; the cap is taken when an episode starts and kept through it.
    pub(super) fn observe(&mut self, fault: bool) {
        if fault {
            if self.left == 0 {
                self.cap = self.recent.iter().flatten().copied().max();
            }
            // This period and the SETTLE_PERIODS after it.
            self.left = SETTLE_PERIODS + 1;
        } else {
            self.left = self.left.saturating_sub(1);
        }
    }

    /// The command written in a period without a fault input, percent.
    pub(super) fn written(&mut self, cmd: u16) {
        self.recent[self.next] = Some(cmd);
        self.next = (self.next + 1) % RECENT_PERIODS;
    }

    /// ACC let go, or armed afresh: nothing before counts.
    pub(super) fn clear(&mut self) {
        *self = Self::default();
    }

    /// The cap in force this period, percent (`None`: not settling, no command known, or
    /// the tool not cutting: `cutting` is whether the period's valid force is at least
    /// [`CUTTING_SHARE`] × Fr).
    pub(super) fn cap(&self, cutting: bool) -> Option<u16> {
        self.cap.filter(|_| self.left > 0 && cutting)
    }

    /// Whether a valid force `force_n` (N) shows the tool cutting against Fr `fr_n` (N).
    pub(super) fn cutting(valid: bool, force_n: f64, fr_n: Option<f64>) -> bool {
        valid && fr_n.is_some_and(|fr| force_n.is_finite() && force_n >= CUTTING_SHARE * fr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn after_a_fault_the_cap_is_the_highest_recent_command_for_the_settling_periods() {
        let mut j = SettleJudge::default();
        for c in [40, 50, 40, 50, 40, 50] {
            j.observe(false);
            j.written(c);
        }
        assert_eq!(j.cap(true), None);
        j.observe(true);
        assert_eq!(j.cap(true), Some(50));
        // Commands during the settling (below the cap) do not move it; a second fault
        // prolongs the episode with the same cap.
        for k in 0..SETTLE_PERIODS - 1 {
            j.observe(false);
            j.written(30);
            assert_eq!(j.cap(true), Some(50), "{k}");
            if k == 3 {
                j.observe(true);
                assert_eq!(j.cap(true), Some(50));
            }
        }
        // The episode ends SETTLE_PERIODS clean periods after its last fault.
        for _ in 0..5 {
            j.observe(false);
            j.written(30);
        }
        assert_eq!(j.cap(true), Some(50));
        j.observe(false);
        assert_eq!(j.cap(true), None);
        // The next episode caps at what was written since.
        j.observe(true);
        assert_eq!(j.cap(true), Some(30));
        j.clear();
        assert_eq!(j.cap(true), None);
        j.observe(true);
        assert_eq!(j.cap(true), None, "no command known: no cap");
        j.clear();
        j.written(40);
        j.observe(true);
        assert_eq!(j.cap(true), Some(40));
        assert_eq!(j.cap(false), None, "in air: no cap");
        assert!(SettleJudge::cutting(true, 200.0, Some(800.0)));
        assert!(!SettleJudge::cutting(true, 100.0, Some(800.0)));
        assert!(!SettleJudge::cutting(false, 900.0, Some(800.0)));
        assert!(!SettleJudge::cutting(true, 900.0, None));
    }
}
