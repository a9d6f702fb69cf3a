//! Shutdown judge: *is the cut over, so that a stop may hand the override back?* A stop
//! (Ctrl-C, SIGTERM) in the middle of a cut keeps ACC in control until the cut has ended:
//! the drain counts the periods out of the cut in a row ([`FaultPolicy::air_periods`]): the
//! status read (accepted or held) and either `CYCLE_ACTIVE` off or a valid force sample
//! below `air_force_n`. Then [`FaultPolicy::shutdown`] hands the override back; a stop
//! that cannot wait holds the feed first ([`FaultPolicy::shutdown_with_hold`]).

use acc_pmc::ControlBits;

use super::{AccState, FaultPolicy, PolicyInput};

/// Periods out of the cut in a row.
#[derive(Debug, Clone, Default)]
pub(crate) struct DrainJudge {
    /// Force below which a valid sample is out of the cut, N (0: only a fallen
    /// `CYCLE_ACTIVE` counts).
    pub(crate) air_force_n: f64,
    /// Consecutive periods out of the cut.
    pub(crate) air_periods: u32,
}

impl DrainJudge {
    /// Count this period (every period the policy steps).
    pub(crate) fn observe(&mut self, input: &PolicyInput) {
        let f = input.force;
        let air = input.link.is_ok_and(|s| {
            !s.cycle_active || (f.valid && f.force_n.is_finite() && f.force_n < self.air_force_n)
        });
        self.air_periods = if air {
            self.air_periods.saturating_add(1)
        } else {
            0
        };
    }
}

impl FaultPolicy {
    /// This policy counting a period as out of the cut when its valid force sample is below
    /// `air_force_n`, N (default 0: only a fallen `CYCLE_ACTIVE` counts); see
    /// [`FaultPolicy::air_periods`].
    pub fn with_air_force_n(mut self, air_force_n: f64) -> Self {
        self.drain.air_force_n = air_force_n;
        self
    }

    /// Consecutive periods up to now that were out of the cut: the status read and either
    /// `CYCLE_ACTIVE` off or a valid force sample below the air threshold. A shutdown drains
    /// until this reaches its configured count.
    pub fn air_periods(&self) -> u32 {
        self.drain.air_periods
    }

    /// The `CONTROL` bits for an orderly shutdown: ACC request cleared, the override left to
    /// the operator. A feed hold the policy requested (an overload, a release that would have
    /// raised the feed) is kept: stopping the program must not restart the axes. Moves the
    /// policy to idle.
    pub fn shutdown(&mut self) -> ControlBits {
        self.state = AccState::Idle;
        self.acc_request = false;
        ControlBits {
            acc_request: false,
            feed_hold_request: self.feed_hold,
            alarm_reset: false,
        }
    }

    /// The `CONTROL` bits of a stop in the middle of a cut: ACC request cleared, feed hold
    /// requested (and kept). Moves the policy to idle.
    pub fn shutdown_with_hold(&mut self) -> ControlBits {
        self.feed_hold = true;
        self.shutdown()
    }
}
