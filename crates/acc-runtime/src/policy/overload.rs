//! Overload judge: *has the force been above the overload limit for too long?* Judged in
//! every state on valid samples: `overload_force_n` exceeded for
//! [`super::PolicyConfig::overload_periods`] periods in a row trips the tool's reaction
//! (the tool table's `overload_reaction`; default feed hold). A held read says nothing
//! about the force: the count neither grows nor restarts.

use acc_config::OverloadReaction;

use super::PolicyConfig;

/// What the overload rule asks of the policy this period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OverloadVerdict {
    /// Nothing to do.
    Quiet,
    /// Below the limit with the `warning` reaction: the warning alarm may clear.
    ClearWarning,
    /// Tripped with the `warning` reaction: raise the alarm, keep regulating.
    Warn,
    /// Tripped: feed hold, release and latch (`spindle_stop`: also ask for a spindle stop).
    Hold {
        /// The reaction is `spindle_stop`.
        spindle_stop: bool,
    },
}

/// Consecutive periods above the limit and the tool's reaction.
#[derive(Debug, Clone)]
pub(crate) struct OverloadJudge {
    /// Consecutive periods so far with the force above `overload_force_n`.
    count: u32,
    /// Reaction to an overload (the tool table's `overload_reaction`; default feed hold).
    pub(crate) reaction: OverloadReaction,
}

impl Default for OverloadJudge {
    fn default() -> Self {
        Self {
            count: 0,
            reaction: OverloadReaction::FeedHold,
        }
    }
}

impl OverloadJudge {
    /// Judge one period's force `force_n`, N (`valid`: the sample is valid; `held`: the line
    /// guard held the read) against `cfg`'s limit and time.
    pub(crate) fn judge(
        &mut self,
        valid: bool,
        force_n: f64,
        held: bool,
        cfg: &PolicyConfig,
    ) -> OverloadVerdict {
        if valid && force_n > cfg.overload_force_n {
            self.count = self.count.saturating_add(1);
            if self.count < cfg.overload_periods() {
                OverloadVerdict::Quiet
            } else if self.reaction == OverloadReaction::Warning {
                OverloadVerdict::Warn
            } else {
                OverloadVerdict::Hold {
                    spindle_stop: self.reaction == OverloadReaction::SpindleStop,
                }
            }
        } else if held {
            OverloadVerdict::Quiet
        } else {
            self.count = 0;
            if self.reaction == OverloadReaction::Warning {
                OverloadVerdict::ClearWarning
            } else {
                OverloadVerdict::Quiet
            }
        }
    }
}
