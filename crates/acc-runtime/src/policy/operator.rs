//! Operator judge: *does the operator take the override back?* The operator has priority
//! over every other rule:
//! - the ACC switch off releases at once (not latched), and a latched release re-arms only
//!   once the switch has been seen off and then on again;
//! - the knob turned down by more than `operator_handback_pct` from its highest position
//!   since arming hands the override back (latched). On a board without the fallback clamp
//!   (v1) a knob still at or above ACC's last command is not handed back (the board would
//!   move to the knob and raise the feed): ACC keeps control with the knob as the ceiling of
//!   its command, and hands back once the knob is below that command.

use acc_pmc::BoardStatus;

/// What the operator's controls ask of an active policy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OperatorVerdict {
    /// ACC keeps control (the knob may cap its command: [`OperatorJudge::knob_ceiling`]).
    Keep,
    /// The switch is off: release, not latched.
    SwitchOff,
    /// The knob was turned down: hand back, latched.
    Handback,
}

/// The operator's switch and knob as the policy has seen them.
#[derive(Debug, Clone, Default)]
pub(crate) struct OperatorJudge {
    /// The switch was seen off since the last latched release (a latch re-arms only after
    /// the switch has been off and on again).
    pub(crate) switch_seen_off: bool,
    /// The knob's highest position since arming, percent.
    pub(crate) knob_ref_pct: u16,
    /// The knob in the last accepted status, percent.
    pub(crate) last_knob_pct: Option<u16>,
    /// The knob as a ceiling on ACC's command: set when the knob is turned down but handing
    /// back would raise the feed (a board without the fallback clamp, knob at or above ACC's
    /// last command). Cleared on arming.
    pub(crate) knob_ceiling: Option<u16>,
}

impl OperatorJudge {
    /// Every accepted status, in every state: the switch and the knob as seen.
    pub(crate) fn observe(&mut self, s: &BoardStatus) {
        if !s.acc_switch {
            self.switch_seen_off = true;
        }
        self.last_knob_pct = Some(s.operator_override_pct);
    }

    /// ACC armed at status `s`: the knob's reference is where it stands now.
    pub(crate) fn armed(&mut self, s: &BoardStatus) {
        self.knob_ceiling = None;
        self.knob_ref_pct = s.operator_override_pct;
    }

    /// The switch went off and on again since the last latched release.
    pub(crate) fn switch_cycled(&self, s: &BoardStatus) -> bool {
        self.switch_seen_off && s.acc_switch
    }

    /// The knob is still within `handback_pct` of its reference (a link-restored re-arm is
    /// allowed).
    pub(crate) fn knob_kept(&self, s: &BoardStatus, handback_pct: u16) -> bool {
        u32::from(s.operator_override_pct) + u32::from(handback_pct) >= u32::from(self.knob_ref_pct)
    }

    /// Judge the switch and the knob of an active policy. `board_clamps`: a release engages
    /// the board's fallback clamp (v2); `last_cmd`: ACC's last command, percent.
    pub(crate) fn judge(
        &mut self,
        s: &BoardStatus,
        handback_pct: u16,
        board_clamps: bool,
        last_cmd: Option<u16>,
    ) -> OperatorVerdict {
        if !s.acc_switch {
            return OperatorVerdict::SwitchOff;
        }
        let knob = s.operator_override_pct;
        self.knob_ref_pct = self.knob_ref_pct.max(knob);
        if self.knob_kept(s, handback_pct) {
            self.knob_ceiling = None;
            return OperatorVerdict::Keep;
        }
        // Handing back moves the board to the knob. Without the fallback clamp (v1) a knob
        // still above ACC's last command would raise the feed: keep control with the knob as
        // the ceiling instead, and hand back once the knob is below ACC's command (at the
        // knob's own value the command may be a dither step above ACC's regulated level,
        // which a hand-back would hold for good).
        let raising = !board_clamps && last_cmd.is_some_and(|c| knob >= c);
        if !raising {
            return OperatorVerdict::Handback;
        }
        if self.knob_ceiling != Some(knob) {
            tracing::info!(
                knob_pct = knob,
                "operator's knob down: it caps ACC's command (handing back would raise the feed on this board)"
            );
        }
        self.knob_ceiling = Some(knob);
        OperatorVerdict::Keep
    }
}
